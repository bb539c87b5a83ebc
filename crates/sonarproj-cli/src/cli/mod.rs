//! Argument parsing (clap) and dispatch to the sub-commands.

/// Writes a line to stdout as `println!` does, but returns [`Error::WriteOutput`] (exit status
/// 1) instead of panicking when stdout is a closed pipe or a full disk.
macro_rules! outln {
    () => {
        $crate::cli::write_stdout(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

mod advise;
mod batch;
mod bench;
mod devices;
mod gpu_env;
mod mask;
mod mask_json;
mod mask_stream;
mod names;
mod paper;
mod peer;
mod pose_args;
mod project;
mod recover;
mod sonar;
mod sweep;
mod view;

use clap::{Parser, Subcommand};

pub(crate) use names::name;

use std::io::{Read, Write};
use std::path::PathBuf;

use sonarproj::{Backend, BackendChoice, Batch, Sampling, Sonar};
use sonarproj_apps::Error;
use sonarproj_apps::Result;
use sonarproj_apps::report::write_atomic;

/// Epipolar geometry of sonar: where a feature seen by one sonar can appear in another.
#[derive(Debug, Parser)]
#[command(name = "sonarproj", version, about, long_about = None)]
pub(crate) struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Project one feature from sonar 1 into sonar 2; print the metrics as JSON.
    Project(project::ProjectArgs),
    /// Project every row of a CSV of poses; write a CSV of metrics.
    Batch(batch::BatchArgs),
    /// Run the paper's simulations (docs/paper.md): CSV, figures and the findings, checked.
    Paper(paper::PaperArgs),
    /// Run a sweep file (grids of rotations, distances and placements, or pose lists) in
    /// resumable chunks, optionally as one shard of N; write the table (CSV or Parquet), the
    /// summaries a [summary] asks for, and a figure.
    Sweep(sweep::SweepArgs),
    /// Join the shards of a sweep (`sweep --shard K/N`) into the file one run would have written.
    Merge(sweep::MergeArgs),
    /// Rig advisor: score candidate rotations of sonar 2 over the features a rig will see
    /// (correspondence or recovery), refine the best, and find the best small move from a pose.
    Advise(advise::AdviseArgs),
    /// Draw correspondence masks: where each feature of sonar 1 can be in sonar 2 (PNG, NPY,
    /// JSON; or --stream JSON lines for a live pipeline).
    Mask(mask::MaskArgs),
    /// Recover the coordinate each sonar loses from a feature matched in both; print JSON
    /// (or, with --input, read a CSV of correspondences and write a CSV of candidates).
    Recover(recover::RecoverArgs),
    /// Time the same batches on the GPU, the fast CPU path and the CPU reference.
    Bench(bench::BenchArgs),
    /// List the GPU adapters wgpu sees and which one `--backend auto` would use.
    Devices,
    /// Sonars from what their owners have: `sonar from-oculus PING --out DIR` reads a saved
    /// Oculus ping into a sonar file and its image.
    #[command(subcommand)]
    Sonar(sonar::SonarCommand),
    /// Open the interactive viewer: a local web page (served from this binary on 127.0.0.1)
    /// with sliders for the feature and the pose, the 3-D geometry, sonar 2's data, the metrics
    /// and the scene as a command line, a sweep file or Python.
    View(view::ViewArgs),
}

/// Which backend a user asked for: `--backend auto|cpu|cpu-fast|gpu`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum BackendArg {
    /// A hardware GPU when one exists, else the fast CPU path (with a one-line notice; a
    /// software adapter such as lavapipe is slower than the CPU path on the same cores).
    Auto,
    /// The CPU reference (f64, one core, written to be obviously right).
    Cpu,
    /// The fast CPU path: the GPU's algorithm in f64 on every core.
    CpuFast,
    /// The GPU (WGSL through wgpu); fails when no adapter exists.
    Gpu,
}

impl From<BackendArg> for BackendChoice {
    fn from(a: BackendArg) -> BackendChoice {
        match a {
            BackendArg::Auto => BackendChoice::Auto,
            BackendArg::Cpu => BackendChoice::Cpu,
            BackendArg::CpuFast => BackendChoice::CpuFast,
            BackendArg::Gpu => BackendChoice::Gpu,
        }
    }
}

/// Sonar pair, sampling and backend: the options every projecting sub-command shares.
#[derive(Debug, clap::Args)]
pub(crate) struct PairArgs {
    /// Sonar 1 (measures the feature): a preset name or a sonar TOML file.
    #[arg(long, value_name = "SONAR")]
    from: String,
    /// Sonar 2 (where the feature is looked for): a preset name or a sonar TOML file.
    #[arg(long, value_name = "SONAR")]
    to: String,
    /// Sampling step in degrees (as the published code; 0.1 there), or `exact` (an FLS sonar 1's
    /// arc solved in closed form, no samples). Default: auto, so that neighbouring samples land
    /// less than half a bin and half a beam apart in sonar 2.
    #[arg(long, value_name = "DEG|auto|exact", value_parser = parse_step)]
    step: Option<Sampling>,
    /// Cell side (m) of the Cartesian grid over an FLS sonar 2's image that `projection_area`
    /// counts (the paper's: 0.08 m).
    #[arg(long, value_name = "M", default_value_t = sonarproj::PAPER_AREA_GRID)]
    area_grid: f64,
    /// Range error σ (m) that sigma_elevation is computed for. Default: the bin width of the
    /// sonar whose range pins the elevation (sonar 2 for an FLS sonar 1, else sonar 1) over √12.
    #[arg(long, value_name = "M")]
    sigma_range: Option<f64>,
    /// Where to compute: auto picks a hardware GPU when one exists, else the fast CPU path.
    #[arg(long, value_enum, default_value = "auto")]
    backend: BackendArg,
}

impl PairArgs {
    /// Returns the checked batch of sonar 1, sonar 2, the sampling and the area grid, no items yet.
    fn resolve(&self) -> Result<Batch> {
        let source = resolve_sonar(&self.from)?;
        let target = resolve_sonar(&self.to)?;
        let sampling = self.step.unwrap_or(Sampling::Auto);
        let pair = Batch {
            sigma_range: self.sigma_range,
            source,
            target,
            sampling,
            area_grid: self.area_grid,
            items: Vec::new(),
        };
        pair.checker()?;
        Ok(pair)
    }

    /// Returns the backend, printing the one-line notice when `auto` fell back to the CPU.
    fn backend(&self) -> Result<Backend> {
        let (backend, notice) = gpu_env::select(self.backend.into())?;
        if let Some(n) = notice {
            eprintln!("{n}");
        }
        Ok(backend)
    }
}

/// Returns the sampling that `--step` names: `auto`, `exact` or a step in degrees (checked
/// later, where the error names the option).
fn parse_step(s: &str) -> std::result::Result<Sampling, String> {
    match s.trim().to_ascii_lowercase().as_str() {
        "auto" => Ok(Sampling::Auto),
        "exact" => Ok(Sampling::Exact),
        t => t
            .parse::<f64>()
            .map(Sampling::Step)
            .map_err(|_| format!("must be a step in degrees (> 0), `auto` or `exact`, got {s:?}")),
    }
}

/// Returns the sonar `spec` names: a preset, or a sonar TOML file. A file is noted as an input
/// that no output of this command may replace.
///
/// # Errors
/// As [`Sonar::resolve`].
pub(crate) fn resolve_sonar(spec: &str) -> Result<Sonar> {
    let sonar = Sonar::resolve(spec)?;
    if Sonar::preset(spec).is_none() {
        sonarproj_apps::report::note_input(std::path::Path::new(spec));
    }
    Ok(sonar)
}

/// Returns the input `path` ('-' for stdin) opened for reading as a stream.
///
/// # Errors
/// [`Error::ReadInput`] naming the file when it cannot be opened or is a directory.
fn open_input(path: &str) -> Result<Box<dyn Read>> {
    if path == "-" {
        sonarproj_apps::report::note_stdin();
        return Ok(Box::new(std::io::stdin().lock()));
    }
    let path = PathBuf::from(path);
    sonarproj_apps::report::note_input(&path);
    let file = std::fs::File::open(&path).map_err(|source| Error::ReadInput {
        path: path.clone(),
        source,
    })?;
    match file.metadata() {
        Ok(m) if m.is_dir() => Err(Error::ReadInput {
            path,
            source: std::io::Error::other("it is a directory, not a file"),
        }),
        _ => Ok(Box::new(file)),
    }
}

/// Writes `args` to stdout (the [`outln!`] macro's work).
///
/// # Errors
/// [`Error::WriteOutput`] naming stdout when the write fails.
pub(crate) fn write_stdout(args: std::fmt::Arguments<'_>) -> Result<()> {
    std::io::stdout()
        .lock()
        .write_fmt(args)
        .map_err(|e| Error::WriteOutput {
            path: "stdout".into(),
            message: e.to_string(),
        })
}

/// Writes the output `path` ('-' for stdout) with `fill`. A file is written whole or not at all.
fn write_output(path: &str, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    if path == "-" {
        fill(&mut std::io::stdout().lock())
    } else {
        write_atomic(&PathBuf::from(path), |w| fill(w))
    }
}

/// Runs the parsed command line.
pub(crate) fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Project(a) => project::run(a),
        Command::Batch(a) => batch::run(a),
        Command::Paper(a) => paper::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Merge(a) => sweep::merge(a),
        Command::Advise(a) => advise::run(a),
        Command::Mask(a) => mask::run(a),
        Command::Recover(a) => recover::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Devices => devices::run(),
        Command::Sonar(c) => sonar::run(c),
        Command::View(a) => view::run(a),
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    #[test]
    fn the_command_line_definition_is_consistent() {
        super::Cli::command().debug_assert();
    }
}
