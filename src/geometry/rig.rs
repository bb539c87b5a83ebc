//! Relative poses the way rigs describe them: each sonar's mounting in a common frame (the
//! vehicle's, or the world's for two vehicles) as a URDF or TF tree gives it, and the two
//! channels of a sidescan.
//!
//! **Frames.** This crate's sonar frames are FLU, ROS's convention (REP 103): +x along the
//! boresight (forward), +y to port (left), +z up. Marine and aerospace body frames are often
//! FRD: +x forward, +y starboard, +z down (NED in the world). [`Mount::from_frd`] converts a
//! mount whose common frame and sonar frame are both FRD.
//!
//! **Roll, pitch, yaw.** A URDF `<origin rpy="r p y">` (and ROS's `setRPY`) is the *active*
//! rotation `Rz(yaw) · Ry(pitch) · Rx(roll)` that turns the child frame's axes into the
//! parent's ([`Mount::from_rpy_deg`] takes degrees where URDF writes radians). The paper's
//! roll/pitch/yaw ([`Rotation::RollPitchYaw`](crate::geometry::pose::Rotation::RollPitchYaw))
//! is the *transposed* (passive) rotation. So a sonar 2 mounted with ROS angles `(r, p, y)` in
//! sonar 1's frame has the relative rotation
//! `Rotation::RollPitchYaw { roll: r, pitch: p, yaw: y }`, not its inverse.

use glam::{DMat3, DQuat, DVec3};

use crate::error::{Error, Result, finite_named};
use crate::geometry::pose::{QUATERNION_NORM_TOLERANCE, RelativePose};
use crate::geometry::sonar::{Sonar, SonarKind};

/// Where a sonar is mounted: the transform from the sonar's frame into the common frame,
/// `p_common = rotation · p_sonar + position` (TF's parent = common frame, child = sonar).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mount {
    /// Orientation of the sonar's axes in the common frame (unit quaternion; glam's order).
    rotation: DQuat,
    /// Position of the sonar's origin in the common frame (m).
    position: DVec3,
}

impl Mount {
    /// Returns the mount with the sonar's axes turned by `rotation` and its origin at `position`
    /// (m), both in the common frame (FLU).
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for a non-finite value or a quaternion whose norm is not 1 (within
    /// [`QUATERNION_NORM_TOLERANCE`]).
    pub fn new(rotation: DQuat, position: DVec3) -> Result<Mount> {
        for (name, v) in [
            ("x", rotation.x),
            ("y", rotation.y),
            ("z", rotation.z),
            ("w", rotation.w),
        ] {
            finite_named(|| format!("mount rotation {name}"), v)?;
        }
        for (name, v) in [("x", position.x), ("y", position.y), ("z", position.z)] {
            finite_named(|| format!("mount position {name}"), v)?;
        }
        let n = rotation.length();
        if (n - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
            return Err(Error::invalid(
                "mount rotation",
                format!("{rotation:?} (norm {n})"),
                format!("must be a unit quaternion, norm within {QUATERNION_NORM_TOLERANCE} of 1"),
            ));
        }
        // A quaternion already of norm 1 to a few ulp, as this constructor makes them, is kept
        // as is. So a mount rebuilt from its own rotation is the same mount, bit for bit.
        let rotation = if (n - 1.0).abs() <= 4.0 * f64::EPSILON {
            rotation
        } else {
            rotation.normalize()
        };
        Ok(Mount { rotation, position })
    }

    /// Returns the mount of a URDF joint `<origin xyz="…" rpy="…">`, with the angles in degrees.
    /// The sonar's axes are turned by `Rz(yaw) · Ry(pitch) · Rx(roll)` (fixed axes, roll applied
    /// first), and its origin is at `position` (m), in the common frame (FLU).
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for a non-finite value.
    pub fn from_rpy_deg(roll: f64, pitch: f64, yaw: f64, position: DVec3) -> Result<Mount> {
        for (name, v) in [("roll", roll), ("pitch", pitch), ("yaw", yaw)] {
            finite_named(|| format!("mount {name}"), v)?;
        }
        let q = DQuat::from_rotation_z(yaw.to_radians())
            * DQuat::from_rotation_y(pitch.to_radians())
            * DQuat::from_rotation_x(roll.to_radians());
        Mount::new(q, position)
    }

    /// Returns a mount given in FRD axes, in this crate's FLU axes. Both its frames are FRD: +x
    /// forward, +y starboard, +z down (NED for a world frame). Turning both 180° about x,
    /// `F = diag(1, −1, −1)`, makes the rotation `F R F` and the position `F p`.
    ///
    /// # Errors
    /// As [`Mount::new`].
    pub fn from_frd(rotation: DQuat, position: DVec3) -> Result<Mount> {
        let frd = Mount::new(rotation, position)?;
        let f = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
        let r = f * DMat3::from_quat(frd.rotation) * f;
        Mount::new(DQuat::from_mat3(&r), f * frd.position)
    }

    /// Returns the sonar's orientation in the common frame.
    #[must_use]
    pub fn rotation(&self) -> DQuat {
        self.rotation
    }

    /// Returns the sonar's position in the common frame (m).
    #[must_use]
    pub fn position(&self) -> DVec3 {
        self.position
    }

    /// Returns the point `p` of the sonar's frame in the common frame (m).
    #[must_use]
    pub fn to_common(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.position
    }

    /// Returns the point `p` of the common frame in the sonar's frame (m).
    #[must_use]
    pub fn to_sonar(&self, p: DVec3) -> DVec3 {
        self.rotation.inverse() * (p - self.position)
    }
}

/// Returns the pose of sonar 2 relative to sonar 1 (`p2 = R p1 + t`) from their mounts in one
/// common frame: `R = q2⁻¹ q1`, `t = q2⁻¹ (o1 − o2)`.
///
/// ```
/// use glam::DVec3;
/// use sonarproj::rig::{Mount, relative_pose};
///
/// // An FLS looking ahead, and a second one 0.5 m to port turned 20° toward port.
/// let first = Mount::from_rpy_deg(0.0, 0.0, 0.0, DVec3::ZERO)?;
/// let second = Mount::from_rpy_deg(0.0, 0.0, 20.0, DVec3::new(0.0, 0.5, 0.0))?;
/// let pose = relative_pose(&first, &second)?;
/// // Sonar 1's origin lies 0.5 m to sonar 2's starboard, turned into its axes.
/// let o1 = pose.apply(DVec3::ZERO);
/// assert!((o1.length() - 0.5).abs() < 1e-12 && o1.y < 0.0);
/// # Ok::<(), sonarproj::Error>(())
/// ```
///
/// # Errors
/// As [`RelativePose::validate`]. Mounts built by [`Mount`]'s constructors give none, since
/// their rotations are unit quaternions and positions finite. A difference of huge positions
/// may still overflow.
pub fn relative_pose(first: &Mount, second: &Mount) -> Result<RelativePose> {
    let inv = second.rotation.inverse();
    let pose = RelativePose {
        rotation: DMat3::from_quat(inv * first.rotation),
        translation: inv * (first.position - second.position),
    };
    pose.validate()?;
    Ok(pose)
}

/// The two channels of a sidescan: each an SSS sonar with its mount in the vehicle frame.
#[derive(Clone, Debug)]
pub struct SidescanPair {
    /// The port channel (looking to +y of the vehicle, tilted down; its fan across the track).
    pub port: (Sonar, Mount),
    /// The starboard channel (looking to −y of the vehicle, tilted down; its fan across the track).
    pub starboard: (Sonar, Mount),
}

/// Returns the port and starboard channels of a sidescan made of `channel` (an SSS).
/// They are mounted at `port_position` and `starboard_position` (m, vehicle frame, FLU), with
/// their boresights `depression` degrees below the horizontal, square to the track. The port
/// boresight is `(0, cos d, −sin d)` in the vehicle frame, the starboard one
/// `(0, −cos d, −sin d)`. Each channel's thin elevation aperture lies along the track (its +z
/// is the vehicle's +x), and its wide azimuth fan across it, in the vehicle's y–z plane. The
/// fan spans `d ± A/2` below the horizontal to each side. The port channel's +y points up and
/// out, the starboard one's down and in: mirror images. Only the fan's plane matters, since a
/// sidescan measures no azimuth.
///
/// # Errors
/// [`Error::InvalidValue`] when `channel` is not a valid SSS or a value is not finite.
pub fn sidescan_pair(
    channel: &Sonar,
    depression: f64,
    port_position: DVec3,
    starboard_position: DVec3,
) -> Result<SidescanPair> {
    channel.validate()?;
    if channel.kind != SonarKind::Sss {
        return Err(Error::invalid(
            format!("sonar {:?}: kind", channel.name),
            channel.kind.name(),
            "a sidescan pair needs an SSS channel",
        ));
    }
    if channel.two_sided() {
        return Err(Error::invalid(
            format!("sonar {:?}: sides", channel.name),
            2,
            "a channel is one side: give a one-sided SSS (each channel of the pair is one)",
        ));
    }
    finite_named(|| "depression".into(), depression)?;
    let named = |side: &str| Sonar {
        name: format!("{} ({side})", channel.name),
        ..channel.clone()
    };
    Ok(SidescanPair {
        port: (
            named("port"),
            // Roll first, so the fan (local y) goes across the track and the thin axis
            // (local z) along it. Then the depression, and the turn to the side.
            Mount::from_rpy_deg(90.0, depression, 90.0, port_position)?,
        ),
        starboard: (
            named("starboard"),
            Mount::from_rpy_deg(-90.0, depression, -90.0, starboard_position)?,
        ),
    })
}
