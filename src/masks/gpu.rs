//! The GPU side of [`super::MaskEngine`]: `shaders/mask.wgsl`, its pipeline and buffers
//! (built once, grown when a ping needs more), one dispatch per ping, the bitsets read back.
//!
//! The shader works in f32. Each job's radius carries a slack that bounds every rounding of
//! the f32 path (the direction tables and rotation rounded to f32, `R p + t`, `|q|`, the bin
//! arithmetic and the edge tests), so GPU masks contain the CPU engine's and never miss.
#![expect(
    clippy::cast_possible_truncation,
    reason = "GPU buffers hold f32 and u32: values are rounded to f32 on purpose (the slack covers it) and counts are bounded by the device limits checked before packing"
)]

use crate::clip::{MASK_F32_FLOOR, MASK_F32_SLACK, RIGHT_ANGLE_SLACK};
use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::error::{Error, Result};
use crate::geometry::RelativePose;
use crate::gpu::pipeline::{Binding, Stage};
use crate::gpu::pool::SharedPool;
use crate::gpu::{GpuContext, context, read, shaders};
use crate::occupancy::{Layout, Occupancy};

use super::plan::{BLOCK, Plan};

/// Parameters of sonar 2 (members as documented in shaders/mask.wgsl). Keep in sync with
/// `MaskParams` there.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct MaskParams {
    /// Sonar 2's near range (m).
    pub(crate) range_min: f32,
    /// Sonar 2's far range (m).
    pub(crate) range_max: f32,
    /// `range_bins / (range_max - range_min)` (1/m).
    pub(crate) inv_range_bin: f32,
    /// Sonar 2's range bins.
    pub(crate) range_bins: u32,
    /// Sonar 2's beams (1 for a sidescan, 2 for a two-sided one).
    pub(crate) beams: u32,
    /// 32-bit words of one mask's bitset.
    pub(crate) words_per_mask: u32,
    /// Padding (zero).
    pub(crate) _pad0: u32,
    /// 1 when sonar 2 has more than one beam (an FLS, or a two-sided sidescan), 0 for range
    /// bins only.
    pub(crate) beamed: u32,
    /// tan of half the elevation aperture; < 0 when the aperture is 180° (no test).
    pub(crate) tan_half_el: f32,
    /// tan of half the azimuth aperture (< 90°: checked on the CPU).
    pub(crate) tan_half_az: f32,
    /// cos of half the azimuth aperture: the edge search holds while `radius < ρ cos(half_az)`.
    pub(crate) cos_half_az: f32,
    /// Padding (zero).
    pub(crate) _pad: f32,
}

/// One mask to draw (members as documented in shaders/mask.wgsl). Keep in sync with `MaskJob`
/// there.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct MaskJob {
    /// Rows of the rotation `R` (sonar 1 → sonar 2) with the translation `t` in `.w` (m).
    pub(crate) rows: [[f32; 4]; 3],
    /// The measured range of the set being masked (m).
    pub(crate) range: f32,
    /// The ball radius of one cell: cell, noise and rounding slack (m).
    pub(crate) radius: f32,
    /// Cells along the azimuth.
    pub(crate) az_count: u32,
    /// Cells along the elevation.
    pub(crate) el_count: u32,
    /// Where the job's azimuth directions start in the direction table.
    pub(crate) az_offset: u32,
    /// Where the job's elevation directions start in the direction table.
    pub(crate) el_offset: u32,
    /// Where the job's kept blocks start in the block list.
    pub(crate) block_offset: u32,
    /// How many blocks the job keeps.
    pub(crate) block_count: u32,
}

/// Byte sizes of the shared structs (checked against naga's layout in src/gpu/shader_tests.rs).
pub(crate) const MASK_PARAMS_SIZE: usize = 48;
/// See [`MASK_PARAMS_SIZE`].
pub(crate) const MASK_JOB_SIZE: usize = 80;
const _: () = assert!(size_of::<MaskParams>() == MASK_PARAMS_SIZE);
const _: () = assert!(size_of::<MaskJob>() == MASK_JOB_SIZE);

/// Bindings of `shaders/mask.wgsl`: params, edges, jobs, dirs, blocks, bits.
pub(crate) const MASK_BINDINGS: [Binding; 6] = [
    Binding::Uniform,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::ReadWrite,
];

/// Threads per workgroup of the mask stage (WGSL `@workgroup_size` in mask.wgsl; checked in
/// src/gpu/shader_tests.rs).
pub(crate) const MASK_WORKGROUP: u64 = 64;
/// The most workgroups along x (cells are strided beyond).
const MAX_TILES: u64 = 1024;
/// One mask for the GPU to draw: the pose, the plan, and the blocks that survived the cull.
pub(crate) struct Job {
    /// The pose.
    pub(crate) pose: RelativePose,
    /// The cells and radius.
    pub(crate) plan: Plan,
    /// First cells of the blocks to visit ([`super::MaskEngine`]'s `blocks`).
    pub(crate) blocks: Vec<(usize, usize)>,
}

/// Returns the radius (m) added to every ball on the GPU to cover the f32 rounding of a set at
/// range `r` under `pose` in `layout` ([`MASK_F32_SLACK`], [`MASK_F32_FLOOR`]).
pub(crate) fn slack(r: f64, pose: &RelativePose, layout: &Layout) -> f64 {
    MASK_F32_SLACK * (r + pose.translation.length() + layout.range_max) + MASK_F32_FLOOR
}

/// Returns the full source of the mask stage.
#[must_use]
pub(crate) fn source() -> String {
    shaders::mask()
}

/// The buffers of one dispatch, taken from the pool.
struct Buffers {
    jobs: wgpu::Buffer,
    dirs: wgpu::Buffer,
    blocks: wgpu::Buffer,
    bits: wgpu::Buffer,
    staging: wgpu::Buffer,
}

/// The mask pipeline on one GPU, for one sonar 2.
pub(crate) struct GpuMasks {
    ctx: GpuContext,
    stage: Stage,
    params: MaskParams,
    params_buffer: wgpu::Buffer,
    edges: wgpu::Buffer,
    pool: SharedPool,
}

impl std::fmt::Debug for GpuMasks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuMasks")
            .field("adapter", &self.ctx.info.name)
            .finish()
    }
}

impl GpuMasks {
    /// Returns the pipeline for sonar 2's `layout` on `ctx`.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for an azimuth aperture of 180° or more.
    pub(crate) fn new(ctx: GpuContext, layout: &Layout) -> Result<GpuMasks> {
        let ha = layout.half_azimuth;
        if ha >= std::f64::consts::FRAC_PI_2 {
            return Err(Error::invalid(
                "sonar 2 azimuth aperture",
                format!("{} deg", 2.0 * ha.to_degrees()),
                "GPU masks need less than 180 deg; the CPU mask engine takes any aperture",
            ));
        }
        let device = &ctx.device;
        let stage = Stage::new(device, "mask", &source(), &MASK_BINDINGS)?;
        let he = layout.half_elevation;
        let params = MaskParams {
            range_min: layout.range_min as f32,
            range_max: layout.range_max as f32,
            inv_range_bin: (1.0 / layout.range_bin_width) as f32,
            range_bins: layout.range_bins as u32,
            beams: layout.beams() as u32,
            words_per_mask: layout.pixels().div_ceil(32) as u32,
            _pad0: 0,
            beamed: u32::from(layout.beams() > 1),
            tan_half_el: if he < std::f64::consts::FRAC_PI_2 - RIGHT_ANGLE_SLACK {
                he.tan() as f32
            } else {
                -1.0
            },
            tan_half_az: ha.tan() as f32,
            cos_half_az: ha.cos() as f32,
            _pad: 0.0,
        };
        let edges: Vec<[f32; 2]> = layout
            .beam_edges
            .iter()
            .map(|e| [e.cos() as f32, e.sin() as f32])
            .collect();
        let edges = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mask edges"),
            contents: bytemuck::cast_slice(&edges),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("mask params"),
            size: size_of::<MaskParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(GpuMasks {
            ctx,
            stage,
            params,
            params_buffer,
            edges,
            pool: SharedPool::default(),
        })
    }

    /// Returns the adapter's description.
    pub(crate) fn describe(&self) -> String {
        format!("{} (f32 with rounding slack)", context::describe(&self.ctx.info))
    }

    /// Returns the masks of `jobs` (a pose and a plan each), in order.
    ///
    /// # Errors
    /// [`Error::Gpu`] on device failure.
    pub(crate) fn draw(&self, layout: &Layout, jobs: &[Job]) -> Result<Vec<Occupancy>> {
        let words = u64::from(self.params.words_per_mask);
        // Jobs per dispatch: the dispatch's y limit and the device's storage binding size for
        // the bitsets (at most 256 MiB).
        let limit = self
            .ctx
            .limits
            .max_storage_buffer_binding_size
            .min(self.ctx.limits.max_buffer_size)
            .min(256 << 20);
        let per_dispatch = (65_535u64).min(limit / (words * 4)).max(1) as usize;
        let max_dirs = (limit / 8) as usize;
        let mut out = Vec::with_capacity(jobs.len());
        let (mut start, mut dirs) = (0, 0);
        for (k, job) in jobs.iter().enumerate() {
            let d = job.plan.cells.azimuths.len() + job.plan.cells.elevations.len() + job.blocks.len();
            if k > start && (k - start == per_dispatch || dirs + d > max_dirs) {
                out.extend(self.draw_chunk(layout, &jobs[start..k], limit)?);
                (start, dirs) = (k, 0);
            }
            dirs += d;
        }
        if start < jobs.len() {
            out.extend(self.draw_chunk(layout, &jobs[start..], limit)?);
        }
        Ok(out)
    }

    /// Draws one dispatch's worth of `jobs`; buffers stay within `limit` bytes.
    fn draw_chunk(&self, layout: &Layout, jobs: &[Job], limit: u64) -> Result<Vec<Occupancy>> {
        let device = &self.ctx.device;
        let words = u64::from(self.params.words_per_mask);
        // Cell tables, shared between jobs with the same angles (an SSS surface's azimuth cells
        // depend only on their count; an FLS arc's on the measured azimuth).
        let mut dirs: Vec<[f32; 2]> = Vec::new();
        let mut tables: HashMap<Vec<u64>, u32> = HashMap::new();
        let mut table = |angles: &[f64], dirs: &mut Vec<[f32; 2]>| -> u32 {
            let key: Vec<u64> = angles.iter().map(|a| a.to_bits()).collect();
            *tables.entry(key).or_insert_with(|| {
                let at = dirs.len() as u32;
                dirs.extend(angles.iter().map(|a| [a.cos() as f32, a.sin() as f32]));
                at
            })
        };
        let mut max_cells = 1u64;
        let mut blocks: Vec<[u32; 2]> = Vec::new();
        let gpu_jobs: Vec<MaskJob> = jobs
            .iter()
            .map(
                |Job {
                     pose,
                     plan,
                     blocks: job_blocks,
                 }| {
                    let block_offset = blocks.len() as u32;
                    blocks.extend(job_blocks.iter().map(|&(a, e)| [a as u32, e as u32]));
                    let az_offset = table(&plan.cells.azimuths, &mut dirs);
                    let el_offset = table(&plan.cells.elevations, &mut dirs);
                    let (na, ne) = (
                        plan.cells.azimuths.len() as u32,
                        plan.cells.elevations.len() as u32,
                    );
                    max_cells = max_cells.max(job_blocks.len() as u64 * (BLOCK * BLOCK) as u64);
                    let t = pose.translation;
                    let row = |i: usize| {
                        let v = pose.rotation.row(i);
                        [v.x as f32, v.y as f32, v.z as f32, t[i] as f32]
                    };
                    MaskJob {
                        rows: [row(0), row(1), row(2)],
                        range: plan.range as f32,
                        radius: (plan.radius + slack(plan.range, pose, layout)) as f32,
                        az_count: na,
                        el_count: ne,
                        az_offset,
                        el_offset,
                        block_offset,
                        block_count: job_blocks.len() as u32,
                    }
                },
            )
            .collect();
        let n = jobs.len() as u64;
        self.pool.with(|pool| {
            let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
            let mut get = |label, size, usage| pool.get(device, label, size, limit, usage);
            let b = Buffers {
                jobs: get("mask jobs", n * MASK_JOB_SIZE as u64, storage),
                dirs: get("mask dirs", dirs.len() as u64 * 8, storage),
                blocks: get("mask blocks", blocks.len() as u64 * 8, storage),
                bits: get("mask bits", n * words * 4, storage | wgpu::BufferUsages::COPY_SRC),
                staging: get(
                    "mask staging",
                    n * words * 4,
                    wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                ),
            };
            self.submit(layout, &b, &gpu_jobs, &dirs, &blocks, max_cells)
        })
    }

    /// Uploads one dispatch's jobs, cell tables and blocks into `b`, draws them and returns
    /// their masks.
    fn submit(
        &self,
        layout: &Layout,
        b: &Buffers,
        gpu_jobs: &[MaskJob],
        dirs: &[[f32; 2]],
        blocks: &[[u32; 2]],
        max_cells: u64,
    ) -> Result<Vec<Occupancy>> {
        let device = &self.ctx.device;
        let words = u64::from(self.params.words_per_mask);
        let n = gpu_jobs.len() as u64;
        let params = self.params;
        let queue = &self.ctx.queue;
        queue.write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&params));
        queue.write_buffer(&b.jobs, 0, bytemuck::cast_slice(gpu_jobs));
        if !dirs.is_empty() {
            queue.write_buffer(&b.dirs, 0, bytemuck::cast_slice(dirs));
        }
        if !blocks.is_empty() {
            queue.write_buffer(&b.blocks, 0, bytemuck::cast_slice(blocks));
        }
        let group = self.stage.bind(
            device,
            &[
                &self.params_buffer,
                &self.edges,
                &b.jobs,
                &b.dirs,
                &b.blocks,
                &b.bits,
            ],
        );
        let bytes = n * words * 4;
        let mut enc = device.create_command_encoder(&Default::default());
        enc.clear_buffer(&b.bits, 0, Some(bytes));
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.stage.pipeline);
            pass.set_bind_group(0, &group, &[]);
            let tiles = max_cells.div_ceil(MASK_WORKGROUP).clamp(1, MAX_TILES) as u32;
            pass.dispatch_workgroups(tiles, n as u32, 1);
        }
        enc.copy_buffer_to_buffer(&b.bits, 0, &b.staging, 0, bytes);
        queue.submit([enc.finish()]);
        let raw = read(&self.ctx, &b.staging, bytes)?;
        Ok((0..gpu_jobs.len())
            .map(|k| {
                Occupancy::from_words(
                    layout.range_bins,
                    layout.beams(),
                    raw[k * words as usize..(k + 1) * words as usize].to_vec(),
                )
            })
            .collect())
    }
}
