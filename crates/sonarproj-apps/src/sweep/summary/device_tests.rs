//! Summaries reduced on the device (`shaders/summary.wgsl`) against the host's reduction of the
//! same device's metric columns ([`SummarySpec::partial`]): equal, byte for byte, for every
//! metric, sampled and exact, with blocks cut across chunks and workgroups. On lavapipe in CI.

use sonarproj::projection::PoseGrid;
use sonarproj::projection::poses::PLACEMENT_AXES;
use sonarproj::stream::Stop;
use sonarproj::{Backend, Metric, MetricColumns, PoseSource, PoseSweep, Sampling, Sonar};

use super::{HistogramSpec, Summary, SummarySpec};
use crate::sweep::compute::values;
use crate::sweep::config::Axis;
use crate::sweep::grid::Grid;

/// Returns the axes of a grid of `source` → `target` poses: three feature ranges (three sampling
/// plans), placements over sonar 2's view, and rotations that see the set from many sides.
fn axes(source: &Sonar, target: &Sonar) -> [Vec<f64>; 9] {
    let r1 = (source.range_min.max(0.05), source.range_max);
    let r2 = (target.range_min.max(0.05), target.range_max);
    let ha = source.azimuth_aperture / 2.0;
    let lerp = |(a, b): (f64, f64), t: f64| a + (b - a) * t;
    [
        vec![lerp(r1, 0.2), lerp(r1, 0.5), lerp(r1, 0.9)],
        vec![-0.5 * ha, 0.0],
        vec![0.0],
        vec![lerp(r2, 0.3), lerp(r2, 0.7)],
        vec![0.0, 10.0],
        vec![0.0],
        (0..37).map(|k| f64::from(k) * 5.0).collect(),
        vec![-10.0, 0.0, 20.0],
        vec![0.0, 90.0],
    ]
}

/// Returns the apps' grid of `axes` (every axis, so its index is the engine's).
fn apps_grid(axes: &[Vec<f64>; 9]) -> Grid {
    Grid {
        axes: PLACEMENT_AXES
            .iter()
            .zip(axes)
            .map(|(&column, values)| Axis {
                column,
                values: values.clone(),
            })
            .collect(),
        placement: true,
    }
}

/// Returns the summary spec of `metric`, with a histogram of `bins` over the middle of `values`
/// (so values fall below, in and above it), and 1-D and 2-D marginals over fast axes (a
/// workgroup's poses in many cells) and over slow ones (a workgroup's poses mostly in one cell,
/// added up in the workgroup first).
fn spec(metric: Metric, top: usize, bins: usize, values: &[f64]) -> SummarySpec {
    let seen: Vec<f64> = values.iter().copied().filter(|v| !v.is_nan()).collect();
    let low = seen.iter().copied().fold(f64::INFINITY, f64::min);
    let high = seen.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (min, max) = if low < high {
        (low + (high - low) * 0.2, high - (high - low) * 0.3)
    } else if low == high {
        (low - 1.0, low + 1.0)
    } else {
        // no value at all
        (0.0, 1.0)
    };
    SummarySpec {
        by: metric.name().into(),
        top,
        histogram: Some(HistogramSpec { min, max, bins }),
        marginals: vec![
            vec!["roll".into()],
            vec!["place_range".into(), "pitch".into()],
            vec!["range".into()],
            vec!["range".into(), "azimuth".into()],
        ],
        rows: false,
    }
}

/// Returns the host's summary parts of `blocks` of `sweep`, from the device's metric columns.
fn on_the_host(
    backend: &Backend,
    sweep: &PoseSweep<'_>,
    grid: &Grid,
    spec: &SummarySpec,
    metric: Metric,
    blocks: &[std::ops::Range<u64>],
) -> Vec<Summary> {
    let mut out = MetricColumns::default();
    blocks
        .iter()
        .map(|b| {
            backend
                .project_columns(sweep, b.clone(), &mut out, Stop::NEVER)
                .unwrap();
            spec.partial(Some(grid), b.start, &values(&out, metric)).unwrap()
        })
        .collect()
}

/// Returns the device's summary parts of `blocks` of `sweep`.
fn on_the_device(
    backend: &Backend,
    sweep: &PoseSweep<'_>,
    grid: &Grid,
    spec: &SummarySpec,
    blocks: &[std::ops::Range<u64>],
) -> Vec<Summary> {
    let reduction = spec.reduction(Some(grid)).expect("a spec the device reduces");
    let mut parts = Vec::new();
    let mut seen = Vec::new();
    let flow = backend
        .reduce_blocks(sweep, blocks, &reduction, Stop::NEVER, &mut |b, r| {
            seen.push(b);
            parts.push(
                spec.part_of_reduction(Some(grid), r)
                    .expect("values small enough"),
            );
            std::ops::ControlFlow::Continue(())
        })
        .unwrap();
    assert!(flow.is_continue());
    assert_eq!(seen, blocks, "every block once, in order");
    parts
}

/// Returns the GPU backend of the tests' device when it reduces on the device. CI's lavapipe has
/// 64-bit integer atomics, so this never skips there.
fn device() -> Option<Backend> {
    let g = sonarproj_testkit::gpu()?.with_max_chunk_poses(700);
    let backend = Backend::Gpu(Box::new(g));
    let source = Sonar::preset("paper-fls").unwrap();
    let a = axes(&source, &source);
    let grid = PoseGrid::new(a, true, &source).unwrap();
    if !backend.reduces_on_device(&sweep(&source, &source, Sampling::Step(2.0), &grid)) {
        assert!(
            std::env::var("CI").is_err(),
            "CI's device (lavapipe) has 64-bit atomics: the summary stage must run"
        );
        eprintln!("skipped: this device has no 64-bit integer atomics in shaders");
        return None;
    }
    Some(backend)
}

fn sweep<'a>(source: &Sonar, target: &Sonar, sampling: Sampling, grid: &'a PoseGrid) -> PoseSweep<'a> {
    PoseSweep {
        source: source.clone(),
        target: target.clone(),
        sampling,
        area_grid: sonarproj::PAPER_AREA_GRID,
        poses: PoseSource::Grid(grid),
    }
}

/// Runs every metric of `source` → `target` at `sampling` on both sides, for each `(top, bins)`
/// of `specs`, and holds them equal. Histograms of more than 512 bins are counted without the
/// workgroup's shared bins.
fn check(backend: &Backend, source: &str, target: &str, sampling: Sampling, specs: &[(usize, usize)]) {
    let (source, target) = (Sonar::preset(source).unwrap(), Sonar::preset(target).unwrap());
    let a = axes(&source, &target);
    let poses = PoseGrid::new(a.clone(), true, &source).unwrap();
    let grid = apps_grid(&a);
    let s = sweep(&source, &target, sampling, &poses);
    let n = poses.len();
    // Blocks cut across chunks (700 poses) and workgroups (256), one of a single pose.
    let blocks = vec![0..1000, 1000..1001, 1001..2400, 2400..n];
    let mut all = MetricColumns::default();
    backend.project_columns(&s, 0..n, &mut all, Stop::NEVER).unwrap();
    for metric in Metric::all() {
        for &(top, bins) in specs {
            let spec = spec(metric, top, bins, &values(&all, metric));
            let want = on_the_host(backend, &s, &grid, &spec, metric, &blocks);
            let got = on_the_device(backend, &s, &grid, &spec, &blocks);
            for (k, (w, g)) in want.iter().zip(&got).enumerate() {
                let (w, g) = (
                    serde_json::to_string(w).unwrap(),
                    serde_json::to_string(g).unwrap(),
                );
                assert!(
                    w == g,
                    "{} {sampling:?} top {top}, {bins} bins, block {k}:\nhost   {w}\ndevice {g}",
                    metric.name()
                );
            }
        }
    }
}

#[test]
fn an_fls_target_reduces_on_the_device_as_on_the_host() {
    let Some(backend) = device() else { return };
    check(
        &backend,
        "paper-fls",
        "paper-fls",
        Sampling::Step(2.0),
        &[(0, 7), (3, 600), (32, 7)],
    );
}

#[test]
fn an_sss_target_reduces_on_the_device_as_on_the_host() {
    let Some(backend) = device() else { return };
    check(&backend, "paper-fls", "paper-sss", Sampling::Step(2.0), &[(5, 7)]);
}

#[test]
fn an_exact_sweep_reduces_on_the_device_as_on_the_host() {
    let Some(backend) = device() else { return };
    check(&backend, "paper-fls", "paper-sss", Sampling::Exact, &[(4, 7)]);
    check(&backend, "paper-fls", "paper-fls", Sampling::Exact, &[(4, 600)]);
}

/// A summaries-only sweep (reduced on the device) writes the summary that the same sweep with
/// rows (its metric columns read back and reduced on the host) writes, whatever the chunking.
#[test]
fn a_summaries_only_sweep_matches_the_sweep_with_rows() {
    let Some(backend) = device() else { return };
    let file = |rows: bool| {
        format!(
            "from = \"paper-fls\"\nto = \"paper-sss\"\nstep = 1\n\
             [feature]\nrange = [5, 8]\n[place]\nrange = {{ start = 2, stop = 18, step = 2 }}\n\
             [rotation]\nroll = {{ start = 0, stop = 180, step = 1 }}\npitch = [0, 15]\n\
             [summary]\nby = \"span\"\ntop = 6\nhistogram = {{ min = 0, max = 0.05, bins = 20 }}\n\
             marginals = [\"roll\", [\"place_range\", \"roll\"]]\nrows = {rows}\n"
        )
    };
    let run = |rows: bool, chunk: u64| {
        let config =
            crate::sweep::config::SweepConfig::parse("s.toml", &file(rows), std::path::Path::new("."))
                .unwrap();
        let out = crate::sweep::run_in_memory(&config, &backend, None, Some(chunk), Stop::NEVER, &mut |_| {
            std::ops::ControlFlow::Continue(())
        })
        .unwrap()
        .expect("not stopped");
        serde_json::to_string(&out.summary.expect("a summary")).unwrap()
    };
    let want = run(true, 1000);
    assert!(want.contains("\"with_value\":"), "{want}");
    for chunk in [1000, 977, 6516] {
        assert_eq!(run(false, chunk), want, "chunks of {chunk} poses");
    }
}

/// A value too large for the device's exact sums (here 2^22 visible samples and more, times 2^40)
/// sends its chunk back to the host, which sums it exactly: the summary is the one with rows.
#[test]
fn a_value_too_large_for_the_device_is_summed_on_the_host() {
    let Some(backend) = device() else { return };
    let file = |rows: bool| {
        format!(
            "from = \"paper-sss\"\nto = \"paper-sss\"\nstep = 0.002\n\
             [feature]\nrange = 5\n[place]\nrange = 5\n[rotation]\nroll = [0, 90]\n\
             [summary]\nby = \"visible\"\ntop = 1\nmarginals = [\"roll\"]\nrows = {rows}\n"
        )
    };
    let run = |rows: bool| {
        let config =
            crate::sweep::config::SweepConfig::parse("s.toml", &file(rows), std::path::Path::new("."))
                .unwrap();
        let out = crate::sweep::run_in_memory(&config, &backend, None, None, Stop::NEVER, &mut |_| {
            std::ops::ControlFlow::Continue(())
        })
        .unwrap()
        .expect("not stopped");
        out.summary.expect("a summary")
    };
    let want = run(true);
    let visible = want.max.expect("a value").value;
    assert!(
        visible * 2f64.powi(40) >= 2f64.powi(62),
        "{visible} samples: not too large"
    );
    assert_eq!(
        serde_json::to_string(&run(false)).unwrap(),
        serde_json::to_string(&want).unwrap()
    );
}

/// A stop set while a run of blocks is reduced ends it before the next block: the call returns
/// `Break` after the blocks already handed out.
#[test]
fn a_stop_ends_the_reduction_between_blocks() {
    let Some(backend) = device() else { return };
    let source = Sonar::preset("paper-fls").unwrap();
    let target = Sonar::preset("paper-sss").unwrap();
    let a = axes(&source, &target);
    let poses = PoseGrid::new(a.clone(), true, &source).unwrap();
    let grid = apps_grid(&a);
    let s = sweep(&source, &target, Sampling::Step(2.0), &poses);
    let spec = spec(Metric::Span, 2, 7, &[0.0, 1.0]);
    let reduction = spec.reduction(Some(&grid)).unwrap();
    let stopped = std::sync::atomic::AtomicBool::new(false);
    let signal = || stopped.load(std::sync::atomic::Ordering::Relaxed);
    let mut handed = 0;
    let flow = backend
        .reduce_blocks(
            &s,
            &[0..1000, 1000..2000, 2000..3000],
            &reduction,
            Stop::when(&signal),
            &mut |_, _| {
                handed += 1;
                stopped.store(true, std::sync::atomic::Ordering::Relaxed);
                std::ops::ControlFlow::Continue(())
            },
        )
        .unwrap();
    assert!(flow.is_break());
    assert_eq!(handed, 1, "no block after the stop");
}
