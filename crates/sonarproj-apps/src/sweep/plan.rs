//! What a sweep run is before anything is computed: its poses (the whole sweep's or a shard's),
//! its chunks, whether it writes rows or summaries, and the work every chunk shares. Both the run
//! into a directory ([`super::run`]) and the run in memory ([`super::in_memory`]) make one, and
//! compute its chunks with [`Plan::compute`].

use sonarproj::stream::Stop;
use std::ops::{ControlFlow, Range};

use sonarproj::MetricColumns;
use sonarproj::error::Field;
use sonarproj::local_precision::resolve_sigma_range;
use sonarproj::metrics::Metric;
use sonarproj::projection::Backend;

use crate::error::{Error, Result};
use crate::io::parquet::{Kind, Table};
use crate::limits::{MAX_CHUNK_POSES, MAX_CHUNKS};
use crate::sweep::columns::column_kinds;
use crate::sweep::compute::{Work, metric_columns, values};
use crate::sweep::config::{Grid, Poses, SweepConfig};
use crate::sweep::records::Descriptor;
use crate::sweep::shard::Shard;
use crate::sweep::summary::SummarySpec;

/// Most chunks projected in one run of blocks ([`Backend::project_blocks`]): the device goes on
/// from one to the next without waiting, and the run's lists stay small however many chunks.
pub(crate) const RUN_BLOCKS: usize = 256;

/// The default number of poses per chunk of a sweep that writes rows: one Parquet row group.
pub const DEFAULT_CHUNK_POSES: u64 = crate::io::parquet::GROUP_ROWS;

/// The default number of poses per chunk of a sweep of summaries only (`rows = false`): eight
/// row groups' worth. Its chunks are reductions, whose parts on disk are as large as the
/// marginals whatever the chunk's size, so fewer, larger chunks cost less (10^8 poses with a
/// 10 000-value marginal: 763 parts of 0.7 MB at 131 072 poses, 96 at 2^20) and make larger
/// calls to a GPU; memory grows with them (about 0.2 KB a pose).
pub const DEFAULT_SUMMARY_CHUNK_POSES: u64 = 1 << 20;

/// Returns the default number of poses per chunk of `config`: [`DEFAULT_SUMMARY_CHUNK_POSES`]
/// for summaries only, else [`DEFAULT_CHUNK_POSES`].
#[must_use]
pub fn default_chunk_poses(config: &SweepConfig) -> u64 {
    match &config.summary {
        Some(s) if !s.rows => DEFAULT_SUMMARY_CHUNK_POSES,
        _ => DEFAULT_CHUNK_POSES,
    }
}

/// Returns an error unless `chunk_poses` is in `[1, MAX_CHUNK_POSES]`, naming `field`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `field`.
pub(crate) fn check_chunk_poses(chunk_poses: u64, field: impl Into<Field>) -> Result<()> {
    if (1..=MAX_CHUNK_POSES).contains(&chunk_poses) {
        return Ok(());
    }
    Err(Error::invalid(
        field,
        chunk_poses,
        format!("must be in [1, {MAX_CHUNK_POSES}] (a chunk is held in memory)"),
    ))
}

/// A sweep run planned: what it computes and how it is cut, nothing computed or written yet.
pub(crate) struct Plan<'a> {
    pub(crate) config: &'a SweepConfig,
    /// What the sweep is (fingerprint, poses, columns, figure).
    pub(crate) desc: Descriptor,
    /// The poses of this run: the whole sweep's, or a shard's.
    pub(crate) range: Range<u64>,
    /// Poses a chunk; chunks end at its multiples in the pose index.
    pub(crate) chunk_poses: u64,
    /// This run's chunks (a shard's first and last may be short).
    pub(crate) chunks: u64,
    /// Whether rows are written (else the summaries alone).
    pub(crate) rows: bool,
    /// The summaries asked for.
    pub(crate) spec: Option<&'a SummarySpec>,
    /// The metric the summaries reduce.
    pub(crate) by: Option<Metric>,
    /// The grid, for a grid sweep.
    pub(crate) grid: Option<&'a Grid>,
    /// The kinds of the table's columns.
    pub(crate) kinds: Vec<Kind>,
    /// The range error of the local precision (m).
    pub(crate) sigma: f64,
}

/// One chunk computed: its number in the run, its poses, its table (when rows are written) and
/// the values its summary reduces (when one is asked for).
pub(crate) struct Computed {
    pub(crate) chunk: u64,
    pub(crate) poses: Range<u64>,
    pub(crate) table: Option<Table>,
    pub(crate) values: Option<Vec<f64>>,
}

impl<'a> Plan<'a> {
    /// Returns the plan of `config` (described by `desc`), or of `shard` of it, in chunks of
    /// `chunk_poses`.
    ///
    /// # Errors
    /// As [`resolve_sigma_range`].
    pub(crate) fn new(
        config: &'a SweepConfig,
        desc: Descriptor,
        shard: Option<Shard>,
        chunk_poses: u64,
    ) -> Result<Self> {
        let range = shard.map_or(0..desc.poses, |s| s.range(desc.poses));
        let spec = config.summary.as_ref();
        let grid = match &config.poses {
            Poses::Grid(g) => Some(g),
            Poses::List(_) => None,
        };
        let kinds = column_kinds(&desc.columns);
        let sigma = resolve_sigma_range(&config.source, &config.target, config.sigma_range)?;
        let mut plan = Plan {
            config,
            chunks: 0,
            range,
            chunk_poses,
            rows: spec.is_none_or(|s| s.rows),
            spec,
            by: spec.map(|s| Metric::from_name(&s.by).expect("a checked metric name")),
            grid,
            kinds,
            sigma,
            desc,
        };
        plan.chunks = plan.chunks_of(chunk_poses);
        Ok(plan)
    }

    /// Returns the number of poses of this run.
    pub(crate) fn poses(&self) -> u64 {
        self.range.end - self.range.start
    }

    /// Returns the number of chunks this run would have in chunks of `cp` poses.
    fn chunks_of(&self, cp: u64) -> u64 {
        if self.poses() == 0 {
            0
        } else {
            self.range.end.div_ceil(cp) - self.range.start / cp
        }
    }

    /// Returns an error when the run has more than [`MAX_CHUNKS`] chunks, naming `field` (where
    /// the chunk size came from) and the smallest chunk size that works.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming `field`.
    pub(crate) fn check_chunk_count(&self, field: impl Into<Field>) -> Result<()> {
        let (poses, n_chunks) = (self.poses(), self.chunks);
        if n_chunks <= MAX_CHUNKS {
            return Ok(());
        }
        // The smallest chunk size that works: a whole run's, or one more chunk's for a shard
        // that starts between two multiples (at most a step or two above the whole run's).
        let mut fits = poses.div_ceil(MAX_CHUNKS);
        while self.chunks_of(fits) > MAX_CHUNKS {
            fits += 1;
        }
        Err(Error::invalid(
            field,
            self.chunk_poses,
            format!(
                "cuts this run's {poses} poses into {n_chunks} chunk files, more than the \
                 {MAX_CHUNKS} one run keeps: use chunks of {fits} poses or more (or shards)"
            ),
        ))
    }

    /// Returns the poses of chunk `c` of this run.
    pub(crate) fn chunk(&self, c: u64) -> Range<u64> {
        let (cp, first) = (self.chunk_poses, self.range.start / self.chunk_poses);
        ((first + c) * cp).max(self.range.start)..((first + c + 1) * cp).min(self.range.end)
    }

    /// Returns what every chunk's computation shares.
    ///
    /// # Errors
    /// As [`Work::new`].
    pub(crate) fn work(&self) -> Result<Work<'_>> {
        Work::new(self.config, &self.desc.columns, &self.kinds, self.sigma)
    }

    /// Returns the metric columns the chunks fill: the table's kept metrics when rows are
    /// written, and the summary's metric.
    pub(crate) fn metric_columns(&self) -> MetricColumns {
        let table = self.rows.then_some(self.config.result_columns.as_slice());
        metric_columns(table, self.by)
    }

    /// Computes chunks `todo` of this run on `backend` and hands each to `sink`, in order, until
    /// `sink` answers `Break` (returned): a grid's chunks in one run of blocks
    /// ([`Backend::project_blocks`], the device going on from one to the next), a list's one at a
    /// time. `metrics` is reused from chunk to chunk.
    ///
    /// # Errors
    /// As [`Work::block`] and [`Work::rows`]; `sink`'s first error.
    pub(crate) fn compute(
        &self,
        work: &Work<'_>,
        backend: &Backend,
        metrics: &mut MetricColumns,
        todo: Range<u64>,
        sink: &mut dyn FnMut(Computed, &MetricColumns) -> Result<ControlFlow<()>>,
    ) -> Result<ControlFlow<()>> {
        let rows = self.rows;
        let values_of = |m: &MetricColumns| self.by.map(|by| values(m, by));
        let Some(sweep) = work.sweep() else {
            for chunk in todo {
                let poses = self.chunk(chunk);
                let table = work.block(backend, poses.clone(), rows, metrics, Stop::NEVER)?;
                let values = values_of(metrics);
                let computed = Computed {
                    chunk,
                    poses,
                    table,
                    values,
                };
                if sink(computed, metrics)?.is_break() {
                    return Ok(ControlFlow::Break(()));
                }
            }
            return Ok(ControlFlow::Continue(()));
        };
        let blocks: Vec<Range<u64>> = todo.clone().map(|c| self.chunk(c)).collect();
        let mut chunk = todo.start;
        let mut failed = None;
        let flow = backend.project_blocks(&sweep, &blocks, metrics, Stop::NEVER, &mut |poses, metrics| {
            let this = chunk;
            chunk += 1;
            let step = || -> Result<ControlFlow<()>> {
                let table = if rows {
                    Some(work.rows(poses.clone(), metrics)?)
                } else {
                    None
                };
                let values = values_of(metrics);
                let computed = Computed {
                    chunk: this,
                    poses,
                    table,
                    values,
                };
                sink(computed, metrics)
            };
            step().unwrap_or_else(|e| {
                failed = Some(e);
                ControlFlow::Break(())
            })
        })?;
        failed.map_or(Ok(flow), Err)
    }
}
