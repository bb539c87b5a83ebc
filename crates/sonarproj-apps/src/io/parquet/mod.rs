//! Sweep tables as Parquet: typed columns, Snappy-compressed pages, and row groups cut at fixed
//! multiples of the pose index. The same rows then make the same bytes however they were
//! chunked, sharded and merged. Integers hold the index and counts, doubles the poses and
//! metrics, and nulls stand for the CSV's empty cells.

use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use parquet::basic::{Compression, Encoding as ParquetEncoding, Repetition, Type as Physical};
use parquet::column::writer::{ColumnCloseResult, get_column_writer, get_typed_column_writer_mut};
use parquet::data_type::{DoubleType, Int64Type};
use parquet::file::metadata::ColumnChunkMetaData;
use parquet::file::properties::{WriterProperties, WriterPropertiesPtr, WriterVersion};
use parquet::file::reader::FileReader;
use parquet::file::statistics::Statistics;
use parquet::file::writer::{SerializedFileWriter, SerializedPageWriter, TrackedWrite};
use parquet::schema::types::ColumnDescPtr;
use parquet::schema::types::ColumnPath;
use parquet::schema::types::Type;
use rayon::prelude::*;

use crate::error::{Error, Result};

/// Rows per row group: groups start at multiples of this pose index. About 20 MiB of columns
/// are in memory while one is assembled.
pub const GROUP_ROWS: u64 = 1 << 17;

/// What a column holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Whole numbers (the index, counts): `INT64`.
    Int,
    /// Numbers: `DOUBLE`.
    Real,
    /// Numbers that may be absent: `DOUBLE`, nullable.
    Optional,
}

/// One column's values.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// [`Kind::Int`].
    Int(Vec<i64>),
    /// [`Kind::Real`].
    Real(Vec<f64>),
    /// [`Kind::Optional`].
    Optional(Vec<Option<f64>>),
}

impl Column {
    /// Returns an empty column of `kind`.
    #[must_use]
    pub fn new(kind: Kind) -> Column {
        match kind {
            Kind::Int => Column::Int(Vec::new()),
            Kind::Real => Column::Real(Vec::new()),
            Kind::Optional => Column::Optional(Vec::new()),
        }
    }

    /// Returns the number of values.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            Column::Int(v) => v.len(),
            Column::Real(v) => v.len(),
            Column::Optional(v) => v.len(),
        }
    }

    /// Returns whether the column has no values.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Returns value `i` as a number (`None` when absent).
    #[expect(clippy::cast_precision_loss, reason = "indices and counts below 2^53")]
    #[must_use]
    pub fn get(&self, i: usize) -> Option<f64> {
        match self {
            Column::Int(v) => Some(v[i] as f64),
            Column::Real(v) => Some(v[i]),
            Column::Optional(v) => v[i],
        }
    }

    /// Moves the first `n` values out into a new column.
    fn take_front(&mut self, n: usize) -> Column {
        if n == self.len() {
            return std::mem::replace(self, self.empty_like());
        }
        match self {
            Column::Int(v) => Column::Int(v.drain(..n).collect()),
            Column::Real(v) => Column::Real(v.drain(..n).collect()),
            Column::Optional(v) => Column::Optional(v.drain(..n).collect()),
        }
    }

    fn empty_like(&self) -> Column {
        match self {
            Column::Int(_) => Column::Int(Vec::new()),
            Column::Real(_) => Column::Real(Vec::new()),
            Column::Optional(_) => Column::Optional(Vec::new()),
        }
    }

    /// Appends `other`'s values (of the same kind).
    fn append(&mut self, other: Column) {
        match (self, other) {
            (Column::Int(a), Column::Int(b)) => a.extend(b),
            (Column::Real(a), Column::Real(b)) => a.extend(b),
            (Column::Optional(a), Column::Optional(b)) => a.extend(b),
            _ => unreachable!("columns of one schema"),
        }
    }
}

/// Named, typed columns of equal length.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// Column names.
    pub names: Vec<String>,
    /// The columns, in `names` order.
    pub columns: Vec<Column>,
}

impl Table {
    /// Returns an empty table with columns `names` of `kinds`.
    #[must_use]
    pub fn new(names: &[String], kinds: &[Kind]) -> Table {
        Table {
            names: names.to_vec(),
            columns: kinds.iter().map(|&k| Column::new(k)).collect(),
        }
    }

    /// Returns the number of rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Column::len)
    }

    /// Returns the column named `name`.
    #[must_use]
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| &self.columns[i])
    }

    /// Appends `other`'s rows (a table of the same columns).
    ///
    /// # Errors
    /// [`Error::Csv`] when `other`'s columns or their kinds differ.
    pub fn append(&mut self, other: Table) -> Result<()> {
        if other.names != self.names || other.kinds() != self.kinds() {
            return Err(Error::Csv {
                context: "table".into(),
                message: format!("columns {:?} differ from {:?}", other.names, self.names),
            });
        }
        for (a, b) in self.columns.iter_mut().zip(other.columns) {
            a.append(b);
        }
        Ok(())
    }

    /// Returns the kinds of the columns.
    #[must_use]
    pub fn kinds(&self) -> Vec<Kind> {
        self.columns
            .iter()
            .map(|c| match c {
                Column::Int(_) => Kind::Int,
                Column::Real(_) => Kind::Real,
                Column::Optional(_) => Kind::Optional,
            })
            .collect()
    }
}

fn schema(names: &[String], kinds: &[Kind]) -> Result<Arc<Type>> {
    let fields = names
        .iter()
        .zip(kinds)
        .map(|(name, kind)| {
            let (physical, repetition) = match kind {
                Kind::Int => (Physical::INT64, Repetition::REQUIRED),
                Kind::Real => (Physical::DOUBLE, Repetition::REQUIRED),
                Kind::Optional => (Physical::DOUBLE, Repetition::OPTIONAL),
            };
            Type::primitive_type_builder(name, physical)
                .with_repetition(repetition)
                .build()
                .map(Arc::new)
        })
        .collect::<parquet::errors::Result<Vec<_>>>()
        .map_err(|e| Error::invalid("columns", format!("{names:?}"), e.to_string()))?;
    Type::group_type_builder("sweep")
        .with_fields(fields)
        .build()
        .map(Arc::new)
        .map_err(|e| Error::invalid("columns", format!("{names:?}"), e.to_string()))
}

/// How a [`TableWriter`] encodes: Snappy pages, statistics, dictionaries for the columns named
/// (the pose columns, whose values repeat) and deltas for the whole-number columns named (the
/// index, which rises by one a row). Every file of a sweep (chunks, shards, results) uses one
/// encoding, so whole row groups copy between them as they are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Encoding<'a> {
    /// The columns to dictionary-encode.
    pub dictionary: &'a [String],
    /// The whole-number columns to encode as deltas (`DELTA_BINARY_PACKED`).
    pub delta: &'a [String],
}

/// Writes a table as Parquet, one row group at a time. Rows are pushed in index order, and a
/// group ends where the pose index reaches a multiple of [`GROUP_ROWS`].
pub struct TableWriter<'p, W: Write + Send> {
    inner: SerializedFileWriter<W>,
    pending: Table,
    /// The pose index of the first pending row.
    next: u64,
    path: &'p Path,
}

impl<'p, W: Write + Send> TableWriter<'p, W> {
    /// Returns a writer into `sink` of columns `names` of `kinds`, whose first row has pose index
    /// `first`. `path` names the file in messages.
    ///
    /// # Errors
    /// [`Error::WriteOutput`] when the header cannot be written.
    pub fn new(
        sink: W,
        names: &[String],
        kinds: &[Kind],
        first: u64,
        encoding: Encoding<'_>,
        path: &'p Path,
    ) -> Result<Self> {
        let mut props = WriterProperties::builder()
            .set_writer_version(WriterVersion::PARQUET_1_0)
            .set_created_by(format!("sonarproj {}", sonarproj::VERSION))
            .set_dictionary_enabled(false);
        props = props.set_compression(Compression::SNAPPY);
        for name in encoding.dictionary {
            props = props.set_column_dictionary_enabled(ColumnPath::from(name.as_str()), true);
        }
        for name in encoding.delta {
            props = props.set_column_encoding(
                ColumnPath::from(name.as_str()),
                ParquetEncoding::DELTA_BINARY_PACKED,
            );
        }
        let props = props.build();
        let inner = SerializedFileWriter::new(sink, schema(names, kinds)?, Arc::new(props))
            .map_err(|e| Error::write_output(path, e))?;
        Ok(TableWriter {
            inner,
            pending: Table::new(names, kinds),
            next: first,
            path,
        })
    }

    /// Adds `rows` (the next rows in index order) and writes every row group they complete.
    ///
    /// # Errors
    /// [`Error::Csv`] when `rows` has other columns. [`Error::WriteOutput`] on I/O failure.
    pub fn push(&mut self, rows: Table) -> Result<()> {
        if rows.names != self.pending.names || rows.kinds() != self.pending.kinds() {
            return Err(Error::Csv {
                context: self.path.display().to_string(),
                message: format!(
                    "a part's columns {:?} differ from this sweep's {:?}: a part of another sweep",
                    rows.names, self.pending.names
                ),
            });
        }
        if self.pending.rows() == 0 {
            // Nothing pending: take the rows as they are, without copying.
            self.pending.columns = rows.columns;
        } else {
            for (a, b) in self.pending.columns.iter_mut().zip(rows.columns) {
                a.append(b);
            }
        }
        loop {
            #[expect(clippy::cast_possible_truncation, reason = "below GROUP_ROWS")]
            let to_boundary = (GROUP_ROWS - self.next % GROUP_ROWS) as usize;
            if self.pending.rows() < to_boundary {
                return Ok(());
            }
            self.write_group(to_boundary)?;
        }
    }

    /// Writes the first `n` pending rows as one row group. Its columns are encoded on all cores,
    /// each into memory, then spliced into the file in order: the bytes of encoding them in turn.
    fn write_group(&mut self, n: usize) -> Result<()> {
        let err = |e: parquet::errors::ParquetError| Error::write_output(self.path, e);
        let group: Vec<Column> = self.pending.columns.iter_mut().map(|c| c.take_front(n)).collect();
        let descriptors = self.inner.schema_descr().columns().to_vec();
        let props = self.inner.properties().clone();
        let encoded = group
            .par_iter()
            .zip(descriptors)
            .map(|(column, descr)| encode_column(descr, props.clone(), column))
            .collect::<parquet::errors::Result<Vec<_>>>()
            .map_err(err)?;
        let mut rg = self.inner.next_row_group().map_err(err)?;
        for (bytes, close) in encoded {
            rg.append_column(&bytes, close).map_err(err)?;
        }
        rg.close().map_err(err)?;
        self.next += n as u64;
        Ok(())
    }

    /// Copies row group `g` of `part` into this file without decoding it, and returns whether it
    /// did (else the caller pushes its rows). It copies only when that makes the bytes encoding
    /// would: no rows pending, the group starting at a multiple of [`GROUP_ROWS`] in the pose
    /// index, and whole (or `last`, this file's last rows). The part must come from a
    /// [`TableWriter`] with this one's encoding, read with its page indexes.
    ///
    /// # Errors
    /// [`Error::WriteOutput`] on I/O failure.
    pub fn copy_group<R: parquet::file::reader::ChunkReader + 'static>(
        &mut self,
        part: &Part<R>,
        g: usize,
        last: bool,
    ) -> Result<bool> {
        let err = |e: parquet::errors::ParquetError| Error::write_output(self.path, e);
        let meta = part.reader.metadata();
        let group = meta.row_group(g);
        let rows = u64::try_from(group.num_rows()).unwrap_or(0);
        let whole = rows == GROUP_ROWS || (last && rows > 0 && rows < GROUP_ROWS);
        if self.pending.rows() > 0 || !self.next.is_multiple_of(GROUP_ROWS) || !whole {
            return Ok(false);
        }
        // Only a group made with this writer's encoding (compression, statistics, dictionaries,
        // deltas) is copied. A part written otherwise, say by an older version, is decoded and
        // encoded again.
        let props = self.inner.properties();
        let same = group.columns().iter().all(|c| {
            let path = c.column_path();
            let delta = c.encodings().any(|e| e == ParquetEncoding::DELTA_BINARY_PACKED);
            c.compression() == props.compression(path)
                && c.statistics().is_some()
                && c.dictionary_page_offset().is_some() == props.dictionary_enabled(path)
                && delta == (props.encoding(path) == Some(ParquetEncoding::DELTA_BINARY_PACKED))
        });
        if !same {
            return Ok(false);
        }
        let index = meta.page_index();
        let mut rg = self.inner.next_row_group().map_err(err)?;
        for (j, column) in group.columns().iter().enumerate() {
            let close = ColumnCloseResult {
                bytes_written: u64::try_from(column.compressed_size()).unwrap_or(0),
                rows_written: rows,
                metadata: as_written(column).map_err(err)?,
                bloom_filter: None,
                column_index: index.and_then(|i| i.column_index(g, j)).cloned(),
                offset_index: index.and_then(|i| i.offset_index(g, j)).cloned(),
            };
            rg.append_column(&part.file, close).map_err(err)?;
        }
        rg.close().map_err(err)?;
        self.next += rows;
        Ok(true)
    }

    /// Writes the last row group and the footer.
    ///
    /// # Errors
    /// [`Error::WriteOutput`] on I/O failure.
    pub fn finish(mut self) -> Result<()> {
        let n = self.pending.rows();
        if n > 0 {
            self.write_group(n)?;
        }
        self.inner
            .close()
            .map_err(|e| Error::write_output(self.path, e))?;
        Ok(())
    }
}

/// Returns a column chunk's metadata as its writer made it. The reader marks statistics from
/// the `min_value`/`max_value` fields as not backwards compatible. The writer also fills the
/// deprecated `min`/`max` fields for a signed sort order (every column here), so the mark is
/// restored.
fn as_written(column: &ColumnChunkMetaData) -> parquet::errors::Result<ColumnChunkMetaData> {
    let signed = column.column_descr().sort_order().is_signed();
    let Some(stats) = column.statistics() else {
        return Ok(column.clone());
    };
    let stats = match stats.clone() {
        Statistics::Int64(v) => Statistics::Int64(v.with_backwards_compatible_min_max(signed)),
        Statistics::Double(v) => Statistics::Double(v.with_backwards_compatible_min_max(signed)),
        other => other,
    };
    column.clone().into_builder().set_statistics(stats).build()
}

/// Returns `column` encoded alone into memory with `props`: its bytes, and what closing its
/// writer returned (offsets from the start of the bytes).
fn encode_column(
    descr: ColumnDescPtr,
    props: WriterPropertiesPtr,
    column: &Column,
) -> parquet::errors::Result<(bytes::Bytes, ColumnCloseResult)> {
    let mut sink = TrackedWrite::new(Vec::new());
    let close = {
        let mut w = get_column_writer(descr, props, Box::new(SerializedPageWriter::new(&mut sink)));
        match column {
            Column::Int(v) => {
                get_typed_column_writer_mut::<Int64Type>(&mut w).write_batch(v, None, None)?;
            }
            Column::Real(v) => {
                get_typed_column_writer_mut::<DoubleType>(&mut w).write_batch(v, None, None)?;
            }
            Column::Optional(v) => {
                let levels: Vec<i16> = v.iter().map(|x| i16::from(x.is_some())).collect();
                // Sized once: a flattened iterator would grow the vector by doubling.
                let mut values = Vec::with_capacity(v.len());
                values.extend(v.iter().flatten());
                get_typed_column_writer_mut::<DoubleType>(&mut w).write_batch(
                    &values,
                    Some(&levels),
                    None,
                )?;
            }
        }
        w.close()?
    };
    Ok((bytes::Bytes::from(sink.into_inner()?), close))
}

mod read;

pub use read::{Part, open_part, open_part_bytes, read_groups};

#[cfg(test)]
mod tests {
    use super::*;

    fn table(first: i64, n: i64) -> Table {
        let names: Vec<String> = ["index", "roll", "range_min"]
            .iter()
            .map(ToString::to_string)
            .collect();
        #[expect(clippy::cast_precision_loss, reason = "small test values")]
        let columns = vec![
            Column::Int((first..first + n).collect()),
            Column::Real((first..first + n).map(|i| i as f64 * 0.1).collect()),
            Column::Optional(
                (first..first + n)
                    .map(|i| (i % 3 != 0).then_some(i as f64))
                    .collect(),
            ),
        ];
        Table { names, columns }
    }

    /// Returns the encoding with the `delta` and `dictionary` columns named (the tests' own: the
    /// index as deltas, `roll` with a dictionary).
    fn encoding<'a>(delta: &'a [String], dictionary: &'a [String]) -> Encoding<'a> {
        Encoding { dictionary, delta }
    }

    /// Writes `parts`, tables in index order from `first`, into one file and returns its bytes.
    fn write_parts(parts: &[Table], first: u64) -> Vec<u8> {
        let t = &parts[0];
        let (delta, dictionary) = ([t.names[0].clone()], [t.names[1].clone()]);
        write_encoded(parts, first, encoding(&delta, &dictionary))
    }

    /// Writes `parts` as [`write_parts`] does, with `encoding`.
    fn write_encoded(parts: &[Table], first: u64, encoding: Encoding<'_>) -> Vec<u8> {
        let t = &parts[0];
        let mut out = Vec::new();
        let path = Path::new("test.parquet");
        let mut w = TableWriter::new(&mut out, &t.names, &t.kinds(), first, encoding, path).unwrap();
        for p in parts {
            w.push(p.clone()).unwrap();
        }
        w.finish().unwrap();
        out
    }

    #[test]
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_possible_wrap,
        reason = "GROUP_ROWS is 2^17"
    )]
    fn the_same_rows_make_the_same_bytes_however_they_are_cut() {
        let n = 2 * GROUP_ROWS as i64 + 1000;
        let whole = write_parts(&[table(0, n)], 0);
        let cuts = [0, 7, 20_000, GROUP_ROWS as i64, GROUP_ROWS as i64 + 1, n];
        let parts: Vec<Table> = cuts.windows(2).map(|w| table(w[0], w[1] - w[0])).collect();
        assert_eq!(write_parts(&parts, 0), whole);
        // Read back: every value, nulls in place, groups at the multiples of GROUP_ROWS.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.parquet");
        std::fs::write(&path, &whole).unwrap();
        let t = table(0, 1);
        let groups: Vec<Table> = read_groups(&path, &t.names, &t.kinds())
            .unwrap()
            .map(Result::unwrap)
            .collect();
        assert_eq!(
            groups.iter().map(Table::rows).collect::<Vec<_>>(),
            [GROUP_ROWS as usize, GROUP_ROWS as usize, 1000]
        );
        let mut all = Table::new(&t.names, &t.kinds());
        for g in groups {
            for (a, b) in all.columns.iter_mut().zip(g.columns) {
                a.append(b);
            }
        }
        assert_eq!(all, table(0, n));
    }

    /// Whole row groups copied from parts as they are, with the rest decoded and cut again, make
    /// the bytes of writing the rows at once. A copied group's metadata is the writer's.
    #[test]
    #[expect(clippy::cast_possible_wrap, reason = "GROUP_ROWS is 2^17")]
    fn copied_groups_make_the_bytes_of_encoding_them() {
        let g = GROUP_ROWS as i64;
        let n = 2 * g + 1000;
        let whole = write_parts(&[table(0, n)], 0);
        let dir = tempfile::tempdir().unwrap();
        let t = table(0, 1);
        let (delta, dictionary) = ([t.names[0].clone()], [t.names[1].clone()]);
        for cuts in [vec![0, g, g + 7, n], vec![0, g, 2 * g, n], vec![0, 5, n]] {
            let files: Vec<std::path::PathBuf> = cuts
                .windows(2)
                .enumerate()
                .map(|(k, w)| {
                    let path = dir.path().join(format!("part-{k}.parquet"));
                    std::fs::write(&path, write_parts(&[table(w[0], w[1] - w[0])], w[0] as u64)).unwrap();
                    path
                })
                .collect();
            let mut out = Vec::new();
            let path = Path::new("joined.parquet");
            let encoding = encoding(&delta, &dictionary);
            let mut w = TableWriter::new(&mut out, &t.names, &t.kinds(), 0, encoding, path).unwrap();
            let mut copied = 0;
            for (k, file) in files.iter().enumerate() {
                let part = open_part(file, &t.names, &t.kinds()).unwrap();
                let groups = part.group_rows().len();
                for group in 0..groups {
                    let last = k + 1 == files.len() && group + 1 == groups;
                    if w.copy_group(&part, group, last).unwrap() {
                        copied += 1;
                    } else {
                        w.push(part.group(group, file, &t.names, &t.kinds()).unwrap())
                            .unwrap();
                    }
                }
            }
            w.finish().unwrap();
            assert!(
                out == whole,
                "cuts {cuts:?}: {} bytes against {}",
                out.len(),
                whole.len()
            );
            // Aligned whole groups were copied: the last one, and the first part's if it is one.
            assert!(copied >= 1, "cuts {cuts:?}: nothing copied");
        }
    }

    /// A part written with another encoding (without the pose column's dictionary, or without
    /// the index's deltas) is decoded and encoded again, not copied: the joined file still has
    /// the bytes of encoding at once.
    #[test]
    #[expect(clippy::cast_possible_wrap, reason = "GROUP_ROWS is 2^17")]
    fn a_part_of_another_encoding_is_encoded_again() {
        let g = GROUP_ROWS as i64;
        let whole = write_parts(&[table(0, g + 10)], 0);
        let dir = tempfile::tempdir().unwrap();
        let t = table(0, 1);
        let (delta, dictionary) = ([t.names[0].clone()], [t.names[1].clone()]);
        for (k, other) in [encoding(&delta, &[]), encoding(&[], &dictionary)]
            .into_iter()
            .enumerate()
        {
            let foreign = dir.path().join(format!("foreign-{k}.parquet"));
            let bytes = write_encoded(&[table(0, g + 10)], 0, other);
            std::fs::write(&foreign, &bytes).unwrap();
            assert_ne!(bytes, whole);
            let mut out = Vec::new();
            let path = Path::new("joined.parquet");
            let mine = encoding(&delta, &dictionary);
            let mut w = TableWriter::new(&mut out, &t.names, &t.kinds(), 0, mine, path).unwrap();
            let part = open_part(&foreign, &t.names, &t.kinds()).unwrap();
            for group in 0..part.group_rows().len() {
                let last = group + 1 == part.group_rows().len();
                assert!(
                    !w.copy_group(&part, group, last).unwrap(),
                    "{other:?}: group {group} copied"
                );
                w.push(part.group(group, &foreign, &t.names, &t.kinds()).unwrap())
                    .unwrap();
            }
            w.finish().unwrap();
            assert!(
                out == whole,
                "{other:?}: {} bytes against {}",
                out.len(),
                whole.len()
            );
        }
    }

    #[test]
    fn a_file_of_other_columns_or_not_parquet_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.parquet");
        std::fs::write(&path, write_parts(&[table(0, 10)], 0)).unwrap();
        let names: Vec<String> = ["index", "pitch", "range_min"]
            .iter()
            .map(ToString::to_string)
            .collect();
        let kinds = table(0, 1).kinds();
        let e = read_groups(&path, &names, &kinds).err().unwrap().to_string();
        assert!(e.contains("another sweep"), "{e}");
        let real = [Kind::Int, Kind::Real, Kind::Real];
        let e = read_groups(&path, &table(0, 1).names, &real)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("their types"), "{e}");
        std::fs::write(&path, b"index,roll\n0,1\n").unwrap();
        let e = read_groups(&path, &names, &kinds).err().unwrap().to_string();
        assert!(e.contains("not a Parquet file"), "{e}");
    }
}
