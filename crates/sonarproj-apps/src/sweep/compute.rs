//! Computes one block of a sweep's poses: metric columns and, when asked, the typed table.
//! A grid's poses are decoded where the work runs ([`Backend::project_columns`]), with no
//! per-pose objects. A list's items are projected as a batch.

use sonarproj::stream::Stop;
use std::ops::Range;

use rayon::prelude::*;

use sonarproj::Output;
use sonarproj::projection::{Backend, ColumnRef, MetricColumns, PoseGrid, PoseSource, PoseSweep};

use crate::error::Result;
use crate::io::batch::LOCAL_COLUMNS;
use crate::io::parquet::{Column, Kind, Table};
use crate::sweep::columns::{Fill, fill_of, kept_metrics};
use crate::sweep::config::{Poses, SweepConfig};
use crate::sweep::table::{chunk_batch, columns_of};

/// The state every block of one sweep shares: the engine's grid (grid sweeps only), the
/// table's columns and kinds, and the range error for local precision.
pub(crate) struct Work<'a> {
    config: &'a SweepConfig,
    grid: Option<PoseGrid>,
    columns: &'a [String],
    kinds: &'a [Kind],
    sigma: f64,
}

/// Returns the values of `metric` in `metrics` for a summary, NaN where a pose has none.
///
/// # Panics
/// When `metrics` does not keep `metric` (a block's columns come from [`metric_columns`]).
#[expect(
    clippy::cast_precision_loss,
    reason = "counts are below 2^53 (MAX_SAMPLES_PER_POSE)"
)]
pub(crate) fn values(metrics: &MetricColumns, metric: sonarproj::Metric) -> Vec<f64> {
    assert!(
        metrics.keeps(metric),
        "the summary's metric is not kept: {}",
        metric.name()
    );
    match metrics.column(metric) {
        ColumnRef::Real(c) => c.to_vec(),
        ColumnRef::Count(c) => c.iter().map(|&v| v as f64).collect(),
    }
}

/// Returns the columns a sweep's blocks fill: the metrics kept in `table`, plus the summary's
/// metric `by`. The backends write, and the GPU unpacks, only these.
pub(crate) fn metric_columns(table: Option<&[&str]>, by: Option<sonarproj::Metric>) -> MetricColumns {
    let mut kept = table.map(kept_metrics).unwrap_or_default();
    kept.extend(by);
    MetricColumns::only(&kept)
}

impl<'a> Work<'a> {
    /// Returns the work of `config`, with table `columns` of `kinds` and range error `sigma`.
    pub(crate) fn new(
        config: &'a SweepConfig,
        columns: &'a [String],
        kinds: &'a [Kind],
        sigma: f64,
    ) -> Result<Self> {
        let grid = match &config.poses {
            Poses::Grid(g) => Some(g.pose_grid(&config.source)?),
            Poses::List(_) => None,
        };
        Ok(Work {
            config,
            grid,
            columns,
            kinds,
            sigma,
        })
    }

    /// Computes poses `r` on `backend` into `metrics` and, when `rows`, returns their table.
    /// `metrics` keeps its memory between blocks. `stop` works as in [`Backend::project_until`].
    pub(crate) fn block(
        &self,
        backend: &Backend,
        r: Range<u64>,
        rows: bool,
        metrics: &mut MetricColumns,
        stop: Stop<'_>,
    ) -> Result<Option<Table>> {
        let config = self.config;
        let Some(grid) = &self.grid else {
            let (poses, values) = config.items_numeric(r.clone())?;
            let batch = chunk_batch(config, &poses);
            let results = backend.project_until(&batch, Output::MetricsOnly, stop)?;
            metrics.clear();
            for p in &results {
                metrics.push(&p.metrics);
            }
            let table = rows.then(|| columns_of(self.columns, self.kinds, r.start, &values, &results));
            return Ok(table);
        };
        let sweep = self.grid_sweep(grid);
        backend.project_columns(&sweep, r.clone(), metrics, stop)?;
        if !rows {
            return Ok(None);
        }
        Ok(Some(self.grid_rows(grid, r, metrics)?))
    }

    /// Returns the engine's sweep for [`Backend::project_blocks`], or `None` for a list.
    pub(crate) fn sweep(&self) -> Option<PoseSweep<'_>> {
        self.grid.as_ref().map(|g| self.grid_sweep(g))
    }

    fn grid_sweep<'g>(&self, grid: &'g PoseGrid) -> PoseSweep<'g> {
        let config = self.config;
        PoseSweep {
            source: config.source.clone(),
            target: config.target.clone(),
            sampling: config.sampling,
            area_grid: config.area_grid,
            poses: PoseSource::Grid(grid),
        }
    }

    /// Returns the table of poses `r` of a grid sweep, whose `metrics` are projected.
    ///
    /// # Panics
    /// For a list sweep (its table comes from [`Work::block`]).
    pub(crate) fn rows(&self, r: Range<u64>, metrics: &MetricColumns) -> Result<Table> {
        let grid = self.grid.as_ref().expect("a grid sweep");
        self.grid_rows(grid, r, metrics)
    }

    fn grid_rows(&self, grid: &PoseGrid, r: Range<u64>, metrics: &MetricColumns) -> Result<Table> {
        let (mut rpe, mut sig) = (Vec::new(), Vec::new());
        // Local precision costs a tenth of a sweep's time: compute it only if the table keeps it.
        if self.columns.iter().any(|c| LOCAL_COLUMNS.contains(&c.as_str())) {
            let sweep = self.grid_sweep(grid);
            sweep.local_precision_columns(r.clone(), self.sigma, &mut rpe, &mut sig)?;
        }
        Ok(grid_table(self.columns, self.kinds, grid, r, metrics, &rpe, &sig))
    }
}

/// Returns the table of poses `r` of `grid`, in the sweep's `columns` of `kinds`.
/// Columns: the index, the nine axis values, the `metrics`, then local precision `rpe` and
/// `sig` (NaN where none, empty when the table keeps neither).
#[expect(
    clippy::cast_possible_wrap,
    reason = "pose indices are below 2^40 (MAX_POSES) and sample counts below 2^63"
)]
fn grid_table(
    columns: &[String],
    kinds: &[Kind],
    grid: &PoseGrid,
    r: Range<u64>,
    metrics: &MetricColumns,
    rpe: &[f64],
    sig: &[f64],
) -> Table {
    let optional = |v: &[f64]| Column::Optional(v.iter().map(|&x| Some(x).filter(|x| !x.is_nan())).collect());
    let axes = grid.axes();
    let strides: Vec<u64> = (0..9)
        .map(|k| axes[k + 1..].iter().map(|a| a.len() as u64).product())
        .collect();
    let mut table = Table::new(columns, kinds);
    // Column by column on all cores: the next block's projection waits for this table.
    table.columns.par_iter_mut().enumerate().for_each(|(j, column)| {
        *column = if j == 0 {
            Column::Int(r.clone().map(|i| i as i64).collect())
        } else if j <= 9 {
            Column::Real(axis_column(&axes[j - 1], strides[j - 1], r.clone()))
        } else {
            match fill_of(&columns[j]) {
                Fill::Metric(m) => match (metrics.column(m), kinds[j]) {
                    (ColumnRef::Count(c), _) => {
                        Column::Int(c.iter().map(|&v| i64::try_from(v).unwrap_or(i64::MAX)).collect())
                    }
                    (ColumnRef::Real(c), Kind::Real) => Column::Real(c.to_vec()),
                    (ColumnRef::Real(c), _) => optional(c),
                },
                Fill::RangePerElevation => optional(rpe),
                Fill::SigmaElevation => optional(sig),
            }
        };
    });
    table
}

/// Returns the axis `values` at poses `r`, each value lasting `stride` poses.
/// Fills run by run, with one division at the start.
#[expect(
    clippy::cast_possible_truncation,
    reason = "an axis index, and runs within a chunk held in memory"
)]
fn axis_column(values: &[f64], stride: u64, r: Range<u64>) -> Vec<f64> {
    let n = values.len();
    let mut out = Vec::with_capacity((r.end - r.start) as usize);
    let (mut k, mut place) = (((r.start / stride) % n as u64) as usize, r.start % stride);
    let mut i = r.start;
    while i < r.end {
        let take = (stride - place).min(r.end - i);
        out.extend(std::iter::repeat_n(values[k], take as usize));
        i += take;
        place = 0;
        k = if k + 1 == n { 0 } else { k + 1 };
    }
    out
}

#[cfg(test)]
mod tests {
    /// Checks run-by-run axis columns against per-pose division, for any stride, start and end.
    #[test]
    fn axis_columns_are_each_poses_value() {
        let values = [1.0, 2.5, -3.0];
        for stride in [1, 2, 7] {
            for start in 0..30 {
                for len in [0, 1, 5, 23] {
                    let r = start..start + len;
                    let want: Vec<f64> = r
                        .clone()
                        .map(|i| values[usize::try_from((i / stride) % 3).unwrap()])
                        .collect();
                    assert_eq!(super::axis_column(&values, stride, r), want, "stride {stride}");
                }
            }
        }
    }
}
