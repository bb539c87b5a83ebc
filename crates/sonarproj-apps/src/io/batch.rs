//! Batch CSV files: poses in, metrics out, streamed.
//!
//! Input header (any order): `range,azimuth,elevation,roll,pitch,yaw` and either
//! `place_range,place_azimuth,place_elevation` or `tx,ty,tz`. The feature's true point in sonar 1
//! is `sph(range, azimuth, elevation)` (m, deg, deg); its measurement is `(range, azimuth)` for an
//! FLS, `range` for an SSS. Output: the input columns as given, then [`METRIC_COLUMNS`].
//!
//! [`project_csv`] reads, projects and writes [`CHUNK_ROWS`] rows at a time, so a batch of any
//! length runs in bounded memory; it stops at the first bad row, after writing the rows before it.

use std::io::{Read, Write};

use crate::error::Result;
use crate::io::field;
use crate::io::table::{CsvOut, Row, TableReader, header_error, row_error};
use sonarproj::geometry::pose::{RelativePose, Rotation};
use sonarproj::geometry::sonar::Sonar;
use sonarproj::metrics::{METRIC_NAMES, METRICS, Metrics, Value};
use sonarproj::projection::{Batch, BatchItem, Projection};
use sonarproj::sampling::Measurement;

/// Columns every input row must have.
pub const REQUIRED_COLUMNS: [&str; 6] = ["range", "azimuth", "elevation", "roll", "pitch", "yaw"];
/// Placement columns (one way to give the translation).
pub const PLACE_COLUMNS: [&str; 3] = ["place_range", "place_azimuth", "place_elevation"];
/// Translation columns (the other way).
pub const TRANSLATION_COLUMNS: [&str; 3] = ["tx", "ty", "tz"];
/// The metric columns appended to every output row: the metric table's names, in its order.
pub const METRIC_COLUMNS: [&str; METRICS.len()] = METRIC_NAMES;
/// Rows read, projected and written at a time by [`project_csv`] (a few MiB of rows in memory,
/// enough poses to keep a GPU busy).
pub const CHUNK_ROWS: usize = 16_384;

/// A batch CSV read row by row, each row checked against sonar 1.
#[derive(Debug)]
pub struct BatchReader<'s, R: Read> {
    table: TableReader<R>,
    source: &'s Sonar,
    placement: bool,
}

impl<'s, R: Read> BatchReader<'s, R> {
    /// Returns the reader of the batch CSV `reader` with its header read and checked; rows are
    /// checked against sonar 1 (`source`) as they are read.
    ///
    /// # Errors
    /// [`Error::Csv`](crate::Error::Csv) for missing, unknown or duplicate columns or an empty
    /// input.
    pub fn new(reader: R, source: &'s Sonar) -> Result<Self> {
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
        let table = TableReader::new(reader, &allowed, &expected)?;
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
        Ok(BatchReader {
            table,
            source,
            placement,
        })
    }

    /// Returns the header as given.
    #[must_use]
    pub fn headers(&self) -> &[String] {
        self.table.headers()
    }

    /// Returns the next row with the projection it asks for, or `None` at the end of the input.
    ///
    /// # Errors
    /// [`Error::Csv`](crate::Error::Csv) naming the row (1-based, with its line) for a bad
    /// number, a wrong field count, an invalid pose or a feature outside sonar 1's field of view.
    pub fn next_item(&mut self) -> Result<Option<(Row, BatchItem)>> {
        let (source, placement) = (self.source, self.placement);
        self.table
            .next_parsed(|table, fields| item(table, source, placement, fields))
    }
}

/// Returns the projection that the row `fields` of `table` asks for, checked against sonar 1
/// (`source`); `placement` says whether the translation is given as a placement.
fn item<R: Read>(
    table: &TableReader<R>,
    source: &Sonar,
    placement: bool,
    fields: &[String],
) -> Result<BatchItem> {
    let get = |c: &str| table.number(fields, c);
    let feature = [get("range")?, get("azimuth")?, get("elevation")?];
    let rpy = [get("roll")?, get("pitch")?, get("yaw")?];
    let translation = if placement {
        [
            get("place_range")?,
            get("place_azimuth")?,
            get("place_elevation")?,
        ]
    } else {
        [get("tx")?, get("ty")?, get("tz")?]
    };
    Ok(batch_item(source, feature, rpy, placement, translation)?)
}

/// Returns the projection one batch row asks for, checked against sonar 1 (`source`): the
/// feature's true point `feature` = `[range, azimuth, elevation]` (m, deg, deg), the rotation
/// `rpy` = `[roll, pitch, yaw]` (deg), and `translation`: `[place_range, place_azimuth,
/// place_elevation]` when `placement`, else `[tx, ty, tz]` (m). The CSV reader and the Python
/// package's column arrays both build their items here.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] for a feature outside sonar 1's field of view or an
/// invalid pose.
pub fn batch_item(
    source: &Sonar,
    feature: [f64; 3],
    rpy: [f64; 3],
    placement: bool,
    translation: [f64; 3],
) -> sonarproj::Result<BatchItem> {
    let [range, azimuth, elevation] = feature;
    source.check_point("feature", range, azimuth, elevation)?;
    let rotation = Rotation::RollPitchYaw {
        roll: rpy[0],
        pitch: rpy[1],
        yaw: rpy[2],
    };
    let pose = if placement {
        RelativePose::placement(rotation, feature, translation)?
    } else {
        RelativePose::new(rotation, translation)?
    };
    Ok(BatchItem {
        measurement: Measurement::of(source, range, azimuth)?,
        pose,
    })
}

/// A batch CSV read whole (a sweep's pose list): the rows as given and the projections they ask
/// for.
#[derive(Clone, Debug)]
pub struct BatchInput {
    /// The header as given.
    pub headers: Vec<String>,
    /// Each row's fields as given.
    pub rows: Vec<Vec<String>>,
    /// Each row as a measurement and pose.
    pub items: Vec<BatchItem>,
}

/// Returns the whole batch read from CSV `reader`, each row checked against sonar 1 (`source`).
/// (A long batch is better streamed through [`project_csv`].)
///
/// # Errors
/// As [`BatchReader::new`] and [`BatchReader::next_item`]; [`Error::Csv`](crate::Error::Csv)
/// for an input without rows.
pub fn read_batch_csv(reader: impl Read, source: &Sonar) -> Result<BatchInput> {
    let mut input = BatchReader::new(reader, source)?;
    let (mut rows, mut items) = (Vec::new(), Vec::new());
    while let Some((row, item)) = input.next_item()? {
        rows.push(row.fields);
        items.push(item);
    }
    if rows.is_empty() {
        return Err(no_rows());
    }
    Ok(BatchInput {
        headers: input.headers().to_vec(),
        rows,
        items,
    })
}

/// Returns the error of an input with a header and no rows.
pub(crate) fn no_rows() -> crate::Error {
    crate::Error::Csv {
        context: "input".into(),
        message: "no rows after the header: nothing to compute".into(),
    }
}

/// Reads the batch CSV `input`, projects its rows with `project` ([`CHUNK_ROWS`] at a time,
/// between sonars and with the sampling of `pair`, whose items are ignored) and writes the output
/// CSV to `output`; returns the number of rows. Memory stays bounded whatever the input's
/// length. At the first bad row, the rows before it are projected and written, then its error is
/// returned (a caller writing a file discards it; on a stream they are out).
///
/// # Errors
/// As [`BatchReader`] for the input, with each row also checked by [`Batch::checker`] (its
/// sampling plan); an input without rows; `project`'s errors; [`Error::WriteOutput`](crate::Error::WriteOutput) on I/O failure.
pub fn project_csv(
    input: impl Read,
    output: impl Write,
    pair: &Batch,
    mut project: impl FnMut(&Batch) -> Result<Vec<Projection>>,
) -> Result<usize> {
    // The sonars and sampling are checked once; each row then only for itself.
    let checker = pair.checker()?;
    let mut reader = BatchReader::new(input, &pair.source)?;
    let headers = reader.headers().to_vec();
    let mut out = CsvOut::new(output, &headers, &METRIC_COLUMNS);
    let mut chunk = Batch {
        source: pair.source.clone(),
        target: pair.target.clone(),
        sampling: pair.sampling,
        items: Vec::with_capacity(CHUNK_ROWS),
    };
    let mut fields: Vec<Vec<String>> = Vec::with_capacity(CHUNK_ROWS);
    let mut total = 0;
    let mut flush = |chunk: &mut Batch, fields: &mut Vec<Vec<String>>| -> Result<()> {
        if chunk.items.is_empty() {
            return Ok(());
        }
        let results = project(chunk)?;
        for (f, p) in fields.iter().zip(&results) {
            out.row(f, &metric_fields(&p.metrics))?;
        }
        out.flush()?;
        chunk.items.clear();
        fields.clear();
        Ok(())
    };
    let stop = loop {
        let next = reader.next_item().and_then(|next| match next {
            Some((row, item)) => match checker.check(&item) {
                Ok(_) => Ok(Some((row, item))),
                Err(e) => Err(row_error(row.number, row.line, e.into())),
            },
            None => Ok(None),
        });
        match next {
            Ok(Some((row, item))) => {
                chunk.items.push(item);
                fields.push(row.fields);
                total += 1;
                if chunk.items.len() == CHUNK_ROWS {
                    flush(&mut chunk, &mut fields)?;
                }
            }
            Ok(None) => break None,
            Err(e) => break Some(e),
        }
    };
    flush(&mut chunk, &mut fields)?;
    match stop {
        Some(e) => Err(e),
        None if total == 0 => Err(no_rows()),
        None => Ok(total),
    }
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
