//! A CSV table read whole and checked: a header of known, distinct columns, then rows of the
//! header's width, each remembered with its 1-based row number and its line in the file.

use std::collections::HashMap;
use std::io::{Read, Write};

use crate::error::{Error, Result};

/// A checked CSV table.
#[derive(Clone, Debug)]
pub struct Table {
    /// The header as given.
    pub headers: Vec<String>,
    index: HashMap<String, usize>,
    /// The rows: `(row number from 1, line in the file, fields as given)`.
    pub rows: Vec<(usize, u64, Vec<String>)>,
}

/// Returns an error about the header.
#[must_use]
pub fn header_error(message: String) -> Error {
    Error::Csv {
        context: "input header".into(),
        message,
    }
}

impl Table {
    /// Returns the table read from `reader`, whose columns must all be in `allowed` (`expected`
    /// describes the header for the message about an empty input). Call [`Table::require_rows`]
    /// once the header's own checks are done.
    ///
    /// # Errors
    /// [`Error::Csv`] for an empty input, an unknown or repeated column, or a row of the wrong
    /// width (naming the row and line).
    pub fn read(reader: impl Read, allowed: &[&str], expected: &str) -> Result<Table> {
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .flexible(false)
            .from_reader(reader);
        let headers: Vec<String> = rdr
            .headers()
            .map_err(|e| header_error(e.to_string()))?
            .iter()
            .map(str::to_string)
            .collect();
        if headers.iter().all(String::is_empty) {
            return Err(header_error(format!(
                "empty input: expected a header with {expected}"
            )));
        }
        let mut index = HashMap::new();
        for (i, h) in headers.iter().enumerate() {
            if !allowed.contains(&h.as_str()) {
                return Err(header_error(format!(
                    "unknown column {h:?} (allowed: {})",
                    allowed.join(",")
                )));
            }
            if index.insert(h.clone(), i).is_some() {
                return Err(header_error(format!("column {h:?} appears twice")));
            }
        }
        let mut rows = Vec::new();
        for (n, record) in rdr.records().enumerate() {
            let row = n + 1;
            let record = record.map_err(|e| Error::Csv {
                context: format!(
                    "input row {row} (line {})",
                    e.position().map(|p| p.line()).unwrap_or(0)
                ),
                message: e.to_string(),
            })?;
            let line = record.position().map(|p| p.line()).unwrap_or(row as u64 + 1);
            rows.push((row, line, record.iter().map(str::to_string).collect()));
        }
        Ok(Table { headers, index, rows })
    }

    /// Returns an error when the table has no rows.
    ///
    /// # Errors
    /// [`Error::Csv`] saying there is nothing to compute.
    pub fn require_rows(&self) -> Result<()> {
        if self.rows.is_empty() {
            return Err(Error::Csv {
                context: "input".into(),
                message: "no rows after the header: nothing to compute".into(),
            });
        }
        Ok(())
    }

    /// Returns whether column `c` is present.
    #[must_use]
    pub fn has(&self, c: &str) -> bool {
        self.index.contains_key(c)
    }

    /// Returns an error unless every column of `cols` is present.
    ///
    /// # Errors
    /// [`Error::Csv`] naming the first missing column.
    pub fn require(&self, cols: &[&str]) -> Result<()> {
        match cols.iter().find(|c| !self.has(c)) {
            Some(c) => Err(header_error(format!("missing column {c:?}"))),
            None => Ok(()),
        }
    }

    /// Returns the number in column `c` of `fields`, or `None` when the column is absent or the
    /// field empty.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming the column when the field is not a number.
    pub fn optional(&self, fields: &[String], c: &str) -> Result<Option<f64>> {
        match self.index.get(c).map(|&i| fields[i].as_str()) {
            None | Some("") => Ok(None),
            Some(s) => s
                .parse::<f64>()
                .map(Some)
                .map_err(|_| Error::invalid(format!("column {c}"), format!("{s:?}"), "must be a number")),
        }
    }

    /// Returns the number in column `c` of `fields`.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming the column when it is empty or not a number.
    pub fn number(&self, fields: &[String], c: &str) -> Result<f64> {
        self.optional(fields, c)?
            .ok_or_else(|| Error::invalid(format!("column {c}"), "\"\"", "must be a number"))
    }
}

/// Writes a CSV: `headers` then `extra` as the header, then each row of `rows` (a row's input
/// fields followed by its extra fields).
///
/// # Errors
/// [`Error::WriteOutput`] (named `output`) on I/O failure.
pub fn write_rows<F: AsRef<[String]>>(
    w: impl Write,
    headers: &[String],
    extra: &[&str],
    rows: impl IntoIterator<Item = (F, Vec<String>)>,
) -> Result<()> {
    let err = |e: &dyn std::fmt::Display| Error::WriteOutput {
        path: "output".into(),
        message: e.to_string(),
    };
    let mut wtr = csv::Writer::from_writer(w);
    let header = headers.iter().map(String::as_str).chain(extra.iter().copied());
    wtr.write_record(header).map_err(|e| err(&e))?;
    for (fields, more) in rows {
        let record = fields.as_ref().iter().chain(&more).map(String::as_str);
        wtr.write_record(record).map_err(|e| err(&e))?;
    }
    wtr.flush().map_err(|e| err(&e))
}

/// Returns `e` as an error of row `row` at line `line`.
#[must_use]
pub fn row_error(row: usize, line: u64, e: Error) -> Error {
    Error::Csv {
        context: format!("input row {row} (line {line})"),
        message: e.to_string(),
    }
}
