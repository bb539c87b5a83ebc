//! The fast CPU path: the GPU's algorithm (`shaders/splat.wgsl`, `shaders/reduce.wgsl`) in f64 on
//! every core (rayon), so a machine without a GPU is still fast. Unit directions are computed once
//! per plan. A sample costs `M u + t` and trigonometry-free clip and bin decisions. Only the
//! samples that may be an azimuth extreme take a libm `atan2`. The reference stays the checker:
//! `tests/agreement.rs` holds this path to the same envelope as the GPU.
//!
//! What makes it fast changes no result. A unit test holds it to the plain sample-by-sample loop,
//! bit for bit, in every build the processor runs.
//!
//! - **Blocks that cannot be seen are skipped.** A plan's samples are cut into blocks of 16
//!   consecutive samples, each held in a ball and near a chord (computed once per plan). The pose
//!   maps a ball (centre `c`, radius `ρ`) to the ball `M c + t` of radius `range · ρ`, since a
//!   rotation keeps distances. A block whose ball, or whose widened chord, lies wholly outside
//!   sonar 2's field of view by more than a slack far above every rounding is not visited. A block
//!   wholly inside skips the clip tests. Eight blocks' balls are tested together.
//!   `projection::culling` shows why every skipped sample is one the per-sample test would have
//!   rejected.
//! - **One lane stage.** A visited block is transformed, clipped and binned over its lanes in
//!   structure-of-arrays form, branch-free, in the same IEEE operations as the scalar code. The
//!   range bin comes from a guess and the squared edges around it. The beam comes from an azimuth
//!   guessed by a polynomial `atan2` (within 1e-11 rad). The guess is kept only when it lies
//!   farther from the beam's edges than that error; otherwise the edge tests decide, as the plain
//!   loop does. The whole pose loop is built for baseline x86-64, AVX2 and AVX-512, and the widest
//!   the processor runs is chosen at run time. The binary itself targets baseline x86-64.
//! - **Sidescan bins by runs.** When sonar 2 is a sidescan and the moved plan is sampled finer than
//!   its bins (as automatic sampling always is), a run of consecutive visible samples covers
//!   exactly the bins between its nearest and farthest sample (`Scratch::draw_runs` shows why). A
//!   pose whose visible samples form one run (an arc crossing the sheet once) takes no range bin
//!   per sample. Only this path does this. The splat shader bins every visible sample, which costs
//!   the GPU little of the fls→sss row, whose time goes per pose (BENCHMARKS.md).
//! - **Few `atan2`.** An exact `atan2` is taken only for the samples whose azimuth key (the guessed
//!   azimuth, or `y / x` for a sidescan) lies within its error of the pose's extremes.
//! - **Occupancy is reused and counted sparsely.** Each thread keeps one occupancy buffer and a
//!   one-bit-per-word summary of it. Counting, the area sum (in row-major order, as the plain loop
//!   sums it) and clearing visit the touched words only.
//!
//! The decisions are [`crate::clip`]'s, and the culling geometry is `projection::culling`'s. The
//! modules: the per-plan tables (`tables`), the lane stage (`lanes`), drawing a pose (`pose`), the
//! reduce stage and a thread's state (`scratch`), and the choice of instruction set (`isa`).

mod isa;
mod lanes;
mod pose;
mod scratch;
mod tables;
#[cfg(test)]
mod tests;

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::clip::{Clip, cull_slack};
use crate::geometry::sonar::SonarKind;
use crate::metrics::{Extremes, Metrics};
use crate::occupancy::Layout;
use crate::projection::columns::{MetricColumns, MetricSlices};
use crate::projection::pairs::PreparedPairs;
use crate::projection::poses::{GridTables, PreparedGrid};
use crate::projection::{Output, PreparedBatch, Projection};
use crate::sampling::SamplingPlan;
use crate::stream::Stop;
use isa::Isa;
use scratch::Scratch;
use tables::Directions;

/// Samples per block of this path (two AVX-512 vectors, four AVX2 ones).
const LANES: usize = 16;

/// Blocks whose balls are tested together.
const BALLS: usize = 8;

/// The arguments of [`Scratch::draw_pose`]: `(M, t, range, slack)`.
type PoseArgs = (DMat3, DVec3, f64, f64);

/// Sonar 2 as the fast path draws into it: the trigonometry-free decisions ([`Clip`], which this
/// dereferences to), and what the lane stage and the reduce stage add to them.
struct Geometry<'a> {
    clip: Clip<'a>,
    /// Half of each beam's width `Δa_j / 2`, and each row's `r_{i+1}² − r_i²`. Their product is
    /// [`Layout::pixel_measure`], bit for bit.
    half_beam_widths: Vec<f64>,
    row_areas: Vec<f64>,
    /// The lane stage's beam guess `(az − e_0) · inv_beam_width` (uniform beams only): `e_0`, and
    /// the distance (in beams) from a beam edge below which a guess is not trusted.
    guess_origin: f64,
    guess_slack: f64,
    /// The projection-area grid as the lane stage reads it (an FLS target).
    cells: Option<CellGrid>,
}

/// The projection-area grid for the lane stage: [`crate::occupancy::AreaGrid`]'s corner and cell,
/// its largest indices as floats (for the clamp), and its row length.
#[derive(Clone, Copy)]
struct CellGrid {
    x0: f64,
    y0: f64,
    cell: f64,
    last_i: f64,
    last_j: f64,
    ny: i32,
}

impl<'a> Geometry<'a> {
    fn new(layout: &'a Layout) -> Self {
        let clip = Clip::new(layout);
        let guess_slack = lanes::guess_slack(layout.beams(), clip.inv_beam_width);
        Geometry {
            clip,
            half_beam_widths: layout
                .beam_edges
                .windows(2)
                .map(|e| (e[1] - e[0]) / 2.0)
                .collect(),
            row_areas: (0..layout.range_bins)
                .map(|i| {
                    let (r0, r1) = (layout.range_edge(i), layout.range_edge(i + 1));
                    r1 * r1 - r0 * r0
                })
                .collect(),
            guess_origin: layout.beam_edges[0],
            guess_slack,
            #[expect(
                clippy::cast_precision_loss,
                clippy::cast_possible_truncation,
                clippy::cast_possible_wrap,
                reason = "cell counts below MAX_AREA_CELLS (2^26)"
            )]
            cells: layout.area_grid.map(|g| CellGrid {
                x0: g.x0,
                y0: g.y0,
                cell: g.cell,
                last_i: (g.nx - 1) as f64,
                last_j: (g.ny - 1) as f64,
                ny: g.ny as i32,
            }),
        }
    }
}

impl<'a> std::ops::Deref for Geometry<'a> {
    type Target = Clip<'a>;

    #[inline(always)]
    fn deref(&self) -> &Clip<'a> {
        &self.clip
    }
}

/// Returns the projections of every item of `prepared`, on all cores. With
/// [`Output::WithOccupancy`] each carries its occupancy buffer.
#[must_use]
pub fn project(prepared: &PreparedBatch<'_>, output: Output) -> Vec<Projection> {
    project_with(prepared, Keep::all(output), Isa::detect())
}

/// Returns [`project`]'s projections, or `None` once `stop` is set. It is asked before each pose
/// and each tile of a large sampling.
#[must_use]
pub fn project_until(
    prepared: &PreparedBatch<'_>,
    output: Output,
    stop: Stop<'_>,
) -> Option<Vec<Projection>> {
    project_tiled_batch(prepared, Keep::all(output), Isa::detect(), TILE_SAMPLES, stop)
}

/// The most samples whose tables (about 60 bytes a sample) are built at once. A plan with more is
/// drawn in tiles of this many consecutive samples, its poses a few at a time. So one pose of the
/// largest plan (2^26 samples) peaks near 100 MB, not 5 GB: 95 MB measured with glibc's allocator,
/// 121 MB with the command line's mimalloc.
pub(crate) const TILE_SAMPLES: usize = 1 << 20;

/// Returns [`project`]'s projections, with the lane stage built for `isa`. Tests run every build.
fn project_with(prepared: &PreparedBatch<'_>, keep: Keep, isa: Isa) -> Vec<Projection> {
    project_tiled_batch(prepared, keep, isa, TILE_SAMPLES, Stop::NEVER).expect("never stopped")
}

/// What a projection keeps besides the visible count and the ranges' extremes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Keep {
    /// Each pose's occupancy buffer (and cells), returned with its metrics.
    occupancy: bool,
    /// The azimuths' extremes. Their exact `atan2`s take a tenth of a sidescan sweep's time, for
    /// nothing when no one reads them.
    azimuths: bool,
}

impl Keep {
    /// Returns what a batch keeps: every metric, and the occupancy when `output` asks for it.
    fn all(output: Output) -> Self {
        Keep {
            occupancy: output == Output::WithOccupancy,
            azimuths: true,
        }
    }
}

/// The poses a projection draws, whatever their source: how many, each one's plan, and each one's
/// arguments. The arguments are built from a batch item, or decoded from a grid's index.
trait PoseTable: Sync {
    fn count(&self) -> usize;
    fn plan_index(&self, n: usize) -> usize;
    /// Returns the arguments of pose `n`: `M = R · Rz(base azimuth) · range`, `t`, the range and
    /// the culling slack.
    fn pose_args(&self, scratch: &mut Scratch, layout: &Layout, n: usize) -> PoseArgs;
}

impl PoseTable for PreparedBatch<'_> {
    fn count(&self) -> usize {
        self.batch.items.len()
    }

    fn plan_index(&self, n: usize) -> usize {
        PreparedBatch::plan_index(self, n)
    }

    fn pose_args(&self, scratch: &mut Scratch, layout: &Layout, n: usize) -> PoseArgs {
        let item = &self.batch.items[n];
        let range = item.measurement.range;
        let m = item.pose.rotation * scratch.rotation_z(self.base_azimuth(n)) * range;
        let t = item.pose.translation;
        (m, t, range, cull_slack(range, t, layout))
    }
}

/// Poses `first..first + count` of a grid, decoded from their index.
struct GridPoses<'a> {
    tables: GridTables<'a>,
    first: u64,
    count: usize,
    /// The plan of each value of the feature's range axis.
    plan_of_range: &'a [u32],
}

impl PoseTable for GridPoses<'_> {
    fn count(&self) -> usize {
        self.count
    }

    fn plan_index(&self, n: usize) -> usize {
        let range = self.tables.range_index(self.first + n as u64);
        self.plan_of_range[range] as usize
    }

    #[inline]
    fn pose_args(&self, _: &mut Scratch, layout: &Layout, n: usize) -> PoseArgs {
        let d = self.tables.decode(self.first + n as u64);
        let m = d.rotation * d.base * d.range;
        let t = d.translation;
        (m, t, d.range, cull_slack(d.range, t, layout))
    }
}

/// Where a projection's results go: a block of consecutive poses' slots.
trait Slots: Send {
    /// Stores pose `k` of the block.
    fn put(&mut self, k: usize, p: Projection);
}

impl Slots for &mut [Option<Projection>] {
    fn put(&mut self, k: usize, p: Projection) {
        self[k] = Some(p);
    }
}

impl Slots for MetricSlices<'_> {
    fn put(&mut self, k: usize, p: Projection) {
        self.set(k, &p.metrics);
    }
}

/// Poses a thread takes at a time.
const POSE_BLOCK: usize = 256;

/// Writes the metric columns of poses `range` of `grid` (prepared by [`PreparedGrid`]) into `out`,
/// on all cores. Its rows are replaced and its memory kept. Returns `None` once `stop` is set,
/// which is asked before each pose and each tile of a large sampling.
pub(crate) fn project_grid(
    prepared: &PreparedGrid<'_>,
    range: std::ops::Range<u64>,
    out: &mut MetricColumns,
    stop: Stop<'_>,
) -> Option<()> {
    let count = usize::try_from(range.end - range.start).expect("a block of poses in memory");
    let poses = GridPoses {
        tables: GridTables::new(prepared.grid, &prepared.source),
        first: range.start,
        count,
        plan_of_range: &prepared.plan_of_range,
    };
    project_into(&poses, &prepared.plans, &prepared.layout, out, stop)
}

/// Pairs `first..first + count` of prepared pairs, their poses composed from the tables.
struct PairPoses<'a> {
    prepared: &'a PreparedPairs<'a>,
    first: usize,
    count: usize,
}

impl PoseTable for PairPoses<'_> {
    fn count(&self) -> usize {
        self.count
    }

    fn plan_index(&self, n: usize) -> usize {
        self.prepared.pose(self.first + n).3
    }

    /// The composition of [`PreparedBatch`]'s, so a pair's pose is its item's bit for bit.
    #[inline]
    fn pose_args(&self, scratch: &mut Scratch, layout: &Layout, n: usize) -> PoseArgs {
        let (pose, range, base, _) = self.prepared.pose(self.first + n);
        let m = pose.rotation * scratch.rotation_z(base) * range;
        let t = pose.translation;
        (m, t, range, cull_slack(range, t, layout))
    }
}

/// Writes the metric columns of pairs `range` (prepared by [`PreparedPairs`]) into `out`, as
/// [`project_grid`] does for a grid.
pub(crate) fn project_pairs(
    prepared: &PreparedPairs<'_>,
    range: std::ops::Range<u64>,
    out: &mut MetricColumns,
    stop: Stop<'_>,
) -> Option<()> {
    debug_assert!(!prepared.exact, "pairs prepared for the exact solver");
    let first = usize::try_from(range.start).expect("pairs are in memory");
    let count = usize::try_from(range.end - range.start).expect("pairs are in memory");
    let poses = PairPoses {
        prepared,
        first,
        count,
    };
    project_into(&poses, &prepared.plans, &prepared.layout, out, stop)
}

/// Writes the metric columns of `poses` into `out` on all cores, its rows replaced.
fn project_into<T: PoseTable>(
    poses: &T,
    plans: &[SamplingPlan],
    layout: &Layout,
    out: &mut MetricColumns,
    stop: Stop<'_>,
) -> Option<()> {
    let count = poses.count();
    out.resize(count);
    let keep = Keep {
        occupancy: false,
        azimuths: out.keeps(crate::Metric::AzimuthMin) || out.keeps(crate::Metric::AzimuthMax),
    };
    let blocks = out.slices(0..count).chunks(POSE_BLOCK);
    let large = project_tiled(
        poses,
        plans,
        layout,
        blocks,
        keep,
        Isa::detect(),
        TILE_SAMPLES,
        stop,
    )?;
    let mut all = out.slices(0..count);
    for (n, p) in large {
        all.set(n, &p.metrics);
    }
    Some(())
}

/// Draws one pose, or one tile of it, into `scratch`. A sidescan's one beam is drawn by runs of
/// range bins. Beams (an FLS, or a two-sided sidescan's two sides) are drawn sample by sample. The
/// azimuths' extremes are left out unless `keep` asks for them.
fn draw(
    isa: Isa,
    scratch: &mut Scratch,
    geo: &Geometry<'_>,
    dirs: &Directions,
    pose: PoseArgs,
    keep: Keep,
) -> (u64, Extremes) {
    if geo.layout.beams() > 1 || geo.layout.kind == SonarKind::Fls {
        isa::draw_pose::<true>(isa, scratch, geo, dirs, pose, keep.azimuths)
    } else {
        isa::draw_pose::<false>(isa, scratch, geo, dirs, pose, keep.azimuths)
    }
}

/// Returns the projection of what `scratch` holds: `visible` of `total` samples, `extremes`.
fn reduced(
    geo: &Geometry<'_>,
    scratch: &mut Scratch,
    keep: bool,
    visible: u64,
    total: u64,
    extremes: Extremes,
) -> Projection {
    let (occupied, measure, occupancy) = scratch.reduce(geo, keep);
    let (area, cells) = scratch.reduce_cells(geo, keep);
    Projection {
        local: Default::default(),
        metrics: Metrics::new(visible, total, extremes, (occupied, measure), area),
        occupancy: occupancy.map(|o| geo.layout.to_data_order(o)),
        cells,
    }
}

/// Returns [`project_with`]'s projections with tiles of `tile` samples (tests make them small), or
/// `None` once `stop` is set.
fn project_tiled_batch(
    prepared: &PreparedBatch<'_>,
    keep: Keep,
    isa: Isa,
    tile: usize,
    stop: Stop<'_>,
) -> Option<Vec<Projection>> {
    let mut out: Vec<Option<Projection>> = vec![None; prepared.count()];
    let blocks: Vec<&mut [Option<Projection>]> = out.chunks_mut(POSE_BLOCK).collect();
    let large = project_tiled(
        prepared,
        &prepared.plans,
        &prepared.layout,
        blocks,
        keep,
        isa,
        tile,
        stop,
    )?;
    for (n, p) in large {
        out[n] = Some(p);
    }
    Some(out.into_iter().map(|p| p.expect("every item drawn")).collect())
}

/// Draws every pose of `poses` into `blocks` (consecutive blocks of [`POSE_BLOCK`] poses), each on
/// one thread. Poses whose plan has more than `tile` samples are drawn tile by tile, and their
/// projections returned. Returns `None` once `stop` is set.
#[expect(clippy::too_many_arguments, reason = "the parts of one projection, named")]
fn project_tiled<T: PoseTable, S: Slots>(
    poses: &T,
    plans: &[SamplingPlan],
    layout: &Layout,
    blocks: Vec<S>,
    keep: Keep,
    isa: Isa,
    tile: usize,
    stop: Stop<'_>,
) -> Option<Vec<(usize, Projection)>> {
    let stopped = std::sync::atomic::AtomicBool::new(false);
    let halt = || {
        let now = stopped.load(std::sync::atomic::Ordering::Relaxed) || stop.is_set();
        if now {
            stopped.store(true, std::sync::atomic::Ordering::Relaxed);
        }
        now
    };
    let geo = Geometry::new(layout);
    let samples = |p: usize| plans[p].azimuths.len() * plans[p].elevations.len();
    // Plans up to a tile: tables built once, shared by their poses, each pose on one thread.
    let directions: Vec<Option<Directions>> = (0..plans.len())
        .map(|p| {
            let plan = &plans[p];
            (samples(p) <= tile).then(|| Directions::of(&plan.azimuths, &plan.elevations))
        })
        .collect();
    let tiled: Vec<Vec<usize>> = blocks
        .into_par_iter()
        .enumerate()
        .map_init(
            || Scratch::new(layout),
            |scratch, (b, mut slots)| {
                let mut tiled = Vec::new();
                let first = b * POSE_BLOCK;
                for n in first..(first + POSE_BLOCK).min(poses.count()) {
                    let Some(dirs) = directions[poses.plan_index(n)].as_ref() else {
                        tiled.push(n);
                        continue;
                    };
                    if halt() {
                        return tiled;
                    }
                    let pose = poses.pose_args(scratch, layout, n);
                    let (visible, extremes) = draw(isa, scratch, &geo, dirs, pose, keep);
                    slots.put(
                        n - first,
                        reduced(
                            &geo,
                            scratch,
                            keep.occupancy,
                            visible,
                            dirs.units.len() as u64,
                            extremes,
                        ),
                    );
                }
                tiled
            },
        )
        .collect();
    // Larger plans go tile by tile. Each tile's tables are built once for a group of poses drawn on
    // all cores. Every pose keeps its own buffers and running sums until its last tile.
    if halt() {
        return None;
    }
    let tiled: Vec<usize> = tiled.concat();
    let mut out = Vec::with_capacity(tiled.len());
    let group = rayon::current_num_threads().max(1);
    let mut states: Vec<(Scratch, u64, Extremes)> = Vec::new();
    for same_plan in tiled.chunk_by(|&a, &b| poses.plan_index(a) == poses.plan_index(b)) {
        let plan = &plans[poses.plan_index(same_plan[0])];
        let total = samples(poses.plan_index(same_plan[0]));
        for items in same_plan.chunks(group) {
            states.resize_with(states.len().max(items.len()), || {
                (Scratch::new(layout), 0, Extremes::default())
            });
            let args: Vec<PoseArgs> = items
                .iter()
                .zip(&mut states)
                .map(|(&n, (scratch, visible, extremes))| {
                    (*visible, *extremes) = (0, Extremes::default());
                    poses.pose_args(scratch, layout, n)
                })
                .collect();
            for start in (0..total).step_by(tile) {
                if halt() {
                    return None;
                }
                let dirs = Directions::of_samples(
                    &plan.azimuths,
                    &plan.elevations,
                    start..(start + tile).min(total),
                );
                states[..items.len()].par_iter_mut().zip(&args).for_each(
                    |((scratch, visible, extremes), &pose)| {
                        let (v, e) = draw(isa, scratch, &geo, &dirs, pose, keep);
                        scratch.settle_span();
                        *visible += v;
                        extremes.merge(&e);
                    },
                );
            }
            for (&n, (scratch, visible, extremes)) in items.iter().zip(&mut states) {
                out.push((
                    n,
                    reduced(&geo, scratch, keep.occupancy, *visible, total as u64, *extremes),
                ));
            }
        }
    }
    Some(out)
}
