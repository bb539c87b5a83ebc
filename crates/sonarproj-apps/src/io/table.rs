//! CSV tables, read one row at a time and checked: a header of known, distinct columns, then
//! rows of the header's width, each with its 1-based row number and its line in the file.
//! A record longer than [`MAX_LINE_BYTES`] is refused before it is held, so memory stays
//! bounded by one record plus what the caller keeps. [`CsvOut`] writes tables row by row.

use std::collections::HashMap;
use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crate::error::{Error, Result};
use crate::io::{MAX_LINE_BYTES, excerpt};

/// Returns an error about the header.
#[must_use]
pub fn header_error(message: String) -> Error {
    Error::Csv {
        context: "input header".into(),
        message,
    }
}

/// Returns `e` as an error of row `row` at line `line`.
#[must_use]
pub fn row_error(row: usize, line: u64, e: Error) -> Error {
    Error::Csv {
        context: format!("input row {row} (line {line})"),
        message: e.to_string(),
    }
}

/// How far the reader may read: the byte offset it must not pass, and whether it tried to.
#[derive(Debug, Default)]
struct Fence {
    at: AtomicU64,
    crossed: AtomicBool,
}

/// A reader that fails once it would pass its fence, which [`TableReader`] sets a record ahead.
struct Fenced<R> {
    inner: R,
    read: u64,
    fence: Arc<Fence>,
}

impl<R: Read> Read for Fenced<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let left = self.fence.at.load(Ordering::Relaxed).saturating_sub(self.read);
        if left == 0 {
            self.fence.crossed.store(true, Ordering::Relaxed);
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("a record longer than {MAX_LINE_BYTES} bytes"),
            ));
        }
        let n = buf.len().min(usize::try_from(left).unwrap_or(usize::MAX));
        let got = self.inner.read(&mut buf[..n])?;
        self.read += got as u64;
        Ok(got)
    }
}

/// The slack between the parser's position and the fence: what its own buffer may read ahead.
const READ_AHEAD: u64 = 64 << 10;

/// One row of a table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Row {
    /// Row number, from 1 (the header is row 0).
    pub number: usize,
    /// Line of the file the row starts on, from 1.
    pub line: u64,
    /// The fields as given (trimmed).
    pub fields: Vec<String>,
}

/// A checked CSV table, read row by row.
pub struct TableReader<R: Read> {
    rdr: csv::Reader<Fenced<R>>,
    fence: Arc<Fence>,
    headers: Vec<String>,
    index: HashMap<String, usize>,
    record: csv::StringRecord,
    rows: usize,
}

impl<R: Read> std::fmt::Debug for TableReader<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TableReader")
            .field("headers", &self.headers)
            .field("rows", &self.rows)
            .finish_non_exhaustive()
    }
}

impl<R: Read> TableReader<R> {
    /// Returns the table of `reader` with its header read and checked: every column in `allowed`,
    /// none twice. `expected` describes the header in the error for an empty input.
    ///
    /// # Errors
    /// [`Error::Csv`] for an empty input, an unknown or repeated column, or a header longer than
    /// [`MAX_LINE_BYTES`]. [`Error::ReadInput`] (named `input`) when reading fails.
    pub fn new(reader: R, allowed: &[&str], expected: &str) -> Result<Self> {
        let fence = Arc::new(Fence::default());
        fence
            .at
            .store(MAX_LINE_BYTES as u64 + READ_AHEAD, Ordering::Relaxed);
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .flexible(false)
            .from_reader(Fenced {
                inner: reader,
                read: 0,
                fence: Arc::clone(&fence),
            });
        let headers: Vec<String> = match rdr.headers() {
            Ok(h) => h.iter().map(str::to_string).collect(),
            Err(e) => return Err(read_error(&fence, "input header", e)),
        };
        if headers.iter().all(String::is_empty) {
            return Err(header_error(format!(
                "empty input: expected a header with {expected}"
            )));
        }
        let mut index = HashMap::new();
        for (i, h) in headers.iter().enumerate() {
            if !allowed.contains(&h.as_str()) {
                return Err(header_error(format!(
                    "unknown column {} (allowed: {})",
                    excerpt(h),
                    allowed.join(",")
                )));
            }
            if index.insert(h.clone(), i).is_some() {
                return Err(header_error(format!("column {h:?} appears twice")));
            }
        }
        Ok(TableReader {
            rdr,
            fence,
            headers,
            index,
            record: csv::StringRecord::new(),
            rows: 0,
        })
    }

    /// Returns the header as given.
    #[must_use]
    pub fn headers(&self) -> &[String] {
        &self.headers
    }

    /// Returns the number of rows read so far.
    #[must_use]
    pub fn rows_read(&self) -> usize {
        self.rows
    }

    /// Returns the next row, or `None` at the end of the input.
    ///
    /// # Errors
    /// [`Error::Csv`] naming the row and line for a row of the wrong width, bad CSV, a record
    /// longer than [`MAX_LINE_BYTES`] or a read failure.
    pub fn next_row(&mut self) -> Result<Option<Row>> {
        let (start, start_line) = (self.rdr.position().byte(), self.rdr.position().line());
        self.fence
            .at
            .store(start + MAX_LINE_BYTES as u64 + READ_AHEAD, Ordering::Relaxed);
        let number = self.rows + 1;
        match self.rdr.read_record(&mut self.record) {
            Ok(false) => Ok(None),
            Ok(true) => {
                self.rows = number;
                let line = self
                    .record
                    .position()
                    .map_or(number as u64 + 1, csv::Position::line);
                if self.record.as_slice().len() > MAX_LINE_BYTES {
                    return Err(Error::Csv {
                        context: format!("input row {number} (line {line})"),
                        message: format!("longer than {MAX_LINE_BYTES} bytes"),
                    });
                }
                Ok(Some(Row {
                    number,
                    line,
                    fields: self.record.iter().map(str::to_string).collect(),
                }))
            }
            Err(e) => {
                // A read stopped at the fence has no position: the row starts where the last ended.
                let line = e.position().map_or(start_line, csv::Position::line);
                Err(read_error(
                    &self.fence,
                    &format!("input row {number} (line {line})"),
                    e,
                ))
            }
        }
    }

    /// Returns the next row with what `parse` makes of its fields, or `None` at the end.
    ///
    /// # Errors
    /// As [`TableReader::next_row`], or `parse`'s error named by the row and its line.
    pub fn next_parsed<T>(
        &mut self,
        parse: impl FnOnce(&Self, &[String]) -> Result<T>,
    ) -> Result<Option<(Row, T)>> {
        let Some(row) = self.next_row()? else {
            return Ok(None);
        };
        let parsed = parse(self, &row.fields).map_err(|e| row_error(row.number, row.line, e))?;
        Ok(Some((row, parsed)))
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
                .map_err(|_| Error::invalid(format!("column {c}"), excerpt(s), "must be a number")),
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

/// Returns the error of reading at `context`: a record past the fence, bad CSV, or I/O.
fn read_error(fence: &Fence, context: &str, e: csv::Error) -> Error {
    let message = if fence.crossed.load(Ordering::Relaxed) {
        format!("longer than {MAX_LINE_BYTES} bytes, the most one row may hold")
    } else {
        match e.kind() {
            csv::ErrorKind::Io(io) => format!("cannot read the input: {io}"),
            csv::ErrorKind::Utf8 { .. } => "not valid UTF-8".to_string(),
            csv::ErrorKind::UnequalLengths {
                expected_len, len, ..
            } => {
                format!("{len} fields where the header has {expected_len}")
            }
            _ => e.to_string(),
        }
    };
    Error::Csv {
        context: context.to_string(),
        message,
    }
}

/// A CSV written row by row: the given columns plus extra ones, then rows of input fields plus
/// extra fields. The header goes out with the first row, so a table without rows writes nothing.
pub struct CsvOut<'a, W: Write> {
    wtr: csv::Writer<W>,
    header: Option<(&'a [String], &'a [&'a str])>,
}

impl<'a, W: Write> CsvOut<'a, W> {
    /// Returns a writer to `w` of tables with the columns `headers` then `extra`.
    pub fn new(w: W, headers: &'a [String], extra: &'a [&'a str]) -> Self {
        CsvOut {
            wtr: csv::Writer::from_writer(w),
            header: Some((headers, extra)),
        }
    }

    /// Writes one row: `fields` then `more`.
    ///
    /// # Errors
    /// [`Error::WriteOutput`] (named `output`) on I/O failure.
    pub fn row(&mut self, fields: &[String], more: &[String]) -> Result<()> {
        if let Some((headers, extra)) = self.header.take() {
            let header = headers.iter().map(String::as_str).chain(extra.iter().copied());
            self.wtr.write_record(header).map_err(write_error)?;
        }
        let record = fields.iter().chain(more).map(String::as_str);
        self.wtr.write_record(record).map_err(write_error)
    }

    /// Writes out what is buffered.
    ///
    /// # Errors
    /// [`Error::WriteOutput`] (named `output`) on I/O failure.
    pub fn flush(&mut self) -> Result<()> {
        self.wtr.flush().map_err(write_error)
    }
}

fn write_error(e: impl std::fmt::Display) -> Error {
    Error::WriteOutput {
        path: "output".into(),
        message: e.to_string(),
    }
}

/// Writes a CSV: `headers` then `extra` as the header, then each row of `rows` (input fields,
/// then extra fields). The header is written even without rows.
///
/// # Errors
/// [`Error::WriteOutput`] (named `output`) on I/O failure.
pub fn write_rows<F: AsRef<[String]>>(
    w: impl Write,
    headers: &[String],
    extra: &[&str],
    rows: impl IntoIterator<Item = (F, Vec<String>)>,
) -> Result<()> {
    let mut wtr = csv::Writer::from_writer(w);
    let header = headers.iter().map(String::as_str).chain(extra.iter().copied());
    wtr.write_record(header).map_err(write_error)?;
    for (fields, more) in rows {
        let record = fields.as_ref().iter().chain(&more).map(String::as_str);
        wtr.write_record(record).map_err(write_error)?;
    }
    wtr.flush().map_err(write_error)
}
