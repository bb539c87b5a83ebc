//! Reading sweep tables back: a part opened for copying whole row groups, or its groups decoded
//! one at a time, after checking its columns are the sweep's.

use std::path::Path;

use parquet::column::reader::ColumnReader;
use parquet::file::reader::{ChunkReader, FileReader, SerializedFileReader};
use parquet::file::serialized_reader::ReadOptionsBuilder;

use super::{Column, Kind, Table, schema};
use crate::error::{Error, Result};

/// A Parquet part opened for [`super::TableWriter::copy_group`]: its bytes (a file, or in
/// memory) and their reader (with page indexes).
pub struct Part<R: ChunkReader = std::fs::File> {
    pub(super) file: R,
    pub(super) reader: SerializedFileReader<R>,
}

impl<R: ChunkReader + 'static> Part<R> {
    /// Returns the row counts of the part's row groups.
    #[must_use]
    pub fn group_rows(&self) -> Vec<u64> {
        self.reader
            .metadata()
            .row_groups()
            .iter()
            .map(|g| u64::try_from(g.num_rows()).unwrap_or(0))
            .collect()
    }

    /// Returns row group `g` as a table.
    ///
    /// # Errors
    /// [`Error::Csv`] naming the file when the group cannot be read.
    pub fn group(&self, g: usize, path: &Path, names: &[String], kinds: &[Kind]) -> Result<Table> {
        read_group(&self.reader, g, path, names, kinds)
    }
}

/// Returns Parquet file `path` opened as a [`Part`], after checking that its columns are `names`
/// of `kinds`.
///
/// # Errors
/// As [`read_groups`].
pub fn open_part(path: &Path, names: &[String], kinds: &[Kind]) -> Result<Part> {
    let file = open(path)?;
    let reader_file = file.try_clone().map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })?;
    part_of(file, reader_file, path, names, kinds)
}

/// Returns the Parquet bytes `bytes` (part `path`, for messages) opened as a [`Part`], after
/// checking that its columns are `names` of `kinds`.
///
/// # Errors
/// [`Error::Csv`] naming `path` when the bytes are not Parquet or have other columns.
pub fn open_part_bytes(
    bytes: bytes::Bytes,
    path: &Path,
    names: &[String],
    kinds: &[Kind],
) -> Result<Part<bytes::Bytes>> {
    part_of(bytes.clone(), bytes, path, names, kinds)
}

/// Returns the part `file` read through `reader_file` (the same bytes), its columns checked.
fn part_of<R: ChunkReader + 'static>(
    file: R,
    reader_file: R,
    path: &Path,
    names: &[String],
    kinds: &[Kind],
) -> Result<Part<R>> {
    // Keep every field of the column chunks as written (page encoding statistics as a list, not
    // the reader's default mask), so a copied group matches the bytes of encoding it.
    let options = ReadOptionsBuilder::new()
        .with_page_index()
        .with_encoding_stats_as_mask(false)
        .build();
    let reader =
        SerializedFileReader::new_with_options(reader_file, options).map_err(|e| not_parquet(path, &e))?;
    check_schema(&reader, path, names, kinds)?;
    Ok(Part { file, reader })
}

fn open(path: &Path) -> Result<std::fs::File> {
    std::fs::File::open(path).map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })
}

fn not_parquet(path: &Path, e: &parquet::errors::ParquetError) -> Error {
    Error::Csv {
        context: path.display().to_string(),
        message: format!("not a Parquet file ({e})"),
    }
}

/// Returns `Ok` when `reader`'s columns are `names` of `kinds`.
fn check_schema<R: parquet::file::reader::ChunkReader + 'static>(
    reader: &SerializedFileReader<R>,
    path: &Path,
    names: &[String],
    kinds: &[Kind],
) -> Result<()> {
    let want = schema(names, kinds)?;
    let have = reader.metadata().file_metadata().schema();
    if have.get_fields() != want.get_fields() {
        let have: Vec<&str> = have.get_fields().iter().map(|f| f.name()).collect();
        return Err(Error::Csv {
            context: path.display().to_string(),
            message: format!(
                "its columns {have:?} (or their types) differ from this sweep's {names:?}: a part of another sweep"
            ),
        });
    }
    Ok(())
}

/// Returns row group `g` of `reader` (the file `path`) as a table of `names` of `kinds`.
fn read_group<R: parquet::file::reader::ChunkReader + 'static>(
    reader: &SerializedFileReader<R>,
    g: usize,
    path: &Path,
    names: &[String],
    kinds: &[Kind],
) -> Result<Table> {
    let bad = |message: String| Error::Csv {
        context: path.display().to_string(),
        message,
    };
    let group = reader
        .get_row_group(g)
        .map_err(|e| bad(format!("row group {g}: {e}")))?;
    let rows = usize::try_from(group.metadata().num_rows())
        .map_err(|_| bad(format!("row group {g} has a negative row count")))?;
    let mut table = Table::new(names, kinds);
    for (j, column) in table.columns.iter_mut().enumerate() {
        let reader = group
            .get_column_reader(j)
            .map_err(|e| bad(format!("row group {g}, column {j}: {e}")))?;
        *column = read_column(reader, kinds[j], rows)
            .map_err(|e| bad(format!("row group {g}, column {}: {e}", names[j])))?;
    }
    Ok(table)
}

/// Returns the row groups of the Parquet file `path` one at a time, each as a table, after
/// checking that its columns are `names` of `kinds`.
///
/// # Errors
/// [`Error::ReadInput`] when the file cannot be opened. [`Error::Csv`] naming the file when it
/// is not Parquet or has other columns.
pub fn read_groups<'a>(
    path: &'a Path,
    names: &[String],
    kinds: &[Kind],
) -> Result<impl Iterator<Item = Result<Table>> + 'a> {
    let reader = SerializedFileReader::new(open(path)?).map_err(|e| not_parquet(path, &e))?;
    check_schema(&reader, path, names, kinds)?;
    let (names, kinds) = (names.to_vec(), kinds.to_vec());
    Ok((0..reader.num_row_groups()).map(move |g| read_group(&reader, g, path, &names, &kinds)))
}

/// Returns the `rows` values of a required column chunk of any physical type.
fn read_required<T: parquet::data_type::DataType>(
    mut r: parquet::column::reader::ColumnReaderImpl<T>,
    rows: usize,
) -> std::result::Result<Vec<T::T>, String> {
    let mut values = Vec::with_capacity(rows);
    while values.len() < rows {
        let (records, _, _) = r
            .read_records(rows - values.len(), None, None, &mut values)
            .map_err(|e| e.to_string())?;
        if records == 0 {
            return Err(format!("{} values where the row group has {rows}", values.len()));
        }
    }
    Ok(values)
}

/// Returns the `rows` values of one column chunk.
fn read_column(reader: ColumnReader, kind: Kind, rows: usize) -> std::result::Result<Column, String> {
    let short = |n: usize| format!("{n} values where the row group has {rows}");
    match (reader, kind) {
        (ColumnReader::Int64ColumnReader(r), Kind::Int) => read_required(r, rows).map(Column::Int),
        (ColumnReader::DoubleColumnReader(r), Kind::Real) => read_required(r, rows).map(Column::Real),
        (ColumnReader::DoubleColumnReader(mut r), Kind::Optional) => {
            let (mut values, mut levels) = (Vec::new(), Vec::with_capacity(rows));
            while levels.len() < rows {
                let (records, _, _) = r
                    .read_records(rows - levels.len(), Some(&mut levels), None, &mut values)
                    .map_err(|e| e.to_string())?;
                if records == 0 {
                    return Err(short(levels.len()));
                }
            }
            let mut present = values.into_iter();
            let column = levels
                .iter()
                .map(|&l| if l > 0 { present.next() } else { None })
                .collect();
            Ok(Column::Optional(column))
        }
        _ => Err("its type differs from the schema's".into()),
    }
}
