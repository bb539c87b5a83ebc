//! Sonar files: a sonar read from its TOML file (its fields, its beam centres or edges, or a
//! HoloOcean sensor's `[holoocean]` table), or named by a preset, and written back as TOML.

use std::path::Path;

use serde::Deserialize;

use super::beam_table::edges_from_centres;
use super::sonar::{BeamLayout, Sonar, SonarKind};
use crate::error::{Error, Result};
use crate::limits::MAX_SONAR_FILE_BYTES;

/// Returns the UTF-8 text of the regular file at `path`, refusing a device, a FIFO or anything
/// longer than `limit` bytes before reading more than that.
fn read_small_text(path: &Path, limit: u64) -> Result<String> {
    use std::io::Read;
    let fail = |source: std::io::Error| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    };
    // Opened without waiting on a FIFO, and refused when not a regular file.
    let file = crate::files::open_regular(path).map_err(|e| {
        if e.to_string() == crate::files::NOT_REGULAR {
            fail(std::io::Error::other(
                "not a regular file (a device, a FIFO or a directory); give a sonar TOML file",
            ))
        } else {
            fail(e)
        }
    })?;
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
    // The configuration's keys sit in the table itself, or in a [holoocean.configuration]
    // table as a scenario nests them.
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
    /// [`Error::UnknownSonar`] when it is neither. File and validation errors as
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
            // A long name is cut: an error never echoes a long input whole.
            name: crate::error::shortened(spec),
            presets: Sonar::preset_names().join(", "),
        })
    }

    /// Returns the sonar described by the TOML file at `path`, validated.
    ///
    /// Keys: `kind` (`"fls"`/`"sss"`), `range_min`, `range_max` (m), `azimuth_aperture`,
    /// `elevation_aperture` (deg) and `range_bins`. An FLS also takes one of `beams` (uniform),
    /// `beam_edges` or `beam_centres` (deg). An SSS optionally takes `sides`: 1, or 2 for a
    /// two-sided sidescan ([`Sonar::two_sided`]).
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
    /// round-trip form). [`Sonar::from_toml_str`] reads it back to this sonar.
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
}
