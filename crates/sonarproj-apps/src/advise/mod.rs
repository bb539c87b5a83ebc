//! The rig advisor: which relative rotation of two sonars makes correspondence easy or recovery
//! precise, and which small move improves the current pose.
//!
//! Candidates are scored over a fixed draw of features (or given points). The shared features
//! are those both sonars see. Each is projected (range span for an SSS sonar 2; for an FLS the
//! pixels its exact arc meets, or the projection area when sampled) and gets its recovered
//! coordinate's first-order sigma. The objective (`config`) reduces these, with a standard error
//! over the draw: correspondence (the mean cost of finding a match, a blind search for a
//! feature not shared), ambiguity, recovery or a mix. `search` covers the asked rotations,
//! refines the best by pattern search, and finds the best small move from a given pose; the
//! candidates within two standard errors of the best are tied, and `pareto` keeps those no
//! other beats on shared share, ambiguity and sigma at once. `report` writes everything
//! evaluated, so `sonarproj batch` can recompute a score.

pub mod config;
pub mod features;
pub mod pareto;
pub mod pool;
mod report;
pub mod score;
pub mod search;

pub use config::{AdviseConfig, FromPose, Objective, Rig};
pub use features::Features;
pub use report::{Written, write};
pub use score::{Params, Score, Scorer, Stats};
pub use search::{Move, Stage};

/// Returns the unit of `config`'s score: `m` or `m²` (the metric's), `deg` (recovery) or `1` (mix).
#[must_use]
pub fn score_unit(config: &AdviseConfig) -> &'static str {
    report::units(config).1
}

/// Returns the rule that picks the recommended candidate among the ties, in words.
#[must_use]
pub fn recommended_rule(config: &AdviseConfig) -> &'static str {
    report::recommended_rule(config)
}

use sonarproj::projection::Backend;

use crate::error::Result;

/// What the advisor found.
#[derive(Clone, Debug, PartialEq)]
pub struct Advice {
    /// Every candidate evaluated, in order, with where it came from.
    pub candidates: Vec<(Stage, Score)>,
    /// The feasible candidates, best first, as indices into `candidates`; each rotation once.
    pub ranked: Vec<usize>,
    /// The candidate the advisor recommends, an index into `candidates`: among those tied with
    /// the best (`Score::tied`), the nearest to `[from_pose]` when one is given, else the
    /// simplest (the roundest angles and offsets, [`search::roundness`]).
    pub recommended: Option<usize>,
    /// The feasible candidates on the Pareto front of shared share, ambiguity and recovery sigma
    /// ([`pareto::front`]), as indices into `candidates`, most shared first.
    pub pareto: Vec<usize>,
    /// What the advisor could not help with, in words (an objective the search cannot move).
    pub warnings: Vec<String>,
    /// The next-best move, when the advise file gives a pose.
    pub next: Option<Move>,
    /// The metric scored: `span`, `occupied_measure` (exact, an imaging sonar 2) or
    /// `projection_area`.
    pub metric: &'static str,
}

impl Advice {
    /// Returns the best feasible candidate's score, if any.
    #[must_use]
    pub fn best(&self) -> Option<&Score> {
        self.ranked.first().map(|&i| &self.candidates[i].1)
    }
}

/// Runs the advisor of `config` on `backend`: scores the cover, refines the best
/// `config.refine` feasible candidates, and finds the next-best move from `config.from_pose`.
///
/// # Errors
/// As [`Scorer::score_all`].
pub fn advise(config: &AdviseConfig, backend: &Backend) -> Result<Advice> {
    advise_until(config, backend, sonarproj::stream::Stop::NEVER)
}

/// Runs the advisor as [`advise()`] does, ending with [`sonarproj::Error::Stopped`] once `stop`
/// is set (looked at before each batch of projections).
///
/// # Errors
/// As [`advise()`], and [`sonarproj::Error::Stopped`].
pub fn advise_until(
    config: &AdviseConfig,
    backend: &Backend,
    stop: sonarproj::stream::Stop<'_>,
) -> Result<Advice> {
    let scorer = Scorer::new(config, backend)?.until(stop);
    let cover = search::candidates(config);
    let mut candidates: Vec<(Stage, Score)> = scorer
        .score_all(&cover)?
        .into_iter()
        .map(|s| (Stage::Cover, s))
        .collect();
    let (mut free, mut spacing) = search::free_axes(&config.axes);
    if let Some(n) = config.uniform {
        for k in 0..3 {
            free[k] = true;
            spacing[k] = search::uniform_spacing(n);
        }
    }
    if config.refine > 0 && free.iter().any(|&f| f) {
        let starts: Vec<Score> = ranking(&candidates)
            .into_iter()
            .take(config.refine)
            .map(|i| candidates[i].1)
            .collect();
        let finest = std::array::from_fn(|k| {
            if k < 3 {
                config.refine_to
            } else {
                config.refine_to_m
            }
        });
        // Rotations turn freely; the offsets stay within the box the search covers.
        let bounds = std::array::from_fn(|k| {
            if k < 3 {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                let a = &config.axes[k];
                (
                    a.iter().copied().fold(f64::INFINITY, f64::min),
                    a.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                )
            }
        });
        let refined = search::refine(&scorer, &starts, free, spacing, finest, bounds)?;
        candidates.extend(refined.into_iter().map(|s| (Stage::Refine, s)));
    }
    let next = match config.from_pose {
        None => None,
        Some(p) => {
            let (m, evaluated) = next_move(config, &scorer, p, free)?;
            candidates.extend(evaluated.into_iter().map(|s| (Stage::Move, s)));
            Some(m)
        }
    };
    let ranked = ranking(&candidates);
    mark_ties(&mut candidates, &ranked);
    let recommended = recommend(&candidates, &ranked, config.from_pose.as_ref());
    let scores: Vec<Score> = candidates.iter().map(|c| c.1).collect();
    let pareto = pareto::front(&scores, &ranked);
    Ok(Advice {
        pareto,
        ranked,
        recommended,
        candidates,
        next,
        metric: score::metric_name(config),
        warnings: warnings(config),
    })
}

/// Returns the next-best move from `p` (and the candidates it scored) over the `free` axes of
/// the search; every rotation axis, and the offsets of a rig that has them, when none is free.
fn next_move(
    config: &AdviseConfig,
    scorer: &Scorer<'_>,
    p: FromPose,
    free: [bool; 6],
) -> Result<(Move, Vec<Score>)> {
    // With every axis fixed, the move still turns the pose about all three rotation axes, and
    // moves it along x, y, z for a rig with an origin or translation.
    let movable = !matches!(config.rig, Rig::Place { .. });
    let free = if free.iter().any(|&f| f) {
        free
    } else {
        std::array::from_fn(|k| k < 3 || movable)
    };
    let from = [
        p.rotation[0],
        p.rotation[1],
        p.rotation[2],
        p.offset[0],
        p.offset[1],
        p.offset[2],
    ];
    let per_axis = |deg: f64, m: f64| std::array::from_fn(|k| if k < 3 { deg } else { m });
    search::next_move(
        scorer,
        from,
        free,
        per_axis(p.step, p.step_m),
        per_axis(p.gradient_step, p.gradient_step_m),
    )
}

/// Marks the feasible candidates within two standard errors (the best's `score_se`) of the best
/// as tied with it.
fn mark_ties(candidates: &mut [(Stage, Score)], ranked: &[usize]) {
    let Some(&first) = ranked.first() else {
        return;
    };
    let best = candidates[first].1;
    let (Some(value), se) = (best.score, best.score_se.unwrap_or(0.0)) else {
        return;
    };
    for (_, s) in candidates.iter_mut() {
        s.tied = s.score.is_some_and(|v| v <= value + 2.0 * se);
    }
}

/// Returns the recommended candidate among the ranked ones tied with the best: the nearest to
/// `from` (rotation angle first, then offset distance), else the roundest; then by score.
fn recommend(candidates: &[(Stage, Score)], ranked: &[usize], from: Option<&FromPose>) -> Option<usize> {
    let tied = ranked.iter().copied().filter(|&i| candidates[i].1.tied);
    let key = |i: usize| -> (f64, f64) {
        let s = &candidates[i].1;
        match from {
            Some(p) => (
                search::rotation_angle(s.rotation, p.rotation),
                (0..3)
                    .map(|k| (s.offset[k] - p.offset[k]).powi(2))
                    .sum::<f64>()
                    .sqrt(),
            ),
            None => (search::roundness(&s.params()), 0.0),
        }
    };
    // `ranked` is in score order, so the first of equal keys has the better score.
    tied.min_by(|&a, &b| {
        let (ka, kb) = (key(a), key(b));
        ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    })
    .or_else(|| ranked.first().copied())
}

/// Returns warnings about objectives the search cannot move: with sonar 2's origin fixed
/// (`origin` rig, no offsets searched), its rotation leaves every range sonar 2 measures, and
/// so the recovery sigma, unchanged; only which features are shared moves it.
fn warnings(config: &AdviseConfig) -> Vec<String> {
    let recovery = match config.objective {
        Objective::Recovery => true,
        Objective::Mix { weight, .. } => weight < 1.0,
        Objective::Correspondence | Objective::Ambiguity => false,
    };
    let offsets_fixed = config.axes[3..].iter().all(|a| a.len() < 2);
    // With an imaging sonar 1 the sigma depends on sonar 2's origin alone (the slope of its
    // range along sonar 1's arc); a sidescan sonar 1's depends on sonar 2's own arc, which turns.
    let fls_source = config.source.kind == sonarproj::SonarKind::Fls;
    if recovery && offsets_fixed && fls_source && matches!(config.rig, Rig::Origin(_)) {
        vec![
            "the recovery sigma cannot change with sonar 2's rotation here: with its origin fixed \
             (rig origin), the ranges sonar 2 measures do not depend on how it turns, and only \
             which features both sonars see moves the median; search the baseline instead \
             ([search] x, y, z offsets, or another [rig] origin)"
                .to_string(),
        ]
    } else {
        Vec::new()
    }
}

/// Returns the feasible candidates best first, each rotation once; ties keep evaluation order.
fn ranking(candidates: &[(Stage, Score)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..candidates.len())
        .filter(|&i| candidates[i].1.score.is_some())
        .collect();
    order.sort_by(|&a, &b| {
        let (x, y) = (candidates[a].1.score, candidates[b].1.score);
        let value = |v: Option<f64>| v.unwrap_or(f64::INFINITY);
        value(x).total_cmp(&value(y)).then(a.cmp(&b))
    });
    let mut seen = std::collections::HashSet::new();
    order.retain(|&i| seen.insert(candidates[i].1.params().map(f64::to_bits)));
    order
}
