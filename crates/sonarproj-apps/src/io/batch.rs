//! Batch CSV files: poses in, metrics out.
//!
//! Input header (any order): `range,azimuth,elevation,roll,pitch,yaw` and either
//! `place_range,place_azimuth,place_elevation` or `tx,ty,tz`. The feature's true point in sonar 1
//! is `sph(range, azimuth, elevation)` (m, deg, deg); its measurement is `(range, azimuth)` for an
//! FLS, `range` for an SSS. Output: the input columns as given, then [`METRIC_COLUMNS`].

use std::io::{Read, Write};

use crate::error::Result;
use crate::io::field;
use crate::io::table::{Table, header_error, row_error, write_rows};
use sonarproj::geometry::pose::{RelativePose, Rotation};
use sonarproj::geometry::sonar::Sonar;
use sonarproj::metrics::{METRIC_NAMES, METRICS, Metrics, Value};
use sonarproj::projection::{BatchItem, Projection};
use sonarproj::sampling::Measurement;

/// Columns every input row must have.
pub const REQUIRED_COLUMNS: [&str; 6] = ["range", "azimuth", "elevation", "roll", "pitch", "yaw"];
/// Placement columns (one way to give the translation).
pub const PLACE_COLUMNS: [&str; 3] = ["place_range", "place_azimuth", "place_elevation"];
/// Translation columns (the other way).
pub const TRANSLATION_COLUMNS: [&str; 3] = ["tx", "ty", "tz"];
/// The metric columns appended to every output row: the metric table's names, in its order.
pub const METRIC_COLUMNS: [&str; METRICS.len()] = METRIC_NAMES;

/// A parsed batch CSV: the rows as given (for echoing) and the projections they ask for.
#[derive(Clone, Debug)]
pub struct BatchInput {
    /// The header as given.
    pub headers: Vec<String>,
    /// Each row's fields as given.
    pub rows: Vec<Vec<String>>,
    /// Each row as a measurement and pose.
    pub items: Vec<BatchItem>,
}

/// Returns the batch read from CSV `reader`, each row checked against sonar 1 (`source`).
///
/// # Errors
/// [`Error::Csv`](crate::Error::Csv) naming the header or the row (1-based, with its line) for missing, unknown or
/// duplicate columns, an empty input, a bad number, a wrong field count, or a feature outside
/// sonar 1's field of view.
pub fn read_batch_csv(reader: impl Read, source: &Sonar) -> Result<BatchInput> {
    let allowed: Vec<&str> = REQUIRED_COLUMNS
        .iter()
        .chain(&PLACE_COLUMNS)
        .chain(&TRANSLATION_COLUMNS)
        .copied()
        .collect();
    let expected = format!(
        "{} and either {} or {}",
        REQUIRED_COLUMNS.join(","),
        PLACE_COLUMNS.join(","),
        TRANSLATION_COLUMNS.join(",")
    );
    let table = Table::read(reader, &allowed, &expected)?;
    table.require(&REQUIRED_COLUMNS)?;
    let count = |cols: &[&str]| cols.iter().filter(|c| table.has(c)).count();
    let placement = match (count(&PLACE_COLUMNS), count(&TRANSLATION_COLUMNS)) {
        (0, 0) => {
            return Err(header_error(format!(
                "missing translation: give {} or {}",
                PLACE_COLUMNS.join(","),
                TRANSLATION_COLUMNS.join(",")
            )));
        }
        (p, t) if p > 0 && t > 0 => {
            return Err(header_error(format!(
                "give either {} or {}, not both",
                PLACE_COLUMNS.join(","),
                TRANSLATION_COLUMNS.join(",")
            )));
        }
        (p, _) if p > 0 => {
            table.require(&PLACE_COLUMNS)?;
            true
        }
        _ => {
            table.require(&TRANSLATION_COLUMNS)?;
            false
        }
    };
    table.require_rows()?;
    let mut items = Vec::with_capacity(table.rows.len());
    for (row, line, fields) in &table.rows {
        let get = |c: &str| table.number(fields, c);
        let item = (|| -> Result<BatchItem> {
            let (range, azimuth, elevation) = (get("range")?, get("azimuth")?, get("elevation")?);
            source.check_point("feature", range, azimuth, elevation)?;
            let rotation = Rotation::RollPitchYaw {
                roll: get("roll")?,
                pitch: get("pitch")?,
                yaw: get("yaw")?,
            };
            let pose = if placement {
                RelativePose::placement(
                    rotation,
                    [range, azimuth, elevation],
                    [
                        get("place_range")?,
                        get("place_azimuth")?,
                        get("place_elevation")?,
                    ],
                )?
            } else {
                RelativePose::new(rotation, [get("tx")?, get("ty")?, get("tz")?])?
            };
            Ok(BatchItem {
                measurement: Measurement::of(source, range, azimuth)?,
                pose,
            })
        })()
        .map_err(|e| row_error(*row, *line, e))?;
        items.push(item);
    }
    Ok(BatchInput {
        headers: table.headers,
        rows: table.rows.into_iter().map(|(_, _, f)| f).collect(),
        items,
    })
}

/// Returns the metric fields of one projection, in [`METRIC_COLUMNS`] order: numbers in their
/// shortest exact form (every digit of the f64; f32 results keep their f32 value), empty where
/// nothing is visible.
#[must_use]
pub fn metric_fields(m: &Metrics) -> Vec<String> {
    METRICS
        .iter()
        .map(|info| match m.get(info.metric) {
            Value::Count(n) => n.to_string(),
            Value::Real(v) => v.to_string(),
            Value::Extreme(v) => field(v),
        })
        .collect()
}

/// Writes the output CSV: the input's columns as given, then the metrics of each row.
///
/// # Errors
/// [`Error::WriteOutput`](crate::Error::WriteOutput) (named `output`) on I/O failure.
pub fn write_batch_csv(w: impl Write, input: &BatchInput, results: &[Projection]) -> Result<()> {
    let rows = input
        .rows
        .iter()
        .zip(results)
        .map(|(fields, p)| (fields.as_slice(), metric_fields(&p.metrics)));
    write_rows(w, &input.headers, &METRIC_COLUMNS, rows)
}
