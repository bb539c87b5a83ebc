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
    /// Output directory: best.json (the ranked poses, the next-best move), candidates.parquet
    /// (every candidate evaluated), features.csv (the features with the best pose, batch's
    /// columns) and landscape.png (the score over two axes).
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
    let best = match advice.best() {
        Some(b) => format!(
            "best roll {}, pitch {}, yaw {} deg: score {:.6}, {:.0} % of the features shared",
            b.rotation[0],
            b.rotation[1],
            b.rotation[2],
            b.score.unwrap_or(f64::NAN),
            100.0 * b.shared
        ),
        None => "no candidate is feasible (see min_shared)".to_string(),
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
    if let Some(m) = &advice.next {
        let now = format!(
            "from roll {}, pitch {}, yaw {}",
            m.now.rotation[0], m.now.rotation[1], m.now.rotation[2]
        );
        match (&m.best, m.gain) {
            (Some(b), gain) => eprintln!(
                "advise: {now}: move to roll {:.3}, pitch {:.3}, yaw {:.3}{} ({})",
                b.rotation[0],
                b.rotation[1],
                b.rotation[2],
                if b.offset == m.now.offset {
                    String::new()
                } else {
                    format!(", offset {:?} m", b.offset)
                },
                gain.map_or(
                    "the pose now is infeasible; this one is not".to_string(),
                    |g| format!("gain {g:.6}")
                )
            ),
            (None, _) => eprintln!(
                "advise: {now}: no move within {} deg ({} m) scores better",
                m.step[0], m.step[3]
            ),
        }
    }
    Ok(())
}
