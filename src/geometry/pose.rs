//! Relative poses between two sonars (docs/conventions.md): `p2 = R p1 + t`.

use glam::{DMat3, DQuat, DVec3};

use crate::error::{Error, Result, finite, finite_named};
use crate::limits::MAX_TRANSLATION;

/// Largest deviation from orthonormality (`max |RᵀR − I|`) accepted for a given matrix.
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-6;
/// Largest deviation of a quaternion's norm from 1 that is accepted (then it is normalised).
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-6;

/// A rigid transform mapping sonar-1 coordinates to sonar-2 coordinates: `p2 = R p1 + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelativePose {
    /// The rotation `R` (orthonormal, det +1).
    pub rotation: DMat3,
    /// The translation `t` in metres.
    pub translation: DVec3,
}

/// A rotation as given by a user, before it becomes a matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rotation {
    /// Roll, pitch, yaw in degrees, the paper's convention: `R = (Rz(yaw) Ry(pitch) Rx(roll))ᵀ`.
    RollPitchYaw {
        /// Roll (deg), about x.
        roll: f64,
        /// Pitch (deg), about y.
        pitch: f64,
        /// Yaw (deg), about z.
        yaw: f64,
    },
    /// Unit quaternion of the rotation `R` itself, in the order `[w, x, y, z]` of the command
    /// line's `--quaternion W,X,Y,Z`. glam, ROS and scipy write `x, y, z, w`: for those, use
    /// [`Rotation::Quat`] with a glam quaternion.
    QuaternionWxyz([f64; 4]),
    /// Unit quaternion of the rotation `R` itself, as glam's `DQuat` (built with
    /// `DQuat::from_xyzw(x, y, z, w)`).
    Quat(DQuat),
    /// The 3×3 matrix `R`, row-major.
    Matrix([[f64; 3]; 3]),
}

/// Returns the Cartesian point of spherical `(r, az, el)` (radians; docs/conventions.md).
#[must_use]
pub fn sph_to_cart(r: f64, az: f64, el: f64) -> DVec3 {
    DVec3::new(r * el.cos() * az.cos(), r * el.cos() * az.sin(), r * el.sin())
}

/// Returns `(r, az, el)` (radians) of a Cartesian point: `r = |p|`, `az = atan2(y, x)`,
/// `el = asin(z / r)` (docs/conventions.md); `el = 0` at the origin.
#[must_use]
pub fn cart_to_sph(p: DVec3) -> (f64, f64, f64) {
    let r = p.length();
    let el = if r > 0.0 {
        (p.z / r).clamp(-1.0, 1.0).asin()
    } else {
        0.0
    };
    (r, p.y.atan2(p.x), el)
}

/// Returns the matrix with the given rows.
fn from_rows(r: [[f64; 3]; 3]) -> DMat3 {
    DMat3::from_cols_array_2d(&r).transpose()
}

impl Rotation {
    /// Returns the rotation matrix `R`, checking the input.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for non-finite numbers, a quaternion whose norm is not 1 (within
    /// [`QUATERNION_NORM_TOLERANCE`]), or a matrix that is not orthonormal with det +1 (within
    /// [`ORTHONORMAL_TOLERANCE`]).
    pub fn to_matrix(&self) -> Result<DMat3> {
        match *self {
            Rotation::RollPitchYaw { roll, pitch, yaw } => {
                let (roll, pitch, yaw) = (
                    finite("roll", roll)?.to_radians(),
                    finite("pitch", pitch)?.to_radians(),
                    finite("yaw", yaw)?.to_radians(),
                );
                // R = (Rz Ry Rx)ᵀ: the passive rotation (docs/conventions.md).
                let (rx, ry, rz) = (
                    DMat3::from_rotation_x(roll),
                    DMat3::from_rotation_y(pitch),
                    DMat3::from_rotation_z(yaw),
                );
                Ok((rz * ry * rx).transpose())
            }
            Rotation::Quat(q) => Rotation::QuaternionWxyz([q.w, q.x, q.y, q.z]).to_matrix(),
            Rotation::QuaternionWxyz(q) => {
                for (i, name) in ["quaternion w", "quaternion x", "quaternion y", "quaternion z"]
                    .iter()
                    .enumerate()
                {
                    finite(name, q[i])?;
                }
                let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
                if (n - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                    return Err(Error::invalid(
                        "quaternion",
                        format!("{q:?} (norm {n})"),
                        format!(
                            "must be a unit quaternion (w, x, y, z), norm within {QUATERNION_NORM_TOLERANCE} of 1"
                        ),
                    ));
                }
                let [w, x, y, z] = q.map(|v| v / n);
                Ok(DMat3::from_quat(DQuat::from_xyzw(x, y, z, w)))
            }
            Rotation::Matrix(rows) => {
                for (i, row) in rows.iter().enumerate() {
                    for (j, v) in row.iter().enumerate() {
                        finite_named(|| format!("matrix r{}{}", i + 1, j + 1), *v)?;
                    }
                }
                let m = from_rows(rows);
                let dev = orthonormal_deviation(m);
                if dev > ORTHONORMAL_TOLERANCE {
                    return Err(Error::invalid(
                        "matrix",
                        format!("{rows:?}"),
                        format!(
                            "must be orthonormal (max |RᵀR − I| = {dev:.3e} exceeds {ORTHONORMAL_TOLERANCE})"
                        ),
                    ));
                }
                let det = m.determinant();
                if det < 0.0 {
                    return Err(Error::invalid(
                        "matrix",
                        format!("{rows:?}"),
                        format!("must be a rotation with determinant +1 (it is {det:.6}: a reflection)"),
                    ));
                }
                Ok(m)
            }
        }
    }
}

/// Returns `v` when it is a usable translation component (m): finite and at most
/// [`MAX_TRANSLATION`] in size.
///
/// # Errors
/// [`Error::InvalidValue`] naming `field`.
fn translation_component(field: &str, v: f64) -> Result<f64> {
    finite(field, v)?;
    if v.abs() > MAX_TRANSLATION {
        return Err(Error::invalid(
            field,
            v,
            format!(
                "must be within ±{MAX_TRANSLATION} m (two sonars of 10 km range share nothing that far apart)"
            ),
        ));
    }
    Ok(v)
}

impl RelativePose {
    /// Returns the pose with rotation `rotation` and translation `t` (m): a `DVec3` or an
    /// `[x, y, z]` array.
    ///
    /// # Errors
    /// As [`Rotation::to_matrix`], and for a non-finite translation.
    pub fn new(rotation: Rotation, t: impl Into<DVec3>) -> Result<Self> {
        let t: DVec3 = t.into();
        for (i, c) in ["tx", "ty", "tz"].iter().enumerate() {
            translation_component(c, t[i])?;
        }
        Ok(RelativePose {
            rotation: rotation.to_matrix()?,
            translation: t,
        })
    }

    /// Returns the placement pose (docs/conventions.md): the feature's true point `sph(first)` in
    /// sonar 1 appears at `sph(second)` in sonar 2, so `t = sph(second) − R sph(first)`. Both are
    /// `[range (m), azimuth (deg), elevation (deg)]`.
    ///
    /// ```
    /// use sonarproj::{RelativePose, Rotation};
    /// use sonarproj::geometry::sph_to_cart;
    ///
    /// let yaw = Rotation::RollPitchYaw { roll: 0.0, pitch: 0.0, yaw: 30.0 };
    /// let pose = RelativePose::placement(yaw, [5.0, 0.0, 0.0], [8.0, 0.0, 0.0])?;
    /// // The feature's point 5 m ahead of sonar 1 is 8 m ahead of sonar 2.
    /// let p2 = pose.apply(sph_to_cart(5.0, 0.0, 0.0));
    /// assert!((p2 - sph_to_cart(8.0, 0.0, 0.0)).length() < 1e-12);
    /// # Ok::<(), sonarproj::Error>(())
    /// ```
    ///
    /// # Errors
    /// As [`Rotation::to_matrix`], and for non-finite or negative ranges, or ranges so large
    /// that the translation overflows.
    pub fn placement(rotation: Rotation, first: [f64; 3], second: [f64; 3]) -> Result<Self> {
        let rotation = rotation.to_matrix()?;
        let p1 = spherical_point("feature", first)?;
        let p2 = spherical_point("place", second)?;
        let translation = p2 - rotation * p1;
        if !(translation.is_finite() && translation.abs().max_element() <= MAX_TRANSLATION) {
            let (field, value) = if second[0] >= first[0] {
                ("place range", second[0])
            } else {
                ("feature range", first[0])
            };
            return Err(Error::invalid(
                field,
                value,
                format!(
                    "too large: the translation of the placement must be at most \
                     {MAX_TRANSLATION} m per axis"
                ),
            ));
        }
        Ok(RelativePose {
            rotation,
            translation,
        })
    }

    /// Returns `Ok(())` when the pose is usable: a finite translation, and a rotation matrix that
    /// is orthonormal with determinant +1 (within [`ORTHONORMAL_TOLERANCE`]). The constructors give
    /// such poses. Every entry point that takes a pose checks it again, since the fields are public
    /// and a pose may be built by hand.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming `pose tx` … or the `pose matrix` and what is wrong with it.
    pub fn validate(&self) -> Result<()> {
        // The common case first, without building anything, since batches check every pose. The
        // slow path below finds and names what is wrong.
        let m = self.rotation;
        if self.translation.is_finite()
            && self.translation.abs().max_element() <= MAX_TRANSLATION
            && m.is_finite()
            && orthonormal_deviation(m) <= ORTHONORMAL_TOLERANCE
            && m.determinant() >= 0.0
        {
            return Ok(());
        }
        for (i, c) in ["tx", "ty", "tz"].iter().enumerate() {
            translation_component(&format!("pose {c}"), self.translation[i])?;
        }
        let rows = [0, 1, 2].map(|i| m.row(i).to_array());
        Rotation::Matrix(rows)
            .to_matrix()
            .map_err(|e| e.in_context("pose"))?;
        Ok(())
    }

    /// Returns `R p + t`.
    #[must_use]
    pub fn apply(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }
}

/// Returns `max |RᵀR − I|` over the entries: 0 for an orthonormal `m`.
fn orthonormal_deviation(m: DMat3) -> f64 {
    (m.transpose() * m - DMat3::IDENTITY)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, v| a.max(v.abs()))
}

/// Returns the Cartesian point of `[range, azimuth, elevation]` (m, deg, deg), checked.
fn spherical_point(what: &str, v: [f64; 3]) -> Result<DVec3> {
    let r = finite_named(|| format!("{what} range"), v[0])?;
    let az = finite_named(|| format!("{what} azimuth"), v[1])?;
    let el = finite_named(|| format!("{what} elevation"), v[2])?;
    if r < 0.0 {
        return Err(Error::invalid(format!("{what} range"), r, "must be >= 0 m"));
    }
    Ok(sph_to_cart(r, az.to_radians(), el.to_radians()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DMat3, b: DMat3) -> bool {
        (a - b).to_cols_array().iter().all(|v| v.abs() < 1e-12)
    }

    #[test]
    fn rpy_is_the_transpose_of_the_active_zyx_rotation() {
        // yaw 90°: active Rz(90) maps x to y; the passive pose maps sonar-1 +y to sonar-2 +x.
        let r = Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 0.0,
            yaw: 90.0,
        }
        .to_matrix()
        .unwrap();
        assert!((r * DVec3::Y - DVec3::X).length() < 1e-12);
        // pitch 90°: active Ry(90) maps x to -z; the passive pose maps sonar-1 +x to sonar-2 +z.
        let r = Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 90.0,
            yaw: 0.0,
        }
        .to_matrix()
        .unwrap();
        assert!((r * DVec3::X - DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn quaternion_and_matrix_agree_with_rpy() {
        // The passive yaw of 90° is an active rotation of -90° about z: q = (cos45, 0, 0, -sin45).
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let q = Rotation::QuaternionWxyz([s, 0.0, 0.0, -s]).to_matrix().unwrap();
        let rpy = Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 0.0,
            yaw: 90.0,
        }
        .to_matrix()
        .unwrap();
        assert!(close(q, rpy));
        let m = Rotation::Matrix([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
            .to_matrix()
            .unwrap();
        assert!(close(m, rpy));
    }

    #[test]
    fn bad_rotations_are_rejected() {
        let e = Rotation::Matrix([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
            .to_matrix()
            .unwrap_err();
        assert!(e.to_string().contains("determinant"), "{e}");
        let e = Rotation::Matrix([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
            .to_matrix()
            .unwrap_err();
        assert!(e.to_string().contains("orthonormal"), "{e}");
        let e = Rotation::QuaternionWxyz([1.0, 1.0, 0.0, 0.0])
            .to_matrix()
            .unwrap_err();
        assert!(e.to_string().contains("unit quaternion"), "{e}");
        let e = Rotation::RollPitchYaw {
            roll: f64::NAN,
            pitch: 0.0,
            yaw: 0.0,
        }
        .to_matrix()
        .unwrap_err();
        assert!(e.to_string().contains("roll = NaN"), "{e}");
    }

    #[test]
    fn placement_puts_the_feature_where_asked() {
        let rot = Rotation::RollPitchYaw {
            roll: 10.0,
            pitch: -20.0,
            yaw: 30.0,
        };
        let pose = RelativePose::placement(rot, [5.0, 10.0, 2.0], [7.0, -5.0, 0.1]).unwrap();
        let p2 = pose.apply(sph_to_cart(5.0, 10f64.to_radians(), 2f64.to_radians()));
        let (r, az, el) = cart_to_sph(p2);
        assert!((r - 7.0).abs() < 1e-12);
        assert!((az.to_degrees() + 5.0).abs() < 1e-10);
        assert!((el.to_degrees() - 0.1).abs() < 1e-10);
    }
}
