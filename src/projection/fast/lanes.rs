//! The lane stage, and the polynomial `atan2` its beam guess uses. One block of a pose is
//! transformed, clipped and binned as structure-of-arrays over its [`LANES`] lanes, branch-free. It
//! uses the same IEEE operations as the scalar decisions of [`crate::clip::Clip`], so it gives the
//! same bits.

use glam::DVec3;

use super::tables::BlockUnits;
use super::{Geometry, LANES};
use crate::clip::{ATAN_ERROR, F64_ROUNDINGS, GUESS_SLACK_FLOOR, UNIFORM_BEAMS, to_index};

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

/// One block after the lane stage ([`draw_lanes`]), and the running extremes of the pose.
pub(super) struct Lanes {
    /// The points in sonar 2's frame.
    pub(super) x: [f64; LANES],
    pub(super) y: [f64; LANES],
    pub(super) z: [f64; LANES],
    /// An azimuth key, ordered as the azimuth. With beams, it is the approximate azimuth
    /// ([`approx_atan2`]). For an SSS it is `y / x`, NaN where `x ≤ 0`; such samples always get an
    /// exact `atan2`.
    pub(super) key: [f64; LANES],
    /// The pixel `i · beams + j`, its beam `j` guessed from the approximate azimuth.
    pub(super) pixel: [i32; LANES],
    /// Whether the beam guess is sure (far enough from the beam's edges).
    pub(super) sure: [bool; LANES],
    /// Whether the sample is visible.
    pub(super) keep: [bool; LANES],
    /// The projection-area cell `i · ny + j` (an FLS target with a grid). It uses the operations of
    /// [`crate::occupancy::AreaGrid::flat_cell`], so it is the same cell.
    pub(super) cell: [i32; LANES],
}

/// Per lane, over the visible samples of the pose so far: range (or squared range) and key
/// extremes.
pub(super) struct Running {
    pub(super) range_min: [f64; LANES],
    pub(super) range_max: [f64; LANES],
    pub(super) key_min: [f64; LANES],
    pub(super) key_max: [f64; LANES],
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
            cell: [0; LANES],
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
    #[inline(always)]
    pub(super) fn start_pose(&mut self) {
        self.range_min = [f64::INFINITY; LANES];
        self.range_max = [f64::NEG_INFINITY; LANES];
        self.key_min = [f64::INFINITY; LANES];
        self.key_max = [f64::NEG_INFINITY; LANES];
    }

    /// Returns the pose's `(range_min, range_max, key_min, key_max)` over its visible samples. It
    /// halves the lanes each step, so that it vectorises. Where it matters, neither a range nor a
    /// key is NaN or a signed zero that the order of a fold could tell apart.
    #[inline(always)]
    pub(super) fn extremes(&self) -> (f64, f64, f64, f64) {
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
/// vectorises. It takes the angle of `min(|x|, |y|) / max(|x|, |y|)` in `[0, π/4]`, folded about
/// π/8 so the polynomial sees `|t| ≤ tan(π/8)`. Then it places the angle in its octant.
#[inline(always)]
pub(super) fn approx_atan2(y: f64, x: f64) -> f64 {
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

/// Returns the distance (in beams) from a beam edge within which the edge tests, not the lane
/// stage's beam guess, settle the beam. It adds up the azimuth's error [`ATAN_ERROR`] in beams, the
/// beams' departure from uniform summed over the beams, and the roundings of the guess and the edge
/// tests (below [`F64_ROUNDINGS`] rad and beams a beam). Each beam's width is within
/// [`UNIFORM_BEAMS`] of the mean ([`crate::occupancy::Layout::uniform_beam_width`]). The sum is
/// doubled, plus [`GUESS_SLACK_FLOOR`].
pub(super) fn guess_slack(beams: usize, inv_beam_width: Option<f64>) -> f64 {
    let scale = inv_beam_width.unwrap_or(0.0);
    2.0 * ((ATAN_ERROR + F64_ROUNDINGS) * scale + beams as f64 * (UNIFORM_BEAMS + F64_ROUNDINGS))
        + GUESS_SLACK_FLOOR
}

/// The lane stage of one block, branch-free over the lanes so that it vectorises. Returns the
/// visible lanes as a bit mask; `m` is `M`'s columns then `t`. Per lane:
/// - `p = M u + t`, in the operation order of glam's `DMat3 * DVec3` and `length_squared`;
/// - the clip of [`crate::clip::Clip::in_view`] (skipped when `inside`), the range bin of
///   [`crate::clip::Clip::range_bin`], and the azimuth key;
/// - with beams (`BEAMS`), the beam guessed from the approximate azimuth. It is sure when farther
///   than `guess_slack` from the beam's edges: the edge tests then find the same beam;
/// - the running extremes over visible lanes. Lanes past the block's length repeat its last unit,
///   so they change none.
#[inline(always)]
pub(super) fn draw_lanes<const BEAMS: bool>(
    geo: &Geometry<'_>,
    m: &[f64; 12],
    u: &BlockUnits,
    inside: bool,
    out: &mut Lanes,
    run: &mut Running,
) -> u32 {
    let beams = geo.beams;
    let cells = if BEAMS { geo.cells } else { None };
    // NaN without uniform beams, so no guess is ever sure.
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
        let i = geo.range_bin(r, r2);
        let key = if BEAMS {
            // The beam guess (NaN without uniform beams: never sure).
            let az = approx_atan2(y, x);
            let g = (az - geo.guess_origin) * guess_scale;
            let j = to_index(g.max(0.0).min(f64::from(beams - 1)));
            let frac = g - f64::from(j);
            out.sure[k] = (frac > geo.guess_slack) & (frac < 1.0 - geo.guess_slack);
            out.pixel[k] = i * beams + j;
            if let Some(g) = cells {
                // (x, y) scaled to length r; (r, 0) on the z axis.
                let rho2 = x * x + y * y;
                let s = r / rho2.sqrt();
                let (u, v) = if rho2 > 0.0 { (s * x, s * y) } else { (r, 0.0) };
                let ci = to_index(((u - g.x0) / g.cell).max(0.0).min(g.last_i));
                let cj = to_index(((v - g.y0) / g.cell).max(0.0).min(g.last_j));
                out.cell[k] = ci * g.ny + cj;
            }
            az
        } else {
            out.pixel[k] = i;
            let q = y / x;
            if x > 0.0 { q } else { f64::NAN }
        };
        out.x[k] = x;
        out.y[k] = y;
        if BEAMS {
            out.z[k] = z;
        }
        out.key[k] = key;
        out.keep[k] = keep;
        // A compare and a select; NaN, for a lane not kept, never wins. Ranges are positive and
        // keys only set thresholds, so which of equal values is kept does not matter.
        let (r_in, key_in) = if keep { (r, key) } else { (f64::NAN, f64::NAN) };
        let lo = |a: f64, b: f64| if b < a { b } else { a };
        let hi = |a: f64, b: f64| if b > a { b } else { a };
        run.range_min[k] = lo(run.range_min[k], r_in);
        run.range_max[k] = hi(run.range_max[k], r_in);
        run.key_min[k] = lo(run.key_min[k], key_in);
        run.key_max[k] = hi(run.key_max[k], key_in);
    }
    // Eight flags (bytes 0 or 1) at a time are gathered into a byte by one multiplication. Byte `i`
    // times byte `7 − i` of the constant lands on bit `56 + i`, and no two terms land on one bit.
    const { assert!(LANES.is_multiple_of(8) && LANES <= 32) };
    let mut mask = 0;
    for k in (0..LANES).step_by(8) {
        let flags = u64::from_le_bytes(std::array::from_fn(|b| u8::from(out.keep[k + b])));
        mask |= u32::try_from(flags.wrapping_mul(0x0102_0408_1020_4080) >> 56).unwrap_or(0) << k;
    }
    mask
}

/// The lane stage of one block of a pose drawn by runs ([`Scratch::draw_runs`], sonar 2 an SSS).
/// Returns the visible lanes as a bit mask. No range bin is taken. It stores at block `b` of `out`
/// what [`draw_lanes`] computes: `p = M u + t`, its squared range, the clip (skipped when `inside`)
/// and the azimuth key `y / x`. It keeps the running extremes of the key and of the squared range.
/// The range's extremes are their square roots, since `sqrt` is monotone and correctly rounded.
#[inline(always)]
pub(super) fn draw_lanes_runs(
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

/// The lane stage's results for every block of a pose drawn by runs: one array per quantity (block
/// `b`'s lanes at `b · LANES..`), and each block's visible lanes (0 when culled).
#[derive(Default)]
pub(super) struct RunLanes {
    pub(super) x: Vec<f64>,
    pub(super) y: Vec<f64>,
    pub(super) key: Vec<f64>,
    pub(super) r2: Vec<f64>,
    pub(super) visible: Vec<u32>,
}
