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
/// within `ρ` of one are a share `(ρ − sin ρ)/π ≈ ρ³/(6π)`. A cover leaves no rotation much
/// farther than `ρ` from a candidate (1.3 `ρ` for this spiral).
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
/// way) is taken while it lowers the score; else the steps halve, down to each axis's `finest`.
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
                Some(n) if better(n, &best) => best = *n,
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
        },
        evaluated,
    ))
}
