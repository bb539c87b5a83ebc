//! A sweep run in memory, writing nothing: the table's columns and the summaries returned.

use std::ops::ControlFlow;

use sonarproj::projection::Backend;

use crate::error::{Error, Result};
use crate::io::parquet::Table;
use crate::sweep::SweepConfig;
use crate::sweep::plan::{Computed, Plan, RUN_BLOCKS, check_chunk_poses, default_chunk_poses};
use crate::sweep::records::descriptor;
use crate::sweep::run::Event;
use crate::sweep::shard::Shard;
use crate::sweep::summary::Summary;

/// The most bytes of columns [`run_in_memory`] builds: 1 GiB, about 6 million grid poses.
/// A larger sweep runs into a directory, or asks for summaries only.
pub const MAX_IN_MEMORY_BYTES: u64 = 1 << 30;

/// What [`run_in_memory`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct InMemory {
    /// Every pose's row in `sweep.csv`'s columns, unless the `[summary]` says `rows = false`.
    pub table: Option<Table>,
    /// The summaries, when the sweep asks for them.
    pub summary: Option<Summary>,
    /// Poses computed.
    pub poses: u64,
}

/// Runs `config` (or one shard) on `backend` in memory, returning its table and summaries.
///
/// The results match the `sweep.parquet` and `summary.json` of [`super::run::run`], computed in
/// the same chunks of `chunk_poses` (`None`: [`default_chunk_poses`]). `events` hears of
/// progress after each chunk and may stop the run, which then returns `None`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `--chunk-poses` when 0, or `--out` when the table
/// would exceed [`MAX_IN_MEMORY_BYTES`]. Errors of [`Backend::project`].
pub fn run_in_memory(
    config: &SweepConfig,
    backend: &Backend,
    shard: Option<Shard>,
    chunk_poses: Option<u64>,
    stop: sonarproj::stream::Stop<'_>,
    events: &mut dyn FnMut(Event) -> ControlFlow<()>,
) -> Result<Option<InMemory>> {
    if let Some(cp) = chunk_poses {
        check_chunk_poses(cp, crate::params::CHUNK_POSES)?;
    }
    let chunk_poses = chunk_poses.unwrap_or_else(|| default_chunk_poses(config));
    let plan = Plan::new(config, descriptor(config)?, shard, chunk_poses)?;
    let poses = plan.poses();
    let bytes = poses.saturating_mul(8 * plan.desc.columns.len() as u64);
    if plan.rows && bytes > MAX_IN_MEMORY_BYTES {
        return Err(Error::invalid(
            crate::params::OUT,
            "(none)",
            format!(
                "is needed: this sweep's {poses} rows would take {} MiB in memory, more than {} MiB; \
                 give an output directory, or ask for summaries only ([summary] rows = false)",
                bytes >> 20,
                MAX_IN_MEMORY_BYTES >> 20
            ),
        ));
    }
    let mut table = plan.rows.then(|| Table::new(&plan.desc.columns, &plan.kinds));
    let mut summary = plan.spec.map(|s| s.empty(plan.grid));
    let work = plan.work()?;
    let mut metrics = plan.metric_columns();
    let mut add = |computed: Computed, _: &sonarproj::MetricColumns| -> Result<ControlFlow<()>> {
        if let (Some(table), Some(part)) = (&mut table, computed.table) {
            table.append(part)?;
        }
        if let (Some(spec), Some(values), Some(total)) = (plan.spec, computed.values, &mut summary) {
            let part = values.into_part(spec, plan.grid, computed.poses.start)?;
            spec.merge_into(total, &part, "in memory")?;
        }
        Ok(events(Event::Progress {
            done: computed.poses.end - plan.range.start,
            total: poses,
        }))
    };
    // A grid runs RUN_BLOCKS chunks at a time, so the device does not wait between them.
    // A list runs one at a time.
    let run = if work.sweep().is_some() {
        RUN_BLOCKS as u64
    } else {
        1
    };
    let mut c = 0;
    while c < plan.chunks {
        let todo = c..(c + run).min(plan.chunks);
        if plan
            .compute(&work, backend, &mut metrics, todo.clone(), stop, &mut add)?
            .is_break()
        {
            return Ok(None);
        }
        c = todo.end;
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
