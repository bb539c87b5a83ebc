//! What the integration tests reach of the engine's internals, and nothing a user should call:
//! hidden from the documentation, not part of the API, free to change.

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, Stage};

/// Builds a compute stage named `name` of WGSL `source` (entry point `main`) on `ctx`'s device,
/// then drops it. Group 0's bindings are of the kinds `bindings` names (`"uniform"`, `"read"`,
/// `"read_write"`). Every pipeline of the engine goes through this.
///
/// # Errors
/// As the engine's stages: [`crate::Error::Gpu`] when the device refuses the shader or pipeline.
///
/// # Panics
/// On a binding kind other than the three.
#[doc(hidden)]
pub fn build_stage(ctx: &GpuContext, name: &str, source: &str, bindings: &[&str]) -> Result<()> {
    let kinds: Vec<Binding> = bindings
        .iter()
        .map(|b| match *b {
            "uniform" => Binding::Uniform,
            "read" => Binding::Read,
            "read_write" => Binding::ReadWrite,
            other => panic!("no binding kind {other:?}"),
        })
        .collect();
    Stage::new(ctx.device(), name, source, &kinds).map(drop)
}

/// Returns the GPU's projections of poses `range` of `sweep`'s grid, each decoded on the device
/// by the poses stage, with their occupancy (for the envelope check).
///
/// # Errors
/// As [`crate::Backend::project_columns`].
///
/// # Panics
/// When the sweep's poses are not a grid.
#[doc(hidden)]
pub fn gpu_grid_projections(
    gpu: &crate::projection::gpu::GpuBackend,
    sweep: &crate::PoseSweep<'_>,
    range: std::ops::Range<u64>,
) -> Result<Vec<crate::Projection>> {
    let crate::PoseSource::Grid(grid) = sweep.poses else {
        panic!("a grid sweep");
    };
    let prepared = sweep.prepare_grid(grid)?;
    gpu.project_grid_projections(&prepared, range, true)
}

/// Returns the f32s of `bits` widened to f64 on `ctx`'s device by the summary stage's `widen`
/// (`shaders/shared/widen.wgsl`), one thread each.
///
/// # Errors
/// [`crate::Error::Gpu`] when the device lacks f64 or 64-bit integers, refuses the shader, or
/// fails.
#[doc(hidden)]
pub fn widen_on_device(ctx: &GpuContext, bits: &[u32]) -> Result<Vec<f64>> {
    use wgpu::util::DeviceExt;
    let source = format!(
        "{}\n@group(0) @binding(0) var<storage, read> input: array<u32>;\n\
         @group(0) @binding(1) var<storage, read_write> output: array<f64>;\n\
         @compute @workgroup_size(64)\n\
         fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
             if id.x < arrayLength(&input) {{ output[id.x] = widen(input[id.x]); }}\n\
         }}\n",
        crate::projection::gpu::WIDEN
    );
    let stage = Stage::new(
        ctx.device(),
        "widen",
        &source,
        &[Binding::Read, Binding::ReadWrite],
    )?;
    let device = ctx.device();
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("widen input"),
        contents: bytemuck::cast_slice(bits),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (bits.len() * 8) as u64;
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("widen output"),
        size,
        usage,
        mapped_at_creation: false,
    });
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("widen staging"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &stage.layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&stage.pipeline);
        pass.set_bind_group(0, &group, &[]);
        #[expect(clippy::cast_possible_truncation, reason = "a test's few values")]
        pass.dispatch_workgroups(bits.len().div_ceil(64) as u32, 1, 1);
    }
    enc.copy_buffer_to_buffer(&output, 0, &staging, 0, size);
    let index = ctx.queue().submit([enc.finish()]);
    let words = crate::gpu::read_after(ctx, &staging, size, Some(index), <[u32]>::to_vec)?;
    Ok(words
        .chunks_exact(2)
        .map(|w| f64::from_bits(u64::from(w[0]) | u64::from(w[1]) << 32))
        .collect())
}
