//! Sonars: kind, field of view and data layout (docs/sonars.md), the presets, and sonar TOML files.

use serde::Deserialize;

use crate::error::{Error, Result, finite, finite_named};

/// The two sonar kinds: what a sonar keeps of a 3D point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SonarKind {
    /// Forward-looking (imaging) sonar: keeps range and azimuth, loses elevation.
    Fls,
    /// Sidescan sonar: keeps range only.
    Sss,
}

impl SonarKind {
    /// Returns the lowercase name used in files and on the command line (`fls`, `sss`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            SonarKind::Fls => "fls",
            SonarKind::Sss => "sss",
        }
    }
}

/// How the azimuth aperture of an FLS image is split into beams.
#[derive(Clone, Debug, PartialEq)]
pub enum BeamLayout {
    /// `count` beams of equal width over the aperture. An SSS has one, or two for a two-sided
    /// sidescan: one fan over port and starboard, its data one row of both sides
    /// ([`Sonar::two_sided`]).
    Uniform {
        /// Number of beams.
        count: u32,
    },
    /// Explicit beam edges in degrees, increasing, from `-aperture/2` to `+aperture/2`
    /// (`beams + 1` values), for sonars whose beams are not uniform.
    Edges(Vec<f64>),
}

/// A sonar: kind, field of view (metres, degrees) and the layout of its data.
///
/// Build it from a preset ([`Sonar::preset`]) or a TOML file ([`Sonar::from_toml_file`]), or
/// directly and then check it with [`Sonar::validate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Sonar {
    /// A name for messages and reports (preset name or file name).
    pub name: String,
    /// FLS or SSS.
    pub kind: SonarKind,
    /// Minimum range (m), `0 <= range_min < range_max`.
    pub range_min: f64,
    /// Maximum range (m).
    pub range_max: f64,
    /// Full azimuth aperture (deg), in `(0, 360]`, centred on the boresight.
    pub azimuth_aperture: f64,
    /// Full elevation aperture (deg), in `(0, 180]`, centred on the boresight.
    pub elevation_aperture: f64,
    /// Number of uniform range bins over `[range_min, range_max]`.
    pub range_bins: u32,
    /// Beams of the FLS image. An SSS has `Uniform { count: 1 }`, or `Uniform { count: 2 }` for a
    /// two-sided sidescan (starboard then port: [`Sonar::two_sided`]).
    pub beams: BeamLayout,
}

pub use crate::limits::{MAX_BEAMS, MAX_PIXELS, MAX_RANGE, MAX_RANGE_BINS, MAX_SONAR_FILE_BYTES};

impl Sonar {
    /// Returns the sonar when every field holds (docs/sonars.md). Use it to check a sonar built by
    /// hand.
    ///
    /// ```
    /// use sonarproj::{BeamLayout, Sonar, SonarKind};
    /// let sonar = Sonar {
    ///     name: "my-fls".into(),
    ///     kind: SonarKind::Fls,
    ///     range_min: 0.5,
    ///     range_max: 30.0,
    ///     azimuth_aperture: 130.0,
    ///     elevation_aperture: 20.0,
    ///     range_bins: 512,
    ///     beams: BeamLayout::Uniform { count: 256 },
    /// };
    /// assert!(sonar.clone().validated().is_ok());
    /// let broken = Sonar { range_bins: 0, ..sonar };
    /// let e = broken.validated().unwrap_err().to_string();
    /// assert!(e.contains("range_bins = 0"), "{e}");
    /// ```
    ///
    /// # Errors
    /// As [`Sonar::validate`].
    pub fn validated(self) -> Result<Sonar> {
        self.validate()?;
        Ok(self)
    }

    /// Returns `Ok(())` when every field holds (docs/sonars.md).
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the sonar, the field, its value and the allowed range.
    pub fn validate(&self) -> Result<()> {
        let ctx = format!("sonar {:?}", self.name);
        let f = |field: &str| format!("{ctx}: {field}");
        finite(&f("range_min"), self.range_min)?;
        finite(&f("range_max"), self.range_max)?;
        finite(&f("azimuth_aperture"), self.azimuth_aperture)?;
        finite(&f("elevation_aperture"), self.elevation_aperture)?;
        if self.range_min < 0.0 {
            return Err(Error::invalid(f("range_min"), self.range_min, "must be >= 0 m"));
        }
        if self.range_max <= self.range_min {
            return Err(Error::invalid(
                f("range_max"),
                self.range_max,
                format!("must be greater than range_min = {} m", self.range_min),
            ));
        }
        if self.range_max > MAX_RANGE {
            return Err(Error::invalid(
                f("range_max"),
                self.range_max,
                format!("must be at most {MAX_RANGE} m (no sonar reaches farther)"),
            ));
        }
        if !(self.azimuth_aperture > 0.0 && self.azimuth_aperture <= 360.0) {
            return Err(Error::invalid(
                f("azimuth_aperture"),
                self.azimuth_aperture,
                "must be in (0, 360] degrees",
            ));
        }
        if !(self.elevation_aperture > 0.0 && self.elevation_aperture <= 180.0) {
            return Err(Error::invalid(
                f("elevation_aperture"),
                self.elevation_aperture,
                "must be in (0, 180] degrees",
            ));
        }
        if self.range_bins == 0 || self.range_bins > MAX_RANGE_BINS {
            return Err(Error::invalid(
                f("range_bins"),
                self.range_bins,
                format!("must be in [1, {MAX_RANGE_BINS}]"),
            ));
        }
        match &self.beams {
            BeamLayout::Uniform { count } => {
                if self.kind == SonarKind::Sss && !matches!(*count, 1 | 2) {
                    return Err(Error::invalid(
                        f("sides"),
                        count,
                        "an SSS has 1 side, or 2 for a two-sided sidescan",
                    ));
                }
                if *count == 0 || *count > MAX_BEAMS {
                    return Err(Error::invalid(
                        f("beams"),
                        count,
                        format!("must be in [1, {MAX_BEAMS}]"),
                    ));
                }
            }
            BeamLayout::Edges(edges) => {
                if self.kind == SonarKind::Sss {
                    return Err(Error::invalid(f("beam_edges"), "given", "an SSS has no beams"));
                }
                check_edges(&ctx, self.azimuth_aperture, edges)?;
            }
        }
        let pixels = u64::from(self.range_bins) * u64::from(self.beam_count());
        if pixels > MAX_PIXELS {
            return Err(Error::invalid(
                f("range_bins x beams"),
                pixels,
                format!("must be at most {MAX_PIXELS} pixels"),
            ));
        }
        Ok(())
    }

    /// Returns whether this is a two-sided sidescan: an SSS whose one fan covers port and
    /// starboard (`Uniform { count: 2 }`), its data one row of both sides as HoloOcean's
    /// `SidescanSonar` returns it. Each side has `range_bins` bins over `[range_min, range_max]`.
    /// Azimuth `>= 0` (toward +y) is port, below 0 starboard. The row holds `2 × range_bins`
    /// values (HoloOcean's `RangeBins`): port from far to near, bin `i` at `range_bins − 1 − i`,
    /// then starboard from near to far, bin `i` at `range_bins + i`.
    #[must_use]
    pub fn two_sided(&self) -> bool {
        self.kind == SonarKind::Sss && self.beams == (BeamLayout::Uniform { count: 2 })
    }

    /// Returns the number of beams (1 for an SSS, 2 for a two-sided one; 0 for an invalid
    /// sonar with fewer than two beam edges).
    #[must_use]
    pub fn beam_count(&self) -> u32 {
        match &self.beams {
            BeamLayout::Uniform { count } => *count,
            BeamLayout::Edges(e) => u32::try_from(e.len().saturating_sub(1)).unwrap_or(u32::MAX),
        }
    }

    /// Returns the beam edges in radians, increasing, `beam_count() + 1` values from
    /// `-azimuth_aperture/2` to `+azimuth_aperture/2`.
    #[must_use]
    pub fn beam_edges_rad(&self) -> Vec<f64> {
        let h = self.half_azimuth();
        match &self.beams {
            BeamLayout::Uniform { count } => {
                let n = *count as usize;
                let w = 2.0 * h / n as f64;
                let mut e: Vec<f64> = (0..=n).map(|j| -h + j as f64 * w).collect();
                e[n] = h;
                e
            }
            BeamLayout::Edges(edges) => edges.iter().map(|d| d.to_radians()).collect(),
        }
    }

    /// Returns the beam edges in degrees, increasing, `beam_count() + 1` values from exactly
    /// `-azimuth_aperture/2` to exactly `+azimuth_aperture/2` (the given edges for
    /// [`BeamLayout::Edges`]).
    #[must_use]
    pub fn beam_edges_deg(&self) -> Vec<f64> {
        let h = self.azimuth_aperture / 2.0;
        match &self.beams {
            BeamLayout::Uniform { count } => {
                let n = *count as usize;
                let w = self.azimuth_aperture / n as f64;
                let mut e: Vec<f64> = (0..=n).map(|j| -h + j as f64 * w).collect();
                e[n] = h;
                e
            }
            BeamLayout::Edges(edges) => edges.clone(),
        }
    }

    /// Returns half the azimuth aperture in radians.
    #[must_use]
    pub fn half_azimuth(&self) -> f64 {
        (self.azimuth_aperture / 2.0).to_radians()
    }

    /// Returns half the elevation aperture in radians.
    #[must_use]
    pub fn half_elevation(&self) -> f64 {
        (self.elevation_aperture / 2.0).to_radians()
    }

    /// Returns the width of one range bin in metres.
    #[must_use]
    pub fn range_bin_width(&self) -> f64 {
        (self.range_max - self.range_min) / f64::from(self.range_bins)
    }

    /// Returns `Ok(())` when the point `(range, azimuth, elevation)` (m, deg, deg) lies in this
    /// sonar's field of view, else an error naming `what` (e.g. `"feature"`) and the bound.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for a non-finite value or one outside the field of view.
    pub fn check_point(&self, what: &str, range: f64, azimuth: f64, elevation: f64) -> Result<()> {
        let f = |c: &str| format!("{what} {c}");
        finite_named(|| f("range"), range)?;
        finite_named(|| f("azimuth"), azimuth)?;
        finite_named(|| f("elevation"), elevation)?;
        if range < self.range_min || range > self.range_max || range <= 0.0 {
            return Err(Error::invalid(
                f("range"),
                range,
                format!(
                    "must be within sonar {:?}'s range [{}, {}] m (and > 0)",
                    self.name, self.range_min, self.range_max
                ),
            ));
        }
        let ha = self.azimuth_aperture / 2.0;
        if azimuth.abs() > ha {
            return Err(Error::invalid(
                f("azimuth"),
                azimuth,
                format!(
                    "must be within sonar {:?}'s azimuth aperture [-{ha}, {ha}] deg",
                    self.name
                ),
            ));
        }
        let he = self.elevation_aperture / 2.0;
        if elevation.abs() > he {
            return Err(Error::invalid(
                f("elevation"),
                elevation,
                format!(
                    "must be within sonar {:?}'s elevation aperture [-{he}, {he}] deg",
                    self.name
                ),
            ));
        }
        Ok(())
    }
}

/// Checks explicit beam edges (deg): at least two, strictly increasing, from -A/2 to +A/2.
fn check_edges(ctx: &str, aperture: f64, edges: &[f64]) -> Result<()> {
    let field = format!("{ctx}: beam_edges");
    if edges.len() < 2 || edges.len() - 1 > MAX_BEAMS as usize {
        return Err(Error::invalid(
            field,
            format!("{} values", edges.len()),
            format!("needs beams + 1 values, between 2 and {}", MAX_BEAMS + 1),
        ));
    }
    for (i, &e) in edges.iter().enumerate() {
        finite(&format!("{field}[{i}]"), e)?;
    }
    let h = aperture / 2.0;
    let tol = crate::clip::APERTURE_ENDS * aperture;
    if (edges[0] + h).abs() > tol || (edges[edges.len() - 1] - h).abs() > tol {
        return Err(Error::invalid(
            field,
            format!("[{}, …, {}]", edges[0], edges[edges.len() - 1]),
            format!("must start at -{h} and end at {h} deg (the aperture)"),
        ));
    }
    if let Some(i) = edges.windows(2).position(|w| w[1] <= w[0]) {
        return Err(Error::invalid(
            format!("{field}[{}]", i + 1),
            edges[i + 1],
            format!("edges must increase strictly (previous is {})", edges[i]),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    /// Every preset, a two-sided sidescan, and an imaging sonar with a driver's uneven beams read
    /// back from their TOML to themselves, bit for bit.
    #[test]
    fn to_toml_reads_back_to_the_same_sonar() {
        let mut sonars: Vec<Sonar> = Sonar::preset_names()
            .into_iter()
            .map(|n| Sonar::preset(n).unwrap())
            .collect();
        let uneven = Sonar::preset("holoocean-imaging")
            .unwrap()
            .with_beam_centres(&[-59.3, -20.1, -3.7, 0.1, 1.0 / 3.0, 17.77, 58.0], None)
            .unwrap();
        sonars.push(uneven);
        for s in sonars {
            let back = Sonar::from_toml_str(&s.name, &s.to_toml()).unwrap();
            assert_eq!(back, s, "{}", s.to_toml());
        }
    }

    use super::*;

    #[test]
    fn presets_validate_and_match_spec_layouts() {
        for name in Sonar::preset_names() {
            Sonar::preset(name).unwrap().validate().unwrap();
            assert!(Sonar::preset_source(name).is_some());
        }
        let fls = Sonar::preset("paper-fls").unwrap();
        assert_eq!((fls.range_bins, fls.beam_count()), (990, 512));
        assert!((fls.range_bin_width() - 0.01).abs() < 1e-12);
        let sss = Sonar::preset("paper-sss").unwrap();
        assert_eq!((sss.range_bins, sss.beam_count()), (2990, 1));
        assert!((sss.range_bin_width() - 0.01).abs() < 1e-12);
    }

    #[test]
    fn beam_edges_span_the_aperture() {
        let fls = Sonar::preset("paper-fls").unwrap();
        let e = fls.beam_edges_rad();
        assert_eq!(e.len(), 513);
        assert_eq!(e[0], -(30f64).to_radians());
        assert_eq!(e[512], (30f64).to_radians());
    }

    #[test]
    fn toml_file_with_centres() {
        let s = Sonar::from_toml_str(
            "t",
            "kind = 'fls'\nrange_min = 1\nrange_max = 5\nazimuth_aperture = 30\nelevation_aperture = 10\nrange_bins = 4\nbeam_centres = [-10, 0, 10]\n",
        )
        .unwrap();
        assert_eq!(s.beams, BeamLayout::Edges(vec![-15.0, -5.0, 5.0, 15.0]));
    }

    #[test]
    fn bad_sonars_name_field_and_value() {
        let base = "kind = 'fls'\nrange_bins = 4\nbeams = 8\nelevation_aperture = 10\n";
        let cases = [
            (
                "range_min = -1\nrange_max = 5\nazimuth_aperture = 30\n",
                "range_min = -1",
            ),
            (
                "range_min = 6\nrange_max = 5\nazimuth_aperture = 30\n",
                "range_max = 5",
            ),
            (
                "range_min = 1\nrange_max = 5\nazimuth_aperture = 0\n",
                "azimuth_aperture = 0",
            ),
            (
                "range_min = 1\nrange_max = 5\nazimuth_aperture = 361\n",
                "azimuth_aperture = 361",
            ),
            (
                "range_min = 1\nrange_max = 5\nazimuth_aperture = nan\n",
                "azimuth_aperture = NaN",
            ),
        ];
        for (extra, want) in cases {
            let err = Sonar::from_toml_str("t", &format!("{base}{extra}")).unwrap_err();
            assert!(err.is_input());
            assert!(err.to_string().contains(want), "{err} lacks {want}");
        }
        let err = Sonar::from_toml_str("t", "kind = 'fls'\nbogus = 1\n").unwrap_err();
        assert!(err.to_string().contains("bogus"), "{err}");
    }
}
