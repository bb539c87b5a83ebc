//! The GPU backend: WGSL compute shaders through wgpu. A batch is cut into chunks that fit the
//! device; each chunk is one submission of two stages (splat, reduce) and reads back the metric
//! slots the caller's columns need, at most 32 bytes a pose (plus the bitsets only when
//! occupancy is asked for). The CPU twin of the two stages is [`crate::projection::fast`],
//! block culling included.
#![expect(
    clippy::cast_possible_truncation,
    reason = "GPU buffers hold f32 and u32: values are rounded to f32 on purpose and counts are bounded by the device limits checked before packing"
)]

mod slots;
mod source;
mod tables;
pub(crate) mod types;
mod unpack;

use std::ops::ControlFlow;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geometry::SonarKind;
pub(crate) use crate::gpu::options::SPLAT_WORKGROUP;
pub use crate::gpu::options::SPLAT_WORKGROUPS;
use crate::gpu::pipeline::{Binding, Stage};
use crate::gpu::pool::{BufferPool, SharedPool};
use crate::gpu::timing::{DeviceClock, PassTimer, Timed};
use crate::gpu::{GpuContext, GpuOptions, read_after};
use crate::projection::columns::MetricColumns;
use crate::projection::poses::PreparedGrid;
use crate::projection::{Output, PreparedBatch, Projection};
use bytemuck::Zeroable;
use slots::{Directions, InFlight, SLOT_LABELS, Shape, Slot, SlotSizes};
use tables::{grid_table, pose_gpu};
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

/// Bindings of `shaders/poses.wgsl`: grid params, grid table, plans, poses.
pub(crate) const POSES_BINDINGS: [Binding; 4] =
    [Binding::Uniform, Binding::Read, Binding::Read, Binding::ReadWrite];

/// Threads a workgroup of the poses stage (one pose each).
pub(crate) const POSES_WORKGROUP: u64 = 64;

/// Most workgroups one pose's samples are spread over in the splat stage.
const MAX_TILES: u64 = 1024;
/// Most bytes one chunk's largest buffer (its bitsets, or its poses) may hold (also capped by
/// the device's binding size); two chunks are in flight.
const MAX_CHUNK_BUFFER_BYTES: u64 = 128 << 20;
/// Chunks a call of many poses (at least 4 × [`MIN_OVERLAP_POSES`]) is cut into at least, so
/// that the device has the next chunk to project while the host reads one back.
const OVERLAP_CHUNKS: usize = 4;
/// Fewest poses a chunk is cut to for that overlap (a submission's fixed cost stays small beside
/// its work).
const MIN_OVERLAP_POSES: usize = 16_384;

/// Variants of the splat stage, chosen when its pipeline is built (WGSL `override` constants), so
/// that one build can measure each on a GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplatOptions {
    /// Skip blocks of samples whose ball lies wholly outside sonar 2's view, and the clip tests
    /// of those wholly inside (the fast CPU path always does). Results are the same either way.
    pub cull: bool,
    /// Decide each sample in f32 first, with a slack far above the f32 roundings, and in `Real`
    /// (f64 or double-f32) only the samples f32 leaves undecided (near a clip bound or a bin or
    /// beam edge); a hidden sample then takes no `Real` operation, a visible one only its
    /// `Real` point (the reported range and azimuth). Results are the same either way.
    pub filter: bool,
    /// Threads a workgroup, one of [`SPLAT_WORKGROUPS`]: a workgroup takes this many
    /// consecutive samples of a pose at a time. Results are the same whatever it is.
    pub workgroup: u32,
}

impl SplatOptions {
    /// Returns the variant `options` ask for on `ctx`'s adapter, with the engine's choice where
    /// they leave one open: culling and the f32 filter on a hardware GPU, where `Real`
    /// arithmetic costs many f32 operations (f64 on consumer GPUs, double-f32), and neither on
    /// a software adapter such as lavapipe, measured slower there with each (BENCHMARKS.md);
    /// workgroups of [`SPLAT_WORKGROUP`] threads. Of `options`, only `cull`, `filter` and
    /// `workgroup` are read (the device is `ctx`).
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

/// The GPU backend: a device and the two pipelines, built once, and the chunk buffers, kept
/// between calls and grown to the largest batch seen ([`GpuBackend::kept_bytes`] says how much
/// GPU memory that is, [`GpuBackend::release_buffers`] frees it). Calls from several threads at
/// once are allowed: one uses the kept buffers, the others allocate their own.
#[derive(Debug)]
pub struct GpuBackend {
    ctx: GpuContext,
    splat: Stage,
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

    /// Returns the backend on `ctx` with valid `options`.
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

    /// Starts (clearing the sum) or stops timing this backend's compute passes on the device's
    /// clock; without timestamp queries on the adapter nothing is timed.
    pub fn time_device(&self, on: bool) {
        self.clock.set(on);
    }

    /// Returns the device time of the compute passes (pose decoding, splat, reduce) since
    /// [`GpuBackend::time_device`] started timing, or `None` when the adapter has no timestamp
    /// queries.
    #[must_use]
    pub fn device_time(&self) -> Option<std::time::Duration> {
        self.ctx
            .device()
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| self.clock.total(Timed::Device))
    }

    /// Returns the time the host spent, since [`GpuBackend::time_device`] started timing,
    /// waiting for chunks to finish on the device and unpacking their results (what a call
    /// costs beside the device's passes, with two chunks in flight).
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

    /// Returns the backend with chunks of at most `poses` poses (results do not depend on it;
    /// tests use it to prove so).
    #[must_use]
    pub fn with_max_chunk_poses(mut self, poses: usize) -> Self {
        self.max_chunk_poses = Some(poses.max(1));
        self
    }

    /// Returns the number of poses per chunk of a call of `total` poses with bitsets of `words`
    /// u32 each.
    fn chunk_poses(&self, words: usize, total: usize) -> usize {
        let limits = self.ctx.limits();
        // The largest of a chunk's buffers a pose: its bitsets, or its packed pose (which also
        // holds more than its 32 bytes of metrics).
        let bytes_per_pose = (words as u64 * 4).max(size_of::<PoseGpu>() as u64);
        let budget = MAX_CHUNK_BUFFER_BYTES
            .min(limits.max_storage_buffer_binding_size)
            .min(limits.max_buffer_size);
        let by_memory = (budget / bytes_per_pose).max(1) as usize;
        // Poses are spread over two dispatch dimensions (splat: y and z; reduce: x and y); the
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

    /// Returns the projections of every item of `prepared`; with [`Output::WithOccupancy`] each
    /// carries its occupancy buffer (read back from the GPU).
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
    /// their occupancy when `keep_occupancy` (what the tests hold to the envelope).
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
                    &mut |u| {
                        out.extend(u.projections());
                        Ok(ControlFlow::Continue(()))
                    },
                )
            })
            .map(|_| ())?;
        Ok(out)
    }

    /// Projects poses `blocks` of a prepared grid (ranges in increasing order, none empty) block
    /// by block into `out` (its rows replaced by each block's), handing each block's columns to
    /// `each` as soon as its last chunk is unpacked: each chunk's poses decoded on the device by the poses
    /// stage (`shaders/poses.wgsl`) from tables built once in f64, none packed or uploaded by
    /// the host, and the next block's first chunk already on the device while `each` runs (the
    /// device does not wait between blocks). Returns `Break` as soon as `each` does.
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
        let Some(first) = blocks.first() else {
            return Ok(ControlFlow::Continue(()));
        };
        let at = |i: u64| usize::try_from(i - first.start).expect("blocks of poses in memory");
        let runs: Vec<std::ops::Range<usize>> = blocks.iter().map(|b| at(b.start)..at(b.end)).collect();
        let source = Source::Grid {
            prepared,
            first: first.start,
        };
        // Only the slots of the columns kept are copied back.
        let slots = slots_of(crate::Metric::all().filter(|&m| out.keeps(m)));
        let mut block = 0;
        self.pool.with(|pool| {
            self.project_with(pool, &source, false, slots, &runs, &mut |u| {
                let run = runs[block].clone();
                if u.start == run.start {
                    out.resize(run.len());
                }
                // Straight into the columns, on all cores, no per-pose object; pieces small
                // enough for every core to take several (a chunk of 32 768 poses in 4096-row
                // pieces left half of 16 cores idle).
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

    /// Returns the metric columns of poses `range` of a prepared grid into `out` (its rows
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
        // No rows for no poses (a block is never empty); else the block's first chunk sets them,
        // the rows kept from the last call not zeroed first.
        if range.is_empty() {
            out.resize(0);
            return Ok(());
        }
        self.project_grid_blocks(prepared, &[range], out, &mut |_, _| ControlFlow::Continue(()))
            .map(|_| ())
    }

    /// Returns the bytes of GPU memory the backend keeps between calls (its chunk buffers, two
    /// sets once a call had two chunks or more, grown to the largest batch seen so far).
    #[must_use]
    pub fn kept_bytes(&self) -> u64 {
        self.pool.bytes()
    }

    /// Frees the buffers kept between calls (the next call allocates them again).
    pub fn release_buffers(&self) {
        self.pool.clear();
    }

    /// Projects poses `runs` of `source` (ranges of its poses, in increasing order, each cut into
    /// chunks of its own) with the buffers of `pool`, handing each chunk's results as read back
    /// (metric `read_slots`, and the bitsets when `keep_occupancy`) to `emit`, in order, until
    /// `emit` returns `Break` (returned; the chunk then in flight is left unread). Two chunks are
    /// in flight: the device projects one while the host reads back, unpacks and hands out the
    /// one before (and, for items, packs the one after).
    fn project_with(
        &self,
        pool: &mut BufferPool,
        source: &Source<'_>,
        keep_occupancy: bool,
        read_slots: Slots,
        runs: &[std::ops::Range<usize>],
        emit: &mut dyn FnMut(&Unpack<'_>) -> Result<ControlFlow<()>>,
    ) -> Result<ControlFlow<()>> {
        let device = self.ctx.device();
        let layout = source.layout();
        let plans = source.plans();
        let words = words_per_pose(layout);
        let bits_per_pose_bytes = (words as u64 * 4).max(4);
        if bits_per_pose_bytes > self.ctx.limits().max_storage_buffer_binding_size {
            return Err(Error::gpu_limit(format!(
                "one occupancy buffer ({bits_per_pose_bytes} bytes) exceeds this device's \
                 largest storage binding ({} bytes); the CPU backends have no such limit",
                self.ctx.limits().max_storage_buffer_binding_size
            )));
        }
        // Each run cut into chunks of the size its own length gives.
        let chunks: Vec<std::ops::Range<usize>> = runs
            .iter()
            .flat_map(|r| {
                let chunk = self.chunk_poses(words, r.len());
                r.clone().step_by(chunk).map(move |s| s..(s + chunk).min(r.end))
            })
            .collect();
        let chunk = chunks.iter().map(ExactSizeIterator::len).max().unwrap_or(1);

        // Every buffer comes from the pool: the target's tables are rewritten on each call (a few
        // KiB), the chunk buffers are reused whenever the kept ones are large enough.
        // Buffers are bound whole, so growth stops at the largest binding.
        let limit = self
            .ctx
            .limits()
            .max_storage_buffer_binding_size
            .min(self.ctx.limits().max_buffer_size);
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let queue = self.ctx.queue();
        let mut upload = |label: &'static str, contents: &[u8], usage| {
            let buffer = pool.get(device, label, contents.len() as u64, limit, usage);
            queue.write_buffer(&buffer, 0, contents);
            buffer
        };
        let edges = upload("beam_edges", bytemuck::cast_slice(&beam_edges(layout)), storage);
        let weights = upload("row_weights", bytemuck::cast_slice(&row_weights(layout)), storage);
        let edges_sq = upload(
            "range_edges_sq",
            bytemuck::cast_slice(&range_edges_sq(layout)),
            storage,
        );
        // A grid's axis table, once per call.
        let grid = match source {
            Source::Items(_) => None,
            Source::Grid { prepared, .. } => {
                let (table, offsets) = grid_table(prepared.grid);
                Some((
                    upload("grid_table", bytemuck::cast_slice(&table), storage),
                    offsets,
                ))
            }
        };
        let timed = self.clock.on();
        let sizes = SlotSizes {
            chunk,
            bits: chunk as u64 * bits_per_pose_bytes,
            metrics: (chunk * METRIC_STRIDE * 4) as u64,
            grid: grid.is_some(),
            occupancy: keep_occupancy,
        };
        // The second slot only when there is a second chunk.
        let slots: Vec<Slot> = (0..chunks.len().clamp(1, 2))
            .map(|s| Slot::new(&self.ctx, pool, &SLOT_LABELS[s], &sizes, limit, timed))
            .collect();
        let shape = Shape {
            source,
            layout,
            plans,
            words,
            bits_per_pose_bytes,
            slots: read_slots,
        };

        let mut directions: Option<Directions> = None;
        let dim = self.ctx.limits().max_compute_workgroups_per_dimension.max(1);
        let mut in_flight: Option<InFlight> = None;
        for (i, &std::ops::Range { start, end }) in chunks.iter().enumerate() {
            let n = end - start;
            let (slot, labels) = (&slots[i % 2], &SLOT_LABELS[i % 2]);

            // Direction table of the plans this chunk uses (kept when the same plans repeat;
            // rewritten in queue order, after the chunk in flight has read the old one).
            let used = source.plans_used(start..end);
            let max_samples = used.iter().map(|&p| plans[p].total() as u64).fold(1, u64::max);
            if directions.as_ref().is_none_or(|d| d.plans != used) {
                directions = Some(Directions::upload(&self.ctx, pool, source, used, limit));
            }
            let Directions {
                buffer: dir_buffer,
                offsets,
                range_plans,
                ..
            } = directions.as_ref().expect("set above");

            // Items: packed on all cores (serial, this loop and the unpacking took 80–180 ns a
            // pose here, BENCHMARKS.md). A grid: the digits of the chunk's first pose, the poses
            // decoded by the poses stage.
            let decode = match (source, &grid, &slot.grid_params, range_plans) {
                (Source::Items(prepared), _, _, _) => {
                    let items = &prepared.batch.items;
                    let pose_data: Vec<PoseGpu> = (start..end)
                        .into_par_iter()
                        .map(|k| {
                            let plan_index = prepared.plan_index(k);
                            let plan = &prepared.plans[plan_index];
                            let [az_off, el_off] = offsets[&plan_index];
                            pose_gpu(
                                &items[k].pose.rotation,
                                items[k].pose.translation.to_array(),
                                items[k].measurement.range,
                                prepared.base_azimuth(k),
                                [
                                    az_off,
                                    plan.azimuths.len() as u32,
                                    el_off,
                                    plan.elevations.len() as u32,
                                ],
                            )
                        })
                        .collect();
                    queue.write_buffer(&slot.poses, 0, bytemuck::cast_slice(&pose_data));
                    None
                }
                (
                    Source::Grid { prepared, first, .. },
                    Some((table, axis_offsets)),
                    Some(grid_params),
                    Some(range_plans),
                ) => {
                    let grid = prepared.grid;
                    let digits = grid.indices(first + start as u64);
                    let mut g = GridParams {
                        count: n as u32,
                        placement: u32::from(grid.placement()),
                        fls: u32::from(prepared.source.kind == SonarKind::Fls),
                        ..GridParams::zeroed()
                    };
                    for k in 0..9 {
                        g.first[k] = digits[k] as u32;
                        g.lens[k] = grid.axes()[k].len() as u32;
                        g.offsets[k] = axis_offsets[k];
                    }
                    queue.write_buffer(grid_params, 0, bytemuck::bytes_of(&g));
                    Some(pool.bind(
                        device,
                        labels.poses_group,
                        &self.poses,
                        &[grid_params, table, range_plans, &slot.poses],
                    ))
                }
                _ => unreachable!("a grid has its tables"),
            };
            queue.write_buffer(
                &slot.params,
                0,
                bytemuck::bytes_of(&TargetParams::new(layout, n as u32)),
            );

            // The groups are kept with the pool's buffers: made again only when one was grown.
            let splat_group = pool.bind(
                device,
                labels.splat_group,
                &self.splat,
                &[
                    &slot.params,
                    &edges,
                    &edges_sq,
                    &slot.poses,
                    dir_buffer,
                    &slot.bits,
                    &slot.metrics,
                ],
            );
            let reduce_group = pool.bind(
                device,
                labels.reduce_group,
                &self.reduce,
                &[&slot.params, &edges, &weights, &slot.bits, &slot.metrics],
            );
            let tiles = max_samples
                .div_ceil(u64::from(self.options.workgroup))
                .clamp(1, MAX_TILES) as u32;
            let (used_bits, used_metrics) = shape.bytes(n);
            // The chunk's poses over two dimensions of workgroups.
            let across = (n as u32).min(dim);
            let rows = (n as u32).div_ceil(across);

            let mut enc = device.create_command_encoder(&Default::default());
            enc.clear_buffer(&slot.bits, 0, Some(used_bits));
            enc.clear_buffer(&slot.metrics, 0, Some(used_metrics));
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: None,
                    timestamp_writes: slot.timer.as_ref().map(PassTimer::writes),
                });
                if let Some(group) = &decode {
                    pass.set_pipeline(&self.poses.pipeline);
                    pass.set_bind_group(0, group, &[]);
                    pass.dispatch_workgroups((n as u64).div_ceil(POSES_WORKGROUP) as u32, 1, 1);
                }
                pass.set_pipeline(&self.splat.pipeline);
                pass.set_bind_group(0, &splat_group, &[]);
                pass.dispatch_workgroups(tiles, across, rows);
                pass.set_pipeline(&self.reduce.pipeline);
                pass.set_bind_group(0, &reduce_group, &[]);
                pass.dispatch_workgroups(across, rows, 1);
            }
            shape.copy_slots(&mut enc, &slot.metrics, &slot.metrics_staging, n);
            if let Some(staging) = &slot.bits_staging {
                enc.copy_buffer_to_buffer(&slot.bits, 0, staging, 0, used_bits);
            }
            if let Some(t) = &slot.timer {
                t.resolve(&mut enc);
            }
            let index = queue.submit([enc.finish()]);
            // While the device projects this chunk, the one before is read back and handed out.
            let before = in_flight.replace(InFlight {
                slot: i % 2,
                index,
                start,
                count: n,
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

    /// Waits for chunk `chunk` in `slot`, adds its device time when timed, and hands its results
    /// to `emit`: the metric slots read back, unpacked where they were mapped (no copy of them
    /// first).
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
            self.clock.add(Timed::Device, t.elapsed(&self.ctx, index())?);
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
        let read = shape.read_bytes(chunk.count);
        read_after(&self.ctx, &slot.metrics_staging, read, index(), |raw| {
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
            });
            if timed {
                self.clock.add(Timed::Unpack, unpacking.elapsed());
            }
            flow
        })?
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
