//! CPU reference, fast CPU path and GPU on the same batches (criterion).
//! `cargo bench --bench projection`.
//! The GPU group is left out when no adapter exists.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sonarproj::gpu::{GpuBackend, GpuContext};
use sonarproj::{Batch, BatchItem, Measurement, RelativePose, Rotation, Sampling, Sonar, cpu, cpu_fast};

/// Returns `n` placement poses of the paper's kind (features at half range, rotations spread
/// over the sphere) from `from` to `to`.
fn batch(from: &str, to: &str, n: usize) -> Batch {
    let (source, target) = (Sonar::preset(from).unwrap(), Sonar::preset(to).unwrap());
    let items = (0..n)
        .map(|k| {
            let a = k as f64 * 360.0 / n as f64;
            let rot = Rotation::RollPitchYaw {
                roll: a,
                pitch: a * 0.5 - 90.0,
                yaw: 180.0 - a,
            };
            let f = [source.range_max / 2.0, 0.0, 0.0];
            let pose = RelativePose::placement(rot, f, [target.range_max / 2.0, 0.0, 0.0]).unwrap();
            BatchItem {
                measurement: Measurement::of(&source, f[0], 0.0).unwrap(),
                pose,
            }
        })
        .collect();
    Batch {
        source,
        target,
        sampling: Sampling::Step(0.1),
        items,
    }
}

fn projection(c: &mut Criterion) {
    let gpu = GpuContext::new().ok().map(GpuBackend::new);
    for (from, to, n) in [("paper-fls", "paper-sss", 2000), ("paper-sss", "paper-fls", 200)] {
        let b = batch(from, to, n);
        let prepared = b.prepare().unwrap();
        let samples: usize = prepared.plan_of.iter().map(|&p| prepared.plans[p].total()).sum();
        let mut group = c.benchmark_group(format!("{from}->{to} x{n}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(samples as u64));
        group.bench_function("cpu-reference", |bench| {
            bench.iter(|| cpu::project(&prepared, false))
        });
        group.bench_function("cpu-fast", |bench| {
            bench.iter(|| cpu_fast::project(&prepared, false))
        });
        if let Some(g) = &gpu {
            group.bench_function("gpu", |bench| bench.iter(|| g.project(&prepared, false).unwrap()));
        }
        group.finish();
    }
}

criterion_group!(benches, projection);
criterion_main!(benches);
