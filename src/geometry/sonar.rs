//! Sonars: kind, field of view and data layout (README: Sonars), the presets, and sonar TOML files.

use std::path::Path;

use serde::Deserialize;

pub use super::beam_table::aperture_of_beam_centres;
use super::beam_table::edges_from_centres;
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
    /// sidescan (one fan over port and starboard, its data one row of both sides: see
    /// [`Sonar::two_sided`]).
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
/// Construct it from a preset ([`Sonar::preset`]), a TOML file ([`Sonar::from_toml_file`]) or
/// directly followed by [`Sonar::validate`].
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
    /// Beams of the FLS image; for an SSS `Uniform { count: 1 }`, or `Uniform { count: 2 }` for
    /// a two-sided sidescan (starboard then port: [`Sonar::two_sided`]).
    pub beams: BeamLayout,
}

pub use crate::limits::{MAX_BEAMS, MAX_PIXELS, MAX_RANGE, MAX_RANGE_BINS};

/// The largest sonar file read (bytes): a sonar file is a few hundred bytes, one with
/// [`MAX_BEAMS`] beam edges about 1.5 MB.
pub const MAX_SONAR_FILE_BYTES: u64 = 4 << 20;

/// Returns the UTF-8 text of the regular file at `path`, refusing a device, a FIFO or anything
/// longer than `limit` bytes before reading more than that.
fn read_small_text(path: &Path, limit: u64) -> Result<String> {
    use std::io::Read;
    let fail = |source: std::io::Error| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(fail)?;
    let meta = file.metadata().map_err(fail)?;
    if !meta.is_file() {
        return Err(fail(std::io::Error::other(
            "not a regular file (a device, a FIFO or a directory); give a sonar TOML file",
        )));
    }
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(fail)?;
    if bytes.len() as u64 > limit {
        return Err(fail(std::io::Error::other(format!(
            "longer than {limit} bytes: not a sonar file (a sonar file is a few hundred bytes)"
        ))));
    }
    String::from_utf8(bytes).map_err(|e| fail(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))
}

/// Returns the sonar of a file holding a `[holoocean]` table (a HoloOcean sensor's
/// `sensor_type` and its configuration keys) and nothing else.
fn holoocean_file(name: &str, mut table: toml::Table) -> Result<Sonar> {
    use super::holoocean::HoloValue;
    let ctx = format!("sonar {name:?}");
    if let Some(other) = table.keys().find(|k| *k != "holoocean") {
        return Err(Error::input(
            format!("{ctx}: {}", crate::error::excerpt(other)),
            "a file with a [holoocean] table holds nothing else (the table describes the sonar)",
        ));
    }
    let Some(toml::Value::Table(mut sensor)) = table.remove("holoocean") else {
        return Err(Error::input(
            format!("{ctx}: holoocean"),
            "must be a table: [holoocean]",
        ));
    };
    let sensor_type = match sensor.remove("sensor_type") {
        Some(toml::Value::String(t)) => t,
        _ => {
            return Err(Error::input(
                format!("{ctx}: holoocean.sensor_type"),
                "missing or not a string: \"ImagingSonar\" or \"SidescanSonar\"",
            ));
        }
    };
    // The configuration's keys in the table itself, or in a [holoocean.configuration] table as a
    // scenario nests them.
    if let Some(toml::Value::Table(nested)) = sensor.remove("configuration") {
        for (k, v) in nested {
            if sensor.contains_key(&k) {
                return Err(Error::input(
                    format!("{ctx}: holoocean.{}", crate::error::excerpt(&k)),
                    "given twice: in [holoocean] and in [holoocean.configuration]",
                ));
            }
            sensor.insert(k, v);
        }
    }
    let config: Vec<(String, HoloValue)> = sensor
        .into_iter()
        .map(|(k, v)| {
            let value = match v {
                #[expect(
                    clippy::cast_precision_loss,
                    reason = "HoloOcean reads JSON numbers as doubles too"
                )]
                toml::Value::Integer(i) => HoloValue::Number(i as f64),
                toml::Value::Float(f) => HoloValue::Number(f),
                toml::Value::Boolean(_) => HoloValue::Other("bool"),
                toml::Value::String(_) => HoloValue::Other("string"),
                toml::Value::Array(_) => HoloValue::Other("list"),
                toml::Value::Datetime(_) => HoloValue::Other("date"),
                toml::Value::Table(_) => HoloValue::Other("table"),
            };
            (k, value)
        })
        .collect();
    Sonar::from_holoocean(name, &sensor_type, &config).map_err(|e| e.in_context(&ctx))
}

/// The keys of a sonar TOML file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SonarFile {
    kind: SonarKind,
    range_min: f64,
    range_max: f64,
    azimuth_aperture: f64,
    elevation_aperture: f64,
    range_bins: u32,
    beams: Option<u32>,
    beam_edges: Option<Vec<f64>>,
    beam_centres: Option<Vec<f64>>,
    sides: Option<u32>,
}

impl Sonar {
    /// Returns the sonar named by `spec`: a preset name, or else a path to a sonar TOML file.
    ///
    /// # Errors
    /// [`Error::UnknownSonar`] when it is neither; file and validation errors from
    /// [`Sonar::from_toml_file`].
    pub fn resolve(spec: &str) -> Result<Sonar> {
        if let Some(s) = Sonar::preset(spec) {
            return Ok(s);
        }
        let path = Path::new(spec);
        if path.is_file() {
            return Sonar::from_toml_file(path);
        }
        if path.is_dir() {
            return Err(Error::ReadInput {
                path: path.to_path_buf(),
                source: std::io::Error::other("it is a directory; give a sonar TOML file or a preset"),
            });
        }
        if path.exists() {
            return Err(Error::ReadInput {
                path: path.to_path_buf(),
                source: std::io::Error::other(
                    "not a regular file (a device or a FIFO); give a sonar TOML file or a preset",
                ),
            });
        }
        Err(Error::UnknownSonar {
            name: spec.to_string(),
            presets: Sonar::preset_names().join(", "),
        })
    }

    /// Returns the sonar described by the TOML file at `path`, validated.
    ///
    /// Keys: `kind` (`"fls"`/`"sss"`), `range_min`, `range_max` (m), `azimuth_aperture`,
    /// `elevation_aperture` (deg), `range_bins`, and for an FLS one of `beams` (uniform),
    /// `beam_edges` or `beam_centres` (deg); for an SSS optionally `sides` (1, or 2 for a
    /// two-sided sidescan: [`Sonar::two_sided`]).
    ///
    /// # Errors
    /// [`Error::ReadInput`], [`Error::SonarFile`] (syntax, unknown or missing keys) or
    /// [`Error::InvalidValue`] naming the file and the key.
    pub fn from_toml_file(path: &Path) -> Result<Sonar> {
        let text = read_small_text(path, MAX_SONAR_FILE_BYTES)?;
        let name = path.display().to_string();
        Sonar::from_toml_str(&name, &text).map_err(|e| match e {
            Error::SonarFile { message, .. } => Error::SonarFile {
                path: path.to_path_buf(),
                message,
            },
            other => other,
        })
    }

    /// Returns the sonar described by TOML `text`, called `name` in messages, validated.
    ///
    /// # Errors
    /// As [`Sonar::from_toml_file`].
    pub fn from_toml_str(name: &str, text: &str) -> Result<Sonar> {
        let syntax = |e: &dyn std::fmt::Display| Error::SonarFile {
            path: name.into(),
            message: crate::error::parser_message(&e.to_string()),
        };
        let table: toml::Table = toml::from_str(text).map_err(|e| syntax(&e))?;
        if table.contains_key("holoocean") {
            return holoocean_file(name, table);
        }
        let file: SonarFile = SonarFile::deserialize(table).map_err(|e| syntax(&e))?;
        let ctx = format!("sonar {name:?}");
        let given = [
            file.beams.is_some(),
            file.beam_edges.is_some(),
            file.beam_centres.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if given > 1 {
            return Err(Error::input(
                format!("{ctx}: beams/beam_edges/beam_centres"),
                "more than one given; give exactly one of beams, beam_edges, beam_centres",
            ));
        }
        let beams = match (file.kind, file.beams, file.beam_edges, file.beam_centres) {
            (SonarKind::Sss, Some(_), _, _) if file.sides.is_some() => {
                return Err(Error::input(
                    format!("{ctx}: beams"),
                    "give sides (1 or 2) for a sidescan, not beams",
                ));
            }
            (SonarKind::Sss, None | Some(1), None, None) => match file.sides {
                None | Some(1) => BeamLayout::Uniform { count: 1 },
                Some(2) => BeamLayout::Uniform { count: 2 },
                Some(n) => {
                    return Err(Error::invalid(
                        format!("{ctx}: sides"),
                        n,
                        "must be 1 (one side) or 2 (port and starboard in one row, as HoloOcean's SidescanSonar)",
                    ));
                }
            },
            (SonarKind::Sss, _, _, _) => {
                return Err(Error::input(
                    format!("{ctx}: beams"),
                    "an SSS has no beams; leave beams, beam_edges and beam_centres out (sides = 2 for a two-sided sidescan)",
                ));
            }
            (SonarKind::Fls, ..) if file.sides.is_some() => {
                return Err(Error::input(
                    format!("{ctx}: sides"),
                    "only a sidescan (kind = \"sss\") has sides; leave it out for an FLS",
                ));
            }
            (SonarKind::Fls, Some(n), None, None) => BeamLayout::Uniform { count: n },
            (SonarKind::Fls, None, Some(edges), None) => BeamLayout::Edges(edges),
            (SonarKind::Fls, None, None, Some(centres)) => {
                BeamLayout::Edges(edges_from_centres(&ctx, file.azimuth_aperture, &centres)?)
            }
            (SonarKind::Fls, _, _, _) => {
                return Err(Error::input(
                    format!("{ctx}: beams"),
                    "missing; an FLS needs beams (a count), beam_edges or beam_centres",
                ));
            }
        };
        let sonar = Sonar {
            name: name.to_string(),
            kind: file.kind,
            range_min: file.range_min,
            range_max: file.range_max,
            azimuth_aperture: file.azimuth_aperture,
            elevation_aperture: file.elevation_aperture,
            range_bins: file.range_bins,
            beams,
        };
        sonar.validate()?;
        Ok(sonar)
    }

    /// Returns the sonar as a sonar TOML file's text, every number exact (Rust's shortest
    /// round-trip form): [`Sonar::from_toml_str`] reads it back to this sonar.
    ///
    /// ```
    /// use sonarproj::Sonar;
    /// let s = Sonar::preset("holoocean-sidescan").unwrap();
    /// let back = Sonar::from_toml_str(&s.name, &s.to_toml())?;
    /// assert_eq!(back, s);
    /// # Ok::<(), sonarproj::Error>(())
    /// ```
    #[must_use]
    pub fn to_toml(&self) -> String {
        use std::fmt::Write;
        let mut t = format!(
            "kind = \"{}\"\nrange_min = {:?}\nrange_max = {:?}\nazimuth_aperture = {:?}\n\
             elevation_aperture = {:?}\nrange_bins = {}\n",
            self.kind.name(),
            self.range_min,
            self.range_max,
            self.azimuth_aperture,
            self.elevation_aperture,
            self.range_bins
        );
        match (&self.beams, self.kind) {
            (BeamLayout::Uniform { count: 2 }, SonarKind::Sss) => t.push_str("sides = 2\n"),
            (_, SonarKind::Sss) => {}
            (BeamLayout::Uniform { count }, SonarKind::Fls) => {
                let _ = writeln!(t, "beams = {count}");
            }
            (BeamLayout::Edges(edges), SonarKind::Fls) => {
                let list: Vec<String> = edges.iter().map(|e| format!("{e:?}")).collect();
                let _ = writeln!(t, "beam_edges = [{}]", list.join(", "));
            }
        }
        t
    }

    /// Returns the sonar when every field holds (README: Sonars): the way to check a sonar
    /// built by hand.
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

    /// Returns `Ok(())` when every field holds (README: Sonars).
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
    /// starboard (`Uniform { count: 2 }`) and whose data is one row of both sides, as
    /// HoloOcean's `SidescanSonar` returns it. Each side has `range_bins` bins over
    /// `[range_min, range_max]`; a point with azimuth `>= 0` (toward +y) is to port, below 0
    /// to starboard. The row holds `2 × range_bins` values: port from far to near, then
    /// starboard from near to far — index `range_bins − 1 − i` for port bin `i`,
    /// `range_bins + i` for starboard bin `i` (HoloOcean's `RangeBins` is `2 × range_bins`).
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
    /// Every preset, a sidescan with two sides and an imaging sonar with a driver's uneven
    /// beams read back from their TOML to themselves, bit for bit.
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
