//! The search: the cover of the rotations asked for, a pattern search around the best feasible
//! candidates, and the next-best move from a given pose.

use serde::Serialize;

use crate::advise::score::{Params, Score, Scorer};
use crate::error::Result;

/// Where a candidate came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// The cover: every combination of the axes' values.
    Cover,
    /// The pattern search around the best.
    Refine,
    /// The next-best move's evaluations: the pose now, its finite differences and its moves.
    Move,
}

impl Stage {
    /// Returns the stage's code in the candidates table: 0 cover, 1 refine, 2 move.
    #[must_use]
    pub fn code(self) -> i64 {
        match self {
            Stage::Cover => 0,
            Stage::Refine => 1,
            Stage::Move => 2,
        }
    }
}

/// Returns whether `a` ranks strictly before `b`: feasible scores by value, then infeasible ones.
#[must_use]
pub fn better(a: &Score, b: &Score) -> bool {
    match (a.score, b.score) {
        (Some(x), Some(y)) => x < y,
        (Some(_), None) => true,
        _ => false,
    }
}

/// Returns whether `a` ranks before `b` by more than `margin`: feasible where `b` is not, or
/// both feasible and `a`'s score below `b`'s less the margin.
#[must_use]
pub fn better_by(a: &Score, b: &Score, margin: f64) -> bool {
    match (a.score, b.score) {
        (Some(x), Some(y)) => x < y - margin,
        (Some(_), None) => true,
        _ => false,
    }
}

/// Returns the angle (deg) of the rotation between two roll, pitch, yaw triples (deg).
#[must_use]
pub fn rotation_angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    use glam::{DQuat, EulerRot};
    let q = |r: [f64; 3]| {
        DQuat::from_euler(
            EulerRot::ZYX,
            r[2].to_radians(),
            r[1].to_radians(),
            r[0].to_radians(),
        )
    };
    let d = q(a).dot(q(b)).abs().min(1.0);
    2.0 * d.acos().to_degrees()
}

/// Returns how plain a candidate's values are, smaller being plainer: for each value, the
/// position in a list of ever finer steps (90°, 45°, 30°, 15°, 10°, 5°, 1°, 0.5°, 0.1°, … for
/// angles; 1, 0.5, 0.25, 0.1, 0.05, 0.01 m, … for offsets) of the first it is a multiple of,
/// summed; then the values' sizes (angles over 540°, offsets over 3000 m, below 1 in all)
/// break equal counts.
#[must_use]
pub fn roundness(params: &Params) -> f64 {
    const ANGLES: [f64; 12] = [
        90.0, 45.0, 30.0, 15.0, 10.0, 5.0, 1.0, 0.5, 0.1, 0.05, 0.01, 0.001,
    ];
    const METRES: [f64; 9] = [1.0, 0.5, 0.25, 0.1, 0.05, 0.01, 0.005, 0.001, 0.0001];
    let rank = |v: f64, steps: &[f64]| {
        steps
            .iter()
            .position(|s| {
                let q = v / s;
                (q - q.round()).abs() < 1e-9 * q.abs().max(1.0)
            })
            .unwrap_or(steps.len())
    };
    let mut count = 0usize;
    let mut size = 0.0;
    for (k, &v) in params.iter().enumerate() {
        count += if k < 3 { rank(v, &ANGLES) } else { rank(v, &METRES) };
        size += v.abs() / if k < 3 { 540.0 } else { 3000.0 };
    }
    #[expect(clippy::cast_precision_loss, reason = "a small count")]
    let count = count as f64;
    count + size.min(0.999)
}

/// Returns `n` rotations spread uniformly over SO(3), as roll, pitch, yaw in degrees.
/// They come from the super-Fibonacci spiral of unit quaternions (M. Alexa, "Super-Fibonacci
/// Spirals: Fast, Low-Discrepancy Sampling of SO(3)", CVPR 2022). Point `i` sits at height
/// `s = (i + ½) / n` on two circles turned by the irrational ratios √2 and ψ (ψ⁴ = ψ + 4). Each
/// is taken as the active rotation `Rz(yaw) Ry(pitch) Rx(roll)`, `R`'s transpose in the paper's
/// convention. That is fine: the inverse of a uniform rotation is uniform too.
#[must_use]
pub fn uniform_rotations(n: usize) -> Vec<[f64; 3]> {
    use glam::{DQuat, EulerRot};
    const PSI: f64 = 1.533_751_168_755_204_3;
    let phi = std::f64::consts::SQRT_2;
    let tau = std::f64::consts::TAU;
    #[expect(clippy::cast_precision_loss, reason = "at most 10^7 rotations")]
    let total = n as f64;
    (0..n)
        .map(|i| {
            #[expect(clippy::cast_precision_loss, reason = "at most 10^7 rotations")]
            let s = i as f64 + 0.5;
            let (r, big_r) = ((s / total).sqrt(), (1.0 - s / total).sqrt());
            let (alpha, beta) = (tau * s / phi, tau * s / PSI);
            let q = DQuat::from_xyzw(
                r * alpha.sin(),
                r * alpha.cos(),
                big_r * beta.sin(),
                big_r * beta.cos(),
            )
            .normalize();
            let (yaw, pitch, roll) = q.to_euler(EulerRot::ZYX);
            [roll.to_degrees(), pitch.to_degrees(), yaw.to_degrees()]
        })
        .collect()
}

/// Returns the spacing (deg) of `n` rotations spread over SO(3): `ρ = (6π/n)^⅓`.
/// The ball of radius `ρ` around each rotation holds `1/n` of them all, since the rotations
/// within `ρ` of one are a share `(ρ − sin ρ)/π ≈ ρ³/(6π)`. No cover leaves every rotation
/// within `ρ` of a candidate; this spiral leaves none farther than 1.7 `ρ` (1.47–1.59 `ρ`
/// measured for 300 to 5000 rotations: `tests/advise_honest.rs`).
#[must_use]
pub fn uniform_spacing(n: usize) -> f64 {
    #[expect(clippy::cast_precision_loss, reason = "at most 10^7 rotations")]
    let per = 6.0 * std::f64::consts::PI / n.max(1) as f64;
    per.cbrt().to_degrees()
}

/// Returns the candidates of `config`: the uniform rotations (when asked for) or the roll,
/// pitch, yaw grid, each with every combination of the offsets.
#[must_use]
pub fn candidates(config: &crate::advise::AdviseConfig) -> Vec<Params> {
    match config.uniform {
        None => cover(&config.axes),
        Some(n) => {
            let offsets = cover(&config.axes);
            uniform_rotations(n)
                .into_iter()
                .flat_map(|r| offsets.iter().map(move |o| [r[0], r[1], r[2], o[3], o[4], o[5]]))
                .collect()
        }
    }
}

/// Returns every combination of `axes`' values (roll, pitch, yaw, x, y, z), the last fastest.
#[must_use]
pub fn cover(axes: &[Vec<f64>; 6]) -> Vec<Params> {
    let n: usize = axes.iter().map(Vec::len).product();
    (0..n)
        .map(|mut i| {
            let mut c = [0.0; 6];
            for k in (0..6).rev() {
                c[k] = axes[k][i % axes[k].len()];
                i /= axes[k].len();
            }
            c
        })
        .collect()
}

/// Returns which axes vary, and each axis's spacing: its smallest gap, 0 for a fixed axis.
#[must_use]
pub fn free_axes(axes: &[Vec<f64>; 6]) -> ([bool; 6], [f64; 6]) {
    let mut free = [false; 6];
    let mut spacing = [0.0; 6];
    for k in 0..6 {
        let mut v = axes[k].clone();
        v.sort_by(f64::total_cmp);
        v.dedup();
        free[k] = v.len() > 1;
        spacing[k] = v.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min);
        if !free[k] {
            spacing[k] = 0.0;
        }
    }
    (free, spacing)
}

/// Refines `starts` by pattern search over the free axes and returns every candidate scored.
/// Steps start at half the cover's spacing. The best one-step move along a free axis (either
/// way) is taken while it lowers the score by more than the current pose's `score_se` (a smaller
/// gain is the feature draw's noise); else the steps halve, down to each axis's `finest`.
/// No move leaves `bounds`, so offsets stay within the searched box.
///
/// # Errors
/// As [`Scorer::score_all`].
pub fn refine(
    scorer: &Scorer<'_>,
    starts: &[Score],
    free: [bool; 6],
    spacing: [f64; 6],
    finest: [f64; 6],
    bounds: [(f64, f64); 6],
) -> Result<Vec<Score>> {
    let mut evaluated = Vec::new();
    for start in starts {
        let mut best = *start;
        let mut step = spacing.map(|s| s / 2.0);
        // Bounded: each halving or move is one round; a move must lower the score.
        for _ in 0..400 {
            if (0..6).all(|k| !free[k] || step[k] < finest[k]) {
                break;
            }
            let mut moves = Vec::new();
            for k in (0..6).filter(|&k| free[k] && step[k] >= finest[k]) {
                for sign in [-1.0, 1.0] {
                    let mut r = best.params();
                    r[k] += sign * step[k];
                    if (bounds[k].0..=bounds[k].1).contains(&r[k]) {
                        moves.push(r);
                    }
                }
            }
            let scores = scorer.score_all(&moves)?;
            evaluated.extend_from_slice(&scores);
            let next = scores.iter().fold(None::<&Score>, |b, s| match b {
                Some(b) if !better(s, b) => Some(b),
                _ => Some(s),
            });
            match next {
                Some(n) if better_by(n, &best, best.score_se.unwrap_or(0.0)) => best = *n,
                _ => step = step.map(|s| s / 2.0),
            }
        }
    }
    Ok(evaluated)
}

/// The next-best move from a pose.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Move {
    /// The pose now.
    pub now: Score,
    /// The objective's derivative along each free axis of [`AXES`](crate::advise::config::AXES),
    /// per deg or m, by central differences over `gradient_step`. `None` for a fixed axis, or
    /// where a neighbour is infeasible.
    pub gradient: [Option<f64>; 6],
    /// The finite differences' step on each axis (deg, m).
    pub gradient_step: [f64; 6],
    /// The largest move on each axis (deg, m).
    pub step: [f64; 6],
    /// The best pose within the steps, when one scores better than now. The moves tried are
    /// every combination of −step, 0, +step on the free axes, and a step down the gradient.
    pub best: Option<Score>,
    /// `now − best` of the objective: the move's gain, both scored exactly, not predicted.
    pub gain: Option<f64>,
    /// The gain's standard error over the feature draw: the two scores' errors combined as if
    /// independent (an upper bound for the draw they share).
    pub gain_se: Option<f64>,
    /// Whether to stay: no move gains more than twice its `gain_se` (the draw cannot tell the
    /// best move from the pose now). A move out of an infeasible pose to a feasible one is
    /// always offered.
    pub stay: bool,
    /// The move in words ([`move_words`]: "pitch +5°: its boresight tilts down 5°"), when one
    /// is offered.
    pub words: Option<String>,
}

/// Returns the next-best move from candidate `from` over the `free` axes, with moves of up to
/// `step` and the gradient over `gradient_step` (per axis), and every candidate evaluated.
///
/// # Errors
/// As [`Scorer::score_all`].
pub fn next_move(
    scorer: &Scorer<'_>,
    from: Params,
    free: [bool; 6],
    step: [f64; 6],
    gradient_step: [f64; 6],
) -> Result<(Move, Vec<Score>)> {
    let axes: Vec<usize> = (0..6).filter(|&k| free[k]).collect();
    let mut poses = vec![from];
    for &k in &axes {
        for sign in [-1.0, 1.0] {
            let mut r = from;
            r[k] += sign * gradient_step[k];
            poses.push(r);
        }
    }
    let first = scorer.score_all(&poses)?;
    let now = first[0];
    let mut gradient = [None; 6];
    for (i, &k) in axes.iter().enumerate() {
        let (minus, plus) = (first[1 + 2 * i].score, first[2 + 2 * i].score);
        gradient[k] = minus.zip(plus).map(|(m, p)| (p - m) / (2.0 * gradient_step[k]));
    }
    // Every combination of −step, 0, +step on the free axes except staying, then down the
    // gradient. Each axis counts in units of its step, so degrees and metres weigh alike.
    let mut moves = Vec::new();
    let combos = 3usize.pow(u32::try_from(axes.len()).expect("six axes at most"));
    for c in 0..combos {
        let mut r = from;
        let mut code = c;
        for &k in &axes {
            r[k] += [-step[k], 0.0, step[k]][code % 3];
            code /= 3;
        }
        if r != from {
            moves.push(r);
        }
    }
    let g: Vec<f64> = axes
        .iter()
        .map(|&k| gradient[k].unwrap_or(0.0) * step[k])
        .collect();
    let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
    if norm > 0.0 {
        let mut r = from;
        for (i, &k) in axes.iter().enumerate() {
            r[k] -= step[k] * g[i] / norm;
        }
        moves.push(r);
    }
    let scored = scorer.score_all(&moves)?;
    let best = scored
        .iter()
        .filter(|s| better(s, &now))
        .fold(None::<&Score>, |b, s| match b {
            Some(b) if !better(s, b) => Some(b),
            _ => Some(s),
        })
        .copied();
    let gain = best.and_then(|b| now.score.zip(b.score).map(|(n, b)| n - b));
    // A missing error (a single feature) counts as 0; none at all when both are missing.
    let gain_se = best.and_then(|b| match (now.score_se, b.score_se) {
        (None, None) => None,
        (n, b) => Some(n.unwrap_or(0.0).hypot(b.unwrap_or(0.0))),
    });
    let stay = match (best, gain) {
        (None, _) => true,
        (Some(_), None) => false,
        (Some(_), Some(g)) => g <= 2.0 * gain_se.unwrap_or(0.0),
    };
    let words = best.filter(|_| !stay).map(|b| move_words(from, b.params()));
    let mut evaluated = first;
    evaluated.extend(scored);
    Ok((
        Move {
            now,
            gradient,
            gradient_step,
            step,
            best,
            gain,
            gain_se,
            stay,
            words,
        },
        evaluated,
    ))
}

/// What a move does to sonar 2, in sonar 1's frame (x forward, y port, z up): how far its
/// boresight (+x, the middle of its field of view) tilts up and turns to port, and how far it
/// then rolls about that boresight (+ clockwise as seen from behind, looking along the
/// boresight: an upright sonar's port side rises), all in degrees.
/// The move is the boresight's shortest turn followed by the roll, whatever the angles it starts
/// from; `turn` is `None` where the boresight is within 1° of vertical (no heading to turn).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// The boresight's change of elevation (deg, + up).
    pub tilt: f64,
    /// The boresight's change of heading (deg, + to port).
    pub turn: Option<f64>,
    /// The roll about the boresight after its shortest turn (deg, + clockwise from behind).
    pub roll: f64,
}

/// Returns sonar 2's orientation `Q = Rz(yaw) Ry(pitch) Rx(roll)` in sonar 1's frame for roll,
/// pitch, yaw in degrees.
fn orientation(r: [f64; 3]) -> glam::DQuat {
    glam::DQuat::from_euler(
        glam::EulerRot::ZYX,
        r[2].to_radians(),
        r[1].to_radians(),
        r[0].to_radians(),
    )
}

/// Returns what the rotation from `from` to `to` (roll, pitch, yaw in degrees) does to sonar 2.
#[must_use]
pub fn motion(from: [f64; 3], to: [f64; 3]) -> Motion {
    use glam::{DQuat, DVec3};
    let (q0, q1) = (orientation(from), orientation(to));
    let (b0, b1) = (q0 * DVec3::X, q1 * DVec3::X);
    let elevation = |b: DVec3| b.z.atan2(b.x.hypot(b.y)).to_degrees();
    let level = 1f64.to_radians().sin();
    let flat = |b: DVec3| b.x.hypot(b.y) > level;
    let turn = (flat(b0) && flat(b1)).then(|| {
        let d = b1.y.atan2(b1.x) - b0.y.atan2(b0.x);
        // Into (−180°, 180°].
        (d.to_degrees() + 180.0).rem_euclid(360.0) - 180.0
    });
    // The boresight's shortest turn, then the roll about it that brings the port axis home.
    let shortest = DQuat::from_rotation_arc(b0, b1);
    let (y_turned, y1) = (shortest * (q0 * DVec3::Y), q1 * DVec3::Y);
    let roll = b1.dot(y_turned.cross(y1)).atan2(y_turned.dot(y1)).to_degrees();
    Motion {
        tilt: elevation(b1) - elevation(b0),
        turn,
        roll,
    }
}

/// Returns the move from `from` to `to` in words a rig builder follows: the changed values
/// ("roll +5°, pitch −2.5°", offsets in m), then what the rotation does to sonar 2 in sonar 1's
/// frame ([`motion`]): "its boresight tilts down 2.5° and turns 1° to port; it rolls 5°
/// clockwise as seen from behind". Parts under 0.0005 are left out; "stay" when nothing changes.
#[must_use]
pub fn move_words(from: Params, to: Params) -> String {
    let shown = |v: f64| (v * 1000.0).round() / 1000.0 + 0.0;
    let mut changes = Vec::new();
    for k in 0..6 {
        let d = shown(to[k] - from[k]);
        if d == 0.0 {
            continue;
        }
        let sign = if d > 0.0 { "+" } else { "" };
        let unit = if k < 3 { "°" } else { " m" };
        let name = if k < 3 {
            crate::advise::config::AXES[k].to_string()
        } else {
            format!("offset {}", crate::advise::config::AXES[k])
        };
        changes.push(format!("{name} {sign}{d}{unit}"));
    }
    if changes.is_empty() {
        return "stay".to_string();
    }
    let m = motion([from[0], from[1], from[2]], [to[0], to[1], to[2]]);
    let mut boresight = Vec::new();
    let tilt = shown(m.tilt);
    if tilt != 0.0 {
        boresight.push(format!(
            "tilts {} {}°",
            if tilt < 0.0 { "down" } else { "up" },
            tilt.abs()
        ));
    }
    if let Some(turn) = m.turn.map(shown).filter(|&t| t != 0.0) {
        let side = if turn > 0.0 { "port" } else { "starboard" };
        boresight.push(format!("turns {}° to {side}", turn.abs()));
    }
    let mut effects = Vec::new();
    if !boresight.is_empty() {
        effects.push(format!("its boresight {}", boresight.join(" and ")));
    }
    let roll = shown(m.roll);
    if roll != 0.0 {
        let way = if roll > 0.0 {
            "clockwise"
        } else {
            "counter-clockwise"
        };
        effects.push(format!("it rolls {}° {way} as seen from behind", roll.abs()));
    }
    let mut words = changes.join(", ");
    if !effects.is_empty() {
        words.push_str(": ");
        words.push_str(&effects.join("; "));
    }
    words
}
