//! CPU reference vs GPU and fast CPU path on random poses: for each of the four sonar pairs and
//! several presets, 1000 random configurations, every result inside the envelope the reference
//! computes for it
//! (docs/gpu.md, "How the GPU is checked": bin-exact except samples within 1e-5 relative of a clip bound or bin edge), and
//! the number of pixels where the two differ never above the number of such samples.

use sonarproj_testkit as common;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sonarproj::gpu::Precision;
use sonarproj::projection::gpu::{GpuBackend, SPLAT_WORKGROUPS, SplatOptions};
use sonarproj::projection::{PreparedBatch, envelope, fast, reference};
use sonarproj::{
    Batch, BatchItem, BeamLayout, Measurement, RelativePose, Rotation, Sampling, Sonar, SonarKind,
};
use sonarproj::{Output, Projection};

const POSES: usize = 1000;

/// Returns a random point `[range, azimuth, elevation]` inside `s`'s field of view.
fn point_in(rng: &mut ChaCha8Rng, s: &Sonar) -> [f64; 3] {
    let (ha, he) = (s.azimuth_aperture / 2.0, s.elevation_aperture / 2.0);
    [
        rng.random_range(s.range_min.max(0.05)..=s.range_max),
        rng.random_range(-ha..=ha),
        rng.random_range(-he..=he),
    ]
}

/// Returns `n` random items from `source` to `target`: mostly placements of a random feature
/// at a random place in sonar 2 under a random rotation, one in ten a random translation (often
/// nothing visible).
fn random_items(seed: u64, source: &Sonar, target: &Sonar, n: usize) -> Vec<BatchItem> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|k| {
            let feature = point_in(&mut rng, source);
            let rotation = Rotation::RollPitchYaw {
                roll: rng.random_range(-180.0..180.0),
                pitch: rng.random_range(-180.0..180.0),
                yaw: rng.random_range(-180.0..180.0),
            };
            let pose = if k % 10 == 9 {
                let r = target.range_max;
                let t = [(); 3].map(|_| rng.random_range(-r..r));
                RelativePose::new(rotation, t).unwrap()
            } else {
                RelativePose::placement(rotation, feature, point_in(&mut rng, target)).unwrap()
            };
            BatchItem {
                true_point: None,
                measurement: Measurement::of(source, feature[0], feature[1]).unwrap(),
                pose,
            }
        })
        .collect()
}

/// An FLS with non-uniform beams (denser at the centre, as real ones are).
fn nonuniform_fls() -> Sonar {
    let n = 256;
    let edges = (0..=n)
        .map(|k| {
            let u = -1.0 + 2.0 * k as f64 / n as f64;
            45.0 * (u + 0.3 * u * u * u) / 1.3
        })
        .collect();
    Sonar {
        name: "nonuniform".into(),
        kind: SonarKind::Fls,
        range_min: 0.5,
        range_max: 20.0,
        azimuth_aperture: 90.0,
        elevation_aperture: 20.0,
        range_bins: 780,
        beams: BeamLayout::Edges(edges),
    }
}

/// An FLS that sees everything: 360° azimuth, 180° elevation, range from 0.
fn omni_fls() -> Sonar {
    Sonar {
        name: "omni".into(),
        kind: SonarKind::Fls,
        range_min: 0.0,
        range_max: 12.0,
        azimuth_aperture: 360.0,
        elevation_aperture: 180.0,
        range_bins: 600,
        beams: BeamLayout::Uniform { count: 720 },
    }
}

/// Runs `poses` random configurations on the reference and checks every result of the fast
/// CPU path and (where an adapter exists; always in CI) the GPU against the reference's envelope.
fn agree(seed: u64, source: Sonar, target: Sonar, sampling: Sampling, poses: usize) {
    let items = random_items(seed, &source, &target, poses);
    agree_on(items, source, target, sampling);
}

/// Checks every result of the fast CPU path and (where an adapter exists; always in CI) every
/// variant of the GPU's splat stage on `items` against the reference's envelope.
fn agree_on(items: Vec<BatchItem>, source: Sonar, target: Sonar, sampling: Sampling) {
    source.validate().unwrap();
    target.validate().unwrap();
    let poses = items.len();
    let batch = Batch {
        sigma_range: None,
        items,
        source,
        target,
        sampling,
        area_grid: sonarproj::PAPER_AREA_GRID,
    };
    let prepared = batch.prepare().unwrap();
    let reference = reference::project(&prepared, Output::WithOccupancy);
    let mut checked = vec![("cpu-fast", fast::project(&prepared, Output::WithOccupancy))];
    if let Some(gpu) = common::gpu() {
        let results = gpu.project(&prepared, Output::WithOccupancy).unwrap();
        // Culling skips samples and clip tests, the f32 filter decides samples in f32 that Real
        // would decide the same way: neither changes a decision, so every variant of the splat
        // stage gives the very same bits.
        let workgroup = gpu.options().workgroup;
        for cull in [false, true] {
            for filter in [false, true] {
                let options = SplatOptions {
                    cull,
                    filter,
                    workgroup,
                };
                if options == gpu.options() {
                    continue;
                }
                let variant = GpuBackend::with_options(gpu.context().clone(), options).unwrap();
                assert_eq!(
                    variant.project(&prepared, Output::WithOccupancy).unwrap(),
                    results,
                    "GPU, {} against {}",
                    options.describe(),
                    gpu.options().describe()
                );
            }
        }
        checked.push(("gpu", results));
    }
    // The envelopes at an input tolerance: f64 decisions (the CPU paths, a GPU with f64) or a
    // GPU deciding in double-f32, which some drivers leave at f32 precision.
    let envelopes_at = |input_tolerance: f64| -> Vec<_> {
        (0..poses)
            .map(|k| {
                let item = &batch.items[k];
                envelope::bounds_with(
                    prepared.layout(),
                    prepared.plan(k),
                    prepared.base_azimuth(k),
                    item.measurement.range,
                    &item.pose,
                    input_tolerance,
                )
            })
            .collect()
    };
    let envelopes = envelopes_at(envelope::INPUT_TOLERANCE);
    let gpu_envelopes = common::gpu().map(|g| match g.context().precision() {
        Precision::F64 => envelopes.clone(),
        Precision::DoubleF32 => envelopes_at(envelope::DOUBLE_F32_TOLERANCE),
    });
    let visible: u64 = reference.iter().map(|c| c.metrics.visible).sum();
    // The reference lies in its own envelope (a check of the envelope).
    for (k, (c, b)) in reference.iter().zip(&envelopes).enumerate() {
        common::check_within_bounds(prepared.layout(), b, c)
            .unwrap_or_else(|e| panic!("pose {k}: reference outside its envelope: {e}"));
    }
    for (name, results) in &checked {
        let envelopes = if *name == "gpu" {
            gpu_envelopes.as_ref().expect("a GPU")
        } else {
            &envelopes
        };
        let near: u64 = envelopes.iter().map(|b| b.near_edge).sum();
        let mut differing = 0;
        for (k, ((c, g), b)) in reference.iter().zip(results).zip(envelopes).enumerate() {
            let item = &batch.items[k];
            common::check_within_bounds(prepared.layout(), b, g).unwrap_or_else(|e| {
                panic!("pose {k} ({item:?}): {name} outside the envelope: {e}\ncpu {c:?}\n{name} {g:?}")
            });
            assert_eq!(c.metrics.total, g.metrics.total);
            let diff = common::differing_pixels(c.occupancy.as_ref().unwrap(), g.occupancy.as_ref().unwrap());
            // A sample near a bin edge that lands on the other side changes two pixels (the
            // one it left, the one it entered), one near a clip bound changes one.
            assert!(
                diff <= 2 * b.near_edge,
                "pose {k}: {name}: {diff} pixels differ, {} samples near an edge",
                b.near_edge
            );
            differing += diff;
        }
        eprintln!(
            "{} -> {}, {name}: {poses} poses, {visible} visible samples, {near} near an edge, {differing} pixels differ",
            batch.source.name, batch.target.name
        );
    }
    assert!(visible > poses as u64, "the random poses must see something");
}

#[test]
fn fls_to_sss() {
    agree(
        1,
        common::preset("paper-fls"),
        common::preset("paper-sss"),
        Sampling::Auto,
        POSES,
    );
    agree(
        2,
        common::preset("oculus-m1200d-hf"),
        common::preset("holoocean-sidescan"),
        Sampling::Step(0.1),
        POSES,
    );
}

#[test]
fn sss_to_fls() {
    agree(
        3,
        common::preset("paper-sss"),
        common::preset("paper-fls"),
        Sampling::Step(0.1),
        POSES,
    );
    agree(
        4,
        common::preset("holoocean-sidescan"),
        common::preset("holoocean-imaging"),
        Sampling::Step(0.1),
        POSES,
    );
    agree(
        5,
        common::preset("paper-sss"),
        nonuniform_fls(),
        Sampling::Step(0.1),
        POSES,
    );
}

#[test]
fn fls_to_fls() {
    agree(
        6,
        common::preset("paper-fls"),
        common::preset("holoocean-imaging"),
        Sampling::Auto,
        POSES,
    );
    agree(
        7,
        common::preset("oculus-m750d"),
        omni_fls(),
        Sampling::Step(0.1),
        POSES,
    );
    agree(
        8,
        common::preset("holoocean-imaging"),
        nonuniform_fls(),
        Sampling::Auto,
        POSES,
    );
}

#[test]
fn sss_to_sss() {
    agree(
        9,
        common::preset("paper-sss"),
        common::preset("holoocean-sidescan"),
        Sampling::Step(0.1),
        POSES,
    );
    agree(
        10,
        common::preset("holoocean-sidescan"),
        common::preset("paper-sss"),
        Sampling::Step(0.1),
        POSES,
    );
}

#[test]
fn auto_sampling_of_surfaces() {
    // Auto sampling draws far more samples from a surface; fewer poses keep the CPU side quick.
    agree(
        11,
        common::preset("paper-sss"),
        common::preset("paper-fls"),
        Sampling::Auto,
        30,
    );
    agree(
        12,
        common::preset("holoocean-sidescan"),
        common::preset("holoocean-imaging"),
        Sampling::Auto,
        10,
    );
}

/// Returns `n` items that each put one sample of `source`'s plan (step sampling at `step`
/// degrees) on a clip bound or a bin or beam edge of `target`, as exactly as f64 places it: a
/// random sample of the plan is the feature, placed under a random rotation at a point of
/// sonar 2 on a random one of its azimuth and elevation bounds (the ±180° seam of a full
/// circle, the poles of a 180° elevation aperture), range bounds, range-bin edges and (FLS)
/// beam edges. Random poses almost never put a sample within f32 precision of a clip
/// bound; these do, so a decision that f32 gets wrong there shows.
fn items_on_bounds(seed: u64, source: &Sonar, target: &Sonar, step: f64, n: usize) -> Vec<BatchItem> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (ha, he) = (target.azimuth_aperture / 2.0, target.elevation_aperture / 2.0);
    let width = (target.range_max - target.range_min) / f64::from(target.range_bins);
    let beam_edges: Vec<f64> = match &target.beams {
        BeamLayout::Uniform { count } => (1..*count)
            .map(|j| -ha + f64::from(j) * target.azimuth_aperture / f64::from(*count))
            .collect(),
        BeamLayout::Edges(edges) => edges[1..edges.len() - 1].to_vec(),
    };
    (0..n)
        .map(|_| {
            let [range, azimuth, _] = point_in(&mut rng, source);
            let measurement = Measurement::of(source, range, azimuth).unwrap();
            let one = Batch {
                sigma_range: None,
                items: vec![BatchItem {
                    true_point: None,
                    measurement,
                    pose: RelativePose::new(
                        Rotation::RollPitchYaw {
                            roll: 0.0,
                            pitch: 0.0,
                            yaw: 0.0,
                        },
                        [0.0; 3],
                    )
                    .unwrap(),
                }],
                source: source.clone(),
                target: target.clone(),
                sampling: Sampling::Step(step),
                area_grid: sonarproj::PAPER_AREA_GRID,
            };
            let plan = one.prepare().unwrap();
            let (az_offsets, elevations) = (&plan.plan(0).azimuths, &plan.plan(0).elevations);
            let az = plan.base_azimuth(0) + az_offsets[rng.random_range(0..az_offsets.len())];
            let el = elevations[rng.random_range(0..elevations.len())];
            let feature = [measurement.range, az.to_degrees(), el.to_degrees()];
            // The place in sonar 2: inside, then one coordinate moved onto a bound or an edge.
            let [mut r, mut a, mut e] = point_in(&mut rng, target);
            match rng.random_range(0..5) {
                0 => a = if rng.random() { ha } else { -ha },
                1 => e = if rng.random() { he } else { -he },
                // (A range_min of 0 is no bound: a point at the origin is never seen.)
                2 if target.range_min > 0.0 && rng.random() => r = target.range_min,
                2 => r = target.range_max,
                3 => r = target.range_min + f64::from(rng.random_range(1..target.range_bins)) * width,
                _ if !beam_edges.is_empty() => a = beam_edges[rng.random_range(0..beam_edges.len())],
                _ => a = if rng.random() { ha } else { -ha },
            }
            let rotation = Rotation::RollPitchYaw {
                roll: rng.random_range(-180.0..180.0),
                pitch: rng.random_range(-180.0..180.0),
                yaw: rng.random_range(-180.0..180.0),
            };
            BatchItem {
                true_point: None,
                measurement,
                pose: RelativePose::placement(rotation, feature, [r, a, e]).unwrap(),
            }
        })
        .collect()
}

#[test]
fn samples_on_bounds_and_edges() {
    for (seed, source, target) in [
        (21, common::preset("paper-fls"), common::preset("paper-sss")),
        (22, common::preset("paper-sss"), common::preset("paper-fls")),
        (
            23,
            common::preset("oculus-m1200d-hf"),
            common::preset("holoocean-imaging"),
        ),
        (24, common::preset("holoocean-sidescan"), nonuniform_fls()),
        // The full circle (its ±180° seam), range_min 0 and no elevation clip.
        (25, common::preset("oculus-m750d"), omni_fls()),
        (26, common::preset("paper-sss"), omni_fls()),
    ] {
        let items = items_on_bounds(seed, &source, &target, 0.1, 300);
        agree_on(items, source, target, Sampling::Step(0.1));
    }
}

#[test]
fn results_do_not_depend_on_the_chunk_size() {
    let Some(gpu) = common::gpu() else { return };
    let (source, target) = (common::preset("paper-sss"), common::preset("paper-fls"));
    let batch = Batch {
        sigma_range: None,
        items: random_items(13, &source, &target, 100),
        source,
        target,
        sampling: Sampling::Step(0.2),
        area_grid: sonarproj::PAPER_AREA_GRID,
    };
    let prepared = batch.prepare().unwrap();
    let whole = gpu.project(&prepared, Output::WithOccupancy).unwrap();
    let gpu = gpu.with_max_chunk_poses(7);
    let chunked = gpu.project(&prepared, Output::WithOccupancy).unwrap();
    assert_eq!(whole, chunked);
}

/// A backend keeps its buffers and bind groups between calls: after a small batch, a larger one
/// (its buffers grown, its bind groups made again over them), the small one again (the larger
/// buffers kept), and the larger one in chunks of 64 (both slots of chunks in flight, the
/// second's groups made on the kept buffers) give the results of backends that never ran
/// before.
#[test]
fn a_backend_reused_across_batch_sizes_gives_a_fresh_backends_results() {
    let (Some(gpu), Some(fresh_large), Some(fresh_small)) = (common::gpu(), common::gpu(), common::gpu())
    else {
        return;
    };
    let (source, target) = (common::preset("paper-sss"), common::preset("paper-fls"));
    let batch = |seed, n| Batch {
        sigma_range: None,
        items: random_items(seed, &source, &target, n),
        source: source.clone(),
        target: target.clone(),
        sampling: Sampling::Step(0.2),
        area_grid: sonarproj::PAPER_AREA_GRID,
    };
    let (small, large) = (batch(16, 3), batch(17, 400));
    let (small, large) = (small.prepare().unwrap(), large.prepare().unwrap());
    let project = |g: &GpuBackend, b: &PreparedBatch<'_>| g.project(b, Output::WithOccupancy).unwrap();
    project(&gpu, &small);
    let want = project(&fresh_large, &large);
    assert_eq!(project(&gpu, &large), want, "after a small batch");
    assert_eq!(
        project(&gpu, &small),
        project(&fresh_small, &small),
        "after a large batch"
    );
    let gpu = gpu.with_max_chunk_poses(64);
    assert_eq!(project(&gpu, &large), want, "in chunks of 64");
}

/// Every workgroup size of the splat stage, with and without culling (whose block decisions a
/// workgroup shares) and the f32 filter, gives the same bits, also where the workgroups step
/// through a long plan; a size outside the list is an error naming it.
#[test]
fn results_do_not_depend_on_the_workgroup_size() {
    let Some(gpu) = common::gpu() else { return };
    let pairs = [
        (
            14,
            common::preset("paper-fls"),
            common::preset("paper-sss"),
            Sampling::Step(0.1),
            200,
        ),
        (
            15,
            common::preset("paper-sss"),
            common::preset("paper-fls"),
            Sampling::Step(0.1),
            200,
        ),
        // Plans of more samples than the most workgroups a pose gets (1024) hold threads: the
        // workgroups step through the plan.
        (
            16,
            common::preset("paper-sss"),
            common::preset("paper-fls"),
            Sampling::Step(0.01),
            3,
        ),
    ];
    for (seed, source, target, sampling, poses) in pairs {
        let batch = Batch {
            sigma_range: None,
            items: random_items(seed, &source, &target, poses),
            source,
            target,
            sampling,
            area_grid: sonarproj::PAPER_AREA_GRID,
        };
        let prepared = batch.prepare().unwrap();
        if sampling == Sampling::Step(0.01) {
            let samples = prepared.plan(0).total();
            assert!(
                samples > 1024 * 256,
                "{samples} samples do not make the workgroups step"
            );
        }
        let want = gpu.project(&prepared, Output::WithOccupancy).unwrap();
        let variants = SPLAT_WORKGROUPS
            .into_iter()
            .flat_map(|w| [(w, false), (w, true)])
            .flat_map(|(w, c)| [(w, c, false), (w, c, true)]);
        for (workgroup, cull, filter) in variants {
            let options = SplatOptions {
                workgroup,
                cull,
                filter,
            };
            let variant = GpuBackend::with_options(gpu.context().clone(), options).unwrap();
            let got = variant.project(&prepared, Output::WithOccupancy).unwrap();
            assert_eq!(got.len(), want.len());
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                assert_eq!(g, w, "pose {k}, {}", options.describe());
            }
        }
    }
    let bad = SplatOptions {
        workgroup: 100,
        ..gpu.options()
    };
    let err = GpuBackend::with_options(gpu.context().clone(), bad)
        .unwrap_err()
        .to_string();
    assert!(err.contains("GPU workgroup") && err.contains("100"), "{err}");
}

/// One backend kept across calls of different sizes and targets (its buffers reused, grown and
/// holding an earlier call's data) answers exactly as a fresh backend does for each call, and a
/// repeated call allocates nothing more.
#[test]
fn kept_buffers_do_not_change_results() {
    let Some(ctx) = common::gpu_context() else { return };
    let kept = sonarproj_testkit::gpu_backend_on(ctx.clone());
    let batch = |seed, source: &str, target: &str, n| {
        let (source, target) = (common::preset(source), common::preset(target));
        Batch {
            sigma_range: None,
            items: random_items(seed, &source, &target, n),
            source,
            target,
            sampling: Sampling::Step(0.2),
            area_grid: sonarproj::PAPER_AREA_GRID,
        }
    };
    let calls = [
        (batch(21, "paper-sss", "paper-fls", 40), Output::WithOccupancy),
        (batch(22, "paper-fls", "paper-sss", 3), Output::MetricsOnly),
        (batch(23, "paper-sss", "paper-fls", 5), Output::WithOccupancy),
        (batch(24, "paper-fls", "paper-sss", 60), Output::WithOccupancy),
        (batch(21, "paper-sss", "paper-fls", 40), Output::WithOccupancy),
    ];
    let mut sizes = Vec::new();
    for (k, (batch, output)) in calls.iter().enumerate() {
        let prepared = batch.prepare().unwrap();
        let fresh = sonarproj_testkit::gpu_backend_on(ctx.clone())
            .project(&prepared, *output)
            .unwrap();
        let reused = kept.project(&prepared, *output).unwrap();
        assert_eq!(reused, fresh, "call {k}");
        sizes.push(kept.kept_bytes());
    }
    assert!(sizes[0] > 0, "nothing kept: {sizes:?}");
    assert_eq!(sizes[4], sizes[3], "a repeated call grew the buffers: {sizes:?}");
    kept.release_buffers();
    assert_eq!(kept.kept_bytes(), 0);
}

/// The checker the GPU is held to can fail: a result with a certain pixel dropped, a visible
/// count past the envelope, a range past its interval or a projection area outside its cells'
/// interval is refused. Run on the fast CPU path
/// everywhere, and on the GPU where there is one.
#[test]
fn the_envelope_check_catches_wrong_results() {
    let (source, target) = (common::preset("paper-sss"), common::preset("paper-fls"));
    let batch = Batch {
        sigma_range: None,
        items: random_items(14, &source, &target, 1),
        source,
        target,
        sampling: Sampling::Step(0.1),
        area_grid: sonarproj::PAPER_AREA_GRID,
    };
    let prepared = batch.prepare().unwrap();
    let mut results = vec![(
        "cpu-fast",
        fast::project(&prepared, Output::WithOccupancy).remove(0),
    )];
    if let Some(gpu) = common::gpu() {
        results.push((
            "gpu",
            gpu.project(&prepared, Output::WithOccupancy).unwrap().remove(0),
        ));
    }
    for (name, good) in results {
        catches_wrong_results(&prepared, &batch, &good, name);
    }
}

/// Asserts that `good` (`name`'s result for the one item of `batch`) passes the envelope check
/// and that three ways of spoiling it do not.
fn catches_wrong_results(prepared: &PreparedBatch<'_>, batch: &Batch, good: &Projection, name: &str) {
    let item = &batch.items[0];
    let b = envelope::bounds(
        prepared.layout(),
        prepared.plan(0),
        0.0,
        item.measurement.range,
        &item.pose,
    );
    common::check_within_bounds(prepared.layout(), &b, good).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(
        good.metrics.visible > 0,
        "{name}: nothing visible, the test proves nothing"
    );

    let mut dropped = good.clone();
    let (i, j) = b.certain.pixels().next().expect("a certain pixel");
    let occ = dropped.occupancy.as_mut().unwrap();
    let k = i * occ.beams + j;
    occ.words[k / 32] &= !(1 << (k % 32));
    dropped.metrics.occupied -= 1;
    assert!(
        common::check_within_bounds(prepared.layout(), &b, &dropped).is_err(),
        "{name}: dropped"
    );

    let mut counted = good.clone();
    counted.metrics.visible = b.visible_max + 1;
    assert!(
        common::check_within_bounds(prepared.layout(), &b, &counted).is_err(),
        "{name}: counted"
    );

    let mut far = good.clone();
    far.metrics.range_max = Some(b.range_max.1 + 1e-4);
    assert!(
        common::check_within_bounds(prepared.layout(), &b, &far).is_err(),
        "{name}: far"
    );

    // A projection area one cell short of the certain cells, or one past the possible ones.
    let grid = prepared.layout().area_grid.expect("an FLS target has a grid");
    let (lo, hi) = b
        .projection_area(prepared.layout())
        .expect("an FLS target has an area");
    assert!(lo > 0.0, "{name}: no certain cell, the test proves nothing");
    for (what, area) in [("short", lo - grid.area(1)), ("wide", hi + grid.area(1))] {
        let mut wrong = good.clone();
        wrong.metrics.projection_area = Some(area);
        assert!(
            common::check_within_bounds(prepared.layout(), &b, &wrong).is_err(),
            "{name}: area {what}"
        );
    }
    // One cell moved where no sample can be: the same count, the wrong place.
    let mut moved = good.clone();
    let cells = moved.cells.as_mut().expect("cells read back with the occupancy");
    let (i, j) = b.cells_certain.pixels().next().expect("a certain cell");
    let far = (0..grid.nx)
        .flat_map(|a| (0..grid.ny).map(move |c| (a, c)))
        .find(|&(a, c)| !b.cells_possible.get(a, c))
        .expect("a cell out of reach");
    let k = i * cells.beams + j;
    cells.words[k / 32] &= !(1 << (k % 32));
    cells.set(far.0, far.1);
    assert!(
        common::check_within_bounds(prepared.layout(), &b, &moved).is_err(),
        "{name}: cell moved"
    );
}

/// A process opens one GPU context per device asked for (backends, adapter, precision) and shares
/// it: asking again, from any thread, or for another variant of the splat stage, opens nothing new
/// (on NVIDIA's driver, instances created and dropped by threads at once crashed the process);
/// the context returned carries the options asked for. Another precision opens another, once.
#[test]
fn one_context_per_process_and_device() {
    use sonarproj::gpu::{GpuContext, GpuOptions, Precision};
    let Some(first) = common::gpu_context() else {
        return;
    };
    let options = sonarproj_testkit::gpu_options();
    let before = GpuContext::opened();
    let threads: Vec<_> = (0..4)
        .map(|_| {
            let options = options.clone();
            std::thread::spawn(move || GpuContext::open(&options).unwrap().info().name.clone())
        })
        .collect();
    for t in threads {
        assert_eq!(t.join().unwrap(), first.info().name);
    }
    // Another variant of the splat stage is the backend's, on the same device.
    let variant = GpuOptions {
        workgroup: Some(128),
        cull: Some(true),
        ..options.clone()
    };
    let ctx = GpuContext::open(&variant).unwrap();
    let splat = SplatOptions::for_adapter(&ctx, &variant);
    assert_eq!((splat.workgroup, splat.cull), (128, true), "the caller's variant");
    assert_eq!(GpuBackend::with_options(ctx, splat).unwrap().options(), splat);
    assert_eq!(GpuContext::opened(), before, "a second device for the same one");
    let other = GpuOptions {
        precision: match options.precision {
            Some(Precision::DoubleF32) => None,
            _ => Some(Precision::DoubleF32),
        },
        ..options
    };
    for _ in 0..3 {
        let precision = GpuContext::open(&other).unwrap().precision();
        assert!(
            other.precision.is_none_or(|p| p == precision),
            "{precision:?}: not the precision asked for"
        );
    }
    assert_eq!(GpuContext::opened(), before + 1);
}

/// The local precision travels with the projection: an item that gives its feature's true
/// point comes back with [`sonarproj::local_precision::local_precision`] there (for the batch's
/// range error, or the default), an item without one with none; every backend alike, the
/// metrics untouched by it.
#[test]
fn the_true_point_in_gives_the_local_precision_out() {
    use sonarproj::Backend;
    use sonarproj::local_precision::{LocalPrecision, local_precision, resolve_sigma_range};
    for (from, to) in [("paper-fls", "paper-sss"), ("paper-sss", "paper-fls")] {
        let (source, target) = (common::preset(from), common::preset(to));
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        let mut items = random_items(30, &source, &target, 40);
        let truths: Vec<Option<[f64; 3]>> = (0..items.len())
            .map(|k| (k % 3 != 0).then(|| point_in(&mut rng, &source)))
            .collect();
        for (item, truth) in items.iter_mut().zip(&truths) {
            item.true_point = *truth;
        }
        let mut backends = vec![Backend::Cpu, Backend::CpuFast];
        backends.extend(common::gpu().map(|g| Backend::Gpu(Box::new(g))));
        for sigma_range in [None, Some(0.02)] {
            let batch = Batch {
                source: source.clone(),
                target: target.clone(),
                sampling: Sampling::Step(0.5),
                area_grid: sonarproj::PAPER_AREA_GRID,
                sigma_range,
                items: items.clone(),
            };
            let sigma = resolve_sigma_range(&source, &target, sigma_range).unwrap();
            let without = Batch {
                items: items
                    .iter()
                    .map(|i| BatchItem {
                        true_point: None,
                        ..*i
                    })
                    .collect(),
                ..batch.clone()
            };
            for backend in &backends {
                let out = backend.project(&batch, Output::MetricsOnly).unwrap();
                let plain = backend.project(&without, Output::MetricsOnly).unwrap();
                for (k, ((p, q), item)) in out.iter().zip(&plain).zip(&items).enumerate() {
                    let want = item.true_point.map_or_else(LocalPrecision::default, |t| {
                        local_precision(&source, &target, t, &item.pose, sigma)
                    });
                    assert_eq!(p.local, want, "{from} -> {to}, {}, item {k}", backend.name());
                    assert_eq!(
                        p.metrics,
                        q.metrics,
                        "{from} -> {to}, {}, item {k}",
                        backend.name()
                    );
                    assert_eq!(q.local, LocalPrecision::default());
                }
            }
        }
        // A true point that is not finite is refused, naming the item.
        let mut bad = items.clone();
        bad[5].true_point = Some([f64::NAN, 0.0, 0.0]);
        let batch = Batch {
            source: source.clone(),
            target: target.clone(),
            sampling: Sampling::Step(0.5),
            area_grid: sonarproj::PAPER_AREA_GRID,
            sigma_range: None,
            items: bad,
        };
        let e = Backend::CpuFast
            .project(&batch, Output::MetricsOnly)
            .unwrap_err()
            .to_string();
        assert!(e.contains("item 5") && e.contains("true point range"), "{e}");
    }
}

/// The summary stage widens f32 bits to f64 with integer operations, so that a device flushing
/// subnormals in its conversion still gets the host's value: every class of f32 (zeros, the
/// subnormals the exact stage writes, normals, the extremes, infinities, a NaN) widens to the
/// bits of `f64::from`.
#[test]
fn f32_bits_widen_on_the_device_as_on_the_host() {
    let Some(ctx) = common::gpu_context() else { return };
    if !ctx
        .features()
        .contains(wgpu::Features::SHADER_F64 | wgpu::Features::SHADER_INT64)
    {
        assert!(
            std::env::var("CI").is_err(),
            "CI's lavapipe has f64 and 64-bit integers"
        );
        eprintln!("skipped: this device has no f64 or 64-bit integers in shaders");
        return;
    }
    let mut bits: Vec<u32> = vec![
        0,
        0x8000_0000,
        1,
        0x8000_0001,
        0x007f_ffff,
        0x0080_0000,
        0x3f80_0000,
        0xbf80_0001,
        0x7f7f_ffff,
        0xff7f_ffff,
        0x7f80_0000,
        0xff80_0000,
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    bits.extend((0..4000).map(|_| rng.random::<u32>()));
    let widened = sonarproj::test_support::widen_on_device(&ctx, &bits).unwrap();
    for (&b, &w) in bits.iter().zip(&widened) {
        let want = f64::from(f32::from_bits(b));
        if want.is_nan() {
            assert!(w.is_nan(), "{b:#010x}: {w} is not a NaN");
        } else {
            assert_eq!(w.to_bits(), want.to_bits(), "{b:#010x}: {w:e} against {want:e}");
        }
    }
}
