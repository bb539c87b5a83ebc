//! Recovering the lost coordinate (docs/recover.md): random scenes seen by both sonars, for every pair and
//! several presets, with exact measurements (truth among the candidates to 1e-9 m) and noisy ones
//! (truth within the predicted sigmas at the Gaussian rates); degenerate geometry is reported.

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sonarproj::geometry::pose::{cart_to_sph, sph_to_cart};
use sonarproj::recovery::{DEFAULT_CURVE_STEP, Flag, Observation, Recovery, Sigmas, recover};
use sonarproj::{RelativePose, Rotation, Sonar, SonarKind};

use sonarproj_testkit as common;

/// A random scene: a pose and a point seen by both sonars (true point, `[r, az, el]` in each).
struct Scene {
    pose: RelativePose,
    p1: DVec3,
    p2: DVec3,
}

fn point_in(rng: &mut ChaCha8Rng, s: &Sonar) -> [f64; 3] {
    let (ha, he) = (s.azimuth_aperture / 2.0, s.elevation_aperture / 2.0);
    [
        rng.random_range(s.range_min.max(0.2)..s.range_max),
        rng.random_range(-ha..ha),
        rng.random_range(-he..he),
    ]
}

fn scene(rng: &mut ChaCha8Rng, s1: &Sonar, s2: &Sonar) -> Scene {
    let f = point_in(rng, s1);
    let rot = Rotation::RollPitchYaw {
        roll: rng.random_range(-180.0..180.0),
        pitch: rng.random_range(-180.0..180.0),
        yaw: rng.random_range(-180.0..180.0),
    };
    let pose = RelativePose::placement(rot, f, point_in(rng, s2)).unwrap();
    let p1 = sph_to_cart(f[0], f[1].to_radians(), f[2].to_radians());
    Scene {
        pose,
        p1,
        p2: pose.apply(p1),
    }
}

/// Returns what `sonar` measures of `p` (plus noise `(dr, daz_deg)`).
fn observe(sonar: &Sonar, p: DVec3, noise: (f64, f64)) -> Observation {
    let (r, az, _) = cart_to_sph(p);
    Observation {
        range: r + noise.0,
        azimuth: (sonar.kind == SonarKind::Fls).then(|| az.to_degrees() + noise.1),
    }
}

fn run(
    s1: &Sonar,
    s2: &Sonar,
    sc: &Scene,
    o1: Observation,
    o2: Observation,
    sig: Option<Sigmas>,
) -> Recovery {
    recover(s1, s2, &sc.pose, o1, o2, sig, DEFAULT_CURVE_STEP).unwrap()
}

const PAIRS: [(&str, &str); 8] = [
    ("paper-fls", "paper-sss"),
    ("oculus-m1200d-hf", "holoocean-sidescan"),
    ("paper-sss", "paper-fls"),
    ("holoocean-sidescan", "holoocean-imaging"),
    ("paper-fls", "holoocean-imaging"),
    ("oculus-m750d", "oculus-m1200d-hf"),
    ("paper-sss", "holoocean-sidescan"),
    ("holoocean-sidescan", "paper-sss"),
];

#[test]
fn exact_measurements_recover_the_true_point() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for (a, b) in PAIRS {
        let (s1, s2) = (common::preset(a), common::preset(b));
        for k in 0..500 {
            let sc = scene(&mut rng, &s1, &s2);
            let rec = run(
                &s1,
                &s2,
                &sc,
                observe(&s1, sc.p1, (0.0, 0.0)),
                observe(&s2, sc.p2, (0.0, 0.0)),
                None,
            );
            if let Some(curve) = &rec.curve {
                // SSS + SSS: the truth lies on the circle, inside one of the visible arcs.
                let c = DVec3::from_array(curve.center_first);
                let (u, v) = (DVec3::from_array(curve.u_first), DVec3::from_array(curve.v_first));
                let d = sc.p1 - c;
                let theta = d.dot(v).atan2(d.dot(u)).to_degrees().rem_euclid(360.0);
                let on = c + curve.radius * (theta.to_radians().cos() * u + theta.to_radians().sin() * v);
                assert!(
                    (on - sc.p1).length() < 1e-9,
                    "{a}->{b} #{k}: truth {} m off the circle",
                    (on - sc.p1).length()
                );
                let inside = curve.arcs.iter().any(|[s, e]| {
                    (s - 1e-7..=e + 1e-7).contains(&theta) || (s - 1e-7..=e + 1e-7).contains(&(theta + 360.0))
                });
                assert!(
                    inside,
                    "{a}->{b} #{k}: θ {theta} not in the visible arcs {:?}",
                    curve.arcs
                );
                let nearest = rec
                    .candidates
                    .iter()
                    .map(|c| (DVec3::from_array(c.point_first) - sc.p1).length())
                    .fold(f64::INFINITY, f64::min);
                assert!(nearest <= curve.step, "{a}->{b} #{k}: nearest sample {nearest} m");
                continue;
            }
            let hit = rec.candidates.iter().find(|c| {
                (DVec3::from_array(c.point_first) - sc.p1).length() < 1e-9
                    && (DVec3::from_array(c.point_second) - sc.p2).length() < 1e-9
            });
            let hit = hit.unwrap_or_else(|| {
                panic!(
                    "{a}->{b} #{k}: truth not among {:?} (flags {:?})",
                    rec.candidates, rec.flags
                )
            });
            assert!(hit.in_view, "{a}->{b} #{k}: the true point is seen by both");
            if s1.kind == SonarKind::Fls && s2.kind == SonarKind::Fls {
                assert_eq!(
                    hit.rank, 1,
                    "{a}->{b} #{k}: the second azimuth ranks the truth first"
                );
                assert_eq!(hit.consistent, Some(true));
            }
        }
    }
}

/// Returns a standard normal draw (Box–Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

#[test]
fn noisy_measurements_land_within_the_predicted_sigmas() {
    // First-order propagation: |error| <= 1σ about 68.27% of the time, <= 3σ 99.73%, where it
    // holds: small noise (at 2 mm / 0.05° the arc's curvature measurably thins the 3σ coverage,
    // to about 99.45% on these scenes: src/recover.rs), and not near tangency (flagged
    // near_tangent/tangent, or no solution left by the noise), which is counted apart.
    let sig = Sigmas {
        range: 0.0002,
        azimuth: 0.005,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for (a, b) in [
        ("paper-fls", "paper-sss"),
        ("paper-sss", "paper-fls"),
        ("paper-fls", "holoocean-imaging"),
    ] {
        let (s1, s2) = (common::preset(a), common::preset(b));
        let (mut n, mut within1, mut within3, mut lost, mut near) = (0, 0, 0, 0, 0);
        while n < 3000 {
            let sc = scene(&mut rng, &s1, &s2);
            let mut noise = || (sig.range * normal(&mut rng), sig.azimuth * normal(&mut rng));
            let (o1, o2) = (observe(&s1, sc.p1, noise()), observe(&s2, sc.p2, noise()));
            let (Ok(rec), true) = (
                recover(&s1, &s2, &sc.pose, o1, o2, Some(sig), DEFAULT_CURVE_STEP),
                o1.range <= s1.range_max
                    && o2.range <= s2.range_max
                    && o1.range >= s1.range_min
                    && o2.range >= s2.range_min,
            ) else {
                continue; // the noise pushed a measurement out of its sonar
            };
            if rec
                .flags
                .iter()
                .any(|f| matches!(f, Flag::NearTangent | Flag::Tangent | Flag::NoSolution))
            {
                near += 1;
                continue;
            }
            // The recovered coordinate: sonar 1's elevation from an FLS first, else sonar 2's.
            let (truth, idx) = if s1.kind == SonarKind::Fls {
                (cart_to_sph(sc.p1).2, 0)
            } else {
                (cart_to_sph(sc.p2).2, 1)
            };
            let best = rec
                .candidates
                .iter()
                .map(|c| {
                    let el = if idx == 0 { c.first[2] } else { c.second[2] };
                    (el - truth.to_degrees(), c.sigma_elevation)
                })
                .min_by(|x, y| x.0.abs().total_cmp(&y.0.abs()));
            n += 1;
            match best {
                Some((err, Some(s))) => {
                    within1 += usize::from(err.abs() <= s);
                    within3 += usize::from(err.abs() <= 3.0 * s);
                }
                _ => lost += 1,
            }
        }
        let (f1, f3) = (within1 as f64 / n as f64, within3 as f64 / n as f64);
        eprintln!(
            "{a}->{b}: {n} trials, within 1σ {f1:.3}, within 3σ {f3:.4}, no estimate {lost}, \
             near tangency {near}"
        );
        // Binomial spread over 3000 trials, 3 standard errors: 68.27% ± 2.55%; 99.73% - 0.28%.
        assert!((0.657..=0.709).contains(&f1), "{a}->{b}: {f1} within 1σ");
        assert!(f3 >= 0.9945, "{a}->{b}: {f3} within 3σ");
        assert_eq!(
            lost, 0,
            "{a}->{b}: trials without an estimate outside the flagged ones"
        );
        assert!(
            near as f64 <= 0.03 * (n + near) as f64,
            "{a}->{b}: {near} near tangency"
        );
    }
}

#[test]
fn degenerate_geometry_is_reported() {
    let (fls, sss) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let ident = |t: [f64; 3]| {
        RelativePose::new(
            Rotation::RollPitchYaw {
                roll: 0.0,
                pitch: 0.0,
                yaw: 0.0,
            },
            t,
        )
        .unwrap()
    };
    let fls_obs = |r: f64, az: f64| Observation {
        range: r,
        azimuth: Some(az),
    };
    let sss_obs = |r: f64| Observation {
        range: r,
        azimuth: None,
    };
    let go = |s1: &Sonar, s2: &Sonar, pose: RelativePose, o1, o2| {
        recover(s1, s2, &pose, o1, o2, None, DEFAULT_CURVE_STEP).unwrap()
    };

    // No solution: sonar 2 is 10 m ahead, the arc at 5 m is at least 5 m from it, range 2 m.
    let r = go(
        &fls,
        &sss,
        ident([-10.0, 0.0, 0.0]),
        fls_obs(5.0, 0.0),
        sss_obs(2.0),
    );
    assert_eq!(
        (r.flags.as_slice(), r.candidates.len()),
        (&[Flag::NoSolution][..], 0)
    );
    // Tangency: range exactly 5 m touches the arc at el = 0.
    let r = go(
        &fls,
        &sss,
        ident([-10.0, 0.0, 0.0]),
        fls_obs(5.0, 0.0),
        sss_obs(5.0),
    );
    assert!(r.flags.contains(&Flag::Tangent), "{:?}", r.flags);
    assert_eq!(r.candidates.len(), 1);
    assert!(r.candidates[0].first[2].abs() < 1e-6);
    // a² + b² = 0: sonar 2 sits beside the arc's vertical plane, equidistant from all of it.
    let r = go(
        &fls,
        &sss,
        ident([0.0, -3.0, 0.0]),
        fls_obs(5.0, 0.0),
        sss_obs(34f64.sqrt()),
    );
    assert_eq!(r.flags, vec![Flag::Degenerate]);
    assert!(r.candidates.is_empty());
    // Concentric range spheres (SSS + SSS at the same place).
    let r = go(&sss, &sss, ident([0.0; 3]), sss_obs(5.0), sss_obs(5.0));
    assert_eq!(r.flags, vec![Flag::Degenerate]);
    let r = go(&sss, &sss, ident([0.0; 3]), sss_obs(5.0), sss_obs(6.0));
    assert_eq!(r.flags, vec![Flag::NoSolution]);
    // Solutions outside the fields of view are returned, flagged.
    let r = go(
        &fls,
        &fls,
        ident([0.0, 0.0, -1.0]),
        fls_obs(5.0, 0.0),
        fls_obs(4.5, 0.0),
    );
    assert!(
        r.candidates.iter().all(|c| !c.in_view) && r.flags.contains(&Flag::NoneInView),
        "{r:?}"
    );
}

#[test]
fn bad_observations_name_the_field() {
    let (fls, sss) = (common::preset("paper-fls"), common::preset("paper-sss"));
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
        },
        [1.0, 0.0, 0.0],
    )
    .unwrap();
    let cases = [
        (
            Observation {
                range: 5.0,
                azimuth: None,
            },
            Observation {
                range: 5.0,
                azimuth: None,
            },
            "first azimuth",
        ),
        (
            Observation {
                range: 5.0,
                azimuth: Some(0.0),
            },
            Observation {
                range: 5.0,
                azimuth: Some(1.0),
            },
            "second azimuth = 1",
        ),
        (
            Observation {
                range: 11.0,
                azimuth: Some(0.0),
            },
            Observation {
                range: 5.0,
                azimuth: None,
            },
            "first range = 11",
        ),
        (
            Observation {
                range: 5.0,
                azimuth: Some(40.0),
            },
            Observation {
                range: 5.0,
                azimuth: None,
            },
            "first azimuth = 40",
        ),
        (
            Observation {
                range: f64::NAN,
                azimuth: Some(0.0),
            },
            Observation {
                range: 5.0,
                azimuth: None,
            },
            "first range = NaN",
        ),
    ];
    for (o1, o2, want) in cases {
        let e = recover(&fls, &sss, &pose, o1, o2, None, DEFAULT_CURVE_STEP).unwrap_err();
        assert!(e.is_input() && e.to_string().contains(want), "{e} lacks {want}");
    }
}
