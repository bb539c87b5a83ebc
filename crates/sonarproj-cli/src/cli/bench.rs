//! `sonarproj bench`: the same batches on every backend, samples and poses per second.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use sonarproj::stream::Stop;
use sonarproj_apps::bench::{self, STANDARD, Timing};
use std::time::Instant;

use sonarproj::gpu::GpuContext;
use sonarproj::masks::{Counts, MaskEngine};
use sonarproj::{Backend, BackendChoice, Sonar};
use sonarproj_apps::Result;

/// Printed under the device list when the GPU is a software adapter.
const SOFTWARE_NOTE: &str =
    "gpu-sw: a software adapter on the CPU's cores; its figures say nothing of a real GPU";

/// What `sonarproj bench` measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum Subject {
    /// Projection batches: samples and poses per second on every backend.
    Projection,
    /// Correspondence-mask latency: one mask, and a ping of 100 features (the mask latency
    /// cases: holoocean-sidescan to holoocean-imaging and back).
    Masks,
    /// A grid sweep (fls→sss, roll × pitch × yaw, `--poses` of them): its projection with the
    /// poses decoded where the work runs, the same poses as batches of items, the sweep to
    /// Parquet, and the sweep with summaries only.
    Sweep,
}

/// A backend `sonarproj bench` times.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum Timed {
    /// The GPU (a software adapter such as lavapipe counts, labelled gpu-sw).
    Gpu,
    /// The fast CPU path on every core.
    CpuFast,
    /// The f64 CPU reference on one core.
    Cpu,
}

/// Options of `sonarproj bench`.
#[derive(Debug, clap::Args)]
pub(super) struct BenchArgs {
    /// What to measure.
    #[arg(value_enum, default_value = "projection")]
    subject: Subject,
    /// Timed runs per backend and batch, at most 10000. The median is reported, after one
    /// warm-up run.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    runs: u32,
    /// The backends to time, comma-separated (projection only): gpu, cpu-fast, cpu. Default:
    /// all three, the GPU where an adapter exists. Naming gpu without one is an error.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        value_name = "LIST",
        conflicts_with = "no_reference"
    )]
    backends: Vec<Timed>,
    /// Leave out the CPU reference (slow on big batches): the default backends but cpu.
    #[arg(long)]
    no_reference: bool,
    /// Multiply the standard batches' pose counts (2000 fls→sss, 200 sss→fls) by this, so
    /// that each batch runs long enough to measure (at most 1000). Measured on two cores
    /// (2-core AMD EPYC, 5 runs): `--scale 500 --backends cpu-fast` takes about 12 s. The CPU
    /// reference and a software GPU (lavapipe) take minutes more at that scale.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    scale: u32,
    /// Poses of the sweep (sweep only): roll × pitch 0–99° by 1° and as many yaw values as make
    /// at least this many (at most 10^8). Measured on two cores (2-core AMD EPYC): the default
    /// takes about 6 s on cpu-fast (`time sonarproj bench sweep --backends cpu-fast`). Lavapipe
    /// takes minutes.
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..=100_000_000))]
    poses: u64,
    /// Poses per projection call in the sweep's "project" and "per item" measures (sweep only;
    /// default 131072, the sweep's chunk and Parquet row group).
    #[arg(long, default_value_t = 131_072, value_parser = clap::value_parser!(u64).range(1..=100_000_000))]
    block: u64,
    /// The sweep's measures to take besides the projection, comma-separated (sweep only):
    /// items, parquet, span, summary. Default: all four. At 10^8 poses the Parquet sweep writes
    /// 4.7 GB twice and the span's 1.2 GB twice, so `--measures summary` takes the projections
    /// and the summaries alone.
    #[arg(long, value_delimiter = ',', value_enum)]
    measures: Vec<SweepMeasure>,
    /// The sweep's sampling (sweep only): a step in degrees, `auto` or `exact`. Run it twice,
    /// `--step 0.1` and `--step exact`, to compare the two side by side.
    #[arg(long, value_name = "DEG|auto|exact", default_value = "0.1", value_parser = super::parse_step)]
    step: sonarproj::Sampling,
    /// Also time pyarrow writing the Parquet sweep's table again, with this Python interpreter
    /// (sweep only, with the parquet measure): the table of one more sweep read back and written
    /// with Snappy and pyarrow's other defaults, `--runs` times. Each backend's Parquet sweep is then
    /// set against its projection plus that write.
    #[arg(long, value_name = "PYTHON")]
    pyarrow: Option<std::path::PathBuf>,
}

/// The values of `--measures`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum SweepMeasure {
    /// The same poses as batches of items (the per-item path).
    Items,
    /// The whole sweep to Parquet.
    Parquet,
    /// The whole sweep to Parquet keeping the span alone of the result columns (`columns =
    /// ["span"]`), against the projection of the span alone.
    Span,
    /// The whole sweep with summaries only.
    Summary,
}

/// Runs `sonarproj bench`.
pub(super) fn run(a: BenchArgs) -> Result<()> {
    if a.subject == Subject::Masks {
        return masks(a.runs.max(1));
    }
    let sweep = a.subject == Subject::Sweep;
    let chosen = !a.backends.is_empty();
    let wanted = |t: Timed| {
        if chosen {
            a.backends.contains(&t)
        } else {
            // The reference takes hours on a sweep's million poses: only when named.
            t != Timed::Cpu || !(a.no_reference || sweep)
        }
    };
    let mut backends = Vec::new();
    if wanted(Timed::Gpu) {
        match super::gpu_env::select(BackendChoice::Gpu) {
            Ok((gpu, _)) => backends.push(gpu),
            // A bad GPU variable or an adapter name that matches none: the user's input.
            Err(e) if e.is_input() || chosen => return Err(e),
            Err(e) => outln!("GPU: not measured ({e})")?,
        }
    }
    if wanted(Timed::CpuFast) {
        backends.push(Backend::CpuFast);
    }
    if wanted(Timed::Cpu) {
        backends.push(Backend::Cpu);
    }
    for b in &backends {
        outln!("{:8} {}", b.label(), b.device())?;
    }
    if backends.iter().any(|b| b.label() == "gpu-sw") {
        outln!("{SOFTWARE_NOTE}")?;
    }
    outln!()?;
    if sweep {
        let measures = if a.measures.is_empty() {
            bench::SweepMeasures::default()
        } else {
            bench::SweepMeasures {
                per_item: a.measures.contains(&SweepMeasure::Items),
                parquet: a.measures.contains(&SweepMeasure::Parquet),
                span: a.measures.contains(&SweepMeasure::Span),
                summaries: a.measures.contains(&SweepMeasure::Summary),
            }
        };
        if a.pyarrow.is_some() && !measures.parquet {
            return Err(sonarproj_apps::Error::input(
                "--pyarrow",
                "times pyarrow against the Parquet sweep: it needs the parquet measure",
            ));
        }
        let step = a.step.validated()?;
        let peer = a.pyarrow.as_deref().map(|python| (python, step, a.runs));
        return sweep_table(&backends, a.poses, a.block, a.runs, measures, step, peer);
    }
    outln!(
        "{:28} {:8} {:>8} {:>12} {:>14} {:>14} {:>12}",
        "batch",
        "backend",
        "poses",
        "median (ms)",
        "poses/s",
        "samples/s",
        "vs reference"
    )?;
    // On stderr, drawn only when it is a terminal (indicatif hides it otherwise).
    let bar = ProgressBar::with_draw_target(
        Some((STANDARD.len() * backends.len()) as u64),
        ProgressDrawTarget::stderr(),
    );
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} timings  {elapsed}  {msg}")
            .expect("valid template"),
    );
    for (from, to, n) in STANDARD {
        let batch = bench::batch(
            &Sonar::preset(from).expect("preset"),
            &Sonar::preset(to).expect("preset"),
            n * a.scale as usize,
        )?;
        let timings: Vec<(&Backend, Timing)> = backends
            .iter()
            .map(|b| {
                bar.set_message(format!("{from} -> {to} on {}, {} runs", b.label(), a.runs + 1));
                let t = bench::time(b, &batch, a.runs)?;
                bar.inc(1);
                Ok((b, t))
            })
            .collect::<Result<_>>()?;
        let reference = timings
            .iter()
            .find(|(b, _)| matches!(b, Backend::Cpu))
            .map(|t| t.1.samples_per_second());
        // Printed with the bar cleared, so that it never lands inside a row.
        bar.suspend(|| -> Result<()> {
            for (b, t) in &timings {
                let ratio = reference
                    .map(|r| format!("{:.1}x", t.samples_per_second() / r))
                    .unwrap_or_default();
                outln!(
                    "{:28} {:8} {:>8} {:>12.2} {:>14.0} {:>14.3e} {:>12}",
                    format!("{from} -> {to}"),
                    b.label(),
                    t.poses,
                    t.median.as_secs_f64() * 1e3,
                    t.poses_per_second(),
                    t.samples_per_second(),
                    ratio
                )?;
            }
            Ok(())
        })?;
    }
    bar.finish_and_clear();
    Ok(())
}

/// Prints the times of the benchmark sweep on each of `backends`, each also as a multiple of
/// the projection: the projection (grid decoded where the work runs), the per-item path, and
/// the two sweeps.
fn sweep_table(
    backends: &[Backend],
    poses: u64,
    block: u64,
    runs: u32,
    measures: bench::SweepMeasures,
    step: sonarproj::Sampling,
    pyarrow: Option<(&std::path::Path, sonarproj::Sampling, u32)>,
) -> Result<()> {
    // The peer's write first: a Python without pyarrow is refused before the long timings.
    let peer = match (pyarrow, backends.first()) {
        (Some((python, step, runs)), Some(b)) => {
            Some(super::peer::pyarrow_write(python, b, poses, step, runs)?)
        }
        _ => None,
    };
    outln!(
        "{:9} {:>9} {:>10} {:>12} {:>11} {:>9} {:>11} {:>13} {:>13} {:>12} {:>7} {:>13} {:>13} {:>7} {:>12} {:>7}",
        "backend",
        "poses",
        "samples/s",
        "project (s)",
        "device (s)",
        "wait (s)",
        "unpack (s)",
        "per item (s)",
        "host ns/pose",
        "parquet (s)",
        "ratio",
        "span proj (s)",
        "span pq (s)",
        "ratio",
        "summary (s)",
        "ratio"
    )?;
    let mut notes = Vec::new();
    for b in backends {
        let t = bench::time_sweep(b, poses, block, runs, measures, step)?;
        notes.extend(sweep_notes(b, &t, peer));
        sweep_row(b, &t)?;
    }
    for note in notes {
        outln!("{note}")?;
    }
    outln!(
        "\nproject: the grid decoded where the work runs, metric columns out; device: of project, \
         the GPU's compute passes on its own clock (timestamp queries; a timed run takes a pass a \
         stage, split below); wait and unpack: of the \
         same timed run, the host waiting for the GPU's chunks and unpacking their metrics (two \
         chunks in flight: the device works during an unpack); per item: the same \
         poses as batches of items built, packed and unpacked by the host (host ns/pose: the \
         difference a pose); parquet: the whole sweep into a directory (ratio: its multiple of \
         project); span proj: the projection keeping the span alone (no azimuth extremes); span \
         pq: the sweep to Parquet keeping the span alone of the result columns, and summary: the \
         sweep with summaries of the span only (ratios: their multiples of span proj); - where not measured (no timestamp queries, or left out of \
         --measures); medians of the runs after one warm-up"
    )?;
    Ok(())
}

/// Returns the lines printed under the sweep table for backend `b`'s times `t`: its Parquet
/// sweep against the `peer`'s write, and a timed run's device time by stage.
fn sweep_notes(b: &Backend, t: &bench::SweepTiming, peer: Option<std::time::Duration>) -> Vec<String> {
    let mut notes = Vec::new();
    if let (Some(write), Some(parquet)) = (peer, t.parquet) {
        let (p, w, q) = (
            t.decoded.as_secs_f64(),
            write.as_secs_f64(),
            parquet.as_secs_f64(),
        );
        notes.push(format!(
            "{} parquet against pyarrow: {q:.3} s, {:.2}x of project {p:.3} s + pyarrow's write of the same table {w:.3} s",
            b.label(),
            q / (p + w)
        ));
    }
    // A timed run's device passes: their sum, then each stage's part.
    let stages = |d: &sonarproj::projection::gpu::DeviceStages| {
        format!(
            "{:.3} s (poses {:.3}, splat {:.3}, reduce {:.3})",
            d.total().as_secs_f64(),
            d.poses.as_secs_f64(),
            d.splat.as_secs_f64(),
            d.reduce.as_secs_f64()
        )
    };
    if let Some(d) = &t.device {
        notes.push(format!(
            "{} project, one more timed run: device {}",
            b.label(),
            stages(d)
        ));
    }
    if let Some((device, host)) = t.summary_gpu {
        let device = device.as_ref().map_or("-".to_string(), stages);
        notes.push(format!(
            "{} summary sweep, one more timed run: device {device}, wait {:.3} s, unpack {:.3} s",
            b.label(),
            host.wait.as_secs_f64(),
            host.unpack.as_secs_f64()
        ));
    }
    notes
}

/// Prints backend `b`'s row of the sweep table from its times `t`.
fn sweep_row(b: &Backend, t: &bench::SweepTiming) -> Result<()> {
    let secs = |d: std::time::Duration| d.as_secs_f64();
    // A measure's seconds and its multiple of the projection ("-" where not taken).
    let time = |d: Option<std::time::Duration>| d.map_or("-".to_string(), |d| format!("{:.3}", secs(d)));
    let ratio = |d: Option<std::time::Duration>, of: Option<std::time::Duration>| match (d, of) {
        (Some(d), Some(of)) => format!("{:.2}x", secs(d) / secs(of)),
        _ => "-".to_string(),
    };
    #[expect(clippy::cast_precision_loss, reason = "pose and sample counts below 2^53")]
    let (per_pose, rate) = (
        t.per_item.map_or("-".to_string(), |p| {
            format!("{:.0}", (secs(p) - secs(t.decoded)) * 1e9 / t.poses as f64)
        }),
        // Exact mode draws no samples: no rate.
        (t.samples > 0).then(|| t.samples as f64 / secs(t.decoded)),
    );
    outln!(
        "{:9} {:>9} {:>10} {:>12.3} {:>11} {:>9} {:>11} {:>13} {:>13} {:>12} {:>7} {:>13} {:>13} {:>7} {:>12} {:>7}",
        b.label(),
        t.poses,
        rate.map_or("-".to_string(), |r| format!("{r:.3e}")),
        secs(t.decoded),
        time(t.device.map(|d| d.total())),
        time(t.host.map(|h| h.wait)),
        time(t.host.map(|h| h.unpack)),
        time(t.per_item),
        per_pose,
        time(t.parquet),
        ratio(t.parquet, Some(t.decoded)),
        time(t.span_decoded),
        time(t.span_parquet),
        ratio(t.span_parquet, t.span_decoded),
        time(t.summaries),
        ratio(t.summaries, t.span_decoded)
    )?;
    Ok(())
}

/// Pings a call in the `pings` rows of `bench masks`.
const PINGS: usize = 10;

/// Prints the median latency of one mask and of a 100-feature ping for each of
/// [`bench::MASK_CASES`], as whole masks and as summaries (each mask's count and box, and the
/// union). Runs on the GPU when an adapter exists, and on the CPU engine.
fn masks(runs: u32) -> Result<()> {
    let runs = runs.max(20);
    let options = super::gpu_env::gpu_options()?;
    let gpu = match GpuContext::open(&options).map_err(sonarproj_apps::Error::from) {
        Ok(ctx) if ctx.is_software() => {
            outln!("gpu-sw {}", sonarproj::gpu::context::describe(ctx.info()))?;
            outln!("{SOFTWARE_NOTE}")?;
            Some("gpu-sw")
        }
        Ok(ctx) => {
            outln!("gpu   {}", sonarproj::gpu::context::describe(ctx.info()))?;
            Some("gpu")
        }
        Err(e) if e.is_input() => return Err(e),
        Err(e) => {
            outln!("GPU: not measured ({})", e.render(&super::name))?;
            None
        }
    };
    outln!("cpu   {}", sonarproj::projection::cpu_device())?;
    outln!("median and 90th percentile of {runs} runs after one warm-up")?;
    outln!()?;
    outln!(
        "{:44} {:6} {:8} {:>9} {:>12} {:>10} {:>10} {:>11} {:>9} {:>12}",
        "case",
        "engine",
        "output",
        "features",
        "median (ms)",
        "p90 (ms)",
        "pings/s",
        "cells/mask",
        "seen",
        "pixels/mask"
    )?;
    for (from, to) in bench::MASK_CASES {
        let (source, target) = (
            Sonar::preset(from).expect("preset"),
            Sonar::preset(to).expect("preset"),
        );
        let mut engines = Vec::new();
        if let Some(label) = gpu {
            engines.push((
                label,
                MaskEngine::on_gpu(source.clone(), target.clone(), GpuContext::open(&options)?)?,
            ));
        }
        engines.push(("cpu", MaskEngine::new(source.clone(), target.clone())?));
        for (name, engine) in &engines {
            for n in [1, 100] {
                let (pose, features) = bench::mask_ping(&source, &target, n)?;
                let summary = engine.summary(&pose, &features, None)?;
                let cells = summary.features.iter().map(|f| f.cells).sum::<u64>() / n as u64;
                let seen = summary.features.iter().filter(|f| f.occupied > 0).count();
                let pixels = summary.features.iter().map(|f| f.occupied).sum::<u64>() / n as u64;
                // - masks: every feature's bits.
                // - summary: each mask's pixel count and box, and the union (all a GPU reads back).
                // - pings: summaries of ten pings at once (two in flight on a GPU), timed per ping.
                let pings = vec![(pose, features.clone()); PINGS];
                for output in ["masks", "summary", "pings"] {
                    let ping = || -> Result<()> {
                        match output {
                            "masks" => drop(engine.masks(&pose, &features, None, Counts::Skip)?),
                            "summary" => drop(engine.summary(&pose, &features, None)?),
                            _ => drop(engine.summaries_of_pings(&pings, None, Stop::NEVER)?),
                        }
                        Ok(())
                    };
                    let per_call = if output == "pings" { PINGS as f64 } else { 1.0 };
                    ping()?;
                    let mut times = Vec::with_capacity(runs as usize);
                    for _ in 0..runs {
                        let start = Instant::now();
                        ping()?;
                        times.push(start.elapsed().as_secs_f64() / per_call);
                    }
                    times.sort_by(f64::total_cmp);
                    let median = times[times.len() / 2];
                    outln!(
                        "{:44} {:6} {:8} {:>9} {:>12.3} {:>10.3} {:>10.1} {:>11} {:>9} {:>12}",
                        format!("{from} -> {to}"),
                        name,
                        output,
                        n,
                        median * 1e3,
                        times[times.len() * 9 / 10] * 1e3,
                        1.0 / median,
                        cells,
                        format!("{seen}/{n}"),
                        pixels
                    )?;
                }
            }
        }
    }
    Ok(())
}
