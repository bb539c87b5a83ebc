//! Input and output formats:
//! - CSV projection batches (`batch`) and correspondences to recover (`recover`), both read
//!   through one checked table reader (`table`);
//! - values given as text: pose strings, features, mask stream lines (`text`);
//! - sweep tables as Parquet (`parquet`).

pub mod bag;
pub mod bag_masks;
pub mod batch;
pub mod oculus;
pub mod parquet;
pub mod pose_columns;
pub mod recover;
pub mod table;
pub mod text;
pub mod tf;
pub(crate) mod toml_keys;

pub use batch::{
    BatchInput, BatchReader, METRIC_COLUMNS, metric_fields, project_csv, read_batch_csv,
    read_batch_csv_at_most,
};

/// Returns `v` in its shortest exact form, or an empty field for `None`.
#[must_use]
pub fn field(v: Option<f64>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

pub use crate::limits::MAX_LINE_BYTES;
pub use sonarproj::error::excerpt;
pub use sonarproj::limits::EXCERPT_CHARS;

/// One line read by [`read_line_bounded`].
#[derive(Debug, PartialEq, Eq)]
pub enum BoundedLine {
    /// A line within the limit is in the buffer (without its `\n` or `\r\n`).
    Line,
    /// A line longer than the limit was skipped. Holds its length in bytes.
    TooLong(u64),
}

/// Reads the next line of `reader` into `buf`, or returns `None` at the end of the input.
/// `buf` is cleared first and holds at most `max` bytes, counting a `\r` before the `\n`. A
/// longer line is read through and dropped.
///
/// # Errors
/// The reader's I/O errors.
pub fn read_line_bounded(
    reader: &mut impl std::io::BufRead,
    max: usize,
    buf: &mut Vec<u8>,
) -> std::io::Result<Option<BoundedLine>> {
    buf.clear();
    let mut len: u64 = 0;
    let mut started = false;
    loop {
        let chunk = match reader.fill_buf() {
            Ok(c) => c,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if chunk.is_empty() {
            if !started {
                return Ok(None);
            }
            break;
        }
        started = true;
        let end = chunk.iter().position(|&b| b == b'\n');
        let part = &chunk[..end.unwrap_or(chunk.len())];
        len += part.len() as u64;
        if len <= max as u64 {
            buf.extend_from_slice(part);
        } else {
            buf.clear();
        }
        let used = end.map_or(chunk.len(), |i| i + 1);
        reader.consume(used);
        if end.is_some() {
            break;
        }
    }
    if len > max as u64 {
        return Ok(Some(BoundedLine::TooLong(len)));
    }
    if buf.last() == Some(&b'\r') {
        buf.pop();
    }
    Ok(Some(BoundedLine::Line))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn excerpts_cut_long_text() {
        assert_eq!(excerpt("range"), "\"range\"");
        let long = "é".repeat(1000);
        let quoted = excerpt(&long);
        assert!(quoted.starts_with(&format!("{:?}", "é".repeat(EXCERPT_CHARS))));
        assert!(quoted.ends_with("… (2000 bytes)"), "{quoted}");
    }

    #[test]
    fn lines_are_read_whole_or_skipped_past_the_limit() {
        let mut input: &[u8] = b"short\r\n0123456789\nlast";
        let mut buf = Vec::new();
        let mut next = |buf: &mut Vec<u8>| read_line_bounded(&mut input, 6, buf).unwrap();
        assert_eq!(next(&mut buf), Some(BoundedLine::Line));
        assert_eq!(buf, b"short");
        assert_eq!(next(&mut buf), Some(BoundedLine::TooLong(10)));
        assert_eq!(next(&mut buf), Some(BoundedLine::Line));
        assert_eq!(buf, b"last");
        assert_eq!(next(&mut buf), None);
    }
}
