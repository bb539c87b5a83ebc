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

use sonarproj::Output;
use std::ops::{ControlFlow, Range};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use rayon::prelude::*;
use sonarproj::limits::MAX_CHUNKS;
use sonarproj::projection::Backend;

use crate::error::{Error, Result};
use crate::io::batch::{PoseRow, local_of};
use crate::io::parquet::{Column, Encoding, Kind, Table, TableWriter, read_groups};
use crate::io::table::write_rows;
use crate::io::{METRIC_COLUMNS, metric_fields};
use crate::report::{check_output_file, figures, output_dir, remove_stale_temporaries};
use crate::sweep::SweepConfig;
use crate::sweep::parts::{self, write_json};
use crate::sweep::summary::{PartSummary, Summary, SummarySpec};
use sonarproj::local_precision::resolve_sigma_range;
use sonarproj::metrics::Metric;
use sonarproj::projection::{Batch, Projection};

/// The default number of poses per chunk.
pub const DEFAULT_CHUNK_POSES: u64 = 20_000;

/// Part `k` (1-based) of `n` independent parts of a sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Which part, 1 to `n`.
    pub k: u64,
    /// How many parts.
    pub n: u64,
}

pub use sonarproj::limits::MAX_SHARDS;

impl Shard {
    /// Returns the shard written `K/N`.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming `--shard` unless `1 <= K <= N`.
    pub fn parse(text: &str) -> Result<Shard> {
        let bad = || {
            Error::invalid(
                "--shard",
                format!("{text:?}"),
                "must be K/N with 1 <= K <= N, e.g. 3/8",
            )
        };
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (k, n): (u64, u64) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if k == 0 || k > n {
            return Err(bad());
        }
        if n > MAX_SHARDS {
            return Err(Error::invalid(
                "--shard",
                format!("{text:?}"),
                format!("N must be at most {MAX_SHARDS} (merge lists the parts it finds)"),
            ));
        }
        Ok(Shard { k, n })
    }

    /// Returns the pose indices of this shard out of `total`: contiguous, sizes differing by at
    /// most one.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "pose counts and chunk sizes are bounded (MAX_POSES) before this point"
    )]
    #[must_use]
    pub fn range(self, total: u64) -> Range<u64> {
        let at = |k: u64| (u128::from(total) * u128::from(k) / u128::from(self.n)) as u64;
        at(self.k - 1)..at(self.k)
    }

    /// Returns the shard's file stem, `shard-K-of-N`.
    #[must_use]
    pub fn stem(self) -> String {
        format!("shard-{}-of-{}", self.k, self.n)
    }
}

/// What a sweep is: written to `DIR/sweep.json` by every run and shard.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Descriptor {
    /// [`SweepConfig::fingerprint`].
    pub fingerprint: String,
    /// The number of poses of the whole sweep.
    pub poses: u64,
    /// The CSV header.
    pub columns: Vec<String>,
    /// The grid columns that vary (a figure is drawn for one or two).
    pub varying: Vec<String>,
    /// The metric the figure draws and its axis label.
    pub metric: String,
    /// The metric's axis label.
    pub metric_label: String,
    /// The figure title.
    pub title: String,
    /// The summaries asked for (absent when none: the descriptors of sweeps without one are
    /// unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub summary: Option<SummarySpec>,
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

/// What decides a run's numbers besides the sweep file (whose fingerprint the parts carry): the
/// engine's version and the backend's settings ([`Backend::settings`]), by name. Written beside
/// each shard (`shard-K-of-N.run.json`), so that `merge` joins only shards computed alike.
pub type Settings = std::collections::BTreeMap<String, String>;

/// Returns the settings of a run on `backend`.
#[must_use]
pub fn settings(backend: &Backend) -> Settings {
    let mut out: Settings = backend
        .settings()
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    out.insert("engine version".into(), sonarproj::VERSION.into());
    out
}

/// Returns the first setting (in name order) whose values differ between `a` and `b`, with both
/// values (`(none)` where one lacks it).
fn first_difference(a: &Settings, b: &Settings) -> Option<(String, String, String)> {
    let none = || "(none)".to_string();
    a.keys()
        .chain(b.keys())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .find(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            (
                k.clone(),
                a.get(k).cloned().unwrap_or_else(none),
                b.get(k).cloned().unwrap_or_else(none),
            )
        })
}

/// Returns the path of the settings record of part `file` (`NAME.csv` → `NAME.run.json`,
/// `NAME.parquet` → `NAME.parquet.run.json`).
fn settings_path(file: &Path) -> PathBuf {
    parts::beside(file, "run.json")
}

/// The format of a sweep's tables.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// CSV: one line of text a pose, numbers in their shortest exact form, empty cells where
    /// nothing is visible.
    #[default]
    Csv,
    /// Parquet: typed columns (integers for the index and counts, doubles for the rest, null
    /// where the CSV leaves a cell empty), Snappy-compressed, row groups at the multiples of
    /// [`GROUP_ROWS`](crate::io::parquet::GROUP_ROWS) in the pose index.
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

/// Returns the kinds of a sweep table's `columns` (its descriptor's): the index an integer, the
/// pose columns numbers, then the metric columns as the metric table types them (counts
/// integers; extremes, the projection area and the local precision nullable).
#[must_use]
pub fn column_kinds(columns: &[String]) -> Vec<Kind> {
    let metrics = sonarproj::Metrics::default();
    let metric_kinds = sonarproj::metrics::METRICS
        .iter()
        .map(|info| match metrics.get(info.metric) {
            sonarproj::metrics::Value::Count(_) => Kind::Int,
            sonarproj::metrics::Value::Real(_) => Kind::Real,
            sonarproj::metrics::Value::Optional(_) => Kind::Optional,
        })
        .chain([Kind::Optional, Kind::Optional]);
    let poses = columns.len().saturating_sub(1 + METRIC_COLUMNS.len());
    std::iter::once(Kind::Int)
        .chain(std::iter::repeat_n(Kind::Real, poses))
        .chain(metric_kinds)
        .collect()
}

/// How to run a sweep.
#[derive(Clone, Debug)]
pub struct Options {
    /// The output directory.
    pub out: PathBuf,
    /// One part of the sweep, or all of it.
    pub shard: Option<Shard>,
    /// Poses per chunk (the unit of resumption).
    pub chunk_poses: u64,
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

/// Returns the JSON in `path`, or `None` when the file does not exist.
fn read_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<Option<T>> {
    match std::fs::read(path) {
        Ok(bytes) => serde_json::from_slice(&bytes).map(Some).map_err(|e| Error::Csv {
            context: path.display().to_string(),
            message: format!("not a sonarproj sweep file ({e}); remove it or choose another --out"),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(Error::ReadInput {
            path: path.to_path_buf(),
            source,
        }),
    }
}

/// Returns the descriptor of `config`.
pub fn descriptor(config: &SweepConfig) -> Result<Descriptor> {
    let mut columns = config.columns();
    columns.extend(METRIC_COLUMNS.iter().map(|c| c.to_string()));
    Ok(Descriptor {
        fingerprint: config.fingerprint(),
        poses: config.count()?,
        columns,
        varying: config.varying(),
        metric: config.metric.name().to_string(),
        metric_label: config.metric_label().to_string(),
        title: format!("{} to {}", config.source.name, config.target.name),
        summary: config.summary.clone(),
    })
}

/// Writes `DIR/sweep.json`, or checks that the one there describes the same sweep.
fn claim(dir: &Path, d: &Descriptor) -> Result<()> {
    let path = dir.join("sweep.json");
    match read_json::<Descriptor>(&path)? {
        Some(old) if old == *d => Ok(()),
        Some(_) => Err(Error::invalid(
            "--out",
            dir.display(),
            "holds results of a different sweep (its sweep.json differs); choose another directory or empty this one",
        )),
        None => write_json(&path, d),
    }
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
    if opts.chunk_poses == 0 {
        return Err(Error::invalid("--chunk-poses", 0, "must be >= 1"));
    }
    // Everything is checked before the directory is created: a refused run leaves nothing.
    let dir = &opts.out;
    let desc = descriptor(config)?;
    let (stem, range) = match opts.shard {
        Some(s) => (s.stem(), s.range(desc.poses)),
        None => ("sweep".to_string(), 0..desc.poses),
    };
    let poses = range.end - range.start;
    // One file a chunk: their number is bounded, and nothing is kept per chunk but its file.
    let n_chunks = poses.div_ceil(opts.chunk_poses);
    if n_chunks > MAX_CHUNKS {
        return Err(Error::invalid(
            "--chunk-poses",
            opts.chunk_poses,
            format!(
                "cuts this run's {poses} poses into {n_chunks} chunk files, more than the \
                 {MAX_CHUNKS} one run keeps: use --chunk-poses {} or more (or shards)",
                poses.div_ceil(MAX_CHUNKS)
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
        chunk_poses: opts.chunk_poses,
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
        let s = range.start + c * opts.chunk_poses;
        s..(s + opts.chunk_poses).min(range.end)
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
    let mut done = 0;
    let mut budget = opts.max_chunks.unwrap_or(u64::MAX);
    for c in 0..n_chunks {
        let r = &chunk(c);
        let path = chunk_path(c);
        let files = chunk_files(c);
        let (damaged, status) = first_not_good(
            &files.iter().map(PathBuf::as_path).collect::<Vec<_>>(),
            expected(r),
        );
        if status == parts::Status::Good {
            outcome.resumed += r.end - r.start;
        } else {
            if budget == 0 {
                return Ok(outcome);
            }
            budget -= 1;
            if let parts::Status::Damaged(reason) = status
                && events(Event::Recomputing {
                    file: damaged.to_path_buf(),
                    reason,
                })
                .is_break()
            {
                return Ok(outcome);
            }
            let results = match (rows, opts.format) {
                (true, Format::Csv) => {
                    let (poses, fields) = config.items(r.clone())?;
                    let batch = chunk_batch(config, &poses);
                    let results = backend.project(&batch, Output::MetricsOnly)?;
                    let body = csv_rows(&batch, &poses, &fields, &results, sigma, &path)?;
                    parts::write(&path, expected(r), |w| {
                        write_rows(
                            &mut *w,
                            &header,
                            &METRIC_COLUMNS,
                            std::iter::empty::<(&[String], Vec<String>)>(),
                        )?;
                        w.write_all(&body).map_err(|e| Error::write_output(&path, e))
                    })?;
                    results
                }
                (_, format) => {
                    let (poses, values) = config.items_numeric(r.clone())?;
                    let batch = chunk_batch(config, &poses);
                    let results = backend.project(&batch, Output::MetricsOnly)?;
                    if rows {
                        debug_assert_eq!(format, Format::Parquet);
                        let table = columns_of(
                            &desc.columns,
                            &kinds,
                            r.start,
                            &batch,
                            &poses,
                            &values,
                            &results,
                            sigma,
                        );
                        parts::write(&path, expected(r), |w| {
                            let mut t = TableWriter::new(
                                w,
                                &desc.columns,
                                &kinds,
                                r.start,
                                Encoding::Scratch,
                                &path,
                            )?;
                            t.push(table)?;
                            t.finish()
                        })?;
                    }
                    results
                }
            };
            if let (Some(spec), Some(by)) = (spec, by) {
                let values: Vec<Option<f64>> = results.iter().map(|p| p.metrics.get(by).as_f64()).collect();
                let part = spec.summarise(grid, r.start, &values)?.to_part();
                let sum_path = chunk_summary(c);
                parts::write(&sum_path, expected(r), |w| {
                    serde_json::to_writer(&mut *w, &part).map_err(|e| Error::write_output(&sum_path, e))
                })?;
            }
            outcome.computed += r.end - r.start;
        }
        done += r.end - r.start;
        if events(Event::Progress { done, total: poses }).is_break() {
            return Ok(outcome);
        }
    }
    // The settings first: a result never stands without them.
    write_json(&settings_path(&file), &manifest.settings)?;
    if let Some(spec) = spec {
        let template = spec.empty(grid);
        let mut total = template.clone();
        for c in 0..n_chunks {
            let path = chunk_summary(c);
            let context = path.display().to_string();
            let r = chunk(c);
            let part: PartSummary = read_part(&path, expected(&r))?;
            let part = part.into_summary(&template, &context)?;
            spec.check(&part, r.start, r.end - r.start, &context)?;
            total = spec.combine(&total, &part, &context)?;
        }
        write_summary(&summary_file, whole, &total)?;
        outcome.summary = Some(summary_file.clone());
    }
    if rows {
        match opts.format {
            Format::Csv => parts::join((0..n_chunks).map(chunk_path), &desc.columns, &file, whole)?,
            Format::Parquet => {
                parts::join_parquet((0..n_chunks).map(chunk_path), &desc.columns, &kinds, &file, whole)?;
            }
        }
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
/// `summary.json`. `events` hears of progress after each chunk of `chunk_poses` poses and may
/// stop the run (the result is then `None`).
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `--chunk-poses` when 0, and `--out` when the table
/// would exceed [`MAX_IN_MEMORY_BYTES`]; errors of [`Backend::project`].
pub fn run_in_memory(
    config: &SweepConfig,
    backend: &Backend,
    shard: Option<Shard>,
    chunk_poses: u64,
    events: &mut dyn FnMut(Event) -> ControlFlow<()>,
) -> Result<Option<InMemory>> {
    if chunk_poses == 0 {
        return Err(Error::invalid("--chunk-poses", 0, "must be >= 1"));
    }
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
    let mut start = range.start;
    while start < range.end {
        let r = start..(start + chunk_poses).min(range.end);
        let (pose_rows, values) = config.items_numeric(r.clone())?;
        let batch = chunk_batch(config, &pose_rows);
        let results = backend.project(&batch, Output::MetricsOnly)?;
        if let Some(table) = &mut table {
            let part = columns_of(
                &desc.columns,
                &kinds,
                r.start,
                &batch,
                &pose_rows,
                &values,
                &results,
                sigma,
            );
            table.append(part)?;
        }
        if let (Some(spec), Some(by), Some(total)) = (spec, by, &mut summary) {
            let values: Vec<Option<f64>> = results.iter().map(|p| p.metrics.get(by).as_f64()).collect();
            let part = spec.summarise(grid, r.start, &values)?;
            *total = spec.combine(total, &part, "in memory")?;
        }
        start = r.end;
        if events(Event::Progress {
            done: start - range.start,
            total: poses,
        })
        .is_break()
        {
            return Ok(None);
        }
    }
    Ok(Some(InMemory {
        table,
        summary,
        poses,
    }))
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

/// Writes the summaries `total` to `path` as pretty JSON, with its record for `expected`.
fn write_summary(path: &Path, expected: parts::Expected<'_>, total: &Summary) -> Result<()> {
    parts::write(path, expected, |w| {
        serde_json::to_writer_pretty(&mut *w, total).map_err(|e| Error::write_output(path, e))?;
        w.write_all(b"\n").map_err(|e| Error::write_output(path, e))
    })
}

/// Returns the first of `files` that is not good for `expected`, with its status; the last
/// file and [`parts::Status::Good`] when all are.
fn first_not_good<'f>(files: &[&'f Path], expected: parts::Expected<'_>) -> (&'f Path, parts::Status) {
    for f in files {
        let status = parts::check(f, expected);
        if status != parts::Status::Good {
            return (f, status);
        }
    }
    (files[files.len() - 1], parts::Status::Good)
}

/// Returns the JSON part `path`, after checking its bytes against its record for `expected`
/// (read once: what is checked is what is parsed).
fn read_part<T: for<'de> Deserialize<'de>>(path: &Path, expected: parts::Expected<'_>) -> Result<T> {
    let bytes = std::fs::read(path).map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })?;
    let damaged = |message: String| Error::Csv {
        context: path.display().to_string(),
        message,
    };
    parts::check_bytes(path, &bytes, expected).map_err(damaged)?;
    serde_json::from_slice(&bytes).map_err(|e| damaged(format!("not a sweep summary ({e})")))
}

/// Draws `DIR/sweep-METRIC.png` from the summaries in `summary` when the sweep writes no rows
/// and a marginal is over exactly the grid's varying axes (each of its cells is one pose: the
/// figure is the one the table would give); returns its path.
fn figure_of_marginal(dir: &Path, d: &Descriptor, summary: &Path) -> Result<Option<PathBuf>> {
    if d.varying.is_empty() || d.varying.len() > 2 {
        return Ok(None);
    }
    let bytes = std::fs::read(summary).map_err(|source| Error::ReadInput {
        path: summary.to_path_buf(),
        source,
    })?;
    let s: Summary = serde_json::from_slice(&bytes).map_err(|e| Error::Csv {
        context: summary.display().to_string(),
        message: e.to_string(),
    })?;
    if s.metric != d.metric {
        return Ok(None);
    }
    let Some(m) = s.marginals.iter().find(|m| m.axes == d.varying) else {
        return Ok(None);
    };
    let points: Vec<(Vec<f64>, Option<f64>)> = match m.values.as_slice() {
        [x] => x.iter().zip(&m.mean).map(|(&x, &v)| (vec![x], v)).collect(),
        [x, y] => x
            .iter()
            .flat_map(|&a| y.iter().map(move |&b| vec![a, b]))
            .zip(&m.mean)
            .map(|(c, &v)| (c, v))
            .collect(),
        _ => return Ok(None),
    };
    draw(dir, d, &points).map(Some)
}

/// Returns the batch of a chunk's `poses`.
fn chunk_batch(config: &SweepConfig, poses: &[PoseRow]) -> Batch {
    Batch {
        source: config.source.clone(),
        target: config.target.clone(),
        sampling: config.sampling,
        area_grid: config.area_grid,
        items: poses.iter().map(|p| p.item).collect(),
    }
}

/// Returns a chunk's table: the index from `first`, the pose columns `values` (row after row),
/// the metrics of `results` and the local precision of `poses` (range error `sigma`), in the
/// sweep's `columns` of `kinds`.
#[expect(clippy::too_many_arguments, reason = "the parts of one chunk, named")]
#[expect(
    clippy::cast_possible_wrap,
    reason = "pose indices are below 2^40 (MAX_POSES)"
)]
fn columns_of(
    columns: &[String],
    kinds: &[Kind],
    first: u64,
    batch: &Batch,
    poses: &[PoseRow],
    values: &[f64],
    results: &[Projection],
    sigma: f64,
) -> Table {
    let mut table = Table::new(columns, kinds);
    let n = poses.len();
    let pose_columns = columns.len() - 1 - METRIC_COLUMNS.len();
    let locals: Vec<_> = poses
        .par_iter()
        .map(|pose| local_of(batch, &pose.item, pose.true_point, sigma))
        .collect();
    for (j, column) in table.columns.iter_mut().enumerate() {
        *column = if j == 0 {
            Column::Int((0..n as u64).map(|i| (first + i) as i64).collect())
        } else if j <= pose_columns {
            Column::Real((0..n).map(|i| values[i * pose_columns + j - 1]).collect())
        } else if let Some(info) = sonarproj::metrics::METRICS.get(j - 1 - pose_columns) {
            match kinds[j] {
                Kind::Int => Column::Int(
                    results
                        .iter()
                        .map(|p| match p.metrics.get(info.metric) {
                            sonarproj::metrics::Value::Count(c) => i64::try_from(c).unwrap_or(i64::MAX),
                            _ => unreachable!("the metric table's counts"),
                        })
                        .collect(),
                ),
                Kind::Real => Column::Real(
                    results
                        .iter()
                        .map(|p| p.metrics.get(info.metric).as_f64().unwrap_or(f64::NAN))
                        .collect(),
                ),
                Kind::Optional => Column::Optional(
                    results
                        .iter()
                        .map(|p| p.metrics.get(info.metric).as_f64())
                        .collect(),
                ),
            }
        } else if j == columns.len() - 2 {
            Column::Optional(locals.iter().map(|l| l.range_per_elevation).collect())
        } else {
            Column::Optional(locals.iter().map(|l| l.sigma_elevation).collect())
        };
    }
    table
}

/// Returns the CSV rows (no header) of `fields` followed by the metrics of `results` and the
/// local precision of `poses` of `batch` (range error `sigma`), formatted in parallel blocks (the
/// same bytes as one writer would produce: each record is formatted on its own).
fn csv_rows(
    batch: &Batch,
    poses: &[PoseRow],
    fields: &[Vec<String>],
    results: &[Projection],
    sigma: f64,
    path: &Path,
) -> Result<Vec<u8>> {
    let blocks: Vec<Vec<u8>> = fields
        .par_chunks(4096)
        .zip(results.par_chunks(4096))
        .zip(poses.par_chunks(4096))
        .map(|((f, r), poses)| {
            let mut w = csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(Vec::new());
            for ((fields, p), pose) in f.iter().zip(r).zip(poses) {
                let local = local_of(batch, &pose.item, pose.true_point, sigma);
                let metrics = metric_fields(&p.metrics, &local);
                w.write_record(fields.iter().chain(metrics.iter()))
                    .map_err(|e| Error::write_output(path, e))?;
            }
            w.into_inner().map_err(|e| Error::write_output(path, e))
        })
        .collect::<Result<_>>()?;
    Ok(blocks.concat())
}

/// Joins the shard files `shard-K-of-N.csv` in `dir` into `dir/sweep.csv` (byte for byte the
/// file one run would have written) and draws the figure; returns both paths.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `DIR` when there is no sweep there, parts of different
/// counts, or a missing part; [`Error::Csv`] for a part with the wrong header or row count.
pub fn merge(dir: &Path) -> Result<Merged> {
    let desc: Descriptor = read_json(&dir.join("sweep.json"))?.ok_or_else(|| {
        Error::invalid(
            "DIR",
            dir.display(),
            "has no sweep.json: not the --out directory of a sharded sweep",
        )
    })?;
    // A shard's result: its table, or its summaries when the sweep writes no rows.
    let rows = desc.summary.as_ref().is_none_or(|s| s.rows);
    let suffixes: &[(&str, Format)] = if rows {
        &[(".csv", Format::Csv), (".parquet", Format::Parquet)]
    } else {
        &[(".summary.json", Format::Csv)]
    };
    let mut shards: Vec<(Shard, Format)> = Vec::new();
    let entries = std::fs::read_dir(dir).map_err(|source| Error::ReadInput {
        path: dir.to_path_buf(),
        source,
    })?;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        for &(suffix, format) in suffixes {
            if let Some(s) = name
                .strip_prefix("shard-")
                .and_then(|s| s.strip_suffix(suffix))
                .and_then(|s| Shard::parse(&s.replace("-of-", "/")).ok())
            {
                shards.push((s, format));
            }
        }
    }
    let format = match shards
        .iter()
        .map(|s| s.1)
        .collect::<std::collections::BTreeSet<_>>()
    {
        f if f.len() == 2 => {
            return Err(Error::invalid(
                "DIR",
                dir.display(),
                "holds shards as CSV and as Parquet; keep one set (remove the other's shard files)",
            ));
        }
        f => f.first().copied().unwrap_or_default(),
    };
    let ext = format.extension();
    let main = |stem: &str| {
        if rows {
            dir.join(format!("{stem}.{ext}"))
        } else {
            dir.join(format!("{stem}.summary.json"))
        }
    };
    let shards: Vec<Shard> = shards.into_iter().map(|s| s.0).collect();
    let n = match shards
        .iter()
        .map(|s| s.n)
        .collect::<std::collections::BTreeSet<_>>()
    {
        ns if ns.len() == 1 => *ns.first().expect("one"),
        ns if ns.is_empty() => {
            return Err(Error::invalid(
                "DIR",
                dir.display(),
                if rows {
                    "holds no finished shard-K-of-N.csv or shard-K-of-N.parquet"
                } else {
                    "holds no finished shard-K-of-N.summary.json"
                },
            ));
        }
        ns => {
            return Err(Error::invalid(
                "DIR",
                dir.display(),
                format!("holds shards of different counts N ({ns:?}); keep one set"),
            ));
        }
    };
    let missing: Vec<u64> = (1..=n).filter(|k| !shards.iter().any(|s| s.k == *k)).collect();
    if !missing.is_empty() {
        return Err(Error::invalid(
            "DIR",
            dir.display(),
            format!("lacks shards {missing:?} of {n} (run them with --shard K/{n}, or finish them)"),
        ));
    }
    // Every shard must be this sweep's part K, whole: checked against its record before
    // anything is written, and again while it is copied.
    let mut files = Vec::new();
    let mut summaries = Vec::new();
    for k in 1..=n {
        let shard = Shard { k, n };
        let file = main(&shard.stem());
        let summary = dir.join(format!("{}.summary.json", shard.stem()));
        let r = shard.range(desc.poses);
        let expected = parts::Expected {
            fingerprint: &desc.fingerprint,
            first: r.start,
            rows: r.end - r.start,
        };
        let mut checked: Vec<&Path> = vec![&file];
        if rows && desc.summary.is_some() {
            checked.push(&summary);
        }
        let (file, status) = first_not_good(&checked, expected);
        let file = file.to_path_buf();
        match status {
            parts::Status::Good => {
                files.push(main(&shard.stem()));
                summaries.push((summary, r));
            }
            parts::Status::Missing => {
                return Err(Error::invalid(
                    "DIR",
                    dir.display(),
                    format!(
                        "lacks {} (shard {k} of {n}): run `sweep --shard {k}/{n}` again",
                        file.file_name()
                            .map_or_else(String::new, |f| f.to_string_lossy().into_owned())
                    ),
                ));
            }
            parts::Status::Damaged(reason) => {
                return Err(Error::Csv {
                    context: file.display().to_string(),
                    message: format!(
                        "{reason}; nothing merged (run `sweep --shard {k}/{n}` again to recompute this shard)"
                    ),
                });
            }
        }
    }
    // Every shard computed alike: the same engine and backend settings as shard 1, else nothing
    // is written.
    let mut first: Option<Settings> = None;
    for (k, file) in files.iter().enumerate() {
        let path = settings_path(file);
        let record: Settings = read_json(&path)?.ok_or_else(|| Error::Csv {
            context: file.display().to_string(),
            message: format!(
                "has no record of how it was computed ({} is missing); nothing merged (remove it and run `sweep --shard {}/{n}` again)",
                path.display(),
                k + 1
            ),
        })?;
        match &first {
            None => first = Some(record),
            Some(one) => {
                if let Some((name, a, b)) = first_difference(one, &record) {
                    return Err(Error::invalid(
                        name.clone(),
                        format!("{b:?} in shard {} of {n}", k + 1),
                        format!(
                            "differs from {a:?} in shard 1: shards computed with different {name} would merge into a table no single run writes; nothing merged (recompute one set alike)"
                        ),
                    ));
                }
            }
        }
    }
    let whole = parts::Expected {
        fingerprint: &desc.fingerprint,
        first: 0,
        rows: desc.poses,
    };
    let summary_file = dir.join("summary.json");
    // Both results can be written before either is.
    if desc.summary.is_some() {
        check_output_file(&summary_file, "DIR")?;
    }
    if rows {
        check_output_file(&dir.join(format!("sweep.{ext}")), "DIR")?;
    }
    if let Some(spec) = &desc.summary {
        // The shards' summaries combined, each read once and checked against its record.
        let mut total: Option<Summary> = None;
        for (path, r) in &summaries {
            let expected = parts::Expected {
                fingerprint: &desc.fingerprint,
                first: r.start,
                rows: r.end - r.start,
            };
            let part: Summary = read_part(path, expected)?;
            let context = path.display().to_string();
            spec.check(&part, r.start, r.end - r.start, &context)?;
            total = Some(match total {
                None if part.metric == spec.by => part,
                None => {
                    return Err(Error::Csv {
                        context,
                        message: format!("summarises {:?}, not this sweep's {:?}", part.metric, spec.by),
                    });
                }
                Some(t) => spec.combine(&t, &part, &context)?,
            });
        }
        let total = total.expect("at least one shard");
        write_summary(&summary_file, whole, &total)?;
    }
    let summary = desc.summary.as_ref().map(|_| summary_file.clone());
    if !rows {
        let figure = figure_of_marginal(dir, &desc, &summary_file)?;
        return Ok(Merged {
            file: None,
            summary,
            figure,
        });
    }
    let out = dir.join(format!("sweep.{ext}"));
    match format {
        Format::Csv => parts::join(files, &desc.columns, &out, whole)?,
        Format::Parquet => {
            parts::join_parquet(files, &desc.columns, &column_kinds(&desc.columns), &out, whole)?;
        }
    }
    let figure = figure(&out, format, &desc)?;
    Ok(Merged {
        file: Some(out),
        summary,
        figure,
    })
}

/// What [`merge`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Merged {
    /// The table (`sweep.csv` or `sweep.parquet`), unless the sweep writes no rows.
    pub file: Option<PathBuf>,
    /// `summary.json`, when the sweep has a `[summary]`.
    pub summary: Option<PathBuf>,
    /// The figure, when the sweep draws one.
    pub figure: Option<PathBuf>,
}

/// Draws `DIR/sweep-METRIC.png` from the result `table` (`DIR/sweep.csv` or `sweep.parquet`)
/// when the grid has one or two varying axes; returns its path.
fn figure(table: &Path, format: Format, d: &Descriptor) -> Result<Option<PathBuf>> {
    if d.varying.is_empty() || d.varying.len() > 2 {
        return Ok(None);
    }
    let dir = table.parent().unwrap_or(Path::new("."));
    let col = |name: &str| {
        d.columns
            .iter()
            .position(|c| c == name)
            .expect("descriptor column")
    };
    let xs: Vec<usize> = d.varying.iter().map(|v| col(v)).collect();
    let m = col(&d.metric);
    let mut points = Vec::new();
    match format {
        Format::Csv => {
            let mut rdr = csv::Reader::from_path(table).map_err(|e| Error::Csv {
                context: table.display().to_string(),
                message: e.to_string(),
            })?;
            for rec in rdr.records() {
                let rec = rec.map_err(|e| Error::Csv {
                    context: table.display().to_string(),
                    message: e.to_string(),
                })?;
                let num = |i: usize| rec.get(i).and_then(|s| s.parse::<f64>().ok());
                let coords: Vec<f64> = xs.iter().map(|&i| num(i).unwrap_or(f64::NAN)).collect();
                points.push((coords, num(m)));
            }
        }
        Format::Parquet => {
            for group in read_groups(table, &d.columns, &column_kinds(&d.columns))? {
                let group = group?;
                for i in 0..group.rows() {
                    let coords: Vec<f64> = xs
                        .iter()
                        .map(|&j| group.columns[j].get(i).unwrap_or(f64::NAN))
                        .collect();
                    points.push((coords, group.columns[m].get(i)));
                }
            }
        }
    }
    if points.is_empty() {
        // A table that reads back empty (written through a link to a device): nothing to draw.
        return Ok(None);
    }
    draw(dir, d, &points).map(Some)
}

/// Draws `DIR/sweep-METRIC.png` of `points` (the varying axes' values, the metric); returns its
/// path.
fn draw(dir: &Path, d: &Descriptor, points: &[(Vec<f64>, Option<f64>)]) -> Result<PathBuf> {
    let path = dir.join(format!("sweep-{}.png", d.metric));
    let caption = match d.varying.as_slice() {
        [x] => format!("{}: {} against {x}", d.title, d.metric_label),
        _ => format!("{}: {}", d.title, d.metric_label),
    };
    let axes: Vec<String> = d.varying.iter().map(|c| column_label(c)).collect();
    figures::sweep(&path, &caption, &axes, &d.metric_label, points)?;
    Ok(path)
}

/// Returns the axis label of sweep column `c`, with its unit.
fn column_label(c: &str) -> String {
    let unit = match c {
        "range" | "place_range" | "tx" | "ty" | "tz" => "m",
        _ => "deg",
    };
    format!("{c} ({unit})")
}
