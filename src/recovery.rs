//! Recovering the coordinate a sonar loses, from a correspondence between two sonars
//! (docs/recover.md).
//!
//! An FLS measurement `(r, az)` leaves the elevation free: the point lies on the arc
//! `p(el) = sph(r, az, el)`. The other sonar's range `d` puts it on the sphere of radius `d`
//! around that sonar's origin `o`, in the arc's frame. On the arc, `|p(el) − o| = d` becomes
//! `a cos el + b sin el = c`, with `a = r (o_x cos az + o_y sin az)`, `b = r o_z` and
//! `c = (r² + |o|² − d²) / 2`. That gives zero, one (tangency) or two elevations, in closed
//! form ([`solve_arc`]).
//!
//! - FLS + SSS: the FLS arc (in sonar 1) against the SSS range sphere (around sonar 2).
//! - SSS + FLS: the FLS arc (in sonar 2) against the SSS range sphere (around sonar 1).
//! - FLS + FLS: the first arc against the second range. The second azimuth then ranks the
//!   candidates and tells which fit it.
//! - SSS + SSS: the two range spheres meet in a circle. Its parts inside both fields of view
//!   are returned as angular intervals, sampled, with their length.
//!
//! Sensitivity: with `g(el) = |p(el) − o| − d`, the recovered elevation moves by
//! `∂el/∂m = −(∂g/∂m)/(∂g/∂el)` for each measurement `m`. Here `∂g/∂el` is `d range / d el` of
//! the arc seen from the other sonar, whose integral over the arc is the range span. So a long
//! span means a large `|d range/d el|` and a small `σ_el = σ_range / |d range/d el|`.
//!
//! The sigmas are first order. On 3000 random paper-preset scenes (`tests/recover.rs`) at
//! σ_range = 0.2 mm and σ_azimuth = 0.005°, the true elevation fell within 1σ / 3σ in 67–69% /
//! 99.6–99.7% of trials (Gaussian: 68.3% / 99.73%). At 2 mm / 0.05° the arc's curvature brings
//! 3σ coverage down to about 99.45%. Near tangency (flagged) the sigmas do not hold.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::DVec3;
use serde::Serialize;

use crate::error::{Error, Param, Result, finite};

/// The range error of the two measurements (m), as the fronts name it (`--sigma-range`,
/// `sigma_range`).
pub const SIGMA_RANGE: Param = Param::new("sigma_range");
/// The azimuth error of the two measurements (deg), as the fronts name it.
pub const SIGMA_AZIMUTH: Param = Param::new("sigma_azimuth");
use crate::geometry::pose::{RelativePose, cart_to_sph, sph_to_cart};
use crate::geometry::sonar::{Sonar, SonarKind};

/// The relative tolerance for zero in the geometry (`a² + b²`, a vanishing circle) and for the
/// field-of-view test of a recovered point, which sits on a bound when the true point does.
pub const GEOMETRY_TOLERANCE: f64 = 1e-9;
/// The relative overshoot of `|c| / √(a² + b²)` past 1 taken as rounding of a tangency. A larger
/// one would merge two real solutions: `acos` spreads `1 − 1e-10` to ±1.4e-5 rad.
pub const TANGENCY_TOLERANCE: f64 = 1e-12;
/// Two solutions closer than this many sigmas are flagged [`Flag::NearTangent`]. On random
/// paper-preset scenes, 3 σ left 3-σ coverage at 99.43%, and 5 σ restores the Gaussian 99.7%.
pub const NEAR_TANGENT_SIGMAS: f64 = 5.0;
/// The default spacing (m) of the points returned along an SSS + SSS curve.
pub const DEFAULT_CURVE_STEP: f64 = 0.01;
pub use crate::limits::MAX_CURVE_POINTS;

/// What one sonar measured of the feature: range (m), and azimuth (deg) for an FLS.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    /// Range (m).
    pub range: f64,
    /// Azimuth (deg); `None` for an SSS.
    pub azimuth: Option<f64>,
}

/// The standard deviations of the measurements, the same for both sonars.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Sigmas {
    /// Of a range (m).
    pub range: f64,
    /// Of an azimuth (deg).
    pub azimuth: f64,
}

/// Something about the geometry a caller should know.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flag {
    /// The arc never reaches the other sonar's range (`|c| > √(a² + b²)`), or the two spheres do
    /// not meet.
    NoSolution,
    /// The arc only touches the range sphere (one solution; the elevation is ill-conditioned).
    Tangent,
    /// Two solutions within 5 σ of each other. Near tangency, first-order sigmas understate the
    /// error, and noise can remove both solutions.
    NearTangent,
    /// `a² + b² = 0`: the arc is centred on the other sonar's origin, or the spheres are
    /// concentric. Every point has the same range there, so nothing can be recovered.
    Degenerate,
    /// Solutions exist, but none lies inside both fields of view.
    NoneInView,
}

impl Flag {
    /// Returns the flag's name in JSON and CSV (`no_solution`, `tangent`, `near_tangent`,
    /// `degenerate`, `none_in_view`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Flag::NoSolution => "no_solution",
            Flag::Tangent => "tangent",
            Flag::NearTangent => "near_tangent",
            Flag::Degenerate => "degenerate",
            Flag::NoneInView => "none_in_view",
        }
    }
}

impl Serialize for Flag {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// One recovered point.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Candidate {
    /// 1 for the most plausible: inside both fields of view first, then (FLS + FLS) consistent
    /// with the second azimuth, then the smallest azimuth residual, then the smallest sigma.
    pub rank: usize,
    /// `[x, y, z]` (m) in sonar 1's frame.
    pub point_first: [f64; 3],
    /// `[x, y, z]` (m) in sonar 2's frame.
    pub point_second: [f64; 3],
    /// `[range (m), azimuth (deg), elevation (deg)]` in sonar 1.
    pub first: [f64; 3],
    /// `[range (m), azimuth (deg), elevation (deg)]` in sonar 2.
    pub second: [f64; 3],
    /// Inside both fields of view (bounds widened by [`GEOMETRY_TOLERANCE`]).
    pub in_view: bool,
    /// Which coordinate was recovered: `"first elevation"`, `"second elevation"` or
    /// `"curve"` (SSS + SSS).
    pub recovered: &'static str,
    /// `d range / d el` (m/deg): how fast the other sonar's range moves along the arc here.
    pub range_per_elevation: Option<f64>,
    /// Standard deviation (deg) of the recovered elevation, first order, when sigmas were given.
    pub sigma_elevation: Option<f64>,
    /// FLS + FLS: predicted minus measured second azimuth (deg).
    pub azimuth_residual: Option<f64>,
    /// FLS + FLS: whether the residual is within 3 σ (√2 σ_azimuth) when sigmas were given, else
    /// within 1e-6°.
    pub consistent: Option<bool>,
}

/// The part of the circle where two range spheres meet that both sonars see (SSS + SSS).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Curve {
    /// Centre of the circle (m), sonar 1's frame.
    pub center_first: [f64; 3],
    /// Unit normal of the circle's plane (toward sonar 2), sonar 1's frame.
    pub axis_first: [f64; 3],
    /// First in-plane unit vector: the circle is `center + radius (cos θ u + sin θ v)`.
    pub u_first: [f64; 3],
    /// Second in-plane unit vector, `axis × u`.
    pub v_first: [f64; 3],
    /// Radius (m).
    pub radius: f64,
    /// The visible arcs as `[θ_start, θ_end]` (deg, increasing, end may exceed 360).
    pub arcs: Vec<[f64; 2]>,
    /// Total length (m) of the visible arcs.
    pub length: f64,
    /// Spacing (m) of the returned points.
    pub step: f64,
}

/// Everything recovered from one correspondence.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Recovery {
    /// The candidates, best first (for SSS + SSS: points sampled along the visible curve).
    pub candidates: Vec<Candidate>,
    /// Flags on the geometry.
    pub flags: Vec<Flag>,
    /// SSS + SSS only: the visible part of the circle.
    pub curve: Option<Curve>,
}

/// Solutions of `a cos el + b sin el = c` for el in `[−π/2, π/2]`.
#[derive(Clone, Debug, PartialEq)]
pub enum ArcSolution {
    /// `a² + b² = 0` (relative to the scale).
    Degenerate,
    /// `|c| > √(a² + b²)`.
    None,
    /// One tangent solution.
    Tangent(f64),
    /// Zero, one or two transversal solutions (those with `|el| > π/2` are not on the arc).
    Points(Vec<f64>),
}

/// Returns the elevations (rad) where the arc `sph(r, az, ·)` is at distance `d` from `o`.
/// The scale `r·(r + |o| + d)` (m²) sets what counts as zero.
#[must_use]
pub fn solve_arc(r: f64, az: f64, o: DVec3, d: f64) -> ArcSolution {
    let a = r * (o.x * az.cos() + o.y * az.sin());
    let b = r * o.z;
    let c = (r * r + o.length_squared() - d * d) / 2.0;
    let rho = a.hypot(b);
    let scale = r * (r + o.length() + d);
    if rho <= GEOMETRY_TOLERANCE * scale {
        return ArcSolution::Degenerate;
    }
    let ratio = c / rho;
    let phi = b.atan2(a);
    let tol = TANGENCY_TOLERANCE * scale / rho;
    if ratio.abs() > 1.0 + tol {
        return ArcSolution::None;
    }
    if ratio.abs() >= 1.0 {
        let el = wrap(if ratio > 0.0 { phi } else { phi + PI });
        return ArcSolution::Tangent(el);
    }
    let delta = ratio.acos();
    let els = [wrap(phi - delta), wrap(phi + delta)]
        .into_iter()
        .filter(|e| e.abs() <= FRAC_PI_2)
        .collect();
    ArcSolution::Points(els)
}

/// Returns `x` wrapped into `(−π, π]`.
fn wrap(x: f64) -> f64 {
    let y = (x + PI).rem_euclid(TAU) - PI;
    if y <= -PI { y + TAU } else { y }
}

/// Returns whether `p` lies in `sonar`'s field of view, bounds widened by
/// [`GEOMETRY_TOLERANCE`] (relative).
fn sees(sonar: &Sonar, p: DVec3) -> bool {
    let (r, az, el) = cart_to_sph(p);
    let t = GEOMETRY_TOLERANCE;
    r > 0.0
        && r >= sonar.range_min * (1.0 - t)
        && r <= sonar.range_max * (1.0 + t)
        && az.abs() <= sonar.half_azimuth() + t
        && el.abs() <= sonar.half_elevation() + t
}

/// Returns `[range, azimuth (deg), elevation (deg)]` of `p`.
fn spherical_deg(p: DVec3) -> [f64; 3] {
    let (r, az, el) = cart_to_sph(p);
    [r, az.to_degrees(), el.to_degrees()]
}

/// Checks one observation against its sonar: finite, range inside, and an azimuth (inside the
/// aperture) exactly when the sonar is an FLS.
fn check(which: &str, sonar: &Sonar, obs: &Observation) -> Result<()> {
    let f = |c: &str| format!("{which} {c}");
    finite(&f("range"), obs.range)?;
    if obs.range < sonar.range_min || obs.range > sonar.range_max || obs.range <= 0.0 {
        return Err(Error::invalid(
            f("range"),
            obs.range,
            format!(
                "must be within sonar {:?}'s range [{}, {}] m (and > 0)",
                sonar.name, sonar.range_min, sonar.range_max
            ),
        ));
    }
    match (sonar.kind, obs.azimuth) {
        (SonarKind::Fls, None) => Err(Error::input(
            f("azimuth"),
            format!(
                "missing; sonar {:?} is an FLS, which measures one: give R,A (range, azimuth)",
                sonar.name
            ),
        )),
        (SonarKind::Sss, Some(a)) => Err(Error::invalid(
            f("azimuth"),
            a,
            format!(
                "sonar {:?} is an SSS, which measures no azimuth: give the range only",
                sonar.name
            ),
        )),
        (SonarKind::Fls, Some(a)) => {
            finite(&f("azimuth"), a)?;
            let h = sonar.azimuth_aperture / 2.0;
            if a.abs() > h {
                return Err(Error::invalid(
                    f("azimuth"),
                    a,
                    format!(
                        "must be within sonar {:?}'s azimuth aperture [-{h}, {h}] deg",
                        sonar.name
                    ),
                ));
            }
            Ok(())
        }
        (SonarKind::Sss, None) => Ok(()),
    }
}

/// Returns the candidates for a correspondence between `first` (sonar 1) and `second` (sonar 2)
/// under `pose`, with first-order sigmas of the recovered elevation when `sigmas` is given.
///
/// # Errors
/// [`Error::InvalidValue`] naming the observation, when a value is not finite or outside its
/// sonar's field of view, or an azimuth is given to an SSS or missing for an FLS. Also for
/// negative or non-finite sigmas.
pub fn recover(
    sonar1: &Sonar,
    sonar2: &Sonar,
    pose: &RelativePose,
    first: Observation,
    second: Observation,
    sigmas: Option<Sigmas>,
    curve_step: f64,
) -> Result<Recovery> {
    sonar1.validate().map_err(|e| e.in_context("sonar 1"))?;
    sonar2.validate().map_err(|e| e.in_context("sonar 2"))?;
    pose.validate()?;
    check("first", sonar1, &first)?;
    check("second", sonar2, &second)?;
    if let Some(s) = sigmas {
        use crate::limits::{MAX_SIGMA_ANGLE, MAX_SIGMA_RANGE};
        for (name, v, max, unit) in [
            (SIGMA_RANGE, s.range, MAX_SIGMA_RANGE, "m"),
            (SIGMA_AZIMUTH, s.azimuth, MAX_SIGMA_ANGLE, "deg"),
        ] {
            if !(0.0..=max).contains(&v) {
                return Err(Error::invalid(name, v, format!("must be in [0, {max}] {unit}")));
            }
        }
    }
    finite("curve step", curve_step)?;
    if curve_step <= 0.0 {
        return Err(Error::invalid("curve step", curve_step, "must be > 0 m"));
    }
    let ctx = Context {
        sonar1,
        sonar2,
        pose,
        sigmas,
    };
    let mut rec = match (first.azimuth, second.azimuth) {
        (Some(az1), az2) => ctx.arc_meets_sphere(ArcSide::First, first.range, az1, second.range, az2),
        (None, Some(az2)) => ctx.arc_meets_sphere(ArcSide::Second, second.range, az2, first.range, None),
        (None, None) => ctx.spheres(first.range, second.range, curve_step),
    };
    if !rec.candidates.is_empty() && !rec.candidates.iter().any(|c| c.in_view) {
        rec.flags.push(Flag::NoneInView);
    }
    Ok(rec)
}

/// Which sonar's FLS arc is intersected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ArcSide {
    First,
    Second,
}

/// The fixed inputs of one recovery.
struct Context<'a> {
    sonar1: &'a Sonar,
    sonar2: &'a Sonar,
    pose: &'a RelativePose,
    sigmas: Option<Sigmas>,
}

impl Context<'_> {
    /// Returns the point in both frames from a point in the arc's frame.
    fn both_frames(&self, side: ArcSide, p: DVec3) -> (DVec3, DVec3) {
        match side {
            ArcSide::First => (p, self.pose.apply(p)),
            ArcSide::Second => (self.pose.rotation.transpose() * (p - self.pose.translation), p),
        }
    }

    /// Returns the candidates where the FLS arc `(r, az)` on `side` meets the other sonar's range
    /// `d`. `az_other` is the other sonar's azimuth when it is an FLS too, used for ranking only.
    fn arc_meets_sphere(
        &self,
        side: ArcSide,
        r: f64,
        az_deg: f64,
        d: f64,
        az_other: Option<f64>,
    ) -> Recovery {
        let az = az_deg.to_radians();
        // The other sonar's origin, in the arc's frame.
        let o = match side {
            ArcSide::First => -(self.pose.rotation.transpose() * self.pose.translation),
            ArcSide::Second => self.pose.translation,
        };
        let mut flags = Vec::new();
        let els = match solve_arc(r, az, o, d) {
            ArcSolution::Degenerate => {
                flags.push(Flag::Degenerate);
                vec![]
            }
            ArcSolution::None => {
                flags.push(Flag::NoSolution);
                vec![]
            }
            ArcSolution::Tangent(el) => {
                flags.push(Flag::Tangent);
                if el.abs() <= FRAC_PI_2 { vec![el] } else { vec![] }
            }
            ArcSolution::Points(els) => els,
        };
        let recovered = match side {
            ArcSide::First => "first elevation",
            ArcSide::Second => "second elevation",
        };
        let mut candidates: Vec<Candidate> = els
            .into_iter()
            .map(|el| {
                let p = sph_to_cart(r, az, el);
                let (p1, p2) = self.both_frames(side, p);
                let (dg_del, sigma) = self.sensitivity(r, az, el, o);
                let residual = az_other.map(|a| {
                    let predicted = cart_to_sph(p2).1.to_degrees();
                    (predicted - a + 180.0).rem_euclid(360.0) - 180.0
                });
                let consistent = residual.map(|res| {
                    let tol = self
                        .sigmas
                        .map_or(1e-6, |s| (3.0 * s.azimuth * 2f64.sqrt()).max(1e-6));
                    res.abs() <= tol
                });
                Candidate {
                    rank: 0,
                    point_first: p1.to_array(),
                    point_second: p2.to_array(),
                    first: spherical_deg(p1),
                    second: spherical_deg(p2),
                    in_view: sees(self.sonar1, p1) && sees(self.sonar2, p2),
                    recovered,
                    range_per_elevation: Some(dg_del.to_radians()),
                    sigma_elevation: sigma,
                    azimuth_residual: residual,
                    consistent,
                }
            })
            .collect();
        if let [x, y] = candidates.as_slice() {
            let recovered = |c: &Candidate| match side {
                ArcSide::First => c.first[2],
                ArcSide::Second => c.second[2],
            };
            let apart = (recovered(x) - recovered(y)).abs();
            let sigma = x
                .sigma_elevation
                .unwrap_or(0.0)
                .max(y.sigma_elevation.unwrap_or(0.0));
            if apart < NEAR_TANGENT_SIGMAS * sigma {
                flags.push(Flag::NearTangent);
            }
        }
        rank(&mut candidates);
        Recovery {
            candidates,
            flags,
            curve: None,
        }
    }

    /// Returns `(∂g/∂el (m/rad), σ_el (deg))` at elevation `el` of the arc `(r, az)` against the
    /// sphere around `o`. σ needs sigmas, and is `None` where `∂g/∂el` vanishes (tangency).
    fn sensitivity(&self, r: f64, az: f64, el: f64, o: DVec3) -> (f64, Option<f64>) {
        let p = sph_to_cart(r, az, el);
        let n = (p - o).normalize_or_zero();
        let dp_del = DVec3::new(-r * el.sin() * az.cos(), -r * el.sin() * az.sin(), r * el.cos());
        let dp_daz = DVec3::new(-r * el.cos() * az.sin(), r * el.cos() * az.cos(), 0.0);
        let dp_dr = p / r;
        let dg_del = n.dot(dp_del);
        let sigma = self.sigmas.and_then(|s| {
            if dg_del.abs() <= GEOMETRY_TOLERANCE * r {
                return None;
            }
            // ∂el/∂m = −(∂g/∂m)/(∂g/∂el), and ∂g/∂d = −1 for the other sonar's range.
            let by_r = n.dot(dp_dr) / dg_del;
            let by_az = n.dot(dp_daz) / dg_del;
            let by_d = 1.0 / dg_del;
            let var = (by_r * s.range).powi(2)
                + (by_az * s.azimuth.to_radians()).powi(2)
                + (by_d * s.range).powi(2);
            // Empty where the slope is too small for a finite sigma.
            Some(var.sqrt().to_degrees()).filter(|s| s.is_finite())
        });
        (dg_del, sigma)
    }

    /// Returns the SSS + SSS recovery: the visible arcs of the circle where `|p| = r1` meets
    /// `|R p + t| = r2`.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a saturating float-to-count conversion, clamped to a bounded number of points"
    )]
    fn spheres(&self, r1: f64, r2: f64, step: f64) -> Recovery {
        let o = -(self.pose.rotation.transpose() * self.pose.translation);
        let dist = o.length();
        let scale = r1 + r2 + dist;
        let mut rec = Recovery {
            candidates: vec![],
            flags: vec![],
            curve: None,
        };
        if dist <= GEOMETRY_TOLERANCE * scale {
            rec.flags.push(if (r1 - r2).abs() <= GEOMETRY_TOLERANCE * scale {
                Flag::Degenerate
            } else {
                Flag::NoSolution
            });
            return rec;
        }
        let axis = o / dist;
        let x0 = (dist * dist + r1 * r1 - r2 * r2) / (2.0 * dist);
        let rho2 = r1 * r1 - x0 * x0;
        if rho2 < -GEOMETRY_TOLERANCE * scale * scale {
            rec.flags.push(Flag::NoSolution);
            return rec;
        }
        let radius = rho2.max(0.0).sqrt();
        let center = axis * x0;
        let u = axis.any_orthonormal_vector();
        let v = axis.cross(u);
        let at = |theta: f64| center + radius * (theta.cos() * u + theta.sin() * v);
        let visible = |theta: f64| {
            let p = at(theta);
            sees(self.sonar1, p) && sees(self.sonar2, self.pose.apply(p))
        };
        if radius <= GEOMETRY_TOLERANCE * scale {
            rec.flags.push(Flag::Tangent);
        }
        let arcs = visible_arcs(&visible, radius);
        let length = arcs.iter().fold(0.0, |sum, [a, b]| sum + radius * (b - a));
        let mut spacing = step;
        if length / spacing > MAX_CURVE_POINTS as f64 {
            spacing = length / MAX_CURVE_POINTS as f64;
        }
        for &[a, b] in &arcs {
            let n = ((radius * (b - a) / spacing).ceil() as usize).max(1);
            for k in 0..=n {
                let theta = a + (b - a) * k as f64 / n as f64;
                let p1 = at(theta);
                let p2 = self.pose.apply(p1);
                rec.candidates.push(Candidate {
                    rank: rec.candidates.len() + 1,
                    point_first: p1.to_array(),
                    point_second: p2.to_array(),
                    first: spherical_deg(p1),
                    second: spherical_deg(p2),
                    in_view: true,
                    recovered: "curve",
                    range_per_elevation: None,
                    sigma_elevation: None,
                    azimuth_residual: None,
                    consistent: None,
                });
            }
        }
        if arcs.is_empty() {
            rec.flags.push(Flag::NoneInView);
        }
        rec.curve = Some(Curve {
            center_first: center.to_array(),
            axis_first: axis.to_array(),
            u_first: u.to_array(),
            v_first: v.to_array(),
            radius,
            arcs: arcs
                .iter()
                .map(|[a, b]| [a.to_degrees(), b.to_degrees()])
                .collect(),
            length,
            step: spacing,
        });
        rec
    }
}

/// Returns the intervals `[a, b]` (rad, `0 <= a < 2π`, `b` may pass 2π) of the circle where
/// `visible` holds. It scans at 1 mm along the circle (3600 to 2·10⁶ steps), so a visible
/// piece shorter than a step can be missed. Each end is refined by bisection to 1e-12 rad.
#[expect(
    clippy::cast_possible_truncation,
    reason = "a saturating float-to-count conversion, clamped to a bounded number of points"
)]
fn visible_arcs(visible: &dyn Fn(f64) -> bool, radius: f64) -> Vec<[f64; 2]> {
    let n = ((TAU * radius / 1e-3).ceil() as usize).clamp(3600, 2_000_000);
    let h = TAU / n as f64;
    let flags: Vec<bool> = (0..n).map(|k| visible(k as f64 * h)).collect();
    let Some(start) = flags.iter().position(|&f| !f) else {
        return vec![[0.0, TAU]];
    };
    // The visibility changes between lo and lo + h. Returns the visible side of the change.
    let edge = |lo: f64, visible_at_lo: bool| {
        let (mut a, mut b) = (lo, lo + h);
        while b - a > 1e-12 {
            let mid = 0.5 * (a + b);
            if visible(mid) == visible_at_lo {
                a = mid
            } else {
                b = mid
            }
        }
        if visible_at_lo { a } else { b }
    };
    // One lap from an invisible sample back to it, so every run that opens also closes.
    let mut arcs = Vec::new();
    let mut open = None;
    for k in start + 1..=start + n {
        let lo = (k - 1) as f64 * h;
        match (flags[(k - 1) % n], flags[k % n]) {
            (false, true) => open = Some(edge(lo, false)),
            (true, false) => {
                if let Some(a) = open.take() {
                    arcs.push([a, edge(lo, true)]);
                }
            }
            _ => {}
        }
    }
    for arc in &mut arcs {
        let shift = (arc[0] / TAU).floor() * TAU;
        arc[0] -= shift;
        arc[1] -= shift;
    }
    arcs.sort_by(|a, b| a[0].total_cmp(&b[0]));
    arcs
}

/// Sorts `c` best first and numbers the ranks from 1.
fn rank(c: &mut [Candidate]) {
    c.sort_by(|a, b| {
        b.in_view
            .cmp(&a.in_view)
            .then(b.consistent.unwrap_or(true).cmp(&a.consistent.unwrap_or(true)))
            .then(
                a.azimuth_residual
                    .map_or(0.0, f64::abs)
                    .total_cmp(&b.azimuth_residual.map_or(0.0, f64::abs)),
            )
            .then(
                a.sigma_elevation
                    .unwrap_or(f64::INFINITY)
                    .total_cmp(&b.sigma_elevation.unwrap_or(f64::INFINITY)),
            )
    });
    for (i, cand) in c.iter_mut().enumerate() {
        cand.rank = i + 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_solutions_cover_every_case() {
        // An arc of radius 5 at az 0, the other origin 10 m ahead: distances vary along the arc.
        let o = DVec3::new(10.0, 0.0, 0.0);
        match solve_arc(5.0, 0.0, o, 5.5) {
            ArcSolution::Points(els) => {
                assert_eq!(els.len(), 2);
                for el in els {
                    let d = (sph_to_cart(5.0, 0.0, el) - o).length();
                    assert!((d - 5.5).abs() < 1e-12);
                }
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(solve_arc(5.0, 0.0, o, 20.0), ArcSolution::None);
        assert!(matches!(solve_arc(5.0, 0.0, o, 5.0), ArcSolution::Tangent(e) if e.abs() < 1e-12));
        // The other origin at the sonar's own origin, or on the normal of the arc's plane:
        // every elevation has the same distance.
        assert_eq!(solve_arc(5.0, 0.3, DVec3::ZERO, 5.0), ArcSolution::Degenerate);
        assert_eq!(
            solve_arc(5.0, 0.0, DVec3::new(0.0, 3.0, 0.0), 5.0),
            ArcSolution::Degenerate
        );
    }

    #[test]
    fn wrap_stays_in_range() {
        for x in [-7.0, -PI, -1.0, 0.0, PI, 4.0, 10.0] {
            let w = wrap(x);
            assert!(w > -PI && w <= PI, "{x} -> {w}");
            assert!(((w - x) / TAU - ((w - x) / TAU).round()).abs() < 1e-12);
        }
    }
}
