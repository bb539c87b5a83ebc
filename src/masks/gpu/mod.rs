//! The GPU side of [`super::MaskEngine`].
//!
//! - `shaders/mask.wgsl` draws every mask. It culls blocks of cells on the device and keeps
//!   each mask's box as it sets its spans.
//! - `shaders/mask_reduce.wgsl` counts each mask's pixels from the rows of its box, and makes
//!   the ping's union.
//!
//! Their pipelines, bind groups, buffers and cell tables stay on the device between pings. They
//! are built once and grown when a ping needs more. A ping uploads its jobs (80 bytes a feature)
//! and reads back the union and five words a feature, and the bitsets only when asked for.
//!
//! The shaders work in f32. Each job's radii carry a slack that bounds every rounding of the
//! f32 path: the direction tables and rotation rounded to f32, `R p + t`, `|q|`, the bin
//! arithmetic and the edge tests. So GPU masks contain the CPU engine's and never miss.
#![expect(
    clippy::cast_possible_truncation,
    reason = "GPU buffers hold f32 and u32: values are rounded to f32 on purpose (the slack covers it) and counts are bounded by the device limits checked before packing"
)]

use crate::clip::{MASK_F32_FLOOR, MASK_F32_SLACK, RIGHT_ANGLE_SLACK};
use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::error::{Error, Result};
use crate::geometry::RelativePose;
use crate::gpu::pipeline::{Binding, Stage};
use crate::gpu::pool::BufferPool;
use crate::gpu::{GpuContext, context, read_after};
use crate::occupancy::{Layout, Occupancy};
use crate::stream::Flow;

mod source;
mod tables;

use super::plan::{BLOCK, Plan};
use super::summary::Reduced;
use tables::{Tables, block_shape, table_entries};

/// Sonar 2's parameters, as `MaskParams` in shaders/mask.wgsl documents them. Keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct MaskParams {
    /// Sonar 2's near range (m).
    pub(crate) range_min: f32,
    /// Sonar 2's far range (m).
    pub(crate) range_max: f32,
    /// `range_bins / (range_max - range_min)` (1/m).
    pub(crate) inv_range_bin: f32,
    pub(crate) range_bins: u32,
    /// Sonar 2's beams (1 for a sidescan, 2 for a two-sided one).
    pub(crate) beams: u32,
    pub(crate) words_per_mask: u32,
    pub(crate) _pad0: u32,
    /// 1 when sonar 2 has several beams (an FLS or a two-sided sidescan), 0 for range bins only.
    pub(crate) beamed: u32,
    /// tan of half the elevation aperture, or < 0 for a 180° aperture (no test).
    pub(crate) tan_half_el: f32,
    /// tan of half the azimuth aperture (below 90°, checked on the CPU).
    pub(crate) tan_half_az: f32,
    /// cos of half the azimuth aperture. The edge search holds while `radius < ρ cos(half_az)`.
    pub(crate) cos_half_az: f32,
    pub(crate) _pad: f32,
}

/// One mask to draw, as `MaskJob` in shaders/mask.wgsl documents it. Keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct MaskJob {
    /// Rows of the rotation `R` (sonar 1 → sonar 2) with the translation `t` in `.w` (m).
    pub(crate) rows: [[f32; 4]; 3],
    /// The measured range of the set being masked (m).
    pub(crate) range: f32,
    /// The ball radius of one cell: cell, noise and rounding slack (m).
    pub(crate) radius: f32,
    /// The ball radius of a `BLOCK × BLOCK` block of cells around its middle point: block, noise
    /// and rounding slack (m).
    pub(crate) block_radius: f32,
    pub(crate) az_count: u32,
    pub(crate) el_count: u32,
    /// The job's first azimuth direction in the direction table. Its blocks' middles follow.
    pub(crate) az_offset: u32,
    /// The job's first elevation direction in the direction table. Its blocks' middles follow.
    pub(crate) el_offset: u32,
    /// Cells of a block along the azimuth: 1, 2, 4, 8, 16, 32 or 64, and `64 / block_a` along the
    /// elevation ([`block_shape`]).
    pub(crate) block_a: u32,
}

/// Byte sizes of the shared structs. src/masks/gpu/source_tests.rs checks them against naga.
pub(crate) const MASK_PARAMS_SIZE: usize = 48;
/// See [`MASK_PARAMS_SIZE`].
pub(crate) const MASK_JOB_SIZE: usize = 80;
const _: () = assert!(size_of::<MaskParams>() == MASK_PARAMS_SIZE);
const _: () = assert!(size_of::<MaskJob>() == MASK_JOB_SIZE);

/// Bindings of `shaders/mask.wgsl`: params, edges, jobs, dirs, bits, summaries (masks' bounds).
pub(crate) const MASK_BINDINGS: [Binding; 6] = [
    Binding::Uniform,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::ReadWrite,
    Binding::ReadWrite,
];

/// Bindings of `shaders/mask_reduce.wgsl`: params, bits, summaries, union.
pub(crate) const MASK_REDUCE_BINDINGS: [Binding; 4] = [
    Binding::Uniform,
    Binding::Read,
    Binding::ReadWrite,
    Binding::ReadWrite,
];

/// Threads per workgroup of the mask stage, one per cell of a block. WGSL `@workgroup_size` in
/// mask.wgsl, checked in src/masks/gpu/source_tests.rs.
pub(crate) const MASK_WORKGROUP: u64 = 64;
const _: () = assert!(MASK_WORKGROUP as usize == BLOCK * BLOCK);
/// Threads per workgroup of the reduce stage (checked in src/masks/gpu/source_tests.rs).
pub(crate) const MASK_REDUCE_WORKGROUP: u64 = 64;
/// Words a mask's summary takes in the reduce stage's output.
const SUMMARY_WORDS: usize = 5;
/// The most workgroups along x. Beyond it, workgroups stride over blocks or a mask's words.
const MAX_TILES: u64 = 4096;
/// The most direction-table entries kept between pings (8 MiB). Past it, the tables start afresh.
const MAX_TABLE_ENTRIES: usize = 1 << 20;
/// The most bytes of mask bitsets one dispatch holds on the device (64 MiB). A ping of many
/// features goes in several dispatches, two in flight, so a summary holds at most twice this
/// whatever its number of features.
const MAX_DISPATCH_BITSET_BYTES: u64 = 64 << 20;

/// Returns how many masks of `words` 32-bit words one dispatch takes: within the y limit, with
/// the bitsets and what is read back of them (union, summaries, bitsets) in one binding of
/// `limit` bytes, and the bitsets within [`MAX_DISPATCH_BITSET_BYTES`]. One at least.
#[expect(clippy::cast_possible_truncation, reason = "at most 65 535")]
fn jobs_per_dispatch(words: u64, limit: u64) -> usize {
    let per_mask = words * 4 + SUMMARY_WORDS as u64 * 4;
    let by_binding = limit.saturating_sub(words * 4) / per_mask;
    let by_budget = MAX_DISPATCH_BITSET_BYTES / (words * 4).max(1);
    65_535u64.min(by_binding).min(by_budget).max(1) as usize
}

/// Returns the most workgroups a mask gets along x in the draw and the reduce stage.
///
/// A hardware GPU gets many, since its cores run them at once. A software adapter such as
/// lavapipe pays a fixed cost per workgroup on the CPU's cores. It gets few, which stride over
/// the blocks and words instead. On lavapipe with 2 cores (`bench masks`), a 100-feature ping
/// took 29–30 ms with 4096 workgroups and 13.5–14 ms with one draw and four reduce workgroups a
/// mask. Later shader work and [`rows_of_jobs`] brought it to 4.5–4.6 ms.
fn tiles(ctx: &GpuContext) -> (u64, u64) {
    if ctx.is_software() {
        (1, 4)
    } else {
        (MAX_TILES, MAX_TILES)
    }
}

/// Returns the workgroup row (dispatch order) of each of a dispatch's `n` jobs.
///
/// Job `k` goes in row `k · s mod n`, where `s` is the first stride from `0.618 n` up that is
/// coprime with `n`. So any run of consecutive rows holds jobs from all over the ping. A
/// software adapter such as lavapipe gives each thread a run of consecutive workgroups. Features
/// in order (by range, as a detector lists them) would give the runs unequal work. A 100-feature
/// ping on lavapipe, 2 cores, took 6.7–6.9 ms in job order and 4.5 ms spread (`bench masks`).
/// Results are handed out in job order whatever the rows.
fn rows_of_jobs(n: usize) -> Vec<usize> {
    const fn gcd(a: usize, b: usize) -> usize {
        if b == 0 { a } else { gcd(b, a % b) }
    }
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_precision_loss,
        reason = "a stride below n, n a dispatch's job count"
    )]
    let mut s = ((n as f64 * 0.618) as usize).max(1);
    while gcd(s, n) != 1 {
        s += 1;
    }
    (0..n).map(|k| k * s % n).collect()
}

/// One mask for the GPU to draw: the pose and the plan.
pub(crate) struct Job {
    pub(crate) pose: RelativePose,
    /// The cells and radius.
    pub(crate) plan: Plan,
}

/// What the GPU returns of a ping, in sonar 2's layout: the union, each mask's reduction, and
/// the masks themselves when asked for.
pub(crate) struct Drawn {
    pub(crate) union: Occupancy,
    /// Per mask, its pixel count and bounds.
    pub(crate) reduced: Vec<Reduced>,
    /// Per mask, its bits (only when asked for).
    pub(crate) masks: Option<Vec<Occupancy>>,
}

/// Returns the radius (m) added to every ball on the GPU to cover f32 rounding, for a set at
/// range `r` under `pose` in `layout` ([`MASK_F32_SLACK`], [`MASK_F32_FLOOR`]).
pub(crate) fn slack(r: f64, pose: &RelativePose, layout: &Layout) -> f64 {
    MASK_F32_SLACK * (r + pose.translation.length() + layout.range_max) + MASK_F32_FLOOR
}

/// What the engine keeps on the device between pings: the tables, and two slots of buffer pools
/// with their bind groups. A bind group is remade only when one of its buffers is. Two slots
/// let two dispatches be in flight ([`GpuMasks::draw_pings`]).
#[derive(Default)]
struct State {
    tables: Tables,
    slots: [BufferPool; 2],
}

/// A dispatch submitted and not yet read: its slot, each job's workgroup row ([`rows_of_jobs`]),
/// whether it copied the masks too, and what to read after which submission.
struct Pending {
    slot: usize,
    rows: Vec<usize>,
    masks: bool,
    staging: wgpu::Buffer,
    read_bytes: u64,
    index: wgpu::SubmissionIndex,
}

impl Drawn {
    /// Returns an empty result in `layout`, with room for masks when `masks`.
    fn empty(layout: &Layout, masks: bool) -> Drawn {
        Drawn {
            union: Occupancy::new(layout.range_bins, layout.beams()),
            reduced: Vec::new(),
            masks: masks.then(Vec::new),
        }
    }
}

/// The mask pipelines on one GPU, for one sonar 2.
pub(crate) struct GpuMasks {
    ctx: GpuContext,
    stage: Stage,
    reduce: Stage,
    params: MaskParams,
    params_buffer: wgpu::Buffer,
    edges: wgpu::Buffer,
    state: Mutex<State>,
    /// The most workgroups a mask of the draw and the reduce stage gets along x.
    tiles: (u64, u64),
}

impl std::fmt::Debug for GpuMasks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuMasks")
            .field("adapter", &self.ctx.info().name)
            .finish()
    }
}

impl GpuMasks {
    /// Returns the pipelines for sonar 2's `layout` on `ctx`.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for an azimuth aperture of 180° or more. [`Error::Gpu`] when the
    /// device refuses a stage.
    pub(crate) fn new(ctx: GpuContext, layout: &Layout) -> Result<GpuMasks> {
        let ha = layout.half_azimuth;
        if ha >= std::f64::consts::FRAC_PI_2 {
            return Err(Error::invalid(
                "sonar 2 azimuth aperture",
                format!("{} deg", 2.0 * ha.to_degrees()),
                "GPU masks need less than 180 deg; the CPU mask engine takes any aperture",
            ));
        }
        let device = ctx.device();
        let tiles = tiles(&ctx);
        let stage = Stage::new(device, "mask", &source::mask(), &MASK_BINDINGS)?;
        let reduce = Stage::new(
            device,
            "mask reduce",
            &source::mask_reduce(),
            &MASK_REDUCE_BINDINGS,
        )?;
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
        let params_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mask params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        Ok(GpuMasks {
            ctx,
            stage,
            reduce,
            params,
            params_buffer,
            edges,
            state: Mutex::new(State::default()),
            tiles,
        })
    }

    /// Returns the adapter's description.
    pub(crate) fn describe(&self) -> String {
        format!("{} (f32 with rounding slack)", context::describe(self.ctx.info()))
    }

    /// Returns the largest storage binding the stages use (at most 256 MiB).
    fn binding_limit(&self) -> u64 {
        self.ctx
            .limits()
            .max_storage_buffer_binding_size
            .min(self.ctx.limits().max_buffer_size)
            .min(256 << 20)
    }

    /// Returns the union and reductions of the masks of `jobs` (a pose and a plan each), in order
    /// and in sonar 2's layout, and the masks themselves when `masks`.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when one job's cell tables exceed what the device can bind.
    /// [`Error::Gpu`] on device failure.
    pub(crate) fn draw(&self, layout: &Layout, jobs: &[Job], masks: bool) -> Result<Drawn> {
        let mut out = None;
        // The sink never breaks: the one ping is always given out.
        let _ = self.draw_pings(layout, &[jobs], masks, &mut |_, drawn| {
            out = Some(drawn);
            Ok(Flow::Continue(()))
        })?;
        Ok(out.expect("one ping"))
    }

    /// Gives `emit` each ping's index and [`GpuMasks::draw`], in order, as soon as it is read back.
    /// It stops when `emit` answers `Break`, and returns that. Two dispatches are in flight: the
    /// next ping is planned, uploaded and submitted while the GPU draws the one before, and read
    /// back after it. So `emit` runs while the GPU draws the next.
    ///
    /// # Errors
    /// As [`GpuMasks::draw`], and `emit`'s errors (which stop it).
    pub(crate) fn draw_pings(
        &self,
        layout: &Layout,
        pings: &[&[Job]],
        masks: bool,
        emit: &mut dyn FnMut(usize, Drawn) -> Result<Flow>,
    ) -> Result<Flow> {
        let mut state = self.state.lock().unwrap_or_else(|poisoned| {
            let mut state = poisoned.into_inner();
            *state = State::default();
            state
        });
        let mut dispatches = Vec::new();
        for (p, jobs) in pings.iter().enumerate() {
            dispatches.extend(self.dispatches(jobs)?.into_iter().map(|(r, e)| (p, r, e)));
        }
        let mut out: Vec<Option<Drawn>> = pings.iter().map(|_| Some(Drawn::empty(layout, masks))).collect();
        // Dispatches of each ping not yet read back, and the first ping not yet given out.
        let mut left = vec![0usize; pings.len()];
        for (p, _, _) in &dispatches {
            left[*p] += 1;
        }
        let mut next = 0;
        let mut give_out = |out: &mut Vec<Option<Drawn>>, left: &[usize], next: &mut usize| -> Result<Flow> {
            while *next < left.len() && left[*next] == 0 {
                let flow = emit(*next, out[*next].take().expect("a ping given out once"))?;
                *next += 1;
                if flow.is_break() {
                    return Ok(flow);
                }
            }
            Ok(Flow::Continue(()))
        };
        // Reads back dispatch `pending` of ping `q` into its drawing.
        let read_back = |state: &mut State,
                         out: &mut Vec<Option<Drawn>>,
                         left: &mut [usize],
                         (q, pending): (usize, Pending)|
         -> Result<()> {
            self.collect(
                state,
                pending,
                layout,
                out[q].as_mut().expect("a ping still drawn"),
            )?;
            left[q] -= 1;
            Ok(())
        };
        let mut in_flight: std::collections::VecDeque<(usize, Pending)> = std::collections::VecDeque::new();
        let result = (|| -> Result<Flow> {
            if give_out(&mut out, &left, &mut next)?.is_break() {
                return Ok(Flow::Break(()));
            }
            for (i, (p, r, entries)) in dispatches.into_iter().enumerate() {
                // This slot was last used two dispatches ago. Read that dispatch first.
                if in_flight.len() == 2
                    && let Some(oldest) = in_flight.pop_front()
                {
                    read_back(&mut state, &mut out, &mut left, oldest)?;
                }
                // Submit before giving out, so the GPU draws the next meanwhile.
                let pending = self.submit(&mut state, i % 2, layout, &pings[p][r], entries, masks)?;
                in_flight.push_back((p, pending));
                if give_out(&mut out, &left, &mut next)?.is_break() {
                    return Ok(Flow::Break(()));
                }
            }
            while let Some(oldest) = in_flight.pop_front() {
                read_back(&mut state, &mut out, &mut left, oldest)?;
                if give_out(&mut out, &left, &mut next)?.is_break() {
                    return Ok(Flow::Break(()));
                }
            }
            Ok(Flow::Continue(()))
        })();
        if !matches!(result, Ok(Flow::Continue(()))) {
            // A failed dispatch or readback may leave a staging buffer mapped. A stream ended
            // early leaves dispatches unread. Either way, start afresh.
            *state = State::default();
        }
        result
    }

    /// Returns the dispatches `jobs` are drawn in: each one's range of jobs and the table entries
    /// it may add.
    ///
    /// # Errors
    /// As [`GpuMasks::draw`].
    fn dispatches(&self, jobs: &[Job]) -> Result<Vec<(std::ops::Range<usize>, usize)>> {
        let words = u64::from(self.params.words_per_mask);
        let limit = self.binding_limit();
        // The most entries the tables' binding holds. A job's, and a dispatch's, must fit.
        let tables_cap = (limit / 8) as usize;
        let per_dispatch = jobs_per_dispatch(words, limit);
        let mut out = Vec::new();
        let (mut start, mut entries) = (0, 0);
        for (k, job) in jobs.iter().enumerate() {
            let (na, ne) = (job.plan.cells.azimuths.len(), job.plan.cells.elevations.len());
            let (ba, be) = block_shape(na, ne);
            let e = table_entries(na, ba) + table_entries(ne, be);
            if e > tables_cap {
                return Err(Error::invalid(
                    "mask cells",
                    e,
                    format!(
                        "at most {tables_cap} cell directions on this GPU (the CPU mask engine has no such limit)"
                    ),
                ));
            }
            if k > start && (k - start == per_dispatch || entries + e > tables_cap) {
                out.push((start..k, entries));
                (start, entries) = (k, 0);
            }
            entries += e;
        }
        if start < jobs.len() {
            out.push((start..jobs.len(), entries));
        }
        Ok(out)
    }

    /// Submits the drawing and reduction of one dispatch's `jobs` in `slot`, copying the masks out
    /// too when `masks`. Their tables take at most `entries` new entries.
    fn submit(
        &self,
        state: &mut State,
        slot: usize,
        layout: &Layout,
        jobs: &[Job],
        entries: usize,
        masks: bool,
    ) -> Result<Pending> {
        // Tables kept between pings stay within MAX_TABLE_ENTRIES and start afresh past it. Only
        // a dispatch that needs more may go further, up to its binding.
        let keep = MAX_TABLE_ENTRIES
            .min((self.binding_limit() / 8) as usize)
            .max(entries);
        if state.tables.host.len() + entries > keep {
            state.tables.clear();
        }
        let (gpu_jobs, rows, max_blocks) = pack_jobs(&mut state.tables, layout, jobs);
        state.tables.upload(&self.ctx);
        let device = self.ctx.device();
        let queue = self.ctx.queue();
        let words = u64::from(self.params.words_per_mask);
        let n = jobs.len() as u64;
        let limit = self.binding_limit();
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let bits_bytes = n * words * 4;
        let union_bytes = words * 4;
        let summary_bytes = n * SUMMARY_WORDS as u64 * 4;
        let read_bytes = union_bytes + summary_bytes + if masks { bits_bytes } else { 0 };
        let pool = &mut state.slots[slot];
        let jobs_buffer = pool.get(device, "mask jobs", n * MASK_JOB_SIZE as u64, limit, storage);
        let mut output =
            |label, size| pool.get(device, label, size, limit, storage | wgpu::BufferUsages::COPY_SRC);
        let (bits, summaries, union) = (
            output("mask bits", bits_bytes),
            output("mask summaries", summary_bytes),
            output("mask union", union_bytes),
        );
        let staging = pool.get(
            device,
            "mask staging",
            read_bytes,
            limit,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let dirs = state.tables.buffer.clone().expect("uploaded above");
        let draw_group = pool.bind(
            device,
            "mask draw",
            &self.stage,
            &[
                &self.params_buffer,
                &self.edges,
                &jobs_buffer,
                &dirs,
                &bits,
                &summaries,
            ],
        );
        let reduce_group = pool.bind(
            device,
            "mask reduce",
            &self.reduce,
            &[&self.params_buffer, &bits, &summaries, &union],
        );
        queue.write_buffer(&jobs_buffer, 0, bytemuck::cast_slice(&gpu_jobs));
        let mut enc = device.create_command_encoder(&Default::default());
        enc.clear_buffer(&bits, 0, Some(bits_bytes));
        enc.clear_buffer(&summaries, 0, Some(summary_bytes));
        enc.clear_buffer(&union, 0, Some(union_bytes));
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.stage.pipeline);
            pass.set_bind_group(0, &draw_group, &[]);
            pass.dispatch_workgroups(max_blocks.min(self.tiles.0) as u32, n as u32, 1);
            pass.set_pipeline(&self.reduce.pipeline);
            pass.set_bind_group(0, &reduce_group, &[]);
            let tiles = words.div_ceil(MASK_REDUCE_WORKGROUP).clamp(1, self.tiles.1);
            pass.dispatch_workgroups(tiles as u32, n as u32, 1);
        }
        enc.copy_buffer_to_buffer(&union, 0, &staging, 0, union_bytes);
        enc.copy_buffer_to_buffer(&summaries, 0, &staging, union_bytes, summary_bytes);
        if masks {
            enc.copy_buffer_to_buffer(&bits, 0, &staging, union_bytes + summary_bytes, bits_bytes);
        }
        let index = queue.submit([enc.finish()]);
        Ok(Pending {
            slot,
            rows,
            masks,
            staging,
            read_bytes,
            index,
        })
    }

    /// Reads back `pending` once its submission is done and adds its union, reductions and
    /// masks to `drawn`.
    fn collect(&self, state: &mut State, pending: Pending, layout: &Layout, drawn: &mut Drawn) -> Result<()> {
        let words = self.params.words_per_mask as usize;
        let Pending {
            slot,
            rows,
            masks,
            staging,
            read_bytes,
            index,
        } = pending;
        let jobs = rows.len();
        debug_assert!(!masks || drawn.masks.is_some());
        // Read in place: the union, summaries and masks go straight into their own vectors.
        read_after(&self.ctx, &staging, read_bytes, Some(index), |raw| {
            for (u, w) in drawn.union.words.iter_mut().zip(&raw[..words]) {
                *u |= w;
            }
            // Job k's results are in row rows[k].
            let summaries = &raw[words..words + SUMMARY_WORDS * jobs];
            drawn.reduced.extend(rows.iter().map(|&row| {
                let s = &summaries[row * SUMMARY_WORDS..(row + 1) * SUMMARY_WORDS];
                Reduced {
                    pixels: u64::from(s[0]),
                    bounds: (s[0] > 0)
                        .then(|| ((!s[1] as usize, s[2] as usize), (!s[3] as usize, s[4] as usize))),
                }
            }));
            if let Some(out) = drawn.masks.as_mut().filter(|_| masks) {
                let bits = &raw[words + SUMMARY_WORDS * jobs..];
                out.extend(rows.iter().map(|&row| {
                    let w = &bits[row * words..(row + 1) * words];
                    Occupancy::from_words(layout.range_bins, layout.beams(), w.to_vec())
                }));
            }
        })
        .inspect_err(|_| state.slots[slot] = BufferPool::default())
    }
}

/// Returns `jobs` as the mask stage reads them, in the order of their rows ([`rows_of_jobs`]),
/// with each job's row and the most blocks of cells in one job. Adds their cell tables to
/// `tables`.
fn pack_jobs(tables: &mut Tables, layout: &Layout, jobs: &[Job]) -> (Vec<MaskJob>, Vec<usize>, u64) {
    let mut max_blocks = 1u64;
    let rows = rows_of_jobs(jobs.len());
    let mut in_rows = vec![0; jobs.len()];
    for (k, &row) in rows.iter().enumerate() {
        in_rows[row] = k;
    }
    let gpu_jobs: Vec<MaskJob> = in_rows
        .iter()
        .map(|&k| &jobs[k])
        .map(|Job { pose, plan }| {
            let cells = &plan.cells;
            let (na, ne) = (cells.azimuths.len(), cells.elevations.len());
            let (ba, be) = block_shape(na, ne);
            max_blocks = max_blocks.max((na.div_ceil(ba) * ne.div_ceil(be)) as u64);
            let slack = slack(plan.range, pose, layout);
            // A block's half-extents are those of its cells, as `View::blocks` measures them.
            // This also covers the smaller blocks at a grid's end.
            let block_half = (na.min(ba) as f64 * cells.half.0, ne.min(be) as f64 * cells.half.1);
            let block_radius = plan.range * block_half.0.hypot(block_half.1) + plan.noise_radius + slack;
            let t = pose.translation;
            let row = |i: usize| {
                let v = pose.rotation.row(i);
                [v.x as f32, v.y as f32, v.z as f32, t[i] as f32]
            };
            MaskJob {
                rows: [row(0), row(1), row(2)],
                range: plan.range as f32,
                radius: (plan.radius + slack) as f32,
                block_radius: block_radius as f32,
                az_count: na as u32,
                el_count: ne as u32,
                az_offset: tables.offset(&cells.azimuths, ba),
                el_offset: tables.offset(&cells.elevations, be),
                block_a: ba as u32,
            }
        })
        .collect();
    (gpu_jobs, rows, max_blocks)
}

#[cfg(test)]
mod tests {
    use super::{MAX_DISPATCH_BITSET_BYTES, jobs_per_dispatch, rows_of_jobs};

    /// A dispatch's bitsets stay within the budget and its binding, whatever the mask's size
    /// (one word to 1 GiB), and it takes one mask at least.
    #[test]
    fn a_dispatch_holds_a_bounded_number_of_masks() {
        for words in [1u64, 7, 1000, 8192, 1 << 16, 1 << 20, 1 << 28] {
            for limit in [128u64 << 20, 256 << 20, 2 << 30] {
                let n = jobs_per_dispatch(words, limit) as u64;
                assert!((1..=65_535).contains(&n), "{words} words: {n}");
                if n > 1 {
                    assert!(n * words * 4 <= MAX_DISPATCH_BITSET_BYTES, "{words} words: {n}");
                    assert!(n * (words * 4 + 20) + words * 4 <= limit, "{words} words: {n}");
                }
            }
        }
        // 32 KiB masks (a 512 × 512 image): 2048 a dispatch, 64 MiB.
        assert_eq!(jobs_per_dispatch(8192, 256 << 20), 2048);
    }

    /// Every job gets a row of its own, and every run of a tenth, quarter or half of the rows holds
    /// jobs from all over the ping. Their mean index is within an eighth of the middle (in job
    /// order it would be off by up to 45%). So features listed by range give lavapipe's threads
    /// runs of like work.
    #[test]
    fn rows_of_jobs_spread_a_permutation() {
        for n in 0..300 {
            let mut seen = vec![false; n];
            for &row in &rows_of_jobs(n) {
                assert!(row < n && !seen[row], "n {n}: row {row} twice or past the end");
                seen[row] = true;
            }
        }
        for n in [50, 64, 100, 128, 200, 257, 1000] {
            let mut jobs_in_row = vec![0; n];
            for (k, &row) in rows_of_jobs(n).iter().enumerate() {
                jobs_in_row[row] = k;
            }
            let runs = [n / 10, n / 4, n / 2].map(|size| jobs_in_row.chunks_exact(size));
            for run in runs.into_iter().flatten() {
                #[expect(clippy::cast_precision_loss, reason = "small counts")]
                let mean = run.iter().sum::<usize>() as f64 / run.len() as f64;
                let middle = (n - 1) as f64 / 2.0;
                assert!(
                    (mean - middle).abs() <= n as f64 / 8.0,
                    "n {n}: a run's jobs {run:?}"
                );
            }
        }
    }
}
