//! The one clip and error model: field-of-view tests, range bins, beams and every tolerance.
//!
//! Each tolerance carries its derivation. The WGSL twin is `shaders/shared/clip.wgsl`, which
//! holds the splat stage's decisions and its f32 slack. Read the two side by side.
//!
//! Two kinds of decision live here:
//!
//! - **The definition** ([`Layout::inside`], [`Layout::range_bin`], [`Layout::beam`]) uses a
//!   point's range, azimuth and elevation, with trigonometry, as the conventions state them.
//!   Bounds are inclusive. Bin `i` covers `[edge(i), edge(i + 1))`. The last bin and beam also
//!   take the upper bound. The reference (`projection::reference`) decides this way.
//! - **The same decisions without trigonometry** (`Clip`) use the Cartesian point in sonar 2:
//!   `r²` against the squared bounds, `x sin h − |y| cos h ≥ 0` for the azimuth,
//!   `z² cos² e ≤ (x² + y²) sin² e` for the elevation, and a first guess of the bin and beam
//!   settled by edge tests. The fast CPU path and the splat shader decide this way. They differ
//!   from the definition only within a rounding of a bound or edge, which the envelope
//!   ([`RELATIVE_TOLERANCE`]) allows.
//!
//! The masks test balls, not points, against the field of view. `View::may_meet` is false only
//! when no point of the ball can be in view. Its twin is `may_meet_view` in `shaders/mask.wgsl`.

use glam::DVec3;

use crate::geometry::Sonar;
use crate::occupancy::Layout;

// Tolerances. Each says what it is relative to and why it is large enough. The splat
// shader's F32_SLACK and F32_WIDEN are generated from these by projection/gpu/source.rs.

/// The envelope of "How the GPU is checked", relative to the sample's range in sonar 2.
/// A GPU result may disagree with the reference only this close to a bound or edge. The GPU
/// reports ranges and azimuths rounded to f32 (about 6e-8 relative) and decides in f64 or
/// double-f32, far inside it.
pub const RELATIVE_TOLERANCE: f64 = 1e-5;

/// The rounding of the pose and directions to f32 hi + lo pairs for the GPU, relative to
/// `range + |t|` (the magnitudes the transform adds). A pair keeps about 48 bits, so 1e-14.
/// The bound takes a wide margin.
pub const INPUT_TOLERANCE: f64 = 1e-9;

/// [`INPUT_TOLERANCE`] for a GPU that decides in double-f32.
/// Where the driver keeps f32 arithmetic exact and fuses `fma`, double-f32 is that precise.
/// Drivers that do not (lavapipe, and the H100's driver, which gave the same 2e-6 m errors)
/// leave it at f32. Then a coordinate takes eight roundings: `u` from the plan's angles, and
/// three products and sums with the pose. Each errs by up to 2⁻²⁴ ≈ 6e-8 of `range + |t|`, so
/// 5e-7 in all. The bound doubles that.
pub const DOUBLE_F32_TOLERANCE: f64 = 1e-6;

/// The extra neighbourhood of a projection-area cell edge within which a GPU's cell may differ
/// from the reference's, relative to sonar 2's `range_max`, on top of [`RELATIVE_TOLERANCE`].
/// The splat shader (WGSL `set_cell`) places a sample in f32 from its f32 range and point, as
/// `x0 + r · x / √(x² + y²)`. The scaled point errs by a few ulps of `r` (under 4e-7 · r).
/// `x − x0` errs by an ulp of `range_max` (6e-8), `× 1/cell` by an ulp of the index
/// (6e-8 · 2 range_max), and `x0` itself by an ulp (6e-8 · range_max). That is under
/// 6e-7 · `range_max` in all, taken as 1e-6.
pub const CELL_SLACK: f64 = 1e-6;

/// The fast CPU path's block-culling slack, relative to `range + |t| + range_max`. The roundings
/// of `M u + t` in f64 and of the clip functions are below 1e-15 of that sum. So a block is
/// culled only when it clears a bound by a million times them.
pub(crate) const CULL_SLACK: f64 = 1e-9;

/// The slack of the splat shader's f32 decisions (block culling and the f32 filter), relative to
/// `range + |t| + range_max` (WGSL `F32_SLACK`, in `f32_slack`). It covers three errors:
///
/// 1. A point moved in f32, from the pose's hi parts and the f32 unit, lies within
///    `4e-6 · (range + |t|)` of the `Real` one: the unit is within 4e-7 ([`F32_UNIT_ERROR`]),
///    each entry of `M` and `t` within 2⁻²⁴, and the dot product's four roundings each within
///    2⁻²⁴ of `|M| |u| + |t|`.
/// 2. A clip or edge function evaluated there in f32 adds a few roundings of `|p| ≤ range + |t|`.
/// 3. A double-f32 `Real` left at f32 precision by its driver adds [`DOUBLE_F32_TOLERANCE`].
///
/// 1e-5 is more than twice their sum.
pub(crate) const F32_SLACK: f64 = 1e-5;

/// The relative widening of an f32 ball radius or chord reach in the splat shader (WGSL
/// `F32_WIDEN`). `length(M row)` and the product with the radius round by a few 2⁻²⁴ ≈ 6e-8.
pub(crate) const F32_WIDEN: f64 = 1e-5;

/// How far the f32 centre of a culling ball may lie from its f64 centre once rounded. That is
/// √3 · 2⁻²⁴ of a unit vector's coordinates, below 2e-7. The direction table's radii grow by it.
pub(crate) const F32_CENTRE_ERROR: f64 = 2e-7;

/// How far a unit direction built in f32 by the shader (`unit_f32`, from the direction table's
/// hi parts) may lie from the f64 one. A product and three roundings stay below 4e-7. The
/// direction table's chord reaches grow by it.
pub(crate) const F32_UNIT_ERROR: f64 = 4e-7;

/// The relative rounding-up of every f32 radius and reach in the direction table, so that the
/// stored value is never below the f64 one.
pub(crate) const F32_ROUND_UP: f64 = 1e-6;

/// The relative widening of a culling radius in f64 (fast path). The radius, the range and
/// their product round by a few 2⁻⁵³.
pub(crate) const F64_WIDEN: f64 = 1e-12;

/// The slack of a mask's ball in the GPU's f32 drawing (`shaders/mask.wgsl`), relative to
/// `r + |t| + range_max`. About 17 f32 ulps of the largest distance bound every rounding of the
/// shader's transform, length and bin arithmetic. [`MASK_F32_FLOOR`] (m) covers distances near
/// zero. So a GPU mask holds the CPU mask of the same scene.
pub(crate) const MASK_F32_SLACK: f64 = 2e-6;

/// The absolute floor (m) of a mask's f32 slack.
pub(crate) const MASK_F32_FLOOR: f64 = 1e-6;

/// The slack of a mask's ball in the CPU's f64 drawing, relative to `r + |t| + range_max`, and
/// its absolute floor (m). The f64 roundings of `q = R p + t` and `|q|` are below 1e-15 of the
/// distances.
pub(crate) const MASK_F64_SLACK: f64 = 1e-12;

/// The angular slack (rad) of the masks' beam spread `asin(radius / ρ)` in f64. It covers the
/// roundings of `atan2` and `asin`, a few 1e-16.
pub(crate) const MASK_ANGLE_SLACK: f64 = 1e-12;

/// How close (rad) to 90° a half aperture may come and still bound the masks' ball test by its
/// tangent. Nearer, the bound is dropped, since the tangent would overflow or lose all precision.
pub(crate) const RIGHT_ANGLE_SLACK: f64 = 1e-9;

/// How far a sonar's first and last beam edges may lie from `∓aperture / 2`, relative to the
/// aperture. Files write edges as decimals of the aperture's half.
pub(crate) const APERTURE_ENDS: f64 = 1e-9;

/// A few roundings of an f64 computation, relative to its magnitude (2⁻⁵³ ≈ 1.1e-16 each).
pub(crate) const F64_ROUNDINGS: f64 = 1e-15;

/// The floor (in beams) of the fast path's beam-guess slack.
pub(crate) const GUESS_SLACK_FLOOR: f64 = 1e-9;

/// How far from an even split a sonar's beam widths may be (relative to the mean width) and
/// still count as uniform. Uniform beams are first guessed by one multiplication.
pub(crate) const UNIFORM_BEAMS: f64 = 1e-12;

/// The bound on `|approx_atan2(y, x) − atan2(y, x)|` (rad) of the fast path's polynomial
/// `atan2`. It covers the fitted polynomial's 4.2e-12 (`scripts/fit_atan.py`) and the roundings
/// of its evaluation, with margin. A unit test holds the function to it against libm.
pub(crate) const ATAN_ERROR: f64 = 1e-11;

/// The relative tolerance of the fast path's azimuth key `y / x` (sonar 2 an SSS). Samples
/// within it of the pose's smallest (largest) key get an exact `atan2` for the azimuth extremes.
/// Other azimuths are larger (smaller) by far more than `atan2`'s rounding.
pub(crate) const KEY_TOLERANCE: f64 = 1e-12;

/// Returns the fast path's culling slack (m) for a pose of this range and translation into
/// `layout` ([`CULL_SLACK`]).
#[inline]
pub(crate) fn cull_slack(range: f64, t: DVec3, layout: &Layout) -> f64 {
    CULL_SLACK * (range + t.length() + layout.range_max)
}

// The definition: decisions from range, azimuth and elevation.

impl Layout {
    /// Returns true when `(r, az, el)` (m, rad, rad) lies in the field of view. Bounds are
    /// inclusive; the origin is outside.
    #[must_use]
    pub fn inside(&self, r: f64, az: f64, el: f64) -> bool {
        r > 0.0
            && r >= self.range_min
            && r <= self.range_max
            && az.abs() <= self.half_azimuth
            && el.abs() <= self.half_elevation
    }

    /// Returns the lower edge (m) of range bin `i`; `i = range_bins` gives `range_max`.
    #[must_use]
    pub fn range_edge(&self, i: usize) -> f64 {
        if i >= self.range_bins {
            self.range_max
        } else {
            self.range_min + i as f64 * self.range_bin_width
        }
    }

    /// Returns the range bin of `r` (m). Bin `i` covers `[edge(i), edge(i+1))`, and the last one
    /// also takes `range_max`. `r` must lie in `[range_min, range_max]`.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a saturating float-to-index conversion, clamped to the table right after"
    )]
    #[must_use]
    #[inline]
    pub fn range_bin(&self, r: f64) -> usize {
        // The floor of a non-negative quotient is its truncation; NaN and negatives give bin 0.
        let i = (r - self.range_min) / self.range_bin_width;
        if i >= 0.0 {
            (i as usize).min(self.range_bins - 1)
        } else {
            0
        }
    }

    /// Returns the beam of `az` (rad). Beam `j` covers `[e_j, e_{j+1})`, and the last one also
    /// takes `+half_azimuth`. `az` must lie in the aperture.
    #[must_use]
    #[inline]
    pub fn beam(&self, az: f64) -> usize {
        let j = self.edges_at_or_below(az);
        j.saturating_sub(1).min(self.beams() - 1)
    }

    /// Returns how many beam edges are `<= az`, as `beam_edges.partition_point(|&e| e <= az)`.
    /// It guesses the position as if the edges were uniform, then checks the edges themselves.
    /// It binary-searches only when the guess is more than a few edges off.
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_precision_loss,
        reason = "a guess clamped to the table, checked against it before it is used"
    )]
    #[inline]
    pub(crate) fn edges_at_or_below(&self, az: f64) -> usize {
        let e = &self.beam_edges;
        let n = e.len();
        let span = e[n - 1] - e[0];
        // Truncation is the floor for the non-negative guesses kept; NaN and negatives give 0.
        let x = (az - e[0]) / span * (n - 1) as f64;
        let mut p = if x >= 0.0 {
            (x.min(n as f64) as usize + 1).min(n)
        } else {
            0
        };
        for _ in 0..4 {
            if p > 0 && e[p - 1] > az {
                p -= 1;
            } else if p < n && e[p] <= az {
                p += 1;
            } else {
                return p;
            }
        }
        e.partition_point(|&x| x <= az)
    }

    /// Returns `(sin h, cos h)` for the trigonometry-free azimuth clip `x sin h − |y| cos h ≥ 0`,
    /// which is `|az| ≤ h` for `h` in `(0, π]`. The full circle gives exactly `(0, −1)`.
    #[must_use]
    pub fn azimuth_clip(&self) -> (f64, f64) {
        let h = self.half_azimuth;
        if h >= std::f64::consts::PI {
            (0.0, -1.0)
        } else {
            (h.sin(), h.cos())
        }
    }

    /// Returns `(sin² e, cos² e)` for the elevation clip `z² cos² e ≤ (x² + y²) sin² e`, which is
    /// `|el| ≤ e`. Returns `None` for a 180° aperture, which clips nothing.
    #[must_use]
    pub fn elevation_clip(&self) -> Option<(f64, f64)> {
        let e = self.half_elevation;
        (e < std::f64::consts::FRAC_PI_2).then(|| (e.sin().powi(2), e.cos().powi(2)))
    }

    /// Returns the beam width (rad) when the beams split the aperture uniformly, else `None`.
    /// Uniform means each width lies within 1e-12 of the mean (`clip::UNIFORM_BEAMS`).
    #[must_use]
    pub fn uniform_beam_width(&self) -> Option<f64> {
        let width = 2.0 * self.half_azimuth / self.beams() as f64;
        self.beam_edges
            .windows(2)
            .all(|w| ((w[1] - w[0]) - width).abs() <= UNIFORM_BEAMS * width)
            .then_some(width)
    }

    /// Returns the squared range-bin edges `(range_min + iΔ)²`, `i = 0..=range_bins`.
    #[must_use]
    pub fn range_edges_sq(&self) -> Vec<f64> {
        (0..=self.range_bins)
            .map(|i| self.range_edge(i).powi(2))
            .collect()
    }
}

// The same decisions without trigonometry, from the Cartesian point: the fast CPU path's,
// twins of the splat shader's (shaders/shared/clip.wgsl: in_view, range_bin, at_or_above,
// beam_of).

/// The most beam edges [`Clip::beam_near`] walks from a starting beam.
const WALK: usize = 4;

/// Sonar 2's field of view and layout as the trigonometry-free decisions use them. The f64 twin
/// of the splat shader's `TargetParams`.
pub(crate) struct Clip<'a> {
    pub layout: &'a Layout,
    pub range_min_sq: f64,
    pub range_max_sq: f64,
    pub sin_half_az: f64,
    pub cos_half_az: f64,
    pub clip_elevation: bool,
    pub sin2_half_el: f64,
    pub cos2_half_el: f64,
    /// `(sin e, cos e)` of the half elevation aperture, for the culling cone.
    pub sin_cos_half_el: (f64, f64),
    /// `1 / Δ`, so the range-bin guess is one multiplication. The edge tests then settle it.
    pub inv_range_bin: f64,
    /// `(cos, sin)` of each beam edge.
    pub beam_edges_cs: Vec<(f64, f64)>,
    /// `beams / aperture` when the beams are uniform.
    pub inv_beam_width: Option<f64>,
    /// The last range bin and the beam count, as integers of the fast path's lanes.
    pub last_bin: i32,
    pub beams: i32,
}

impl<'a> Clip<'a> {
    /// Returns the decisions' constants for `layout`.
    pub(crate) fn new(layout: &'a Layout) -> Self {
        let (sin_half_az, cos_half_az) = layout.azimuth_clip();
        let elevation = layout.elevation_clip();
        Clip {
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
            beam_edges_cs: layout.beam_edges.iter().map(|a| (a.cos(), a.sin())).collect(),
            inv_beam_width: layout.uniform_beam_width().map(|w| 1.0 / w),
            last_bin: i32::try_from(layout.range_bins - 1).expect("range bins are limited to 2^20"),
            beams: i32::try_from(layout.beams()).expect("beams are limited to 2^16"),
        }
    }

    /// Returns whether `p` (squared range `r2`) is in view, as the splat shader's `in_view`.
    /// Every test is evaluated (`&`, not `&&`), so there is no branch to mispredict per sample.
    #[inline(always)]
    pub(crate) fn in_view(&self, p: DVec3, r2: f64) -> bool {
        (r2 > 0.0)
            & (r2 >= self.range_min_sq)
            & (r2 <= self.range_max_sq)
            & (p.x * self.sin_half_az >= p.y.abs() * self.cos_half_az)
            & (!self.clip_elevation
                | ((p.x * p.x + p.y * p.y) * self.sin2_half_el >= p.z * p.z * self.cos2_half_el))
    }

    /// Returns the range bin of a point at range `r` (squared `r2`): a guess, then the guessed
    /// bin's squared edges. The edges are computed as [`Layout::range_edge`] does, so they equal
    /// [`Layout::range_edges_sq`], the splat shader's table. This is the fast path's one range-bin
    /// decision (lanes, runs, the plain loop of its tests), and in `Real` the shader's `range_bin`.
    #[inline(always)]
    pub(crate) fn range_bin(&self, r: f64, r2: f64) -> i32 {
        let l = self.layout;
        let last_bin = self.last_bin;
        let i = to_index(
            ((r - l.range_min) * self.inv_range_bin)
                .max(0.0)
                .min(f64::from(last_bin)),
        );
        let lower = l.range_min + f64::from(i) * l.range_bin_width;
        let upper = l.range_min + f64::from(i + 1) * l.range_bin_width;
        let down = (i > 0) & (r2 < lower * lower);
        let up = !down & (i < last_bin) & (r2 >= upper * upper);
        i - i32::from(down) + i32::from(up)
    }

    /// Returns whether `p` lies at or above (counter-clockwise of) beam edge `k`, as the shader's
    /// `at_or_above`. The test is `sin(az − e) · ρ = y cos e − x sin e ≥ 0`, valid within a
    /// quarter turn of the edge.
    #[inline(always)]
    pub(crate) fn at_or_above(&self, p: DVec3, k: usize) -> bool {
        let (c, s) = self.beam_edges_cs[k];
        p.y * c - p.x * s >= 0.0
    }

    /// Returns the beam of `p` at azimuth `az`: a first guess, then the side of the guessed beam's
    /// edges (the shader's `beam_of`).
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a saturating float-to-index conversion, clamped to the table right after"
    )]
    #[inline]
    pub(crate) fn beam(&self, p: DVec3, az: f64) -> usize {
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

    /// Returns the beam of `p`, walking at most [`WALK`] edges from beam `from`, or `None` when it
    /// lies farther. `from` is the fast path's guess or the previous sample's beam. The edge tests
    /// are those of [`Clip::beam`], so both give the same beam. The side test `sin(az − e) ≥ 0` is
    /// right only within half a turn of the edge, which every edge is when the aperture is at most
    /// 180°. Wider sonars, where an edge may lie behind the point, always get `None`.
    #[inline]
    pub(crate) fn beam_near(&self, p: DVec3, from: usize) -> Option<usize> {
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

// Balls instead of points: the masks' test, twin of may_meet_view in shaders/mask.wgsl.

/// Sonar 2's field of view as the balls of a mask are tested against it.
#[derive(Debug)]
pub(crate) struct View {
    pub(crate) layout: Layout,
    /// `tan` of the half elevation aperture, or `None` at 90° or more (no bound).
    tan_elevation: Option<f64>,
    /// `tan` of the half azimuth aperture, or `None` at 90° or more (no bound).
    tan_azimuth: Option<f64>,
}

impl View {
    /// Returns the view of sonar 2 (`target`, validated).
    pub(crate) fn of(target: &Sonar) -> View {
        let layout = Layout::of(target);
        let tan = |h: f64| (h < std::f64::consts::FRAC_PI_2 - RIGHT_ANGLE_SLACK).then(|| h.tan());
        View {
            tan_elevation: tan(layout.half_elevation),
            tan_azimuth: tan(layout.half_azimuth),
            layout,
        }
    }

    /// Returns false only when no point within `radius` of `q` lies in sonar 2's field of view.
    pub(crate) fn may_meet(&self, q: DVec3, radius: f64) -> bool {
        self.may_meet_at(q, q.length(), q.x.hypot(q.y), radius)
    }

    /// Returns [`View::may_meet`], given `q`'s length `d` and its distance `rho` from the z axis
    /// (`x.hypot(y)`). The caller computes them because it needs them again.
    #[inline]
    pub(crate) fn may_meet_at(&self, q: DVec3, d: f64, rho: f64, radius: f64) -> bool {
        let l = &self.layout;
        if d - radius > l.range_max || d + radius < l.range_min {
            return false;
        }
        let outside_elevation = self
            .tan_elevation
            .is_some_and(|t| q.z.abs() > t * (rho + radius) + radius);
        let outside_azimuth = self
            .tan_azimuth
            .is_some_and(|t| q.x + radius < 0.0 || q.y.abs() > t * (q.x + radius) + radius);
        !(outside_elevation || outside_azimuth)
    }
}

/// Returns `v` as an index. The caller clamps `v` to be finite and within `0..=i32::MAX`, so the
/// conversion is an exact truncation. Unlike `as`, it vectorises.
#[inline(always)]
pub(crate) fn to_index(v: f64) -> i32 {
    debug_assert!((0.0..=f64::from(i32::MAX)).contains(&v));
    // SAFETY: the callers clamp `v` to `[0, n]` with `n < 2^31` by `max` and `min`, which map
    // NaN to the bound, so `v` is finite and representable after truncation.
    unsafe { v.to_int_unchecked::<i32>() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Sonar;

    /// The guessed search gives the binary search's answer for every kind of azimuth: on the
    /// edges, next to them, outside the aperture, NaN, and for uneven beams.
    #[test]
    fn beams_from_a_guess_are_the_binary_searchs() {
        let uneven = Sonar::preset("holoocean-imaging")
            .unwrap()
            .with_beam_centres(&[-59.0, -40.0, -39.5, -10.0, 0.0, 0.25, 30.0, 58.0], None)
            .unwrap();
        for sonar in [
            Sonar::preset("paper-fls").unwrap(),
            Sonar::preset("oculus-m750d").unwrap(),
            uneven,
        ] {
            let l = Layout::of(&sonar);
            let mut probes: Vec<f64> = vec![f64::NAN, -10.0, 10.0, f64::INFINITY, f64::NEG_INFINITY];
            for &edge in &l.beam_edges {
                probes.extend([edge, edge.next_down(), edge.next_up(), edge - 1e-9, edge + 1e-9]);
            }
            probes.extend((0..10_000).map(|k| -1.2 + 2.4 * f64::from(k) / 10_000.0));
            for az in probes {
                let binary = l.beam_edges.partition_point(|&e| e <= az);
                assert_eq!(l.edges_at_or_below(az), binary, "{}: az {az}", sonar.name);
            }
        }
    }

    #[test]
    fn bins_follow_the_conventions_edges() {
        let l = Layout::of(&Sonar::preset("paper-sss").unwrap());
        assert_eq!(l.range_bin(0.1), 0);
        assert_eq!(l.range_bin(0.1 + 0.015), 1);
        assert_eq!(l.range_bin(30.0), 2989, "range_max goes to the last bin");
        let f = Layout::of(&Sonar::preset("paper-fls").unwrap());
        assert_eq!(f.beam(-(30f64).to_radians()), 0);
        assert_eq!(f.beam(0.0), 256, "0 is the lower edge of beam 256");
        assert_eq!(f.beam((30f64).to_radians()), 511, "+A/2 goes to the last beam");
    }

    /// The trigonometry-free range bin matches the definition wherever a point is not within a
    /// rounding of an edge: at bin centres, and a millionth of a bin inside each edge.
    #[test]
    fn the_two_range_bins_agree_away_from_edges() {
        for name in ["paper-sss", "paper-fls", "oculus-m750d"] {
            let l = Layout::of(&Sonar::preset(name).unwrap());
            let clip = Clip::new(&l);
            for i in 0..l.range_bins {
                let (lo, hi) = (l.range_edge(i), l.range_edge(i + 1));
                let inset = 1e-6 * l.range_bin_width;
                for r in [lo + inset, (lo + hi) / 2.0, hi - inset] {
                    let fast = usize::try_from(clip.range_bin(r, r * r)).unwrap();
                    assert_eq!(fast, l.range_bin(r), "{name}: r = {r} in bin {i}");
                    assert_eq!(fast, i, "{name}: r = {r}");
                }
            }
        }
    }
}
