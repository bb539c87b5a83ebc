//! The batches that `sonarproj bench` and `cargo bench` measure speed on: placement poses of
//! the paper's kind, with 0.1° step sampling as in the published code.

use sonarproj::Output;
use sonarproj::stream::Stop;
use std::time::{Duration, Instant};

use crate::error::{Error, Result};
use crate::sweep::plan::RUN_BLOCKS;
use sonarproj::geometry::pose::{RelativePose, Rotation};
use sonarproj::geometry::sonar::Sonar;
use sonarproj::projection::Backend;
use sonarproj::projection::gpu::DeviceStages;
use sonarproj::projection::{Batch, BatchItem};
use sonarproj::sampling::{Measurement, Sampling};

/// The standard batches as `(from, to, poses)`, sized to take about as long on the reference.
pub const STANDARD: [(&str, &str, usize); 2] =
    [("paper-fls", "paper-sss", 2000), ("paper-sss", "paper-fls", 200)];

/// Returns `n` placement poses from `source` to `target`, with rotations spread over the
/// sphere and the feature on the boresight at half of each sonar's maximum range.
///
/// # Errors
/// Invalid sonars, as in [`RelativePose::placement`].
pub fn batch(source: &Sonar, target: &Sonar, n: usize) -> Result<Batch> {
    let f = [source.range_max / 2.0, 0.0, 0.0];
    let place = [target.range_max / 2.0, 0.0, 0.0];
    let items = (0..n)
        .map(|k| {
            let a = k as f64 * 360.0 / n as f64;
            let rot = Rotation::RollPitchYaw {
                roll: a,
                pitch: a * 0.5 - 90.0,
                yaw: 180.0 - a,
            };
            Ok(BatchItem {
                true_point: None,
                measurement: Measurement::of(source, f[0], 0.0)?,
                pose: RelativePose::placement(rot, f, place)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Batch {
        sigma_range: None,
        source: source.clone(),
        target: target.clone(),
        sampling: Sampling::Step(0.1),
        area_grid: sonarproj::PAPER_AREA_GRID,
        items,
    })
}

/// One backend's speed on one batch.
#[derive(Clone, Debug)]
pub struct Timing {
    /// Median wall time of one run.
    pub median: Duration,
    /// Poses in the batch.
    pub poses: usize,
    /// Samples drawn in the batch.
    pub samples: u64,
}

impl Timing {
    /// Returns poses per second.
    #[must_use]
    pub fn poses_per_second(&self) -> f64 {
        self.poses as f64 / self.median.as_secs_f64()
    }

    /// Returns samples per second.
    #[must_use]
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.median.as_secs_f64()
    }
}

pub use crate::limits::MAX_RUNS;

/// Returns the median time of `runs` runs (after one warm-up run) of `batch` on `backend`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] unless `1 <= runs <= MAX_RUNS`. Else as [`Backend::project`].
pub fn time(backend: &Backend, batch: &Batch, runs: u32) -> Result<Timing> {
    if !(1..=MAX_RUNS).contains(&runs) {
        return Err(Error::invalid(
            "runs",
            runs,
            format!("must be in [1, {MAX_RUNS}]"),
        ));
    }
    let first = backend.project(batch, Output::MetricsOnly)?;
    let samples = first.iter().map(|p| p.metrics.total).sum();
    let mut times = Vec::with_capacity(runs as usize);
    for _ in 0..runs {
        let start = Instant::now();
        backend.project(batch, Output::MetricsOnly)?;
        times.push(start.elapsed());
    }
    times.sort();
    Ok(Timing {
        median: times[times.len() / 2],
        poses: batch.items.len(),
        samples,
    })
}

/// The mask latency cases: `(from, to)`, a sidescan to an imaging sonar and back.
pub const MASK_CASES: [(&str, &str); 2] = [
    ("holoocean-sidescan", "holoocean-imaging"),
    ("holoocean-imaging", "holoocean-sidescan"),
];

/// Returns the pose and `n` features of a mask benchmark ping: the slowest case.
/// The sonars sit side by side, nearly aligned, so a sidescan's fan lies inside the imaging
/// sonar's elevation aperture (the largest masks) and each imaging-sonar arc crosses the
/// sidescan's beam. Features spread evenly over the ranges both sonars see and, for an FLS,
/// over 90 % of the azimuths.
///
/// # Errors
/// None for valid sonars.
pub fn mask_ping(source: &Sonar, target: &Sonar, n: usize) -> Result<(RelativePose, Vec<Measurement>)> {
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 5.0,
            yaw: 10.0,
        },
        [0.3, 0.2, -0.1],
    )?;
    let far = source.range_max.min(0.95 * target.range_max);
    let features = (0..n)
        .map(|k| {
            let f = (k as f64 + 0.5) / n as f64;
            let range = source.range_min + f * (far - source.range_min);
            // A golden-ratio walk over the aperture, decorrelated from the range.
            let g = (k as f64 * 0.618_033_988_749_895).fract();
            Measurement::of(source, range, (g - 0.5) * 0.9 * source.azimuth_aperture)
        })
        .collect::<sonarproj::Result<Vec<_>>>()?;
    Ok((pose, features))
}

/// Returns the sweep that `bench sweep` times, writing its table or summaries as `output` says.
/// It goes fls→sss at `sampling` (0.1° by default), the feature 5 m ahead placed 10 m from the
/// sidescan. Roll and pitch run 0–99° by 1°, and yaw 0, 1, … until there are at least `poses`
/// poses (a million in `data/bench-sweep-1m.toml`).
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `poses` outside `[1, 10^8]`.
pub fn sweep_config(
    poses: u64,
    output: SweepOutput,
    sampling: Sampling,
) -> Result<crate::sweep::SweepConfig> {
    if !(1..=100_000_000).contains(&poses) {
        return Err(Error::invalid("poses", poses, "must be in [1, 100000000]"));
    }
    let yaws = poses.div_ceil(10_000);
    let step = match sampling {
        Sampling::Step(s) => format!("{s}"),
        other => format!("\"{other}\""),
    };
    let mut text = format!(
        "from = \"paper-fls\"\nto = \"paper-sss\"\nstep = {step}\n[feature]\nrange = 5\n[place]\nrange = 10\n\
         [rotation]\nroll = {{ start = 0, stop = 99, step = 1 }}\npitch = {{ start = 0, stop = 99, step = 1 }}\n\
         yaw = {{ start = 0, stop = {}, step = 1 }}\n",
        yaws - 1
    );
    if output == SweepOutput::Span {
        text.insert_str(0, "columns = [\"span\"]\n");
    }
    if output == SweepOutput::Summaries {
        text.push_str(
            "[summary]\ntop = 10\nhistogram = { min = 0, max = 1.2, bins = 120 }\nrows = false\n\
             marginals = [[\"roll\", \"pitch\"], \"yaw\"]\n",
        );
    }
    crate::sweep::SweepConfig::parse("bench sweep", &text, std::path::Path::new("."))
}

/// What the benchmark sweep ([`sweep_config`]) writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepOutput {
    /// Its table, every column.
    Table,
    /// Its table, the span alone of the result columns (`columns = ["span"]`).
    Span,
    /// A `[summary]` of its span (top 10, a histogram of 120 bins, the roll × pitch and the
    /// yaw marginals) and no rows.
    Summaries,
}

/// One backend's times on the benchmark sweep (medians of the runs).
#[derive(Clone, Debug)]
pub struct SweepTiming {
    /// Poses of the sweep.
    pub poses: u64,
    /// Samples drawn.
    pub samples: u64,
    /// The sweep's own computation: the poses projected block by block into metric columns
    /// ([`Backend::project_blocks`]).
    pub decoded: Duration,
    /// The same poses as batches of items, which the host builds, packs and unpacks. `None` when
    /// not asked for.
    pub per_item: Option<Duration>,
    /// The whole sweep to Parquet (`sweep --format parquet`). `None` when not asked for.
    pub parquet: Option<Duration>,
    /// As `decoded`, keeping the span alone, as the span's sweeps compute. `None` when neither is
    /// asked for.
    pub span_decoded: Option<Duration>,
    /// The whole sweep to Parquet, with the span as its only result column. `None` when not asked.
    pub span_parquet: Option<Duration>,
    /// The whole sweep with summaries only (`rows = false`). `None` when not asked for.
    pub summaries: Option<Duration>,
    /// The GPU compute passes' part of `decoded`, on the device's clock, from one more run (a
    /// pass a stage). `None` on the CPU backends and on adapters without timestamp queries.
    pub device: Option<DeviceStages>,
    /// In that run, the host's time waiting for the GPU's chunks and unpacking their metrics.
    /// `None` on the CPU backends.
    pub host: Option<sonarproj::projection::gpu::HostTime>,
    /// The device's and host's times of one more summaries-only sweep. `None` on the CPU backends
    /// or when summaries are not measured.
    pub summary_gpu: Option<(Option<DeviceStages>, sonarproj::projection::gpu::HostTime)>,
}

/// Which of `bench sweep`'s measures to take besides the projection (`true`: taken).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SweepMeasures {
    /// The per-item path.
    pub per_item: bool,
    /// The whole sweep to Parquet.
    pub parquet: bool,
    /// The whole sweep to Parquet, the span alone of the result columns.
    pub span: bool,
    /// The whole sweep with summaries only.
    pub summaries: bool,
}

impl Default for SweepMeasures {
    /// Returns all of them.
    fn default() -> Self {
        SweepMeasures {
            per_item: true,
            parquet: true,
            span: true,
            summaries: true,
        }
    }
}

/// Returns the times of the benchmark sweep ([`sweep_config`]) of about `poses` poses.
/// Each is the median of `runs` runs after a warm-up. Projections take `block` poses a call.
/// Sweeps are written under the system's temporary directory and removed after each run.
///
/// # Errors
/// As [`time`], [`sweep_config`] and [`crate::sweep::run()`], or [`Error::WriteOutput`] when
/// no temporary directory can be made.
pub fn time_sweep(
    backend: &Backend,
    poses: u64,
    block: u64,
    runs: u32,
    measures: SweepMeasures,
    sampling: Sampling,
) -> Result<SweepTiming> {
    use crate::sweep::Poses;
    if !(1..=MAX_RUNS).contains(&runs) {
        return Err(Error::invalid(
            "runs",
            runs,
            format!("must be in [1, {MAX_RUNS}]"),
        ));
    }
    let rows = sweep_config(poses, SweepOutput::Table, sampling)?;
    let span_rows = sweep_config(poses, SweepOutput::Span, sampling)?;
    let summaries = sweep_config(poses, SweepOutput::Summaries, sampling)?;
    let Poses::Grid(grid) = &rows.poses else {
        unreachable!("a grid sweep")
    };
    let grid = grid.pose_grid(&rows.source)?;
    let n = grid.len();
    let sweep = sonarproj::PoseSweep {
        source: rows.source.clone(),
        target: rows.target.clone(),
        sampling: rows.sampling,
        area_grid: rows.area_grid,
        poses: sonarproj::PoseSource::Grid(&grid),
    };
    let block = block.max(1);
    let blocks = || (0..n.div_ceil(block)).map(move |b| b * block..((b + 1) * block).min(n));
    let mut samples = 0;
    let mut decode = |columns: &mut sonarproj::MetricColumns| -> Result<()> {
        samples = 0;
        // Block after block as a sweep projects them, RUN_BLOCKS at a time.
        let mut all = blocks();
        loop {
            let run: Vec<_> = all.by_ref().take(RUN_BLOCKS).collect();
            if run.is_empty() {
                return Ok(());
            }
            // Every block is taken: the flow is always `Continue`.
            let _ = backend.project_blocks(&sweep, &run, columns, Stop::NEVER, &mut |_, c| {
                samples += c.total.iter().sum::<u64>();
                std::ops::ControlFlow::Continue(())
            })?;
        }
    };
    let span_decoded = (measures.span || measures.summaries)
        .then(|| {
            let mut span = sonarproj::MetricColumns::only(&[sonarproj::Metric::Span]);
            median(runs, &mut || decode(&mut span))
        })
        .transpose()?;
    let mut all = sonarproj::MetricColumns::default();
    let mut decoded = || decode(&mut all);
    let decoded_time = median(runs, &mut decoded)?;
    let timed = on_gpu_clock(backend, &mut decoded)?;
    let (device, host) = (timed.and_then(|t| t.0), timed.map(|t| t.1));
    let decoded = decoded_time;
    let per_item = measures
        .per_item
        .then(|| {
            median(runs, &mut || {
                for r in blocks() {
                    let (pose_rows, _) = rows.items_numeric(r)?;
                    let batch = crate::sweep::table::chunk_batch(&rows, &pose_rows);
                    backend.project(&batch, Output::MetricsOnly)?;
                }
                Ok(())
            })
        })
        .transpose()?;
    let scratch = tempfile::tempdir().map_err(|e| Error::write_output(&std::env::temp_dir(), e))?;
    let sweep_into = |config: &crate::sweep::SweepConfig| sweep_once(config, backend, scratch.path());
    let parquet = measures
        .parquet
        .then(|| median(runs, &mut || sweep_into(&rows)))
        .transpose()?;
    let span_parquet = measures
        .span
        .then(|| median(runs, &mut || sweep_into(&span_rows)))
        .transpose()?;
    let (summaries, summary_gpu) = if measures.summaries {
        let time = median(runs, &mut || sweep_into(&summaries))?;
        (Some(time), on_gpu_clock(backend, &mut || sweep_into(&summaries))?)
    } else {
        (None, None)
    };
    Ok(SweepTiming {
        poses: n,
        samples,
        decoded,
        per_item,
        parquet,
        span_decoded,
        span_parquet,
        summaries,
        device,
        host,
        summary_gpu,
    })
}

/// Runs the sweep of `config` once as Parquet into a folder of `scratch`, then removes it.
///
/// # Errors
/// As [`crate::sweep::run()`].
fn sweep_once(
    config: &crate::sweep::SweepConfig,
    backend: &Backend,
    scratch: &std::path::Path,
) -> Result<()> {
    let out = scratch.join("bench-sweep");
    let result = sweep_into(config, backend, &out);
    let _ = std::fs::remove_dir_all(&out);
    result.map(drop)
}

/// Runs the sweep of `config` once as Parquet into folder `out`. Returns its result file.
fn sweep_into(
    config: &crate::sweep::SweepConfig,
    backend: &Backend,
    out: &std::path::Path,
) -> Result<Option<std::path::PathBuf>> {
    use crate::sweep::{Format, Options, run};
    let opts = Options {
        out: out.to_path_buf(),
        shard: None,
        chunk_poses: None,
        max_chunks: None,
        format: Format::Parquet,
    };
    let outcome = run(config, backend, &opts, Stop::NEVER, &mut |_| {
        std::ops::ControlFlow::Continue(())
    })?;
    Ok(outcome.file)
}

/// Runs the benchmark sweep ([`sweep_config`], its whole table) of about `poses` poses once
/// as Parquet into folder `out`, and returns its Parquet file: the table a peer writer (pyarrow,
/// say) writes again, to set the sweep's time against.
///
/// # Errors
/// As [`sweep_config`] and [`crate::sweep::run()`].
pub fn parquet_table(
    backend: &Backend,
    poses: u64,
    sampling: Sampling,
    out: &std::path::Path,
) -> Result<std::path::PathBuf> {
    let config = sweep_config(poses, SweepOutput::Table, sampling)?;
    sweep_into(&config, backend, out)?
        .ok_or_else(|| Error::write_output(out, "the sweep left no result file"))
}

/// Returns the device's time a stage (`None` without timestamp queries) and the host's time of
/// one more call of `f` on the GPU. `None` on the CPU backends.
fn on_gpu_clock(
    backend: &Backend,
    f: &mut dyn FnMut() -> Result<()>,
) -> Result<Option<(Option<DeviceStages>, sonarproj::projection::gpu::HostTime)>> {
    let Backend::Gpu(g) = backend else {
        return Ok(None);
    };
    g.time_device(true);
    let run = f();
    let (device, host) = (g.device_stages(), g.host_time());
    g.time_device(false);
    run.map(|()| Some((device, host)))
}

fn median(runs: u32, f: &mut dyn FnMut() -> Result<()>) -> Result<Duration> {
    f()?;
    let mut times = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f().map(|()| start.elapsed())
        })
        .collect::<Result<Vec<_>>>()?;
    times.sort();
    Ok(times[times.len() / 2])
}
