//! `sonarproj sweep` and `sonarproj merge`: grids or pose lists from a TOML file, run in
//! resumable chunks and shards, with a progress bar on a terminal.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use super::BackendArg;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use sonarproj_apps::Result;
use sonarproj_apps::sweep::{self, Event, Options, Shard, SweepConfig};

/// Options of `sonarproj sweep`.
#[derive(Debug, clap::Args)]
pub(super) struct SweepArgs {
    /// The sweep file (TOML): sonar pair, sampling, and a grid ([feature], [place] or
    /// [translation], [rotation]) or `poses = "FILE.csv"`. See docs/sweeps.md.
    #[arg(long, value_name = "FILE.toml")]
    config: PathBuf,
    /// Output directory: sweep.csv or sweep.parquet (or shard-K-of-N.csv/.parquet), summary.json
    /// when the sweep file has a [summary], sweep.json, and sweep-METRIC.png for a grid with one
    /// or two varying axes. Re-running the same command resumes an interrupted run.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Run part K of N independent parts (e.g. a Slurm array task); `sonarproj merge DIR` joins them.
    #[arg(long, value_name = "K/N")]
    shard: Option<String>,
    /// Poses per chunk: each finished chunk is kept on disk, so an interrupted run loses at most
    /// one. Default: 131072 (one Parquet row group), 1048576 for summaries only ([summary] rows =
    /// false). A resumed run keeps the size it started with.
    #[arg(long, value_name = "N")]
    chunk_poses: Option<u64>,
    /// Compute at most N chunks, then stop (for time-limited jobs; re-run to go on).
    #[arg(long, value_name = "N")]
    max_chunks: Option<u64>,
    /// The table's format: csv (text, a line a pose) or parquet (typed, compressed columns that
    /// pandas, polars, pyarrow and DuckDB read; the faster to write).
    #[arg(long, value_enum, default_value = "csv")]
    format: FormatArg,
    /// Where to compute.
    #[arg(long, value_enum, default_value = "auto")]
    backend: BackendArg,
}

/// The values of `--format`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub(super) enum FormatArg {
    /// DIR/sweep.csv: one line of text a pose.
    Csv,
    /// DIR/sweep.parquet: typed columns, null where the CSV leaves a cell empty.
    Parquet,
}

/// Options of `sonarproj merge`.
#[derive(Debug, clap::Args)]
pub(super) struct MergeArgs {
    /// The --out directory the shards of one sweep wrote to.
    #[arg(value_name = "DIR")]
    dir: PathBuf,
}

/// Runs `sonarproj sweep`.
pub(super) fn run(a: SweepArgs) -> Result<()> {
    let shard = a.shard.as_deref().map(Shard::parse).transpose()?;
    let config = SweepConfig::load(&a.config)?;
    let opts = Options {
        out: a.out,
        shard,
        chunk_poses: a.chunk_poses,
        max_chunks: a.max_chunks,
        format: match a.format {
            FormatArg::Csv => sweep::Format::Csv,
            FormatArg::Parquet => sweep::Format::Parquet,
        },
    };
    let (backend, notice) = super::gpu_env::select(a.backend.into())?;
    if let Some(n) = notice {
        eprintln!("{n}");
    }
    // Drawn only when stderr is a terminal (indicatif hides it otherwise).
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{wide_bar} {human_pos}/{human_len} poses  {rate}  {eta} left")
            .expect("valid template")
            .with_key(
                "rate",
                |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = write!(w, "{:.0} poses/s", s.per_sec());
                },
            ),
    );
    let start = Instant::now();
    let outcome = sweep::run(
        &config,
        &backend,
        &opts,
        sonarproj::stream::Stop::NEVER,
        &mut |event| match event {
            Event::Progress { done, total } => {
                bar.set_length(total);
                bar.set_position(done);
                ControlFlow::Continue(())
            }
            Event::Recomputing { file, reason } => {
                bar.suspend(|| {
                    eprintln!(
                        "sweep: {} is damaged ({reason}); computing it again",
                        file.display()
                    );
                });
                ControlFlow::Continue(())
            }
            _ => ControlFlow::Continue(()),
        },
    );
    bar.finish_and_clear();
    let outcome = outcome?;
    let secs = start.elapsed().as_secs_f64();
    let what = match shard {
        Some(s) => format!("shard {}/{} ({} poses)", s.k, s.n, outcome.poses),
        None => format!("{} poses", outcome.poses),
    };
    match listed(&[&outcome.file, &outcome.summary, &outcome.figure]) {
        Some(files) => {
            let rate = outcome.computed as f64 / secs.max(1e-9);
            if outcome.finished_before {
                // Finished by an earlier run: nothing was written now.
                outln!("sweep: {what}: already finished, nothing computed; {files} unchanged")?;
            } else {
                outln!(
                    "sweep: {what} on {}: {} computed in {secs:.2} s ({rate:.0} poses/s), {} from earlier runs; wrote {files}",
                    backend.device(),
                    outcome.computed,
                    outcome.resumed,
                )?;
            }
        }
        None => outln!(
            "sweep: {what}: stopped after --max-chunks with {} of {} poses done; re-run the same command to go on",
            outcome.computed + outcome.resumed,
            outcome.poses
        )?,
    }
    Ok(())
}

/// Runs `sonarproj merge`.
pub(super) fn merge(a: MergeArgs) -> Result<()> {
    let merged = sweep::merge(&a.dir)?;
    let files = listed(&[&merged.file, &merged.summary, &merged.figure]).unwrap_or_default();
    outln!("merge: wrote {files}")?;
    Ok(())
}

/// Returns the paths of `files` that are there as a list in words ("a, b and c"), or `None`
/// when none is.
fn listed(files: &[&Option<PathBuf>]) -> Option<String> {
    let names: Vec<String> = files
        .iter()
        .filter_map(|f| f.as_ref())
        .map(|f| f.display().to_string())
        .collect();
    let (last, rest) = names.split_last()?;
    Some(if rest.is_empty() {
        last.clone()
    } else {
        format!("{} and {last}", rest.join(", "))
    })
}
