//! Sweep parts on disk (chunks, shards, the result), each with a record `NAME.meta.json`.
//!
//! The record holds the sweep's fingerprint, first pose index, row count, size and CRC-32. A
//! part counts only when its record and bytes match. This catches truncated, foreign and
//! copied-over parts.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::report::{write_atomic, write_atomic_unsynced};

/// The record beside a part file: what the part holds.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartRecord {
    /// The fingerprint of the sweep the part belongs to.
    pub fingerprint: String,
    /// The index of its first pose.
    pub first: u64,
    /// Its rows (poses), not counting the header.
    pub rows: u64,
    /// Its size in bytes.
    pub bytes: u64,
    /// The CRC-32 of its bytes, as 8 hex digits.
    pub crc32: String,
}

/// What a reader expects of a part.
#[derive(Clone, Copy, Debug)]
pub struct Expected<'a> {
    /// The sweep's fingerprint.
    pub fingerprint: &'a str,
    /// The index of the first pose.
    pub first: u64,
    /// The number of poses.
    pub rows: u64,
}

/// The state of a part on disk.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Status {
    /// Present and as expected.
    Good,
    /// Not there.
    Missing,
    /// There, but not as expected. Holds the reason in words.
    Damaged(String),
}

/// Returns the path of part `file`'s record. CSV and Parquet parts keep separate records:
/// `NAME.csv` → `NAME.meta.json`, `NAME.parquet` → `NAME.parquet.meta.json`.
#[must_use]
pub fn record_path(file: &Path) -> PathBuf {
    beside(file, "meta.json")
}

/// Returns the path of the file `suffix` beside part `file`: `NAME.suffix` for a CSV part,
/// `NAME.EXT.suffix` for any other.
#[must_use]
pub fn beside(file: &Path, suffix: &str) -> PathBuf {
    match file.extension().and_then(|e| e.to_str()) {
        Some("csv") | None => file.with_extension(suffix),
        Some(ext) => file.with_extension(format!("{ext}.{suffix}")),
    }
}

struct Summing<'w> {
    inner: &'w mut (dyn Write + Send),
    hasher: crc32fast::Hasher,
    bytes: u64,
}

impl Write for Summing<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hasher.update(&buf[..n]);
        self.bytes += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Writes part `file` with `fill`, whole or not at all, then its record for `expected`.
/// The record comes second, so a part cut off between the two is found damaged and redone.
///
/// # Errors
/// As [`write_atomic`], and `fill`'s errors.
pub fn write(
    file: &Path,
    expected: Expected<'_>,
    fill: impl FnOnce(&mut (dyn Write + Send)) -> Result<()>,
) -> Result<()> {
    write_with(file, expected, true, fill)
}

/// Writes a run's chunk `file` like [`write()`], but unflushed ([`write_atomic_unsynced`]).
///
/// A chunk is read only after its size and checksum match its record. So a crash that loses its
/// bytes leaves it damaged and recomputed, never wrong. A run's results use [`write()`].
///
/// # Errors
/// As [`write()`].
pub fn write_chunk(
    file: &Path,
    expected: Expected<'_>,
    fill: impl FnOnce(&mut (dyn Write + Send)) -> Result<()>,
) -> Result<()> {
    state_file(file)?;
    state_file(&record_path(file))?;
    write_with(file, expected, false, fill)
}

/// Returns an error when `path`, a file of a run's state, exists and is not a regular file (a
/// FIFO, a device, a link): the state holds only files the run wrote, and writing through such
/// a one would wait on a FIFO or feed a device.
///
/// # Errors
/// [`Error::WriteOutput`] naming it.
pub(crate) fn state_file(path: &Path) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if !m.file_type().is_file() => Err(Error::WriteOutput {
            path: path.to_path_buf(),
            message: format!(
                "{}: a run's state holds only the files it wrote; remove it (or the whole {}) to \
                 go on",
                sonarproj::files::NOT_REGULAR,
                path.parent()
                    .map_or_else(String::new, |p| p.display().to_string())
            ),
        }),
        _ => Ok(()),
    }
}

/// Writes like [`write()`], flushing to disk only when `sync`.
fn write_with(
    file: &Path,
    expected: Expected<'_>,
    sync: bool,
    fill: impl FnOnce(&mut (dyn Write + Send)) -> Result<()>,
) -> Result<()> {
    let atomic = |path: &Path, fill: &mut dyn FnMut(&mut (dyn Write + Send)) -> Result<()>| {
        if sync {
            write_atomic(path, fill)
        } else {
            write_atomic_unsynced(path, fill)
        }
    };
    let mut fill = Some(fill);
    let mut sums = (0u64, 0u32);
    atomic(file, &mut |w: &mut (dyn Write + Send)| {
        let mut summing = Summing {
            inner: w,
            hasher: crc32fast::Hasher::new(),
            bytes: 0,
        };
        (fill.take().expect("written once"))(&mut summing)?;
        sums = (summing.bytes, summing.hasher.finalize());
        Ok(())
    })?;
    let record = PartRecord {
        fingerprint: expected.fingerprint.to_string(),
        first: expected.first,
        rows: expected.rows,
        bytes: sums.0,
        crc32: format!("{:08x}", sums.1),
    };
    write_json_with(&record_path(file), &record, sync)
}

/// Writes `value` to `path` as pretty JSON, whole or not at all.
pub(crate) fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    write_json_with(path, value, true)
}

/// Writes like [`write_json`], flushing before the rename only when `sync`.
fn write_json_with<T: Serialize>(path: &Path, value: &T, sync: bool) -> Result<()> {
    let fill = |w: &mut (dyn Write + Send)| {
        serde_json::to_writer_pretty(&mut *w, value).map_err(|e| Error::write_output(path, e))?;
        w.write_all(b"\n").map_err(|e| Error::write_output(path, e))
    };
    if sync {
        write_atomic(path, fill)
    } else {
        write_atomic_unsynced(path, fill)
    }
}

fn check_record(file: &Path, expected: Expected<'_>) -> std::result::Result<PartRecord, String> {
    let path = record_path(file);
    let text = sonarproj::files::read_regular(&path, crate::sweep::records::MAX_RECORD_BYTES).map_err(
        |e| match e.kind() {
            std::io::ErrorKind::NotFound => format!("its record {} is missing", name(&path)),
            _ => format!("its record {} cannot be read ({e})", name(&path)),
        },
    )?;
    let record: PartRecord =
        serde_json::from_slice(&text).map_err(|e| format!("its record {} is not one ({e})", name(&path)))?;
    if record.fingerprint != expected.fingerprint {
        return Err(format!(
            "it belongs to another sweep (its fingerprint is {}, sweep.json's is {})",
            record.fingerprint, expected.fingerprint
        ));
    }
    if (record.first, record.rows) != (expected.first, expected.rows) {
        return Err(format!(
            "it holds poses {} to {} where poses {} to {} belong",
            record.first,
            (record.first + record.rows).saturating_sub(1),
            expected.first,
            (expected.first + expected.rows).saturating_sub(1)
        ));
    }
    Ok(record)
}

fn name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// Returns `Ok` when `bytes`, the content of part `file`, match its record for `expected`.
///
/// # Errors
/// The reason in words, as [`Status::Damaged`] gives it.
pub fn check_bytes(file: &Path, bytes: &[u8], expected: Expected<'_>) -> std::result::Result<(), String> {
    let record = check_record(file, expected)?;
    if bytes.len() as u64 != record.bytes {
        return Err(format!(
            "it has {} bytes where its record says {}",
            bytes.len(),
            record.bytes
        ));
    }
    if format!("{:08x}", crc32fast::hash(bytes)) != record.crc32 {
        return Err("its bytes differ from its record's checksum".into());
    }
    Ok(())
}

/// Returns whether `path` is a regular file, following links. A device or FIFO is never read
/// back: opening a FIFO would wait for a writer.
pub(crate) fn is_regular(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.is_file())
}

/// Returns the state of part `file`: good when record and bytes match `expected`, missing when
/// absent or a device or FIFO (nothing to read back), else damaged with the reason.
#[must_use]
pub fn check(file: &Path, expected: Expected<'_>) -> Status {
    if !is_regular(file) {
        return Status::Missing;
    }
    let record = match check_record(file, expected) {
        Ok(r) => r,
        Err(reason) => return Status::Damaged(reason),
    };
    match sums(file) {
        Ok((bytes, crc)) if bytes == record.bytes && format!("{crc:08x}") == record.crc32 => Status::Good,
        Ok((bytes, _)) if bytes != record.bytes => Status::Damaged(format!(
            "it has {bytes} bytes where its record says {}",
            record.bytes
        )),
        Ok(_) => Status::Damaged("its bytes differ from its record's checksum".into()),
        Err(e) => Status::Damaged(format!("it cannot be read ({e})")),
    }
}

/// Returns the record of part `part`, or `None` when it is missing or unreadable.
fn record_of(part: &Path) -> Option<PartRecord> {
    let text =
        sonarproj::files::read_regular(&record_path(part), crate::sweep::records::MAX_RECORD_BYTES).ok()?;
    serde_json::from_slice(&text).ok()
}

fn sums(file: &Path) -> std::io::Result<(u64, u32)> {
    let mut r = BufReader::with_capacity(1 << 16, sonarproj::files::open_regular(file)?);
    let mut hasher = crc32fast::Hasher::new();
    let mut bytes = 0u64;
    loop {
        let buf = r.fill_buf()?;
        if buf.is_empty() {
            return Ok((bytes, hasher.finalize()));
        }
        hasher.update(buf);
        let n = buf.len();
        bytes += n as u64;
        r.consume(n);
    }
}

/// Writes CSV `out` and its record, whole or not at all: header `columns`, then each part's rows.
/// Each part is checked as read: its header must be `columns`, its size and checksum its record's.
///
/// # Errors
/// [`Error::Csv`] naming a part that is not what its record says; [`Error::ReadInput`] and
/// [`Error::WriteOutput`] on I/O failure.
pub fn join(
    parts: impl IntoIterator<Item = PathBuf>,
    columns: &[String],
    out: &Path,
    expected: Expected<'_>,
) -> Result<()> {
    let mut want = Vec::new();
    {
        let mut w = csv::Writer::from_writer(&mut want);
        w.write_record(columns).map_err(|e| Error::write_output(out, e))?;
        w.flush().map_err(|e| Error::write_output(out, e))?;
    }
    write(out, expected, |w| {
        w.write_all(&want).map_err(|e| Error::write_output(out, e))?;
        for part in parts {
            let part = &part;
            let damaged = |message: String| Error::Csv {
                context: part.display().to_string(),
                message,
            };
            let record =
                record_of(part).ok_or_else(|| damaged("its record is missing or unreadable".into()))?;
            let f = sonarproj::files::open_regular(part).map_err(|source| Error::ReadInput {
                path: part.clone(),
                source,
            })?;
            let mut r = BufReader::with_capacity(1 << 16, f);
            let mut hasher = crc32fast::Hasher::new();
            let mut line = Vec::new();
            let mut read = |r: &mut BufReader<std::fs::File>, line: &mut Vec<u8>| {
                line.clear();
                let n = r.read_until(b'\n', line).map_err(|source| Error::ReadInput {
                    path: part.clone(),
                    source,
                })?;
                hasher.update(line);
                Ok::<_, Error>(n)
            };
            read(&mut r, &mut line)?;
            if line != want {
                return Err(damaged(
                    "its header differs from this sweep's columns: a part of another sweep".into(),
                ));
            }
            let mut bytes = line.len() as u64;
            while read(&mut r, &mut line)? > 0 {
                w.write_all(&line).map_err(|e| Error::write_output(out, e))?;
                bytes += line.len() as u64;
            }
            let crc = format!("{:08x}", hasher.finalize());
            if bytes != record.bytes || crc != record.crc32 {
                return Err(damaged(
                    "its bytes changed after it was checked (size or checksum differ from its record)".into(),
                ));
            }
        }
        Ok(())
    })
}

/// Writes Parquet `out` and its record, whole or not at all, from the rows of `parts` in order.
///
/// Each part's size and checksum are checked before and after reading, its columns against
/// `columns`. Row groups are cut at multiples of [`GROUP_ROWS`](crate::io::parquet::GROUP_ROWS)
/// of the pose index, so the same rows make the same file however they were chunked or sharded.
///
/// # Errors
/// [`Error::Csv`] naming a part that is not what its record says or not this sweep's table;
/// [`Error::ReadInput`] and [`Error::WriteOutput`] on I/O failure.
pub fn join_parquet(
    parts: impl IntoIterator<Item = PathBuf>,
    columns: &[String],
    kinds: &[crate::io::parquet::Kind],
    out: &Path,
    expected: Expected<'_>,
) -> Result<()> {
    write(out, expected, |w| {
        let mut join = ParquetJoin::new(w, columns, kinds, out, expected)?;
        let parts: Vec<PathBuf> = parts.into_iter().collect();
        for (p, part) in parts.iter().enumerate() {
            join.add_file(part, p + 1 == parts.len())?;
        }
        join.finish()
    })
}

/// A Parquet table joined from parts in index order, by [`join_parquet`] or a running sweep.
/// Whole row groups are copied as they are (all parts share one encoding); others are re-cut.
pub(crate) struct ParquetJoin<'a, W: Write + Send> {
    table: crate::io::parquet::TableWriter<'a, W>,
    columns: &'a [String],
    kinds: &'a [crate::io::parquet::Kind],
    out: &'a Path,
    rows: u64,
    expected: u64,
}

impl<'a, W: Write + Send> ParquetJoin<'a, W> {
    /// Returns a join into `w` (the file `out`) of the table `expected` describes.
    pub(crate) fn new(
        w: W,
        columns: &'a [String],
        kinds: &'a [crate::io::parquet::Kind],
        out: &'a Path,
        expected: Expected<'_>,
    ) -> Result<Self> {
        let table = crate::io::parquet::TableWriter::new(
            w,
            columns,
            kinds,
            expected.first,
            final_encoding(columns),
            out,
        )?;
        Ok(ParquetJoin {
            table,
            columns,
            kinds,
            out,
            rows: 0,
            expected: expected.rows,
        })
    }

    /// Adds the rows of part `part`, checked against its record before and after reading.
    pub(crate) fn add_file(&mut self, part: &Path, last: bool) -> Result<()> {
        let damaged = |message: String| Error::Csv {
            context: part.display().to_string(),
            message,
        };
        let record = record_of(part).ok_or_else(|| damaged("its record is missing or unreadable".into()))?;
        let same = |when: &str| match sums(part) {
            Ok((bytes, crc)) if bytes == record.bytes && format!("{crc:08x}") == record.crc32 => Ok(()),
            Ok(_) => Err(damaged(format!(
                "its bytes differ from its record (size or checksum) {when} it was read"
            ))),
            Err(source) => Err(Error::ReadInput {
                path: part.to_path_buf(),
                source,
            }),
        };
        same("before")?;
        let opened = crate::io::parquet::open_part(part, self.columns, self.kinds)?;
        self.add(&opened, part, last)?;
        same("after")
    }

    /// Adds the rows of the Parquet `bytes` just written as part `part`.
    pub(crate) fn add_bytes(&mut self, bytes: bytes::Bytes, part: &Path, last: bool) -> Result<()> {
        let opened = crate::io::parquet::open_part_bytes(bytes, part, self.columns, self.kinds)?;
        self.add(&opened, part, last)
    }

    fn add<R: parquet::file::reader::ChunkReader + 'static>(
        &mut self,
        opened: &crate::io::parquet::Part<R>,
        part: &Path,
        last: bool,
    ) -> Result<()> {
        let groups = opened.group_rows();
        for (g, n) in groups.iter().enumerate() {
            let last = last && g + 1 == groups.len();
            if !self.table.copy_group(opened, g, last)? {
                self.table
                    .push(opened.group(g, part, self.columns, self.kinds)?)?;
            }
            self.rows += n;
        }
        Ok(())
    }

    /// Writes the footer, after checking that the parts held the expected rows.
    pub(crate) fn finish(self) -> Result<()> {
        if self.rows != self.expected {
            return Err(Error::Csv {
                context: self.out.display().to_string(),
                message: format!("its parts hold {} rows where {} belong", self.rows, self.expected),
            });
        }
        self.table.finish()
    }
}

/// Returns the encoding shared by a sweep's chunks, shards and result, so row groups copy as-is.
/// It uses Snappy pages, statistics, dictionaries for the pose columns, whose values repeat, and
/// deltas for the index (the first column), which rises by one a row: a few bytes a row group
/// instead of half a megabyte.
#[must_use]
pub fn final_encoding(columns: &[String]) -> crate::io::parquet::Encoding<'_> {
    let poses = crate::sweep::columns::pose_column_count(columns);
    crate::io::parquet::Encoding {
        dictionary: columns.get(1..1 + poses).unwrap_or_default(),
        delta: columns.get(..1).filter(|c| c[0] == "index").unwrap_or_default(),
    }
}

/// Removes part `file` and its record, left by an earlier run, where this run keeps the part in
/// memory instead. Special files there are refused, as [`write_chunk`] refuses them.
///
/// # Errors
/// As [`state_file`] and [`remove`].
pub(crate) fn remove_stale(file: &Path) -> Result<()> {
    state_file(file)?;
    state_file(&record_path(file))?;
    remove(file)
}

/// Removes part `file` and its record, when they exist.
///
/// # Errors
/// [`Error::WriteOutput`] when one exists and cannot be removed.
pub fn remove(file: &Path) -> Result<()> {
    for path in [file.to_path_buf(), record_path(file)] {
        match std::fs::remove_file(&path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(Error::write_output(&path, e)),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_is_good_only_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("chunk-00000001.csv");
        let expected = Expected {
            fingerprint: "abc",
            first: 10,
            rows: 2,
        };
        assert_eq!(check(&file, expected), Status::Missing);
        write(&file, expected, |w| {
            w.write_all(b"index,x\n10,1\n11,2\n").unwrap();
            Ok(())
        })
        .unwrap();
        assert_eq!(check(&file, expected), Status::Good);
        // The CRC-32, computed apart from the writer.
        let record: PartRecord = serde_json::from_slice(&std::fs::read(record_path(&file)).unwrap()).unwrap();
        assert_eq!(
            record.crc32,
            format!("{:08x}", crc32fast::hash(b"index,x\n10,1\n11,2\n"))
        );
        assert_eq!(record.bytes, 18);

        let other = Expected {
            fingerprint: "abd",
            ..expected
        };
        assert!(matches!(check(&file, other), Status::Damaged(r) if r.contains("another sweep")));
        let moved = Expected {
            first: 12,
            ..expected
        };
        assert!(matches!(check(&file, moved), Status::Damaged(r) if r.contains("poses 10 to 11")));
        std::fs::write(&file, b"index,x\n10,1\n11,3\n").unwrap();
        assert!(matches!(check(&file, expected), Status::Damaged(r) if r.contains("checksum")));
        std::fs::write(&file, b"index,x\n10,1\n").unwrap();
        assert!(matches!(check(&file, expected), Status::Damaged(r) if r.contains("bytes")));
        std::fs::remove_file(record_path(&file)).unwrap();
        assert!(matches!(check(&file, expected), Status::Damaged(r) if r.contains("missing")));
        // A chunk written without flushing is the same part: the same bytes, the same record.
        let chunk = dir.path().join("chunk-00000002.csv");
        write_chunk(&chunk, expected, |w| {
            w.write_all(b"index,x\n10,1\n11,2\n").unwrap();
            Ok(())
        })
        .unwrap();
        assert_eq!(check(&chunk, expected), Status::Good);
        assert_eq!(std::fs::read(&chunk).unwrap(), b"index,x\n10,1\n11,2\n");
        assert_eq!(
            std::fs::read(record_path(&chunk)).unwrap(),
            serde_json::to_vec_pretty(&record)
                .unwrap()
                .into_iter()
                .chain(*b"\n")
                .collect::<Vec<u8>>()
        );
    }
}
