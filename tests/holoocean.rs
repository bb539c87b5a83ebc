//! HoloOcean's frames, index for index. Its `SidescanSonar` returns one row of `RangeBins`
//! values for both sides: port from far to near, then starboard from near to far; the
//! `holoocean-sidescan` preset is that row, bin for bin. Its `ImagingSonar` returns
//! `(RangeBins, AzimuthBins)`, row `X = (int)((r − RangeMin) / RangeRes)`, column
//! `Y = (int)((az − (−Azimuth/2)) / AzimuthRes)` with its azimuth `atan2(−y_unreal, x)`, positive
//! to port. These tests hold every backend's occupancy and masks, for presets and for sonars read
//! from HoloOcean configurations (`Sonar::from_holoocean`), to independent copies of the
//! simulator's own indexing (its `SidescanSonar.cpp` and `ImagingSonar.cpp`, restated below), for
//! points to port and to starboard.

use sonarproj_testkit as common;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sonarproj::geometry::holoocean::HoloValue::Number;
use sonarproj::masks::{Counts, MaskEngine, bounding_box};
use sonarproj::projection::{fast, reference};
use sonarproj::{
    Batch, BatchItem, BeamLayout, Layout, Measurement, Output, RelativePose, Rotation, Sampling, Sonar,
    SonarKind,
};

/// HoloOcean's sidescan defaults (SidescanSonar.cpp): RangeMin 0.5 m, RangeMax 35 m,
/// RangeBins 2000.
const RANGE_MIN: f64 = 0.5;
const RANGE_MAX: f64 = 35.0;
const RANGE_BINS: usize = 2000;

/// Returns the index HoloOcean writes a return at range `r` (m) and azimuth `az` (deg) to:
/// `X = (int)((r − RangeMin) / RangeRes)` with `RangeRes = (RangeMax − RangeMin) / RangeBins`;
/// to port (positive azimuth: HoloOcean's azimuth is `atan2(−y_unreal, x)`, +y_ROS, the left)
/// `RangeBins/2 − X/2 − 1`, else `RangeBins/2 + X/2`. (HoloOcean decides the side by its
/// azimuth bin, `Y > AzimuthBins/2`, which puts the first azimuth bin above 0 to starboard;
/// callers keep away from the nadir.)
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "HoloOcean's own (int) cast of a range inside the sonar's"
)]
fn holoocean_index(r: f64, az: f64) -> usize {
    let res = (RANGE_MAX - RANGE_MIN) / RANGE_BINS as f64;
    let x = ((r - RANGE_MIN) / res) as usize;
    if az > 0.0 {
        RANGE_BINS / 2 - x / 2 - 1
    } else {
        RANGE_BINS / 2 + x / 2
    }
}

/// Returns whether range `r` lies within `tol` (m) of an edge of HoloOcean's per-side bins
/// (`2 · RangeRes` wide), where rounding may decide either way.
fn near_edge(r: f64, tol: f64) -> bool {
    let w = 2.0 * (RANGE_MAX - RANGE_MIN) / RANGE_BINS as f64;
    let f = (r - RANGE_MIN) / w;
    (f - f.round()).abs() * w < tol
}

/// A source whose back-projected arc is one sample: an FLS with an elevation aperture far
/// below the sampling step, so that the only sample is the measured point itself.
fn point_source() -> Sonar {
    Sonar {
        name: "point".into(),
        kind: SonarKind::Fls,
        range_min: 0.1,
        range_max: 60.0,
        azimuth_aperture: 120.0,
        elevation_aperture: 1e-6,
        range_bins: 100,
        beams: BeamLayout::Uniform { count: 10 },
    }
    .validated()
    .unwrap()
}

/// Returns one batch item that puts a point measured by [`point_source`] at `(r, az, el)` in
/// sonar 2, under a random rotation.
fn item_at(rng: &mut ChaCha8Rng, source: &Sonar, target_point: [f64; 3]) -> BatchItem {
    let feature = [rng.random_range(1.0..50.0), rng.random_range(-50.0..50.0), 0.0];
    let rotation = Rotation::RollPitchYaw {
        roll: rng.random_range(-180.0..180.0),
        pitch: rng.random_range(-90.0..90.0),
        yaw: rng.random_range(-180.0..180.0),
    };
    BatchItem {
        true_point: None,
        measurement: Measurement::of(source, feature[0], feature[1]).unwrap(),
        pose: RelativePose::placement(rotation, feature, target_point).unwrap(),
    }
}

/// Places each of `points` (m, deg, deg in the sidescan) under a random rotation as the one
/// sample of [`point_source`], projects them on every backend (the GPU where an adapter exists:
/// always in CI) and checks that each sets HoloOcean's bin, and only it, in a row of
/// `RangeBins`.
fn land_where_holoocean_puts_them(points: &[[f64; 3]], rng: &mut ChaCha8Rng) {
    let source = point_source();
    let items: Vec<BatchItem> = points.iter().map(|&p| item_at(rng, &source, p)).collect();
    let batch = Batch {
        sigma_range: None,
        items,
        source,
        target: Sonar::preset("holoocean-sidescan").unwrap(),
        sampling: Sampling::Step(1.0),
        area_grid: sonarproj::PAPER_AREA_GRID,
    };
    let prepared = batch.prepare().unwrap();
    let mut runs = vec![
        ("cpu", reference::project(&prepared, Output::WithOccupancy)),
        ("cpu-fast", fast::project(&prepared, Output::WithOccupancy)),
    ];
    if let Some(gpu) = common::gpu() {
        runs.push(("gpu", gpu.project(&prepared, Output::WithOccupancy).unwrap()));
    }
    for (name, results) in runs {
        for (p, result) in points.iter().zip(&results) {
            let occ = result.occupancy.as_ref().unwrap();
            assert_eq!((occ.range_bins, occ.beams), (RANGE_BINS, 1), "{name}");
            let set: Vec<usize> = occ.pixels().map(|(i, _)| i).collect();
            assert_eq!(
                set,
                vec![holoocean_index(p[0], p[1])],
                "{name}: point {p:?} (1 sample, {} visible)",
                result.metrics.visible
            );
        }
    }
}

#[test]
fn the_preset_is_holooceans_two_sided_row() {
    let s = Sonar::preset("holoocean-sidescan").unwrap();
    assert!(s.two_sided());
    let layout = Layout::of(&s);
    assert_eq!(layout.data_shape(), (RANGE_BINS, 1));
    // Per side, HoloOcean's bins are two of its RangeRes wide: ours are those.
    let side_bin = 2.0 * (RANGE_MAX - RANGE_MIN) / RANGE_BINS as f64;
    assert!((layout.range_bin_width - side_bin).abs() < 1e-15);
    // A one-sided sidescan keeps its plain layout.
    assert!(!Sonar::preset("paper-sss").unwrap().two_sided());
}

#[test]
fn a_point_to_port_and_one_to_starboard_land_where_holoocean_puts_them() {
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    // Port, starboard, and each near the sonar's near and far ends.
    let points = [
        [12.34, 40.0, 0.05],
        [12.34, -40.0, -0.05],
        [0.51, 80.0, 0.0],
        [0.51, -80.0, 0.0],
        [34.99, 5.0, 0.1],
        [34.99, -5.0, -0.1],
    ];
    land_where_holoocean_puts_them(&points, &mut rng);
    // Port is the first half, far range first; starboard the second, near range first.
    let near_port = holoocean_index(0.51, 80.0);
    let near_starboard = holoocean_index(0.51, -80.0);
    assert_eq!((near_port, near_starboard), (RANGE_BINS / 2 - 1, RANGE_BINS / 2));
    assert_eq!(holoocean_index(34.99, 5.0), 0);
    assert_eq!(holoocean_index(34.99, -5.0), RANGE_BINS - 1);
}

#[test]
fn random_points_agree_with_holooceans_indexing_on_every_backend() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut points = Vec::new();
    while points.len() < 500 {
        let r = rng.random_range(RANGE_MIN..RANGE_MAX);
        // Away from the nadir (HoloOcean's side split is an azimuth bin, not 0) and from bin
        // edges, where the rounding of the placement may decide either way.
        let az = rng.random_range(1.0..84.9) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        let el = rng.random_range(-0.12..0.12);
        if !near_edge(r, 1e-9) {
            points.push([r, az, el]);
        }
    }
    land_where_holoocean_puts_them(&points, &mut rng);
}

#[test]
fn masks_in_a_two_sided_row_hold_the_point_on_its_side() {
    // An imaging sonar sees a feature; the sidescan's mask must hold the feature's true point
    // at HoloOcean's index, on its side only when the arc stays on that side.
    let source = Sonar::preset("holoocean-imaging").unwrap();
    let target = Sonar::preset("holoocean-sidescan").unwrap();
    let mut engines = vec![("cpu", MaskEngine::new(source.clone(), target.clone()).unwrap())];
    if let Some(ctx) = common::gpu_context() {
        engines.push((
            "gpu",
            MaskEngine::on_gpu(source.clone(), target.clone(), ctx).unwrap(),
        ));
    }
    let layout = Layout::of(&target);
    for (side, az2) in [("port", 30.0), ("starboard", -30.0)] {
        let feature = [6.0, 10.0, 0.0];
        let truth = [14.2, az2, 0.0];
        let pose = RelativePose::placement(
            Rotation::RollPitchYaw {
                roll: 90.0,
                pitch: 0.0,
                yaw: 0.0,
            },
            feature,
            truth,
        )
        .unwrap();
        let m = Measurement::of(&source, feature[0], feature[1]).unwrap();
        for (name, engine) in &engines {
            let set = engine.masks(&pose, &[m], None, Counts::Skip).unwrap();
            let mask = &set.masks[0].occupancy;
            assert_eq!((mask.range_bins, mask.beams), (RANGE_BINS, 1), "{name}");
            let k = holoocean_index(truth[0], truth[1]);
            assert!(
                mask.get(k, 0),
                "{name} {side}: the true point's bin {k} is missing"
            );
            // The box names the side: its azimuth interval holds the true point's.
            let b = bounding_box(&layout, mask).unwrap();
            assert!(
                b.azimuth_min <= az2 && az2 <= b.azimuth_max,
                "{name} {side}: {b:?}"
            );
            assert!(
                b.range_min <= truth[0] && truth[0] <= b.range_max,
                "{name} {side}: {b:?}"
            );
        }
    }
}

#[test]
fn sides_are_checked() {
    let toml = |sides: &str| {
        format!(
            "kind = 'sss'\nrange_min = 0.5\nrange_max = 35\nazimuth_aperture = 170\n\
             elevation_aperture = 0.25\nrange_bins = 1000\n{sides}"
        )
    };
    let two = Sonar::from_toml_str("two", &toml("sides = 2")).unwrap();
    assert!(two.two_sided());
    assert_eq!(
        Sonar {
            name: "holoocean-sidescan".into(),
            ..two
        },
        Sonar::preset("holoocean-sidescan").unwrap()
    );
    assert!(
        !Sonar::from_toml_str("one", &toml("sides = 1"))
            .unwrap()
            .two_sided()
    );
    let e = Sonar::from_toml_str("three", &toml("sides = 3"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sides") && e.contains('3') && e.contains("1") && e.contains("2"),
        "{e}"
    );
    let fls = "kind = 'fls'\nrange_min = 0.5\nrange_max = 35\nazimuth_aperture = 120\n\
               elevation_aperture = 20\nrange_bins = 100\nbeams = 16\nsides = 2";
    let e = Sonar::from_toml_str("fls", fls).unwrap_err().to_string();
    assert!(e.contains("sides"), "{e}");
    let e = Sonar::from_toml_str("both", &toml("sides = 2\nbeams = 1"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("beams") && e.contains("sides"), "{e}");
}

#[test]
fn a_sidescan_pair_takes_one_sided_channels() {
    let two = Sonar::preset("holoocean-sidescan").unwrap();
    let e = sonarproj::rig::sidescan_pair(&two, 30.0, glam::DVec3::ZERO, glam::DVec3::ZERO)
        .unwrap_err()
        .to_string();
    assert!(e.contains("sides") && e.contains("one-sided"), "{e}");
    let one = Sonar::preset("paper-sss").unwrap();
    assert!(sonarproj::rig::sidescan_pair(&one, 30.0, glam::DVec3::ZERO, glam::DVec3::ZERO).is_ok());
}

/// An imaging sonar as a HoloOcean scenario configures one (not the defaults: every number of
/// the layout differs from them, and the bins come from resolutions).
const IMAGING: [(&str, f64); 7] = [
    ("Azimuth", 130.0),
    ("Elevation", 20.0),
    ("RangeMin", 1.0),
    ("RangeMax", 40.0),
    ("RangeRes", 0.05),
    ("AzimuthRes", 0.25),
    ("InitOctreeRange", 50.0),
];

/// Returns the index HoloOcean's `ImagingSonar` writes a return at range `r` (m) and azimuth
/// `az` (deg, positive to port) to in its frame of [`IMAGING`]: `X · AzimuthBins + Y`.
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "HoloOcean's own (int) casts of a point inside the sonar's view"
)]
fn holoocean_imaging_index(r: f64, az: f64) -> usize {
    let (range_min, range_res, azimuth, azimuth_res) = (1.0, 0.05, 130.0, 0.25);
    let azimuth_bins = (azimuth / azimuth_res) as usize;
    let x = ((r - range_min) / range_res) as usize;
    let y = ((az - (-azimuth / 2.0)) / azimuth_res) as usize;
    x * azimuth_bins + y
}

fn imaging_from_config() -> Sonar {
    let config: Vec<_> = IMAGING.iter().map(|&(k, v)| (k.to_string(), Number(v))).collect();
    Sonar::from_holoocean("scenario-imaging", "ImagingSonar", &config).unwrap()
}

#[test]
fn an_imaging_sonar_from_its_configuration_puts_points_where_holoocean_does() {
    let target = imaging_from_config();
    let layout = Layout::of(&target);
    assert_eq!(
        layout.data_shape(),
        (780, 520),
        "(RangeBins, AzimuthBins) of HoloOcean's frame"
    );
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let mut points = vec![
        [1.01, 64.9, 0.0],
        [1.01, -64.9, 0.0],
        [39.99, 0.1, 5.0],
        [20.02, -0.1, -5.0],
    ];
    while points.len() < 300 {
        let (r, az): (f64, f64) = (rng.random_range(1.0..40.0), rng.random_range(-65.0..65.0));
        // Away from bin edges, where the rounding of the placement may decide either way.
        let (fr, fa) = ((r - 1.0) / 0.05, (az + 65.0) / 0.25);
        if (fr - fr.round()).abs() > 1e-6 && (fa - fa.round()).abs() > 1e-6 {
            points.push([r, az, rng.random_range(-9.0..9.0)]);
        }
    }
    let source = point_source();
    let items: Vec<BatchItem> = points.iter().map(|&p| item_at(&mut rng, &source, p)).collect();
    let batch = Batch {
        sigma_range: None,
        items,
        source,
        target,
        sampling: Sampling::Step(1.0),
        area_grid: sonarproj::PAPER_AREA_GRID,
    };
    let prepared = batch.prepare().unwrap();
    let mut runs = vec![
        ("cpu", reference::project(&prepared, Output::WithOccupancy)),
        ("cpu-fast", fast::project(&prepared, Output::WithOccupancy)),
    ];
    if let Some(gpu) = common::gpu() {
        runs.push(("gpu", gpu.project(&prepared, Output::WithOccupancy).unwrap()));
    }
    for (name, results) in runs {
        for (p, result) in points.iter().zip(&results) {
            let occ = result.occupancy.as_ref().unwrap();
            let set: Vec<usize> = occ.pixels().map(|(i, j)| i * occ.beams + j).collect();
            assert_eq!(
                set,
                vec![holoocean_imaging_index(p[0], p[1])],
                "{name}: point {p:?}"
            );
        }
    }
    // Port is the high columns, starboard column 0.
    assert_eq!(holoocean_imaging_index(1.01, -64.9) % 520, 0);
    assert_eq!(holoocean_imaging_index(1.01, 64.9) % 520, 519);
}

#[test]
fn a_sidescan_from_its_configuration_is_the_preset_row() {
    let config = [
        ("RangeMin".to_string(), Number(RANGE_MIN)),
        ("RangeMax".to_string(), Number(RANGE_MAX)),
        ("RangeBins".to_string(), Number(RANGE_BINS as f64)),
    ];
    let s = Sonar::from_holoocean("scenario-sidescan", "SidescanSonar", &config).unwrap();
    let preset = Sonar::preset("holoocean-sidescan").unwrap();
    assert_eq!(Layout::of(&s).data_shape(), (RANGE_BINS, 1));
    assert_eq!(
        Sonar {
            name: preset.name.clone(),
            ..s
        },
        preset
    );
}
