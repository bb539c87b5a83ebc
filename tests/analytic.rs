//! Cases worked out by hand, checked on the CPU reference and (where an adapter exists) the GPU.
//! None of the samples here sits near a bin edge or clip bound, so counts are exact on both;
//! ranges and angles from the GPU carry f32 rounding, allowed at 1e-5 relative (docs/gpu.md, "How the GPU is checked").

use sonarproj_testkit as common;

use sonarproj::Output;
use sonarproj::{
    Backend, Batch, BatchItem, BeamLayout, Measurement, Metrics, RelativePose, Rotation, Sampling, Sonar,
};

/// Returns the metrics from every backend available: both CPU paths, and the GPU when there is one.
fn run_all(
    source: &Sonar,
    target: &Sonar,
    range: f64,
    az: f64,
    pose: RelativePose,
) -> Vec<(&'static str, Metrics)> {
    let batch = Batch {
        sigma_range: None,
        source: source.clone(),
        target: target.clone(),
        sampling: Sampling::Step(0.1),
        area_grid: sonarproj::PAPER_AREA_GRID,
        items: vec![BatchItem {
            true_point: None,
            measurement: Measurement::of(source, range, az).unwrap(),
            pose,
        }],
    };
    let mut out = vec![
        (
            "cpu",
            Backend::Cpu.project(&batch, Output::MetricsOnly).unwrap()[0].metrics,
        ),
        (
            "cpu-fast",
            Backend::CpuFast.project(&batch, Output::MetricsOnly).unwrap()[0].metrics,
        ),
    ];
    if let Some(gpu) = common::gpu() {
        let prepared = batch.prepare().unwrap();
        out.push((
            "gpu",
            gpu.project(&prepared, Output::MetricsOnly).unwrap()[0].metrics,
        ));
    }
    out
}

/// Asserts `got` is within 1e-5 relative of `want` (f32 on the GPU; f64 is far closer).
fn close(what: &str, got: Option<f64>, want: f64) {
    let got = got.unwrap_or_else(|| panic!("{what}: nothing visible"));
    assert!(
        (got - want).abs() <= 1e-5 * want.abs().max(1.0),
        "{what}: got {got}, want {want}"
    );
}

/// paper-fls with a 20° elevation aperture, so a paper-fls arc (±6°) is never clipped.
fn tall_fls() -> Sonar {
    Sonar {
        name: "tall".into(),
        elevation_aperture: 20.0,
        ..common::preset("paper-fls")
    }
}

/// Centre of beam 341 of a 60°, 512-beam FLS (deg): away from every beam edge.
const MID_BEAM: f64 = -30.0 + 341.5 * 60.0 / 512.0;

#[test]
fn identity_pose_keeps_the_arc_in_one_pixel() {
    let (s1, s2) = (common::preset("paper-fls"), tall_fls());
    // 5.005 m is the middle of range bin 490 ([5.00, 5.01)).
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
        },
        [0.0; 3],
    )
    .unwrap();
    let area = (60f64 / 512.0).to_radians() / 2.0 * (5.01f64.powi(2) - 5.0f64.powi(2));
    for (backend, m) in run_all(&s1, &s2, 5.005, MID_BEAM, pose) {
        assert_eq!((m.visible, m.total, m.occupied), (121, 121, 1), "{backend}");
        close(backend, m.range_min, 5.005);
        close(backend, m.range_max, 5.005);
        close(backend, m.azimuth_min, MID_BEAM);
        close(backend, m.azimuth_max, MID_BEAM);
        assert!(m.span < 1e-5, "{backend}: span {}", m.span);
        assert!(
            (m.occupied_measure - area).abs() < 1e-5 * area,
            "{backend}: {}",
            m.occupied_measure
        );
    }
}

#[test]
#[expect(
    clippy::cast_possible_truncation,
    reason = "bin counts of the presets, far below u64::MAX"
)]
fn translation_along_the_bearing_stretches_the_arc_in_range_only() {
    // t = d (cos az, sin az, 0): the arc stays in the vertical plane of the bearing, so the
    // azimuth is unchanged and the range is sqrt(r² + d² + 2 r d cos el), largest at el = 0.
    let (s1, s2) = (common::preset("paper-fls"), tall_fls());
    let (r, d) = (4.0, 1.005);
    let az = MID_BEAM.to_radians();
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
        },
        [d * az.cos(), d * az.sin(), 0.0],
    )
    .unwrap();
    let range = |el: f64| (r * r + d * d + 2.0 * r * d * el.to_radians().cos()).sqrt();
    let (lo, hi) = (range(6.0), range(0.0));
    let bins = ((hi - 0.1) / 0.01).floor() - ((lo - 0.1) / 0.01).floor() + 1.0;
    for (backend, m) in run_all(&s1, &s2, r, MID_BEAM, pose) {
        assert_eq!(m.visible, 121, "{backend}");
        close(backend, m.range_min, lo);
        close(backend, m.range_max, hi);
        close(backend, m.azimuth_min, MID_BEAM);
        close(backend, m.azimuth_max, MID_BEAM);
        assert_eq!(
            m.occupied, bins as u64,
            "{backend}: one beam, every bin from lo to hi"
        );
    }
}

#[test]
#[expect(
    clippy::cast_possible_truncation,
    reason = "bin counts of the presets, far below u64::MAX"
)]
fn pitch_90_lays_the_fls_arc_along_the_sss_range_axis() {
    // Pitch 90°: R maps sonar-1 (x, y, z) to sonar-2 (−z, y, x). The arc 5 (cos e, 0, sin e),
    // placed at 15 m in the SSS, becomes (15 − 5 sin e, 0, 5 cos e − 5): a line through the
    // SSS's thin beam along its range axis, every sample visible (|el2| <= 0.11° < 0.15°).
    let (s1, s2) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let rot = Rotation::RollPitchYaw {
        roll: 0.0,
        pitch: 90.0,
        yaw: 0.0,
    };
    let pose = RelativePose::placement(rot, [5.0, 0.0, 0.0], [15.0, 0.0, 0.0]).unwrap();
    let range = |e: f64| {
        let e = e.to_radians();
        ((15.0 - 5.0 * e.sin()).powi(2) + (5.0 * e.cos() - 5.0).powi(2)).sqrt()
    };
    let (lo, hi) = (range(6.0), range(-6.0));
    for (backend, m) in run_all(&s1, &s2, 5.0, 0.0, pose) {
        assert_eq!(m.visible, 121, "{backend}");
        close(backend, m.range_min, lo);
        close(backend, m.range_max, hi);
        assert!(
            (m.span - (hi - lo)).abs() < 1e-5 * 30.0,
            "{backend}: span {}",
            m.span
        );
        // Range falls monotonically along the arc, at most 5 m × 0.1° = 8.7 mm between
        // neighbouring samples: less than a 1 cm bin, so every bin from lo to hi is hit.
        let bins = ((hi - 0.1) / 0.01).floor() - ((lo - 0.1) / 0.01).floor() + 1.0;
        assert_eq!(m.occupied, bins as u64, "{backend}");
        assert!((m.occupied_measure - m.occupied as f64 * 0.01).abs() < 1e-9);
    }
}

#[test]
fn the_field_of_view_cuts_an_sss_surface_at_the_fls_azimuth_bound() {
    // Same origin and orientation: the SSS surface at 5.005 m (azimuth −65..65° in 0.1° steps,
    // elevation −0.15, 0, 0.15°) seen by an FLS of 60.05° aperture keeps the 601 azimuth columns
    // within ±30°; the bound at ±30.025° lies between samples. Beams are 0.117° wide, wider than
    // the 0.1° spacing, so every beam of range bin 490 is hit.
    let s1 = common::preset("paper-sss");
    let s2 = Sonar {
        azimuth_aperture: 60.05,
        ..common::preset("paper-fls")
    };
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
        },
        [0.0; 3],
    )
    .unwrap();
    let row = (60.05f64).to_radians() / 2.0 * (5.01f64.powi(2) - 5.0f64.powi(2));
    for (backend, m) in run_all(&s1, &s2, 5.005, 0.0, pose) {
        assert_eq!((m.visible, m.total), (601 * 3, 1301 * 3), "{backend}");
        close(backend, m.azimuth_min, -30.0);
        close(backend, m.azimuth_max, 30.0);
        assert_eq!(m.occupied, 512, "{backend}");
        assert!(
            (m.occupied_measure - row).abs() < 1e-5 * row,
            "{backend}: {}",
            m.occupied_measure
        );
    }
}

#[test]
fn a_sample_at_sonar_2_origin_is_not_visible() {
    // t = −sph(5, 0, 0) brings the el = 0 sample to sonar 2's origin; an omnidirectional FLS
    // from range 0 sees the other 120.
    let s1 = common::preset("paper-fls");
    let s2 = Sonar {
        name: "omni".into(),
        range_min: 0.0,
        azimuth_aperture: 360.0,
        elevation_aperture: 180.0,
        beams: BeamLayout::Uniform { count: 360 },
        ..common::preset("paper-fls")
    };
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
        },
        [-5.0, 0.0, 0.0],
    )
    .unwrap();
    for (backend, m) in run_all(&s1, &s2, 5.0, 0.0, pose) {
        assert_eq!(m.visible, 120, "{backend}");
    }
}

#[test]
fn nothing_visible_gives_empty_metrics() {
    let (s1, s2) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
        },
        [100.0, 0.0, 0.0],
    )
    .unwrap();
    for (backend, m) in run_all(&s1, &s2, 5.0, 0.0, pose) {
        assert_eq!(
            (m.visible, m.occupied, m.span, m.occupied_measure),
            (0, 0, 0.0, 0.0),
            "{backend}"
        );
        assert_eq!((m.range_min, m.azimuth_max), (None, None), "{backend}");
    }
}

#[test]
fn measurements_at_the_edge_of_sonar_1_are_accepted_and_beyond_rejected() {
    let s = common::preset("paper-fls");
    assert!(Measurement::of(&s, 10.0, 30.0).is_ok());
    assert!(Measurement::of(&s, 0.1, -30.0).is_ok());
    let e = Measurement::of(&s, 10.001, 0.0).unwrap_err();
    assert!(e.to_string().contains("feature range = 10.001"), "{e}");
    let e = Measurement::of(&s, 5.0, 30.01).unwrap_err();
    assert!(e.to_string().contains("feature azimuth = 30.01"), "{e}");
}
