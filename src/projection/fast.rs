//! The fast CPU path: the GPU's algorithm (`shaders/splat.wgsl`, `shaders/reduce.wgsl`) in f64
//! on every core (rayon), so a machine without a GPU is still fast. Unit directions are computed
//! once per plan, a sample costs `M u + t` and trigonometry-free clip and bin decisions; only
//! the samples that may be an azimuth extreme take a libm `atan2`. The reference stays the
//! checker: `tests/agreement.rs` holds this path to the same envelope as the GPU.
//!
//! What makes it fast changes no result (a unit test holds it to the plain sample-by-sample
//! loop, bit for bit, in every build the processor runs):
//!
//! - **Blocks that cannot be seen are skipped.** A plan's samples are cut into blocks of
//!   16 consecutive samples; each block's unit directions lie in a ball (centre `c`,
//!   radius `ρ`, computed once per plan). The pose maps it to the ball `M c + t`, radius
//!   `range · ρ` (a rotation keeps distances), and a block whose ball lies wholly outside sonar 2's
//!   field of view, by more than a slack far above every rounding, is not visited: each clip
//!   bound is a 1-Lipschitz function of the point (range; the azimuth half-planes; the elevation
//!   cone's `|z| cos e − ρ sin e`), so its value at the centre less the radius bounds it over the
//!   ball. Every skipped sample is one the per-sample test would have rejected; a block wholly
//!   inside skips the clip tests. Eight blocks' balls are tested together. A ball can be far
//!   wider than a thin field of view (a sidescan's sheet) while its block's samples, on an arc,
//!   stay close to the chord between its first and last: when a ball lies across a bound, the
//!   chord (widened by the samples' largest distance from it) is tested against the convex parts
//!   of the outside, and a block whose chord lies wholly in one is skipped too.
//! - **One lane stage.** A visited block is transformed, clipped and binned over its lanes in
//!   structure-of-arrays form, branch-free, in the same IEEE operations as the scalar code: the
//!   range bin from a guess and the squared edges around it, the beam from an azimuth guessed by
//!   a polynomial `atan2` (within 1e-11 rad) and kept only when it lies farther from the beam's
//!   edges than that error (else the edge tests decide, as the plain loop does). The whole pose
//!   loop is built for baseline x86-64, AVX2 and AVX-512, and the widest the processor runs is
//!   chosen at run time (the binary itself targets baseline x86-64).
//! - **Sidescan bins by runs.** When sonar 2 is a sidescan and no two consecutive samples of the
//!   plan lie a range bin apart once moved (an arc sampled finer than the bins, as automatic
//!   sampling always is), consecutive samples' bins are equal or adjacent, so a run of
//!   consecutive visible samples covers exactly the bins between its nearest and farthest
//!   sample. A pose whose visible samples form one run (an arc crossing the sheet once) takes no
//!   range bin per sample: the lane stage keeps only the squared range's extremes, and the bins
//!   are those of its two ends; a pose with several runs bins each visible sample. (This path
//!   only: the splat shader bins every visible sample, which costs the GPU little of the
//!   fls→sss row, whose time goes per pose: BENCHMARKS.md.)
//! - **Few `atan2`.** An exact `atan2` is taken only for the samples whose azimuth key (the
//!   guessed azimuth, or `y / x` for a sidescan) lies within its error of the pose's extremes.
//! - **Occupancy is reused and counted sparsely.** Each thread keeps one occupancy buffer and a
//!   one-bit-per-word summary of it; counting, the area sum (in row-major order, as the plain loop
//!   sums it) and clearing visit the touched words only.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::geometry::sonar::SonarKind;
use crate::metrics::{Extremes, Metrics};
use crate::occupancy::{Layout, Occupancy};
use crate::projection::{Output, PreparedBatch, Projection};

/// Samples per culling block of the splat shader (consecutive in the plan's order, azimuth
/// index fastest).
pub const BLOCK: usize = 16;

/// Samples per culling block of this path (two AVX-512 vectors, four AVX2 ones).
const LANES: usize = 16;

/// Most beam edges walked from the previous sample's beam before an `atan2` guess is taken.
const WALK: usize = 4;

/// Bound on `|approx_atan2(y, x) − atan2(y, x)|` (rad): the fitted polynomial's 4.2e-12
/// (`scripts/fit_atan.py`) and the roundings of its evaluation, with margin; a unit test holds the
/// function to it against libm.
const ATAN_ERROR: f64 = 1e-11;

/// Relative tolerance on the azimuth key `y / x` (sonar 2 an SSS): samples whose key lies within
/// it of the pose's smallest (largest) key get an exact `atan2` for the azimuth extremes; the
/// others' azimuths are larger (smaller) by far more than `atan2`'s rounding, so they cannot be
/// an extreme.
const KEY_TOLERANCE: f64 = 1e-12;

/// `atan t ≈ t · P(t²)` on `|t| ≤ tan(π/8)`: `P`'s coefficients, `t²`'s power 0 first
/// (`python scripts/fit_atan.py`).
const ATAN_POLY: [f64; 7] = [
    0.999999999848201,
    -0.33333329991221494,
    0.19999786271792946,
    -0.14279648396545372,
    0.11021714819692073,
    -0.08368934777722066,
    0.04551281871436571,
];

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
    /// `(range_min + iΔ)²`, `i = 0..=range_bins`: the plain loop's bins (tests), which the lane
    /// stage computes in place.
    #[cfg(test)]
    range_edges_sq: Vec<f64>,
    /// Half of each beam's width `Δa_j / 2` and each row's `r_{i+1}² − r_i²`: their product is
    /// [`Layout::pixel_measure`], bit for bit.
    half_beam_widths: Vec<f64>,
    row_areas: Vec<f64>,
    /// `(cos, sin)` of each beam edge.
    beam_edges_cs: Vec<(f64, f64)>,
    /// `beams / aperture` when the beams are uniform.
    inv_beam_width: Option<f64>,
    /// The lane stage's beam guess `(az − e_0) · inv_beam_width` (uniform beams only): `e_0`, and
    /// the distance (in beams) from a beam edge below which a guess is not trusted.
    guess_origin: f64,
    guess_slack: f64,
    /// The last range bin and the beam count, as the lane stage's integers.
    last_bin: i32,
    beams: i32,
}

impl<'a> Geometry<'a> {
    fn new(layout: &'a Layout) -> Self {
        let (sin_half_az, cos_half_az) = layout.azimuth_clip();
        let elevation = layout.elevation_clip();
        let inv_beam_width = layout.uniform_beam_width().map(|w| 1.0 / w);
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
            #[cfg(test)]
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
            inv_beam_width,
            guess_origin: layout.beam_edges[0],
            guess_slack: guess_slack(layout.beams(), inv_beam_width),
            last_bin: i32::try_from(layout.range_bins - 1).expect("range bins are limited to 2^20"),
            beams: i32::try_from(layout.beams()).expect("beams are limited to 2^16"),
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

    /// Returns whether the ball of `radius` around `c` lies wholly outside the field of view
    /// and whether wholly inside it (else across a bound). Each clip bound is a 1-Lipschitz
    /// function of the point (the range; the azimuth half-planes' signed distances; the
    /// elevation cone's `|z| cos e − ρ sin e`, as `p ↦ (|z|, ρ)` is 1-Lipschitz), so its value at
    /// `c` moves by at most `radius` over the ball. The splat shader's `block_side`; branch-free,
    /// so that it vectorises over blocks.
    #[inline(always)]
    fn ball_side(&self, c: [f64; 3], radius: f64) -> (bool, bool) {
        let l = self.layout;
        let [x, y, z] = c;
        let d = (x * x + y * y + z * z).sqrt();
        // Azimuth: the wedge is {x sin h − y cos h ≥ 0} ∩ {x sin h + y cos h ≥ 0} for h ≤ 90°,
        // their union beyond; both normals are unit vectors.
        let upper = x * self.sin_half_az - y * self.cos_half_az;
        let lower = x * self.sin_half_az + y * self.cos_half_az;
        let wedge = if self.cos_half_az >= 0.0 {
            upper.min(lower)
        } else {
            upper.max(lower)
        };
        let (az_out, az_in) = (wedge < -radius, wedge > radius);
        // Elevation: |z| cos e − ρ sin e > 0 outside.
        let (s, co) = self.sin_cos_half_el;
        let cone = z.abs() * co - (x * x + y * y).sqrt() * s;
        let el_out = self.clip_elevation & (cone > radius);
        let el_in = !self.clip_elevation | (cone < -radius);
        let outside = (d - radius > l.range_max) | (d + radius < l.range_min) | az_out | el_out;
        let inside =
            (d - radius > 0.0) & (d - radius > l.range_min) & (d + radius < l.range_max) & az_in & el_in;
        (outside, inside & !outside)
    }

    /// Returns whether every point within `margin` of the segment `[a, b]` lies outside the
    /// field of view, without the range bounds (the ball test has them). The outside is a union
    /// of parts on each of which a concave, 1-Lipschitz function is positive: past one azimuth
    /// half-plane (its signed distance; for apertures over 180° both, the larger of the two),
    /// above the elevation sheet (`z cos e − ρ sin e`, concave as `ρ` is convex) or below it
    /// (`−z cos e − ρ sin e`). A concave function on a segment is at least the smaller of its
    /// values at the ends, so both ends beyond `margin` in one part put every point within
    /// `margin` of the segment in it. The splat shader's `chord_outside`; branch-free, so that
    /// it vectorises over blocks.
    #[inline(always)]
    fn chord_outside(&self, a: [f64; 3], b: [f64; 3], margin: f64) -> bool {
        let (s, co) = self.sin_cos_half_el;
        // Per end: beyond the upper and the lower half-plane, the pair of them, above, below.
        let beyond = |[x, y, z]: [f64; 3]| {
            let upper = x * self.sin_half_az - y * self.cos_half_az;
            let lower = x * self.sin_half_az + y * self.cos_half_az;
            let rho = (x * x + y * y).sqrt() * s;
            [
                upper < -margin,
                lower < -margin,
                upper.max(lower) < -margin,
                z * co - rho > margin,
                -z * co - rho > margin,
            ]
        };
        let (ea, eb) = (beyond(a), beyond(b));
        let both = |k: usize| ea[k] & eb[k];
        let azimuth = if self.cos_half_az >= 0.0 {
            both(0) | both(1)
        } else {
            both(2)
        };
        azimuth | (self.clip_elevation & (both(3) | both(4)))
    }

    /// Returns the range bin: a first guess, then the side of the guessed bin's squared edges
    /// (the plain loop's; the lane stage computes the same edges in place).
    #[cfg(test)]
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
    /// lane stage's guess, or the previous sample's beam), or `None` when it lies farther. The edge tests are those of
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

/// A visible sample of the pose being drawn, for the exact azimuth extremes: its `x`, `y` and
/// azimuth key (see [`Lanes::key`]).
#[derive(Clone, Copy, Default)]
struct Seen {
    x: f64,
    y: f64,
    key: f64,
}

/// Returns, per block of [`BLOCK`] consecutive samples of the plan with these azimuth offsets
/// and elevations (rad), the centre and radius of a ball holding the block's unit directions,
/// and the largest distance of those from the block's chord (the segment from its first unit
/// direction to its last): the splat shader's culling balls and chords (this path cuts its own
/// blocks, also of 16 samples).
#[must_use]
pub fn block_bounds(azimuths: &[f64], elevations: &[f64]) -> (Vec<(DVec3, f64)>, Vec<f64>) {
    let units = unit_directions(azimuths, elevations);
    let reaches = chords(&units, BLOCK)
        .into_iter()
        .map(|(_, _, reach)| reach)
        .collect();
    (balls(&units, BLOCK), reaches)
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

/// Returns, per block of `size` of `units`, the centre (their mean) and radius of a ball
/// holding them.
fn balls(units: &[DVec3], size: usize) -> Vec<(DVec3, f64)> {
    units
        .chunks(size)
        .map(|b| {
            let centre = b.iter().sum::<DVec3>() / b.len() as f64;
            let radius = b.iter().map(|u| (*u - centre).length()).fold(0.0, f64::max);
            (centre, radius)
        })
        .collect()
}

/// A plan's unit directions (azimuth index fastest) and, per block of [`LANES`] of them, the
/// centre and radius of a ball holding them.
struct Directions {
    units: Vec<DVec3>,
    /// The same units block by block in structure-of-arrays form, for the lane stage.
    lanes: Vec<BlockUnits>,
    /// The largest distance between consecutive units (0 for a single sample).
    max_step: f64,
    /// The balls, [`BALLS`] blocks at a time in structure-of-arrays form (the last chunk padded
    /// with copies of the last ball).
    ball_chunks: Vec<BallChunk>,
}

/// Blocks whose balls are tested together.
const BALLS: usize = 8;

/// [`BALLS`] blocks' balls: centres and radii.
#[derive(Clone)]
struct BallChunk {
    x: [f64; BALLS],
    y: [f64; BALLS],
    z: [f64; BALLS],
    r: [f64; BALLS],
    /// The blocks' chords: their first and last units (`x`, `y`, `z` arrays) and how far the
    /// blocks' units lie from them.
    first: [[f64; BALLS]; 3],
    last: [[f64; BALLS]; 3],
    reach: [f64; BALLS],
}

/// The unit directions of one block, one array per coordinate; lanes past `len` repeat the last
/// unit and are never kept.
#[derive(Clone)]
struct BlockUnits {
    x: [f64; LANES],
    y: [f64; LANES],
    z: [f64; LANES],
    len: usize,
}

/// One block after the lane stage ([`draw_lanes`]), and the running extremes of the pose.
struct Lanes {
    /// The points in sonar 2's frame.
    x: [f64; LANES],
    y: [f64; LANES],
    z: [f64; LANES],
    /// An azimuth key, ordered as the azimuth: sonar 2 an FLS, the approximate azimuth
    /// ([`approx_atan2`]); an SSS, `y / x`, NaN where `x ≤ 0` (such samples always get an exact
    /// `atan2`).
    key: [f64; LANES],
    /// The pixel `i · beams + j`, its beam `j` guessed from the approximate azimuth.
    pixel: [i32; LANES],
    /// Whether the beam guess is sure (far enough from the beam's edges).
    sure: [bool; LANES],
    /// Whether the sample is visible.
    keep: [bool; LANES],
}

/// Per lane, over the visible samples of the pose so far: range (or squared range) and key
/// extremes.
struct Running {
    range_min: [f64; LANES],
    range_max: [f64; LANES],
    key_min: [f64; LANES],
    key_max: [f64; LANES],
}

impl Default for Lanes {
    fn default() -> Self {
        let zero = [0.0; LANES];
        Lanes {
            x: zero,
            y: zero,
            z: zero,
            key: zero,
            pixel: [0; LANES],
            sure: [false; LANES],
            keep: [false; LANES],
        }
    }
}

impl Default for Running {
    fn default() -> Self {
        Running {
            range_min: [f64::INFINITY; LANES],
            range_max: [f64::NEG_INFINITY; LANES],
            key_min: [f64::INFINITY; LANES],
            key_max: [f64::NEG_INFINITY; LANES],
        }
    }
}

impl Running {
    /// Empties the running extremes for the next pose.
    fn start_pose(&mut self) {
        self.range_min = [f64::INFINITY; LANES];
        self.range_max = [f64::NEG_INFINITY; LANES];
        self.key_min = [f64::INFINITY; LANES];
        self.key_max = [f64::NEG_INFINITY; LANES];
    }

    /// Returns the pose's `(range_min, range_max, key_min, key_max)` over its visible samples
    /// (halving the lanes each step, so that it vectorises; neither a range nor a key is NaN or
    /// a signed zero that the order of a fold could tell apart, where it matters).
    #[inline(always)]
    fn extremes(&self) -> (f64, f64, f64, f64) {
        fn fold(v: &[f64; LANES], f: fn(f64, f64) -> f64) -> f64 {
            let mut v = *v;
            let mut n = LANES;
            while n > 1 {
                n /= 2;
                for k in 0..n {
                    v[k] = f(v[k], v[k + n]);
                }
            }
            v[0]
        }
        (
            fold(&self.range_min, f64::min),
            fold(&self.range_max, f64::max),
            fold(&self.key_min, f64::min),
            fold(&self.key_max, f64::max),
        )
    }
}

/// Returns `atan2(y, x)` within [`ATAN_ERROR`] (NaN where `x = y = 0`), branch-free so that it
/// vectorises: the angle of `min(|x|, |y|) / max(|x|, |y|)` in `[0, π/4]` (folded about π/8 so the
/// polynomial sees `|t| ≤ tan(π/8)`), then placed in its octant.
#[inline(always)]
fn approx_atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, SQRT_2};
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // atan(lo / hi) = π/4 + atan((lo − hi) / (lo + hi)).
    let fold = lo > (SQRT_2 - 1.0) * hi; // tan(π/8) = √2 − 1
    let t = if fold { (lo - hi) / (lo + hi) } else { lo / hi };
    let s = t * t;
    let mut p = ATAN_POLY[6];
    for c in ATAN_POLY[..6].iter().rev() {
        p = p * s + c;
    }
    let a = p * t + if fold { FRAC_PI_4 } else { 0.0 };
    let a = if ay > ax { FRAC_PI_2 - a } else { a };
    let a = if x < 0.0 { PI - a } else { a };
    a.copysign(y)
}

/// Returns the distance (in beams) from a beam edge within which the lane stage's beam guess is
/// settled by the edge tests instead: the azimuth's error [`ATAN_ERROR`] in beams, the beams'
/// departure from uniform (each width within 1e-12 of the mean: [`Layout::uniform_beam_width`])
/// summed over the beams, and the roundings of the guess and the edge tests (below 1e-15 rad and
/// 1e-15 beams a beam), doubled, plus 1e-9.
fn guess_slack(beams: usize, inv_beam_width: Option<f64>) -> f64 {
    let scale = inv_beam_width.unwrap_or(0.0);
    2.0 * ((ATAN_ERROR + 1e-15) * scale + beams as f64 * (1e-12 + 1e-15)) + 1e-9
}

/// Returns the distance from `p` to the segment `[a, b]`.
fn distance_to_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let s = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + s * ab)).length()
}

/// Returns, per block of `size` of `units`, its chord (first and last unit) and the largest
/// distance of its units from the chord: a block of a plan's arc (one azimuth, or one elevation
/// row) lies within its sagitta of the chord, far closer than to its ball's centre.
fn chords(units: &[DVec3], size: usize) -> Vec<(DVec3, DVec3, f64)> {
    units
        .chunks(size)
        .map(|b| {
            let (first, last) = (b[0], b[b.len() - 1]);
            let reach = b
                .iter()
                .map(|u| distance_to_segment(*u, first, last))
                .fold(0.0, f64::max);
            (first, last, reach)
        })
        .collect()
}

/// Returns `M u + t` (`m` is `M`'s columns then `t`) in the operation order of glam's
/// `DMat3 * DVec3`.
#[inline(always)]
fn moved(m: &[f64; 12], [ux, uy, uz]: [f64; 3]) -> [f64; 3] {
    [
        m[0] * ux + m[3] * uy + m[6] * uz + m[9],
        m[1] * ux + m[4] * uy + m[7] * uz + m[10],
        m[2] * ux + m[5] * uy + m[8] * uz + m[11],
    ]
}

/// Returns `M` (scaled by the range) and `t` as [`moved`] and the lane stage take them: `M`'s
/// columns then `t`.
fn pose_columns(m: DMat3, t: DVec3) -> [f64; 12] {
    let columns = [m.x_axis, m.y_axis, m.z_axis, t].map(|c| c.to_array());
    std::array::from_fn(|k| columns[k / 3][k % 3])
}

/// Returns the culling slack of a pose with this range and translation into `layout`: far above
/// the roundings of `M u + t` and of the clip tests ([`CULL_SLACK`]).
fn cull_slack(range: f64, t: DVec3, layout: &Layout) -> f64 {
    CULL_SLACK * (range + t.length() + layout.range_max)
}

/// Returns, for the [`BALLS`] blocks of `chunk`, bit masks of those whose balls (moved by the
/// pose: `m` is `M`'s columns then `t`; radii scaled by `range`, widened by `slack` and a
/// relative 1e-12) lie wholly outside and wholly inside the field of view
/// ([`Geometry::ball_side`]), tested together so that it vectorises; when some ball lies across
/// a bound, the blocks' chords widened the same way ([`Geometry::chord_outside`]) may show more
/// blocks wholly outside.
#[inline(always)]
fn ball_sides(geo: &Geometry<'_>, m: &[f64; 12], chunk: &BallChunk, range: f64, slack: f64) -> (u32, u32) {
    let mut out = [false; BALLS];
    let mut ins = [false; BALLS];
    for k in 0..BALLS {
        let c = moved(m, [chunk.x[k], chunk.y[k], chunk.z[k]]);
        (out[k], ins[k]) = geo.ball_side(c, range * chunk.r[k] * (1.0 + 1e-12) + slack);
    }
    let mask = |v: [bool; BALLS]| v.iter().enumerate().fold(0, |m, (k, &b)| m | u32::from(b) << k);
    let (out, ins) = (mask(out), mask(ins));
    if out | ins == (1 << BALLS) - 1 {
        return (out, ins);
    }
    // A ball lies across a bound: its block's chord, moved by the pose (a rotation and the
    // scale `range`, so distances scale by `range`), may still show the block outside — as for
    // a thin sheet, whose bounds a block's ball straddles while its arc stays on one side.
    let mut far = [false; BALLS];
    for (k, far) in far.iter_mut().enumerate() {
        let end = |e: &[[f64; BALLS]; 3]| moved(m, [e[0][k], e[1][k], e[2][k]]);
        let margin = range * chunk.reach[k] * (1.0 + 1e-12) + slack;
        *far = geo.chord_outside(end(&chunk.first), end(&chunk.last), margin);
    }
    let far = mask(far);
    (out | far, ins & !far)
}

/// The lane stage of one block, branch-free over the lanes so that it vectorises: `p = M u + t`
/// in the operation order of glam's `DMat3 * DVec3` and `length_squared`; the clip of
/// [`Geometry::in_view`] (skipped when `inside`); the range bin of [`Geometry::range_bin`], its
/// edges computed as [`Layout::range_edge`] does; the azimuth key; for an FLS the beam guessed
/// from the approximate azimuth, sure when farther than `guess_slack` from the beam's edges (the
/// edge tests then find the same beam); the running extremes over visible lanes (lanes past the
/// block's length repeat its last unit, so they change none). Returns the visible lanes as a bit
/// mask. `m` is `M`'s columns then `t`.
#[inline(always)]
fn draw_lanes<const FLS: bool>(
    geo: &Geometry<'_>,
    m: &[f64; 12],
    u: &BlockUnits,
    inside: bool,
    out: &mut Lanes,
    run: &mut Running,
) -> u32 {
    let beams = geo.beams;
    // NaN without uniform beams: no guess is ever sure.
    let guess_scale = geo.inv_beam_width.unwrap_or(f64::NAN);
    for k in 0..LANES {
        let (ux, uy, uz) = (u.x[k], u.y[k], u.z[k]);
        let x = m[0] * ux + m[3] * uy + m[6] * uz + m[9];
        let y = m[1] * ux + m[4] * uy + m[7] * uz + m[10];
        let z = m[2] * ux + m[5] * uy + m[8] * uz + m[11];
        let r2 = x * x + y * y + z * z;
        let keep = inside | geo.in_view(DVec3::new(x, y, z), r2);
        // Range bin: the guess, then the guessed bin's squared edges.
        let r = r2.sqrt();
        let i = range_bin(geo, r, r2);
        let key = if FLS {
            // The beam guess (NaN without uniform beams: never sure).
            let az = approx_atan2(y, x);
            let g = (az - geo.guess_origin) * guess_scale;
            let j = to_index(g.max(0.0).min(f64::from(beams - 1)));
            let frac = g - f64::from(j);
            out.sure[k] = (frac > geo.guess_slack) & (frac < 1.0 - geo.guess_slack);
            out.pixel[k] = i * beams + j;
            az
        } else {
            out.pixel[k] = i;
            let q = y / x;
            if x > 0.0 { q } else { f64::NAN }
        };
        out.x[k] = x;
        out.y[k] = y;
        if FLS {
            out.z[k] = z;
        }
        out.key[k] = key;
        out.keep[k] = keep;
        // A compare and a select (NaN, for a lane not kept, never wins): ranges are positive
        // and keys only set thresholds, so which of equal values is kept does not matter.
        let (r_in, key_in) = if keep { (r, key) } else { (f64::NAN, f64::NAN) };
        let lo = |a: f64, b: f64| if b < a { b } else { a };
        let hi = |a: f64, b: f64| if b > a { b } else { a };
        run.range_min[k] = lo(run.range_min[k], r_in);
        run.range_max[k] = hi(run.range_max[k], r_in);
        run.key_min[k] = lo(run.key_min[k], key_in);
        run.key_max[k] = hi(run.key_max[k], key_in);
    }
    // Eight flags (bytes 0 or 1) at a time gathered into a byte by one multiplication: byte
    // `i` times byte `7 − i` of the constant lands on bit `56 + i`, no two terms on one bit.
    const { assert!(LANES.is_multiple_of(8) && LANES <= 32) };
    let mut mask = 0;
    for k in (0..LANES).step_by(8) {
        let flags = u64::from_le_bytes(std::array::from_fn(|b| u8::from(out.keep[k + b])));
        mask |= u32::try_from(flags.wrapping_mul(0x0102_0408_1020_4080) >> 56).unwrap_or(0) << k;
    }
    mask
}

/// Returns the range bin of a point at range `r` (squared `r2`): a guess, then the guessed
/// bin's squared edges, computed as [`Layout::range_edge`] does (the lane stage's, and the
/// runs' ends in [`Scratch::draw_runs`]: one function, so both give the same bin).
#[inline(always)]
fn range_bin(geo: &Geometry<'_>, r: f64, r2: f64) -> i32 {
    let l = geo.layout;
    let last_bin = geo.last_bin;
    let i = to_index(
        ((r - l.range_min) * geo.inv_range_bin)
            .max(0.0)
            .min(f64::from(last_bin)),
    );
    let lower = l.range_min + f64::from(i) * l.range_bin_width;
    let upper = l.range_min + f64::from(i + 1) * l.range_bin_width;
    let down = (i > 0) & (r2 < lower * lower);
    let up = !down & (i < last_bin) & (r2 >= upper * upper);
    i - i32::from(down) + i32::from(up)
}

/// The lane stage of one block of a pose drawn by runs ([`Scratch::draw_runs`], sonar 2 an
/// SSS): `p = M u + t`, its squared range, the clip (skipped when `inside`) and the azimuth key
/// `y / x` as [`draw_lanes`] computes them, stored at block `b` of `out`; the running extremes
/// of the squared range (the range's are their square roots: `sqrt` is monotone and correctly
/// rounded) and of the key. No range bin. Returns the visible lanes as a bit mask.
#[inline(always)]
fn draw_lanes_runs(
    geo: &Geometry<'_>,
    m: &[f64; 12],
    u: &BlockUnits,
    inside: bool,
    out: &mut RunLanes,
    b: usize,
    run: &mut Running,
) -> u32 {
    let (xs, ys, keys, r2s) = (
        &mut out.x[b * LANES..][..LANES],
        &mut out.y[b * LANES..][..LANES],
        &mut out.key[b * LANES..][..LANES],
        &mut out.r2[b * LANES..][..LANES],
    );
    let mut keep = [false; LANES];
    for k in 0..LANES {
        let (ux, uy, uz) = (u.x[k], u.y[k], u.z[k]);
        let x = m[0] * ux + m[3] * uy + m[6] * uz + m[9];
        let y = m[1] * ux + m[4] * uy + m[7] * uz + m[10];
        let z = m[2] * ux + m[5] * uy + m[8] * uz + m[11];
        let r2 = x * x + y * y + z * z;
        keep[k] = inside | geo.in_view(DVec3::new(x, y, z), r2);
        let q = y / x;
        let key = if x > 0.0 { q } else { f64::NAN };
        xs[k] = x;
        ys[k] = y;
        keys[k] = key;
        r2s[k] = r2;
        let (r_in, key_in) = if keep[k] { (r2, key) } else { (f64::NAN, f64::NAN) };
        let lo = |a: f64, b: f64| if b < a { b } else { a };
        let hi = |a: f64, b: f64| if b > a { b } else { a };
        run.range_min[k] = lo(run.range_min[k], r_in);
        run.range_max[k] = hi(run.range_max[k], r_in);
        run.key_min[k] = lo(run.key_min[k], key_in);
        run.key_max[k] = hi(run.key_max[k], key_in);
    }
    let mut mask = 0;
    for k in (0..LANES).step_by(8) {
        let flags = u64::from_le_bytes(std::array::from_fn(|b| u8::from(keep[k + b])));
        mask |= u32::try_from(flags.wrapping_mul(0x0102_0408_1020_4080) >> 56).unwrap_or(0) << k;
    }
    mask
}

/// The lane stage's results for every block of a pose drawn by runs, one array per quantity
/// (block `b`'s lanes at `b · LANES..`), and each block's visible lanes (0 when culled).
#[derive(Default)]
struct RunLanes {
    x: Vec<f64>,
    y: Vec<f64>,
    key: Vec<f64>,
    r2: Vec<f64>,
    visible: Vec<u32>,
}

/// Returns `v` as an index: `v` is finite and within `0..=i32::MAX` (clamped by the caller),
/// so the conversion is exact truncation; unlike `as`, it vectorises.
#[inline(always)]
fn to_index(v: f64) -> i32 {
    debug_assert!((0.0..=f64::from(i32::MAX)).contains(&v));
    // SAFETY: the callers clamp `v` to `[0, n]` with `n < 2^31` by `max` and `min`, which map
    // NaN to the bound, so `v` is finite and representable after truncation.
    unsafe { v.to_int_unchecked::<i32>() }
}

/// Which build of the lane stage runs: baseline x86-64, AVX2, AVX-512.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Isa {
    Baseline,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Isa {
    /// Returns the widest build this processor runs (detected at run time: the binary itself
    /// targets baseline x86-64).
    fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx512f")
                && is_x86_feature_detected!("avx512dq")
                && is_x86_feature_detected!("avx512vl")
            {
                return Isa::Avx512;
            }
            if is_x86_feature_detected!("avx2") {
                return Isa::Avx2;
            }
        }
        Isa::Baseline
    }

    /// Returns every build this processor runs (tests compare them).
    #[cfg(test)]
    fn available() -> Vec<Self> {
        let mut all = vec![Isa::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx2") {
                all.push(Isa::Avx2);
            }
            if Isa::detect() == Isa::Avx512 {
                all.push(Isa::Avx512);
            }
        }
        all
    }
}

impl Directions {
    fn of(azimuths: &[f64], elevations: &[f64]) -> Self {
        let units = unit_directions(azimuths, elevations);
        let blocks = balls(&units, LANES);
        let lanes = units
            .chunks(LANES)
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
        let chords = chords(&units, LANES);
        let ball_chunks = blocks
            .chunks(BALLS)
            .zip(chords.chunks(BALLS))
            .map(|(b, c)| {
                let at = |k: usize| b[k.min(b.len() - 1)];
                let ch = |k: usize| c[k.min(c.len() - 1)];
                BallChunk {
                    x: std::array::from_fn(|k| at(k).0.x),
                    y: std::array::from_fn(|k| at(k).0.y),
                    z: std::array::from_fn(|k| at(k).0.z),
                    r: std::array::from_fn(|k| at(k).1),
                    first: std::array::from_fn(|i| std::array::from_fn(|k| ch(k).0[i])),
                    last: std::array::from_fn(|i| std::array::from_fn(|k| ch(k).1[i])),
                    reach: std::array::from_fn(|k| ch(k).2),
                }
            })
            .collect();
        let max_step = units
            .windows(2)
            .map(|w| (w[1] - w[0]).length())
            .fold(0.0, f64::max);
        Directions {
            units,
            lanes,
            max_step,
            ball_chunks,
        }
    }
}

/// One thread's occupancy buffer and a summary of it: one bit per occupancy word, set when the
/// word is, so that counting, summing and clearing visit the touched words only, in row-major
/// order, without sorting.
struct Scratch {
    occ: Occupancy,
    summary: Vec<u64>,
    /// The visible samples of the pose being drawn (as many slots as the longest plan drawn
    /// so far has samples).
    seen: Vec<Seen>,
    /// The block being drawn.
    lanes: Box<Lanes>,
    /// The pose's running extremes.
    running: Box<Running>,
    /// The blocks of a pose drawn by runs.
    runs: RunLanes,
    /// The bins `lo..=hi` a pose drawn as one run covers, not yet set in `occ`: counted without
    /// touching it unless the occupancy is kept.
    span: Option<(usize, usize)>,
    /// The last base azimuth's bits and its rotation `Rz` (neighbouring items mostly share it).
    rz: Option<(u64, DMat3)>,
}

impl Scratch {
    fn new(layout: &Layout) -> Self {
        let occ = Occupancy::new(layout.range_bins, layout.beams());
        let summary = vec![0; occ.words.len().div_ceil(64)];
        Scratch {
            occ,
            summary,
            seen: Vec::new(),
            lanes: Box::default(),
            running: Box::default(),
            runs: RunLanes::default(),
            span: None,
            rz: None,
        }
    }

    /// Returns `Rz(azimuth)`, computed only when the azimuth differs from the last one's bits.
    fn rotation_z(&mut self, azimuth: f64) -> DMat3 {
        match self.rz {
            Some((bits, rz)) if bits == azimuth.to_bits() => rz,
            _ => {
                let rz = DMat3::from_rotation_z(azimuth);
                self.rz = Some((azimuth.to_bits(), rz));
                rz
            }
        }
    }

    /// Draws one pose: `m` is `M = R · Rz(base azimuth) · range` and `t` the translation,
    /// `slack` the culling slack. Returns the visible count and the extremes, the pixels set in
    /// the occupancy buffer.
    #[inline(always)]
    fn draw_pose<const FLS: bool>(
        &mut self,
        geo: &Geometry<'_>,
        dirs: &Directions,
        (m, t, range, slack): PoseArgs,
    ) -> (u64, Extremes) {
        if !FLS && range * dirs.max_step * (1.0 + 1e-12) + slack < geo.layout.range_bin_width {
            return self.draw_runs(geo, dirs, (m, t, range, slack));
        }
        let Scratch {
            occ,
            summary,
            seen,
            lanes,
            running,
            ..
        } = self;
        // Room for every sample of the plan, made before the pose loop: a push that may grow
        // the vector would be a call there, around which the loop's constants leave registers.
        if seen.len() < dirs.units.len() {
            seen.resize(dirs.units.len(), Seen::default());
        }
        let mut n_seen = 0;
        running.start_pose();
        let columns = pose_columns(m, t);
        #[expect(clippy::cast_sign_loss, reason = "beams are at least 1")]
        let beams = geo.beams as usize;
        let mut beam = 0;
        let (mut word, mut bits) = (0, 0);
        let (mut outside, mut inside) = (0, 0);
        for (b, units) in dirs.lanes.iter().enumerate() {
            if b % BALLS == 0 {
                (outside, inside) = ball_sides(geo, &columns, &dirs.ball_chunks[b / BALLS], range, slack);
            }
            if outside & (1 << (b % BALLS)) != 0 {
                continue;
            }
            let inside = inside & (1 << (b % BALLS)) != 0;
            let mut visible = draw_lanes::<FLS>(geo, &columns, units, inside, lanes, running);
            visible &= (1 << units.len) - 1;
            while visible != 0 {
                let k = visible.trailing_zeros() as usize;
                visible &= visible - 1;
                #[expect(clippy::cast_sign_loss, reason = "pixels are clamped to 0..")]
                let mut pixel = lanes.pixel[k] as usize;
                let (x, y) = (lanes.x[k], lanes.y[k]);
                if FLS && !lanes.sure[k] {
                    // The edge tests, walked from the guess (uniform beams) or the previous
                    // sample's beam, else from an exact atan2.
                    let p = DVec3::new(x, y, lanes.z[k]);
                    let (i, guess) = (pixel / beams, pixel % beams);
                    let from = if geo.inv_beam_width.is_some() { guess } else { beam };
                    beam = geo.beam_near(p, from).unwrap_or_else(|| geo.beam(p, y.atan2(x)));
                    pixel = i * beams + beam;
                }
                // Bits of one word gather in a register while the samples stay in it.
                if pixel / 32 != word {
                    set(occ, summary, word, bits);
                    (word, bits) = (pixel / 32, 0);
                }
                bits |= 1 << (pixel % 32);
                seen[n_seen] = Seen {
                    x,
                    y,
                    key: lanes.key[k],
                };
                n_seen += 1;
            }
        }
        set(occ, summary, word, bits);
        // The extremes: ranges folded over the lanes; exact azimuths for the samples that may
        // be an extreme, in sample order (the fold then equals the fold over every sample: the
        // others' azimuths are strictly inside).
        let (range_min, range_max, key_min, key_max) = running.extremes();
        let mut extremes = Extremes {
            range_min,
            range_max,
            ..Extremes::default()
        };
        let (low, high) = if FLS {
            // Approximate azimuths: an exact azimuth lies within ATAN_ERROR of its guess.
            (key_min + 3.0 * ATAN_ERROR, key_max - 3.0 * ATAN_ERROR)
        } else {
            // y / x orders azimuths in (−90°, 90°), far beyond atan2's rounding.
            (
                key_min + KEY_TOLERANCE * key_min.abs(),
                key_max - KEY_TOLERANCE * key_max.abs(),
            )
        };
        for s in &seen[..n_seen] {
            if !(s.key > low && s.key < high) {
                extremes.add_azimuth(s.y.atan2(s.x));
            }
        }
        (n_seen as u64, extremes)
    }

    /// Draws one pose into an SSS whose range bins are wider than the step from any sample of
    /// the plan to the next (moved by the pose, a step keeps its length `range · |u' − u|`; the
    /// caller checks it with the culling slack as margin). Two consecutive samples' ranges then
    /// differ by less than a bin, so their bins are equal or adjacent, and a run of consecutive
    /// visible samples covers exactly the bins from its nearest sample's to its farthest's. When
    /// the visible samples form one run (an arc crossing the sonar's sheet once), the bins are
    /// those of the two ends of the range; otherwise each visible sample's bin is taken. The same
    /// results as [`Scratch::draw_pose`].
    #[inline(always)]
    fn draw_runs(
        &mut self,
        geo: &Geometry<'_>,
        dirs: &Directions,
        (m, t, range, slack): PoseArgs,
    ) -> (u64, Extremes) {
        let Scratch {
            occ,
            summary,
            running,
            runs,
            span,
            ..
        } = self;
        let blocks = dirs.lanes.len();
        if runs.visible.len() < blocks {
            for v in [&mut runs.x, &mut runs.y, &mut runs.key, &mut runs.r2] {
                v.resize(blocks * LANES, 0.0);
            }
            runs.visible.resize(blocks, 0);
        }
        running.start_pose();
        let columns = pose_columns(m, t);
        let (mut outside, mut inside) = (0, 0);
        let (mut n_seen, mut first, mut last) = (0, usize::MAX, 0);
        for (b, units) in dirs.lanes.iter().enumerate() {
            if b % BALLS == 0 {
                (outside, inside) = ball_sides(geo, &columns, &dirs.ball_chunks[b / BALLS], range, slack);
            }
            if outside & (1 << (b % BALLS)) != 0 {
                runs.visible[b] = 0;
                continue;
            }
            let inside = inside & (1 << (b % BALLS)) != 0;
            let visible =
                draw_lanes_runs(geo, &columns, units, inside, runs, b, running) & ((1 << units.len) - 1);
            runs.visible[b] = visible;
            n_seen += visible.count_ones() as usize;
            if visible != 0 {
                first = first.min(b * LANES + visible.trailing_zeros() as usize);
                last = b * LANES + 31 - visible.leading_zeros() as usize;
            }
        }
        if n_seen == 0 {
            return (0, Extremes::default());
        }
        let (r2_min, r2_max, key_min, key_max) = running.extremes();
        let mut extremes = Extremes {
            range_min: r2_min.sqrt(),
            range_max: r2_max.sqrt(),
            ..Extremes::default()
        };
        if last - first + 1 == n_seen {
            // One run: every bin from the nearest sample's to the farthest's.
            let lo = range_bin(geo, extremes.range_min, r2_min);
            let hi = range_bin(geo, extremes.range_max, r2_max);
            #[expect(clippy::cast_sign_loss, reason = "bins are clamped to 0..")]
            let bins = (lo as usize, hi as usize);
            *span = Some(bins);
        } else {
            let (mut word, mut bits) = (usize::MAX, 0);
            for (b, &visible) in runs.visible[..blocks].iter().enumerate() {
                let mut visible = visible;
                while visible != 0 {
                    let k = b * LANES + visible.trailing_zeros() as usize;
                    visible &= visible - 1;
                    let r2 = runs.r2[k];
                    #[expect(clippy::cast_sign_loss, reason = "bins are clamped to 0..")]
                    let pixel = range_bin(geo, r2.sqrt(), r2) as usize;
                    if pixel / 32 != word {
                        if word != usize::MAX {
                            set(occ, summary, word, bits);
                        }
                        (word, bits) = (pixel / 32, 0);
                    }
                    bits |= 1 << (pixel % 32);
                }
            }
            set(occ, summary, word, bits);
        }
        // Exact azimuths for the samples that may be an extreme, in sample order.
        let (low, high) = (
            key_min + KEY_TOLERANCE * key_min.abs(),
            key_max - KEY_TOLERANCE * key_max.abs(),
        );
        for (b, &visible) in runs.visible[..blocks].iter().enumerate() {
            if visible == 0 {
                continue;
            }
            let keys = &runs.key[b * LANES..][..LANES];
            let mut near = 0u32;
            for (k, &key) in keys.iter().enumerate() {
                near |= u32::from(!((key > low) & (key < high))) << k;
            }
            near &= visible;
            while near != 0 {
                let k = b * LANES + near.trailing_zeros() as usize;
                near &= near - 1;
                extremes.add_azimuth(runs.y[k].atan2(runs.x[k]));
            }
        }
        (n_seen as u64, extremes)
    }

    /// Returns `(occupied, occupied_measure)` (the reduce shader's work, over the touched words
    /// in row-major order, so the area sums in the order of the plain loop) and the occupancy
    /// when asked for, leaving the buffer empty.
    fn reduce(&mut self, geo: &Geometry<'_>, keep: bool) -> (u64, f64, Option<Occupancy>) {
        let layout = geo.layout;
        if let Some((lo, hi)) = self.span.take() {
            if keep {
                set_span(&mut self.occ, &mut self.summary, lo, hi);
            } else {
                let occupied = (hi - lo + 1) as u64;
                return (occupied, occupied as f64 * layout.range_bin_width, None);
            }
        }
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

/// The arguments of [`Scratch::draw_pose`]: `(M, t, range, slack)`.
type PoseArgs = (DMat3, DVec3, f64, f64);

/// [`Scratch::draw_pose`] compiled for AVX2 (four f64 lanes a vector): the same IEEE operations
/// (Rust never fuses a multiply and an add), so the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn draw_pose_avx2<const FLS: bool>(
    s: &mut Scratch,
    geo: &Geometry<'_>,
    dirs: &Directions,
    pose: PoseArgs,
) -> (u64, Extremes) {
    s.draw_pose::<FLS>(geo, dirs, pose)
}

/// [`Scratch::draw_pose`] compiled for AVX-512 (eight f64 lanes a vector), the same bits again.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
fn draw_pose_avx512<const FLS: bool>(
    s: &mut Scratch,
    geo: &Geometry<'_>,
    dirs: &Directions,
    pose: PoseArgs,
) -> (u64, Extremes) {
    s.draw_pose::<FLS>(geo, dirs, pose)
}

/// Runs [`Scratch::draw_pose`] in the build `isa` names (which this processor runs:
/// [`Isa::detect`]).
fn draw_pose<const FLS: bool>(
    isa: Isa,
    s: &mut Scratch,
    geo: &Geometry<'_>,
    dirs: &Directions,
    pose: PoseArgs,
) -> (u64, Extremes) {
    match isa {
        Isa::Baseline => s.draw_pose::<FLS>(geo, dirs, pose),
        // SAFETY: `isa` came from `Isa::detect` or `Isa::available`, which saw the processor run
        // these instructions.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { draw_pose_avx2::<FLS>(s, geo, dirs, pose) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { draw_pose_avx512::<FLS>(s, geo, dirs, pose) },
    }
}

/// Sets the bits of pixels `lo..=hi` in `occ`, marking their words in `summary`.
fn set_span(occ: &mut Occupancy, summary: &mut [u64], lo: usize, hi: usize) {
    for w in lo / 32..=hi / 32 {
        let from = if w == lo / 32 { lo % 32 } else { 0 };
        let to = if w == hi / 32 { hi % 32 } else { 31 };
        set(occ, summary, w, (u32::MAX >> (31 - to)) & (u32::MAX << from));
    }
}

/// Sets `bits` in word `w` of `occ`, marking the word in `summary` (when any bit is set).
fn set(occ: &mut Occupancy, summary: &mut [u64], w: usize, bits: u32) {
    if bits != 0 {
        occ.words[w] |= bits;
        summary[w / 64] |= 1 << (w % 64);
    }
}

/// Returns the projections of every item of `prepared` on all cores; with
/// [`Output::WithOccupancy`] each carries its occupancy buffer.
#[must_use]
pub fn project(prepared: &PreparedBatch<'_>, output: Output) -> Vec<Projection> {
    project_with(prepared, output == Output::WithOccupancy, Isa::detect())
}

/// [`project`], with the lane stage built for `isa` (tests run every build).
fn project_with(prepared: &PreparedBatch<'_>, keep_occupancy: bool, isa: Isa) -> Vec<Projection> {
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
                let dirs = &directions[prepared.plan_index(n)];
                let range = item.measurement.range;
                let m = item.pose.rotation * scratch.rotation_z(prepared.base_azimuth(n)) * range;
                let t = item.pose.translation;
                let pose = (m, t, range, cull_slack(range, t, layout));
                let (visible, extremes) = match layout.kind {
                    SonarKind::Fls => draw_pose::<true>(isa, scratch, &geo, dirs, pose),
                    SonarKind::Sss => draw_pose::<false>(isa, scratch, &geo, dirs, pose),
                };
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
                    * DMat3::from_rotation_z(prepared.base_azimuth(n))
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

    /// Returns a feature anywhere in sonar 1's view, placed anywhere in sonar 2's view with a
    /// random rotation.
    fn random_item(s1: &Sonar, s2: &Sonar, rng: &mut ChaCha8Rng) -> BatchItem {
        let mut point = |s: &Sonar| {
            let r = s.range_min + rng.random::<f64>() * (s.range_max - s.range_min);
            let a = (rng.random::<f64>() - 0.5) * s.azimuth_aperture;
            let e = (rng.random::<f64>() - 0.5) * s.elevation_aperture;
            [r, a, e]
        };
        let (f, place) = (point(s1), point(s2));
        let rot = Rotation::RollPitchYaw {
            roll: rng.random::<f64>() * 360.0 - 180.0,
            pitch: rng.random::<f64>() * 180.0 - 90.0,
            yaw: rng.random::<f64>() * 360.0 - 180.0,
        };
        BatchItem {
            measurement: Measurement::of(s1, f[0], f[1]).unwrap(),
            pose: RelativePose::placement(rot, f, place).unwrap(),
        }
    }

    /// Returns an imaging sonar that sees everything: 360° of beams (edges behind a point), and
    /// arcs of 180° (which cross a sidescan's sheet twice).
    fn omni() -> Sonar {
        Sonar::from_toml_str(
            "omni",
            "kind = 'fls'\nrange_min = 0\nrange_max = 12\nazimuth_aperture = 360\n\
             elevation_aperture = 180\nrange_bins = 600\nbeams = 720\n",
        )
        .unwrap()
    }

    /// Poses drawn by runs (an arc into a sidescan, sampled finer than its range bins, as
    /// automatic sampling always is) give the plain loop's results in every build, with and
    /// without the occupancy, whether
    /// their visible samples form one run (bins from the range's two ends) or several (each
    /// sample's bin); both occur, and every pose here is drawn by runs.
    #[test]
    fn runs_change_no_result() {
        let mut rng = ChaCha8Rng::seed_from_u64(33);
        let sss = Sonar::preset("paper-sss").unwrap();
        let layout = Layout::of(&sss);
        let (mut one, mut several) = (0, 0);
        for s1 in [
            Sonar::preset("paper-fls").unwrap(),
            Sonar::preset("oculus-m750d").unwrap(),
            omni(),
        ] {
            let items = (0..300).map(|_| random_item(&s1, &sss, &mut rng)).collect();
            let batch = Batch {
                source: s1.clone(),
                target: sss.clone(),
                sampling: Sampling::Auto,
                items,
            };
            let prepared = batch.prepare().unwrap();
            let plain = project_plainly(&prepared);
            let fast = project_with(&prepared, true, Isa::Baseline);
            for isa in Isa::available() {
                assert_eq!(project_with(&prepared, true, isa), fast, "{}: {isa:?}", s1.name);
                // Without the occupancy, one run's bins are counted, not set.
                let lean = project_with(&prepared, false, isa);
                assert!(
                    lean.iter()
                        .zip(&fast)
                        .all(|(l, f)| l.metrics == f.metrics && l.occupancy.is_none()),
                    "{}: {isa:?} without the occupancy",
                    s1.name
                );
            }
            for (n, (f, (metrics, occ))) in fast.iter().zip(&plain).enumerate() {
                assert_eq!(&f.metrics, metrics, "{} item {n}", s1.name);
                assert_eq!(f.occupancy.as_ref(), Some(occ), "{} item {n}", s1.name);
                // Drawn by runs, and with how many.
                let item = &batch.items[n];
                let plan = prepared.plan(n);
                let dirs = Directions::of(&plan.azimuths, &plan.elevations);
                let range = item.measurement.range;
                let t = item.pose.translation;
                let slack = cull_slack(range, t, &layout);
                assert!(
                    range * dirs.max_step * (1.0 + 1e-12) + slack < layout.range_bin_width,
                    "{} item {n} is not drawn by runs",
                    s1.name
                );
                let m = item.pose.rotation * DMat3::from_rotation_z(prepared.base_azimuth(n)) * range;
                let geo = Geometry::new(&layout);
                let seen: Vec<usize> = (0..dirs.units.len())
                    .filter(|&k| {
                        let p = m * dirs.units[k] + t;
                        geo.in_view(p, p.length_squared())
                    })
                    .collect();
                if let (Some(first), Some(last)) = (seen.first(), seen.last()) {
                    if last - first + 1 == seen.len() {
                        one += 1;
                    } else {
                        several += 1;
                    }
                }
            }
        }
        assert!(
            one > 300 && several > 50,
            "one run {one} times, several {several}"
        );
    }

    /// The azimuth guess keeps within `ATAN_ERROR` of libm's `atan2` in every octant, near the
    /// axes and diagonals, over many magnitudes; NaN only at the origin.
    #[test]
    fn approx_atan2_is_within_its_bound() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut worst: f64 = 0.0;
        let mut check = |y: f64, x: f64| {
            let (a, e) = (approx_atan2(y, x), y.atan2(x));
            assert!((a - e).abs() <= ATAN_ERROR, "atan2({y}, {x}): {a} against {e}");
            worst = worst.max((a - e).abs());
        };
        for _ in 0..1_000_000 {
            let a = (rng.random::<f64>() - 0.5) * std::f64::consts::TAU;
            let r = 10f64.powf(rng.random::<f64>() * 8.0 - 4.0);
            check(r * a.sin(), r * a.cos());
        }
        for k in 0..=64 {
            let a = f64::from(k) * std::f64::consts::FRAC_PI_8 / 8.0 - std::f64::consts::PI;
            for d in [-1e-9, -1e-15, 0.0, 1e-15, 1e-9] {
                check((a + d).sin(), (a + d).cos());
            }
        }
        for (y, x) in [
            (0.0, 1.0),
            (-0.0, 1.0),
            (1.0, 0.0),
            (1.0, -0.0),
            (-1.0, 0.0),
            (0.0, -1.0),
        ] {
            check(y, x);
        }
        // Not merely within the bound by luck: the polynomial is fitted to 4.2e-12.
        assert!(worst > 1e-13 && worst < 6e-12, "worst error {worst}");
        assert!(approx_atan2(0.0, 0.0).is_nan() && approx_atan2(-0.0, -0.0).is_nan());
    }

    /// A block the chord test skips has no visible sample (the plain test, sample by sample),
    /// and the chord test skips blocks the balls keep — most of them where a sidescan's thin
    /// sheet is the bound — on random placements of a feature in sonar 2's view (its arc then
    /// crosses the bounds). `ball_sides` returns the balls' decisions with the chords' added.
    #[test]
    fn chords_skip_only_blocks_without_a_visible_sample() {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        for (from, to, least) in [
            ("paper-fls", "paper-sss", 0.15),
            ("oculus-m750d", "paper-sss", 0.25),
            ("paper-sss", "paper-fls", 0.1),
            ("paper-fls", "paper-fls", 0.05),
        ] {
            let (s1, s2) = (Sonar::preset(from).unwrap(), Sonar::preset(to).unwrap());
            let layout = Layout::of(&s2);
            let geo = Geometry::new(&layout);
            let (mut across, mut chord_only) = (0, 0);
            for _ in 0..300 {
                let item = random_item(&s1, &s2, &mut rng);
                let batch = Batch {
                    source: s1.clone(),
                    target: s2.clone(),
                    sampling: Sampling::Step(0.1),
                    items: vec![item],
                };
                let prepared = batch.prepare().unwrap();
                let plan = prepared.plan(0);
                let dirs = Directions::of(&plan.azimuths, &plan.elevations);
                let range = item.measurement.range;
                let m = item.pose.rotation * DMat3::from_rotation_z(prepared.base_azimuth(0)) * range;
                let t = item.pose.translation;
                let slack = cull_slack(range, t, &layout);
                let columns = pose_columns(m, t);
                let balls = balls(&dirs.units, LANES);
                let chords = chords(&dirs.units, LANES);
                for (b, units) in dirs.units.chunks(LANES).enumerate() {
                    let (centre, radius) = balls[b];
                    let (first, last, reach) = chords[b];
                    let widen = |r: f64| range * r * (1.0 + 1e-12) + slack;
                    let (ball_out, ball_in) = geo.ball_side((m * centre + t).to_array(), widen(radius));
                    let chord_out = geo.chord_outside(
                        (m * first + t).to_array(),
                        (m * last + t).to_array(),
                        widen(reach),
                    );
                    let (out, ins) = ball_sides(&geo, &columns, &dirs.ball_chunks[b / BALLS], range, slack);
                    let bit = 1 << (b % BALLS);
                    assert_eq!(out & bit != 0, ball_out | chord_out, "{from} -> {to} block {b}");
                    assert_eq!(ins & bit != 0, ball_in & !chord_out, "{from} -> {to} block {b}");
                    if chord_out {
                        for u in units {
                            let p = m * *u + t;
                            assert!(
                                !geo.in_view(p, p.length_squared()),
                                "{from} -> {to}: block {b} skipped by its chord holds a visible sample"
                            );
                        }
                    }
                    if !ball_out && !ball_in {
                        across += 1;
                        chord_only += usize::from(chord_out);
                    }
                }
            }
            let share = chord_only as f64 / across as f64;
            assert!(
                across > 0 && share >= least,
                "{from} -> {to}: the chords skip {chord_only} of {across} blocks the balls keep"
            );
        }
    }

    /// Culling, the lane stage's guessed bins and beams, exact `atan2` only for extreme
    /// candidates, the sparse reduce and every build of the pose loop (baseline, AVX2, AVX-512,
    /// as the processor runs them) change no bit of any result: the fast path against the plain
    /// loop on random placements (features anywhere in sonar 1's view, placed anywhere in sonar
    /// 2's, random rotations) for every preset pair, a 360° sonar and one with non-uniform
    /// beams, in both sampling modes.
    #[test]
    fn culling_changes_no_result() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        // The presets, a sonar that sees everything ([`omni`]) and one with non-uniform beams.
        let mut sonars: Vec<Sonar> = Sonar::preset_names()
            .into_iter()
            .map(|n| Sonar::preset(n).unwrap())
            .collect();
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
        sonars.extend([omni(), nonuniform]);
        for s1 in &sonars {
            for s2 in &sonars {
                let (from, to) = (&s1.name, &s2.name);
                let (s1, s2) = (s1.clone(), s2.clone());
                for sampling in [Sampling::Step(0.5), Sampling::Auto] {
                    let items = (0..40).map(|_| random_item(&s1, &s2, &mut rng)).collect();
                    let batch = Batch {
                        source: s1.clone(),
                        target: s2.clone(),
                        sampling,
                        items,
                    };
                    let prepared = batch.prepare().unwrap();
                    let plain = project_plainly(&prepared);
                    // Every build of the lane stage this processor runs gives the same bits.
                    let fast = project_with(&prepared, true, Isa::Baseline);
                    for isa in Isa::available() {
                        assert_eq!(
                            project_with(&prepared, true, isa),
                            fast,
                            "{from} -> {to}: {isa:?}"
                        );
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
