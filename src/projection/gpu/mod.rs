//! The GPU backend: WGSL compute shaders through wgpu. A batch is cut into chunks that fit the
//! device. Each chunk is one submission of two stages (splat, reduce). It reads back the metric
//! slots the caller's columns need, at most 32 bytes a pose, and the bitsets only when occupancy is
//! asked for. The CPU twin of the two stages, block culling included, is
//! [`crate::projection::fast`]. A summaries-only sweep adds a third stage and reads back no metric
//! slot (`summary.rs`, twin of the applications' summaries).
#![expect(
    clippy::cast_possible_truncation,
    reason = "GPU buffers hold f32 and u32: values are rounded to f32 on purpose and counts are bounded by the device limits checked before packing"
)]

mod slots;
mod source;
mod submit;
mod summary;
mod tables;
pub(crate) mod types;
mod unpack;

use std::ops::ControlFlow;

use rayon::prelude::*;

use crate::error::{Error, Result};
pub(crate) use crate::gpu::options::SPLAT_WORKGROUP;
pub use crate::gpu::options::SPLAT_WORKGROUPS;
use crate::gpu::pipeline::{Binding, Stage};
use crate::gpu::pool::{BufferPool, SharedPool};
use crate::gpu::timing::{DeviceClock, Timed};
use crate::gpu::{GpuContext, GpuOptions, read_after};
use crate::projection::columns::MetricColumns;
use crate::projection::pairs::PreparedPairs;
use crate::projection::poses::PreparedGrid;
use crate::projection::{Output, PreparedBatch, Projection};
use slots::{Directions, InFlight, SLOT_LABELS, Shape, Slot, SlotSizes};
pub(crate) use source::WIDEN;
use submit::{CallTables, Chunk};
pub(crate) use summary::FEATURES as SUMMARY_FEATURES;
use summary::SummaryRun;
use types::*;
use unpack::{Source, Unpack};

/// Bindings of `shaders/splat.wgsl`: params, beam_edges, range_edges_sq, poses, directions,
/// bits, metrics.
pub(crate) const SPLAT_BINDINGS: [Binding; 7] = [
    Binding::Uniform,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::ReadWrite,
    Binding::ReadWrite,
];

/// Bindings of `shaders/reduce.wgsl`: params, beam_edges, row_weights, bits, metrics.
pub(crate) const REDUCE_BINDINGS: [Binding; 5] = [
    Binding::Uniform,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::ReadWrite,
];

/// Bindings of `shaders/summary.wgsl`: params, metrics, poses, edges, marginal table,
/// accumulators, candidates.
pub(crate) const SUMMARY_BINDINGS: [Binding; 7] = [
    Binding::Uniform,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::Read,
    Binding::ReadWrite,
    Binding::ReadWrite,
];

/// Bindings of `shaders/poses.wgsl`: grid params, grid table, plans, poses.
pub(crate) const POSES_BINDINGS: [Binding; 4] =
    [Binding::Uniform, Binding::Read, Binding::Read, Binding::ReadWrite];

/// Threads a workgroup of the poses stage (one pose each).
pub(crate) const POSES_WORKGROUP: u64 = 64;

/// Threads a workgroup of the exact stage (one pose each) on a hardware GPU.
pub(crate) const EXACT_WORKGROUP: u32 = 64;

/// Most workgroups one pose's samples are spread over in the splat stage.
const MAX_TILES: u64 = 1024;
/// Most bytes one chunk's largest buffer (its bitsets, or its poses) may hold. The device's binding
/// size also caps it. Two chunks are in flight.
const MAX_CHUNK_BUFFER_BYTES: u64 = 128 << 20;
/// Fewest chunks a call of many poses (at least 4 × [`MIN_OVERLAP_POSES`]) is cut into, so that the
/// device has the next chunk to project while the host reads one back.
const OVERLAP_CHUNKS: usize = 4;
/// Fewest poses a chunk is cut to for that overlap, so a submission's fixed cost stays small beside
/// its work.
const MIN_OVERLAP_POSES: usize = 16_384;

/// Variants of the splat stage, chosen when its pipeline is built (WGSL `override` constants). One
/// build can then measure each on a GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplatOptions {
    /// Skip blocks of samples whose ball lies wholly outside sonar 2's view, and the clip tests of
    /// those wholly inside. The fast CPU path always does. Results are the same either way.
    pub cull: bool,
    /// Decide each sample in f32 first, with a slack far above the f32 roundings. Only the samples
    /// f32 leaves undecided (near a clip bound, a bin or a beam edge) are decided in `Real` (f64 or
    /// double-f32). A hidden sample then takes no `Real` operation, and a visible one only its
    /// `Real` point (the reported range and azimuth). Results are the same either way.
    pub filter: bool,
    /// Threads a workgroup, one of [`SPLAT_WORKGROUPS`]. A workgroup takes this many consecutive
    /// samples of a pose at a time. Results are the same whatever it is.
    pub workgroup: u32,
}

impl SplatOptions {
    /// Returns the variant `options` ask for on `ctx`'s adapter. Where they leave a choice open,
    /// the engine culls and filters in f32 on a hardware GPU, where `Real` arithmetic (f64 on
    /// consumer GPUs, double-f32) costs many f32 operations. On a software adapter such as lavapipe
    /// it does neither: each measured slower there (BENCHMARKS.md). Workgroups have
    /// [`SPLAT_WORKGROUP`] threads. Only `cull`, `filter` and `workgroup` of `options` are read;
    /// the device is `ctx`.
    #[must_use]
    pub fn for_adapter(ctx: &GpuContext, options: &GpuOptions) -> Self {
        let hardware = !ctx.is_software();
        let o = options;
        SplatOptions {
            cull: o.cull.unwrap_or(hardware),
            filter: o.filter.unwrap_or(hardware),
            workgroup: o.workgroup.unwrap_or(SPLAT_WORKGROUP),
        }
    }

    /// Returns a short description, such as `culling, f32 filter, 64 threads a workgroup`.
    #[must_use]
    pub fn describe(&self) -> String {
        let cull = if self.cull { "culling" } else { "no culling" };
        let filter = if self.filter {
            "f32 filter"
        } else {
            "no f32 filter"
        };
        format!("{cull}, {filter}, {} threads a workgroup", self.workgroup)
    }

    /// Returns `Ok(())` when the options can be built.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the workgroup size when it is not one of
    /// [`SPLAT_WORKGROUPS`].
    pub fn validate(&self) -> Result<()> {
        crate::gpu::options::check_workgroup(self.workgroup)
    }
}

/// The GPU backend: a device, its pipelines built once, and the chunk buffers. The buffers are kept
/// between calls and grown to the largest batch seen. [`GpuBackend::kept_bytes`] says how much GPU
/// memory that is, and [`GpuBackend::release_buffers`] frees it. Calls from several threads at once
/// are allowed: one uses the kept buffers, the others allocate their own.
#[derive(Debug)]
pub struct GpuBackend {
    ctx: GpuContext,
    splat: Stage,
    /// The exact stage, built on first use (f64 devices only).
    exact: std::sync::OnceLock<Stage>,
    /// The summary stage, built on first use (devices with 64-bit integer atomics only).
    summary: std::sync::OnceLock<Stage>,
    reduce: Stage,
    poses: Stage,
    options: SplatOptions,
    max_chunk_poses: Option<usize>,
    pool: SharedPool,
    clock: DeviceClock,
}

impl GpuBackend {
    /// Returns the backend on `ctx` with the engine's variant of the splat stage for its adapter
    /// ([`SplatOptions::for_adapter`] with no option given).
    ///
    /// # Errors
    /// [`Error::Gpu`] when the device refuses a stage's shader or pipeline.
    pub fn new(ctx: GpuContext) -> Result<Self> {
        let options = SplatOptions::for_adapter(&ctx, &GpuOptions::default());
        Self::with_options(ctx, options)
    }

    /// Returns the backend on `ctx`, building its pipelines with `options`.
    ///
    /// # Errors
    /// As [`SplatOptions::validate`]; [`Error::Gpu`] when the device refuses a stage.
    pub fn with_options(ctx: GpuContext, options: SplatOptions) -> Result<Self> {
        options.validate()?;
        Self::build(ctx, options)
    }

    fn build(ctx: GpuContext, options: SplatOptions) -> Result<Self> {
        let splat = Stage::with_constants(
            ctx.device(),
            "splat",
            &source::splat(ctx.precision()),
            &SPLAT_BINDINGS,
            &[
                ("CULL", f64::from(u8::from(options.cull))),
                ("FILTER", f64::from(u8::from(options.filter))),
                ("WORKGROUP", f64::from(options.workgroup)),
            ],
        )?;
        let reduce = Stage::new(ctx.device(), "reduce", &source::reduce(), &REDUCE_BINDINGS)?;
        let poses = Stage::new(
            ctx.device(),
            "poses",
            &source::poses(ctx.precision()),
            &POSES_BINDINGS,
        )?;
        Ok(GpuBackend {
            ctx,
            splat,
            exact: std::sync::OnceLock::new(),
            summary: std::sync::OnceLock::new(),
            reduce,
            poses,
            options,
            max_chunk_poses: None,
            pool: SharedPool::default(),
            clock: DeviceClock::default(),
        })
    }

    /// Returns the device context.
    #[must_use]
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Returns whether this device solves exact calls (`--step exact`) itself: it needs f64 in
    /// shaders ([`Precision::F64`](crate::gpu::Precision::F64)). Where it does not, the backend
    /// runs the fast CPU twin for them.
    #[must_use]
    pub fn solves_exact(&self) -> bool {
        self.ctx.precision() == crate::gpu::Precision::F64
    }

    /// Returns the threads a workgroup of the exact stage: [`EXACT_WORKGROUP`], or one on a
    /// software adapter (see `shaders/exact.wgsl`).
    fn exact_workgroup(&self) -> u32 {
        if self.ctx.is_software() {
            1
        } else {
            EXACT_WORKGROUP
        }
    }

    /// Returns the exact stage, building it on first use.
    fn exact_stage(&self) -> Result<&Stage> {
        built(&self.exact, || {
            Stage::with_constants(
                self.ctx.device(),
                "exact",
                &source::exact(),
                &SPLAT_BINDINGS,
                &[("WORKGROUP", f64::from(self.exact_workgroup()))],
            )
        })
    }

    /// Returns the summary stage, building it on first use.
    fn summary_stage(&self) -> Result<&Stage> {
        built(&self.summary, || {
            Stage::new(
                self.ctx.device(),
                "summary",
                &source::summary(),
                &SUMMARY_BINDINGS,
            )
        })
    }

    /// Starts (clearing the sum) or stops timing this backend's compute passes on the device's
    /// clock. Without timestamp queries on the adapter, nothing is timed.
    pub fn time_device(&self, on: bool) {
        self.clock.set(on);
    }

    /// Returns the device time of the compute passes (pose decoding, splat, reduce) since
    /// [`GpuBackend::time_device`] started timing. `None` when the adapter has no timestamp
    /// queries.
    #[must_use]
    pub fn device_time(&self) -> Option<std::time::Duration> {
        self.ctx
            .device()
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| self.clock.total(Timed::Device))
    }

    /// Returns the device time of each compute pass since [`GpuBackend::time_device`] started
    /// timing. `None` when the adapter has no timestamp queries. Timed chunks run a pass a stage
    /// where untimed ones run one pass for all three.
    #[must_use]
    pub fn device_stages(&self) -> Option<DeviceStages> {
        self.device_time().map(|_| DeviceStages {
            poses: self.clock.total(Timed::Poses),
            splat: self.clock.total(Timed::Splat),
            reduce: self.clock.total(Timed::Reduce),
        })
    }

    /// Returns the host's time since [`GpuBackend::time_device`] started timing: waiting for chunks
    /// to finish on the device, and unpacking their results. It is what a call costs beside the
    /// device's passes, with two chunks in flight.
    #[must_use]
    pub fn host_time(&self) -> HostTime {
        HostTime {
            wait: self.clock.total(Timed::Wait),
            unpack: self.clock.total(Timed::Unpack),
        }
    }

    /// Returns the splat stage's variant.
    #[must_use]
    pub fn options(&self) -> SplatOptions {
        self.options
    }

    /// Returns the backend with chunks of at most `poses` poses. Results do not depend on it, and
    /// tests use it to prove so.
    #[must_use]
    pub fn with_max_chunk_poses(mut self, poses: usize) -> Self {
        self.max_chunk_poses = Some(poses.max(1));
        self
    }

    /// Returns the number of poses per chunk of a call of `total` poses with bitsets of `words`
    /// u32 each.
    fn chunk_poses(&self, words: usize, total: usize) -> usize {
        let limits = self.ctx.limits();
        // The largest of a chunk's buffers, per pose: its bitsets, or its packed pose (which is
        // larger than its 32 bytes of metrics).
        let bytes_per_pose = (words as u64 * 4).max(size_of::<PoseGpu>() as u64);
        let budget = MAX_CHUNK_BUFFER_BYTES
            .min(limits.max_storage_buffer_binding_size)
            .min(limits.max_buffer_size);
        let by_memory = (budget / bytes_per_pose).max(1) as usize;
        // Poses are spread over two dispatch dimensions (splat: y and z; reduce: x and y). The
        // poses stage takes POSES_WORKGROUP a workgroup along x.
        let dim = u64::from(limits.max_compute_workgroups_per_dimension);
        let by_dispatch = usize::try_from((dim * POSES_WORKGROUP).min(dim * dim)).unwrap_or(usize::MAX);
        let by_overlap = total.div_ceil(OVERLAP_CHUNKS).max(MIN_OVERLAP_POSES);
        let mut n = by_memory.min(by_dispatch).min(by_overlap).min(total.max(1));
        if let Some(cap) = self.max_chunk_poses {
            n = n.min(cap);
        }
        n
    }

    /// Returns the projections of every item of `prepared`. With [`Output::WithOccupancy`] each
    /// carries its occupancy buffer, read back from the GPU.
    ///
    /// # Errors
    /// [`Error::Gpu`] when the device fails or a bitset does not fit in one binding.
    #[doc(hidden)]
    pub fn project(&self, prepared: &PreparedBatch<'_>, output: Output) -> Result<Vec<Projection>> {
        let mut out = Vec::with_capacity(prepared.batch.items.len());
        self.pool.with(|pool| {
            self.project_with(
                pool,
                &Source::Items(prepared),
                output == Output::WithOccupancy,
                ALL_SLOTS,
                std::slice::from_ref(&(0..prepared.batch.items.len())),
                None,
                &mut |u| {
                    out.extend(u.projections());
                    Ok(ControlFlow::Continue(()))
                },
            )
            .map(|_| ())
        })?;
        Ok(out)
    }

    /// Returns the projections of poses `range` of a prepared grid decoded on the device, with
    /// their occupancy when `keep_occupancy`. The tests hold these to the envelope.
    ///
    /// # Errors
    /// As [`GpuBackend::project_grid`].
    pub(crate) fn project_grid_projections(
        &self,
        prepared: &PreparedGrid<'_>,
        range: std::ops::Range<u64>,
        keep_occupancy: bool,
    ) -> Result<Vec<Projection>> {
        let count = usize::try_from(range.end - range.start).expect("a block of poses in memory");
        let source = Source::Grid {
            prepared,
            first: range.start,
        };
        let mut out = Vec::with_capacity(count);
        self.pool
            .with(|pool| {
                self.project_with(
                    pool,
                    &source,
                    keep_occupancy,
                    ALL_SLOTS,
                    std::slice::from_ref(&(0..count)),
                    None,
                    &mut |u| {
                        out.extend(u.projections());
                        Ok(ControlFlow::Continue(()))
                    },
                )
            })
            .map(|_| ())?;
        Ok(out)
    }

    /// Projects poses `blocks` of a prepared grid block by block into `out`, and hands each block's
    /// columns to `each` once its last chunk is unpacked. Returns `Break` as soon as `each` does.
    /// `blocks` are ranges in increasing order, none empty; each replaces `out`'s rows. The poses
    /// stage (`shaders/poses.wgsl`) decodes the poses on the device from tables built once in f64,
    /// so the host packs and uploads none. The next block's first chunk is already on the device
    /// while `each` runs, so the device does not wait between blocks.
    ///
    /// # Errors
    /// [`Error::Gpu`] when the device fails or a bitset does not fit in one binding.
    pub(crate) fn project_grid_blocks(
        &self,
        prepared: &PreparedGrid<'_>,
        blocks: &[std::ops::Range<u64>],
        out: &mut MetricColumns,
        each: &mut dyn FnMut(std::ops::Range<u64>, &MetricColumns) -> ControlFlow<()>,
    ) -> Result<ControlFlow<()>> {
        self.project_source_blocks(&|first| Source::Grid { prepared, first }, blocks, out, each)
    }

    /// Projects pairs `blocks` (prepared) block by block into `out`, as
    /// [`GpuBackend::project_grid_blocks`] does for a grid, sampled or (on a device that
    /// [`GpuBackend::solves_exact`]) exact. The host composes each pair's pose from the tables on
    /// all cores, as it packs a batch's items, and no item object is built.
    ///
    /// # Errors
    /// As [`GpuBackend::project_grid_blocks`].
    pub(crate) fn project_pairs_blocks(
        &self,
        prepared: &PreparedPairs<'_>,
        blocks: &[std::ops::Range<u64>],
        out: &mut MetricColumns,
        each: &mut dyn FnMut(std::ops::Range<u64>, &MetricColumns) -> ControlFlow<()>,
    ) -> Result<ControlFlow<()>> {
        self.project_source_blocks(&|first| Source::Pairs { prepared, first }, blocks, out, each)
    }

    /// Projects `blocks` of the source that `source_from` gives for the blocks' first pose, block
    /// by block into `out`, handing each block's columns to `each`.
    fn project_source_blocks<'s>(
        &self,
        source_from: &dyn Fn(u64) -> Source<'s>,
        blocks: &[std::ops::Range<u64>],
        out: &mut MetricColumns,
        each: &mut dyn FnMut(std::ops::Range<u64>, &MetricColumns) -> ControlFlow<()>,
    ) -> Result<ControlFlow<()>> {
        let Some((first, runs)) = runs_of(blocks) else {
            return Ok(ControlFlow::Continue(()));
        };
        let source = source_from(first);
        // Only the slots of the columns kept are copied back.
        let slots = slots_of(crate::Metric::all().filter(|&m| out.keeps(m)));
        let mut block = 0;
        self.pool.with(|pool| {
            self.project_with(pool, &source, false, slots, &runs, None, &mut |u| {
                let run = runs[block].clone();
                if u.start == run.start {
                    out.resize(run.len());
                }
                // Straight into the columns, on all cores, with no per-pose object. Pieces are
                // small enough for every core to take several: a chunk of 32 768 poses in 4096-row
                // pieces left half of 16 cores idle.
                let piece = (u.count / (4 * rayon::current_num_threads())).clamp(256, 4096);
                let rows = u.start - run.start..u.start - run.start + u.count;
                let rows = out.slices(rows).chunks(piece);
                rows.into_par_iter()
                    .enumerate()
                    .for_each(|(b, rows)| u.fill(rows, b * piece));
                if u.start + u.count < run.end {
                    return Ok(ControlFlow::Continue(()));
                }
                block += 1;
                Ok(each(blocks[block - 1].clone(), out))
            })
        })
    }

    /// Writes the metric columns of poses `range` of a prepared grid into `out` (its rows
    /// replaced), as [`GpuBackend::project_grid_blocks`] does for one block.
    ///
    /// # Errors
    /// As [`GpuBackend::project_grid_blocks`].
    pub(crate) fn project_grid(
        &self,
        prepared: &PreparedGrid<'_>,
        range: std::ops::Range<u64>,
        out: &mut MetricColumns,
    ) -> Result<()> {
        self.project_source(&|first| Source::Grid { prepared, first }, range, out)
    }

    /// Writes the metric columns of pairs `range` (prepared) into `out` (its rows replaced), as
    /// [`GpuBackend::project_pairs_blocks`] does for one block.
    ///
    /// # Errors
    /// As [`GpuBackend::project_grid_blocks`].
    pub(crate) fn project_pairs(
        &self,
        prepared: &PreparedPairs<'_>,
        range: std::ops::Range<u64>,
        out: &mut MetricColumns,
    ) -> Result<()> {
        self.project_source(&|first| Source::Pairs { prepared, first }, range, out)
    }

    /// Writes the metric columns of poses `range` of the source that `source_from` gives for its
    /// first pose into `out`, its rows replaced.
    fn project_source<'s>(
        &self,
        source_from: &dyn Fn(u64) -> Source<'s>,
        range: std::ops::Range<u64>,
        out: &mut MetricColumns,
    ) -> Result<()> {
        // No rows for no poses (a block is never empty). Otherwise the block's first chunk sets
        // them; the rows kept from the last call are not zeroed first.
        if range.is_empty() {
            out.resize(0);
            return Ok(());
        }
        self.project_source_blocks(source_from, &[range], out, &mut |_, _| ControlFlow::Continue(()))
            .map(|_| ())
    }

    /// Returns the bytes of GPU memory the backend keeps between calls: its chunk buffers, grown to
    /// the largest batch seen so far. There are two sets once a call had two chunks or more.
    #[must_use]
    pub fn kept_bytes(&self) -> u64 {
        self.pool.bytes()
    }

    /// Frees the buffers kept between calls. The next call allocates them again.
    pub fn release_buffers(&self) {
        self.pool.clear();
    }

    /// Projects poses `runs` of `source` with the buffers of `pool`, and hands each chunk's results
    /// to `emit` in order as they are read back. `runs` are ranges of poses in increasing order,
    /// each cut into its own chunks. The results are the metric `read_slots`, and the bitsets when
    /// `keep_occupancy`. Stops when `emit` returns `Break`, and returns it; the chunk then in
    /// flight is left unread.
    ///
    /// Two chunks are in flight: the device projects one while the host reads back, unpacks and
    /// hands out the one before (and, for items, packs the one after).
    ///
    /// With a `summary` run, the summary stage reduces each chunk on the device and no metric slot
    /// is read back (`read_slots` is empty): `emit` gets the chunk's candidates, and at each run's
    /// end its accumulators.
    #[expect(clippy::too_many_arguments, reason = "the call's shape, one argument each")]
    fn project_with(
        &self,
        pool: &mut BufferPool,
        source: &Source<'_>,
        keep_occupancy: bool,
        read_slots: Slots,
        runs: &[std::ops::Range<usize>],
        summary: Option<&SummaryRun>,
        emit: &mut dyn FnMut(&Unpack<'_>) -> Result<ControlFlow<()>>,
    ) -> Result<ControlFlow<()>> {
        let layout = source.layout();
        let words = words_per_pose(layout);
        let bits_per_pose_bytes = (words as u64 * 4).max(4);
        let max_binding = self.ctx.limits().max_storage_buffer_binding_size;
        if bits_per_pose_bytes > max_binding {
            return Err(Error::gpu_limit(format!(
                "one occupancy buffer ({bits_per_pose_bytes} bytes) exceeds this device's \
                 largest storage binding ({max_binding} bytes); the CPU backends have no such limit"
            )));
        }
        let chunks = self.chunks_of(words, runs);
        let chunk = chunks.iter().map(ExactSizeIterator::len).max().unwrap_or(1);
        // Buffers are bound whole, so growth stops at the largest binding.
        let limit = max_binding.min(self.ctx.limits().max_buffer_size);
        let tables = CallTables::upload(&self.ctx, pool, source, limit);
        let sizes = SlotSizes {
            chunk,
            bits: chunk as u64 * bits_per_pose_bytes,
            metrics: (chunk * METRIC_STRIDE * 4) as u64,
            grid: tables.grid.is_some(),
            occupancy: keep_occupancy,
            summary: summary.map(|s| (s.candidate_bytes(chunk), s.acc_bytes)),
        };
        // A second slot only when there is a second chunk.
        let timed = self.clock.on();
        let slots: Vec<Slot> = (0..chunks.len().clamp(1, 2))
            .map(|s| Slot::new(&self.ctx, pool, &SLOT_LABELS[s], &sizes, limit, timed))
            .collect();
        let shape = Shape {
            source,
            layout,
            plans: source.plans(),
            words,
            bits_per_pose_bytes,
            slots: read_slots,
            summary,
        };
        let mut directions: Option<Directions> = None;
        let mut in_flight: Option<InFlight> = None;
        for (i, poses) in chunks.iter().enumerate() {
            let chunk = Chunk {
                slot: i % 2,
                poses: poses.clone(),
                first_in_run: runs.iter().any(|r| r.start == poses.start),
                last_in_run: runs.iter().any(|r| r.end == poses.end),
            };
            directions = Some(self.directions_for(pool, &shape, &chunk, directions, limit));
            let directions = directions.as_ref().expect("set above");
            let index = self.submit_chunk(pool, &shape, &tables, &slots, directions, &chunk)?;
            // While the device projects this chunk, the one before is read back and handed out.
            let before = in_flight.replace(InFlight {
                slot: chunk.slot,
                index,
                start: poses.start,
                count: poses.len(),
                last_in_run: chunk.last_in_run,
            });
            if let Some(before) = before
                && self
                    .read_back(&slots[before.slot], &before, &shape, emit)?
                    .is_break()
            {
                return Ok(ControlFlow::Break(()));
            }
        }
        match in_flight {
            Some(last) => self.read_back(&slots[last.slot], &last, &shape, emit),
            None => Ok(ControlFlow::Continue(())),
        }
    }

    /// Returns the chunks of `runs`. Each run is cut into chunks of the size its own length gives
    /// ([`GpuBackend::chunk_poses`], bitsets of `words` a pose).
    fn chunks_of(&self, words: usize, runs: &[std::ops::Range<usize>]) -> Vec<std::ops::Range<usize>> {
        runs.iter()
            .flat_map(|r| {
                let chunk = self.chunk_poses(words, r.len());
                r.clone().step_by(chunk).map(move |s| s..(s + chunk).min(r.end))
            })
            .collect()
    }

    /// Waits for chunk `chunk` in `slot`, adds its device time when timed, and hands its results to
    /// `emit`. The metric slots read back are unpacked where they were mapped, without a copy.
    fn read_back(
        &self,
        slot: &Slot,
        chunk: &InFlight,
        shape: &Shape<'_>,
        emit: &mut dyn FnMut(&Unpack<'_>) -> Result<ControlFlow<()>>,
    ) -> Result<ControlFlow<()>> {
        let index = || Some(chunk.index.clone());
        let timed = self.clock.on();
        let waiting = std::time::Instant::now();
        if let Some(t) = &slot.timer {
            let stages = t.elapsed(&self.ctx, index())?;
            for (what, time) in Timed::STAGES.into_iter().zip(stages) {
                self.clock.add(what, time);
                self.clock.add(Timed::Device, time);
            }
        }
        let (used_bits, _) = shape.bytes(chunk.count);
        let raw_bits: Option<Vec<u32>> = match &slot.bits_staging {
            Some(staging) => Some(read_after(
                &self.ctx,
                staging,
                used_bits,
                index(),
                <[u32]>::to_vec,
            )?),
            None => None,
        };
        // A summary run reads back its candidates, and at a run's end its accumulators.
        let summary = match (shape.summary, &slot.summary) {
            (Some(run), Some(s)) => {
                let candidates = read_after(
                    &self.ctx,
                    &s.candidates_staging,
                    run.candidate_bytes(chunk.count),
                    index(),
                    <[u32]>::to_vec,
                )?;
                let acc = if chunk.last_in_run {
                    Some(read_after(
                        &self.ctx,
                        &s.acc_staging,
                        run.acc_bytes,
                        index(),
                        <[u32]>::to_vec,
                    )?)
                } else {
                    None
                };
                Some((candidates, acc))
            }
            _ => None,
        };
        let read = shape.read_bytes(chunk.count);
        let mut unpack = |raw: &[u32]| {
            let unpacking = std::time::Instant::now();
            if timed {
                self.clock.add(Timed::Wait, unpacking - waiting);
            }
            let flow = emit(&Unpack {
                source: shape.source,
                plans: shape.plans,
                layout: shape.layout,
                raw,
                slots: shape.slots,
                raw_bits: raw_bits.as_deref(),
                words: shape.words,
                pixel_words: types::pixel_words(shape.layout),
                start: chunk.start,
                count: chunk.count,
                exact: shape.source.exact_half().is_some(),
                summary: summary.as_ref().map(|(candidates, acc)| summary::ChunkSummary {
                    candidates,
                    acc: acc.as_deref(),
                }),
            });
            if timed {
                self.clock.add(Timed::Unpack, unpacking.elapsed());
            }
            flow
        };
        if read == 0 {
            return unpack(&[]);
        }
        read_after(&self.ctx, &slot.metrics_staging, read, index(), unpack)?
    }
}

/// Returns the stage in `cell`, built by `build` on first use (a failed build is tried again
/// next time).
fn built(cell: &std::sync::OnceLock<Stage>, build: impl FnOnce() -> Result<Stage>) -> Result<&Stage> {
    if let Some(stage) = cell.get() {
        return Ok(stage);
    }
    let stage = build()?;
    Ok(cell.get_or_init(|| stage))
}

/// Returns the first pose of `blocks` and the blocks as runs of a call from it, or `None` for no
/// block.
fn runs_of(blocks: &[std::ops::Range<u64>]) -> Option<(u64, Vec<std::ops::Range<usize>>)> {
    let first = blocks.first()?.start;
    let at = |i: u64| usize::try_from(i - first).expect("blocks of poses in memory");
    Some((first, blocks.iter().map(|b| at(b.start)..at(b.end)).collect()))
}

/// The device's time in each compute pass while a [`GpuBackend`] was timed
/// ([`GpuBackend::device_stages`]), on the device's own clock.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceStages {
    /// The poses stage: a grid's poses decoded from their index (nothing for items).
    pub poses: std::time::Duration,
    /// The splat stage (samples transformed, clipped and binned), or the exact stage.
    pub splat: std::time::Duration,
    /// The reduce stage: occupancy bits counted into metrics (and, in a summaries-only sweep
    /// reduced on the device, the summary stage after it, in the same pass).
    pub reduce: std::time::Duration,
}

impl DeviceStages {
    /// Returns the three passes' time together.
    #[must_use]
    pub fn total(&self) -> std::time::Duration {
        self.poses + self.splat + self.reduce
    }
}

/// The host's time beside the device's passes while a [`GpuBackend`] was timed
/// ([`GpuBackend::host_time`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HostTime {
    /// Waiting for chunks to finish on the device (their readback's mapping included).
    pub wait: std::time::Duration,
    /// Unpacking chunks' results (metrics into columns or projections, on all cores).
    pub unpack: std::time::Duration,
}
