//! `sonarproj advise`: which relative rotation of two sonars suits a rig, and which small move
//! improves the pose it has.

use std::path::PathBuf;
use std::time::Instant;

use super::BackendArg;
use sonarproj_apps::Result;
use sonarproj_apps::advise::{self, AdviseConfig};

/// Options of `sonarproj advise`.
#[derive(Debug, clap::Args)]
pub(super) struct AdviseArgs {
    /// The advise file (TOML): sonar pair, objective, [features], [rig], [search] and an optional
    /// [from_pose]. See docs/advise.md and data/example-advise.toml.
    #[arg(long, value_name = "FILE.toml")]
    config: PathBuf,
    /// Output directory: best.json (the ranked poses, ties, the recommended pose, the next-best
    /// move), candidates.parquet (every candidate evaluated), pareto.csv (the feasible candidates
    /// no other beats on shared share, ambiguity and recovery sigma at once), features.csv (the
    /// features with the best pose, batch's columns) and landscape.png (the score over two axes,
    /// the best, the pose now and the move marked).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Where to compute.
    #[arg(long, value_enum, default_value = "auto")]
    backend: BackendArg,
}

/// Runs `sonarproj advise`.
pub(super) fn run(a: AdviseArgs) -> Result<()> {
    let config = AdviseConfig::load(&a.config)?;
    let (backend, notice) = super::gpu_env::select(a.backend.into())?;
    if let Some(n) = notice {
        eprintln!("{n}");
    }
    let start = Instant::now();
    let advice = advise::advise(&config, &backend)?;
    let seconds = start.elapsed().as_secs_f64();
    let written = advise::write(&config, &advice, &a.out)?;
    // A mix has no unit ("1"): nothing is printed after its numbers.
    let unit = match advise::score_unit(&config) {
        "1" => String::new(),
        u => format!(" {u}"),
    };
    let with_se = |v: Option<f64>, se: Option<f64>| match (v, se) {
        (Some(v), Some(se)) => format!("{v:.6} ± {se:.6}{unit}"),
        (Some(v), None) => format!("{v:.6}{unit}"),
        _ => "infeasible".to_string(),
    };
    // Angles to a thousandth of a degree, offsets to a tenth of a millimetre: best.json has
    // every digit.
    let round = |v: f64, per: f64| (v * per).round() / per + 0.0;
    let pose = |s: &advise::Score| {
        let [r, p, y] = s.rotation.map(|v| round(v, 1e3));
        let offset = s.offset.map(|v| round(v, 1e4));
        format!(
            "roll {r}, pitch {p}, yaw {y} deg{}",
            if offset == [0.0; 3] {
                String::new()
            } else {
                format!(", offset {offset:?} m")
            }
        )
    };
    let best = match advice.best() {
        Some(b) => format!(
            "best {}: score {}, {:.0} ± {:.0} % of the features shared",
            pose(b),
            with_se(b.score, b.score_se),
            100.0 * b.shared,
            100.0 * b.shared_se
        ),
        // Why none is: nothing shared at all says more than min_shared.
        None if advice.candidates.iter().all(|(_, s)| s.features == 0) => {
            "no candidate is feasible: no candidate pose lets sonar 2 see any of the features \
             (see [rig] and [search])"
                .to_string()
        }
        None => format!(
            "no candidate is feasible: none shares at least min_shared = {} of the features with \
             a score",
            config.min_shared
        ),
    };
    let projected: usize = advice.candidates.iter().map(|(_, s)| s.features).sum();
    eprintln!(
        "advise: {} candidates x {} features ({projected} projections) on {} in {seconds:.2} s; {best}; wrote {}",
        advice.candidates.len(),
        match &config.features {
            advise::Features::Drawn { count, .. } => *count,
            advise::Features::Points(p) => p.len(),
        },
        backend.device(),
        written.best.display()
    );
    let tied = advice
        .ranked
        .iter()
        .filter(|&&i| advice.candidates[i].1.tied)
        .count();
    if let Some(r) = advice.recommended.map(|i| &advice.candidates[i].1) {
        eprintln!(
            "advise: {tied} candidate(s) tied with the best (within 2 standard errors); recommended: {} (score {}), {}",
            pose(r),
            with_se(r.score, r.score_se),
            advise::recommended_rule(&config)
        );
    }
    if let Some(m) = &advice.next {
        let now = format!(
            "from {} (score {})",
            pose(&m.now),
            with_se(m.now.score, m.now.score_se)
        );
        let gain = match (m.gain, m.gain_se) {
            (Some(g), Some(se)) => format!("gain {g:.6} ± {se:.6}{unit}"),
            (Some(g), None) => format!("gain {g:.6}{unit}"),
            (None, _) => "the pose now is infeasible; this one is not".to_string(),
        };
        match (&m.best, m.stay) {
            (Some(b), false) => eprintln!(
                "advise: {now}: move to {}: {} ({gain})",
                pose(b),
                m.words.as_deref().unwrap_or("")
            ),
            (Some(_), true) => eprintln!(
                "advise: {now}: stay; the best move within {} deg ({} m) scores better by less than twice its standard error ({gain})",
                m.step[0], m.step[3]
            ),
            (None, _) => eprintln!(
                "advise: {now}: stay; no move within {} deg ({} m) scores better",
                m.step[0], m.step[3]
            ),
        }
    }
    for w in &advice.warnings {
        eprintln!("advise: warning: {w}");
    }
    Ok(())
}
