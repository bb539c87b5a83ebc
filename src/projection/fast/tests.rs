//! The fast path against the plain sample-by-sample loop: bit for bit, in every build the processor
//! runs, with runs and culling. Also the polynomial `atan2` within its bound.

use crate::stream::Stop;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::isa::Isa;
use super::lanes::approx_atan2;
use super::tables::{Directions, ball_sides, pose_columns};
use super::*;
use crate::clip::ATAN_ERROR;
use crate::geometry::pose::{RelativePose, Rotation};
use crate::geometry::sonar::Sonar;
use crate::metrics::Extremes;
use crate::occupancy::Occupancy;
use crate::projection::culling::{ball_side, balls, chord_outside, chords};
use crate::projection::{Batch, BatchItem};
use crate::sampling::{Measurement, Sampling};

/// Returns the projections drawn sample by sample with every clip test: no culling, no walking
/// beams, no sparse reduce, `atan2` for every visible sample. The fast path must give exactly these
/// results.
fn project_plainly(prepared: &PreparedBatch<'_>) -> Vec<(Metrics, Occupancy)> {
    let layout = &prepared.layout;
    let geo = Geometry::new(layout);
    prepared
        .batch
        .items
        .iter()
        .enumerate()
        .map(|(n, item)| {
            let plan = prepared.plan(n);
            let dirs = Directions::of(&plan.azimuths, &plan.elevations);
            let m = item.pose.rotation
                * DMat3::from_rotation_z(prepared.base_azimuth(n))
                * item.measurement.range;
            let mut occ = Occupancy::new(layout.range_bins, layout.beams());
            let mut cells = layout.cell_bitset();
            let (mut visible, mut extremes) = (0, Extremes::default());
            for u in &dirs.units {
                let p = m * *u + item.pose.translation;
                let r2 = p.length_squared();
                if geo.in_view(p, r2) {
                    let (r, az) = (r2.sqrt(), p.y.atan2(p.x));
                    let bin = usize::try_from(geo.range_bin(r, r2)).expect("a bin index");
                    occ.set(bin, geo.beam(p, az));
                    if let Some(grid) = &layout.area_grid {
                        let c = grid.flat_cell(p.x, p.y, r);
                        cells.set(c / grid.ny, c % grid.ny);
                    }
                    visible += 1;
                    extremes.add(r, az);
                }
            }
            let occupied = occ.count();
            let measure = match layout.kind {
                SonarKind::Sss => occupied as f64 * layout.range_bin_width,
                SonarKind::Fls => occ.pixels().map(|(i, j)| layout.pixel_measure(i, j)).sum(),
            };
            let area = layout.area_grid.map(|g| g.area(cells.count()));
            let total = dirs.units.len() as u64;
            let metrics = Metrics::new(visible, total, extremes, (occupied, measure), area);
            (metrics, layout.to_data_order(occ))
        })
        .collect()
}

/// Returns a feature anywhere in sonar 1's view, placed anywhere in sonar 2's view with a
/// random rotation.
fn random_item(s1: &Sonar, s2: &Sonar, rng: &mut ChaCha8Rng) -> BatchItem {
    let mut point = |s: &Sonar| {
        let r = s.range_min + rng.random::<f64>() * (s.range_max - s.range_min);
        let a = (rng.random::<f64>() - 0.5) * s.azimuth_aperture;
        let e = (rng.random::<f64>() - 0.5) * s.elevation_aperture;
        [r, a, e]
    };
    let (f, place) = (point(s1), point(s2));
    let rot = Rotation::RollPitchYaw {
        roll: rng.random::<f64>() * 360.0 - 180.0,
        pitch: rng.random::<f64>() * 180.0 - 90.0,
        yaw: rng.random::<f64>() * 360.0 - 180.0,
    };
    BatchItem {
        true_point: None,
        measurement: Measurement::of(s1, f[0], f[1]).unwrap(),
        pose: RelativePose::placement(rot, f, place).unwrap(),
    }
}

/// Returns an imaging sonar that sees everything: 360° of beams (edges behind a point), and arcs of
/// 180°, which cross a sidescan's sheet twice.
fn omni() -> Sonar {
    Sonar::from_toml_str(
        "omni",
        "kind = 'fls'\nrange_min = 0\nrange_max = 12\nazimuth_aperture = 360\n\
         elevation_aperture = 180\nrange_bins = 600\nbeams = 720\n",
    )
    .unwrap()
}

/// Poses drawn by runs give the plain loop's results in every build, with and without the
/// occupancy. They are arcs into a sidescan, sampled finer than its range bins, as automatic
/// sampling always is. Both cases occur, and every pose here is drawn by runs: visible samples in
/// one run (bins from the range's two ends) or in several (each sample's bin).
#[test]
fn runs_change_no_result() {
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let sss = Sonar::preset("paper-sss").unwrap();
    let layout = Layout::of(&sss);
    let (mut one, mut several) = (0, 0);
    for s1 in [
        Sonar::preset("paper-fls").unwrap(),
        Sonar::preset("oculus-m750d").unwrap(),
        omni(),
    ] {
        let items = (0..300).map(|_| random_item(&s1, &sss, &mut rng)).collect();
        let batch = Batch {
            sigma_range: None,
            source: s1.clone(),
            target: sss.clone(),
            sampling: Sampling::Auto,
            area_grid: crate::PAPER_AREA_GRID,
            items,
        };
        let prepared = batch.prepare().unwrap();
        let plain = project_plainly(&prepared);
        let fast = project_with(&prepared, Keep::all(Output::WithOccupancy), Isa::Baseline);
        for isa in Isa::available() {
            assert_eq!(
                project_with(&prepared, Keep::all(Output::WithOccupancy), isa),
                fast,
                "{}: {isa:?}",
                s1.name
            );
            // Without the occupancy, one run's bins are counted, not set.
            let lean = project_with(&prepared, Keep::all(Output::MetricsOnly), isa);
            assert!(
                lean.iter()
                    .zip(&fast)
                    .all(|(l, f)| l.metrics == f.metrics && l.occupancy.is_none()),
                "{}: {isa:?} without the occupancy",
                s1.name
            );
        }
        for (n, (f, (metrics, occ))) in fast.iter().zip(&plain).enumerate() {
            assert_eq!(&f.metrics, metrics, "{} item {n}", s1.name);
            assert_eq!(f.occupancy.as_ref(), Some(occ), "{} item {n}", s1.name);
            // Drawn by runs, and with how many.
            let item = &batch.items[n];
            let plan = prepared.plan(n);
            let dirs = Directions::of(&plan.azimuths, &plan.elevations);
            let range = item.measurement.range;
            let t = item.pose.translation;
            let slack = cull_slack(range, t, &layout);
            assert!(
                range * dirs.max_step * (1.0 + crate::clip::F64_WIDEN) + slack < layout.range_bin_width,
                "{} item {n} is not drawn by runs",
                s1.name
            );
            let m = item.pose.rotation * DMat3::from_rotation_z(prepared.base_azimuth(n)) * range;
            let geo = Geometry::new(&layout);
            let seen: Vec<usize> = (0..dirs.units.len())
                .filter(|&k| {
                    let p = m * dirs.units[k] + t;
                    geo.in_view(p, p.length_squared())
                })
                .collect();
            if let (Some(first), Some(last)) = (seen.first(), seen.last()) {
                if last - first + 1 == seen.len() {
                    one += 1;
                } else {
                    several += 1;
                }
            }
        }
    }
    assert!(
        one > 300 && several > 50,
        "one run {one} times, several {several}"
    );
}

/// The azimuth guess keeps within `ATAN_ERROR` of libm's `atan2` in every octant, near the axes and
/// diagonals, over many magnitudes. It is NaN only at the origin.
#[test]
fn approx_atan2_is_within_its_bound() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut worst: f64 = 0.0;
    let mut check = |y: f64, x: f64| {
        let (a, e) = (approx_atan2(y, x), y.atan2(x));
        assert!((a - e).abs() <= ATAN_ERROR, "atan2({y}, {x}): {a} against {e}");
        worst = worst.max((a - e).abs());
    };
    for _ in 0..1_000_000 {
        let a = (rng.random::<f64>() - 0.5) * std::f64::consts::TAU;
        let r = 10f64.powf(rng.random::<f64>() * 8.0 - 4.0);
        check(r * a.sin(), r * a.cos());
    }
    for k in 0..=64 {
        let a = f64::from(k) * std::f64::consts::FRAC_PI_8 / 8.0 - std::f64::consts::PI;
        for d in [-1e-9, -1e-15, 0.0, 1e-15, 1e-9] {
            check((a + d).sin(), (a + d).cos());
        }
    }
    for (y, x) in [
        (0.0, 1.0),
        (-0.0, 1.0),
        (1.0, 0.0),
        (1.0, -0.0),
        (-1.0, 0.0),
        (0.0, -1.0),
    ] {
        check(y, x);
    }
    // Not merely within the bound by luck: the polynomial is fitted to 4.2e-12.
    assert!(worst > 1e-13 && worst < 6e-12, "worst error {worst}");
    assert!(approx_atan2(0.0, 0.0).is_nan() && approx_atan2(-0.0, -0.0).is_nan());
}

/// A block the chord test skips has no visible sample (by the plain test, sample by sample). The
/// chord test also skips blocks the balls keep, most of them where a sidescan's thin sheet is the
/// bound. The poses are random placements of a feature in sonar 2's view, so its arc crosses the
/// bounds. `ball_sides` returns the balls' decisions with the chords' added.
#[test]
fn chords_skip_only_blocks_without_a_visible_sample() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for (from, to, least) in [
        ("paper-fls", "paper-sss", 0.15),
        ("oculus-m750d", "paper-sss", 0.25),
        ("paper-sss", "paper-fls", 0.1),
        ("paper-fls", "paper-fls", 0.05),
    ] {
        let (s1, s2) = (Sonar::preset(from).unwrap(), Sonar::preset(to).unwrap());
        let layout = Layout::of(&s2);
        let geo = Geometry::new(&layout);
        let (mut across, mut chord_only) = (0, 0);
        for _ in 0..300 {
            let item = random_item(&s1, &s2, &mut rng);
            let batch = Batch {
                sigma_range: None,
                source: s1.clone(),
                target: s2.clone(),
                sampling: Sampling::Step(0.1),
                area_grid: crate::PAPER_AREA_GRID,
                items: vec![item],
            };
            let prepared = batch.prepare().unwrap();
            let plan = prepared.plan(0);
            let dirs = Directions::of(&plan.azimuths, &plan.elevations);
            let range = item.measurement.range;
            let m = item.pose.rotation * DMat3::from_rotation_z(prepared.base_azimuth(0)) * range;
            let t = item.pose.translation;
            let slack = cull_slack(range, t, &layout);
            let columns = pose_columns(m, t);
            let balls = balls(&dirs.units, LANES);
            let chords = chords(&dirs.units, LANES);
            for (b, units) in dirs.units.chunks(LANES).enumerate() {
                let (centre, radius) = balls[b];
                let (first, last, reach) = chords[b];
                let widen = |r: f64| range * r * (1.0 + crate::clip::F64_WIDEN) + slack;
                let (ball_out, ball_in) = ball_side(&geo, (m * centre + t).to_array(), widen(radius));
                let chord_out = chord_outside(
                    &geo,
                    (m * first + t).to_array(),
                    (m * last + t).to_array(),
                    widen(reach),
                );
                let (out, ins) = ball_sides(&geo, &columns, &dirs.ball_chunks[b / BALLS], range, slack);
                let bit = 1 << (b % BALLS);
                assert_eq!(out & bit != 0, ball_out | chord_out, "{from} -> {to} block {b}");
                assert_eq!(ins & bit != 0, ball_in & !chord_out, "{from} -> {to} block {b}");
                if chord_out {
                    for u in units {
                        let p = m * *u + t;
                        assert!(
                            !geo.in_view(p, p.length_squared()),
                            "{from} -> {to}: block {b} skipped by its chord holds a visible sample"
                        );
                    }
                }
                if !ball_out && !ball_in {
                    across += 1;
                    chord_only += usize::from(chord_out);
                }
            }
        }
        let share = chord_only as f64 / across as f64;
        assert!(
            across > 0 && share >= least,
            "{from} -> {to}: the chords skip {chord_only} of {across} blocks the balls keep"
        );
    }
}

/// The speed-ups change no bit of any result: culling, the lane stage's guessed bins and beams,
/// exact `atan2` only for extreme candidates, the sparse reduce, and every build of the pose loop
/// (baseline, AVX2, AVX-512, as the processor runs them). The fast path is held to the plain loop
/// on random placements (features anywhere in sonar 1's view, placed anywhere in sonar 2's, random
/// rotations). This runs for every preset pair, a 360° sonar and one with non-uniform beams, in
/// both sampling modes.
#[test]
fn culling_changes_no_result() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    // The presets, a sonar that sees everything ([`omni`]) and one with non-uniform beams.
    let mut sonars: Vec<Sonar> = Sonar::preset_names()
        .into_iter()
        .map(|n| Sonar::preset(n).unwrap())
        .collect();
    let centres: Vec<String> = (0..64)
        .map(|k| {
            let u = -1.0 + 2.0 * (k as f64 + 0.5) / 64.0;
            format!("{}", 40.0 * (u + 0.3 * u * u * u) / 1.3)
        })
        .collect();
    let nonuniform = Sonar::from_toml_str(
        "nonuniform",
        &format!(
            "kind = 'fls'\nrange_min = 0.5\nrange_max = 20\nazimuth_aperture = 90\n\
             elevation_aperture = 20\nrange_bins = 390\nbeam_centres = [{}]\n",
            centres.join(", ")
        ),
    )
    .unwrap();
    sonars.extend([omni(), nonuniform]);
    for s1 in &sonars {
        for s2 in &sonars {
            let (from, to) = (&s1.name, &s2.name);
            let (s1, s2) = (s1.clone(), s2.clone());
            for sampling in [Sampling::Step(0.5), Sampling::Auto] {
                let items = (0..40).map(|_| random_item(&s1, &s2, &mut rng)).collect();
                let batch = Batch {
                    sigma_range: None,
                    source: s1.clone(),
                    target: s2.clone(),
                    sampling,
                    area_grid: crate::PAPER_AREA_GRID,
                    items,
                };
                let prepared = batch.prepare().unwrap();
                let plain = project_plainly(&prepared);
                // Every build of the lane stage this processor runs gives the same bits.
                let fast = project_with(&prepared, Keep::all(Output::WithOccupancy), Isa::Baseline);
                for isa in Isa::available() {
                    assert_eq!(
                        project_with(&prepared, Keep::all(Output::WithOccupancy), isa),
                        fast,
                        "{from} -> {to}: {isa:?}"
                    );
                }
                let mut seen = 0;
                for (k, (f, (metrics, occ))) in fast.iter().zip(&plain).enumerate() {
                    assert_eq!(&f.metrics, metrics, "{from} -> {to} {sampling:?} item {k}");
                    assert_eq!(f.occupancy.as_ref(), Some(occ), "{from} -> {to} item {k}");
                    seen += usize::from(metrics.visible > 0);
                }
                assert!(
                    seen > 0,
                    "{from} -> {to}: no item saw anything, the test proves nothing"
                );
            }
        }
    }
}

/// Plans larger than a tile are drawn tile by tile, their poses a few at a time, with the same bits
/// as drawing them whole. This holds whatever the tile (a block's worth, an odd number of samples,
/// one sample short of the plan), with and without the occupancy, on every build. It covers
/// sidescan targets (by runs: one run split across tiles) and imaging ones (beams, cells).
#[test]
fn tiles_change_no_result() {
    let mut rng = ChaCha8Rng::seed_from_u64(44);
    let pairs = [
        ("paper-fls", "paper-sss"),
        ("paper-sss", "paper-fls"),
        ("holoocean-sidescan", "oculus-m750d"),
        ("oculus-m750d", "holoocean-sidescan"),
    ];
    let mut tiled_and_seen = 0;
    for (a, b) in pairs {
        let (s1, s2) = (Sonar::preset(a).unwrap(), Sonar::preset(b).unwrap());
        let mut items: Vec<BatchItem> = (0..24).map(|_| random_item(&s1, &s2, &mut rng)).collect();
        // The paper's hard case as well: an arc crossing the sidescan's sheet.
        items.push(BatchItem {
            true_point: None,
            measurement: Measurement::of(&s1, s1.range_max / 2.0, 0.0).unwrap(),
            pose: RelativePose::placement(
                Rotation::RollPitchYaw {
                    roll: 0.0,
                    pitch: 90.0,
                    yaw: 0.0,
                },
                [s1.range_max / 2.0, 0.0, 0.0],
                [s2.range_max / 2.0, 0.0, 0.0],
            )
            .unwrap(),
        });
        let batch = Batch {
            sigma_range: None,
            source: s1.clone(),
            target: s2.clone(),
            sampling: Sampling::Step(0.25),
            area_grid: crate::PAPER_AREA_GRID,
            items,
        };
        let prepared = batch.prepare().unwrap();
        let largest = (0..batch.items.len())
            .map(|n| prepared.plan(n).azimuths.len() * prepared.plan(n).elevations.len())
            .max()
            .unwrap();
        for occupancy in [true, false] {
            let keep = Keep {
                occupancy,
                azimuths: true,
            };
            let whole = project_tiled_batch(&prepared, keep, Isa::Baseline, usize::MAX, Stop::NEVER).unwrap();
            for tile in [LANES, 997, 4096, largest - 1] {
                for isa in Isa::available() {
                    let tiled = project_tiled_batch(&prepared, keep, isa, tile, Stop::NEVER).unwrap();
                    assert_eq!(
                        tiled, whole,
                        "{a} -> {b}: tile {tile}, {isa:?}, occupancy {occupancy}"
                    );
                    // Without the azimuths' extremes, every other result is the same. Those
                    // extremes are left empty (infinite where something is visible).
                    let lean = Keep {
                        azimuths: false,
                        ..keep
                    };
                    let lean = project_tiled_batch(&prepared, lean, isa, tile, Stop::NEVER).unwrap();
                    for (l, w) in lean.iter().zip(&whole) {
                        let seen = l.metrics.visible > 0;
                        assert_eq!(l.metrics.azimuth_min, seen.then_some(f64::INFINITY), "{a} -> {b}");
                        assert_eq!(
                            l.metrics.azimuth_max,
                            seen.then_some(f64::NEG_INFINITY),
                            "{a} -> {b}"
                        );
                        let mut l = l.clone();
                        (l.metrics.azimuth_min, l.metrics.azimuth_max) =
                            (w.metrics.azimuth_min, w.metrics.azimuth_max);
                        assert_eq!(&l, w, "{a} -> {b}: tile {tile}, {isa:?}, no azimuths");
                    }
                }
            }
            tiled_and_seen += whole.iter().filter(|p| p.metrics.visible > 0).count();
        }
    }
    assert!(
        tiled_and_seen > 40,
        "too few poses saw anything ({tiled_and_seen}): the test proves little"
    );
}
