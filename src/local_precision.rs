//! How well a match pins the coordinate a sonar loses, at the feature's true point: the local
//! counterpart of the range span (docs/conventions.md).
//!
//! The span is the range extent of the whole clipped arc: how far along sonar 2's range a
//! match must be searched for. How precisely a match then fixes the lost coordinate depends on
//! the slope at the true point. Where the other sonar's range changes fast along the arc, a
//! range error moves the recovered elevation little. The model is the first-order one of
//! [`crate::recovery`] (docs/recover.md):
//!
//! - FLS sonar 1: its arc `p(el) = sph(r, az, el)` is seen by sonar 2 at range
//!   `d(el) = |R p(el) + t|`. Then `range_per_elevation = ∂d/∂el` (m/deg) at the true
//!   elevation, and `sigma_elevation = σ / |∂d/∂el|` (deg). That is the 1-σ of the elevation
//!   recovered from a match when sonar 2's range has an error σ (recovery's "first elevation").
//! - SSS sonar 1, FLS sonar 2: the FLS arc through the true point in sonar 2,
//!   `q(el) = sph(r2, az2, el)`, is seen by the sidescan at sonar 2's `t` (sonar 1's origin),
//!   at range `d(el) = |q(el) − t|`. The same two figures follow, with σ on the sidescan's
//!   range (recovery's "second elevation").
//! - Two sidescans: neither keeps an angle, so there is no elevation to pin (`None`).
//!
//! σ defaults to the range quantisation of the sonar whose range meets the arc: its bin width
//! Δ over √12, the standard deviation of a uniform error over one bin.

use std::f64::consts::PI;

use glam::DVec3;

use crate::error::{Error, Result, finite};
use crate::geometry::pose::{RelativePose, cart_to_sph, sph_to_cart};
use crate::geometry::sonar::{Sonar, SonarKind};
use crate::recovery::GEOMETRY_TOLERANCE;

/// The local precision at a feature's true point (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalPrecision {
    /// `∂d/∂el` (m/deg): how fast the other sonar's range moves along the arc at the true point.
    /// `None` for two sidescans.
    pub range_per_elevation: Option<f64>,
    /// The 1-σ (deg) of the elevation a match recovers, first order. `None` for two sidescans, and
    /// where the slope vanishes (the arc is tangent to the range sphere there).
    pub sigma_elevation: Option<f64>,
}

/// Returns the range error σ (m) the sigma is computed for when none is given: the bin width of
/// the sonar whose range meets the arc, over √12.
#[must_use]
pub fn default_sigma_range(source: &Sonar, target: &Sonar) -> f64 {
    let ranging = match source.kind {
        SonarKind::Fls => target,
        SonarKind::Sss => source,
    };
    ranging.range_bin_width() / 12f64.sqrt()
}

/// Returns the range error σ (m) to compute sigmas for: `sigma_range` checked, or
/// [`default_sigma_range`] when it is `None`.
///
/// # Errors
/// [`Error::InvalidValue`] naming `sigma_range` when it is not finite and positive.
pub fn resolve_sigma_range(source: &Sonar, target: &Sonar, sigma_range: Option<f64>) -> Result<f64> {
    match sigma_range {
        Some(s) => {
            finite("sigma_range", s)?;
            if s <= 0.0 || s > crate::limits::MAX_SIGMA_RANGE {
                return Err(Error::invalid(
                    "sigma_range",
                    s,
                    format!("must be > 0 m and at most {} m", crate::limits::MAX_SIGMA_RANGE),
                ));
            }
            Ok(s)
        }
        None => Ok(default_sigma_range(source, target)),
    }
}

/// Returns the local precision of a match of the feature whose true point in `source` is
/// `true_point` = `[range, azimuth, elevation]` (m, deg, deg), `target` placed by `pose`, for a
/// range error `sigma` (m: [`resolve_sigma_range`]).
#[must_use]
pub fn local_precision(
    source: &Sonar,
    target: &Sonar,
    true_point: [f64; 3],
    pose: &RelativePose,
    sigma: f64,
) -> LocalPrecision {
    TruePoint::new(source, target, true_point).at(pose, sigma)
}

/// A feature's true point, with what [`local_precision`] computes from it alone. For many poses
/// of one feature (a sweep's rotations), it gives the same figures, bit for bit, without the
/// feature's trigonometry each pose.
#[derive(Clone, Copy, Debug)]
pub struct TruePoint {
    kinds: (SonarKind, SonarKind),
    /// Range (m).
    r: f64,
    /// The point in sonar 1's frame.
    p: DVec3,
    /// `∂p/∂el` along the arc (m/rad).
    dp: DVec3,
}

impl TruePoint {
    /// Returns the true point `true_point` = `[range, azimuth, elevation]` (m, deg, deg) of a
    /// feature measured by `source`, matched in `target`.
    #[must_use]
    pub fn new(source: &Sonar, target: &Sonar, true_point: [f64; 3]) -> TruePoint {
        let r = true_point[0];
        let [_, az, el] = true_point.map(f64::to_radians);
        TruePoint {
            kinds: (source.kind, target.kind),
            r,
            p: sph_to_cart(r, az, el),
            dp: arc_tangent(r, az, el),
        }
    }

    /// Returns the local precision of a match with the target placed by `pose`, for a range
    /// error `sigma` (m): [`local_precision`]'s.
    #[must_use]
    pub fn at(&self, pose: &RelativePose, sigma: f64) -> LocalPrecision {
        self.seen_from(&Viewpoint::of(pose), sigma)
    }

    /// Returns [`TruePoint::at`] the pose of `viewpoint`, bit for bit, without the pose's own
    /// arithmetic: for many true points seen from one pose.
    #[must_use]
    pub fn seen_from(&self, viewpoint: &Viewpoint, sigma: f64) -> LocalPrecision {
        let pose = &viewpoint.pose;
        // The slope of the other sonar's range along the arc at the true point, and the arc's
        // radius.
        let (slope, arc_r) = match self.kinds {
            (SonarKind::Sss, SonarKind::Sss) => return LocalPrecision::default(),
            (SonarKind::Fls, _) => (
                (self.p - viewpoint.origin).normalize_or_zero().dot(self.dp),
                self.r,
            ),
            (SonarKind::Sss, SonarKind::Fls) => {
                let (r2, az2, el2) = cart_to_sph(pose.apply(self.p));
                (slope_per_radian(r2, az2, el2, pose.translation), r2)
            }
        };
        let per_degree = slope * PI / 180.0;
        // Empty where the slope is too small for a finite sigma (a point all but at an origin).
        let sigma_elevation = (slope.abs() > GEOMETRY_TOLERANCE * arc_r)
            .then(|| sigma / per_degree.abs())
            .filter(|s| s.is_finite());
        LocalPrecision {
            range_per_elevation: Some(per_degree),
            sigma_elevation,
        }
    }
}

/// A relative pose with what [`TruePoint::seen_from`] needs of it alone, computed once for the
/// many true points one pose sees.
#[derive(Clone, Copy, Debug)]
pub struct Viewpoint {
    pose: RelativePose,
    /// Sonar 2's origin in sonar 1's frame: `−Rᵀ t`.
    origin: DVec3,
}

impl Viewpoint {
    /// Returns the viewpoint of `pose`.
    #[must_use]
    pub fn of(pose: &RelativePose) -> Viewpoint {
        Viewpoint {
            pose: *pose,
            origin: -(pose.rotation.transpose() * pose.translation),
        }
    }
}

/// Returns `∂p/∂el` (m/rad) on the arc `p(el) = sph(r, az, el)` at `el`.
fn arc_tangent(r: f64, az: f64, el: f64) -> DVec3 {
    DVec3::new(-r * el.sin() * az.cos(), -r * el.sin() * az.sin(), r * el.cos())
}

/// Returns `∂|p(el) − o|/∂el` (m/rad) on the arc `p(el) = sph(r, az, el)` at `el`.
fn slope_per_radian(r: f64, az: f64, el: f64, o: DVec3) -> f64 {
    (sph_to_cart(r, az, el) - o)
        .normalize_or_zero()
        .dot(arc_tangent(r, az, el))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pose::Rotation;

    /// Returns `d(el)` of the module documentation by brute force: the arc's point moved to the
    /// other sonar and its range there.
    fn range_along(source: &Sonar, target: &Sonar, point: [f64; 3], pose: &RelativePose, del: f64) -> f64 {
        let r = point[0];
        let [_, az, el] = point.map(f64::to_radians);
        match source.kind {
            SonarKind::Fls => pose.apply(sph_to_cart(r, az, el + del)).length(),
            SonarKind::Sss => {
                let _ = target;
                let (r2, az2, el2) = cart_to_sph(pose.apply(sph_to_cart(r, az, el)));
                (sph_to_cart(r2, az2, el2 + del) - pose.translation).length()
            }
        }
    }

    #[test]
    fn the_slope_is_the_finite_difference_of_the_other_range() {
        let rotation = Rotation::RollPitchYaw {
            roll: 30.0,
            pitch: 70.0,
            yaw: 20.0,
        };
        for (a, b, point, second) in [
            ("paper-fls", "paper-sss", [5.0, 10.0, 3.0], [12.0, 20.0, 0.1]),
            ("paper-fls", "paper-fls", [5.0, -7.0, -2.0], [6.0, 5.0, 4.0]),
            ("paper-sss", "paper-fls", [15.0, 20.0, 0.1], [5.0, 3.0, 2.0]),
        ] {
            let (source, target) = (Sonar::preset(a).unwrap(), Sonar::preset(b).unwrap());
            let pose = RelativePose::placement(rotation, point, second).unwrap();
            let lp = local_precision(&source, &target, point, &pose, 0.01);
            let h = 1e-6f64.to_radians();
            let fd = (range_along(&source, &target, point, &pose, h)
                - range_along(&source, &target, point, &pose, -h))
                / (2.0 * h)
                * PI
                / 180.0;
            let slope = lp.range_per_elevation.unwrap();
            assert!(
                (slope - fd).abs() < 1e-6 * fd.abs().max(1e-3),
                "{a}->{b}: {slope} vs {fd}"
            );
            let sigma = lp.sigma_elevation.unwrap();
            assert!((sigma * slope.abs() - 0.01).abs() < 1e-12, "{a}->{b}");
        }
    }

    #[test]
    fn two_sidescans_have_no_elevation_and_the_default_sigma_is_a_bin_over_root_12() {
        let sss = Sonar::preset("paper-sss").unwrap();
        let pose = RelativePose::new(
            Rotation::Matrix([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
            [1.0, 0.0, 0.0],
        )
        .unwrap();
        let lp = local_precision(&sss, &sss, [10.0, 0.0, 0.0], &pose, 0.01);
        assert_eq!(lp, LocalPrecision::default());
        let fls = Sonar::preset("paper-fls").unwrap();
        let sigma = resolve_sigma_range(&fls, &sss, None).unwrap();
        assert!((sigma - 0.01 / 12f64.sqrt()).abs() < 1e-12);
        for bad in [-1.0, 0.0, f64::NAN, 1.000_001e6, 1e308] {
            let e = resolve_sigma_range(&fls, &sss, Some(bad)).unwrap_err();
            assert!(e.to_string().contains("sigma_range"), "{e}");
        }
        assert_eq!(resolve_sigma_range(&fls, &sss, Some(1e6)).unwrap(), 1e6);
    }

    #[test]
    fn a_sigma_is_finite_or_empty_however_near_the_origin() {
        // A point a hair from sonar 1's origin: the slope is tiny, the largest range error
        // allowed would make the sigma overflow; it is empty instead, never infinite.
        let (fls, sss) = (
            Sonar::preset("paper-fls").unwrap(),
            Sonar::preset("paper-sss").unwrap(),
        );
        let pose = RelativePose::new(
            Rotation::RollPitchYaw {
                roll: 0.0,
                pitch: 90.0,
                yaw: 0.0,
            },
            [0.0, 0.0, 5.0],
        )
        .unwrap();
        for r in [1e-306, 1e-304, 1e-302, 1e-300, 1e-200, 1e-12, 1.0] {
            let lp = local_precision(&fls, &sss, [r, 10.0, 3.0], &pose, 1e6);
            assert!(lp.sigma_elevation.is_none_or(f64::is_finite), "{r}: {lp:?}");
        }
        assert!(
            local_precision(&fls, &sss, [1.0, 10.0, 3.0], &pose, 1e6)
                .sigma_elevation
                .is_some()
        );
    }
}
