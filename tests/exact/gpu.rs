//! The GPU's exact stage (`shaders/exact.wgsl`) held to its CPU twin, the fast solver, within the
//! stage's envelope. It runs on lavapipe in CI, which has f64; a device without f64 runs the twin
//! itself (`main.rs` holds that path to the twin's bits).
//!
//! The envelope, metric by metric. The stage computes every number in f64, as the twin, its
//! `atan` included (fdlibm's), from poses and constants that reach it as f32 hi + lo pairs (about
//! 1e-14 relative); it reports in f32, as every GPU metric:
//! - range extremes, azimuths and the visible fraction: the twin's, rounded to f32. One f32 ulp
//!   of the value is allowed (`ulp`): the device's f64 differs from the CPU's in the last bits,
//!   which may cross a rounding boundary;
//! - span: the difference of the two range extremes, so within an ulp of each;
//! - cells: equal, but where a piece's end or an extreme sits on a bin or beam edge, as the twin
//!   against the reference (`near_an_edge`);
//! - occupied measure: an FLS's pixel areas are summed in f32 by the reduce stage
//!   (`F32_AREA_SUM_RELATIVE`); a sidescan's comes from the exact count.

use super::{RandomBatch, batch, grid_axes, near_an_edge, random_batches, random_case};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sonarproj::exact::Arc;
use sonarproj::projection::PoseGrid;
use sonarproj::stream::Stop;
use sonarproj::{
    Backend, Layout, Metric, MetricColumns, Metrics, Output, PoseSource, PoseSweep, Sampling, Sonar,
    SonarKind,
};
use sonarproj_testkit::F32_AREA_SUM_RELATIVE;

/// Returns one f32 ulp of `v` (at least that of the smallest normal f32), the rounding the stage's
/// values may add to the twin's.
fn ulp(v: f64) -> f64 {
    f64::from(f32::EPSILON) * v.abs().max(f64::from(f32::MIN_POSITIVE))
}

/// Returns the GPU backend of the tests' device when it solves exact calls itself. In CI the
/// device is lavapipe, which has f64, so this never skips there.
fn exact_gpu() -> Option<Backend> {
    let g = sonarproj_testkit::gpu()?;
    if !g.solves_exact() {
        assert!(
            std::env::var("CI").is_err(),
            "CI's device (lavapipe) has f64: its exact stage must run"
        );
        eprintln!("skipped: this device has no f64, so the GPU backend runs the fast twin");
        return None;
    }
    Some(Backend::Gpu(Box::new(g)))
}

/// Returns `Err` naming the first metric of `gpu` outside the envelope of `fast` (the twin's, for
/// the same pose), and `Ok(true)` when they agree but for cells on an edge (`edge`: whether the
/// pose puts a piece's end or an extreme on one, when the cells are known to differ).
fn within(
    fast: &Metrics,
    gpu: &Metrics,
    cells_differ: bool,
    edge: &dyn Fn() -> bool,
) -> Result<bool, String> {
    if (fast.visible_fraction - gpu.visible_fraction).abs() > ulp(fast.visible_fraction) {
        return Err("visible fraction".into());
    }
    if (gpu.visible, gpu.total) != (0, 0) || gpu.projection_area.is_some() {
        return Err("sample counts or projection area in exact mode".into());
    }
    let (Some(_), Some(_)) = (fast.range_min, gpu.range_min) else {
        // One sees a sliver the other missed: its fraction is within an ulp (checked above).
        return Ok(fast.range_min.is_some() != gpu.range_min.is_some());
    };
    for (name, f, g) in [
        ("range_min", fast.range_min, gpu.range_min),
        ("range_max", fast.range_max, gpu.range_max),
    ] {
        let (f, g) = (f.unwrap(), g.unwrap());
        #[expect(clippy::cast_possible_truncation, reason = "rounding to f32 is the test")]
        let rounded = f64::from(g as f32);
        if rounded != g {
            return Err(format!("{name} {g} is not an f32: not the device's"));
        }
        if (f - g).abs() > ulp(f) {
            return Err(name.into());
        }
    }
    if (fast.span - gpu.span).abs() > ulp(fast.range_min.unwrap()) + ulp(fast.range_max.unwrap()) {
        return Err("span".into());
    }
    for (name, f, g) in [
        ("azimuth_min", fast.azimuth_min, gpu.azimuth_min),
        ("azimuth_max", fast.azimuth_max, gpu.azimuth_max),
    ] {
        // Reported in degrees: the f32 radians' ulp, converted.
        let (f, g) = (f.unwrap(), g.unwrap());
        if (f - g).abs() > ulp(f.to_radians()).to_degrees() * (1.0 + 1e-9) {
            return Err(name.into());
        }
    }
    if cells_differ || fast.occupied != gpu.occupied {
        return if edge() {
            Ok(true)
        } else {
            Err("cells off the edges".into())
        };
    }
    let measure = (fast.occupied_measure - gpu.occupied_measure).abs();
    if measure > F32_AREA_SUM_RELATIVE * fast.occupied_measure {
        return Err("occupied measure".into());
    }
    Ok(false)
}

/// Every target, from two sonar 1s, 200 random poses each: the device's projections, occupancy
/// included, within the envelope of the twin's. Cells may differ on an edge in one pose in a
/// thousand, as the twin's against the reference.
#[test]
fn the_exact_stage_agrees_with_its_cpu_twin() {
    let Some(gpu) = exact_gpu() else { return };
    let (mut seen, mut on_edges, mut all) = (0, 0, 0);
    for RandomBatch {
        source,
        target,
        cases,
        batch: b,
    } in random_batches(5000)
    {
        let (source, target, layout) = (&source, &target, Layout::of(&target));
        let want = Backend::CpuFast.project(&b, Output::WithOccupancy).unwrap();
        let got = gpu.project(&b, Output::WithOccupancy).unwrap();
        for (n, ((w, g), &(r, az, pose))) in want.iter().zip(&got).zip(&cases).enumerate() {
            all += 1;
            seen += usize::from(w.metrics.range_min.is_some());
            let arc = Arc::new(r, az, source.half_elevation(), &pose);
            let edge = || near_an_edge(&arc, &layout, target);
            assert!(
                g.cells.is_none() && w.cells.is_none(),
                "no grid cells in exact mode"
            );
            match within(&w.metrics, &g.metrics, w.occupancy != g.occupancy, &edge) {
                Ok(on_edge) => on_edges += usize::from(on_edge),
                Err(what) => panic!(
                    "{what}: {} → {} case {n}: r {r} az {az} pose {pose:?}\nfast {:?}\ngpu {:?}",
                    source.name, target.name, w.metrics, g.metrics
                ),
            }
        }
    }
    println!("{seen} of {all} poses see something; {on_edges} differ on an edge");
    assert!(seen > all / 5, "only {seen} of {all} poses see anything");
    assert!(
        on_edges * 1000 <= all,
        "{on_edges} of {all} poses differ on an edge"
    );
}

/// A pose grid decoded on the device (the poses stage) and solved there gives, in columns, the
/// twin's per-item metrics within the envelope, with every column or a few; and metrics alone
/// equal the device's metrics with the occupancy.
#[test]
fn the_exact_stage_solves_grids_decoded_on_the_device() {
    let Some(gpu) = exact_gpu() else { return };
    let fls = Sonar::preset("paper-fls").unwrap();
    for target in [
        Sonar::preset("paper-sss").unwrap(),
        Sonar::preset("oculus-m750d").unwrap(),
    ] {
        // Off the bin edges: a round placement puts the arcs' extremes on them.
        let grid = PoseGrid::new(grid_axes(0.5 * target.range_max + 0.0037), true, &fls).unwrap();
        let sweep = PoseSweep {
            source: fls.clone(),
            target: target.clone(),
            sampling: Sampling::Exact,
            area_grid: sonarproj::PAPER_AREA_GRID,
            poses: PoseSource::Grid(&grid),
        };
        let items = sweep.batch(0..grid.len()).unwrap();
        let per_item = Backend::CpuFast.project(&items, Output::MetricsOnly).unwrap();
        let with_cells = gpu.project(&items, Output::WithOccupancy).unwrap();
        let alone = gpu.project(&items, Output::MetricsOnly).unwrap();
        assert!(per_item.iter().any(|p| p.metrics.visible_fraction > 0.0));
        let mut columns = MetricColumns::default();
        gpu.project_columns(&sweep, 0..grid.len(), &mut columns, Stop::NEVER)
            .unwrap();
        let mut few = MetricColumns::only(&[Metric::Span, Metric::VisibleFraction]);
        gpu.project_columns(&sweep, 0..grid.len(), &mut few, Stop::NEVER)
            .unwrap();
        let mut on_edges = 0;
        for (k, p) in per_item.iter().enumerate() {
            assert_eq!(alone[k].metrics, with_cells[k].metrics, "pose {k}");
            let got = columns.get(k);
            let arc_edge = || {
                let item = &items.items[k];
                let arc = Arc::new(
                    item.measurement.range,
                    item.measurement.azimuth.to_radians(),
                    fls.half_elevation(),
                    &item.pose,
                );
                near_an_edge(&arc, &Layout::of(&target), &target)
            };
            match within(&p.metrics, &got, false, &arc_edge) {
                Ok(edge) => on_edges += usize::from(edge),
                Err(what) => panic!(
                    "{what}: {} pose {k}\nfast {:?}\ngpu {got:?}",
                    target.name, p.metrics
                ),
            }
            let f = |m: Metric| few.column(m).f64(k).map(f64::to_bits);
            assert_eq!(f(Metric::Span), Some(got.span.to_bits()), "pose {k}");
            assert_eq!(
                f(Metric::VisibleFraction),
                Some(got.visible_fraction.to_bits()),
                "pose {k}"
            );
        }
        assert!(
            on_edges as u64 * 100 <= grid.len(),
            "{on_edges} poses differ on an edge"
        );
        // A sidescan's occupied measure is the count times the bin width, whatever computes it.
        if target.kind == SonarKind::Sss {
            let w = Layout::of(&target).range_bin_width;
            for k in 0..per_item.len() {
                let m = columns.get(k);
                assert_eq!(m.occupied_measure.to_bits(), (m.occupied as f64 * w).to_bits());
            }
        }
    }
}

/// Chunks do not change a pose's answer: the same batch through chunks of 7 poses gives the same
/// bits.
#[test]
fn the_exact_stage_does_not_depend_on_the_chunking() {
    let Some(whole_backend) = exact_gpu() else { return };
    let fls = Sonar::preset("oculus-m750d").unwrap();
    let target = Sonar::preset("oculus-m1200d-hf").unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let cases: Vec<_> = (0..100).map(|_| random_case(&mut rng, &fls, &target)).collect();
    let b = batch(&fls, &target, Sampling::Exact, &cases);
    let whole = whole_backend.project(&b, Output::WithOccupancy).unwrap();
    let small = sonarproj_testkit::gpu().unwrap().with_max_chunk_poses(7);
    let chunked = Backend::Gpu(Box::new(small))
        .project(&b, Output::WithOccupancy)
        .unwrap();
    assert_eq!(whole, chunked);
    assert!(whole.iter().any(|p| p.metrics.occupied > 1));
}
