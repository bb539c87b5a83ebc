//! Pose options shared by the sub-commands that take one pose.

use sonarproj::{RelativePose, Rotation};
use sonarproj_apps::io::text::numbers;
use sonarproj_apps::{Error, Result};

/// The relative pose: a rotation (roll/pitch/yaw, quaternion or matrix) and either a placement of
/// the feature in sonar 2 or an explicit translation.
#[derive(Debug, clap::Args)]
pub(super) struct PoseArgs {
    /// Roll (deg). R = (Rz(yaw) Ry(pitch) Rx(roll))ᵀ, as the paper's code.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    roll: f64,
    /// Pitch (deg).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pitch: f64,
    /// Yaw (deg).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    yaw: f64,
    /// Rotation R as a unit quaternion W,X,Y,Z (instead of roll/pitch/yaw).
    #[arg(long, value_name = "W,X,Y,Z", allow_hyphen_values = true,
          conflicts_with_all = ["roll", "pitch", "yaw", "matrix"])]
    quaternion: Option<String>,
    /// Rotation R as a 3x3 matrix, row-major: R11,R12,R13,R21,...,R33 (checked orthonormal).
    #[arg(long, value_name = "R11,...,R33", allow_hyphen_values = true,
          conflicts_with_all = ["roll", "pitch", "yaw"])]
    matrix: Option<String>,
    /// Placement: the feature appears at this range (m) in sonar 2; t = sph(place) − R·sph(feature).
    #[arg(long, value_name = "M", conflicts_with = "translation")]
    place_range: Option<f64>,
    /// Placement azimuth (deg) in sonar 2 (default 0).
    #[arg(
        long,
        value_name = "DEG",
        allow_negative_numbers = true,
        requires = "place_range"
    )]
    place_azimuth: Option<f64>,
    /// Placement elevation (deg) in sonar 2 (default 0).
    #[arg(
        long,
        value_name = "DEG",
        allow_negative_numbers = true,
        requires = "place_range"
    )]
    place_elevation: Option<f64>,
    /// Translation t (m) as X,Y,Z: p2 = R p1 + t.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    translation: Option<String>,
}

impl PoseArgs {
    /// Returns the rotation as given.
    fn rotation(&self) -> Result<Rotation> {
        if let Some(q) = &self.quaternion {
            return Ok(Rotation::QuaternionWxyz(numbers::<4>("--quaternion", q)?));
        }
        if let Some(m) = &self.matrix {
            let v = numbers::<9>("--matrix", m)?;
            return Ok(Rotation::Matrix([
                [v[0], v[1], v[2]],
                [v[3], v[4], v[5]],
                [v[6], v[7], v[8]],
            ]));
        }
        Ok(Rotation::RollPitchYaw {
            roll: self.roll,
            pitch: self.pitch,
            yaw: self.yaw,
        })
    }

    /// Returns whether the pose is a placement (`--place-*`).
    pub(super) fn is_placement(&self) -> bool {
        self.place_range.is_some()
    }

    /// Returns the pose. `feature` is the true point in sonar 1, `[range, azimuth, elevation]`
    /// (m, deg, deg), which the placement uses.
    pub(super) fn pose(&self, feature: [f64; 3]) -> Result<RelativePose> {
        let rotation = self.rotation()?;
        match (&self.translation, self.place_range) {
            (Some(t), _) => Ok(RelativePose::new(rotation, numbers::<3>("--translation", t)?)?),
            (None, Some(r)) => RelativePose::placement(
                rotation,
                feature,
                [
                    r,
                    self.place_azimuth.unwrap_or(0.0),
                    self.place_elevation.unwrap_or(0.0),
                ],
            )
            .map_err(|e| Error::from(e).in_context("--place")),
            (None, None) => Err(Error::input(
                "pose",
                "no translation given; give --place-range or --translation",
            )),
        }
    }
}
