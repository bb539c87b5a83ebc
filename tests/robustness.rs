//! Arbitrary values (NaN, infinities, zero, negative, huge, tiny) through every public
//! constructor and entry point of the engine: each returns `Ok` or a typed error, and never
//! panics or aborts. A value that passes validation must also run: projections on both CPU
//! backends, masks and recovery are carried out whenever a constructor accepted their inputs.

use sonarproj_testkit as common;

use glam::{DMat3, DVec3};
use proptest::prelude::*;
use sonarproj::Output;
use sonarproj::masks::{Counts, MaskEngine, Noise};
use sonarproj::recovery::{Observation, Sigmas, recover};
use sonarproj::rig::{Mount, relative_pose, sidescan_pair};
use sonarproj::stream::Stop;
use sonarproj::{
    Backend, Batch, BatchItem, BeamLayout, Measurement, MetricColumns, PosePairs, PoseSource, PoseSweep,
    RelativePose, Rotation, Sampling, Sonar, SonarKind,
};

/// Returns a strategy over the floats that break code: specials, signs, extremes, and plain
/// values near the scales sonars use.
fn wild() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(0.0),
        Just(-0.0),
        Just(f64::MAX),
        Just(f64::MIN_POSITIVE),
        Just(1e-300),
        Just(1e300),
        Just(-1.0),
        Just(360.0),
        Just(180.0),
        -1e3..1e3f64,
        0.0..200.0f64,
    ]
}

/// Returns a strategy over counts: zero, one, typical, the limits and beyond.
fn count() -> impl Strategy<Value = u32> {
    prop_oneof![Just(0u32), Just(1), Just(u32::MAX), Just(1 << 20), 1..2048u32]
}

fn kind() -> impl Strategy<Value = SonarKind> {
    prop_oneof![Just(SonarKind::Fls), Just(SonarKind::Sss)]
}

fn beams() -> impl Strategy<Value = BeamLayout> {
    prop_oneof![
        count().prop_map(|count| BeamLayout::Uniform { count }),
        proptest::collection::vec(wild(), 0..6).prop_map(BeamLayout::Edges),
        Just(BeamLayout::Edges(vec![-60.0, -10.0, 0.0, 5.0, 60.0])),
    ]
}

/// Returns a strategy over sonars: arbitrary fields, and presets (so that valid pairs occur).
fn sonar() -> impl Strategy<Value = Sonar> {
    let built = (kind(), wild(), wild(), wild(), wild(), count(), beams()).prop_map(
        |(kind, range_min, range_max, azimuth_aperture, elevation_aperture, range_bins, beams)| Sonar {
            name: "arbitrary".into(),
            kind,
            range_min,
            range_max,
            azimuth_aperture,
            elevation_aperture,
            range_bins,
            beams,
        },
    );
    let preset = proptest::sample::select(Sonar::preset_names()).prop_map(|n| Sonar::preset(n).unwrap());
    prop_oneof![1 => built, 3 => preset]
}

fn rotation() -> impl Strategy<Value = Rotation> {
    prop_oneof![
        (wild(), wild(), wild()).prop_map(|(roll, pitch, yaw)| Rotation::RollPitchYaw { roll, pitch, yaw }),
        prop::array::uniform4(wild()).prop_map(Rotation::QuaternionWxyz),
        prop::array::uniform3(prop::array::uniform3(wild())).prop_map(Rotation::Matrix),
        (-180.0..180.0f64, -90.0..90.0f64, -180.0..180.0f64)
            .prop_map(|(roll, pitch, yaw)| Rotation::RollPitchYaw { roll, pitch, yaw }),
    ]
}

/// Returns a strategy over poses: from the constructors when they accept, and built by hand
/// with arbitrary matrices and translations.
fn pose() -> impl Strategy<Value = RelativePose> {
    let constructed = (rotation(), prop::array::uniform3(wild()))
        .prop_filter_map("rejected by RelativePose::new", |(r, t)| {
            RelativePose::new(r, t).ok()
        });
    let by_hand =
        (prop::array::uniform9(wild()), prop::array::uniform3(wild())).prop_map(|(m, t)| RelativePose {
            rotation: DMat3::from_cols_array(&m),
            translation: DVec3::from_array(t),
        });
    let placed = (-30.0..30.0f64, 1.0..20.0f64).prop_map(|(yaw, r)| {
        RelativePose::placement(
            Rotation::RollPitchYaw {
                roll: 0.0,
                pitch: 0.0,
                yaw,
            },
            [r, 0.0, 0.0],
            [r, 0.0, 0.0],
        )
        .unwrap()
    });
    prop_oneof![2 => constructed, 1 => by_hand, 3 => placed]
}

fn sampling() -> impl Strategy<Value = Sampling> {
    prop_oneof![
        Just(Sampling::Auto),
        Just(Sampling::Exact),
        wild().prop_map(Sampling::Step),
        (0.05..5.0f64).prop_map(Sampling::Step)
    ]
}

/// Returns a strategy over one coordinate of a feature: arbitrary, or (as `Err(f)`) a
/// fraction `f` of the sonar's span, resolved by [`within`] so that valid features are common.
fn coordinate() -> impl Strategy<Value = Result<f64, f64>> {
    prop_oneof![1 => wild().prop_map(Ok), 3 => (0.0..=1.0f64).prop_map(Err)]
}

/// Returns the coordinate: the arbitrary value, or the fraction of `[lo, hi]`.
fn within(c: Result<f64, f64>, lo: f64, hi: f64) -> f64 {
    c.unwrap_or_else(|f| lo + f * (hi - lo))
}

/// The most samples a projection in this test may draw: larger valid batches are correct but
/// too slow on the reference for hundreds of cases (the engine's own cap is checked apart).
const TEST_SAMPLES: usize = 2_000_000;

proptest! {
    #![proptest_config(common::proptest_config())]

    #[test]
    fn sonars_validate_without_panicking(s in sonar()) {
        let ok = s.clone().validated().is_ok();
        // A sonar that validates has a sane layout.
        if ok {
            prop_assert!(s.beam_count() >= 1 && s.range_bins >= 1);
            prop_assert!(s.range_max > s.range_min);
        }
    }

    #[test]
    fn rotations_and_poses_never_panic(r in rotation(), t in prop::array::uniform3(wild()),
                                       a in prop::array::uniform3(wild()), b in prop::array::uniform3(wild())) {
        if let Ok(m) = r.to_matrix() {
            prop_assert!(m.to_cols_array().iter().all(|v| v.is_finite()));
        }
        if let Ok(p) = RelativePose::new(r, t) {
            prop_assert!(p.validate().is_ok());
        }
        if let Ok(p) = RelativePose::placement(r, a, b) {
            prop_assert!(p.translation.is_finite());
        }
    }

    #[test]
    fn rigs_never_panic(q in prop::array::uniform4(wild()), o in prop::array::uniform3(wild()),
                        rpy in prop::array::uniform3(wild()), channel in sonar(), depression in wild()) {
        let q = glam::DQuat::from_xyzw(q[0], q[1], q[2], q[3]);
        let o = DVec3::from_array(o);
        let mounts = [
            Mount::new(q, o),
            Mount::from_frd(q, o),
            Mount::from_rpy_deg(rpy[0], rpy[1], rpy[2], o),
        ];
        for a in mounts.iter().flatten() {
            for b in mounts.iter().flatten() {
                let pose = relative_pose(a, b);
                prop_assert!(pose.is_ok_and(|p| p.validate().is_ok()));
            }
        }
        if let Ok(pair) = sidescan_pair(&channel, depression, o, -o) {
            prop_assert!(pair.port.0.validate().is_ok() && pair.starboard.0.validate().is_ok());
        }
        let _ = Rotation::Quat(q).to_matrix();
        if let Ok(s) = channel.with_beam_centres(&rpy, None) {
            prop_assert!(s.validate().is_ok());
        }
    }

    #[test]
    fn batches_project_or_refuse(source in sonar(), target in sonar(), sampling in sampling(),
                                 range in coordinate(), azimuth in coordinate(), pose in pose()) {
        let range = within(range, source.range_min, source.range_max);
        let azimuth = within(azimuth, -source.azimuth_aperture / 2.0, source.azimuth_aperture / 2.0);
        let batch = Batch { sigma_range: None,
            source: source.clone(),
            target,
            sampling,
            area_grid: sonarproj::PAPER_AREA_GRID,
            items: vec![BatchItem { true_point: None,  measurement: Measurement { range, azimuth }, pose }],
        };
        // The one-item check of a streaming reader agrees with preparing the batch.
        let checked = batch.checker().and_then(|c| c.check(&batch.items[0]));
        let Ok(prepared) = batch.prepare() else {
            prop_assert!(checked.is_err(), "the checker accepted what prepare refused");
            return Ok(());
        };
        prop_assert!(checked.is_ok(), "the checker refused what prepare accepted: {:?}", checked);
        // Accepted: every part is valid, so the measurement could come from sonar 1.
        prop_assert!(Measurement::of(&source, range, azimuth).is_ok());
        prop_assert!(pose.validate().is_ok());
        let samples: usize = prepared.total_samples();
        if samples <= TEST_SAMPLES {
            for backend in [Backend::Cpu, Backend::CpuFast] {
                let out = backend.project(&batch, Output::WithOccupancy).expect("a prepared batch projects");
                prop_assert_eq!(out.len(), 1);
                prop_assert!(out[0].metrics.visible <= out[0].metrics.total);
            }
        }
    }

    /// A pose paired with a feature ([`PosePairs`]) is refused exactly when its item is, and
    /// otherwise projects, through the columns, to its item's metrics bit for bit, on both CPU
    /// backends (the fast path from the tables, sampled or exact).
    #[test]
    fn pairs_project_or_refuse_as_their_item(source in sonar(), target in sonar(), sampling in sampling(),
                                             range in coordinate(), azimuth in coordinate(), pose in pose()) {
        let range = within(range, source.range_min, source.range_max);
        let azimuth = within(azimuth, -source.azimuth_aperture / 2.0, source.azimuth_aperture / 2.0);
        let measurement = Measurement { range, azimuth };
        let batch = Batch { sigma_range: None,
            source: source.clone(),
            target: target.clone(),
            sampling,
            area_grid: sonarproj::PAPER_AREA_GRID,
            items: vec![BatchItem { true_point: None, measurement, pose }],
        };
        let pairs = PosePairs::new(vec![pose], vec![measurement], vec![[0, 0]]).expect("indices within their tables");
        let sweep = PoseSweep { source, target, sampling, area_grid: sonarproj::PAPER_AREA_GRID,
                                poses: PoseSource::Pairs(&pairs) };
        let prepared = batch.prepare();
        if prepared.as_ref().is_ok_and(|p| p.total_samples() > TEST_SAMPLES) {
            return Ok(());
        }
        for backend in [Backend::Cpu, Backend::CpuFast] {
            let mut columns = MetricColumns::default();
            let got = backend.project_columns(&sweep, 0..1, &mut columns, Stop::NEVER);
            prop_assert_eq!(got.is_ok(), prepared.is_ok(), "{}: pairs {:?}, item {:?}",
                            backend.name(), got.as_ref().err(), prepared.as_ref().err());
            if got.is_ok() {
                let item = backend.project(&batch, Output::MetricsOnly).expect("a prepared batch projects");
                prop_assert_eq!(format!("{:?}", columns.get(0)), format!("{:?}", item[0].metrics),
                                "{}", backend.name());
            }
        }
    }

    #[test]
    fn masks_draw_or_refuse(source in sonar(), target in sonar(), pose in pose(),
                            range in coordinate(), azimuth in coordinate(),
                            noise in prop::option::of((prop::array::uniform3(wild()), prop::array::uniform3(wild()), wild(), wild(), wild())),
                            counts in any::<bool>()) {
        let range = within(range, source.range_min, source.range_max);
        let azimuth = within(azimuth, -source.azimuth_aperture / 2.0, source.azimuth_aperture / 2.0);
        let Ok(engine) = MaskEngine::new(source, target) else { return Ok(()) };
        let noise = noise.map(|(rotation, translation, range, azimuth, coverage)| Noise { rotation, translation, range, azimuth, coverage });
        let features = [Measurement { range, azimuth }];
        let counts = if counts { Counts::Draw } else { Counts::Skip };
        if let Ok(set) = engine.masks(&pose, &features, noise.as_ref(), counts) {
            prop_assert!(pose.validate().is_ok());
            prop_assert_eq!(set.masks.len(), 1);
        }
    }

    #[test]
    fn recovery_answers_or_refuses(s1 in sonar(), s2 in sonar(), pose in pose(),
                                   r1 in coordinate(), a1 in coordinate(), flip1 in prop::bool::weighted(0.2),
                                   r2 in coordinate(), a2 in coordinate(), flip2 in prop::bool::weighted(0.2),
                                   sigmas in prop::option::of((wild(), wild())), step in wild()) {
        let sigmas = sigmas.map(|(range, azimuth)| Sigmas { range, azimuth });
        // An azimuth for an FLS, none for an SSS; the other way round one time in five.
        let observe = |s: &Sonar, r, a, flip: bool| Observation {
            range: within(r, s.range_min, s.range_max),
            azimuth: ((s.kind == SonarKind::Fls) != flip)
                .then(|| within(a, -s.azimuth_aperture / 2.0, s.azimuth_aperture / 2.0)),
        };
        let first = observe(&s1, r1, a1, flip1);
        let second = observe(&s2, r2, a2, flip2);
        if let Ok(rec) = recover(&s1, &s2, &pose, first, second, sigmas, step) {
            prop_assert!(rec.candidates.iter().all(|c| c.point_first.iter().all(|v| v.is_finite())));
        }
    }
}
