//! Pose sources against the per-item path: a grid's poses decoded in the fast path's loop give
//! the metrics that projecting the same poses' items gives, bit for bit, on every preset pair,
//! with placements and translations, step and automatic sampling, whatever the range the
//! poses are asked in; a list gives its items' metrics; every backend's columns are its
//! `project`'s.

use sonarproj::stream::Stop;
use sonarproj_testkit as common;

use sonarproj::Metric;
use sonarproj::projection::gpu::HostTime;
use sonarproj::projection::{ColumnRef, PoseGrid};
use sonarproj::{Backend, Error, MetricColumns, Output, PoseSource, PoseSweep, Sampling, Sonar};

/// Returns a small grid of `source` → `target` poses: features over sonar 1's view, placed over
/// sonar 2's (or translated about it), under rotations that see the set from many sides.
fn grid(source: &Sonar, target: &Sonar, placement: bool) -> PoseGrid {
    let r1 = (source.range_min.max(0.05), source.range_max);
    let r2 = (target.range_min.max(0.05), target.range_max);
    let (ha, he) = (source.azimuth_aperture / 2.0, source.elevation_aperture / 2.0);
    let axes = [
        vec![r1.0 + (r1.1 - r1.0) * 0.3, r1.0 + (r1.1 - r1.0) * 0.8],
        vec![-0.6 * ha, 0.0, 0.9 * ha],
        vec![0.0, 0.5 * he],
        if placement {
            vec![r2.0 + (r2.1 - r2.0) * 0.5]
        } else {
            vec![-0.2 * r2.1, 0.1]
        },
        if placement {
            vec![0.0]
        } else {
            vec![0.0, 0.3 * r2.1]
        },
        if placement { vec![0.0] } else { vec![0.05] },
        vec![0.0, 37.0, 90.0],
        vec![-20.0, 0.0, 65.0],
        vec![0.0, 12.5, 180.0],
    ];
    PoseGrid::new(axes, placement, source).unwrap()
}

fn sweep<'a>(source: &Sonar, target: &Sonar, sampling: Sampling, poses: PoseSource<'a>) -> PoseSweep<'a> {
    PoseSweep {
        source: source.clone(),
        target: target.clone(),
        sampling,
        area_grid: sonarproj::PAPER_AREA_GRID,
        poses,
    }
}

/// Returns `backend`'s projections of the sweep's items, as columns.
fn per_item(backend: &Backend, sweep: &PoseSweep<'_>) -> MetricColumns {
    let batch = sweep.batch(0..sweep.poses.len()).unwrap();
    let mut out = MetricColumns::default();
    for p in backend.project(&batch, Output::MetricsOnly).unwrap() {
        out.push(&p.metrics);
    }
    out
}

/// Asserts two column sets equal bit for bit (NaN stands for none in both).
fn same_bits(a: &MetricColumns, b: &MetricColumns, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: rows");
    for k in 0..a.len() {
        assert_eq!(a.get(k), b.get(k), "{what}: pose {k}");
    }
}

#[test]
fn decoded_grids_match_the_per_item_path_on_every_preset_pair() {
    let names = Sonar::preset_names();
    let mut visible = 0;
    for a in &names {
        for b in &names {
            let (source, target) = (Sonar::preset(a).unwrap(), Sonar::preset(b).unwrap());
            for placement in [true, false] {
                let g = grid(&source, &target, placement);
                for sampling in [Sampling::Step(1.0), Sampling::Auto] {
                    // Automatic sampling of a wide surface draws millions of samples a pose:
                    // the step alone there, the per-range plans on the arcs.
                    if sampling == Sampling::Auto && source.kind == sonarproj::SonarKind::Sss {
                        continue;
                    }
                    let s = sweep(&source, &target, sampling, PoseSource::Grid(&g));
                    let want = per_item(&Backend::CpuFast, &s);
                    let mut got = MetricColumns::default();
                    Backend::CpuFast
                        .project_columns(&s, 0..g.len(), &mut got, Stop::NEVER)
                        .unwrap();
                    same_bits(
                        &got,
                        &want,
                        &format!("{a} -> {b}, placement {placement}, {sampling:?}"),
                    );
                    visible += got.visible.iter().filter(|&&v| v > 0).count();
                }
            }
        }
    }
    // The grids see the sets from many sides: most pairs see something.
    assert!(visible > 1000, "{visible} poses saw anything");
}

#[test]
fn columns_do_not_depend_on_the_range_asked() {
    let (source, target) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let g = grid(&source, &target, true);
    let s = sweep(&source, &target, Sampling::Step(0.5), PoseSource::Grid(&g));
    let mut whole = MetricColumns::default();
    Backend::CpuFast
        .project_columns(&s, 0..g.len(), &mut whole, Stop::NEVER)
        .unwrap();
    // Ranges cut anywhere, into columns reused between calls.
    let mut part = MetricColumns::default();
    let mut joined = MetricColumns::default();
    for r in [0..1, 1..77, 77..300, 300..g.len()] {
        Backend::CpuFast
            .project_columns(&s, r.clone(), &mut part, Stop::NEVER)
            .unwrap();
        assert_eq!(part.len() as u64, r.end - r.start);
        for k in 0..part.len() {
            joined.push(&part.get(k));
        }
    }
    same_bits(&joined, &whole, "cut ranges");
}

#[test]
fn every_backend_gives_its_own_projections_as_columns() {
    let (source, target) = (common::preset("paper-sss"), common::preset("paper-fls"));
    let g = grid(&source, &target, true);
    let s = sweep(&source, &target, Sampling::Step(1.0), PoseSource::Grid(&g));
    let batch = s.batch(0..g.len()).unwrap();
    let list = sweep(
        &source,
        &target,
        Sampling::Step(1.0),
        PoseSource::List(&batch.items),
    );
    let mut backends = vec![Backend::Cpu, Backend::CpuFast];
    if let Some(gpu) = common::gpu() {
        backends.push(Backend::Gpu(Box::new(gpu)));
    }
    for backend in &backends {
        let want = per_item(backend, &s);
        for source in [&s, &list] {
            let mut got = MetricColumns::default();
            backend
                .project_columns(source, 0..g.len(), &mut got, Stop::NEVER)
                .unwrap();
            same_bits(&got, &want, backend.name());
        }
    }
}

/// Returns the bits of `metric`'s column (counts as themselves, reals by their bits: NaN and
/// -0 compared exactly).
fn column_bits(c: &MetricColumns, metric: Metric) -> Vec<u64> {
    match c.column(metric) {
        ColumnRef::Count(v) => v.to_vec(),
        ColumnRef::Real(v) => v.iter().map(|x| x.to_bits()).collect(),
    }
}

/// Returns the reference, the fast CPU path and, where an adapter exists, the GPU twice: in
/// chunks as large as it takes, and in chunks of 7 poses (slots copied back at each chunk's
/// own offsets, the last chunk short, blocks cut into several chunks).
fn every_backend() -> Vec<Backend> {
    let mut backends = vec![Backend::Cpu, Backend::CpuFast];
    if let Some(gpu) = common::gpu() {
        let small = sonarproj_testkit::gpu_backend_on(gpu.context().clone()).with_max_chunk_poses(7);
        backends.push(Backend::Gpu(Box::new(gpu)));
        backends.push(Backend::Gpu(Box::new(small)));
    }
    backends
}

/// Asserts `metric`'s column the same bits in `a` and `b`, naming the first pose that differs.
fn same_column(a: &MetricColumns, b: &MetricColumns, metric: Metric, what: &str) {
    let (x, y) = (column_bits(a, metric), column_bits(b, metric));
    assert_eq!(x.len(), y.len(), "{what}: rows of {}", metric.name());
    if let Some(k) = (0..x.len()).find(|&k| x[k] != y[k]) {
        panic!(
            "{what}: {} differs at row {k}: bits {:#x} vs {:#x}",
            metric.name(),
            x[k],
            y[k]
        );
    }
}

/// Columns kept alone ([`MetricColumns::only`]) are the whole columns' own, bit for bit, on
/// every backend (the GPU in one chunk and in chunks of 7), for both target kinds (an FLS's
/// projection area, an SSS's measure from its bins), with the others left empty, in columns
/// reused between calls and ranges.
#[test]
fn a_metric_kept_alone_is_its_column_of_all() {
    let backends = every_backend();
    for (a, b) in [("paper-fls", "paper-sss"), ("paper-sss", "paper-fls")] {
        let (source, target) = (common::preset(a), common::preset(b));
        let g = grid(&source, &target, false);
        let s = sweep(&source, &target, Sampling::Step(1.0), PoseSource::Grid(&g));
        for backend in &backends {
            let what = format!("{a} -> {b} on {}", backend.name());
            let mut all = MetricColumns::default();
            backend
                .project_columns(&s, 1..g.len(), &mut all, Stop::NEVER)
                .unwrap();
            assert!(all.visible.iter().any(|&v| v > 0), "{what}: nothing seen");
            for metric in Metric::all() {
                let mut one = MetricColumns::only(&[metric]);
                // A first call of another range: the second replaces its rows.
                backend.project_columns(&s, 0..5, &mut one, Stop::NEVER).unwrap();
                backend
                    .project_columns(&s, 1..g.len(), &mut one, Stop::NEVER)
                    .unwrap();
                assert_eq!(one.len(), all.len(), "{what}, {}", metric.name());
                same_column(&one, &all, metric, &what);
                for other in Metric::all().filter(|&m| m != metric) {
                    assert!(
                        column_bits(&one, other).is_empty(),
                        "{what}: {} kept, {} column not empty",
                        metric.name(),
                        other.name()
                    );
                }
            }
        }
    }
}

/// A sweep's blocks projected one after the other ([`Backend::project_blocks`]: on the GPU the
/// next block already on the device while a block is handed out) are each block's own columns,
/// bit for bit, on every backend, with gaps between blocks (a resumed sweep's) and columns kept
/// alone; a `Break` ends the run at once; bad blocks and stops are errors.
#[test]
fn blocks_are_each_blocks_own_columns() {
    use std::ops::ControlFlow;
    let backends = every_backend();
    let (source, target) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let g = grid(&source, &target, false);
    let s = sweep(&source, &target, Sampling::Step(1.0), PoseSource::Grid(&g));
    let n = g.len();
    let blocks = [0..5, 5..100, 100..101, 300..n - 1];
    for backend in &backends {
        for keep in [None, Some(Metric::Span)] {
            let what = format!("{}, keeping {keep:?}", backend.name());
            let fresh = || keep.map_or_else(MetricColumns::default, |m| MetricColumns::only(&[m]));
            let mut seen = Vec::new();
            let mut out = fresh();
            let flow = backend
                .project_blocks(&s, &blocks, &mut out, Stop::NEVER, &mut |b, columns| {
                    seen.push((b, columns.clone()));
                    ControlFlow::Continue(())
                })
                .unwrap();
            assert!(flow.is_continue(), "{what}");
            assert_eq!(
                seen.iter().map(|(b, _)| b.clone()).collect::<Vec<_>>(),
                blocks,
                "{what}"
            );
            // Each block's columns are the backend's own for that block alone.
            for (b, columns) in &seen {
                let mut alone = fresh();
                backend
                    .project_columns(&s, b.clone(), &mut alone, Stop::NEVER)
                    .unwrap();
                assert_eq!(columns.len() as u64, b.end - b.start, "{what}: {b:?}");
                for m in Metric::all() {
                    same_column(columns, &alone, m, &format!("{what}: {b:?}"));
                }
            }
            // A break after the second block: no third.
            let mut calls = 0;
            let flow = backend
                .project_blocks(&s, &blocks, &mut out, Stop::NEVER, &mut |_, _| {
                    calls += 1;
                    if calls == 2 {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                })
                .unwrap();
            assert!(
                flow.is_break() && calls == 2,
                "{what}: {calls} blocks after a break"
            );
        }
        let (empty, past) = (4..4, 0..n + 1);
        for bad in [vec![0..5, 3..9], vec![empty], vec![past], vec![9..12, 0..3]] {
            let e = backend
                .project_blocks(
                    &s,
                    &bad,
                    &mut MetricColumns::default(),
                    Stop::NEVER,
                    &mut |_, _| ControlFlow::Continue(()),
                )
                .unwrap_err();
            assert!(
                e.is_input() && e.to_string().contains("pose blocks"),
                "{bad:?}: {e}"
            );
        }
        // A stop ends the stream as its sink's Break does: the flow it returns says so.
        let stop_after_one = std::sync::atomic::AtomicUsize::new(0);
        let signal = || stop_after_one.load(std::sync::atomic::Ordering::Relaxed) > 0;
        let flow = backend
            .project_blocks(
                &s,
                &blocks,
                &mut MetricColumns::default(),
                Stop::when(&signal),
                &mut |_, _| {
                    stop_after_one.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    ControlFlow::Continue(())
                },
            )
            .unwrap();
        assert!(flow.is_break(), "{}: a stop is a Break", backend.name());
        assert_eq!(
            stop_after_one.into_inner(),
            1,
            "{}: blocks after a stop",
            backend.name()
        );
    }
}

#[test]
fn bad_ranges_and_stops_are_errors() {
    let (source, target) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let g = grid(&source, &target, true);
    let s = sweep(&source, &target, Sampling::Step(1.0), PoseSource::Grid(&g));
    let mut out = MetricColumns::default();
    for backend in [Backend::Cpu, Backend::CpuFast] {
        let e = backend
            .project_columns(&s, 0..g.len() + 1, &mut out, Stop::NEVER)
            .unwrap_err();
        assert!(e.is_input() && e.to_string().contains("pose range"), "{e}");
        let e = backend
            .project_columns(&s, 0..g.len(), &mut out, Stop::when(&|| true))
            .unwrap_err();
        assert!(matches!(e, Error::Stopped), "{e}");
    }
    // A grid checked against one sonar is checked again against the sweep's sonar 1.
    let narrow = common::preset("paper-sss");
    let s = sweep(&narrow, &target, Sampling::Step(1.0), PoseSource::Grid(&g));
    let e = Backend::CpuFast
        .project_columns(&s, 0..1, &mut out, Stop::NEVER)
        .unwrap_err();
    assert!(e.is_input() && e.to_string().contains("grid axis"), "{e}");
}

/// The GPU's device-decoded grids (the poses stage) lie in the reference's envelope on every
/// preset pair, with their occupancy; their columns are those projections' metrics; and they do
/// not depend on how the poses are cut into chunks (the digits carried across chunk starts).
#[test]
fn device_decoded_grids_lie_in_the_reference_envelope() {
    let Some(gpu) = common::gpu() else {
        return;
    };
    let small = || sonarproj_testkit::gpu_backend_on(gpu.context().clone()).with_max_chunk_poses(7);
    let names = Sonar::preset_names();
    let mut visible = 0;
    for a in &names {
        for b in &names {
            let (source, target) = (Sonar::preset(a).unwrap(), Sonar::preset(b).unwrap());
            // Automatic sampling on the arcs too: a plan per feature range (a table the poses
            // stage reads by the range's digit).
            let samplings: &[Sampling] = if source.kind == sonarproj::SonarKind::Fls {
                &[Sampling::Step(1.0), Sampling::Auto]
            } else {
                &[Sampling::Step(1.0)]
            };
            for (placement, &sampling) in [true, false]
                .into_iter()
                .flat_map(|p| samplings.iter().map(move |s| (p, s)))
            {
                let g = grid(&source, &target, placement);
                let s = sweep(&source, &target, sampling, PoseSource::Grid(&g));
                let what = format!("{a} -> {b}, placement {placement}, {sampling:?}");
                let (got, _) = device_grid_in_envelope(&gpu, &s, &what, Output::WithOccupancy);
                visible += got.iter().filter(|p| p.metrics.visible > 0).count();
                // The columns are the metrics of the same path, whatever the chunks.
                for backend in [sonarproj_testkit::gpu_backend_on(gpu.context().clone()), small()] {
                    let mut columns = MetricColumns::default();
                    Backend::Gpu(Box::new(backend))
                        .project_columns(&s, 3..g.len(), &mut columns, Stop::NEVER)
                        .unwrap();
                    assert_eq!(columns.len() as u64, g.len() - 3, "{what}");
                    for k in 0..columns.len() {
                        assert_eq!(columns.get(k), got[k + 3].metrics, "{what}, pose {}", k + 3);
                    }
                }
                let cut = sonarproj::test_support::gpu_grid_projections(&small(), &s, 0..g.len()).unwrap();
                assert_eq!(cut.len(), got.len(), "{what}");
                for (k, (p, q)) in got.iter().zip(&cut).enumerate() {
                    // Compared whole (occupancy too), printed by their metrics.
                    assert!(
                        p == q,
                        "{what}, pose {k}, chunks of 7: {:?} vs {:?}",
                        p.metrics,
                        q.metrics
                    );
                }
            }
        }
    }
    assert!(visible > 1000, "{visible} poses saw anything");
}

/// A chunk of more than 65 535 poses (the most workgroups one dispatch dimension may have on
/// most devices) is spread over two dimensions: 70 000 fls->sss poses in one chunk, three samples
/// each, every one in the reference's envelope.
#[test]
fn a_chunk_of_more_poses_than_one_dispatch_dimension_holds() {
    let Some(gpu) = common::gpu() else {
        return;
    };
    let (source, target) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let step = |n: usize, d: f64| (0..n).map(|i| i as f64 * d).collect::<Vec<f64>>();
    let axes = [
        vec![5.0],
        vec![0.0],
        vec![0.0],
        vec![10.0],
        vec![0.0],
        vec![0.0],
        step(70, 5.0),
        step(50, 3.6),
        step(20, 18.0),
    ];
    let g = PoseGrid::new(axes, true, &source).unwrap();
    assert_eq!(g.len(), 70_000);
    let s = sweep(&source, &target, Sampling::Step(6.0), PoseSource::Grid(&g));
    let (got, want) = device_grid_in_envelope(&gpu, &s, "70 000 poses", Output::MetricsOnly);
    let seen = got.iter().filter(|p| p.metrics.visible > 0).count();
    // Poses past the first dimension's 65 535 were drawn (a pose left undrawn would be empty and
    // fail its envelope where the reference sees something).
    assert!(want[65_535..].iter().any(|w| w.metrics.visible > 0));
    assert!(seen > 10_000, "{seen} poses saw anything");
}

/// The device's own clock times the compute passes (what `bench sweep` reports as device time):
/// nothing is counted before timing starts, a projection then counts a positive time no longer
/// than the call took on the host's clock, and stopping keeps the sum (lavapipe has timestamp
/// queries; an adapter without them reports none). The host's waits and unpacking beside them
/// (`host_time`) are counted the same way, and together fit in the call too. The device time is
/// split by stage (`device_stages`), and timing does not change the results.
#[test]
fn device_time_is_counted_only_while_asked_and_within_the_call() {
    let Some(gpu) = common::gpu() else {
        return;
    };
    let gpu = Backend::Gpu(Box::new(gpu));
    let Backend::Gpu(g) = &gpu else {
        unreachable!("made above")
    };
    let (source, target) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let grid = grid(&source, &target, true);
    let s = sweep(&source, &target, Sampling::Step(0.5), PoseSource::Grid(&grid));
    let mut out = MetricColumns::default();
    g.time_device(false);
    gpu.project_columns(&s, 0..grid.len(), &mut out, Stop::NEVER)
        .unwrap();
    let Some(before) = g.device_time() else {
        assert!(!g.context().features().contains(wgpu::Features::TIMESTAMP_QUERY));
        return;
    };
    g.time_device(true);
    assert_eq!(
        g.device_time(),
        Some(std::time::Duration::ZERO),
        "{before:?} kept"
    );
    assert_eq!(
        g.host_time(),
        HostTime::default(),
        "host time counted before timing"
    );
    let start = std::time::Instant::now();
    gpu.project_columns(&s, 0..grid.len(), &mut out, Stop::NEVER)
        .unwrap();
    let wall = start.elapsed();
    let (device, host) = (g.device_time().unwrap(), g.host_time());
    let stages = g.device_stages().unwrap();
    g.time_device(false);
    assert!(
        device > std::time::Duration::ZERO && device <= wall,
        "device {device:?}, call {wall:?}"
    );
    // A pass a stage, each between its own timestamps: the grid's poses decoded, the samples
    // splatted, the bits reduced. Together they are the device time.
    let zero = std::time::Duration::ZERO;
    assert!(
        stages.poses > zero && stages.splat > zero && stages.reduce > zero,
        "{stages:?}"
    );
    assert_eq!(stages.total(), device, "{stages:?}");
    // Timing splits the passes, and the results are the same (Debug: NaN, where nothing is
    // seen, is equal to itself there).
    let timed = format!("{out:?}");
    gpu.project_columns(&s, 0..grid.len(), &mut out, Stop::NEVER)
        .unwrap();
    assert!(timed == format!("{out:?}"), "timing changed the results");
    assert!(
        host.wait > std::time::Duration::ZERO
            && host.unpack > std::time::Duration::ZERO
            && host.wait + host.unpack <= wall,
        "host {host:?}, call {wall:?}"
    );
    assert_eq!(g.device_time(), Some(device), "counted while stopped");
    assert_eq!(g.host_time(), host, "host time counted while stopped");
}

/// Returns the GPU's device-decoded projections of `s`'s grid (with their occupancy) and the
/// reference's (with it when `output` asks), after holding every GPU result to the envelope the
/// reference computes for its pose (at the tolerance of the GPU's precision).
fn device_grid_in_envelope(
    gpu: &sonarproj::projection::gpu::GpuBackend,
    s: &PoseSweep<'_>,
    what: &str,
    output: Output,
) -> (Vec<sonarproj::Projection>, Vec<sonarproj::Projection>) {
    use sonarproj::gpu::Precision;
    use sonarproj::projection::{envelope, reference};
    let tolerance = match gpu.context().precision() {
        Precision::F64 => envelope::INPUT_TOLERANCE,
        Precision::DoubleF32 => envelope::DOUBLE_F32_TOLERANCE,
    };
    let n = s.poses.len();
    let got = sonarproj::test_support::gpu_grid_projections(gpu, s, 0..n).unwrap();
    let batch = s.batch(0..n).unwrap();
    let prepared = batch.prepare().unwrap();
    let want = reference::project(&prepared, output);
    assert_eq!(got.len(), want.len(), "{what}");
    for (k, (w, p)) in want.iter().zip(&got).enumerate() {
        let item = &batch.items[k];
        let bounds = envelope::bounds_with(
            prepared.layout(),
            prepared.plan(k),
            prepared.base_azimuth(k),
            item.measurement.range,
            &item.pose,
            tolerance,
        );
        common::check_within_bounds(prepared.layout(), &bounds, p).unwrap_or_else(|e| {
            panic!(
                "{what}, pose {k}: {e}\nreference {:?}\ngpu {:?}",
                w.metrics, p.metrics
            )
        });
    }
    (got, want)
}

/// Only a GPU with 64-bit atomics reduces on the device. The CPU backends say so, naming what to
/// do instead, and never panic.
#[test]
fn the_cpu_backends_do_not_reduce_on_the_device() {
    use sonarproj::projection::reduction::MetricReduction;
    let source = Sonar::preset("paper-fls").unwrap();
    let target = Sonar::preset("paper-sss").unwrap();
    let g = grid(&source, &target, true);
    let s = sweep(&source, &target, Sampling::Step(5.0), PoseSource::Grid(&g));
    let reduction = MetricReduction {
        metric: Metric::Span,
        top: 1,
        histogram: None,
        cells: Vec::new(),
    };
    for backend in [Backend::Cpu, Backend::CpuFast] {
        assert!(!backend.reduces_on_device(&s));
        let e = backend
            .reduce_blocks(
                &s,
                std::slice::from_ref(&(0..10)),
                &reduction,
                Stop::NEVER,
                &mut |_, _| std::ops::ControlFlow::Continue(()),
            )
            .unwrap_err();
        assert!(matches!(e, Error::Input { .. }), "{e}");
        assert!(
            e.to_string().contains("project its columns and reduce them"),
            "{e}"
        );
    }
}

/// Returns pairs over some of `g`'s poses and features, in a scrambled order with repeats (a
/// pose with several features, a feature from several poses), and the items they stand for.
fn pairs_of(g: &PoseGrid, source: &Sonar, n: u64) -> (sonarproj::PosePairs, Vec<sonarproj::BatchItem>) {
    let items: Vec<_> = (0..g.len()).map(|i| g.item(source, i).unwrap()).collect();
    let poses: Vec<_> = items.iter().step_by(7).map(|i| i.pose).collect();
    let features: Vec<_> = items.iter().step_by(5).map(|i| i.measurement).collect();
    let (np, nf) = (poses.len() as u64, features.len() as u64);
    // Two co-prime strides walk every pose and feature in a mixed order.
    let pairs: Vec<[u32; 2]> = (0..n)
        .map(|k| [(k * 11 + k / 3) % np, (k * 7 + k / 5) % nf].map(|i| u32::try_from(i).unwrap()))
        .collect();
    let list = pairs
        .iter()
        .map(|&[p, f]| sonarproj::BatchItem {
            true_point: None,
            measurement: features[f as usize],
            pose: poses[p as usize],
        })
        .collect();
    (sonarproj::PosePairs::new(poses, features, pairs).unwrap(), list)
}

/// Returns the GPU opened without f64 in its shaders (double-f32) where an adapter exists: its
/// exact calls go to the fast CPU twin, as a device without f64 sends them.
fn gpu_without_f64() -> Option<Backend> {
    common::gpu_context()?;
    let options = sonarproj::GpuOptions {
        precision: Some(sonarproj::gpu::Precision::DoubleF32),
        ..common::gpu_options()
    };
    let ctx = sonarproj::gpu::GpuContext::open(&options).expect("the adapter opens in double-f32");
    let gpu = common::gpu_backend_on(ctx);
    assert!(
        !gpu.solves_exact(),
        "double-f32 solves no exact call on the device"
    );
    Some(Backend::Gpu(Box::new(gpu)))
}

/// Pairs of poses and features project as the items they stand for, bit for bit, on every
/// backend (the GPU in one chunk and in chunks of 7, and opened without f64): every preset pair of
/// the paper's sonars and the field's, step and automatic sampling (several plans: features at
/// several ranges) and exact arcs (an imaging sonar 1's), all columns and each column alone,
/// whole, in cut ranges and in blocks (across the fast paths' blocks of 256 poses).
#[test]
fn pairs_project_as_their_items_on_every_backend() {
    use std::ops::ControlFlow;
    let mut backends = every_backend();
    backends.extend(gpu_without_f64());
    let mut visible = 0;
    for (a, b) in [
        ("paper-fls", "paper-sss"),
        ("paper-sss", "paper-fls"),
        ("paper-fls", "paper-fls"),
        ("holoocean-imaging", "holoocean-sidescan"),
    ] {
        let (source, target) = (common::preset(a), common::preset(b));
        let g = grid(&source, &target, false);
        let (pairs, items) = pairs_of(&g, &source, 600);
        for sampling in [Sampling::Step(1.0), Sampling::Auto, Sampling::Exact] {
            if sampling != Sampling::Step(1.0) && source.kind == sonarproj::SonarKind::Sss {
                continue;
            }
            let s = sweep(&source, &target, sampling, PoseSource::Pairs(&pairs));
            let list = sweep(&source, &target, sampling, PoseSource::List(&items));
            for backend in &backends {
                let what = format!("{a} -> {b}, {sampling:?}, {}", backend.name());
                let want = per_item(backend, &list);
                let mut got = MetricColumns::default();
                backend
                    .project_columns(&s, 0..pairs.len(), &mut got, Stop::NEVER)
                    .unwrap();
                same_bits(&got, &want, &what);
                visible += got.visible.iter().filter(|&&v| v > 0).count();
                // Each column alone: what a solver leaves out changes none of it.
                for metric in Metric::all() {
                    let mut alone = MetricColumns::only(&[metric]);
                    backend
                        .project_columns(&s, 0..pairs.len(), &mut alone, Stop::NEVER)
                        .unwrap();
                    same_column(&alone, &want, metric, &format!("{what}: {} alone", metric.name()));
                }
                // A column alone, in ranges cut anywhere and in blocks.
                let mut part = MetricColumns::only(&[Metric::Span]);
                for r in [0..1, 1..300, 300..600] {
                    backend
                        .project_columns(&s, r.clone(), &mut part, Stop::NEVER)
                        .unwrap();
                    let mut rows = MetricColumns::only(&[Metric::Span]);
                    r.clone()
                        .for_each(|k| rows.push(&want.get(usize::try_from(k).unwrap())));
                    same_column(&part, &rows, Metric::Span, &format!("{what}: {r:?}"));
                }
                let blocks = [0..3, 3..300, 301..600];
                let mut seen = 0;
                let flow = backend
                    .project_blocks(&s, &blocks, &mut part, Stop::NEVER, &mut |r, columns| {
                        let mut rows = MetricColumns::only(&[Metric::Span]);
                        r.clone()
                            .for_each(|k| rows.push(&want.get(usize::try_from(k).unwrap())));
                        same_column(columns, &rows, Metric::Span, &format!("{what}: block {r:?}"));
                        seen += 1;
                        ControlFlow::Continue(())
                    })
                    .unwrap();
                assert!(flow.is_continue() && seen == 3, "{what}: {seen} blocks");
            }
        }
    }
    // The pairs see their sets from many sides: most see something.
    assert!(visible > 500, "{visible} pairs saw anything");
}

/// Pairs name what is wrong with them: an index past its table when made, a pose or a feature
/// the sonars refuse when projected (by its index in its table), on every backend.
#[test]
fn bad_pairs_name_their_index() {
    let (source, target) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let g = grid(&source, &target, false);
    let (pairs, _) = pairs_of(&g, &source, 20);
    let (poses, features) = (pairs.poses().to_vec(), pairs.features().to_vec());
    let mut bad = pairs.pairs().to_vec();
    bad[3][1] = u32::try_from(features.len()).unwrap();
    let e = sonarproj::PosePairs::new(poses.clone(), features.clone(), bad).unwrap_err();
    assert!(
        e.is_input() && e.to_string().contains("pairs[3] feature index"),
        "{e}"
    );
    // The first pair's pose and feature, made invalid.
    let [p0, f0] = pairs.pairs()[0].map(|i| i as usize);
    let mut wide = features.clone();
    wide[f0].azimuth = 170.0;
    let mut skewed = poses.clone();
    skewed[p0].rotation *= 1.5;
    for (p, f, field) in [
        (poses.clone(), wide, format!("features[{f0}]")),
        (skewed, features.clone(), format!("poses[{p0}]")),
    ] {
        let pairs = sonarproj::PosePairs::new(p, f, pairs.pairs().to_vec()).unwrap();
        for sampling in [Sampling::Step(1.0), Sampling::Exact] {
            let s = sweep(&source, &target, sampling, PoseSource::Pairs(&pairs));
            for backend in every_backend() {
                let what = format!("{sampling:?}, {}", backend.name());
                let e = backend
                    .project_columns(&s, 0..pairs.len(), &mut MetricColumns::default(), Stop::NEVER)
                    .unwrap_err();
                assert!(e.is_input(), "{what}: {e}");
                // The reference checks the items themselves, the tables each pose and feature
                // once.
                if !matches!(backend, Backend::Cpu) {
                    assert!(e.to_string().contains(&field), "{what}: {e}");
                }
            }
        }
    }
}
