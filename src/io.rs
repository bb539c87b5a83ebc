//! Batch CSV files: poses in, metrics out.
//!
//! Input header (any order): `range,azimuth,elevation,roll,pitch,yaw` and either
//! `place_range,place_azimuth,place_elevation` or `tx,ty,tz`. The feature's true point in sonar 1
//! is `sph(range, azimuth, elevation)` (m, deg, deg); its measurement is `(range, azimuth)` for an
//! FLS, `range` for an SSS. Output: the input columns as given, then [`METRIC_COLUMNS`].

use std::collections::HashMap;
use std::io::{Read, Write};

use crate::ambiguity::Measurement;
use crate::batch::{BatchItem, Projection};
use crate::error::{Error, Result};
use crate::occupancy::Metrics;
use crate::pose::{RelativePose, Rotation};
use crate::sonar::Sonar;

/// Columns every input row must have.
pub const REQUIRED_COLUMNS: [&str; 6] = ["range", "azimuth", "elevation", "roll", "pitch", "yaw"];
/// Placement columns (one way to give the translation).
pub const PLACE_COLUMNS: [&str; 3] = ["place_range", "place_azimuth", "place_elevation"];
/// Translation columns (the other way).
pub const TRANSLATION_COLUMNS: [&str; 3] = ["tx", "ty", "tz"];
/// The metric columns appended to every output row.
pub const METRIC_COLUMNS: [&str; 9] = [
    "visible",
    "total",
    "range_min",
    "range_max",
    "span",
    "azimuth_min",
    "azimuth_max",
    "occupied",
    "occupied_measure",
];

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
/// [`Error::Csv`] naming the header or the row (1-based, with its line) for missing, unknown or
/// duplicate columns, an empty input, a bad number, a wrong field count, or a feature outside
/// sonar 1's field of view.
pub fn read_batch_csv(reader: impl Read, source: &Sonar) -> Result<BatchInput> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(reader);
    let header_err = |message: String| Error::Csv {
        context: "input header".into(),
        message,
    };
    let headers: Vec<String> = rdr
        .headers()
        .map_err(|e| header_err(e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    if headers.is_empty() || headers.iter().all(String::is_empty) {
        return Err(header_err(format!(
            "empty input: expected a header with {} and either {} or {}",
            REQUIRED_COLUMNS.join(","),
            PLACE_COLUMNS.join(","),
            TRANSLATION_COLUMNS.join(",")
        )));
    }
    let mut index: HashMap<&str, usize> = HashMap::new();
    for (i, h) in headers.iter().enumerate() {
        let known = REQUIRED_COLUMNS
            .iter()
            .chain(&PLACE_COLUMNS)
            .chain(&TRANSLATION_COLUMNS)
            .any(|c| c == h);
        if !known {
            return Err(header_err(format!(
                "unknown column {h:?} (allowed: {}, {}, {})",
                REQUIRED_COLUMNS.join(","),
                PLACE_COLUMNS.join(","),
                TRANSLATION_COLUMNS.join(",")
            )));
        }
        if index.insert(h.as_str(), i).is_some() {
            return Err(header_err(format!("column {h:?} appears twice")));
        }
    }
    for c in REQUIRED_COLUMNS {
        if !index.contains_key(c) {
            return Err(header_err(format!("missing column {c:?}")));
        }
    }
    let has = |cols: &[&str]| cols.iter().filter(|c| index.contains_key(*c)).count();
    let placement = match (has(&PLACE_COLUMNS), has(&TRANSLATION_COLUMNS)) {
        (3, 0) => true,
        (0, 3) => false,
        (0, 0) => {
            return Err(header_err(format!(
                "missing translation: give {} or {}",
                PLACE_COLUMNS.join(","),
                TRANSLATION_COLUMNS.join(",")
            )));
        }
        (p, t) if p > 0 && t > 0 => {
            return Err(header_err(format!(
                "give either {} or {}, not both",
                PLACE_COLUMNS.join(","),
                TRANSLATION_COLUMNS.join(",")
            )));
        }
        _ => {
            let group = if has(&PLACE_COLUMNS) > 0 {
                &PLACE_COLUMNS
            } else {
                &TRANSLATION_COLUMNS
            };
            let missing: Vec<_> = group.iter().filter(|c| !index.contains_key(*c)).collect();
            return Err(header_err(format!("missing column(s) {missing:?}")));
        }
    };

    let mut rows = Vec::new();
    let mut items = Vec::new();
    for (n, record) in rdr.records().enumerate() {
        let row_no = n + 1;
        let record = record.map_err(|e| {
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            Error::Csv {
                context: format!("input row {row_no} (line {line})"),
                message: e.to_string(),
            }
        })?;
        let line = record.position().map(|p| p.line()).unwrap_or(row_no as u64 + 1);
        let context = format!("input row {row_no} (line {line})");
        let row_err = |e: Error| Error::Csv {
            context: context.clone(),
            message: e.to_string(),
        };
        let get = |c: &str| -> Result<f64> {
            let s = &record[index[c]];
            s.parse::<f64>()
                .map_err(|_| Error::invalid(format!("column {c}"), format!("{s:?}"), "must be a number"))
        };
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
        .map_err(row_err)?;
        items.push(item);
        rows.push(record.iter().map(str::to_string).collect());
    }
    if items.is_empty() {
        return Err(Error::Csv {
            context: "input".into(),
            message: "no rows after the header: nothing to compute".into(),
        });
    }
    Ok(BatchInput { headers, rows, items })
}

/// Returns the metric fields of one projection, in [`METRIC_COLUMNS`] order: numbers in their
/// shortest exact form (every digit of the f64; f32 results keep their f32 value), empty where
/// nothing is visible.
pub fn metric_fields(m: &Metrics) -> [String; 9] {
    let opt = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
    [
        m.visible.to_string(),
        m.total.to_string(),
        opt(m.range_min),
        opt(m.range_max),
        m.span.to_string(),
        opt(m.azimuth_min),
        opt(m.azimuth_max),
        m.occupied.to_string(),
        m.occupied_measure.to_string(),
    ]
}

/// Writes the output CSV: the input's columns as given, then the metrics of each row.
///
/// # Errors
/// [`Error::WriteOutput`] (named `output`) on I/O failure.
pub fn write_batch_csv(w: impl Write, input: &BatchInput, results: &[Projection]) -> Result<()> {
    let err = |e: csv::Error| Error::WriteOutput {
        path: "output".into(),
        message: e.to_string(),
    };
    let mut wtr = csv::Writer::from_writer(w);
    let header: Vec<&str> = input
        .headers
        .iter()
        .map(String::as_str)
        .chain(METRIC_COLUMNS)
        .collect();
    wtr.write_record(&header).map_err(err)?;
    for (row, p) in input.rows.iter().zip(results) {
        let fields = metric_fields(&p.metrics);
        wtr.write_record(
            row.iter()
                .map(String::as_str)
                .chain(fields.iter().map(String::as_str)),
        )
        .map_err(err)?;
    }
    wtr.flush().map_err(|e| Error::WriteOutput {
        path: "output".into(),
        message: e.to_string(),
    })
}
