//! A sweep's grid of nine axes (feature, placement or translation, rotation), read from a sweep
//! file. Pose `i` is decoded in mixed radix, the last axis fastest.

use sonarproj::geometry::sonar::Sonar;
use sonarproj::projection::PoseGrid;
use sonarproj::projection::poses::item_of;

use crate::error::Result;
use crate::io::pose_columns::{FEATURE_COLUMNS, PLACE_COLUMNS, RPY_COLUMNS, TRANSLATION_COLUMNS};
use crate::io::toml_keys::ConfigFile;

/// One grid axis: a column of the output and the values it takes.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The output column (also the batch CSV column).
    pub column: &'static str,
    /// The values, in order.
    pub values: Vec<f64>,
}

/// A full grid: every combination of the axes' values, the last axis fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// The axes in column order: range, azimuth, elevation, then place_range, place_azimuth,
    /// place_elevation (or tx, ty, tz), then roll, pitch, yaw.
    pub axes: Vec<Axis>,
    /// Whether the translation is a placement (else tx, ty, tz).
    pub placement: bool,
}

impl Grid {
    /// Returns the axis values of pose `i` (mixed radix, the last axis fastest).
    #[must_use]
    pub fn values(&self, i: u64) -> Vec<f64> {
        let mut out = vec![0.0; self.axes.len()];
        self.values_into(i, &mut out);
        out
    }

    /// Writes the axis values of pose `i` into `out` (one per axis), as [`Grid::values`].
    #[expect(
        clippy::cast_possible_truncation,
        reason = "grid sizes are checked against MAX_POSES before they are used as indices"
    )]
    pub fn values_into(&self, mut i: u64, out: &mut [f64]) {
        for (k, a) in self.axes.iter().enumerate().rev() {
            let n = a.values.len() as u64;
            out[k] = a.values[(i % n) as usize];
            i /= n;
        }
    }

    /// Returns the engine's grid of these axes, checked against sonar 1 `source`.
    ///
    /// # Errors
    /// As [`PoseGrid::new`].
    pub fn pose_grid(&self, source: &Sonar) -> Result<PoseGrid> {
        let axes: [Vec<f64>; 9] = std::array::from_fn(|k| self.axes[k].values.clone());
        Ok(PoseGrid::new(axes, self.placement, source)?)
    }

    /// Returns the batch item for axis values `v`, in [`Grid::axes`] order.
    /// It uses the engine's grid pose, and the first three values as the feature's true point.
    pub(crate) fn item(&self, source: &Sonar, v: &[f64]) -> Result<sonarproj::BatchItem> {
        let v: [f64; 9] = std::array::from_fn(|k| v[k]);
        Ok(sonarproj::BatchItem {
            true_point: Some([v[0], v[1], v[2]]),
            ..item_of(source, &v, self.placement)?
        })
    }

    /// Returns the grid of sweep file `f`, read from the sections of `top`.
    /// The feature is checked against sonar 1 `source`.
    pub(crate) fn read(f: ConfigFile<'_>, top: &toml::Table, source: &Sonar) -> Result<Grid> {
        let rae = ["range", "azimuth", "elevation"];
        let feature = section(f, top, "feature", &rae)?;
        let place = section(f, top, "place", &rae)?;
        let translation = section(f, top, "translation", &["x", "y", "z"])?;
        let rotation = section(f, top, "rotation", &["roll", "pitch", "yaw"])?;
        if feature.is_none() {
            return Err(f.missing(
                "feature",
                "required: [feature] with range (or poses = \"FILE.csv\")",
            ));
        }
        let [range, azimuth, elevation] = FEATURE_COLUMNS;
        let mut axes = vec![
            axis(f, feature, "feature", "range", range, true)?,
            axis(f, feature, "feature", "azimuth", azimuth, false)?,
            axis(f, feature, "feature", "elevation", elevation, false)?,
        ];
        let placement = match (place, translation) {
            (Some(_), Some(_)) => {
                return Err(f.error("translation", "given", "give [place] or [translation], not both"));
            }
            (None, None) => {
                return Err(f.missing("place", "required: [place] with range, or [translation]"));
            }
            (Some(_), None) => {
                let [place_range, place_azimuth, place_elevation] = PLACE_COLUMNS;
                let a = axis(f, place, "place", "range", place_range, true)?;
                if let Some(r) = a.values.iter().find(|r| **r < 0.0) {
                    return Err(f.error("place.range", r, "must be >= 0 m"));
                }
                axes.extend([
                    a,
                    axis(f, place, "place", "azimuth", place_azimuth, false)?,
                    axis(f, place, "place", "elevation", place_elevation, false)?,
                ]);
                true
            }
            (None, Some(_)) => {
                let [tx, ty, tz] = TRANSLATION_COLUMNS;
                axes.extend([
                    axis(f, translation, "translation", "x", tx, false)?,
                    axis(f, translation, "translation", "y", ty, false)?,
                    axis(f, translation, "translation", "z", tz, false)?,
                ]);
                false
            }
        };
        for name in RPY_COLUMNS {
            axes.push(axis(f, rotation, "rotation", name, name, false)?);
        }
        // Every feature point must lie in sonar 1's field of view. Bounds are per coordinate,
        // so checking each value with the others at their first values covers every combination.
        for (k, a) in axes[..3].iter().enumerate() {
            for &v in &a.values {
                let mut p = [axes[0].values[0], axes[1].values[0], axes[2].values[0]];
                p[k] = v;
                source
                    .check_point("feature", p[0], p[1], p[2])
                    .map_err(|e| e.in_context(f.field(&format!("feature.{}", rae[k]))))?;
            }
        }
        let grid = Grid { axes, placement };
        // The engine's checks too (a placement's reach), with errors in the file's terms.
        grid.pose_grid(source)
            .map_err(|e| e.in_context(format!("sweep file {:?}", f.path())))?;
        Ok(grid)
    }
}

/// Returns the table under `key` (empty when missing), checking its keys against `allowed`.
fn section<'a>(
    f: ConfigFile<'_>,
    top: &'a toml::Table,
    key: &str,
    allowed: &[&str],
) -> Result<Option<&'a toml::Table>> {
    match top.get(key) {
        None => Ok(None),
        Some(toml::Value::Table(t)) => {
            f.only(&format!("{key}."), t, allowed)?;
            Ok(Some(t))
        }
        Some(other) => Err(f.error(key, other, format!("must be a table ([{key}])"))),
    }
}

/// Returns the axis `column` read from `table.name` (0 when left out, an error when `required`).
fn axis(
    f: ConfigFile<'_>,
    table: Option<&toml::Table>,
    prefix: &str,
    name: &str,
    column: &'static str,
    required: bool,
) -> Result<Axis> {
    let key = format!("{prefix}.{name}");
    let values = match table.and_then(|t| t.get(name)) {
        Some(v) => f.values(&key, v)?,
        None if required => return Err(f.missing(&key, "required")),
        None => vec![0.0],
    };
    Ok(Axis { column, values })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A section that is not a table is refused, named as the file writes it.
    #[test]
    fn a_section_must_be_a_table() {
        let top: toml::Table = "feature = 5\n".parse().unwrap();
        let source = Sonar::preset("paper-fls").unwrap();
        let e = Grid::read(ConfigFile::sweep("s.toml"), &top, &source)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "sweep file \"s.toml\": feature = 5 is invalid: must be a table ([feature])"
        );
    }
}
