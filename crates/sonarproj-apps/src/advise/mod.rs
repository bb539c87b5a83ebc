//! The rig advisor: which relative rotation of two sonars makes correspondence easy or recovery
//! precise over the features a rig will see, and which small move improves the pose it has.
//!
//! A candidate rotation is scored over a fixed set of features in sonar 1 (drawn over its field of
//! view, or given): the features whose true point sonar 2 also sees are the shared ones; each
//! is projected (its range span in a sidescan sonar 2, its projection area in an FLS) and its
//! recovered coordinate's first-order sigma computed; the objective reduces them
//! (`config`: correspondence, recovery or a mix). The search covers the rotations asked for,
//! refines the best by pattern search and, from a given pose, finds the best small move
//! (`search`). Everything evaluated is written out with the features, so any score can be
//! recomputed with `sonarproj batch` (`report`).

pub mod config;
pub mod features;
mod report;
pub mod score;
pub mod search;

pub use config::{AdviseConfig, FromPose, Objective, Rig};
pub use features::Features;
pub use report::{Written, write};
pub use score::{Params, Score, Scorer, Stats};
pub use search::{Move, Stage};

use sonarproj::projection::Backend;

use crate::error::Result;

/// What the advisor found.
#[derive(Clone, Debug, PartialEq)]
pub struct Advice {
    /// Every candidate evaluated, in order, with where it came from.
    pub candidates: Vec<(Stage, Score)>,
    /// The feasible candidates from best to worst (indices into `candidates`; a rotation
    /// evaluated twice counted once).
    pub ranked: Vec<usize>,
    /// The next-best move, when the advise file gives a pose.
    pub next: Option<Move>,
    /// The metric scored: `span` or `projection_area`.
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
    let scorer = Scorer::new(config, backend)?;
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
            // A search that fixes every axis still turns the pose about all three rotation axes
            // (and moves it along x, y, z for a rig with an origin or translation).
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
            let (m, evaluated) = search::next_move(
                &scorer,
                from,
                free,
                per_axis(p.step, p.step_m),
                per_axis(p.gradient_step, p.gradient_step_m),
            )?;
            candidates.extend(evaluated.into_iter().map(|s| (Stage::Move, s)));
            Some(m)
        }
    };
    Ok(Advice {
        ranked: ranking(&candidates),
        candidates,
        next,
        metric: score::metric_name(config),
    })
}

/// Returns the indices of the feasible candidates from best to worst (ties in evaluation order),
/// each rotation once.
fn ranking(candidates: &[(Stage, Score)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..candidates.len())
        .filter(|&i| candidates[i].1.score.is_some())
        .collect();
    order.sort_by(|&a, &b| {
        let (x, y) = (candidates[a].1.score, candidates[b].1.score);
        x.partial_cmp(&y)
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(a.cmp(&b))
    });
    let mut seen = std::collections::HashSet::new();
    order.retain(|&i| seen.insert(candidates[i].1.params().map(f64::to_bits)));
    order
}
