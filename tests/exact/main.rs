//! Exact geometry held to an independent model written here, not to the engine's roots.
//!
//! The model walks the arc on a dense grid of elevations. Wherever the definition's verdict
//! (`Layout::inside`, with trigonometry) changes between two grid points, it bisects that verdict
//! to the last bit. Between those ends it finds each range and azimuth extreme by golden-section
//! search around the best grid point. It is slow and plain; the engine solves polynomials.
//!
//! What the model can miss: a visible or invisible stretch shorter than its grid step. Poses are
//! random, so such stretches are rare; a pose where the two disagree is printed in full.

mod gpu;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use glam::{DMat3, DVec3};
use sonarproj::exact::{Arc, visible_arc, visible_cells};
use sonarproj::geometry::{cart_to_sph, sph_to_cart};
use sonarproj::projection::PoseGrid;
use sonarproj::stream::Stop;
use sonarproj::{
    Backend, Batch, BatchItem, BeamLayout, Layout, Measurement, Metric, MetricColumns, Occupancy, Output,
    PoseSource, PoseSweep, RelativePose, Rotation, Sampling, Sonar,
};

/// Grid points of the model over the arc.
const GRID: usize = 4000;

/// What the model finds of an arc.
#[derive(Debug)]
struct Model {
    /// Visible intervals of elevation (rad).
    intervals: Vec<[f64; 2]>,
    range: Option<[f64; 2]>,
    azimuth: Option<[f64; 2]>,
}

fn inside(arc: &Arc, layout: &Layout, phi: f64) -> bool {
    let (r, az, el) = cart_to_sph(arc.at(phi));
    layout.inside(r, az, el)
}

/// Returns where the verdict changes between `a` (verdict `va`) and `b`, to the last bit.
fn edge(arc: &Arc, layout: &Layout, mut a: f64, mut b: f64) -> f64 {
    let va = inside(arc, layout, a);
    while b - a > 0.0 {
        let m = 0.5 * (a + b);
        if m <= a || m >= b {
            break;
        }
        if inside(arc, layout, m) == va {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// Returns the largest value of `f` over `[a, b]`: the best of a fine grid, then golden-section
/// search around it.
fn maximise(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let n = 200;
    let xs: Vec<f64> = (0..=n).map(|k| a + (b - a) * k as f64 / n as f64).collect();
    let (k, _) =
        xs.iter()
            .enumerate()
            .map(|(k, &x)| (k, f(x)))
            .fold(
                (0, f64::NEG_INFINITY),
                |best, (k, v)| if v > best.1 { (k, v) } else { best },
            );
    let (mut lo, mut hi) = (xs[k.saturating_sub(1)], xs[(k + 1).min(n)]);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..200 {
        let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if f(x1) < f(x2) {
            lo = x1;
        } else {
            hi = x2;
        }
    }
    [f(a), f(b), f(0.5 * (lo + hi))]
        .into_iter()
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Returns the model's answer. `hints` are places where a visible stretch shorter than the grid
/// step may hide (the engine's pieces): where one's middle is inside and between two grid
/// points the model saw nothing, the model bisects its ends itself.
fn model(arc: &Arc, layout: &Layout, hints: &[[f64; 2]]) -> Model {
    let h = arc.half();
    let step = 2.0 * h / GRID as f64;
    let phis: Vec<f64> = (0..=GRID)
        .map(|k| -h + 2.0 * h * k as f64 / GRID as f64)
        .collect();
    let verdicts: Vec<bool> = phis.iter().map(|&p| inside(arc, layout, p)).collect();
    let mut intervals = Vec::new();
    let mut start = verdicts[0].then_some(-h);
    for k in 1..=GRID {
        if verdicts[k] != verdicts[k - 1] {
            let e = edge(arc, layout, phis[k - 1], phis[k]);
            if verdicts[k] {
                start = Some(e);
            } else {
                intervals.push([start.take().unwrap(), e]);
            }
        }
    }
    if let Some(s) = start {
        intervals.push([s, h]);
    }
    for &[a, b] in hints {
        let mid = 0.5 * (a + b);
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a grid index in [0, GRID]"
        )]
        let k = (((mid + h) / step).floor().max(0.0) as usize).min(GRID - 1);
        let (lo, hi) = (phis[k], phis[k + 1]);
        if !verdicts[k] && !verdicts[k + 1] && b - a < step && inside(arc, layout, mid) {
            intervals.push([edge(arc, layout, lo, mid), edge(arc, layout, mid, hi)]);
        }
    }
    intervals.sort_by(|x, y| x[0].total_cmp(&y[0]));
    let (mut range, mut azimuth) = (None::<[f64; 2]>, None::<[f64; 2]>);
    for &[a, b] in &intervals {
        let r = |p: f64| arc.at(p).length();
        let rr = [-maximise(&|p| -r(p), a, b), maximise(&r, a, b)];
        range = Some(range.map_or(rr, |x| [x[0].min(rr[0]), x[1].max(rr[1])]));
        // The azimuth is atan2's, in (−π, π]: it jumps where the arc crosses the y = 0 plane
        // behind sonar 2. The interval is cut at each jump (found on a grid, then bisected on
        // the sign of y); on each part the azimuth is continuous, with limits ±π at a jump.
        let n = 2000;
        let mut parts = vec![a];
        let y = |p: f64| arc.at(p).y;
        for k in 0..n {
            let (p0, p1) = (
                a + (b - a) * k as f64 / n as f64,
                a + (b - a) * (k + 1) as f64 / n as f64,
            );
            if arc.at(p0).x < 0.0 && (y(p0) < 0.0) != (y(p1) < 0.0) {
                let (mut lo, mut hi) = (p0, p1);
                for _ in 0..200 {
                    let m = 0.5 * (lo + hi);
                    if (y(m) < 0.0) == (y(lo) < 0.0) {
                        lo = m
                    } else {
                        hi = m
                    }
                }
                parts.push(0.5 * (lo + hi));
            }
        }
        parts.push(b);
        let last = parts.len() - 1;
        for k in 0..last {
            // Just inside a jump, the azimuth is within 1e-12 · ρ of its limit ±π.
            let a0 = if k > 0 { parts[k] + 1e-12 } else { parts[k] };
            let a1 = if k + 1 < last {
                parts[k + 1] - 1e-12
            } else {
                parts[k + 1]
            };
            let w = [a0, a1];
            let az = |p: f64| {
                let q = arc.at(p);
                q.y.atan2(q.x)
            };
            let aa = [-maximise(&|p| -az(p), w[0], w[1]), maximise(&az, w[0], w[1])];
            azimuth = Some(azimuth.map_or(aa, |x| [x[0].min(aa[0]), x[1].max(aa[1])]));
        }
    }
    Model {
        intervals,
        range,
        azimuth,
    }
}

/// Returns a random pose placing the arc's middle point near sonar 2's field of view.
fn random_case(rng: &mut ChaCha8Rng, source: &Sonar, target: &Sonar) -> (f64, f64, RelativePose) {
    let r = rng.random_range(source.range_min.max(0.5)..source.range_max);
    let half_az = source.azimuth_aperture / 2.0;
    let az = rng.random_range(-half_az..half_az);
    let rotation = Rotation::RollPitchYaw {
        roll: rng.random_range(-180.0..180.0),
        pitch: rng.random_range(-30.0..30.0),
        yaw: rng.random_range(-40.0..40.0),
    };
    let el = rng.random_range(-source.elevation_aperture / 2.0..source.elevation_aperture / 2.0);
    let second = [
        rng.random_range(target.range_min..target.range_max * 1.1),
        rng.random_range(-target.azimuth_aperture / 1.6..target.azimuth_aperture / 1.6),
        rng.random_range(-target.elevation_aperture / 1.6..target.elevation_aperture / 1.6),
    ];
    let pose = RelativePose::placement(rotation, [r, az, el], second).unwrap();
    (r, az.to_radians(), pose)
}

/// How far (m) the engine's and the model's numbers may differ: both are f64 and find the same
/// roots to the last bits, so this is rounding of ranges up to ~60 m (1e-14 relative) with a
/// wide margin.
const METRES: f64 = 1e-9;

fn check_against_model(source: &Sonar, target: &Sonar, seed: u64, cases: usize) -> usize {
    let layout = Layout::of(target);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut seen = 0;
    for case in 0..cases {
        let (r, az, pose) = random_case(&mut rng, source, target);
        let arc = Arc::new(r, az, source.half_elevation(), &pose);
        let exact = visible_arc(&arc, &layout);
        let m = model(&arc, &layout, &exact.pieces);
        let ctx = || format!("case {case}: r {r} az {az} pose {pose:?}\nexact {exact:?}\nmodel {m:?}");
        let model_length: f64 = m.intervals.iter().map(|i| i[1] - i[0]).sum();
        let fraction = model_length / (2.0 * arc.half());
        // Lengths in elevation (rad) times the range: metres along the arc.
        assert!(
            ((exact.visible_fraction - fraction) * 2.0 * arc.half() * r).abs() <= METRES,
            "visible fraction {} vs {fraction}: {}",
            exact.visible_fraction,
            ctx()
        );
        match m.range {
            None => assert!(exact.visible_fraction == 0.0, "{}", ctx()),
            Some([lo, hi]) => {
                seen += 1;
                let ex = exact.extremes;
                assert!((ex.range_min - lo).abs() <= METRES, "range_min: {}", ctx());
                assert!((ex.range_max - hi).abs() <= METRES, "range_max: {}", ctx());
                let [alo, ahi] = m.azimuth.unwrap();
                // An azimuth error of δ rad moves the point by ρ δ ≤ range_max δ.
                let tol = METRES / target.range_max.max(1.0) * 100.0;
                assert!((ex.azimuth_min - alo).abs() <= tol, "azimuth_min: {}", ctx());
                assert!((ex.azimuth_max - ahi).abs() <= tol, "azimuth_max: {}", ctx());
            }
        }
    }
    seen
}

/// Returns sonar 2 candidates: every preset, non-uniform beams, a full circle of azimuth with a
/// half sphere of elevation (no angle clips) and no minimum range, and a large minimum range.
fn targets() -> Vec<Sonar> {
    let mut out: Vec<Sonar> = Sonar::preset_names()
        .into_iter()
        .map(|n| Sonar::preset(n).unwrap())
        .collect();
    let mut uneven = Sonar::preset("oculus-m750d").unwrap();
    let half = uneven.azimuth_aperture / 2.0;
    uneven.beams = BeamLayout::Edges(vec![-half, -half * 0.8, -0.3, 0.0, 1.0, half * 0.5, half]);
    out.push(uneven);
    let mut open = Sonar::preset("paper-fls").unwrap();
    (open.azimuth_aperture, open.elevation_aperture, open.range_min) = (360.0, 180.0, 0.0);
    open.beams = BeamLayout::Uniform { count: 90 };
    out.push(open);
    let mut far = Sonar::preset("paper-sss").unwrap();
    far.range_min = 8.0;
    out.push(far);
    for s in &out {
        s.validate().unwrap();
    }
    out
}

#[test]
fn every_target_matches_the_dense_model() {
    let sources = [
        Sonar::preset("paper-fls").unwrap(),
        Sonar::preset("oculus-m750d").unwrap(),
    ];
    for (k, target) in targets().iter().enumerate() {
        for (l, source) in sources.iter().enumerate() {
            let cases = 150;
            let seen = check_against_model(source, target, (10 * k + l) as u64, cases);
            assert!(
                seen > cases / 5,
                "{} → {}: only {seen} of {cases} see anything",
                source.name,
                target.name
            );
        }
    }
}

/// Cells: every cell a dense walk along the visible arc meets is an exact cell, and every exact
/// cell the walk misses touches one it meets (the arc crossed it for less than a step).
#[test]
fn cells_hold_every_cell_the_dense_walk_meets() {
    let fls = Sonar::preset("paper-fls").unwrap();
    for (seed, target) in targets().into_iter().enumerate() {
        let layout = Layout::of(&target);
        let mut rng = ChaCha8Rng::seed_from_u64(100 + seed as u64);
        for case in 0..40 {
            let (r, az, pose) = random_case(&mut rng, &fls, &target);
            let arc = Arc::new(r, az, fls.half_elevation(), &pose);
            let exact = visible_arc(&arc, &layout);
            let mut cells = Occupancy::new(layout.range_bins, layout.beams());
            visible_cells(&arc, &layout, &exact, &mut cells);
            let mut walked = Occupancy::new(layout.range_bins, layout.beams());
            let n = 200_000;
            for k in 0..=n {
                let phi = -arc.half() + 2.0 * arc.half() * k as f64 / n as f64;
                let (rr, a, e) = cart_to_sph(arc.at(phi));
                if layout.inside(rr, a, e) {
                    walked.set(layout.range_bin(rr), layout.beam(a));
                }
            }
            assert!(
                walked.is_subset_of(&cells),
                "{} case {case}: a walked cell is not an exact cell",
                target.name
            );
            for (i, j) in cells.pixels() {
                if walked.get(i, j) {
                    continue;
                }
                let near = [
                    (0isize, 1isize),
                    (0, -1),
                    (1, 0),
                    (-1, 0),
                    (1, 1),
                    (1, -1),
                    (-1, 1),
                    (-1, -1),
                ]
                .iter()
                .any(|&(di, dj)| {
                    match (i.checked_add_signed(di), j.checked_add_signed(dj)) {
                        (Some(ii), Some(jj)) => {
                            ii < layout.range_bins && jj < layout.beams() && walked.get(ii, jj)
                        }
                        _ => false,
                    }
                });
                assert!(
                    near,
                    "{} case {case}: exact cell ({i}, {j}) far from the walk",
                    target.name
                );
            }
        }
    }
}

/// Returns an arc of range 1 m over ±6° that touches a bound of sonar 2 at `q0` and runs along
/// `tangent` there. `n` is the bound's normal pointing out of the field of view; the circle's
/// centre lies on the visible side when `visible_side`, so the arc stays in view (or out of it)
/// except at `q0`.
fn grazing(q0: DVec3, n: DVec3, tangent: DVec3, visible_side: bool) -> RelativePose {
    let r = 1.0;
    let u = if visible_side { n } else { -n };
    let w = tangent.normalize();
    assert!(u.dot(w).abs() < 1e-15);
    let pose = RelativePose {
        rotation: DMat3::from_cols(u, w.cross(u), w),
        translation: q0 - r * u,
    };
    let arc = Arc::new(r, 0.0, 6f64.to_radians(), &pose);
    assert!((arc.at(0.0) - q0).length() < 1e-14);
    pose
}

/// What a solver finds of an arc: the visible fraction, the range and azimuth (rad) extremes
/// (infinite when nothing is seen).
#[derive(Debug)]
struct Answer {
    fraction: f64,
    range: [f64; 2],
    azimuth: [f64; 2],
}

/// Returns the reference's and the fast twin's answers (through `Backend::CpuFast`) for the
/// feature at `r` (m), `az` (rad) of `source`, moved into `target` by `pose`.
fn answers(
    source: &Sonar,
    target: &Sonar,
    r: f64,
    az: f64,
    pose: RelativePose,
) -> [(&'static str, Answer); 2] {
    let seen = visible_arc(
        &Arc::new(r, az, source.half_elevation(), &pose),
        &Layout::of(target),
    );
    let ex = seen.extremes;
    let reference = Answer {
        fraction: seen.visible_fraction,
        range: [ex.range_min, ex.range_max],
        azimuth: [ex.azimuth_min, ex.azimuth_max],
    };
    let b = batch(source, target, Sampling::Exact, &[(r, az, pose)]);
    let m = &Backend::CpuFast.project(&b, Output::MetricsOnly).unwrap()[0].metrics;
    let or = |v: Option<f64>, none: f64| v.unwrap_or(none);
    let fast = Answer {
        fraction: m.visible_fraction,
        range: [or(m.range_min, f64::INFINITY), or(m.range_max, f64::NEG_INFINITY)],
        azimuth: [
            or(m.azimuth_min, f64::INFINITY).to_radians(),
            or(m.azimuth_max, f64::NEG_INFINITY).to_radians(),
        ],
    };
    [("reference", reference), ("fast", fast)]
}

fn dir(az_deg: f64, el_deg: f64) -> DVec3 {
    sph_to_cart(1.0, az_deg.to_radians(), el_deg.to_radians())
}

/// Arcs that touch each bound, from the visible and the invisible side, for the reference and the
/// fast twin. At a tangency the
/// bound's function is quadratic in the elevation, so rounding (1e-16 of it) decides the
/// verdict over a sliver of width about √1e-16 = 1e-8 rad around the touching point: the
/// visible fraction is allowed 1e-6 there. The touched bound is reached to 1e-9 from the
/// visible side.
#[test]
fn arcs_grazing_each_bound() {
    let fls = Sonar::preset("paper-fls").unwrap();
    let mut far = Sonar::preset("paper-sss").unwrap();
    far.range_min = 8.0;
    let (h, e) = (30f64, 6f64);
    let (sh, ch, se, ce) = (
        h.to_radians().sin(),
        h.to_radians().cos(),
        e.to_radians().sin(),
        e.to_radians().cos(),
    );
    let az5 = 5f64.to_radians();
    // (name, target, touching point, outward normal, tangent, which extreme equals what)
    let cases: Vec<(&str, &Sonar, DVec3, DVec3, DVec3)> = vec![
        (
            "range max",
            &fls,
            10.0 * dir(10.0, 2.0),
            dir(10.0, 2.0),
            DVec3::new(-(10f64.to_radians().sin()), 10f64.to_radians().cos(), 0.0),
        ),
        (
            "range min",
            &far,
            8.0 * dir(10.0, 0.0),
            -dir(10.0, 0.0),
            dir(100.0, 0.0),
        ),
        (
            "azimuth, vertical",
            &fls,
            DVec3::new(5.0 * ch, 5.0 * sh, 0.1),
            DVec3::new(-sh, ch, 0.0),
            DVec3::Z,
        ),
        (
            "azimuth, radial",
            &fls,
            DVec3::new(5.0 * ch, 5.0 * sh, 0.1),
            DVec3::new(-sh, ch, 0.0),
            DVec3::new(ch, sh, 0.0),
        ),
        (
            "elevation, across",
            &fls,
            5.0 * dir(5.0, e),
            DVec3::new(-se * az5.cos(), -se * az5.sin(), ce),
            DVec3::new(-az5.sin(), az5.cos(), 0.0),
        ),
        (
            "elevation, along",
            &fls,
            5.0 * dir(5.0, e),
            DVec3::new(-se * az5.cos(), -se * az5.sin(), ce),
            dir(5.0, e),
        ),
        (
            "elevation below",
            &fls,
            5.0 * dir(5.0, -e),
            DVec3::new(-se * az5.cos(), -se * az5.sin(), -ce),
            DVec3::new(-az5.sin(), az5.cos(), 0.0),
        ),
    ];
    for (name, target, q0, n, tangent) in cases {
        let layout = Layout::of(target);
        let r0 = q0.length();
        for (solver, seen) in answers(&fls, target, 1.0, 0.0, grazing(q0, n, tangent, true)) {
            assert!(
                seen.fraction >= 1.0 - 1e-6,
                "{name}, visible side, {solver}: {seen:?}"
            );
            let touched = match name {
                "range max" => seen.range[1] - layout.range_max,
                "range min" => seen.range[0] - layout.range_min,
                n if n.starts_with("azimuth") => (seen.azimuth[1] - layout.half_azimuth) * r0,
                // The elevation's extremes are not reported; the fraction says it all.
                _ => 0.0,
            };
            assert!(
                touched.abs() <= 1e-9,
                "{name}, {solver}: the bound is reached to {touched}: {seen:?}"
            );
        }
        for (solver, unseen) in answers(&fls, target, 1.0, 0.0, grazing(q0, n, tangent, false)) {
            assert!(
                unseen.fraction <= 1e-6,
                "{name}, invisible side, {solver}: {unseen:?}"
            );
        }
    }
}

/// Degenerate poses, for the reference and the fast twin: sonar 2 is sonar 1 (the arc's ends on
/// the elevation bounds, the range constant); an arc through sonar 2's origin; an arc wholly
/// behind it. Where the arc's ends sit on a bound, rounding may drop a sliver of a few 1e-17 rad
/// there: fractions are held to 1e-12.
#[test]
fn degenerate_poses() {
    let fls = Sonar::preset("paper-fls").unwrap();
    let same = RelativePose {
        rotation: DMat3::IDENTITY,
        translation: DVec3::ZERO,
    };
    for (solver, seen) in answers(&fls, &fls, 5.0, 0.2, same) {
        assert!((seen.fraction - 1.0).abs() < 1e-12, "{solver}: {seen:?}");
        assert!(
            (seen.range[0] - 5.0).abs() < 1e-14 && (seen.range[1] - 5.0).abs() < 1e-14,
            "{solver}: {seen:?}"
        );
        assert!(
            (seen.azimuth[0] - 0.2).abs() < 1e-14 && (seen.azimuth[1] - 0.2).abs() < 1e-14,
            "{solver}: {seen:?}"
        );
    }

    let mut open = fls.clone();
    (open.azimuth_aperture, open.elevation_aperture, open.range_min) = (360.0, 180.0, 0.0);
    let open_layout = Layout::of(&open);
    let u = DVec3::new(3.0, 0.0, 0.0);
    let through = RelativePose {
        rotation: DMat3::IDENTITY,
        translation: -u,
    };
    let arc = Arc::new(3.0, 0.0, fls.half_elevation(), &through);
    assert_eq!(arc.at(0.0), DVec3::ZERO);
    let m = model(&arc, &open_layout, &visible_arc(&arc, &open_layout).pieces);
    for (solver, seen) in answers(&fls, &open, 3.0, 0.0, through) {
        assert!((seen.fraction - 1.0).abs() < 1e-12, "{solver}: {seen:?}");
        assert!(seen.range[0].abs() < 1e-12, "{solver}: {seen:?}");
        assert!(
            (seen.range[1] - m.range.unwrap()[1]).abs() < 1e-12,
            "{solver}: {seen:?} {m:?}"
        );
    }

    let behind = RelativePose {
        rotation: DMat3::IDENTITY,
        translation: DVec3::new(-20.0, 0.0, 0.0),
    };
    for (solver, seen) in answers(&fls, &fls, 5.0, 0.0, behind) {
        assert_eq!(seen.fraction, 0.0, "{solver}");
        assert!(seen.range[0].is_infinite(), "{solver}: {seen:?}");
    }
    let seen = visible_arc(
        &Arc::new(5.0, 0.0, fls.half_elevation(), &behind),
        &Layout::of(&fls),
    );
    assert!(seen.pieces.is_empty());
}

fn batch(source: &Sonar, target: &Sonar, sampling: Sampling, cases: &[(f64, f64, RelativePose)]) -> Batch {
    Batch {
        source: source.clone(),
        target: target.clone(),
        sampling,
        area_grid: sonarproj::PAPER_AREA_GRID,
        sigma_range: None,
        items: cases
            .iter()
            .map(|&(r, az, pose)| BatchItem {
                measurement: Measurement {
                    range: r,
                    azimuth: az.to_degrees(),
                },
                pose,
                true_point: None,
            })
            .collect(),
    }
}

/// Sampled ⊆ exact: every sample the reference keeps lies in an exact piece (to rounding of a
/// bound), the sampled extremes lie within the exact ones, and every sampled cell is an exact
/// cell. And sampled → exact as the step shrinks.
#[test]
fn sampled_lies_within_exact_and_converges_to_it() {
    let fls = Sonar::preset("paper-fls").unwrap();
    for (seed, target) in [(7, Sonar::preset("paper-sss").unwrap()), (8, fls.clone())] {
        let layout = Layout::of(&target);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut cases: Vec<_> = (0..300).map(|_| random_case(&mut rng, &fls, &target)).collect();
        // Symmetric poses too: quarter turns put tangencies at the arc's middle (the first
        // pose's arc touches sonar 2's y = 0 plane there).
        for (roll, pitch, yaw) in [
            (90.0, 90.0, 0.0),
            (0.0, 90.0, 0.0),
            (90.0, 0.0, 0.0),
            (0.0, 0.0, 90.0),
            (180.0, 90.0, 0.0),
        ] {
            let rotation = Rotation::RollPitchYaw { roll, pitch, yaw };
            let pose = RelativePose::placement(rotation, [5.0, 0.0, 0.0], [8.0, 0.0, 0.0]).unwrap();
            cases.push((5.0, 0.0, pose));
        }
        let exact = Backend::Cpu
            .project(
                &batch(&fls, &target, Sampling::Exact, &cases),
                Output::WithOccupancy,
            )
            .unwrap();
        let mut worst = [0.0f64; 3];
        for (step, bound) in [(0.1, 0), (0.01, 1), (0.001, 2)] {
            let sampled = Backend::Cpu
                .project(
                    &batch(&fls, &target, Sampling::Step(step), &cases),
                    Output::WithOccupancy,
                )
                .unwrap();
            for (k, (ep, s)) in exact.iter().zip(&sampled).enumerate() {
                let (e, s_m) = (&ep.metrics, &s.metrics);
                if s_m.visible == 0 {
                    continue;
                }
                let (lo, hi) = (e.range_min.unwrap(), e.range_max.unwrap());
                assert!(
                    s_m.range_min.unwrap() >= lo - 1e-9 && s_m.range_max.unwrap() <= hi + 1e-9,
                    "case {k}"
                );
                assert!(
                    s_m.span <= e.span + 1e-9,
                    "case {k}: sampled span {} > exact {}",
                    s_m.span,
                    e.span
                );
                let (alo, ahi) = (e.azimuth_min.unwrap(), e.azimuth_max.unwrap());
                assert!(
                    s_m.azimuth_min.unwrap() >= alo - 1e-9 && s_m.azimuth_max.unwrap() <= ahi + 1e-9,
                    "case {k}: sampled azimuths {:?}..{:?} outside exact {alo}..{ahi}",
                    s_m.azimuth_min,
                    s_m.azimuth_max
                );
                // A sample on a bin edge may fall in the neighbouring bin; none of these random
                // cases puts one there.
                let (so, eo) = (s.occupancy.as_ref().unwrap(), ep.occupancy.as_ref().unwrap());
                assert!(
                    so.is_subset_of(eo),
                    "case {k}: a sampled cell is not an exact cell"
                );
                worst[bound] = worst[bound].max(e.span - s_m.span);
            }
            // Every visible sample in an exact piece.
            if step == 0.1 {
                for (k, &(r, az, pose)) in cases.iter().enumerate() {
                    let arc = Arc::new(r, az, fls.half_elevation(), &pose);
                    let pieces = visible_arc(&arc, &layout).pieces;
                    let n = 121;
                    for i in 0..n {
                        let phi = (-6.0 + 12.0 * i as f64 / (n - 1) as f64).to_radians();
                        if inside(&arc, &layout, phi) {
                            assert!(
                                pieces.iter().any(|p| p[0] - 1e-12 <= phi && phi <= p[1] + 1e-12),
                                "case {k}: visible sample at {phi} outside every exact piece {pieces:?}"
                            );
                        }
                    }
                }
            }
        }
        // The span's shortfall shrinks with the step (at least tenfold per tenfold step).
        assert!(
            worst[1] <= worst[0] / 5.0 && worst[2] <= worst[1] / 5.0,
            "{} shortfalls {worst:?}",
            target.name
        );
    }
}

/// Returns whether a cell verdict of `arc` may turn on rounding: a visible piece's end or a
/// range or azimuth extreme (the reference's) within `METRES` of a range-bin edge, or within the
/// azimuth tolerance of a beam edge. Two exact solvers that agree to rounding may then disagree on
/// a cell touched at that point alone.
fn near_an_edge(arc: &Arc, layout: &Layout, target: &Sonar) -> bool {
    let seen = visible_arc(arc, layout);
    let az_tol = METRES / target.range_max.max(1.0) * 100.0;
    let mut points: Vec<(f64, f64)> = seen
        .pieces
        .iter()
        .flat_map(|&[a, b]| [a, b])
        .map(|phi| {
            let (r, az, _) = cart_to_sph(arc.at(phi));
            (r, az)
        })
        .collect();
    let ex = seen.extremes;
    points.extend([(ex.range_min, ex.azimuth_min), (ex.range_max, ex.azimuth_max)]);
    // Inner edges only: the field of view's own bounds end the pieces, and a cell there is in
    // on both sides.
    let beams = layout.beam_edges.len() - 1;
    points.iter().any(|&(r, az)| {
        (1..layout.range_bins).any(|i| (r - layout.range_edge(i)).abs() <= METRES)
            || layout.beam_edges[1..beams]
                .iter()
                .any(|e| (az - e).abs() <= az_tol)
    })
}

/// The fast twin (cpu-fast, and the GPU backend of a device without f64) against the reference
/// on every target, from two sonar 1s: visible lengths, range and azimuth extremes to `METRES`,
/// as each is held to the dense model. Both find the same roots to rounding, from different
/// formulas (φ and `tan(φ/2)`), so their cells are equal, except where a piece's end or an
/// extreme sits on an edge (`near_an_edge`; none of these 3600 poses, one in a thousand allowed).
#[test]
fn fast_twin_agrees_with_the_reference() {
    let (mut seen, mut on_edges, mut cases_all) = (0, 0, 0);
    for RandomBatch {
        source,
        target,
        cases,
        batch: b,
    } in random_batches(1000)
    {
        let (source, target, layout) = (&source, &target, Layout::of(&target));
        let want = Backend::Cpu.project(&b, Output::WithOccupancy).unwrap();
        let got = Backend::CpuFast.project(&b, Output::WithOccupancy).unwrap();
        for (n, ((w, g), &(r, az, pose))) in want.iter().zip(&got).zip(&cases).enumerate() {
            cases_all += 1;
            let arc = Arc::new(r, az, source.half_elevation(), &pose);
            let ctx = || {
                format!(
                    "{} → {} case {n}: r {r} az {az} pose {pose:?}\nreference {:?}\nfast {:?}",
                    source.name, target.name, w.metrics, g.metrics
                )
            };
            let (wm, gm) = (&w.metrics, &g.metrics);
            let metres = |f: f64| f * 2.0 * arc.half() * r;
            assert!(
                metres((wm.visible_fraction - gm.visible_fraction).abs()) <= METRES,
                "visible fraction: {}",
                ctx()
            );
            if wm.visible_fraction == 0.0 || gm.visible_fraction == 0.0 {
                // Both see nothing, or one a sliver the other missed (its length checked above).
                if wm.range_min.is_some() != gm.range_min.is_some() {
                    on_edges += 1;
                }
                continue;
            }
            seen += 1;
            let close = |a: Option<f64>, b: Option<f64>, tol: f64| (a.unwrap() - b.unwrap()).abs() <= tol;
            assert!(close(wm.range_min, gm.range_min, METRES), "range_min: {}", ctx());
            assert!(close(wm.range_max, gm.range_max, METRES), "range_max: {}", ctx());
            let az_tol = (METRES / target.range_max.max(1.0) * 100.0).to_degrees();
            assert!(
                close(wm.azimuth_min, gm.azimuth_min, az_tol),
                "azimuth_min: {}",
                ctx()
            );
            assert!(
                close(wm.azimuth_max, gm.azimuth_max, az_tol),
                "azimuth_max: {}",
                ctx()
            );
            if w.occupancy != g.occupancy {
                assert!(
                    near_an_edge(&arc, &layout, target),
                    "cells differ off the edges: {}",
                    ctx()
                );
                on_edges += 1;
            } else {
                assert_eq!(wm.occupied, gm.occupied, "{}", ctx());
                assert_eq!(
                    wm.occupied_measure.to_bits(),
                    gm.occupied_measure.to_bits(),
                    "{}",
                    ctx()
                );
            }
        }
    }
    assert!(
        seen > cases_all / 5,
        "only {seen} of {cases_all} poses see anything"
    );
    println!("{seen} of {cases_all} poses see something; {on_edges} differ on an edge");
    assert!(
        on_edges * 1000 <= cases_all,
        "{on_edges} of {cases_all} poses differ on an edge"
    );
}

/// The fast twin is one solver on every path: metrics alone equal those computed with the
/// occupancy; a pose grid decoded where it is solved gives its items' bits, with every column or
/// a few. (The GPU's exact stage has its own test, `gpu.rs`.)
#[test]
fn fast_twin_gives_the_same_bits_on_every_path() {
    let fls = Sonar::preset("paper-fls").unwrap();
    for target in [
        Sonar::preset("paper-sss").unwrap(),
        Sonar::preset("oculus-m750d").unwrap(),
    ] {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let cases: Vec<_> = (0..200).map(|_| random_case(&mut rng, &fls, &target)).collect();
        let b = batch(&fls, &target, Sampling::Exact, &cases);
        let want = Backend::CpuFast.project(&b, Output::WithOccupancy).unwrap();
        let alone = Backend::CpuFast.project(&b, Output::MetricsOnly).unwrap();
        for (w, a) in want.iter().zip(&alone) {
            assert_eq!(w.metrics, a.metrics);
        }
        // A grid: every rotation of a few features placed about sonar 2's view.
        let grid = PoseGrid::new(grid_axes(0.5 * target.range_max), true, &fls).unwrap();
        let sweep = PoseSweep {
            source: fls.clone(),
            target: target.clone(),
            sampling: Sampling::Exact,
            area_grid: sonarproj::PAPER_AREA_GRID,
            poses: PoseSource::Grid(&grid),
        };
        let items = sweep.batch(0..grid.len()).unwrap();
        let per_item = Backend::CpuFast.project(&items, Output::MetricsOnly).unwrap();
        assert!(per_item.iter().any(|p| p.metrics.visible_fraction > 0.0));
        // The GPU solves on the device where it has f64; where it does not, it runs this twin.
        let mut backends = vec![Backend::CpuFast];
        backends.extend(
            sonarproj_testkit::gpu()
                .filter(|g| !g.solves_exact())
                .map(|g| Backend::Gpu(Box::new(g))),
        );
        for backend in &backends {
            for kept in [None, Some(vec![Metric::Span, Metric::VisibleFraction])] {
                let mut out = match &kept {
                    None => MetricColumns::default(),
                    Some(m) => MetricColumns::only(m),
                };
                backend
                    .project_columns(&sweep, 0..grid.len(), &mut out, Stop::NEVER)
                    .unwrap();
                for (k, p) in per_item.iter().enumerate() {
                    match &kept {
                        None => assert_eq!(out.get(k), p.metrics, "{} pose {k}", backend.name()),
                        Some(_) => {
                            let f = |m: Metric| out.column(m).f64(k).map(f64::to_bits);
                            assert_eq!(f(Metric::Span), Some(p.metrics.span.to_bits()), "pose {k}");
                            assert_eq!(
                                f(Metric::VisibleFraction),
                                Some(p.metrics.visible_fraction.to_bits()),
                                "pose {k}"
                            );
                        }
                    }
                }
            }
        }
    }
}

/// 200 random exact poses of one sonar pair ([`random_batches`]).
struct RandomBatch {
    source: Sonar,
    target: Sonar,
    cases: Vec<(f64, f64, RelativePose)>,
    batch: Batch,
}

/// Returns 200 random poses ([`random_case`]) into every target ([`targets`]) from each of two
/// sonar 1s (`paper-fls`, `oculus-m750d`), as exact batches; `seed` picks the draw.
fn random_batches(seed: u64) -> Vec<RandomBatch> {
    let sources = [
        Sonar::preset("paper-fls").unwrap(),
        Sonar::preset("oculus-m750d").unwrap(),
    ];
    let mut out = Vec::new();
    for (k, target) in targets().into_iter().enumerate() {
        for (l, source) in sources.iter().enumerate() {
            let mut rng = ChaCha8Rng::seed_from_u64(seed + (10 * k + l) as u64);
            let cases: Vec<_> = (0..200).map(|_| random_case(&mut rng, source, &target)).collect();
            out.push(RandomBatch {
                batch: batch(source, &target, Sampling::Exact, &cases),
                source: source.clone(),
                target: target.clone(),
                cases,
            });
        }
    }
    out
}

/// Returns the axes of a test grid: a few features of sonar 1 placed at `place` (m) in front of
/// sonar 2, under rotations that turn their arcs every way (1 728 poses).
fn grid_axes(place: f64) -> [Vec<f64>; 9] {
    [
        vec![2.0, 7.5],
        vec![-20.0, 0.0, 25.0],
        vec![0.0, 3.0],
        vec![place],
        vec![0.0, 10.0],
        vec![0.0, 0.1],
        vec![0.0, 37.0, 90.0, 181.0],
        vec![-20.0, 0.0, 65.0],
        vec![0.0, 12.5, 180.0],
    ]
}

/// Exact mode asks for an FLS sonar 1; a sidescan's is refused naming the step.
#[test]
fn exact_needs_an_imaging_sonar_1() {
    let sss = Sonar::preset("paper-sss").unwrap();
    let fls = Sonar::preset("paper-fls").unwrap();
    let e = Backend::Cpu
        .project(&batch(&sss, &fls, Sampling::Exact, &[]), Output::MetricsOnly)
        .unwrap_err();
    assert!(
        e.is_input() && e.to_string().contains("step") && e.to_string().contains("exact"),
        "{e}"
    );
    assert_eq!("exact".parse::<Sampling>().unwrap(), Sampling::Exact);
    assert_eq!("0.25".parse::<Sampling>().unwrap(), Sampling::Step(0.25));
    assert!("-1".parse::<Sampling>().is_err() && "often".parse::<Sampling>().is_err());
    assert_eq!(Sampling::Exact.to_string(), "exact");
}
