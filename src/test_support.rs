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
