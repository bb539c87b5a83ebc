//! What a chunk in flight owns. There are two sets of buffers (slots), so that the device projects
//! one chunk while the host reads back the chunk before. The chunks share the direction table.

use std::collections::HashMap;

use crate::gpu::GpuContext;
use crate::gpu::pool::BufferPool;
use crate::gpu::timing::PassTimer;
use crate::occupancy::Layout;
use crate::sampling::SamplingPlan;

use super::Source;
use super::summary::SummaryRun;
use super::tables::{direction_table, exact_table};
use super::types::{ALL_SLOTS, GridParams, METRIC_STRIDE, PoseGpu, Slots, SummaryParams, TargetParams};

/// The pool's names of one slot's buffers and bind groups.
pub(super) struct SlotLabels {
    pub(super) poses_group: &'static str,
    pub(super) splat_group: &'static str,
    pub(super) exact_group: &'static str,
    pub(super) reduce_group: &'static str,
    params: &'static str,
    grid_params: &'static str,
    poses: &'static str,
    bits: &'static str,
    metrics: &'static str,
    metrics_staging: &'static str,
    bits_staging: &'static str,
    pub(super) summary_group: &'static str,
    summary_params: &'static str,
    candidates: &'static str,
    candidates_staging: &'static str,
    acc_staging: &'static str,
}

/// The names of the two slots' buffers and bind groups.
pub(super) const SLOT_LABELS: [SlotLabels; 2] = [
    SlotLabels {
        poses_group: "poses stage 0",
        splat_group: "splat stage 0",
        exact_group: "exact stage 0",
        reduce_group: "reduce stage 0",
        params: "params 0",
        grid_params: "grid_params 0",
        poses: "poses 0",
        bits: "bits 0",
        metrics: "metrics 0",
        metrics_staging: "metrics_staging 0",
        bits_staging: "bits_staging 0",
        summary_group: "summary stage 0",
        summary_params: "summary_params 0",
        candidates: "candidates 0",
        candidates_staging: "candidates_staging 0",
        acc_staging: "accumulators_staging 0",
    },
    SlotLabels {
        poses_group: "poses stage 1",
        splat_group: "splat stage 1",
        exact_group: "exact stage 1",
        reduce_group: "reduce stage 1",
        params: "params 1",
        grid_params: "grid_params 1",
        poses: "poses 1",
        bits: "bits 1",
        metrics: "metrics 1",
        metrics_staging: "metrics_staging 1",
        bits_staging: "bits_staging 1",
        summary_group: "summary stage 1",
        summary_params: "summary_params 1",
        candidates: "candidates 1",
        candidates_staging: "candidates_staging 1",
        acc_staging: "accumulators_staging 1",
    },
];

/// What a slot must hold: the chunk's poses, its bitsets' and metrics' bytes, whether poses are
/// decoded from a grid, and whether the bitsets are read back.
pub(super) struct SlotSizes {
    pub(super) chunk: usize,
    pub(super) bits: u64,
    pub(super) metrics: u64,
    pub(super) grid: bool,
    pub(super) occupancy: bool,
    /// For a summary run: the bytes of a chunk's candidates and of the accumulators.
    pub(super) summary: Option<(u64, u64)>,
}

/// A slot's buffers for the summary stage: its parameters, its chunk's candidates, and where they
/// and the accumulators are read back.
pub(super) struct SummarySlot {
    pub(super) params: wgpu::Buffer,
    pub(super) candidates: wgpu::Buffer,
    pub(super) candidates_staging: wgpu::Buffer,
    pub(super) acc_staging: wgpu::Buffer,
}

/// The buffers of one chunk in flight.
pub(super) struct Slot {
    pub(super) params: wgpu::Buffer,
    pub(super) grid_params: Option<wgpu::Buffer>,
    pub(super) poses: wgpu::Buffer,
    pub(super) bits: wgpu::Buffer,
    pub(super) metrics: wgpu::Buffer,
    pub(super) metrics_staging: wgpu::Buffer,
    pub(super) bits_staging: Option<wgpu::Buffer>,
    /// The summary stage's buffers, in a summary run.
    pub(super) summary: Option<SummarySlot>,
    /// The device's clock around the chunk's pass, when timed.
    pub(super) timer: Option<PassTimer>,
}

impl Slot {
    /// Returns the slot named by `labels` for chunks of `sizes`, with a pass timer when `timed`.
    /// Its buffers come from `pool`, at most `limit` bytes each.
    pub(super) fn new(
        ctx: &GpuContext,
        pool: &mut BufferPool,
        labels: &SlotLabels,
        sizes: &SlotSizes,
        limit: u64,
        timed: bool,
    ) -> Slot {
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let copy_src = wgpu::BufferUsages::COPY_SRC;
        let readback = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        let mut get = |label, size, usage| pool.get(ctx.device(), label, size, limit, usage);
        Slot {
            params: get(labels.params, size_of::<TargetParams>() as u64, uniform),
            grid_params: sizes
                .grid
                .then(|| get(labels.grid_params, size_of::<GridParams>() as u64, uniform)),
            poses: get(labels.poses, (sizes.chunk * size_of::<PoseGpu>()) as u64, storage),
            bits: get(labels.bits, sizes.bits, storage | copy_src),
            metrics: get(labels.metrics, sizes.metrics, storage | copy_src),
            metrics_staging: get(labels.metrics_staging, sizes.metrics, readback),
            bits_staging: sizes
                .occupancy
                .then(|| get(labels.bits_staging, sizes.bits, readback)),
            summary: sizes.summary.map(|(candidates, acc)| SummarySlot {
                params: get(labels.summary_params, size_of::<SummaryParams>() as u64, uniform),
                candidates: get(labels.candidates, candidates, storage | copy_src),
                candidates_staging: get(labels.candidates_staging, candidates, readback),
                acc_staging: get(labels.acc_staging, acc, readback),
            }),
            timer: if timed { PassTimer::new(ctx) } else { None },
        }
    }
}

/// A chunk submitted and not yet read back: its slot, its submission, its first pose and its number
/// of poses.
pub(super) struct InFlight {
    pub(super) slot: usize,
    pub(super) index: wgpu::SubmissionIndex,
    pub(super) start: usize,
    pub(super) count: usize,
    /// Whether the chunk ends its run (a summary run then reads back the accumulators).
    pub(super) last_in_run: bool,
}

/// What every chunk of one call shares: where the poses come from, sonar 2's layout, the plans,
/// and the bitsets' words and bytes a pose.
pub(super) struct Shape<'a> {
    pub(super) source: &'a Source<'a>,
    pub(super) layout: &'a Layout,
    pub(super) plans: &'a [SamplingPlan],
    pub(super) words: usize,
    pub(super) bits_per_pose_bytes: u64,
    /// The metric slots copied back (none in a summary run).
    pub(super) slots: Slots,
    /// The reduction on the device, in a summary run.
    pub(super) summary: Option<&'a SummaryRun>,
}

impl Shape<'_> {
    /// Records into `enc` the copy of the read-back metric slots of a chunk of `n` poses, from
    /// `metrics` (slot-major) to `staging` (the slots one after the other). It is one copy when
    /// every slot is read back, else one a slot.
    pub(super) fn copy_slots(
        &self,
        enc: &mut wgpu::CommandEncoder,
        metrics: &wgpu::Buffer,
        staging: &wgpu::Buffer,
        n: usize,
    ) {
        let run = (n * 4) as u64;
        if self.slots == 0 {
            return;
        }
        if self.slots == ALL_SLOTS {
            enc.copy_buffer_to_buffer(metrics, 0, staging, 0, run * METRIC_STRIDE as u64);
            return;
        }
        let read = (0..METRIC_STRIDE).filter(|&s| self.slots & 1 << s != 0);
        for (j, s) in read.enumerate() {
            enc.copy_buffer_to_buffer(metrics, s as u64 * run, staging, j as u64 * run, run);
        }
    }

    /// Returns the bytes of the metric slots read back for `n` poses.
    pub(super) fn read_bytes(&self, n: usize) -> u64 {
        u64::from(self.slots.count_ones()) * (n * 4) as u64
    }

    /// Returns the bytes of bitsets and of metrics `n` poses use.
    pub(super) fn bytes(&self, n: usize) -> (u64, u64) {
        (
            n as u64 * self.bits_per_pose_bytes,
            (n * METRIC_STRIDE * 4) as u64,
        )
    }
}

/// The direction table uploaded for a chunk: which plans it holds, the buffer, and per plan the
/// offsets of its azimuth and elevation entries. An exact call's table holds the exact stage's
/// constants instead, and no plan.
pub(super) struct Directions {
    pub(super) plans: Vec<usize>,
    pub(super) buffer: wgpu::Buffer,
    pub(super) offsets: HashMap<usize, [u32; 2]>,
    /// A grid's plan of each range value (its entries' offsets in this table).
    pub(super) range_plans: Option<wgpu::Buffer>,
}

impl Directions {
    /// Returns the direction table of plans `used` of `source`, written into the pool's buffer,
    /// and, for a grid, the plan entries of each range value. Writes go in queue order, so a chunk
    /// in flight reads the table it was submitted with.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a plan's azimuths and elevations are bounded by the sample limit (u32)"
    )]
    pub(super) fn upload(
        ctx: &GpuContext,
        pool: &mut BufferPool,
        source: &Source<'_>,
        used: Vec<usize>,
        limit: u64,
    ) -> Directions {
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let plans = source.plans();
        // An exact call has no plans: the table holds the exact stage's constants.
        let (table, offsets) = match source.exact_half() {
            Some(half) => (exact_table(source.layout(), half), HashMap::new()),
            None => direction_table(plans, &used),
        };
        let bytes: &[u8] = bytemuck::cast_slice(&table);
        let buffer = pool.get(ctx.device(), "directions", bytes.len() as u64, limit, storage);
        ctx.queue().write_buffer(&buffer, 0, bytes);
        // A grid's poses find their plan by their range value.
        let range_plans = match source {
            Source::Items(_) | Source::Pairs { .. } => None,
            Source::Grid { prepared, .. } => {
                let entries: Vec<[u32; 4]> = prepared
                    .plan_of_range
                    .iter()
                    .map(|&p| {
                        let p = p as usize;
                        offsets.get(&p).map_or([0; 4], |&[az, el]| {
                            [
                                az,
                                plans[p].azimuths.len() as u32,
                                el,
                                plans[p].elevations.len() as u32,
                            ]
                        })
                    })
                    .collect();
                let bytes: &[u8] = bytemuck::cast_slice(&entries);
                let buffer = pool.get(ctx.device(), "range_plans", bytes.len() as u64, limit, storage);
                ctx.queue().write_buffer(&buffer, 0, bytes);
                Some(buffer)
            }
        };
        Directions {
            plans: used,
            buffer,
            offsets,
            range_plans,
        }
    }
}
