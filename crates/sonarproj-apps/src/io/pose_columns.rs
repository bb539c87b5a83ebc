//! The columns of a pose table, and the projection one row asks for. Every front reads them
//! the same way: a batch CSV, a sweep's pose list, the Python package's dict of arrays.
//!
//! - The feature: `range` (m) always. `azimuth` (deg) for an FLS sonar 1 or a placement, and
//!   `elevation` (deg) for a placement. With `tx,ty,tz` these are optional; when given, they
//!   complete the feature's true point, which the local precision columns need.
//! - The rotation `R` of `p2 = R p1 + t`, one of:
//!   - `roll,pitch,yaw` (deg), in the paper's convention `R = (Rz Ry Rx)ᵀ`;
//!   - a unit quaternion `qw,qx,qy,qz` of `R` itself (Hamilton, scalar first, norm within 1e-6);
//!   - the matrix `r11,r12,…,r33` (row-major, orthonormal within 1e-6, determinant +1).
//! - The translation: `place_range,place_azimuth,place_elevation`, where the true point appears
//!   in sonar 2 (m, deg, deg), or `tx,ty,tz` (m).

use sonarproj::geometry::pose::{RelativePose, Rotation};
use sonarproj::geometry::sonar::{Sonar, SonarKind};
use sonarproj::projection::BatchItem;
use sonarproj::projection::poses::{PLACEMENT_AXES, TRANSLATION_AXES};
use sonarproj::sampling::Measurement;

// A grid's axes name the pose columns ([`PLACEMENT_AXES`], [`TRANSLATION_AXES`]). The other
// forms of the rotation are the tables' own.

/// The feature's columns: its measurement and true point in sonar 1.
pub const FEATURE_COLUMNS: [&str; 3] = [PLACEMENT_AXES[0], PLACEMENT_AXES[1], PLACEMENT_AXES[2]];
/// The rotation as roll, pitch, yaw (deg).
pub const RPY_COLUMNS: [&str; 3] = [PLACEMENT_AXES[6], PLACEMENT_AXES[7], PLACEMENT_AXES[8]];
/// The rotation as a unit quaternion, scalar first.
pub const QUATERNION_COLUMNS: [&str; 4] = ["qw", "qx", "qy", "qz"];
/// The rotation as a matrix, row-major.
pub const MATRIX_COLUMNS: [&str; 9] = ["r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33"];
/// Placement columns: one way to give the translation.
pub const PLACE_COLUMNS: [&str; 3] = [PLACEMENT_AXES[3], PLACEMENT_AXES[4], PLACEMENT_AXES[5]];
/// Translation columns: the other way.
pub const TRANSLATION_COLUMNS: [&str; 3] = [TRANSLATION_AXES[3], TRANSLATION_AXES[4], TRANSLATION_AXES[5]];

/// Returns pose column `c` in words with its unit, for a figure's axis: `place_range` is
/// "feature range in sonar 2 (m)", `roll` "roll (deg)". A column of no known meaning is
/// returned as it is.
#[must_use]
pub fn column_words(c: &str) -> String {
    let words = match c {
        "range" => "feature range in sonar 1 (m)",
        "azimuth" => "feature azimuth in sonar 1 (deg)",
        "elevation" => "feature elevation in sonar 1 (deg)",
        "place_range" => "feature range in sonar 2 (m)",
        "place_azimuth" => "feature azimuth in sonar 2 (deg)",
        "place_elevation" => "feature elevation in sonar 2 (deg)",
        "roll" => "roll (deg)",
        "pitch" => "pitch (deg)",
        "yaw" => "yaw (deg)",
        "tx" => "translation x (m)",
        "ty" => "translation y (m)",
        "tz" => "translation z (m)",
        other => other,
    };
    words.to_string()
}

/// How a table gives the rotation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RotationForm {
    /// `roll,pitch,yaw`.
    RollPitchYaw,
    /// `qw,qx,qy,qz`.
    Quaternion,
    /// `r11..r33`.
    Matrix,
}

impl RotationForm {
    /// Returns the form's columns.
    #[must_use]
    pub fn columns(self) -> &'static [&'static str] {
        match self {
            RotationForm::RollPitchYaw => &RPY_COLUMNS,
            RotationForm::Quaternion => &QUATERNION_COLUMNS,
            RotationForm::Matrix => &MATRIX_COLUMNS,
        }
    }
}

/// Which columns a pose table has, checked once against sonar 1's kind (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PoseColumns {
    /// How the rotation is given.
    pub rotation: RotationForm,
    /// Whether the translation is a placement (else `tx,ty,tz`).
    pub placement: bool,
    /// Whether the table has an `azimuth` column.
    pub azimuth: bool,
    /// Whether the table has an `elevation` column.
    pub elevation: bool,
}

/// Returns every column a pose table may have.
#[must_use]
pub fn allowed_columns() -> Vec<&'static str> {
    [
        &FEATURE_COLUMNS[..],
        &RPY_COLUMNS,
        &QUATERNION_COLUMNS,
        &MATRIX_COLUMNS,
        &PLACE_COLUMNS,
        &TRANSLATION_COLUMNS,
    ]
    .concat()
}

/// Returns the description of the columns a pose table takes, for error messages.
#[must_use]
pub fn expected_columns() -> String {
    format!(
        "range (and azimuth for an imaging sonar 1), a rotation as {} or {} or {}, and either {} \
         (with azimuth,elevation) or {}",
        RPY_COLUMNS.join(","),
        QUATERNION_COLUMNS.join(","),
        MATRIX_COLUMNS.join(","),
        PLACE_COLUMNS.join(","),
        TRANSLATION_COLUMNS.join(",")
    )
}

impl PoseColumns {
    /// Returns the reading of a table whose columns are `names` for a sonar 1 of kind `source`.
    ///
    /// # Errors
    /// A message for the front's header error, naming the missing, mixed or incomplete columns.
    /// Unknown columns are the front's to refuse ([`allowed_columns`]).
    pub fn of(names: &[&str], source: SonarKind) -> Result<Self, String> {
        let has = |c: &str| names.contains(&c);
        let count = |cols: &[&str]| cols.iter().filter(|c| has(c)).count();
        let forms = [
            RotationForm::RollPitchYaw,
            RotationForm::Quaternion,
            RotationForm::Matrix,
        ];
        let given: Vec<RotationForm> = forms.into_iter().filter(|f| count(f.columns()) > 0).collect();
        let rotation = match given.as_slice() {
            [] => {
                return Err(format!(
                    "missing rotation: give {} or {} or {}",
                    RPY_COLUMNS.join(","),
                    QUATERNION_COLUMNS.join(","),
                    MATRIX_COLUMNS.join(",")
                ));
            }
            [one] => *one,
            several => {
                let list: Vec<String> = several.iter().map(|f| f.columns().join(",")).collect();
                return Err(format!("give one rotation, not {}", list.join(" and ")));
            }
        };
        let placement = match (count(&PLACE_COLUMNS), count(&TRANSLATION_COLUMNS)) {
            (0, 0) => {
                return Err(format!(
                    "missing translation: give {} or {}",
                    PLACE_COLUMNS.join(","),
                    TRANSLATION_COLUMNS.join(",")
                ));
            }
            (p, t) if p > 0 && t > 0 => {
                return Err(format!(
                    "give either {} or {}, not both",
                    PLACE_COLUMNS.join(","),
                    TRANSLATION_COLUMNS.join(",")
                ));
            }
            (p, _) => p > 0,
        };
        let mut required: Vec<&str> = vec!["range"];
        if placement || source == SonarKind::Fls {
            required.push("azimuth");
        }
        if placement {
            required.push("elevation");
            required.extend(PLACE_COLUMNS);
        } else {
            required.extend(TRANSLATION_COLUMNS);
        }
        required.extend(rotation.columns());
        let absent: Vec<&str> = required.iter().copied().filter(|c| !has(c)).collect();
        if !absent.is_empty() {
            let why = if placement && absent.iter().any(|c| *c == "azimuth" || *c == "elevation") {
                " (a placement needs the feature's true point)"
            } else {
                ""
            };
            return Err(format!("missing column(s) {}{why}", absent.join(",")));
        }
        Ok(PoseColumns {
            rotation,
            placement,
            azimuth: has("azimuth"),
            elevation: has("elevation"),
        })
    }

    /// Returns the columns a row is read from, in the order [`PoseColumns::item`] takes them: the
    /// feature's that are present, then the rotation's and the translation's.
    #[must_use]
    pub fn columns(&self) -> Vec<&'static str> {
        let mut out = vec!["range"];
        if self.azimuth {
            out.push("azimuth");
        }
        if self.elevation {
            out.push("elevation");
        }
        out.extend(self.rotation.columns());
        out.extend(if self.placement {
            PLACE_COLUMNS
        } else {
            TRANSLATION_COLUMNS
        });
        out
    }

    /// Returns the rotation of a row whose values `v` are in [`PoseColumns::columns`] order.
    fn rotation(&self, v: &[f64]) -> Rotation {
        let r = &v[self.feature_len()..];
        match self.rotation {
            RotationForm::RollPitchYaw => Rotation::RollPitchYaw {
                roll: r[0],
                pitch: r[1],
                yaw: r[2],
            },
            RotationForm::Quaternion => Rotation::QuaternionWxyz([r[0], r[1], r[2], r[3]]),
            RotationForm::Matrix => {
                Rotation::Matrix([[r[0], r[1], r[2]], [r[3], r[4], r[5]], [r[6], r[7], r[8]]])
            }
        }
    }

    /// Returns the number of feature columns present.
    fn feature_len(&self) -> usize {
        1 + usize::from(self.azimuth) + usize::from(self.elevation)
    }

    /// Returns the feature's true point `[range, azimuth, elevation]` (m, deg, deg) of a row, when
    /// the table gives `elevation`. `v` is in [`PoseColumns::columns`] order. Without `azimuth`
    /// (a sidescan sonar 1), the point is at azimuth 0, as [`PoseColumns::item`] places it.
    #[must_use]
    pub fn true_point(&self, v: &[f64]) -> Option<[f64; 3]> {
        let azimuth = if self.azimuth { v[1] } else { 0.0 };
        self.elevation
            .then(|| [v[0], azimuth, v[usize::from(self.azimuth) + 1]])
    }

    /// Returns the projection one row asks for, checked against sonar 1 (`source`), with the
    /// feature's true point when the row gives it. `v` is in [`PoseColumns::columns`] order.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] for a feature outside sonar 1's field of view or an
    /// invalid pose, such as a quaternion off unit norm or a matrix that is not a rotation.
    pub fn item(&self, source: &Sonar, v: &[f64]) -> sonarproj::Result<BatchItem> {
        let range = v[0];
        let azimuth = if self.azimuth { v[1] } else { 0.0 };
        let elevation = if self.elevation {
            v[usize::from(self.azimuth) + 1]
        } else {
            0.0
        };
        if self.elevation {
            source.check_point("feature", range, azimuth, elevation)?;
        }
        let measurement = Measurement::of(source, range, azimuth)?;
        let rotation = self.rotation(v);
        let t = &v[v.len() - 3..];
        let pose = if self.placement {
            RelativePose::placement(rotation, [range, azimuth, elevation], [t[0], t[1], t[2]])?
        } else {
            RelativePose::new(rotation, [t[0], t[1], t[2]])?
        };
        Ok(BatchItem {
            true_point: self.true_point(v),
            measurement,
            pose,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rotation_form_reads_and_the_mixtures_are_refused() {
        let fls = SonarKind::Fls;
        let rpy = PoseColumns::of(
            &[
                "range",
                "azimuth",
                "elevation",
                "roll",
                "pitch",
                "yaw",
                "tx",
                "ty",
                "tz",
            ],
            fls,
        )
        .unwrap();
        assert_eq!(rpy.rotation, RotationForm::RollPitchYaw);
        let q = PoseColumns::of(
            &["range", "azimuth", "qw", "qx", "qy", "qz", "tx", "ty", "tz"],
            fls,
        )
        .unwrap();
        assert_eq!((q.rotation, q.elevation), (RotationForm::Quaternion, false));
        let mut m: Vec<&str> = vec!["range", "azimuth"];
        m.extend(MATRIX_COLUMNS);
        m.extend(TRANSLATION_COLUMNS);
        assert_eq!(PoseColumns::of(&m, fls).unwrap().rotation, RotationForm::Matrix);
        let mixed = PoseColumns::of(
            &[
                "range", "azimuth", "roll", "pitch", "yaw", "qw", "qx", "qy", "qz", "tx", "ty", "tz",
            ],
            fls,
        );
        assert!(mixed.unwrap_err().contains("give one rotation"));
        let partial = PoseColumns::of(&["range", "azimuth", "qw", "qx", "qy", "tx", "ty", "tz"], fls);
        assert!(partial.unwrap_err().contains("missing column(s) qz"));
        // A placement needs the true point. A translation does not, and then a sidescan sonar 1
        // needs no azimuth.
        let place = PoseColumns::of(
            &[
                "range",
                "azimuth",
                "roll",
                "pitch",
                "yaw",
                "place_range",
                "place_azimuth",
                "place_elevation",
            ],
            fls,
        );
        assert!(place.unwrap_err().contains("elevation"));
        let sss = PoseColumns::of(
            &["range", "roll", "pitch", "yaw", "tx", "ty", "tz"],
            SonarKind::Sss,
        )
        .unwrap();
        assert_eq!(sss.columns(), ["range", "roll", "pitch", "yaw", "tx", "ty", "tz"]);
        assert!(PoseColumns::of(&["range", "roll", "pitch", "yaw", "tx", "ty", "tz"], fls).is_err());
    }

    /// Every axis a sweep grid can vary is named in words with its unit on a figure.
    #[test]
    fn every_grid_axis_has_words_and_a_unit() {
        use sonarproj::projection::poses::{PLACEMENT_AXES, TRANSLATION_AXES};
        for c in PLACEMENT_AXES.iter().chain(&TRANSLATION_AXES) {
            let words = super::column_words(c);
            assert!(!words.contains('_'), "{c}: {words}");
            assert!(
                words.ends_with(" (m)") || words.ends_with(" (deg)"),
                "{c}: {words}"
            );
        }
        assert_eq!(super::column_words("place_range"), "feature range in sonar 2 (m)");
    }
}
