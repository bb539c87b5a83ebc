//! The rig advisor: which relative rotation of two sonars makes correspondence easy or recovery
//! precise, and which small move improves the current pose.
//!
//! Candidates are scored over a fixed set of sonar 1 features, drawn or given. The shared
//! features are those sonar 2 also sees. Each is projected (range span for an SSS sonar 2,
//! projection area for an FLS) and gets its recovered coordinate's first-order sigma. The
//! objective (`config`) reduces these for correspondence, recovery or a mix. `search` covers the
//! asked rotations, refines the best by pattern search, and finds the best small move from a
//! given pose. `report` writes everything evaluated, so `sonarproj batch` can recompute a score.

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
    /// The feasible candidates, best first, as indices into `candidates`; each rotation once.
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
            // With every axis fixed, the move still turns the pose about all three rotation axes,
            // and moves it along x, y, z for a rig with an origin or translation.
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

/// Returns the feasible candidates best first, each rotation once; ties keep evaluation order.
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
