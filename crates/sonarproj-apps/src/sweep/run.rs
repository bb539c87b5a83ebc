//! Runs a sweep in chunks that survive interruption, and in shards that can run on different
//! machines and merge into the file one run would write.
//!
//! Files in the output directory `DIR`:
//! - `sweep.json`: what the sweep is (fingerprint, pose count, columns, figure axes). Every run
//!   and shard writes the same one, and refuses a directory holding another sweep's.
//! - `sweep.csv` (a whole run) or `shard-K-of-N.csv` (one shard): `index`, the pose columns and
//!   the metrics, one row per pose in index order. Or the same table as `sweep.parquet` /
//!   `shard-K-of-N.parquet` ([`Format::Parquet`]).
//! - `NAME.meta.json` beside each result: the record of what it holds ([`super::parts`]).
//! - `summary.json` or `shard-K-of-N.summary.json` when the sweep file has a `[summary]`
//!   ([`super::summary`]). With `rows = false` it is the only result.
//! - `sweep-METRIC.png`: the metric against the varying axes (whole runs and merges only).
//! - `.partial-sweep/` or `.partial-shard-K-of-N/` while unfinished: `manifest.json` and one
//!   `chunk-NNNNNNNN.csv` per finished chunk with its record, each written whole or not at all.
//!   The run's last chunk keeps what the results take from memory out of it (its summary part,
//!   and its Parquet table when joined as chunks finish): the results are written next.
//!   A re-run skips finished chunks whose bytes match their records and recomputes the others,
//!   saying so (the last chunk too, when a run stopped before its results). The directory is
//!   removed once the result file is written.

use sonarproj::stream::Stop;
use std::ops::ControlFlow;
use std::path::PathBuf;

use sonarproj::projection::Backend;

use sonarproj::error::Field;

use crate::error::{Error, Result};
use crate::params;
use crate::report::{output_dir, remove_stale_temporaries};
use crate::sweep::SweepConfig;
use crate::sweep::figure::{figure, figure_of_marginal};
use crate::sweep::parts::{self, write_json};
use crate::sweep::plan::{Computed, Plan, RUN_BLOCKS, check_chunk_poses, default_chunk_poses};
use crate::sweep::records::{
    Settings, claim, descriptor, first_difference, first_not_good, read_json, settings, settings_path,
    write_summary,
};
use crate::sweep::shard::Shard;
use crate::sweep::state::{self, Files, Manifest, unfinished};
use crate::sweep::summary::fill_means;
use crate::sweep::table::{CsvChunk, Format};
use crate::sweep::writer::Writer;

/// How to run a sweep.
#[derive(Clone, Debug)]
pub struct Options {
    /// The output directory.
    pub out: PathBuf,
    /// One part of the sweep, or all of it.
    pub shard: Option<Shard>,
    /// Poses per chunk, the unit of resumption.
    /// `None` takes the unfinished run's in the directory, else [`default_chunk_poses`].
    pub chunk_poses: Option<u64>,
    /// Stop after computing this many chunks (the run stays resumable).
    pub max_chunks: Option<u64>,
    /// The format of the result, its chunks and shards.
    pub format: Format,
}

/// What a call to [`run`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The result file, when the sweep (or shard) is complete.
    pub file: Option<PathBuf>,
    /// The figure written, if any.
    pub figure: Option<PathBuf>,
    /// The summaries' file (`summary.json` or a shard's), when asked for and complete.
    pub summary: Option<PathBuf>,
    /// Poses of this run or shard.
    pub poses: u64,
    /// Poses computed by this call.
    pub computed: u64,
    /// Poses found finished by an earlier call.
    pub resumed: u64,
    /// Whether the result was there, whole, from an earlier call: nothing was written.
    pub finished_before: bool,
}

/// What [`run`] reports while it works.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Event {
    /// `done` of this run's `total` poses are finished.
    Progress {
        /// Poses finished.
        done: u64,
        /// Poses of this run or shard.
        total: u64,
    },
    /// A part on disk was not what its record says and is computed again.
    Recomputing {
        /// The part.
        file: PathBuf,
        /// Why it was set aside.
        reason: String,
    },
}

/// Runs `config` (or one shard) on `backend` into `opts.out`, resuming from finished chunks.
///
/// `events` hears of progress after each chunk and of every damaged part set aside. When it
/// answers [`ControlFlow::Break`], the run stops as `max_chunks` stops it: finished chunks stay
/// on disk, the outcome has no file, and the same call resumes.
///
/// The run has four phases:
/// 1. Plan: check everything, write nothing.
/// 2. Lock: claim the directory, lock the run's state and check its manifest.
/// 3. Compute and write: chunk after chunk, each written while the next are computed.
/// 4. Finish: join the result from the chunks, remove the state, draw the figure.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] for a directory holding another sweep or an unfinished run
/// with other settings, or `--chunk-poses` cutting the run into more than
/// [`MAX_CHUNKS`](crate::limits::MAX_CHUNKS) chunks. Errors of [`Backend::project`] and of
/// writing files.
pub fn run(
    config: &SweepConfig,
    backend: &Backend,
    opts: &Options,
    stop: Stop<'_>,
    events: &mut dyn FnMut(Event) -> ControlFlow<()>,
) -> Result<Outcome> {
    // Plan. Everything is checked before the directory is made, so a refused run leaves nothing.
    let plan = plan(config, opts)?;
    let files = Files::new(&plan, &opts.out, opts.shard, opts.format);
    let dir = &opts.out;
    output_dir(dir, params::OUT)?;
    remove_stale_temporaries(dir);
    claim(dir, &plan.desc)?;
    files.check_writable()?;
    let mut outcome = Outcome {
        file: None,
        figure: None,
        summary: None,
        poses: plan.poses(),
        computed: 0,
        resumed: 0,
        finished_before: false,
    };
    if finished_before(&files, backend, opts, events, &mut outcome)?.is_break() {
        return Ok(outcome);
    }
    // Lock.
    let manifest = Manifest {
        fingerprint: plan.desc.fingerprint.clone(),
        format: opts.format,
        chunk_poses: plan.chunk_poses,
        shard: opts.shard,
        settings: settings(backend),
    };
    let _lock = files.open_state(&manifest)?;
    // Compute and write.
    if compute_and_write(
        &files,
        backend,
        opts,
        &manifest.settings,
        stop,
        events,
        &mut outcome,
    )?
    .is_break()
    {
        return Ok(outcome);
    }
    // Finish.
    outcome.summary = plan.spec.map(|_| files.summary.clone());
    std::fs::remove_dir_all(&files.state).map_err(|e| Error::write_output(&files.state, e))?;
    if opts.shard.is_none() {
        outcome.figure = if plan.rows {
            figure(&files.file, opts.format, &plan.desc)?
        } else {
            figure_of_marginal(dir, &plan.desc, &files.summary)?
        };
    }
    outcome.file = plan.rows.then_some(files.file);
    Ok(outcome)
}

/// Returns the plan of the run `opts` asks for, with its chunk size checked.
/// The size is the one given, else the unfinished run's (of this sweep; another is refused
/// later), else the default. An error names where the size came from.
fn plan<'a>(config: &'a SweepConfig, opts: &Options) -> Result<Plan<'a>> {
    let desc = descriptor(config)?;
    let stem = state::stem(opts.shard);
    let (chunk_poses, field) = match opts.chunk_poses {
        Some(cp) => (cp, Field::from(params::CHUNK_POSES)),
        None => unfinished(&opts.out, &stem)
            .filter(|m| m.fingerprint == desc.fingerprint && m.chunk_poses > 0)
            .map_or_else(
                || {
                    let field = Field::param(params::CHUNK_POSES, " (the default)");
                    (default_chunk_poses(config), field)
                },
                |m| {
                    let field = Field::param(params::CHUNK_POSES, " (the unfinished run's)");
                    (m.chunk_poses, field)
                },
            ),
    };
    // Check it whatever its source, before anything is written. An unfinished run's may come
    // from an older version or an edited manifest.
    check_chunk_poses(chunk_poses, field.clone())?;
    // One file per chunk, so their number is bounded; nothing else is kept per chunk.
    // Chunks end at multiples of the chunk size in the pose index (a shard's first and last may
    // be shorter). So a chunk of a multiple of GROUP_ROWS poses is whole row groups, which the
    // join copies as they are.
    let plan = Plan::new(config, desc, opts.shard, chunk_poses)?;
    plan.check_chunk_count(field)?;
    Ok(plan)
}

/// Returns `Break` when the run's result was finished by an earlier call with these settings
/// (`outcome` then says so), or when `events` stops the run as a damaged result is set aside.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] when the result was computed with other settings, or,
/// for a shard, without a record of how.
fn finished_before(
    files: &Files<'_>,
    backend: &Backend,
    opts: &Options,
    events: &mut dyn FnMut(Event) -> ControlFlow<()>,
    outcome: &mut Outcome,
) -> Result<ControlFlow<()>> {
    let (checked, status) = first_not_good(&files.results(), files.whole());
    match status {
        parts::Status::Good => {}
        parts::Status::Missing => return Ok(ControlFlow::Continue(())),
        parts::Status::Damaged(reason) => {
            let file = checked.to_path_buf();
            return Ok(events(Event::Recomputing { file, reason }));
        }
    }
    // Finished earlier: the result is written only once every chunk is. Check the settings too,
    // so a part computed otherwise, or without a record of how, is not passed off as this run's.
    // A shard needs that record to be merged.
    let file = &files.file;
    let record = settings_path(file);
    match read_json::<Settings>(&record)? {
        Some(was) => {
            if let Some((name, a, b)) = first_difference(&was, &settings(backend)) {
                return Err(Error::invalid(
                    if name == "backend" {
                        Field::from(params::BACKEND)
                    } else {
                        Field::from(&name)
                    },
                    b,
                    format!(
                        "{} was finished with {name} {a:?}; run with the same settings, or remove it to compute it again",
                        file.display()
                    ),
                ));
            }
        }
        None if opts.shard.is_some() => {
            return Err(Error::invalid(
                params::SHARD,
                files.stem.clone(),
                format!(
                    "{} is finished but has no record of how it was computed ({} is missing): remove it to compute it again",
                    file.display(),
                    record.display()
                ),
            ));
        }
        None => {}
    }
    let plan = files.plan;
    outcome.resumed = plan.poses();
    outcome.finished_before = true;
    outcome.summary = plan.spec.map(|_| files.summary.clone());
    outcome.file = plan.rows.then(|| file.clone());
    // Finished: nothing left to stop.
    let _ = events(Event::Progress {
        done: plan.poses(),
        total: plan.poses(),
    });
    Ok(ControlFlow::Break(()))
}

/// Computes the unfinished chunks, writing each while the next are computed ([`Writer`]).
/// Once all are done, writes the settings record, the result and the summaries.
/// Returns `Break` when the run stopped first (`max_chunks`, or `events`).
fn compute_and_write(
    files: &Files<'_>,
    backend: &Backend,
    opts: &Options,
    settings: &Settings,
    stop: Stop<'_>,
    events: &mut dyn FnMut(Event) -> ControlFlow<()>,
    outcome: &mut Outcome,
) -> Result<ControlFlow<()>> {
    let plan = files.plan;
    let work = plan.work()?;
    let mut metrics = plan.metric_columns();
    let mut budget = opts.max_chunks.unwrap_or(u64::MAX);
    // A grid's Parquet or summary chunks are projected in runs of blocks, so the device never
    // waits for the host between them. A list's chunks, and CSV chunks, go one at a time.
    let csv = plan.rows && opts.format == Format::Csv;
    let streamed = work.sweep().is_some() && !csv;
    let join = joins_as_chunks_finish(files, opts, budget);
    std::thread::scope(|scope| -> Result<ControlFlow<()>> {
        let mut writer = Writer::new(scope, files, join);
        let mut done = 0;
        let mut c = 0;
        while c < plan.chunks {
            let r = plan.chunk(c);
            let (good, damaged) = files.checked(c);
            let damaged = damaged.map(recomputing);
            if good {
                outcome.resumed += r.end - r.start;
                writer.resumed(c)?;
                done += r.end - r.start;
                c += 1;
                if events(Event::Progress {
                    done,
                    total: plan.poses(),
                })
                .is_break()
                {
                    writer.settle()?;
                    return Ok(ControlFlow::Break(()));
                }
                continue;
            }
            if budget == 0 || damaged.is_some_and(|e| events(e).is_break()) {
                writer.settle()?;
                return Ok(ControlFlow::Break(()));
            }
            budget -= 1;
            // Take this chunk and, when streamed, the unfinished ones after it, within the budget
            // and at most RUN_BLOCKS at a time. A damaged chunk's event is sent when its turn
            // comes, after the chunks before it, as one at a time would.
            let mut announce: Vec<Option<Event>> = vec![None];
            while streamed
                && budget > 0
                && announce.len() < RUN_BLOCKS
                && c + (announce.len() as u64) < plan.chunks
            {
                let (good, damaged) = files.checked(c + announce.len() as u64);
                if good {
                    break;
                }
                budget -= 1;
                announce.push(damaged.map(recomputing));
            }
            let todo = c..c + announce.len() as u64;
            let mut accept = |computed: Computed| -> Result<ControlFlow<()>> {
                let said =
                    announce[usize::try_from(computed.chunk - todo.start).expect("a run's chunk")].take();
                if said.is_some_and(|e| events(e).is_break()) {
                    return Ok(ControlFlow::Break(()));
                }
                let n = computed.poses.end - computed.poses.start;
                let last = computed.chunk + 1 == plan.chunks;
                writer.write(computed, last)?;
                outcome.computed += n;
                done += n;
                Ok(events(Event::Progress {
                    done,
                    total: plan.poses(),
                }))
            };
            let flow = if csv {
                // A CSV chunk streams its rows to disk: the stop is looked at between chunks.
                if stop.is_set() {
                    writer.settle()?;
                    return Ok(ControlFlow::Break(()));
                }
                accept(csv_chunk(files, backend, c)?)?
            } else {
                plan.compute(
                    &work,
                    backend,
                    &mut metrics,
                    todo.clone(),
                    stop,
                    &mut |computed, _| accept(computed),
                )?
            };
            if flow.is_break() {
                writer.settle()?;
                return Ok(ControlFlow::Break(()));
            }
            c = todo.end;
        }
        writer.settle()?;
        write_results(files, opts, settings, &mut writer)?;
        Ok(ControlFlow::Continue(()))
    })
}

fn recomputing((file, reason): (PathBuf, String)) -> Event {
    Event::Recomputing { file, reason }
}

/// Returns whether a Parquet result is joined as its chunks finish, rather than at the end.
/// Only when the run can finish: a run that `max_chunks` (`budget`) will stop would copy the
/// finished chunks for nothing, again on each resume. And only into a regular file: a device
/// or FIFO gets the table only once it is whole.
fn joins_as_chunks_finish(files: &Files<'_>, opts: &Options, budget: u64) -> bool {
    let plan = files.plan;
    let can_finish = opts.max_chunks.is_none_or(|_| {
        let missing = (0..plan.chunks).filter(|&c| files.chunk_files(c).iter().any(|f| !f.exists()));
        usize::try_from(budget).is_ok_and(|b| missing.take(b.saturating_add(1)).count() <= b)
    });
    let regular = !files.file.exists() || parts::is_regular(&files.file);
    plan.rows && opts.format == Format::Parquet && can_finish && regular
}

/// Computes chunk `c` as CSV rows written straight into its file.
/// Returns it with the values its summary reduces; its table is already on disk.
fn csv_chunk(files: &Files<'_>, backend: &Backend, c: u64) -> Result<Computed> {
    let plan = files.plan;
    let poses = plan.chunk(c);
    let header = plan.config.columns();
    let csv = CsvChunk {
        config: plan.config,
        header: &header,
    };
    let path = files.chunk_path(c);
    let values = csv.write(backend, poses.clone(), &path, files.expected(&poses), plan.by)?;
    Ok(Computed {
        chunk: c,
        poses,
        table: None,
        values: values.map(crate::sweep::plan::ForSummary::Values),
    })
}

/// Writes a finished run's results. Settings go first, so a result never stands without them.
/// The summary goes last, after the table, so a summary beside a table means the table is whole.
fn write_results(
    files: &Files<'_>,
    opts: &Options,
    settings: &Settings,
    writer: &mut Writer<'_, '_>,
) -> Result<()> {
    let plan = files.plan;
    let chunks = (0..plan.chunks).map(|c| files.chunk_path(c));
    let (columns, whole) = (&plan.desc.columns, files.whole());
    write_json(&settings_path(&files.file), settings)?;
    match (plan.rows, opts.format) {
        _ if writer.joins() => writer.finish_join()?,
        (true, Format::Csv) => parts::join(chunks, columns, &files.file, whole)?,
        (true, Format::Parquet) => parts::join_parquet(chunks, columns, &plan.kinds, &files.file, whole)?,
        (false, _) => {}
    }
    if let Some(mut total) = writer.total.take() {
        fill_means(&mut total);
        write_summary(&files.summary, whole, &total)?;
    }
    Ok(())
}
