//! A sweep run planned before anything is computed: its poses, chunks, outputs and shared work.
//! Both the run into a directory ([`super::run`]) and the run in memory ([`super::in_memory`])
//! make one and compute its chunks with [`Plan::compute`].

use sonarproj::stream::Stop;
use std::ops::{ControlFlow, Range};

use sonarproj::MetricColumns;
use sonarproj::error::Field;
use sonarproj::local_precision::resolve_sigma_range;
use sonarproj::metrics::Metric;
use sonarproj::projection::{Backend, MetricReduction, PoseSweep};

use crate::error::{Error, Result};
use crate::io::parquet::{Kind, Table};
use crate::limits::{MAX_CHUNK_POSES, MAX_CHUNKS};
use crate::sweep::columns::column_kinds;
use crate::sweep::compute::{Work, metric_columns, values};
use crate::sweep::config::{Grid, Poses, SweepConfig};
use crate::sweep::records::Descriptor;
use crate::sweep::shard::Shard;
use crate::sweep::summary::{Summary, SummarySpec};

/// The most chunks projected in one run of blocks ([`Backend::project_blocks`]).
/// The device goes from one to the next without waiting, and the run's lists stay small.
pub(crate) const RUN_BLOCKS: usize = 256;

/// The default number of poses per chunk of a sweep that writes rows: one Parquet row group.
pub const DEFAULT_CHUNK_POSES: u64 = crate::io::parquet::GROUP_ROWS;

/// The default poses per chunk for a summaries-only sweep (`rows = false`): eight row groups.
///
/// A summary part on disk is as large as its marginals whatever the chunk's size, so fewer,
/// larger chunks cost less and make larger GPU calls. 10^8 poses with a 10 000-value marginal
/// make 763 parts of 0.7 MB at 131 072 poses, 96 at 2^20. Memory grows: about 0.2 KB a pose.
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

/// Returns an error naming `field` unless `chunk_poses` is in `[1, MAX_CHUNK_POSES]`.
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
    /// Poses per chunk. Chunks end at its multiples of the pose index.
    pub(crate) chunk_poses: u64,
    /// This run's chunks (a shard's first and last may be short).
    pub(crate) chunks: u64,
    /// Whether rows are written (else the summaries alone).
    pub(crate) rows: bool,
    pub(crate) spec: Option<&'a SummarySpec>,
    /// The metric the summaries reduce.
    pub(crate) by: Option<Metric>,
    pub(crate) grid: Option<&'a Grid>,
    pub(crate) kinds: Vec<Kind>,
    /// The range error of the local precision (m).
    pub(crate) sigma: f64,
}

/// One computed chunk: its number in the run, its poses, its table (when rows are written) and
/// the values its summary reduces (when one is asked for).
pub(crate) struct Computed {
    pub(crate) chunk: u64,
    pub(crate) poses: Range<u64>,
    pub(crate) table: Option<Table>,
    pub(crate) values: Option<ForSummary>,
}

/// What a chunk's summary is made from: its metric values, or its summary part reduced on the
/// device.
pub(crate) enum ForSummary {
    /// The metric's values (NaN: no value).
    Values(Vec<f64>),
    /// The summary part (no means), as [`SummarySpec::partial`] would make it from the values.
    Reduced(Summary),
}

impl ForSummary {
    /// Returns the summary part (no means) of the chunk from pose `first`, by `spec` over `grid`.
    ///
    /// # Errors
    /// As [`SummarySpec::partial`].
    pub(crate) fn into_part(self, spec: &SummarySpec, grid: Option<&Grid>, first: u64) -> Result<Summary> {
        match self {
            ForSummary::Values(values) => spec.partial(grid, first, &values),
            ForSummary::Reduced(part) => Ok(part),
        }
    }
}

impl<'a> Plan<'a> {
    /// Returns the plan of `config` (described by `desc`) or its `shard`, in `chunk_poses` chunks.
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

    /// Returns an error when the run has more than [`MAX_CHUNKS`] chunks.
    /// It names `field`, where the chunk size came from, and the smallest chunk size that works.
    pub(crate) fn check_chunk_count(&self, field: impl Into<Field>) -> Result<()> {
        let (poses, n_chunks) = (self.poses(), self.chunks);
        if n_chunks <= MAX_CHUNKS {
            return Ok(());
        }
        // The smallest chunk size that works. A shard that starts between two multiples may need
        // one more chunk, so step up from the whole run's size (a step or two at most).
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

    pub(crate) fn chunk(&self, c: u64) -> Range<u64> {
        let (cp, first) = (self.chunk_poses, self.range.start / self.chunk_poses);
        ((first + c) * cp).max(self.range.start)..((first + c + 1) * cp).min(self.range.end)
    }

    /// Returns what every chunk's computation shares.
    pub(crate) fn work(&self) -> Result<Work<'_>> {
        Work::new(self.config, &self.desc.columns, &self.kinds, self.sigma)
    }

    /// Returns the metric columns the chunks fill: the kept metrics and the summary's metric.
    pub(crate) fn metric_columns(&self) -> MetricColumns {
        let table = self.rows.then_some(self.config.result_columns.as_slice());
        metric_columns(table, self.by)
    }

    /// Computes chunks `todo` on `backend` and hands each to `sink` in order, until it breaks
    /// or `stop` is set (polled inside the chunks too: a chunk cut short is not handed on).
    /// A grid's chunks go in one run of blocks ([`Backend::project_blocks`]), so the device never
    /// waits between them. A list's go one at a time. `metrics` is reused between chunks.
    ///
    /// # Errors
    /// As [`Work::block`] and [`Work::rows`], and `sink`'s first error.
    pub(crate) fn compute(
        &self,
        work: &Work<'_>,
        backend: &Backend,
        metrics: &mut MetricColumns,
        todo: Range<u64>,
        stop: Stop<'_>,
        sink: &mut dyn FnMut(Computed, &MetricColumns) -> Result<ControlFlow<()>>,
    ) -> Result<ControlFlow<()>> {
        let rows = self.rows;
        let values_of = |m: &MetricColumns| self.by.map(|by| ForSummary::Values(values(m, by)));
        let Some(sweep) = work.sweep() else {
            for chunk in todo {
                let poses = self.chunk(chunk);
                let table = match work.block(backend, poses.clone(), rows, metrics, stop) {
                    Err(crate::Error::Engine(sonarproj::Error::Stopped)) => {
                        return Ok(ControlFlow::Break(()));
                    }
                    other => other?,
                };
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
        // A summaries-only run on a device that reduces: the host takes over where it cannot.
        let mut todo = todo;
        if let Some(reduction) = self.device_reduction(backend, &sweep) {
            match self.reduce(backend, &sweep, &reduction, todo.clone(), stop, sink)? {
                Ok(flow) => return Ok(flow),
                Err(c) => todo = c..todo.end,
            }
        }
        let blocks: Vec<Range<u64>> = todo.clone().map(|c| self.chunk(c)).collect();
        let mut chunk = todo.start;
        let mut failed = None;
        let flow = backend.project_blocks(&sweep, &blocks, metrics, stop, &mut |poses, metrics| {
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

    /// Returns the reduction of this plan's summary when `backend` reduces `sweep` on the device:
    /// a summaries-only grid sweep on a GPU with 64-bit atomics, within the device's bounds (a
    /// `top` of at most 32, 2^21 marginal cells). Elsewhere the host reduces the metric columns.
    fn device_reduction(&self, backend: &Backend, sweep: &PoseSweep<'_>) -> Option<MetricReduction> {
        if self.rows || !backend.reduces_on_device(sweep) {
            return None;
        }
        self.spec?.reduction(self.grid).filter(|r| r.validate().is_ok())
    }

    /// Summarises chunks `todo` of a grid on the device ([`Backend::reduce_blocks`]), handing each
    /// chunk's summary part to `sink` as [`Plan::compute`] does. Returns `Err(c)` when chunks
    /// `c..todo.end` are left to the host: chunk `c` holds a value too large for the device's
    /// exact sums, or the device could not start the reduction (its stage refused).
    fn reduce(
        &self,
        backend: &Backend,
        sweep: &PoseSweep<'_>,
        reduction: &MetricReduction,
        todo: Range<u64>,
        stop: Stop<'_>,
        sink: &mut dyn FnMut(Computed, &MetricColumns) -> Result<ControlFlow<()>>,
    ) -> Result<std::result::Result<ControlFlow<()>, u64>> {
        let spec = self.spec.expect("a reduction has a summary");
        let blocks: Vec<Range<u64>> = todo.clone().map(|c| self.chunk(c)).collect();
        let mut chunk = todo.start;
        let (mut failed, mut to_host) = (None, None);
        let none = MetricColumns::default();
        let flow = backend.reduce_blocks(sweep, &blocks, reduction, stop, &mut |poses, reduced| {
            let this = chunk;
            chunk += 1;
            let Some(part) = spec.part_of_reduction(self.grid, reduced) else {
                to_host = Some(this);
                return ControlFlow::Break(());
            };
            let computed = Computed {
                chunk: this,
                poses,
                table: None,
                values: Some(ForSummary::Reduced(part)),
            };
            sink(computed, &none).unwrap_or_else(|e| {
                failed = Some(e);
                ControlFlow::Break(())
            })
        });
        match (flow, failed, to_host) {
            // The device refused before any chunk was done: the host takes them all.
            (Err(sonarproj::Error::Gpu { .. }), _, _) if chunk == todo.start => Ok(Err(todo.start)),
            (Err(e), _, _) => Err(e.into()),
            (Ok(_), Some(e), _) => Err(e),
            (Ok(_), None, Some(c)) => Ok(Err(c)),
            (Ok(flow), None, None) => Ok(Ok(flow)),
        }
    }
}
