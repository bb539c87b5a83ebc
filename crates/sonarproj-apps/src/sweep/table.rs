//! A chunk's table: its poses as a batch, its results as CSV rows or typed columns (the
//! format of `sweep.csv` or `sweep.parquet`).

use std::path::Path;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sonarproj::Output;

use sonarproj::metrics::Metric;
use sonarproj::projection::{Backend, Batch, BatchItem, Projection};

use crate::error::{Error, Result};
use crate::io::METRIC_COLUMNS;
use crate::io::batch::LOCAL_COLUMNS;
use crate::io::batch::metric_field;
use crate::io::parquet::{Column, Kind, Table};
use crate::io::table::write_rows;
use crate::sweep::SweepConfig;
use crate::sweep::columns::{Fill, fill_of, pose_column_count};
use crate::sweep::parts;

/// The format of a sweep's tables.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// CSV: one line per pose, numbers in shortest exact form, empty cells where nothing is seen.
    #[default]
    Csv,
    /// Parquet: typed columns, Snappy-compressed, row groups at multiples of
    /// [`GROUP_ROWS`](crate::io::parquet::GROUP_ROWS) of the pose index. Integers for the index
    /// and counts, doubles for the rest, null where the CSV leaves a cell empty.
    Parquet,
}

impl Format {
    /// Returns the file extension (and the name) of the format: `csv` or `parquet`.
    #[must_use]
    pub fn extension(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Parquet => "parquet",
        }
    }

    /// Returns the format named `text` (`csv` or `parquet`).
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming `field` for any other name.
    pub fn parse(text: &str, field: &str) -> Result<Format> {
        match text {
            "csv" => Ok(Format::Csv),
            "parquet" => Ok(Format::Parquet),
            _ => Err(Error::invalid(
                field,
                format!("{text:?}"),
                "must be \"csv\" or \"parquet\"",
            )),
        }
    }
}

/// Returns the batch of a chunk's `poses`. True points, which add local precision (a tenth of a
/// sweep's time), are kept only when rows are written and the table keeps a local column.
pub(crate) fn chunk_batch(config: &SweepConfig, poses: &[BatchItem]) -> Batch {
    let rows = config.summary.as_ref().is_none_or(|s| s.rows);
    let local = rows && config.result_columns.iter().any(|c| LOCAL_COLUMNS.contains(c));
    Batch {
        sigma_range: config.sigma_range,
        source: config.source.clone(),
        target: config.target.clone(),
        sampling: config.sampling,
        area_grid: config.area_grid,
        items: poses
            .iter()
            .map(|p| BatchItem {
                true_point: p.true_point.filter(|_| local),
                ..*p
            })
            .collect(),
    }
}

/// Returns a chunk's table: the index from `first`, the pose columns `values` (row after row),
/// the metrics and local precision of `results`, in the sweep's `columns` of `kinds`.
#[expect(
    clippy::cast_possible_wrap,
    reason = "pose indices are below 2^40 (MAX_POSES)"
)]
pub(crate) fn columns_of(
    columns: &[String],
    kinds: &[Kind],
    first: u64,
    values: &[f64],
    results: &[Projection],
) -> Table {
    let mut table = Table::new(columns, kinds);
    let n = results.len();
    let pose_columns = pose_column_count(columns);
    let locals: Vec<_> = results.iter().map(|p| p.local).collect();
    for (j, column) in table.columns.iter_mut().enumerate() {
        *column = if j == 0 {
            Column::Int((0..n as u64).map(|i| (first + i) as i64).collect())
        } else if j <= pose_columns {
            Column::Real((0..n).map(|i| values[i * pose_columns + j - 1]).collect())
        } else {
            match (fill_of(&columns[j]), kinds[j]) {
                (Fill::Metric(metric), Kind::Int) => Column::Int(
                    results
                        .iter()
                        .map(|p| match p.metrics.get(metric) {
                            sonarproj::metrics::Value::Count(c) => i64::try_from(c).unwrap_or(i64::MAX),
                            _ => unreachable!("the metric table's counts"),
                        })
                        .collect(),
                ),
                (Fill::Metric(metric), Kind::Real) => Column::Real(
                    results
                        .iter()
                        .map(|p| p.metrics.get(metric).as_f64().unwrap_or(f64::NAN))
                        .collect(),
                ),
                (Fill::Metric(metric), Kind::Optional) => {
                    Column::Optional(results.iter().map(|p| p.metrics.get(metric).as_f64()).collect())
                }
                (Fill::RangePerElevation, _) => {
                    Column::Optional(locals.iter().map(|l| l.range_per_elevation).collect())
                }
                (Fill::SigmaElevation, _) => {
                    Column::Optional(locals.iter().map(|l| l.sigma_elevation).collect())
                }
            }
        };
    }
    table
}

/// Returns the CSV rows (no header) of `fields`, then `results`' columns `kept`, in
/// [`METRIC_COLUMNS`] order. Blocks are formatted in parallel. Each record is formatted on its
/// own, so the bytes match one writer's.
pub(crate) fn csv_rows(
    fields: &[Vec<String>],
    (results, kept): (&[Projection], &[&str]),
    path: &Path,
) -> Result<Vec<u8>> {
    let picks: Vec<usize> = kept
        .iter()
        .map(|c| {
            METRIC_COLUMNS
                .iter()
                .position(|m| m == c)
                .expect("a result column")
        })
        .collect();
    let blocks: Vec<Vec<u8>> = fields
        .par_chunks(4096)
        .zip(results.par_chunks(4096))
        .map(|(f, r)| {
            let mut w = csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(Vec::new());
            for (fields, p) in f.iter().zip(r) {
                let local = p.local;
                // The pose fields and kept ones, then the record's end. A row always has its
                // index, so it is never the empty record's lone field.
                let kept = picks.iter().map(|&k| metric_field(&p.metrics, &local, k));
                fields
                    .iter()
                    .map(String::as_bytes)
                    .try_for_each(|f| w.write_field(f))
                    .and_then(|()| kept.into_iter().try_for_each(|f| w.write_field(f)))
                    .and_then(|()| w.write_record(std::iter::empty::<&[u8]>()))
                    .map_err(|e| Error::write_output(path, e))?;
            }
            w.into_inner().map_err(|e| Error::write_output(path, e))
        })
        .collect::<Result<_>>()?;
    Ok(blocks.concat())
}

/// A chunk of a sweep to CSV: its items projected and its rows written with their record.
pub(crate) struct CsvChunk<'a> {
    pub(crate) config: &'a SweepConfig,
    pub(crate) header: &'a [String],
}

impl CsvChunk<'_> {
    /// Projects poses `r` on `backend`, writes their rows into `path` (recorded as `expected`),
    /// and returns the values of `by` when a summary reduces one.
    pub(crate) fn write(
        &self,
        backend: &Backend,
        r: std::ops::Range<u64>,
        path: &Path,
        expected: parts::Expected<'_>,
        by: Option<Metric>,
    ) -> Result<Option<Vec<f64>>> {
        let (poses, fields) = self.config.items(r)?;
        let batch = chunk_batch(self.config, &poses);
        let results = backend.project(&batch, Output::MetricsOnly)?;
        let kept = &self.config.result_columns;
        let body = csv_rows(&fields, (&results, kept), path)?;
        parts::write_chunk(path, expected, |w| {
            write_rows(
                &mut *w,
                self.header,
                kept,
                std::iter::empty::<(&[String], Vec<String>)>(),
            )?;
            w.write_all(&body).map_err(|e| Error::write_output(path, e))
        })?;
        Ok(by.map(|by| {
            results
                .iter()
                .map(|p| p.metrics.get(by).as_f64().unwrap_or(f64::NAN))
                .collect()
        }))
    }
}
