//! Running a sweep in chunks that survive interruption, in shards that can run on different
//! machines, and merging the shards into the file one run would have written.
//!
//! Files in the output directory `DIR`:
//! - `sweep.json`: what the sweep is (fingerprint, pose count, columns, figure axes); every run
//!   and shard writes the same one and refuses a directory holding another sweep's;
//! - `sweep.csv` (a whole run) or `shard-K-of-N.csv` (one shard): `index`, the pose columns and
//!   the metrics, one row per pose in index order; beside each, `NAME.meta.json`, the record of
//!   what it holds ([`super::parts`]: sweep fingerprint, first index, rows, size, CRC-32) — or
//!   the same table as `sweep.parquet` / `shard-K-of-N.parquet` ([`Format::Parquet`]);
//! - `summary.json` or `shard-K-of-N.summary.json` when the sweep file has a `[summary]`
//!   ([`super::summary`]); with `rows = false` it is the only result;
//! - `sweep-METRIC.png`: the metric against the grid's one or two varying axes (whole runs and
//!   merges only);
//! - `.partial-sweep/` or `.partial-shard-K-of-N/` while unfinished: `manifest.json` and one
//!   `chunk-NNNNNNNN.csv` per finished chunk (with its record), each written whole or not at all.
//!   A re-run skips the finished chunks whose bytes match their records and computes the others
//!   again, saying so; the directory is removed once the result file is written.

use std::ops::{ControlFlow, Range};
use std::path::{Path, PathBuf};

use crate::limits::{MAX_CHUNK_POSES, MAX_CHUNKS};
use serde::{Deserialize, Serialize};
use sonarproj::local_precision::resolve_sigma_range;
use sonarproj::metrics::Metric;
use sonarproj::projection::Backend;

use crate::error::{Error, Result};
use crate::io::parquet::{Table, TableWriter};
use crate::report::{check_output_file, output_dir, remove_stale_temporaries};
use crate::sweep::SweepConfig;
use crate::sweep::compute::{Work, for_blocks, metric_columns, values};
use crate::sweep::figure::{figure, figure_of_marginal};
use crate::sweep::parts::{self, final_encoding, write_json};
use crate::sweep::records::{
    Settings, claim, descriptor, first_difference, first_not_good, read_json, read_part, settings,
    settings_path, write_summary,
};
use crate::sweep::shard::Shard;
use crate::sweep::summary::{PartSummary, Summary, fill_means};
use crate::sweep::table::{CsvChunk, Format, column_kinds};

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
pub(crate) fn check_chunk_poses(chunk_poses: u64, field: &str) -> Result<()> {
    if (1..=MAX_CHUNK_POSES).contains(&chunk_poses) {
        return Ok(());
    }
    Err(Error::invalid(
        field,
        chunk_poses,
        format!("must be in [1, {MAX_CHUNK_POSES}] (a chunk is held in memory)"),
    ))
}

/// The state of an unfinished run, in its `.partial-*` directory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Manifest {
    fingerprint: String,
    /// Absent in the manifests of runs from before Parquet: CSV.
    #[serde(default)]
    format: Format,
    chunk_poses: u64,
    shard: Option<Shard>,
    settings: Settings,
}

/// How to run a sweep.
#[derive(Clone, Debug)]
pub struct Options {
    /// The output directory.
    pub out: PathBuf,
    /// One part of the sweep, or all of it.
    pub shard: Option<Shard>,
    /// Poses per chunk (the unit of resumption); `None`: the unfinished run's in the directory,
    /// else [`default_chunk_poses`].
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
    /// The summaries' file (`summary.json`, or a shard's), when the sweep asks for them and is
    /// complete.
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

/// Runs `config` (or one shard of it) on `backend` into `opts.out`, resuming from finished
/// chunks; `events` hears of progress after each chunk and of every damaged part set aside.
/// When `events` answers [`ControlFlow::Break`], the run stops there as `max_chunks` stops it:
/// finished chunks stay on disk, the outcome has no file, and the same call resumes.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] for a directory holding another sweep or an unfinished run with
/// other settings, or `--chunk-poses` cutting the run into more than [`MAX_CHUNKS`] chunks;
/// errors of [`Backend::project`] and of writing files.
pub fn run(
    config: &SweepConfig,
    backend: &Backend,
    opts: &Options,
    events: &mut dyn FnMut(Event) -> ControlFlow<()>,
) -> Result<Outcome> {
    // Everything is checked before the directory is created: a refused run leaves nothing.
    let dir = &opts.out;
    let desc = descriptor(config)?;
    let (stem, range) = match opts.shard {
        Some(s) => (s.stem(), s.range(desc.poses)),
        None => ("sweep".to_string(), 0..desc.poses),
    };
    // Unless given, the chunk size of the unfinished run being resumed (of this sweep: another
    // is refused below), or the default.
    // The field an error names says where the size came from.
    let (chunk_poses, field) = match opts.chunk_poses {
        Some(cp) => (cp, "--chunk-poses"),
        None => read_json::<Manifest>(&dir.join(format!(".partial-{stem}")).join("manifest.json"))
            .ok()
            .flatten()
            .filter(|m| m.fingerprint == desc.fingerprint && m.chunk_poses > 0)
            .map_or_else(
                || (default_chunk_poses(config), "--chunk-poses (the default)"),
                |m| (m.chunk_poses, "--chunk-poses (the unfinished run's)"),
            ),
    };
    // Whichever it came from (an unfinished run's too: of an older version, or an edited
    // manifest), before anything is written.
    check_chunk_poses(chunk_poses, field)?;
    let poses = range.end - range.start;
    // One file a chunk: their number is bounded, and nothing is kept per chunk but its file.
    // Chunks end at the multiples of --chunk-poses in the pose index (a shard's first and last
    // may be shorter), so a chunk of a multiple of GROUP_ROWS poses is whole row groups, which
    // the join copies as they are.
    let cp = chunk_poses;
    let first_chunk = range.start / cp;
    let chunks_of = |cp: u64| {
        if poses == 0 {
            0
        } else {
            range.end.div_ceil(cp) - range.start / cp
        }
    };
    let n_chunks = chunks_of(cp);
    if n_chunks > MAX_CHUNKS {
        // The smallest chunk size that works: a whole run's, or one more chunk's for a shard
        // that starts between two multiples (at most a step or two above the whole run's).
        let mut fits = poses.div_ceil(MAX_CHUNKS);
        while chunks_of(fits) > MAX_CHUNKS {
            fits += 1;
        }
        return Err(Error::invalid(
            field,
            chunk_poses,
            format!(
                "cuts this run's {poses} poses into {n_chunks} chunk files, more than the \
                 {MAX_CHUNKS} one run keeps: use --chunk-poses {fits} or more (or shards)"
            ),
        ));
    }
    output_dir(dir, "--out")?;
    remove_stale_temporaries(dir);
    claim(dir, &desc)?;
    let ext = opts.format.extension();
    let spec = config.summary.as_ref();
    let rows = spec.is_none_or(|s| s.rows);
    let grid = match &config.poses {
        crate::sweep::Poses::Grid(g) => Some(g),
        crate::sweep::Poses::List(_) => None,
    };
    // The result: the table, or the summaries alone when no rows are asked for (the settings
    // record stands beside it).
    let summary_file = match opts.shard {
        Some(_) => dir.join(format!("{stem}.summary.json")),
        None => dir.join("summary.json"),
    };
    let file = if rows {
        dir.join(format!("{stem}.{ext}"))
    } else {
        summary_file.clone()
    };
    // The result files this run writes: the table, the summaries, or both.
    let results: Vec<&Path> = match (rows, spec.is_some()) {
        (true, true) => vec![&file, &summary_file],
        (false, _) => vec![&summary_file],
        (true, false) => vec![&file],
    };
    // Every result file can be written (not a directory, say) before anything is computed.
    for f in &results {
        check_output_file(f, "--out")?;
    }
    let mut outcome = Outcome {
        file: None,
        figure: None,
        summary: None,
        poses,
        computed: 0,
        resumed: 0,
        finished_before: false,
    };
    let whole = parts::Expected {
        fingerprint: &desc.fingerprint,
        first: range.start,
        rows: poses,
    };
    let (checked, status) = first_not_good(&results, whole);
    match status {
        // Finished earlier (the result is written only once every chunk is), with these
        // settings: a part computed otherwise, or without a record of how (a shard must have
        // one to be merged), is not passed off as this run's.
        parts::Status::Good => {
            let record = settings_path(&file);
            let now = settings(backend);
            match read_json::<Settings>(&record)? {
                Some(was) => {
                    if let Some((name, a, b)) = first_difference(&was, &now) {
                        return Err(Error::invalid(
                            if name == "backend" {
                                "--backend".to_string()
                            } else {
                                name.clone()
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
                        "--shard",
                        stem.clone(),
                        format!(
                            "{} is finished but has no record of how it was computed ({} is missing): remove it to compute it again",
                            file.display(),
                            record.display()
                        ),
                    ));
                }
                None => {}
            }
            outcome.resumed = poses;
            outcome.finished_before = true;
            outcome.summary = spec.map(|_| summary_file.clone());
            outcome.file = rows.then_some(file);
            // Finished: nothing left to stop.
            let _ = events(Event::Progress {
                done: poses,
                total: poses,
            });
            return Ok(outcome);
        }
        parts::Status::Missing => {}
        parts::Status::Damaged(reason) => {
            if events(Event::Recomputing {
                file: checked.to_path_buf(),
                reason,
            })
            .is_break()
            {
                return Ok(outcome);
            }
        }
    }
    let state = dir.join(format!(".partial-{stem}"));
    std::fs::create_dir_all(&state).map_err(|e| Error::write_output(&state, e))?;
    // One run at a time in a run's state: a second (the same shard submitted twice, a job
    // requeued while the first still runs) stops here instead of racing over its chunks.
    let _lock = lock_state(&state)?;
    remove_stale_temporaries(&state);
    let manifest = Manifest {
        fingerprint: desc.fingerprint.clone(),
        format: opts.format,
        chunk_poses,
        shard: opts.shard,
        settings: settings(backend),
    };
    let manifest_path = state.join("manifest.json");
    match read_json::<Manifest>(&manifest_path)? {
        None => write_json(&manifest_path, &manifest)?,
        Some(old) if old == manifest => {}
        Some(old) => {
            let (field, was, now) = if old.format != manifest.format {
                (
                    "--format".to_string(),
                    old.format.extension().to_string(),
                    manifest.format.extension().to_string(),
                )
            } else if old.chunk_poses != manifest.chunk_poses {
                (
                    "--chunk-poses".to_string(),
                    old.chunk_poses.to_string(),
                    manifest.chunk_poses.to_string(),
                )
            } else if let Some((name, was, now)) = first_difference(&old.settings, &manifest.settings) {
                (
                    if name == "backend" {
                        "--backend".to_string()
                    } else {
                        name
                    },
                    was,
                    now,
                )
            } else {
                ("--config".to_string(), "another sweep".into(), "this one".into())
            };
            return Err(Error::invalid(
                field,
                now,
                format!(
                    "the unfinished run in {} used {was}; re-run with the same settings to resume, or remove that directory to start over",
                    state.display()
                ),
            ));
        }
    }

    let chunk = |c: u64| {
        let s = ((first_chunk + c) * cp).max(range.start);
        s..((first_chunk + c + 1) * cp).min(range.end)
    };
    let chunk_path = |c: u64| state.join(format!("chunk-{c:08}.{ext}"));
    let chunk_summary = |c: u64| state.join(format!("chunk-{c:08}.summary.json"));
    let chunk_files = |c: u64| -> Vec<PathBuf> {
        let mut out = Vec::with_capacity(2);
        if rows {
            out.push(chunk_path(c));
        }
        if spec.is_some() {
            out.push(chunk_summary(c));
        }
        out
    };
    let by = spec.map(|s| Metric::from_name(&s.by).expect("a checked metric name"));
    let expected = |r: &Range<u64>| parts::Expected {
        fingerprint: &desc.fingerprint,
        first: r.start,
        rows: r.end - r.start,
    };
    let header = config.columns();
    let kinds = column_kinds(&desc.columns);
    let sigma = resolve_sigma_range(&config.source, &config.target, config.sigma_range)?;
    let work = Work::new(config, &desc.columns, &kinds, sigma)?;
    let mut metrics = metric_columns(rows.then_some(config.result_columns.as_slice()), by);
    let mut done = 0;
    let mut budget = opts.max_chunks.unwrap_or(u64::MAX);
    // The summary of the chunks finished so far (this run's, and earlier runs' read back from
    // disk), its means derived once at the end.
    let template = spec.map(|s| s.empty(grid));
    let mut total = template.clone();
    // Writes chunk `c` (poses `r`): its Parquet table when there is one (returned encoded, for
    // the result's join), and the summary of its `values` when one is asked for (returned, for
    // the total).
    let write_chunk =
        |c: u64, r: Range<u64>, table: Option<Table>, values: Option<Vec<f64>>| -> Result<Written> {
            let mut written = Written::default();
            if let Some(table) = table {
                let path = chunk_path(c);
                let mut bytes = Vec::new();
                let mut t = TableWriter::new(
                    &mut bytes,
                    &desc.columns,
                    &kinds,
                    r.start,
                    final_encoding(&desc.columns),
                    &path,
                )?;
                t.push(table)?;
                t.finish()?;
                parts::write_chunk(&path, expected(&r), |w| {
                    w.write_all(&bytes).map_err(|e| Error::write_output(&path, e))
                })?;
                written.table = Some(bytes::Bytes::from(bytes));
            }
            if let (Some(spec), Some(values)) = (spec, values) {
                let summary = spec.partial(grid, r.start, &values)?;
                let part = summary.to_part();
                let sum_path = chunk_summary(c);
                parts::write_chunk(&sum_path, expected(&r), |w| {
                    serde_json::to_writer(&mut *w, &part).map_err(|e| Error::write_output(&sum_path, e))
                })?;
                written.summary = Some(summary);
            }
            Ok(written)
        };
    // Joins the chunks of a Parquet table into the result as they finish, in order, on a thread
    // of its own: the result's temporary file grows while the run goes on, and is renamed into
    // place at `Finish` (a run that stops drops the sender, and the temporary file is removed).
    let join_chunks = |rx: std::sync::mpsc::Receiver<ToJoin>| -> Result<()> {
        parts::write(&file, whole, |w| {
            let mut join = parts::ParquetJoin::new(w, &desc.columns, &kinds, &file, whole)?;
            for message in rx {
                match message {
                    ToJoin::Bytes(c, bytes) => join.add_bytes(bytes, &chunk_path(c), c + 1 == n_chunks)?,
                    ToJoin::File(c) => join.add_file(&chunk_path(c), c + 1 == n_chunks)?,
                    ToJoin::Finish => return join.finish(),
                }
            }
            Err(sonarproj::Error::Stopped.into())
        })
    };
    // A chunk's files are written on a thread of their own while the next chunk is computed
    // (its Parquet encoding and summary overlap the next projection); one chunk at most is being
    // written, and it is finished, its error stopping the run, before the run stops or goes on
    // to the next write.
    let stopped = std::thread::scope(|scope| -> Result<bool> {
        type Writing<'s> = Option<(u64, std::thread::ScopedJoinHandle<'s, Result<Written>>)>;
        let mut writing: Writing<'_> = None;
        // The chunks are joined as they finish only when the run can finish (a run that
        // `--max-chunks` will stop would copy the finished chunks for nothing, again each time
        // it is resumed) into a regular file (a device or FIFO gets the table only once it is
        // whole); otherwise they are joined at the end.
        let can_finish = opts.max_chunks.is_none_or(|_| {
            let missing = (0..n_chunks).filter(|&c| chunk_files(c).iter().any(|f| !f.exists()));
            usize::try_from(budget).is_ok_and(|b| missing.take(b.saturating_add(1)).count() <= b)
        });
        let regular = !file.exists() || parts::is_regular(&file);
        let mut joiner = (rows && opts.format == Format::Parquet && can_finish && regular).then(|| {
            let (tx, rx) = std::sync::mpsc::sync_channel(1);
            Joiner {
                tx,
                handle: scope.spawn(move || join_chunks(rx)),
            }
        });
        // Waits for the chunk being written, adding its summary to the total and its table to
        // the result's join.
        let settle = |writing: &mut Writing<'_>,
                      total: &mut Option<Summary>,
                      joiner: &mut Option<Joiner<'_>>|
         -> Result<()> {
            let Some((c, h)) = writing.take() else {
                return Ok(());
            };
            let written = h
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
            if let (Some(spec), Some(t), Some(s)) = (spec, total, written.summary) {
                spec.merge_into(t, &s, "summary")?;
            }
            match written.table {
                Some(bytes) => Joiner::send(joiner, ToJoin::Bytes(c, bytes)),
                None => Ok(()),
            }
        };
        // Starts writing computed chunk `k` (poses `r`: its table, the values its summary
        // reduces) on a thread of its own; the caller has settled the chunk written before.
        let spawn_writer = |k: u64, r: Range<u64>, (table, values): (Option<Table>, Option<Vec<f64>>)| {
            let write_chunk = &write_chunk;
            (k, scope.spawn(move || write_chunk(k, r, table, values)))
        };
        // Returns whether chunk `c`'s files are all good (a chunk of an earlier run), and the
        // event that says a damaged one is computed again.
        let checked = |c: u64| -> (bool, Option<Event>) {
            let files = chunk_files(c);
            let (damaged, status) = first_not_good(
                &files.iter().map(PathBuf::as_path).collect::<Vec<_>>(),
                expected(&chunk(c)),
            );
            match status {
                parts::Status::Good => (true, None),
                parts::Status::Damaged(reason) => (
                    false,
                    Some(Event::Recomputing {
                        file: damaged.to_path_buf(),
                        reason,
                    }),
                ),
                parts::Status::Missing => (false, None),
            }
        };
        // A grid's chunks to Parquet or summaries are projected block after block, the device
        // never waiting for the host between them (`Backend::project_blocks`).
        let streamed = work.sweep().filter(|_| !(rows && opts.format == Format::Csv));
        let mut c = 0;
        while c < n_chunks {
            let r = &chunk(c);
            let (good, damaged) = checked(c);
            if good {
                outcome.resumed += r.end - r.start;
                if joiner.is_some() {
                    settle(&mut writing, &mut total, &mut joiner)?;
                    Joiner::send(&mut joiner, ToJoin::File(c))?;
                }
                if let (Some(spec), Some(t), Some(template)) = (spec, &mut total, &template) {
                    let path = chunk_summary(c);
                    let context = path.display().to_string();
                    let part: PartSummary = read_part(&path, expected(r))?;
                    let part = part.into_summary(template, &context)?;
                    spec.check(&part, r.start, r.end - r.start, &context)?;
                    spec.merge_into(t, &part, &context)?;
                }
            } else {
                if budget == 0 || damaged.is_some_and(|e| events(e).is_break()) {
                    settle(&mut writing, &mut total, &mut joiner)?;
                    return Ok(true);
                }
                budget -= 1;
                if let Some(sweep) = &streamed {
                    // This chunk and the ones after it still to compute, within the budget, at
                    // most RUN_BLOCKS at a time; a damaged one's event is sent when its turn
                    // comes (after the chunks before it are done, as one at a time would).
                    let mut blocks = vec![r.clone()];
                    let mut announce: Vec<Option<Event>> = vec![None];
                    while budget > 0 && blocks.len() < RUN_BLOCKS && c + (blocks.len() as u64) < n_chunks {
                        let d = c + blocks.len() as u64;
                        let (good, damaged) = checked(d);
                        if good {
                            break;
                        }
                        budget -= 1;
                        blocks.push(chunk(d));
                        announce.push(damaged);
                    }
                    let mut k = c;
                    let stopped = for_blocks(backend, sweep, &blocks, &mut metrics, &mut |r, metrics| {
                        let this = k;
                        k += 1;
                        let said = announce[usize::try_from(this - c).expect("a run's block")].take();
                        if said.is_some_and(|e| events(e).is_break()) {
                            return Ok(true);
                        }
                        let table = if rows {
                            Some(work.rows(r.clone(), metrics)?)
                        } else {
                            None
                        };
                        let values = by.map(|by| values(metrics, by));
                        settle(&mut writing, &mut total, &mut joiner)?;
                        writing = Some(spawn_writer(this, r.clone(), (table, values)));
                        outcome.computed += r.end - r.start;
                        done += r.end - r.start;
                        Ok(events(Event::Progress { done, total: poses }).is_break())
                    })?;
                    if stopped {
                        settle(&mut writing, &mut total, &mut joiner)?;
                        return Ok(true);
                    }
                    c += blocks.len() as u64;
                    continue;
                }
                // A list's chunk (its items), or a chunk of CSV rows.
                let outputs = match (rows, opts.format) {
                    (true, Format::Csv) => {
                        let path = chunk_path(c);
                        let csv = CsvChunk {
                            config,
                            header: &header,
                            sigma,
                        };
                        (None, csv.write(backend, r.clone(), &path, expected(r), by)?)
                    }
                    (_, format) => {
                        let table = work.block(backend, r.clone(), rows, &mut metrics, &|| false)?;
                        debug_assert!(table.is_none() || format == Format::Parquet);
                        (table, by.map(|by| values(&metrics, by)))
                    }
                };
                settle(&mut writing, &mut total, &mut joiner)?;
                writing = Some(spawn_writer(c, r.clone(), outputs));
                outcome.computed += r.end - r.start;
            }
            done += r.end - r.start;
            c += 1;
            if events(Event::Progress { done, total: poses }).is_break() {
                settle(&mut writing, &mut total, &mut joiner)?;
                return Ok(true);
            }
        }
        settle(&mut writing, &mut total, &mut joiner)?;
        // The settings first: a result never stands without them. The table next, the summary
        // last: a summary beside a table means the table is whole.
        write_json(&settings_path(&file), &manifest.settings)?;
        match (joiner, rows, opts.format) {
            (Some(joiner), _, _) => joiner.finish()?,
            (None, true, Format::Csv) => {
                parts::join((0..n_chunks).map(chunk_path), &desc.columns, &file, whole)?;
            }
            (None, true, Format::Parquet) => {
                parts::join_parquet((0..n_chunks).map(chunk_path), &desc.columns, &kinds, &file, whole)?;
            }
            (None, false, _) => {}
        }
        if let Some(mut total) = total.take() {
            fill_means(&mut total);
            write_summary(&summary_file, whole, &total)?;
            outcome.summary = Some(summary_file.clone());
        }
        Ok(false)
    })?;
    if stopped {
        return Ok(outcome);
    }
    std::fs::remove_dir_all(&state).map_err(|e| Error::write_output(&state, e))?;
    if opts.shard.is_none() {
        outcome.figure = if rows {
            figure(&file, opts.format, &desc)?
        } else {
            figure_of_marginal(dir, &desc, &summary_file)?
        };
    }
    outcome.file = rows.then_some(file);
    Ok(outcome)
}

/// What writing a chunk gives back: its table encoded (Parquet), its summary.
#[derive(Default)]
struct Written {
    table: Option<bytes::Bytes>,
    summary: Option<Summary>,
}

/// A message to the thread joining a run's Parquet chunks into its result.
enum ToJoin {
    /// Chunk `c`, just written from these bytes.
    Bytes(u64, bytes::Bytes),
    /// Chunk `c`, on disk from an earlier run.
    File(u64),
    /// Every chunk is in: the result is finished and renamed into place.
    Finish,
}

/// The thread joining a run's Parquet chunks (`join_chunks` in [`run`]), and its channel.
struct Joiner<'s> {
    tx: std::sync::mpsc::SyncSender<ToJoin>,
    handle: std::thread::ScopedJoinHandle<'s, Result<()>>,
}

impl Joiner<'_> {
    /// Sends `message` to the joiner, if there is one; when it has stopped on an error, returns
    /// that error.
    fn send(joiner: &mut Option<Joiner<'_>>, message: ToJoin) -> Result<()> {
        let Some(j) = joiner else {
            return Ok(());
        };
        if j.tx.send(message).is_ok() {
            return Ok(());
        }
        let j = joiner.take().expect("a joiner");
        drop(j.tx);
        match j
            .handle
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        {
            Err(e) => Err(e),
            Ok(()) => Err(Error::write_output(
                Path::new("sweep"),
                "the join of its chunks ended early",
            )),
        }
    }

    /// Tells the joiner every chunk is in and waits for the result to be written.
    fn finish(self) -> Result<()> {
        // A joiner that has stopped on an error has dropped its receiver: its error is returned.
        let _ = self.tx.send(ToJoin::Finish);
        drop(self.tx);
        self.handle
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    }
}

/// Returns the lock of the run state `state` (an open file, its lock released when it is
/// dropped), or `None` where the file system has no locks.
///
/// # Errors
/// [`Error::WriteOutput`] when another process holds it, or the lock file cannot be made.
fn lock_state(state: &Path) -> Result<Option<std::fs::File>> {
    #[cfg(unix)]
    {
        let path = state.join("lock");
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(|e| Error::write_output(&path, e))?;
        match rustix::fs::flock(&file, rustix::fs::FlockOperation::NonBlockingLockExclusive) {
            Ok(()) => Ok(Some(file)),
            Err(e) if e == rustix::io::Errno::WOULDBLOCK => Err(Error::WriteOutput {
                path: state.to_path_buf(),
                message: "another run of this sweep (or shard) is working in it; wait for it to finish, \
                          or run this one into another --out"
                    .into(),
            }),
            // A file system without locks (Lustre mounted without `flock`, some NFS setups):
            // the run goes on unlocked, as it did before locks.
            Err(_) => Ok(None),
        }
    }
    #[cfg(not(unix))]
    {
        let _ = state;
        Ok(None)
    }
}
