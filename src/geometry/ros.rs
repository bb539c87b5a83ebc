//! A driver's beam table as ROS's `marine_acoustic_msgs/ProjectedSonarImage` gives it: one
//! direction vector per beam and the centre of each range bin.
//!
//! That message's frame has **Z forward and X up**, so its Y (Z × X) is **starboard**. This
//! project's sonar frame has x forward, y port, z up. So a direction `(X, Y, Z)` of the message
//! is `(Z, −Y, X)` here: azimuth `atan2(−Y, Z)` (positive to port), elevation
//! `atan2(X, √(Y² + Z²))`. A one-dimensional imaging sonar's beams lie in the message's Y-Z
//! plane. The message may list them port to starboard or starboard to port, so the conversion
//! also says which column of the message's image each beam of the sonar is.

use super::sonar::{BeamLayout, Sonar, SonarKind};
use crate::error::{Error, Result};

/// The largest angle (deg) a beam may point out of the fan's plane. A two-dimensional array is
/// not an imaging sonar this project models.
const MAX_OUT_OF_PLANE_DEG: f64 = 0.5;

/// The relative tolerance within which the range bins' centres must be evenly spaced. The
/// message's ranges are `float32`, whose rounding is far below it.
const EVEN_SPACING: f64 = 1e-3;

/// The finest range bin (m) a message may give: a micrometre, far below any sonar's. So a table
/// of equal ranges is refused, not read as bins of no width.
const MIN_RANGE_STEP: f64 = 1e-6;

impl Sonar {
    /// Returns the FLS that a `ProjectedSonarImage` describes, and `columns`: beam `k` of the
    /// sonar is column `columns[k]` of the message's image, so `image[:, columns]` is the image in
    /// this project's layout. `beam_directions` are in the message frame (X up, Y starboard,
    /// Z forward), of any length. `ranges` (m) are the centres of evenly spaced bins.
    /// `elevation_aperture` (deg) is the message's `ping_info.tx_beamwidths`, in degrees. Beam
    /// edges lie halfway between the beams' azimuths.
    ///
    /// ```
    /// use sonarproj::Sonar;
    /// // Three beams listed port to starboard (Y, to starboard, increasing), bins of 10 cm.
    /// let (s, sin) = (0.5f64, 30f64.to_radians().sin());
    /// let dirs = [[0.0, -s, 0.866], [0.0, 0.0, 1.0], [0.0, sin, 30f64.to_radians().cos()]];
    /// let (sonar, columns) = Sonar::from_projected_sonar_image("ros", &dirs, &[0.05, 0.15, 0.25], 12.0)?;
    /// assert_eq!(columns, [2, 1, 0]); // beam 0 (starboard-most) is the message's last column
    /// assert_eq!((sonar.range_bins, sonar.range_min), (3, 0.0));
    /// # Ok::<(), sonarproj::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming `beam_directions[j]` or `ranges[i]`, for: a direction of zero
    /// length or not finite; a beam out of the fan's plane; azimuths that are not monotonic; fewer
    /// than two beams, or a table not centred on the boresight; fewer than two ranges, or ranges
    /// not evenly spaced, closer than a micrometre or below 0. Also every check of
    /// [`Sonar::validate`].
    pub fn from_projected_sonar_image(
        name: &str,
        beam_directions: &[[f64; 3]],
        ranges: &[f64],
        elevation_aperture: f64,
    ) -> Result<(Sonar, Vec<usize>)> {
        let mut azimuths = Vec::with_capacity(beam_directions.len());
        for (j, &[x, y, z]) in beam_directions.iter().enumerate() {
            let field = || format!("beam_directions[{j}]");
            let across = y.hypot(z);
            if !(x.is_finite() && y.is_finite() && z.is_finite()) || across == 0.0 && x == 0.0 {
                return Err(Error::invalid(
                    field(),
                    format!("({x}, {y}, {z})"),
                    "must be a finite, non-zero vector",
                ));
            }
            let elevation = x.atan2(across).to_degrees();
            if elevation.abs() > MAX_OUT_OF_PLANE_DEG {
                return Err(Error::invalid(
                    field(),
                    format!("({x}, {y}, {z})"),
                    format!(
                        "points {elevation:.2}° out of the fan's plane (X up): the beams of an imaging \
                         sonar lie in the message's Y-Z plane"
                    ),
                ));
            }
            azimuths.push((-y).atan2(z).to_degrees());
        }
        if azimuths.is_empty() {
            return Err(Error::invalid(
                "beam_directions",
                "[]",
                "must hold at least one beam",
            ));
        }
        let increasing = azimuths.windows(2).all(|w| w[1] > w[0]);
        let decreasing = azimuths.windows(2).all(|w| w[1] < w[0]);
        let columns: Vec<usize> = match (increasing, decreasing) {
            (true, _) => (0..azimuths.len()).collect(),
            (false, true) => (0..azimuths.len()).rev().collect(),
            _ => {
                return Err(Error::invalid(
                    "beam_directions",
                    format!("{} beams", azimuths.len()),
                    "their azimuths must go steadily one way (port to starboard or back)",
                ));
            }
        };
        let centres: Vec<f64> = columns.iter().map(|&j| azimuths[j]).collect();
        let aperture = super::beam_table::aperture_of_beam_centres(&centres)
            .map_err(|why| Error::invalid("beam_directions", format!("{} beams", centres.len()), why))?;
        let n = ranges.len();
        if n < 2 {
            return Err(Error::invalid(
                "ranges",
                format!("{n} values"),
                "must hold at least two bins",
            ));
        }
        #[expect(clippy::cast_precision_loss, reason = "a count of range bins")]
        let step = (ranges[n - 1] - ranges[0]) / (n - 1) as f64;
        if !(step.is_finite() && step >= MIN_RANGE_STEP) {
            return Err(Error::invalid(
                "ranges",
                format!("{} … {}", ranges[0], ranges[n - 1]),
                format!("must increase, by at least {MIN_RANGE_STEP} m a bin"),
            ));
        }
        for (i, &r) in ranges.iter().enumerate() {
            #[expect(clippy::cast_precision_loss, reason = "a count of range bins")]
            let want = ranges[0] + i as f64 * step;
            if !r.is_finite() || (r - want).abs() > EVEN_SPACING * step {
                return Err(Error::invalid(
                    format!("ranges[{i}]"),
                    r,
                    format!(
                        "must be evenly spaced: {want} here (bins of {step} m); uneven bins are not modelled"
                    ),
                ));
            }
        }
        let range_min = ranges[0] - step / 2.0;
        if range_min < -EVEN_SPACING * step {
            return Err(Error::invalid(
                "ranges[0]",
                ranges[0],
                format!(
                    "the first bin's centre must be at least half a bin ({}) from 0",
                    step / 2.0
                ),
            ));
        }
        let range_bins = u32::try_from(n).map_err(|_| Error::invalid("ranges", n, "too many bins"))?;
        let sonar = Sonar {
            name: name.to_string(),
            kind: SonarKind::Fls,
            range_min: range_min.max(0.0),
            range_max: ranges[n - 1] + step / 2.0,
            azimuth_aperture: 180.0,
            elevation_aperture,
            range_bins,
            beams: BeamLayout::Uniform { count: 1 },
        }
        .with_beam_centres(&centres, Some(aperture))
        .map_err(|e| e.in_context("ProjectedSonarImage"))?;
        Ok((sonar, columns))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Returns the message's direction of azimuth `az` (deg, positive to port) in the fan: Y is
    /// starboard, Z forward, X up.
    fn direction(az: f64) -> [f64; 3] {
        let a = az.to_radians();
        [0.0, -a.sin(), a.cos()]
    }

    #[test]
    fn either_order_of_beams_gives_the_sonar_and_its_columns() {
        let az = [-40.0, -22.0, -8.0, 0.0, 8.0, 22.0, 40.0];
        let ranges: Vec<f64> = (0..50).map(|i| 0.5 + 0.2 * f64::from(i)).collect();
        let starboard_first: Vec<[f64; 3]> = az.iter().map(|&a| direction(a)).collect();
        let port_first: Vec<[f64; 3]> = az.iter().rev().map(|&a| direction(a)).collect();
        let (a, ca) = Sonar::from_projected_sonar_image("a", &starboard_first, &ranges, 20.0).unwrap();
        let (b, cb) = Sonar::from_projected_sonar_image("a", &port_first, &ranges, 20.0).unwrap();
        assert_eq!(a, b);
        assert_eq!(ca, (0..7).collect::<Vec<_>>());
        assert_eq!(cb, (0..7).rev().collect::<Vec<_>>());
        assert!((a.range_min - 0.4).abs() < 1e-12 && (a.range_max - 10.4).abs() < 1e-12);
        let edges = a.beam_edges_deg();
        for (k, want) in az.iter().enumerate() {
            assert!(edges[k] < *want && *want < edges[k + 1], "beam {k}");
        }
    }

    #[test]
    fn bad_tables_are_refused_naming_the_entry() {
        let ranges = [0.05, 0.15, 0.25];
        let refused = |dirs: &[[f64; 3]], ranges: &[f64], words: &[&str]| {
            let e = Sonar::from_projected_sonar_image("x", dirs, ranges, 12.0)
                .unwrap_err()
                .to_string();
            for w in words {
                assert!(e.contains(w), "{e} lacks {w:?}");
            }
        };
        let fan = [direction(-10.0), direction(0.0), direction(10.0)];
        refused(
            &[direction(-10.0), [0.0, 0.0, 0.0], direction(10.0)],
            &ranges,
            &["beam_directions[1]", "non-zero"],
        );
        refused(
            &[direction(-10.0), [0.2, 0.0, 1.0], direction(10.0)],
            &ranges,
            &["beam_directions[1]", "out of the fan"],
        );
        refused(
            &[direction(-10.0), direction(10.0), direction(0.0)],
            &ranges,
            &["steadily one way"],
        );
        refused(&fan, &[0.05], &["at least two"]);
        refused(&fan, &[0.05, 0.15, 0.3], &["ranges[1]", "evenly spaced"]);
        refused(&fan, &[0.0, 0.1, 0.2], &["ranges[0]", "half a bin"]);
        refused(&fan, &[0.05, 0.05, 0.05], &["ranges", "at least 0.000001 m"]);
        refused(&[direction(0.0)], &ranges, &["beam_directions", "lone beam"]);
        refused(
            &[direction(-10.0), direction(0.0), direction(30.0)],
            &ranges,
            &["beam_directions", "not centred"],
        );
    }
}
