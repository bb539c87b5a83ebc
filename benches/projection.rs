//! CPU reference, fast CPU path and GPU on the same batches (criterion).
//! `cargo bench --bench projection`.
//! The GPU group is left out when no adapter exists.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;
use sonarproj::gpu::GpuContext;
use sonarproj::metrics::{Extremes, Metrics};
use sonarproj::projection::{PoseGrid, Projection, fast, reference};
use sonarproj::stream::Stop;
use sonarproj::{Backend, MetricColumns, Output, PoseSource, PoseSweep, Sampling, Sonar};
use sonarproj_apps::bench;

fn projection(c: &mut Criterion) {
    let gpu = GpuContext::open(&sonarproj_testkit::gpu_options())
        .ok()
        .map(sonarproj_testkit::gpu_backend_on);
    for (from, to, n) in bench::STANDARD {
        let b = bench::batch(&Sonar::preset(from).unwrap(), &Sonar::preset(to).unwrap(), n).unwrap();
        let prepared = b.prepare().unwrap();
        let samples: usize = prepared.total_samples();
        let mut group = c.benchmark_group(format!("{from}->{to} x{n}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(samples as u64));
        group.bench_function("cpu-reference", |bench| {
            bench.iter(|| reference::project(&prepared, Output::MetricsOnly))
        });
        group.bench_function("cpu-fast", |bench| {
            bench.iter(|| fast::project(&prepared, Output::MetricsOnly))
        });
        if let Some(g) = &gpu {
            group.bench_function("gpu", |bench| {
                bench.iter(|| g.project(&prepared, Output::MetricsOnly).unwrap())
            });
        }
        group.finish();
    }
}

/// What `Batch::prepare` costs, validation of every item's measurement and pose included, on
/// 100 000 poses (every backend's `project` begins with it).
fn prepare(c: &mut Criterion) {
    let (from, to) = ("paper-fls", "paper-sss");
    let b = bench::batch(
        &Sonar::preset(from).unwrap(),
        &Sonar::preset(to).unwrap(),
        100_000,
    )
    .unwrap();
    let mut group = c.benchmark_group(format!("prepare {from}->{to} x100000"));
    group.sample_size(10);
    group.throughput(Throughput::Elements(100_000));
    group.bench_function("prepare", |bench| {
        bench.iter(|| b.prepare().unwrap().plans().len())
    });
    group.bench_function("validate items", |bench| {
        bench.iter(|| {
            b.items
                .iter()
                .all(|i| i.measurement.validate(&b.source).is_ok() && i.pose.validate().is_ok())
        })
    });
    group.finish();
}

/// What returning results costs, whatever computes them: 1 000 000 `Projection`s (metrics only,
/// trivial values) collected on all cores into a fresh vector, as every backend's `project`
/// returns them (the bench's fls→sss batch is 1 000 000 poses).
fn results(c: &mut Criterion) {
    let mut group = c.benchmark_group("results x1000000");
    group.sample_size(10);
    group.throughput(Throughput::Elements(1_000_000));
    // Dropped outside the timing (freeing the vector is the caller's business).
    group.bench_function("collect", |bench| {
        bench.iter_with_large_drop(|| {
            (0..1_000_000u64)
                .into_par_iter()
                .map(|k| Projection {
                    local: Default::default(),
                    metrics: Metrics::new(k % 7, 121, Extremes::default(), (k % 5, 0.1), None),
                    occupancy: None,
                    cells: None,
                })
                .collect::<Vec<_>>()
        })
    });
    group.finish();
}

/// One small call after another on one GPU backend (a live mask or a robot's query loop): with
/// the buffers it keeps between calls, and with them freed before each call as every call did
/// before they were kept.
fn small_calls(c: &mut Criterion) {
    let Ok(ctx) = GpuContext::open(&sonarproj_testkit::gpu_options()) else {
        return;
    };
    let gpu = sonarproj_testkit::gpu_backend_on(ctx);
    let (from, to) = ("paper-sss", "paper-fls");
    let b = bench::batch(&Sonar::preset(from).unwrap(), &Sonar::preset(to).unwrap(), 4).unwrap();
    let prepared = b.prepare().unwrap();
    let mut group = c.benchmark_group(format!("gpu calls {from}->{to} x4"));
    group.sample_size(20);
    group.bench_function("kept buffers", |bench| {
        bench.iter(|| gpu.project(&prepared, Output::WithOccupancy).unwrap())
    });
    group.bench_function("new buffers", |bench| {
        bench.iter(|| {
            gpu.release_buffers();
            gpu.project(&prepared, Output::WithOccupancy).unwrap()
        })
    });
    group.finish();
}

/// Grid calls on the fast CPU path, small (181 poses: a figure's curve, a viewer's scene) and
/// large (16 384): poses a second, so the two read side by side. A small call pays for waking
/// the pool's threads and building its tables, so its rate is lower.
fn grid_calls(c: &mut Criterion) {
    let (source, target) = (
        Sonar::preset("paper-fls").unwrap(),
        Sonar::preset("paper-sss").unwrap(),
    );
    for n in [181usize, 16_384] {
        let roll: Vec<f64> = (0..n).map(|k| k as f64 * 180.0 / n as f64).collect();
        let axes = [
            vec![5.0],
            vec![0.0],
            vec![0.0],
            vec![10.0],
            vec![0.0],
            vec![0.0],
            roll,
            vec![0.0],
            vec![0.0],
        ];
        let grid = PoseGrid::new(axes, true, &source).unwrap();
        let sweep = PoseSweep {
            source: source.clone(),
            target: target.clone(),
            sampling: Sampling::Step(0.1),
            area_grid: sonarproj::PAPER_AREA_GRID,
            poses: PoseSource::Grid(&grid),
        };
        let mut out = MetricColumns::default();
        let mut group = c.benchmark_group(format!("cpu-fast grid call x{n}"));
        group.sample_size(20);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function("project_columns", |bench| {
            bench.iter(|| {
                Backend::CpuFast
                    .project_columns(&sweep, 0..n as u64, &mut out, Stop::NEVER)
                    .unwrap()
            })
        });
        group.finish();
    }
}

criterion_group! {
    name = benches;
    // No HTML plots: plotters is built with only our embedded font, which criterion does not load.
    config = Criterion::default().without_plots();
    targets = projection, prepare, results, small_calls, grid_calls
}
criterion_main!(benches);
