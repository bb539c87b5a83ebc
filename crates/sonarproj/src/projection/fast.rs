//! The fast CPU path: the GPU's algorithm (`shaders/splat.wgsl`, `shaders/reduce.wgsl`) in f64
//! on every core (rayon), so a machine without a GPU is still fast. Unit directions are computed
//! once per plan, a sample costs `M u + t` and trigonometry-free clip and bin decisions; only
//! visible samples take a square root and an `atan2`. The reference stays the checker:
//! `tests/agreement.rs` holds this path to the same envelope as the GPU.
//!
//! What makes it fast changes no result (a unit test holds it to the plain sample-by-sample
//! loop, bit for bit):
//!
//! - **Blocks that cannot be seen are skipped.** A plan's samples are cut into blocks of
//!   [`BLOCK`] consecutive samples; each block's unit directions lie in a ball (centre `c`,
//!   radius `ρ`, computed once per plan). The pose maps it to the ball `M c + t`, radius
//!   `range · ρ` (a rotation keeps distances), and a block whose ball lies wholly outside sonar 2's
//!   field of view, by more than a slack far above every rounding, is not visited: each clip
//!   bound is a 1-Lipschitz function of the point (range; the azimuth half-planes; the elevation
//!   cone's `|z| cos e − ρ sin e`), so its value at the centre less the radius bounds it over the
//!   ball. Every skipped sample is one the per-sample test would have rejected; a block wholly
//!   inside skips the clip tests.
//! - **Lanes.** A visited block is transformed and clipped over its lanes in structure-of-arrays
//!   form, branch-free, in the same IEEE operations as the scalar code; an AVX2 build of that loop
//!   is chosen at run time.
//! - **Few `atan2`.** Beams are found by walking from the previous sample's beam; an exact
//!   `atan2` is taken only for the samples that may be an azimuth extreme of the pose.
//! - **Occupancy is reused and counted sparsely.** Each thread keeps one occupancy buffer and a
//!   one-bit-per-word summary of it; counting, the area sum (in row-major order, as the plain loop
//!   sums it) and clearing visit the touched words only.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::geometry::sonar::SonarKind;
use crate::metrics::{Extremes, Metrics};
use crate::occupancy::{Layout, Occupancy};
use crate::projection::{Output, PreparedBatch, Projection};

/// Samples per culling block (consecutive in the plan's order, azimuth index fastest).
pub const BLOCK: usize = 16;

/// Most beam edges walked from the previous sample's beam before an `atan2` guess is taken.
const WALK: usize = 4;

/// Relative tolerance on the azimuth key `y / x`: samples whose key lies within it of the pose's
/// smallest (largest) key get an exact `atan2` for the azimuth extremes; the others' azimuths are
/// larger (smaller) by far more than `atan2`'s rounding, so they cannot be an extreme.
const KEY_TOLERANCE: f64 = 1e-12;

/// Relative slack added to every culling radius: the roundings of `M u + t` and of the clip tests
/// are below 1e-15 of `range + |t| + range_max`; a block is culled only when it clears a bound by
/// a million times that.
const CULL_SLACK: f64 = 1e-9;

/// Sonar 2's field of view and layout as the decisions use them (the f64 twin of the GPU's
/// `TargetParams`).
struct Geometry<'a> {
    layout: &'a Layout,
    range_min_sq: f64,
    range_max_sq: f64,
    sin_half_az: f64,
    cos_half_az: f64,
    clip_elevation: bool,
    sin2_half_el: f64,
    cos2_half_el: f64,
    /// `(sin e, cos e)` of the half elevation aperture, for the culling cone.
    sin_cos_half_el: (f64, f64),
    /// `1 / Δ`: the range bin guess multiplies (the edge tests then settle it).
    inv_range_bin: f64,
    /// `(range_min + iΔ)²`, `i = 0..=range_bins`.
    range_edges_sq: Vec<f64>,
    /// Half of each beam's width `Δa_j / 2` and each row's `r_{i+1}² − r_i²`: their product is
    /// [`Layout::pixel_measure`], bit for bit.
    half_beam_widths: Vec<f64>,
    row_areas: Vec<f64>,
    /// `(cos, sin)` of each beam edge.
    beam_edges_cs: Vec<(f64, f64)>,
    /// `beams / aperture` when the beams are uniform.
    inv_beam_width: Option<f64>,
}

impl<'a> Geometry<'a> {
    fn new(layout: &'a Layout) -> Self {
        let (sin_half_az, cos_half_az) = layout.azimuth_clip();
        let elevation = layout.elevation_clip();
        Geometry {
            layout,
            range_min_sq: layout.range_min * layout.range_min,
            range_max_sq: layout.range_max * layout.range_max,
            sin_half_az,
            cos_half_az,
            clip_elevation: elevation.is_some(),
            sin2_half_el: elevation.map_or(1.0, |e| e.0),
            cos2_half_el: elevation.map_or(0.0, |e| e.1),
            sin_cos_half_el: (layout.half_elevation.sin(), layout.half_elevation.cos()),
            inv_range_bin: 1.0 / layout.range_bin_width,
            range_edges_sq: layout.range_edges_sq(),
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
            beam_edges_cs: layout.beam_edges.iter().map(|a| (a.cos(), a.sin())).collect(),
            inv_beam_width: layout.uniform_beam_width().map(|w| 1.0 / w),
        }
    }

    /// Returns whether `p` (squared range `r2`) is in view: the splat shader's `in_view`.
    /// Every test is evaluated (`&`, not `&&`): no branch to mispredict per sample.
    fn in_view(&self, p: DVec3, r2: f64) -> bool {
        (r2 > 0.0)
            & (r2 >= self.range_min_sq)
            & (r2 <= self.range_max_sq)
            & (p.x * self.sin_half_az >= p.y.abs() * self.cos_half_az)
            & (!self.clip_elevation
                | ((p.x * p.x + p.y * p.y) * self.sin2_half_el >= p.z * p.z * self.cos2_half_el))
    }

    /// Returns where the ball of `radius` around `c` lies: wholly outside the field of view,
    /// wholly inside it, or across a bound. Each clip bound is a 1-Lipschitz function of the
    /// point (the range; the azimuth half-planes' signed distances; the elevation cone's
    /// `|z| cos e − ρ sin e`, as `p ↦ (|z|, ρ)` is 1-Lipschitz), so its value at `c` moves by at
    /// most `radius` over the ball. The splat shader's `block_side`.
    fn ball_side(&self, c: DVec3, radius: f64) -> Side {
        let l = self.layout;
        let d = c.length();
        // Azimuth: the wedge is {x sin h − y cos h ≥ 0} ∩ {x sin h + y cos h ≥ 0} for h ≤ 90°,
        // their union beyond; both normals are unit vectors.
        let upper = c.x * self.sin_half_az - c.y * self.cos_half_az;
        let lower = c.x * self.sin_half_az + c.y * self.cos_half_az;
        let (az_out, az_in) = if self.cos_half_az >= 0.0 {
            (upper.min(lower) < -radius, upper.min(lower) > radius)
        } else {
            (upper.max(lower) < -radius, upper.max(lower) > radius)
        };
        // Elevation: |z| cos e − ρ sin e > 0 outside.
        let (s, co) = self.sin_cos_half_el;
        let cone = c.z.abs() * co - (c.x * c.x + c.y * c.y).sqrt() * s;
        let (el_out, el_in) = if self.clip_elevation {
            (cone > radius, cone < -radius)
        } else {
            (false, true)
        };
        if d - radius > l.range_max || d + radius < l.range_min || az_out || el_out {
            Side::Outside
        } else if d - radius > 0.0 && d - radius > l.range_min && d + radius < l.range_max && az_in && el_in {
            Side::Inside
        } else {
            Side::Across
        }
    }

    /// Returns the range bin: a first guess, then the side of the guessed bin's squared edges.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a saturating float-to-index conversion, clamped to the table right after"
    )]
    fn range_bin(&self, r: f64, r2: f64) -> usize {
        let l = self.layout;
        let last = l.range_bins - 1;
        // `as` truncates toward zero, which is `floor` for the non-negative values `max` leaves
        // (and takes no libm call on baseline x86-64).
        let mut i = (((r - l.range_min) * self.inv_range_bin).max(0.0) as usize).min(last);
        if i > 0 && r2 < self.range_edges_sq[i] {
            i -= 1;
        } else if i < last && r2 >= self.range_edges_sq[i + 1] {
            i += 1;
        }
        i
    }

    /// Returns whether `p` lies at or above (counter-clockwise of) beam edge `k`:
    /// `sin(az − e) · ρ = y cos e − x sin e ≥ 0`, valid within a quarter turn of the edge.
    fn at_or_above(&self, p: DVec3, k: usize) -> bool {
        let (c, s) = self.beam_edges_cs[k];
        p.y * c - p.x * s >= 0.0
    }

    /// Returns the beam of `p` at azimuth `az`: a first guess, then the side of the guessed
    /// beam's edges.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a saturating float-to-index conversion, clamped to the table right after"
    )]
    fn beam(&self, p: DVec3, az: f64) -> usize {
        let beams = self.layout.beams();
        if beams == 1 {
            return 0;
        }
        let guess = match self.inv_beam_width {
            Some(inv) => ((az + self.layout.half_azimuth) * inv).max(0.0) as usize,
            None => self
                .layout
                .beam_edges
                .partition_point(|&e| e <= az)
                .saturating_sub(1),
        };
        let mut j = guess.min(beams - 1);
        if j > 0 && !self.at_or_above(p, j) {
            j -= 1;
        } else if j < beams - 1 && self.at_or_above(p, j + 1) {
            j += 1;
        }
        j
    }

    /// Returns the beam of `p` found by walking at most [`WALK`] edges from beam `from` (the
    /// previous sample's), or `None` when it lies farther. The edge tests are those of
    /// [`Geometry::beam`], so both give the same beam. The side test `sin(az − e) ≥ 0` is right
    /// only within half a turn of the edge, which every edge is when the aperture is at most 180°;
    /// wider sonars (an edge may lie behind the point) always take `None`.
    fn beam_near(&self, p: DVec3, from: usize) -> Option<usize> {
        if self.layout.half_azimuth > std::f64::consts::FRAC_PI_2 {
            return None;
        }
        let last = self.layout.beams() - 1;
        let mut j = from.min(last);
        for _ in 0..WALK {
            if j > 0 && !self.at_or_above(p, j) {
                j -= 1;
            } else if j < last && self.at_or_above(p, j + 1) {
                j += 1;
            } else {
                return Some(j);
            }
        }
        None
    }
}

/// Where a block's ball lies with respect to sonar 2's field of view.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    /// Wholly outside: no sample of the block is visible.
    Outside,
    /// Wholly inside: every sample of the block is visible.
    Inside,
    /// Across a bound: each sample is clipped.
    Across,
}

/// A visible sample of the pose being drawn: its point, squared range and azimuth key.
#[derive(Clone, Copy, Default)]
struct Seen {
    p: DVec3,
    r2: f64,
    key: f64,
}

/// Returns, per block of [`BLOCK`] consecutive samples of the plan with these azimuth offsets
/// and elevations (rad), the centre and radius of a ball holding the block's unit directions:
/// the culling balls of this path and of the splat shader.
#[must_use]
pub fn block_balls(azimuths: &[f64], elevations: &[f64]) -> Vec<(DVec3, f64)> {
    balls(&unit_directions(azimuths, elevations))
}

/// Returns the unit directions of the plan with these azimuth offsets and elevations (rad),
/// azimuth index fastest.
fn unit_directions(azimuths: &[f64], elevations: &[f64]) -> Vec<DVec3> {
    let azimuths: Vec<(f64, f64)> = azimuths.iter().map(|a| (a.cos(), a.sin())).collect();
    elevations
        .iter()
        .flat_map(|e| {
            let (ce, se) = (e.cos(), e.sin());
            azimuths
                .iter()
                .map(move |&(ca, sa)| DVec3::new(ce * ca, ce * sa, se))
        })
        .collect()
}

/// Returns, per block of [`BLOCK`] of `units`, the centre (their mean) and radius of a ball
/// holding them.
fn balls(units: &[DVec3]) -> Vec<(DVec3, f64)> {
    units
        .chunks(BLOCK)
        .map(|b| {
            let centre = b.iter().sum::<DVec3>() / b.len() as f64;
            let radius = b.iter().map(|u| (*u - centre).length()).fold(0.0, f64::max);
            (centre, radius)
        })
        .collect()
}

/// A plan's unit directions (azimuth index fastest) and, per block of [`BLOCK`] of them, the
/// centre and radius of a ball holding them.
struct Directions {
    units: Vec<DVec3>,
    blocks: Vec<(DVec3, f64)>,
    /// The same units block by block in structure-of-arrays form, for the clip loop.
    lanes: Vec<BlockUnits>,
}

/// The unit directions of one block, one array per coordinate; lanes past `len` repeat the last
/// unit and are never kept.
#[derive(Clone)]
struct BlockUnits {
    x: [f64; BLOCK],
    y: [f64; BLOCK],
    z: [f64; BLOCK],
    len: usize,
}

/// One block after the transform and clip: the points, squared ranges, azimuth keys and which
/// lanes are visible.
struct BlockPoints {
    x: [f64; BLOCK],
    y: [f64; BLOCK],
    z: [f64; BLOCK],
    r2: [f64; BLOCK],
    key: [f64; BLOCK],
    keep: [bool; BLOCK],
}

impl Default for BlockPoints {
    fn default() -> Self {
        let zero = [0.0; BLOCK];
        BlockPoints {
            x: zero,
            y: zero,
            z: zero,
            r2: zero,
            key: zero,
            keep: [false; BLOCK],
        }
    }
}

/// Transforms and clips the lanes of `u` into `out`: `p = M u + t` in the operation order of
/// glam's `DMat3 * DVec3` and `length_squared`, the clip of [`Geometry::in_view`] (skipped when
/// `inside`), the key `y / x` (NaN where `x ≤ 0`). Branch-free over the lanes, so it vectorises;
/// `m` is `M`'s columns then `t`.
#[inline(always)]
fn clip_lanes(geo: &Geometry<'_>, m: &[f64; 12], u: &BlockUnits, inside: bool, out: &mut BlockPoints) {
    for k in 0..BLOCK {
        let (ux, uy, uz) = (u.x[k], u.y[k], u.z[k]);
        let x = m[0] * ux + m[3] * uy + m[6] * uz + m[9];
        let y = m[1] * ux + m[4] * uy + m[7] * uz + m[10];
        let z = m[2] * ux + m[5] * uy + m[8] * uz + m[11];
        let r2 = x * x + y * y + z * z;
        out.x[k] = x;
        out.y[k] = y;
        out.z[k] = z;
        out.r2[k] = r2;
        let q = y / x;
        out.key[k] = if x > 0.0 { q } else { f64::NAN };
        out.keep[k] = inside | geo.in_view(DVec3::new(x, y, z), r2);
    }
}

/// [`clip_lanes`] compiled for AVX2 (four f64 lanes a vector): the same IEEE operations, so the
/// same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn clip_lanes_avx2(geo: &Geometry<'_>, m: &[f64; 12], u: &BlockUnits, inside: bool, out: &mut BlockPoints) {
    clip_lanes(geo, m, u, inside, out);
}

/// Runs [`clip_lanes`], in its AVX2 build where the processor has AVX2 (`avx2` says so).
fn clip_block(
    geo: &Geometry<'_>,
    m: &[f64; 12],
    u: &BlockUnits,
    inside: bool,
    out: &mut BlockPoints,
    avx2: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` is `is_x86_feature_detected!("avx2")`, so the processor runs AVX2.
        unsafe { clip_lanes_avx2(geo, m, u, inside, out) };
        return;
    }
    let _ = avx2;
    clip_lanes(geo, m, u, inside, out);
}

impl Directions {
    fn of(azimuths: &[f64], elevations: &[f64]) -> Self {
        let units = unit_directions(azimuths, elevations);
        let blocks = balls(&units);
        let lanes = units
            .chunks(BLOCK)
            .map(|b| {
                let at = |k: usize| b[k.min(b.len() - 1)];
                BlockUnits {
                    x: std::array::from_fn(|k| at(k).x),
                    y: std::array::from_fn(|k| at(k).y),
                    z: std::array::from_fn(|k| at(k).z),
                    len: b.len(),
                }
            })
            .collect();
        Directions { units, blocks, lanes }
    }
}

/// One thread's occupancy buffer and a summary of it: one bit per occupancy word, set when the
/// word is, so that counting, summing and clearing visit the touched words only, in row-major
/// order, without sorting.
struct Scratch {
    occ: Occupancy,
    summary: Vec<u64>,
    /// The visible samples of the pose being drawn.
    seen: Vec<Seen>,
    /// The block being clipped.
    points: Box<BlockPoints>,
}

impl Scratch {
    fn new(layout: &Layout) -> Self {
        let occ = Occupancy::new(layout.range_bins, layout.beams());
        let summary = vec![0; occ.words.len().div_ceil(64)];
        Scratch {
            occ,
            summary,
            seen: Vec::new(),
            points: Box::default(),
        }
    }

    /// Returns `(occupied, occupied_measure)` (the reduce shader's work, over the touched words
    /// in row-major order, so the area sums in the order of the plain loop) and the occupancy
    /// when asked for, leaving the buffer empty.
    fn reduce(&mut self, geo: &Geometry<'_>, keep: bool) -> (u64, f64, Option<Occupancy>) {
        let layout = geo.layout;
        let beams = layout.beams();
        let kept = keep.then(|| self.occ.clone());
        let (mut occupied, mut area) = (0, 0.0);
        for (s, summary) in self.summary.iter_mut().enumerate() {
            let mut touched = std::mem::take(summary);
            while touched != 0 {
                let w = 64 * s + touched.trailing_zeros() as usize;
                touched &= touched - 1;
                let mut bits = std::mem::take(&mut self.occ.words[w]);
                occupied += u64::from(bits.count_ones());
                if layout.kind == SonarKind::Fls {
                    // One division per word: pixels follow each other along the rows.
                    let k0 = 32 * w;
                    let (mut i, mut row_start) = (k0 / beams, k0 / beams * beams);
                    while bits != 0 {
                        let k = k0 + bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        while k >= row_start + beams {
                            i += 1;
                            row_start += beams;
                        }
                        area += geo.half_beam_widths[k - row_start] * geo.row_areas[i];
                    }
                }
            }
        }
        let measure = match layout.kind {
            SonarKind::Sss => occupied as f64 * layout.range_bin_width,
            SonarKind::Fls => area,
        };
        (occupied, measure, kept)
    }
}

/// Sets pixel `(i, j)` of `occ`, marking its word in `summary`.
fn set(occ: &mut Occupancy, summary: &mut [u64], i: usize, j: usize) {
    let k = i * occ.beams + j;
    let w = k / 32;
    occ.words[w] |= 1 << (k % 32);
    summary[w / 64] |= 1 << (w % 64);
}

/// Returns the projections of every item of `prepared` on all cores; with
/// [`Output::WithOccupancy`] each carries its occupancy buffer.
#[must_use]
pub fn project(prepared: &PreparedBatch<'_>, output: Output) -> Vec<Projection> {
    project_with(prepared, output == Output::WithOccupancy, has_avx2())
}

/// Returns whether the processor runs AVX2 (detected at run time: the binary itself targets
/// baseline x86-64).
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    return false;
}

/// [`project`], with the AVX2 build of the clip loop or without it (tests run both).
fn project_with(prepared: &PreparedBatch<'_>, keep_occupancy: bool, avx2: bool) -> Vec<Projection> {
    let layout = &prepared.layout;
    let geo = Geometry::new(layout);
    let directions: Vec<Directions> = prepared
        .plans
        .iter()
        .map(|plan| Directions::of(&plan.azimuths, &plan.elevations))
        .collect();
    prepared
        .batch
        .items
        .par_iter()
        .enumerate()
        .map_init(
            || Scratch::new(layout),
            |scratch, (n, item)| {
                let dirs = &directions[prepared.plan_of[n]];
                let range = item.measurement.range;
                let m = item.pose.rotation * DMat3::from_rotation_z(prepared.base_azimuth[n]) * range;
                let t = item.pose.translation;
                let slack = CULL_SLACK * (range + t.length() + layout.range_max);
                // Pass 1, block by block: clip; keep the visible samples and their azimuth keys.
                let Scratch {
                    occ,
                    summary,
                    seen,
                    points,
                } = &mut *scratch;
                seen.clear();
                let (mut key_min, mut key_max) = (f64::INFINITY, f64::NEG_INFINITY);
                let columns = [m.x_axis, m.y_axis, m.z_axis, t].map(|c| c.to_array());
                let columns: [f64; 12] = std::array::from_fn(|k| columns[k / 3][k % 3]);
                for (units, &(centre, radius)) in dirs.lanes.iter().zip(&dirs.blocks) {
                    let side = geo.ball_side(m * centre + t, range * radius * (1.0 + 1e-12) + slack);
                    if side == Side::Outside {
                        continue;
                    }
                    clip_block(&geo, &columns, units, side == Side::Inside, points, avx2);
                    for k in 0..units.len {
                        if points.keep[k] {
                            // y / x orders azimuths in (−90°, 90°); elsewhere the key is NaN and
                            // the sample always gets an exact atan2.
                            let key = points.key[k];
                            key_min = key_min.min(key);
                            key_max = key_max.max(key);
                            let p = DVec3::new(points.x[k], points.y[k], points.z[k]);
                            seen.push(Seen {
                                p,
                                r2: points.r2[k],
                                key,
                            });
                        }
                    }
                }
                // Pass 2, in sample order: bins, range extremes, and exact azimuths for the
                // samples that may be an azimuth extreme (the fold then equals the fold over
                // every sample: the others are strictly inside).
                let low = key_min + KEY_TOLERANCE * key_min.abs();
                let high = key_max - KEY_TOLERANCE * key_max.abs();
                let mut extremes = Extremes::default();
                let mut beam = 0;
                for s in seen.iter() {
                    let r = s.r2.sqrt();
                    let exact = !(s.key > low && s.key < high);
                    let az = if exact { s.p.y.atan2(s.p.x) } else { f64::NAN };
                    beam = if geo.layout.beams() == 1 {
                        0
                    } else if exact {
                        geo.beam(s.p, az)
                    } else {
                        geo.beam_near(s.p, beam)
                            .unwrap_or_else(|| geo.beam(s.p, s.p.y.atan2(s.p.x)))
                    };
                    set(occ, summary, geo.range_bin(r, s.r2), beam);
                    extremes.add_range(r);
                    if exact {
                        extremes.add_azimuth(az);
                    }
                }
                let visible = seen.len() as u64;
                let (occupied, measure, occupancy) = scratch.reduce(&geo, keep_occupancy);
                Projection {
                    metrics: Metrics::new(visible, dirs.units.len() as u64, extremes, occupied, measure),
                    occupancy,
                }
            },
        )
        .collect()
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::geometry::pose::{RelativePose, Rotation};
    use crate::geometry::sonar::Sonar;
    use crate::projection::{Batch, BatchItem};
    use crate::sampling::{Measurement, Sampling};

    /// Returns the projections drawn sample by sample with every clip test: no culling, no
    /// walking beams, no sparse reduce, `atan2` for every visible sample. The fast path must give
    /// exactly these results.
    fn project_plainly(prepared: &PreparedBatch<'_>) -> Vec<(Metrics, Occupancy)> {
        let layout = &prepared.layout;
        let geo = Geometry::new(layout);
        prepared
            .batch
            .items
            .iter()
            .enumerate()
            .map(|(n, item)| {
                let plan = prepared.plan(n);
                let dirs = Directions::of(&plan.azimuths, &plan.elevations);
                let m = item.pose.rotation
                    * DMat3::from_rotation_z(prepared.base_azimuth[n])
                    * item.measurement.range;
                let mut occ = Occupancy::new(layout.range_bins, layout.beams());
                let (mut visible, mut extremes) = (0, Extremes::default());
                for u in &dirs.units {
                    let p = m * *u + item.pose.translation;
                    let r2 = p.length_squared();
                    if geo.in_view(p, r2) {
                        let (r, az) = (r2.sqrt(), p.y.atan2(p.x));
                        occ.set(geo.range_bin(r, r2), geo.beam(p, az));
                        visible += 1;
                        extremes.add(r, az);
                    }
                }
                let occupied = occ.count();
                let measure = match layout.kind {
                    SonarKind::Sss => occupied as f64 * layout.range_bin_width,
                    SonarKind::Fls => occ.pixels().map(|(i, j)| layout.pixel_measure(i, j)).sum(),
                };
                let metrics = Metrics::new(visible, dirs.units.len() as u64, extremes, occupied, measure);
                (metrics, occ)
            })
            .collect()
    }

    /// Culling, walking beams, exact `atan2` only for extreme candidates, the sparse reduce and
    /// the AVX2 build of the clip loop change no bit of any result: the fast path against the plain loop on random placements
    /// (features anywhere in sonar 1's view, placed anywhere in sonar 2's, random rotations)
    /// for every preset pair, in both sampling modes.
    #[test]
    fn culling_changes_no_result() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        // The presets, a sonar that sees everything (edges behind a point: 360° of beams) and
        // one with non-uniform beams.
        let mut sonars: Vec<Sonar> = Sonar::preset_names()
            .into_iter()
            .map(|n| Sonar::preset(n).unwrap())
            .collect();
        let omni = Sonar::from_toml_str(
            "omni",
            "kind = 'fls'\nrange_min = 0\nrange_max = 12\nazimuth_aperture = 360\n\
             elevation_aperture = 180\nrange_bins = 600\nbeams = 720\n",
        )
        .unwrap();
        let centres: Vec<String> = (0..64)
            .map(|k| {
                let u = -1.0 + 2.0 * (k as f64 + 0.5) / 64.0;
                format!("{}", 40.0 * (u + 0.3 * u * u * u) / 1.3)
            })
            .collect();
        let nonuniform = Sonar::from_toml_str(
            "nonuniform",
            &format!(
                "kind = 'fls'\nrange_min = 0.5\nrange_max = 20\nazimuth_aperture = 90\n\
                 elevation_aperture = 20\nrange_bins = 390\nbeam_centres = [{}]\n",
                centres.join(", ")
            ),
        )
        .unwrap();
        sonars.extend([omni, nonuniform]);
        for s1 in &sonars {
            for s2 in &sonars {
                let (from, to) = (&s1.name, &s2.name);
                let (s1, s2) = (s1.clone(), s2.clone());
                for sampling in [Sampling::Step(0.5), Sampling::Auto] {
                    let point = |s: &Sonar, rng: &mut ChaCha8Rng| {
                        let r = s.range_min + rng.random::<f64>() * (s.range_max - s.range_min);
                        let a = (rng.random::<f64>() - 0.5) * s.azimuth_aperture;
                        let e = (rng.random::<f64>() - 0.5) * s.elevation_aperture;
                        [r, a, e]
                    };
                    let items = (0..40)
                        .map(|_| {
                            let f = point(&s1, &mut rng);
                            let place = point(&s2, &mut rng);
                            let rot = Rotation::RollPitchYaw {
                                roll: rng.random::<f64>() * 360.0 - 180.0,
                                pitch: rng.random::<f64>() * 180.0 - 90.0,
                                yaw: rng.random::<f64>() * 360.0 - 180.0,
                            };
                            BatchItem {
                                measurement: Measurement::of(&s1, f[0], f[1]).unwrap(),
                                pose: RelativePose::placement(rot, f, place).unwrap(),
                            }
                        })
                        .collect();
                    let batch = Batch {
                        source: s1.clone(),
                        target: s2.clone(),
                        sampling,
                        items,
                    };
                    let prepared = batch.prepare().unwrap();
                    let plain = project_plainly(&prepared);
                    // Both builds of the clip loop (the AVX2 one only where the processor has it).
                    let fast = project_with(&prepared, true, false);
                    if has_avx2() {
                        assert_eq!(project_with(&prepared, true, true), fast, "{from} -> {to}: AVX2");
                    }
                    let mut seen = 0;
                    for (k, (f, (metrics, occ))) in fast.iter().zip(&plain).enumerate() {
                        assert_eq!(&f.metrics, metrics, "{from} -> {to} {sampling:?} item {k}");
                        assert_eq!(f.occupancy.as_ref(), Some(occ), "{from} -> {to} item {k}");
                        seen += usize::from(metrics.visible > 0);
                    }
                    assert!(
                        seen > 0,
                        "{from} -> {to}: no item saw anything, the test proves nothing"
                    );
                }
            }
        }
    }
}
