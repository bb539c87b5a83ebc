//! The rig advisor's honesty: standard errors that match the spread of scores over feature
//! seeds, ties and "stay" where the objective is flat, a correspondence objective that never
//! improves by sharing fewer features, moves in words that agree with the documented frames, and
//! a covering bound for the uniform rotations that holds.

use sonarproj::geometry::pose::{RelativePose, Rotation, cart_to_sph, sph_to_cart};
use sonarproj::occupancy::Layout;
use sonarproj::projection::Backend;
use sonarproj_apps::advise::{self, AdviseConfig, Features};

fn config(text: &str) -> AdviseConfig {
    AdviseConfig::parse("test.toml", text, std::path::Path::new(".")).unwrap()
}

/// The example's sonar pair and rig, one candidate (roll 5, pitch −5), `count` features of
/// `seed`, objective `objective`.
fn one_pose(objective: &str, count: usize, seed: u64) -> AdviseConfig {
    // A mix whose two parts weigh about alike at 300 features.
    let mix = if objective == "mix" {
        "[mix]\nweight = 0.5\nmetric_scale = 1\nsigma_scale = 0.0001\n"
    } else {
        ""
    };
    config(&format!(
        "from = \"paper-fls\"\nto = \"paper-fls\"\nstep = 0.1\nobjective = \"{objective}\"\n{mix}\
         [features]\ncount = {count}\nseed = {seed}\n[rig]\norigin = [0, 0, -0.5]\n\
         [search]\nroll = 5\npitch = -5\nyaw = 0\nrefine = 0\n"
    ))
}

/// Returns the mean and the sample standard deviation of `v`.
fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

#[test]
fn standard_errors_match_the_spread_over_feature_seeds() {
    // 40 seeds of 300 features: the scores' standard deviation over the seeds is what score_se
    // estimates from one seed. With 40 seeds the deviation itself is known to about ±11 % (1/√80),
    // so the two agree within a factor 1.4 unless the estimate is wrong (a missing √n, the shared
    // features' count in place of the points examined, would be off by 1.05–30×).
    for (objective, band) in [
        ("correspondence", 1.4),
        ("ambiguity", 1.4),
        ("recovery", 1.6),
        ("mix", 1.6),
    ] {
        let (mut scores, mut ses, mut shared, mut shared_ses) = (vec![], vec![], vec![], vec![]);
        for seed in 1..=40 {
            let a = advise::advise(&one_pose(objective, 300, seed), &Backend::CpuFast).unwrap();
            let s = a.candidates[0].1;
            scores.push(s.score.unwrap());
            ses.push(s.score_se.unwrap());
            shared.push(s.shared);
            shared_ses.push(s.shared_se);
        }
        let (_, spread) = mean_sd(&scores);
        let (se, _) = mean_sd(&ses);
        println!("{objective}: spread {spread} over 40 seeds, mean score_se {se}");
        assert!(
            spread / se < band && se / spread < band,
            "{objective}: scores spread {spread} over seeds, score_se {se}"
        );
        let (_, spread) = mean_sd(&shared);
        let (se, _) = mean_sd(&shared_ses);
        assert!(
            spread / se < 1.4 && se / spread < 1.4,
            "shared spread {spread} over seeds, shared_se {se}"
        );
    }
}

/// Returns the points of a seeded draw over sonar 1 (paper-fls) that sonar 2 (paper-fls at
/// `pose`) sees, and those it does not.
fn seen_and_unseen(pose: &RelativePose, n: usize) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let source = sonarproj::Sonar::preset("paper-fls").unwrap();
    let layout = Layout::of(&source);
    advise::features::draw_features(&source, n, 11)
        .into_iter()
        .partition(|f| {
            let (r, az, el) =
                cart_to_sph(pose.apply(sph_to_cart(f[0], f[1].to_radians(), f[2].to_radians())));
            layout.inside(r, az, el)
        })
}

/// Returns the candidate's score under `objective` over the given `points`.
fn score_of_points(objective: &str, points: &[[f64; 3]]) -> f64 {
    let mut c = one_pose(objective, 1, 1);
    c.features = Features::Points(points.to_vec());
    c.min_shared = 0.0;
    advise::advise(&c, &Backend::CpuFast).unwrap().candidates[0]
        .1
        .score
        .unwrap()
}

#[test]
fn the_default_objective_never_improves_by_sharing_fewer_features() {
    // The pose of `one_pose`: its shared features, each replaced in turn (most ambiguous first)
    // by a point sonar 2 does not see. The mean area of the shared ones (ambiguity) falls, as
    // the old objective rewarded; the correspondence objective rises at every step.
    let c = one_pose("correspondence", 1, 1);
    let pose = c.pose_of([5.0, -5.0, 0.0, 0.0, 0.0, 0.0]).unwrap();
    let (seen, unseen) = seen_and_unseen(&pose, 400);
    let mut seen: Vec<[f64; 3]> = seen.into_iter().take(60).collect();
    assert!(
        seen.len() == 60 && unseen.len() >= 20,
        "{} {}",
        seen.len(),
        unseen.len()
    );
    // Most ambiguous first: each feature's own area, from a one-point score.
    let mut areas: Vec<(f64, [f64; 3])> = seen
        .iter()
        .map(|&p| (score_of_points("ambiguity", &[p]), p))
        .collect();
    areas.sort_by(|a, b| b.0.total_cmp(&a.0));
    seen = areas.iter().map(|a| a.1).collect();
    let mut points = seen.clone();
    let (mut cost, mut ambiguity) = (
        score_of_points("correspondence", &points),
        score_of_points("ambiguity", &points),
    );
    for (k, &u) in unseen.iter().take(20).enumerate() {
        points[k] = u;
        let (c2, a2) = (
            score_of_points("correspondence", &points),
            score_of_points("ambiguity", &points),
        );
        assert!(c2 > cost, "sharing one fewer lowered the cost {cost} to {c2}");
        assert!(
            a2 <= ambiguity,
            "the ambiguity of fewer, less ambiguous features rose"
        );
        (cost, ambiguity) = (c2, a2);
    }
}

/// Returns the config of a flat recovery objective: sonar 2 sees everything within 30 m of it
/// (360° × 180°), at a fixed origin 0.5 m below sonar 1, so every feature is shared and its
/// range, the only thing the recovery sigma depends on, does not change as sonar 2 turns.
fn flat(dir: &std::path::Path) -> AdviseConfig {
    let sonar = dir.join("all-round.toml");
    std::fs::write(
        &sonar,
        "kind = \"fls\"\nrange_min = 0.1\nrange_max = 30\nazimuth_aperture = 360\n\
         elevation_aperture = 180\nrange_bins = 300\nbeams = 64\n",
    )
    .unwrap();
    config(&format!(
        "from = \"paper-fls\"\nto = {:?}\nstep = 1\nobjective = \"recovery\"\n\
         [features]\ncount = 100\nseed = 2\n[rig]\norigin = [0, 0, -0.5]\n\
         [search]\nroll = {{ start = -30, stop = 30, step = 15 }}\npitch = {{ start = -30, stop = 30, step = 15 }}\n\
         refine = 1\n[from_pose]\nroll = 15\npitch = 0\nstep = 5\n",
        sonar.display().to_string()
    ))
}

#[test]
fn a_flat_objective_ties_everything_says_stay_and_warns() {
    let dir = tempfile::tempdir().unwrap();
    let c = flat(dir.path());
    let a = advise::advise(&c, &Backend::CpuFast).unwrap();
    assert_eq!(a.ranked.len(), a.candidates.len() - count_repeats(&a));
    for &i in &a.ranked {
        let s = &a.candidates[i].1;
        assert_eq!(s.shared, 1.0);
        assert!(
            s.tied,
            "{:?} not tied: {:?} ± {:?}",
            s.rotation, s.score, s.score_se
        );
    }
    // Ties go to the pose now: nothing is gained by moving.
    let recommended = &a.candidates[a.recommended.unwrap()].1;
    assert_eq!(recommended.rotation, [15.0, 0.0, 0.0]);
    let m = a.next.unwrap();
    assert!(m.stay && m.words.is_none(), "{m:?}");
    assert_eq!(a.warnings.len(), 1);
    assert!(a.warnings[0].contains("baseline"), "{}", a.warnings[0]);
    // Without a pose now, the tie goes to the roundest angles: level.
    let mut c = c;
    c.from_pose = None;
    let a2 = advise::advise(&c, &Backend::CpuFast).unwrap();
    assert_eq!(a2.candidates[a2.recommended.unwrap()].1.rotation, [0.0, 0.0, 0.0]);
    // The refinement stops at once: no move gains a standard error.
    assert!(
        a.candidates
            .iter()
            .filter(|c| c.0 == advise::Stage::Refine)
            .count()
            <= 40,
        "refined on noise"
    );
}

/// Returns how many candidates repeat an earlier one's values (the ranking keeps one of each).
fn count_repeats(a: &advise::Advice) -> usize {
    let mut seen = std::collections::HashSet::new();
    a.candidates
        .iter()
        .filter(|c| !seen.insert(c.1.params().map(f64::to_bits)))
        .count()
}

#[test]
fn the_example_offers_a_move_only_beyond_its_noise() {
    let c = config(
        &std::fs::read_to_string(sonarproj_testkit::repository().join("data/example-advise.toml")).unwrap(),
    );
    let a = advise::advise(&c, &Backend::CpuFast).unwrap();
    let tied = a.ranked.iter().filter(|&&i| a.candidates[i].1.tied).count();
    assert!(
        tied >= 1 && tied < a.ranked.len() / 2,
        "{tied} of {} tied",
        a.ranked.len()
    );
    let best = a.best().unwrap();
    for &i in &a.ranked {
        let s = &a.candidates[i].1;
        let within = s.score.unwrap() <= best.score.unwrap() + 2.0 * best.score_se.unwrap();
        assert_eq!(s.tied, within);
    }
    let m = a.next.unwrap();
    let (gain, se) = (m.gain.unwrap(), m.gain_se.unwrap());
    assert_eq!(m.stay, gain <= 2.0 * se);
    let (now, moved) = (m.now.score_se.unwrap(), m.best.unwrap().score_se.unwrap());
    assert_eq!(se, now.hypot(moved));
    // The gradient is the central difference of the scores it was taken from.
    let scorer = advise::Scorer::new(&c, &Backend::CpuFast).unwrap();
    let from = m.now.params();
    assert_eq!(m.gradient[2], None, "yaw is not searched");
    for k in 0..2 {
        let h = m.gradient_step[k];
        let (mut lo, mut hi) = (from, from);
        lo[k] -= h;
        hi[k] += h;
        let s = scorer.score_all(&[lo, hi]).unwrap();
        let fd = (s[1].score.unwrap() - s[0].score.unwrap()) / (2.0 * h);
        assert_eq!(m.gradient[k], Some(fd));
    }
}

#[test]
fn the_move_is_the_same_across_seeds_within_its_error() {
    // The example's move from its pose now, found with four feature seeds. Each seed's move,
    // scored with every other seed's features, gains what that seed's own move gains, within
    // twice that gain's standard error: the move does not depend on the draw.
    let text =
        std::fs::read_to_string(sonarproj_testkit::repository().join("data/example-advise.toml")).unwrap();
    let configs: Vec<AdviseConfig> = (1..=4)
        .map(|seed| config(&text.replace("seed = 1", &format!("seed = {seed}"))))
        .collect();
    let moves: Vec<advise::Move> = configs
        .iter()
        .map(|c| advise::advise(c, &Backend::CpuFast).unwrap().next.unwrap())
        .collect();
    for (j, c) in configs.iter().enumerate() {
        let own = &moves[j];
        assert!(!own.stay, "seed {}: {own:?}", j + 1);
        let scorer = advise::Scorer::new(c, &Backend::CpuFast).unwrap();
        for (i, m) in moves.iter().enumerate() {
            let moved = scorer.score_all(&[m.best.unwrap().params()]).unwrap()[0];
            let gain = own.now.score.unwrap() - moved.score.unwrap();
            assert!(
                gain >= own.gain.unwrap() - 2.0 * own.gain_se.unwrap(),
                "seed {}'s move gains {gain} with seed {}'s features, whose own gains {} ± {}",
                i + 1,
                j + 1,
                own.gain.unwrap(),
                own.gain_se.unwrap()
            );
        }
    }
}

#[test]
fn the_ranking_is_a_brute_force_ranking() {
    // A 5 × 5 grid of the example's pair, 100 features: every candidate scored here from the
    // draw itself (the first 100 points sonar 2 sees, in order, each projected alone) with the
    // cost written out, then ranked; the advisor's ranking and scores must be the same.
    let c = config(
        "from = \"paper-fls\"\nto = \"paper-fls\"\nmin_shared = 0.3\n\
         [features]\ncount = 100\nseed = 4\n[rig]\norigin = [0, 0, -0.5]\n\
         [search]\nroll = { start = -20, stop = 20, step = 10 }\npitch = { start = -10, stop = 10, step = 5 }\n\
         yaw = 0\nrefine = 0\n",
    );
    let a = advise::advise(&c, &Backend::CpuFast).unwrap();
    let draw = advise::features::draw_features(&c.source, 100 * 100, 4);
    let layout = Layout::of(&c.target);
    let blind = 60f64.to_radians() / 2.0 * (10f64.powi(2) - 0.1f64.powi(2));
    let mut by_hand: Vec<(f64, [f64; 6])> = Vec::new();
    for roll in [-20.0, -10.0, 0.0, 10.0, 20.0] {
        for pitch in [-10.0, -5.0, 0.0, 5.0, 10.0] {
            let params = [roll, pitch, 0.0, 0.0, 0.0, 0.0];
            let pose = c.pose_of(params).unwrap();
            let (mut examined, mut kept) = (0, Vec::new());
            for (i, f) in draw.iter().enumerate() {
                if kept.len() == 100 {
                    break;
                }
                examined = i + 1;
                let p = sph_to_cart(f[0], f[1].to_radians(), f[2].to_radians());
                let (r, az, el) = cart_to_sph(pose.apply(p));
                if layout.inside(r, az, el) {
                    kept.push(*f);
                }
            }
            if kept.len() < 100 {
                examined = draw.len();
            }
            let items: Vec<sonarproj::projection::BatchItem> = kept
                .iter()
                .filter_map(|f| sonarproj::sampling::Measurement::of(&c.source, f[0], f[1]).ok())
                .map(|measurement| sonarproj::projection::BatchItem {
                    true_point: None,
                    measurement,
                    pose,
                })
                .collect();
            let shared = items.len() as f64 / examined as f64;
            if items.is_empty() || shared < 0.3 {
                continue;
            }
            let batch = sonarproj::projection::Batch {
                sigma_range: None,
                source: c.source.clone(),
                target: c.target.clone(),
                sampling: sonarproj::sampling::Sampling::Exact,
                area_grid: c.area_grid,
                items,
            };
            let projected = Backend::CpuFast
                .project(&batch, sonarproj::Output::MetricsOnly)
                .unwrap();
            let seen: f64 = projected
                .iter()
                .map(|p| p.metrics.occupied_measure.min(blind))
                .sum();
            let unseen = (examined - projected.len()) as f64 * blind;
            by_hand.push(((seen + unseen) / examined as f64, params));
        }
    }
    by_hand.sort_by(|x, y| x.0.total_cmp(&y.0));
    assert!(by_hand.len() >= 10, "{} feasible", by_hand.len());
    assert_eq!(a.ranked.len(), by_hand.len());
    for (k, &i) in a.ranked.iter().enumerate() {
        let s = &a.candidates[i].1;
        assert_eq!(s.params(), by_hand[k].1, "rank {k}");
        let score = s.score.unwrap();
        assert!(
            (score - by_hand[k].0).abs() <= 1e-12 * score,
            "rank {k}: {score} against {}",
            by_hand[k].0
        );
    }
}

/// Returns sonar 2's orientation in sonar 1's frame for roll, pitch, yaw (deg): `Q = Rᵀ`, the
/// transpose of the pose rotation the documented convention defines.
fn orientation(r: [f64; 3]) -> glam::DMat3 {
    Rotation::RollPitchYaw {
        roll: r[0],
        pitch: r[1],
        yaw: r[2],
    }
    .to_matrix()
    .unwrap()
    .transpose()
}

/// Returns the rotation by `angle` (deg) about the unit `axis`, Rodrigues' formula.
fn about(axis: glam::DVec3, angle: f64) -> glam::DMat3 {
    let (s, c) = angle.to_radians().sin_cos();
    let k = glam::DMat3::from_cols(
        glam::DVec3::new(0.0, axis.z, -axis.y),
        glam::DVec3::new(-axis.z, 0.0, axis.x),
        glam::DVec3::new(axis.y, -axis.x, 0.0),
    );
    glam::DMat3::IDENTITY + k * s + k * k * (1.0 - c)
}

#[test]
fn moves_in_words_agree_with_the_documented_frames() {
    // From level, off-axis, upside-down and boresight-vertical poses (the paper's sidescan
    // mount), one-angle and combined changes: the motion's tilt, turn and roll rebuild the new
    // orientation from the old (tilt the boresight, turn it about the vertical, roll about it),
    // and the words say each part with its direction.
    let starts = [
        [0.0, 0.0, 0.0],
        [10.0, -20.0, 30.0],
        [180.0, 0.0, 0.0],
        [0.0, 90.0, 0.0],
        [45.0, 60.0, -120.0],
    ];
    let steps = [
        [5.0, 0.0, 0.0],
        [0.0, 5.0, 0.0],
        [0.0, 0.0, 5.0],
        [-3.0, 4.0, -2.0],
    ];
    for from in starts {
        for step in steps {
            let to = [from[0] + step[0], from[1] + step[1], from[2] + step[2]];
            let m = advise::search::motion(from, to);
            let (q0, q1) = (orientation(from), orientation(to));
            let (b0, b1) = (q0.x_axis, q1.x_axis);
            // The boresight: its elevation and heading, from the matrices.
            let el = |b: glam::DVec3| b.z.atan2(b.x.hypot(b.y)).to_degrees();
            assert!(
                (m.tilt - (el(b1) - el(b0))).abs() < 1e-9,
                "{from:?} -> {to:?}: {m:?}"
            );
            // Rebuild: the shortest turn of the boresight (about b0 × b1), then the roll about b1.
            let axis = b0.cross(b1);
            let shortest = if axis.length() < 1e-12 {
                glam::DMat3::IDENTITY
            } else {
                about(axis.normalize(), b0.dot(b1).clamp(-1.0, 1.0).acos().to_degrees())
            };
            let rebuilt = about(b1, m.roll) * shortest * q0;
            for (a, b) in [
                (rebuilt.x_axis, q1.x_axis),
                (rebuilt.y_axis, q1.y_axis),
                (rebuilt.z_axis, q1.z_axis),
            ] {
                assert!(
                    (a - b).length() < 1e-9,
                    "{from:?} -> {to:?}: {m:?} rebuilds {a} for {b}"
                );
            }
            if let Some(turn) = m.turn {
                let heading = |b: glam::DVec3| b.y.atan2(b.x).to_degrees();
                let d = (heading(b1) - heading(b0) + 540.0).rem_euclid(360.0) - 180.0;
                assert!((turn - d).abs() < 1e-9);
            } else {
                assert!(b0.z.abs() > 0.9998 || b1.z.abs() > 0.9998);
            }
            let words = advise::search::move_words(
                [from[0], from[1], from[2], 0.0, 0.0, 0.0],
                [to[0], to[1], to[2], 0.0, 0.0, 0.0],
            );
            let said = |w: &str| words.contains(w);
            assert_eq!(said("tilts down"), m.tilt < -5e-4, "{words}");
            assert_eq!(said("tilts up"), m.tilt > 5e-4, "{words}");
            assert_eq!(said("to port"), m.turn.is_some_and(|t| t > 5e-4), "{words}");
            assert_eq!(said(" clockwise"), m.roll > 5e-4, "{words}");
            assert_eq!(said("counter-clockwise"), m.roll < -5e-4, "{words}");
        }
    }
    // The sidescan mount (boresight straight down): a yaw turns it about its own boresight.
    let m = advise::search::motion([0.0, 90.0, 0.0], [0.0, 90.0, 5.0]);
    assert!(
        m.tilt.abs() < 1e-9 && m.turn.is_none() && (m.roll.abs() - 5.0).abs() < 1e-9,
        "{m:?}"
    );
    // The example's comment describes its pose now in the same words.
    let text =
        std::fs::read_to_string(sonarproj_testkit::repository().join("data/example-advise.toml")).unwrap();
    let c = config(&text);
    let p = c.from_pose.unwrap().rotation;
    let words = advise::search::move_words([0.0; 6], [p[0], p[1], p[2], 0.0, 0.0, 0.0]);
    let effects = &words[words.find(": ").unwrap() + 2..];
    let comment: String = text
        .lines()
        .filter_map(|l| l.strip_prefix("# "))
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        comment.contains(effects),
        "the example should say {effects:?} ({words})"
    );
}

#[test]
fn the_uniform_cover_meets_its_stated_bound() {
    // The documented bound: no rotation farther than 1.7 (6π/N)^⅓ from one of N uniform
    // rotations. 10^5 random rotations (uniform quaternions) against covers of 300 to 5000, the
    // farthest then climbed to the centres of the holes (measured: 1.51–1.59 times).
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let queries: Vec<glam::DQuat> = (0..100_000)
        .map(|_| {
            loop {
                let v = [(); 4].map(|()| 2.0 * rng.random::<f64>() - 1.0);
                let n = v.iter().map(|x| x * x).sum::<f64>();
                if n > 1e-6 && n <= 1.0 {
                    break glam::DQuat::from_xyzw(v[0], v[1], v[2], v[3]).normalize();
                }
            }
        })
        .collect();
    for n in [300, 1000, 2000, 5000] {
        let cover: Vec<glam::DQuat> = advise::search::uniform_rotations(n)
            .iter()
            .map(|r| {
                glam::DQuat::from_euler(
                    glam::EulerRot::ZYX,
                    r[2].to_radians(),
                    r[1].to_radians(),
                    r[0].to_radians(),
                )
            })
            .collect();
        let nearest = |q: &glam::DQuat| {
            let d = cover.iter().map(|c| c.dot(*q).abs()).fold(0.0, f64::max);
            2.0 * d.min(1.0).acos().to_degrees()
        };
        let mut far: Vec<(f64, glam::DQuat)> = queries.iter().map(|q| (nearest(q), *q)).collect();
        far.sort_by(|a, b| b.0.total_cmp(&a.0));
        // Random points find the holes' neighbourhoods; climbing from the 20 farthest finds
        // their centres (random nudges, kept when farther, shrinking).
        let mut worst: f64 = far[0].0;
        for &(mut d, mut q) in far.iter().take(60) {
            let mut size = 0.05;
            for _ in 0..1500 {
                let v = [(); 4].map(|()| size * (2.0 * rng.random::<f64>() - 1.0));
                let p = glam::DQuat::from_xyzw(q.x + v[0], q.y + v[1], q.z + v[2], q.w + v[3]).normalize();
                let e = nearest(&p);
                if e > d {
                    (d, q) = (e, p);
                } else {
                    size *= 0.995;
                }
            }
            worst = worst.max(d);
        }
        let spacing = advise::search::uniform_spacing(n);
        println!(
            "N = {n}: worst {worst:.3} deg = {:.3} x spacing {spacing:.3}",
            worst / spacing
        );
        assert!(
            worst <= 1.7 * spacing,
            "N = {n}: {worst} deg, {} x",
            worst / spacing
        );
    }
}

/// Two feasible scores a part in 10⁸ apart, equal as f32: the landscape still colours them apart
/// (its scale is worked out in f64), where its colour map once divided zero by zero and panicked.
#[test]
fn scores_equal_in_f32_still_draw_a_landscape() {
    // One point both sonars see, 999 sonar 2 misses: each candidate's cost is the blind cost but
    // for one point's share of it.
    let points = format!("[[5, 0, 0]{}]", ", [0.1, 0, 0]".repeat(999));
    let c = config(&format!(
        "from = \"paper-fls\"\nto = \"paper-fls\"\n[features]\npoints = {points}\n\
         [rig]\norigin = [0, 0, -0.5]\n[search]\nroll = [0, 10]\npitch = [0, 5]\nrefine = 0\n"
    ));
    let a = advise::advise(&c, &Backend::CpuFast).unwrap();
    let scores: Vec<f64> = a.candidates.iter().filter_map(|(_, s)| s.score).collect();
    assert_eq!(scores.len(), 2, "{scores:?}");
    // The case this test is about: different in f64, one value in f32.
    assert_ne!(scores[0], scores[1]);
    #[expect(clippy::cast_possible_truncation, reason = "the f32 the colour map once took")]
    let in_f32 = scores.iter().map(|&s| s as f32).collect::<Vec<_>>();
    assert_eq!(in_f32[0], in_f32[1], "{scores:?}");
    let dir = tempfile::tempdir().unwrap();
    advise::write(&c, &a, dir.path()).unwrap();
    assert!(dir.path().join("landscape.png").is_file());
}
