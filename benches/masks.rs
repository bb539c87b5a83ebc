//! Correspondence-mask latency: one mask and a 100-feature ping for each of the mask latency
//! cases, `bench::MASK_CASES` (sidescan to imaging sonar and back), on the fast CPU path. `cargo bench --bench masks`.

use criterion::{Criterion, criterion_group, criterion_main};
use sonarproj::Sonar;
use sonarproj::masks::{Counts, MaskEngine};
use sonarproj_apps::bench;

fn masks(c: &mut Criterion) {
    for (from, to) in bench::MASK_CASES {
        let (s1, s2) = (Sonar::preset(from).unwrap(), Sonar::preset(to).unwrap());
        let engine = MaskEngine::new(s1.clone(), s2.clone()).unwrap();
        let mut group = c.benchmark_group(format!("mask {from}->{to}"));
        for n in [1, 100] {
            let (pose, features) = bench::mask_ping(&s1, &s2, n).unwrap();
            group.bench_function(format!("cpu-fast, {n} feature(s)"), |b| {
                b.iter(|| engine.masks(&pose, &features, None, Counts::Skip).unwrap())
            });
        }
        group.finish();
    }
}

criterion_group! {
    name = benches;
    // No HTML plots: plotters is built with only our embedded font, which criterion does not load.
    config = Criterion::default().without_plots();
    targets = masks
}
criterion_main!(benches);
