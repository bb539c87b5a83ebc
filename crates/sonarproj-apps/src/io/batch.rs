//! Batch CSV files: poses in, metrics out, streamed.
//!
//! The input header, in any order, holds a pose table's columns ([`crate::io::pose_columns`]):
//! the feature, a rotation, and a placement or a translation. The feature's true point in
//! sonar 1 is `sph(range, azimuth, elevation)` (m, deg, deg). Its measurement is
//! `(range, azimuth)` for an FLS and `range` for an SSS. The output holds the input columns as
//! given, then [`METRIC_COLUMNS`].
//!
//! [`project_csv`] works on [`CHUNK_ROWS`] rows at a time, so memory stays bounded. It stops
//! at the first bad row, after writing the rows before it.

use std::io::{Read, Write};

use crate::error::Result;
use crate::io::pose_columns::{PoseColumns, allowed_columns, expected_columns};
use crate::io::table::{CsvOut, Row, TableReader, header_error, row_error};
use sonarproj::geometry::sonar::Sonar;
use sonarproj::local_precision::LocalPrecision;
use sonarproj::metrics::{METRIC_NAMES, METRICS, Metrics, Value};
use sonarproj::projection::{Batch, BatchItem, Projection};

pub use crate::io::pose_columns::{PLACE_COLUMNS, TRANSLATION_COLUMNS};
/// The local precision columns ([`sonarproj::local_precision`]). Empty where the row does not
/// give the feature's true point, or where two sidescans have no elevation to pin.
pub const LOCAL_COLUMNS: [&str; 2] = ["range_per_elevation", "sigma_elevation"];
/// The result columns appended to every output row: the metric table's names in order, then
/// [`LOCAL_COLUMNS`].
pub const METRIC_COLUMNS: [&str; METRICS.len() + 2] = {
    let mut out = [""; METRICS.len() + 2];
    let mut i = 0;
    while i < METRICS.len() {
        out[i] = METRIC_NAMES[i];
        i += 1;
    }
    out[METRICS.len()] = LOCAL_COLUMNS[0];
    out[METRICS.len() + 1] = LOCAL_COLUMNS[1];
    out
};
/// Rows that [`project_csv`] handles at a time: a few MiB in memory, enough to keep a GPU busy.
pub const CHUNK_ROWS: usize = 16_384;

/// A batch CSV read row by row, each row checked against sonar 1.
#[derive(Debug)]
pub struct BatchReader<'s, R: Read> {
    table: TableReader<R>,
    source: &'s Sonar,
    columns: PoseColumns,
    /// The columns a row is read from, in [`PoseColumns::columns`] order.
    read: Vec<&'static str>,
}

impl<'s, R: Read> BatchReader<'s, R> {
    /// Returns a reader of the batch CSV `reader`, with its header read and checked. Rows are
    /// checked against sonar 1 (`source`) as they are read.
    ///
    /// # Errors
    /// [`Error::Csv`](crate::Error::Csv) for missing, unknown or duplicate columns or an empty
    /// input.
    pub fn new(reader: R, source: &'s Sonar) -> Result<Self> {
        let table = TableReader::new(reader, &allowed_columns(), &expected_columns())?;
        let names: Vec<&str> = table.headers().iter().map(String::as_str).collect();
        let columns = PoseColumns::of(&names, source.kind).map_err(header_error)?;
        Ok(BatchReader {
            table,
            source,
            read: columns.columns(),
            columns,
        })
    }

    /// Returns how the table gives its poses.
    #[must_use]
    pub fn columns(&self) -> &PoseColumns {
        &self.columns
    }

    /// Returns the header as given.
    #[must_use]
    pub fn headers(&self) -> &[String] {
        self.table.headers()
    }

    /// Returns the next row with the projection it asks for, or `None` at the end of the input.
    ///
    /// # Errors
    /// [`Error::Csv`](crate::Error::Csv) naming the row (1-based, with its line) for a bad number,
    /// a wrong field count, an invalid pose or a feature outside sonar 1's field of view.
    pub fn next_item(&mut self) -> Result<Option<(Row, BatchItem)>> {
        let (source, columns, read) = (self.source, &self.columns, &self.read);
        self.table.next_parsed(|table, fields| {
            let values = read
                .iter()
                .map(|c| table.number(fields, c))
                .collect::<Result<Vec<f64>>>()?;
            Ok(columns.item(source, &values)?)
        })
    }
}

/// A batch CSV read whole, such as a sweep's pose list: the rows as given and their projections.
#[derive(Clone, Debug)]
pub struct BatchInput {
    /// The header as given.
    pub headers: Vec<String>,
    /// Each row's fields as given.
    pub rows: Vec<Vec<String>>,
    /// Each row as a measurement and pose, with the feature's true point when the table gives it.
    pub items: Vec<BatchItem>,
}

/// Returns the whole batch read from CSV `reader`, each row checked against sonar 1 (`source`).
/// Stream a long batch through [`project_csv`] instead.
///
/// # Errors
/// As [`BatchReader::new`] and [`BatchReader::next_item`], or [`Error::Csv`](crate::Error::Csv)
/// for an input without rows.
pub fn read_batch_csv(reader: impl Read, source: &Sonar) -> Result<BatchInput> {
    read_batch_csv_at_most(reader, source, usize::MAX, "rows")
}

/// Returns [`read_batch_csv`]'s batch, refused as soon as it passes `max_rows` rows.
///
/// # Errors
/// As [`read_batch_csv`], or [`sonarproj::Error::InvalidValue`] naming `what` past `max_rows`.
pub fn read_batch_csv_at_most(
    reader: impl Read,
    source: &Sonar,
    max_rows: usize,
    what: &str,
) -> Result<BatchInput> {
    let mut input = BatchReader::new(reader, source)?;
    let (mut rows, mut items) = (Vec::new(), Vec::new());
    while let Some((row, item)) = input.next_item()? {
        if rows.len() == max_rows {
            return Err(crate::Error::invalid(
                what,
                format!("more than {max_rows} rows"),
                format!("must hold at most {max_rows} rows (they are held in memory): split it"),
            ));
        }
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

/// Reads the batch CSV `input`, projects its rows with `project` and writes the output CSV to
/// `output`. Returns the number of rows.
///
/// Rows go [`CHUNK_ROWS`] at a time, with the sonars and sampling of `pair` (its items are
/// ignored), so memory stays bounded. At the first bad row, the rows before it are written,
/// then its error is returned.
///
/// # Errors
/// As [`BatchReader`], with each row also checked by [`Batch::checker`]. An input without rows,
/// `project`'s errors, or [`Error::WriteOutput`](crate::Error::WriteOutput) on I/O failure.
pub fn project_csv(
    input: impl Read,
    output: impl Write,
    pair: &Batch,
    mut project: impl FnMut(&Batch) -> Result<Vec<Projection>>,
) -> Result<usize> {
    // The sonars, sampling and range error are checked once. Each row is then checked alone.
    let checker = pair.checker()?;
    let mut reader = BatchReader::new(input, &pair.source)?;
    let headers = reader.headers().to_vec();
    let mut out = CsvOut::new(output, &headers, &METRIC_COLUMNS);
    let mut chunk = Batch {
        sigma_range: pair.sigma_range,
        source: pair.source.clone(),
        target: pair.target.clone(),
        sampling: pair.sampling,
        area_grid: pair.area_grid,
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
            out.row(f, &metric_fields(&p.metrics, &p.local))?;
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

/// Returns the result columns of one projection as a JSON object, as `project` and the viewer
/// print `metrics`. The metric table's keys come first, then the local precision's. `null`
/// stands for an empty CSV cell.
#[must_use]
pub fn metrics_json(m: &Metrics, local: &LocalPrecision) -> serde_json::Value {
    let mut out = serde_json::to_value(m).expect("plain numbers");
    out[LOCAL_COLUMNS[0]] = serde_json::json!(local.range_per_elevation);
    out[LOCAL_COLUMNS[1]] = serde_json::json!(local.sigma_elevation);
    out
}

/// Returns the result fields of one projection in [`METRIC_COLUMNS`] order: the metrics, then
/// the local precision `local`. Numbers are in their shortest exact form, so f32 results keep
/// their f32 value. Fields are empty where nothing is visible or there is no value.
#[must_use]
pub fn metric_fields(m: &Metrics, local: &LocalPrecision) -> Vec<String> {
    (0..METRIC_COLUMNS.len())
        .map(|k| metric_field(m, local, k))
        .collect()
}

/// Returns result field `k` of [`METRIC_COLUMNS`] for one projection, as [`metric_fields`] does.
///
/// # Panics
/// When `k` is not below `METRIC_COLUMNS.len()`.
#[must_use]
pub fn metric_field(m: &Metrics, local: &LocalPrecision, k: usize) -> String {
    let mut out = String::new();
    push_metric_field(&mut out, m, local, k);
    out
}

/// Appends result field `k` of [`METRIC_COLUMNS`] for one projection to `out`: the text of
/// [`metric_field`], without a string of its own (the paper's CSV formats millions of them).
///
/// # Panics
/// When `k` is not below `METRIC_COLUMNS.len()`.
pub fn push_metric_field(out: &mut String, m: &Metrics, local: &LocalPrecision, k: usize) {
    use std::fmt::Write;
    let v = match METRICS.get(k) {
        Some(info) => match m.get(info.metric) {
            Value::Count(n) => {
                write!(out, "{n}").expect("a String takes every write");
                return;
            }
            Value::Real(v) => Some(v),
            Value::Optional(v) => v,
        },
        None => [local.range_per_elevation, local.sigma_elevation][k - METRICS.len()],
    };
    if let Some(v) = v {
        write!(out, "{v}").expect("a String takes every write");
    }
}
