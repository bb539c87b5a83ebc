//! A sweep run in memory, writing nothing: the table's columns and the summaries returned.

use std::ops::ControlFlow;

use sonarproj::local_precision::resolve_sigma_range;
use sonarproj::metrics::Metric;
use sonarproj::projection::Backend;

use crate::error::{Error, Result};
use crate::io::parquet::Table;
use crate::sweep::SweepConfig;
use crate::sweep::compute::{Work, for_blocks, metric_columns, values};
use crate::sweep::records::descriptor;
use crate::sweep::run::Event;
use crate::sweep::run::RUN_BLOCKS;
use crate::sweep::shard::Shard;
use crate::sweep::summary::Summary;
use crate::sweep::table::column_kinds;

/// The most bytes of columns [`run_in_memory`] builds (1 GiB: about 6 million poses of a grid
/// sweep); a larger sweep runs into a directory, or asks for summaries only.
pub const MAX_IN_MEMORY_BYTES: u64 = 1 << 30;

/// What [`run_in_memory`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct InMemory {
    /// The table (every pose's row, the columns of `sweep.csv`), unless the sweep's `[summary]`
    /// says `rows = false`.
    pub table: Option<Table>,
    /// The summaries, when the sweep asks for them.
    pub summary: Option<Summary>,
    /// Poses computed.
    pub poses: u64,
}

/// Runs `config` (or one shard of it) on `backend` and returns its table's columns and its
/// summaries, writing nothing: the rows are those `sweep.parquet` holds, the summaries those of
/// `summary.json`. `events` hears of progress after each chunk of `chunk_poses` poses (`None`:
/// [`default_chunk_poses`](super::run::default_chunk_poses)) and may stop the run (the result
/// is then `None`).
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `--chunk-poses` when 0, and `--out` when the table
/// would exceed [`MAX_IN_MEMORY_BYTES`]; errors of [`Backend::project`].
pub fn run_in_memory(
    config: &SweepConfig,
    backend: &Backend,
    shard: Option<Shard>,
    chunk_poses: Option<u64>,
    events: &mut dyn FnMut(Event) -> ControlFlow<()>,
) -> Result<Option<InMemory>> {
    if let Some(cp) = chunk_poses {
        super::run::check_chunk_poses(cp, "--chunk-poses")?;
    }
    let chunk_poses = chunk_poses.unwrap_or_else(|| super::run::default_chunk_poses(config));
    let desc = descriptor(config)?;
    let range = shard.map_or(0..desc.poses, |s| s.range(desc.poses));
    let poses = range.end - range.start;
    let spec = config.summary.as_ref();
    let rows = spec.is_none_or(|s| s.rows);
    let bytes = poses.saturating_mul(8 * desc.columns.len() as u64);
    if rows && bytes > MAX_IN_MEMORY_BYTES {
        return Err(Error::invalid(
            "--out",
            "(none)",
            format!(
                "is needed: this sweep's {poses} rows would take {} MiB in memory, more than {} MiB; \
                 give an output directory, or ask for summaries only ([summary] rows = false)",
                bytes >> 20,
                MAX_IN_MEMORY_BYTES >> 20
            ),
        ));
    }
    let grid = match &config.poses {
        crate::sweep::Poses::Grid(g) => Some(g),
        crate::sweep::Poses::List(_) => None,
    };
    let kinds = column_kinds(&desc.columns);
    let sigma = resolve_sigma_range(&config.source, &config.target, config.sigma_range)?;
    let by = spec.map(|s| Metric::from_name(&s.by).expect("a checked metric name"));
    let mut table = rows.then(|| Table::new(&desc.columns, &kinds));
    let mut summary = spec.map(|s| s.empty(grid));
    let work = Work::new(config, &desc.columns, &kinds, sigma)?;
    let mut metrics = metric_columns(rows.then_some(config.result_columns.as_slice()), by);
    let mut next = range.start;
    // The next `n` blocks at most (none at the end).
    let mut take = |n: usize| -> Vec<std::ops::Range<u64>> {
        let mut out = Vec::new();
        while next < range.end && out.len() < n {
            let r = next..(next + chunk_poses).min(range.end);
            next = r.end;
            out.push(r);
        }
        out
    };
    // Adds block `r` (its table, when rows are asked for, and its metrics) to the results;
    // returns whether to stop.
    let mut add =
        |r: std::ops::Range<u64>, part: Option<Table>, metrics: &sonarproj::MetricColumns| -> Result<bool> {
            if let (Some(table), Some(part)) = (&mut table, part) {
                table.append(part)?;
            }
            if let (Some(spec), Some(by), Some(total)) = (spec, by, &mut summary) {
                let part = spec.partial(grid, r.start, &values(metrics, by))?;
                spec.merge_into(total, &part, "in memory")?;
            }
            Ok(events(Event::Progress {
                done: r.end - range.start,
                total: poses,
            })
            .is_break())
        };
    if let Some(sweep) = work.sweep() {
        // A grid's blocks one after the other, the device not waiting between them.
        loop {
            let blocks = take(RUN_BLOCKS);
            if blocks.is_empty() {
                break;
            }
            let mut each = |r: std::ops::Range<u64>, metrics: &sonarproj::MetricColumns| {
                let part = if rows {
                    Some(work.rows(r.clone(), metrics)?)
                } else {
                    None
                };
                add(r, part, metrics)
            };
            if for_blocks(backend, &sweep, &blocks, &mut metrics, &mut each)? {
                return Ok(None);
            }
        }
    } else {
        while let Some(r) = take(1).pop() {
            let part = work.block(backend, r.clone(), rows, &mut metrics, &|| false)?;
            if add(r, part, &metrics)? {
                return Ok(None);
            }
        }
    }
    if let Some(s) = &mut summary {
        crate::sweep::summary::fill_means(s);
    }
    Ok(Some(InMemory {
        table,
        summary,
        poses,
    }))
}
