//! `sonarproj paper`: the paper's simulations (docs/paper.md), CSV, figures and findings.

use std::path::PathBuf;

use std::time::Instant;

use super::BackendArg;
use sonarproj::Sampling;
use sonarproj_apps::Result;
use sonarproj_apps::paper::{self, angles};
use sonarproj_apps::report::check_output_dir;

/// Options of `sonarproj paper`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub(super) struct PaperArgs {
    /// Output directory (created when missing): fls-to-sss.csv, sss-to-fls.csv, the figures
    /// (*-lines.png: scenarios 1–6, *-heatmaps.png: scenarios 7–9) and findings.md.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Step (deg) of the swept angles, 0 to 180.
    #[arg(long, value_name = "DEG", default_value_t = 1.0)]
    angle_step: f64,
    /// Sampling step (deg) of the arcs and surfaces: 0.1 as the published code (its curves are
    /// staircases, as the authors' are), `auto` for smooth curves (neighbouring samples less
    /// than half a bin and half a beam apart in sonar 2), or `exact` (FLS arcs solved in closed
    /// form, SSS surfaces, which have no exact mode, sampled at 0.1).
    #[arg(long, value_name = "DEG|auto|exact", default_value = "0.1", value_parser = super::parse_step)]
    step: Sampling,
    /// Where to compute.
    #[arg(long, value_enum, default_value = "auto")]
    backend: BackendArg,
}

/// Runs `sonarproj paper`.
pub(super) fn run(a: PaperArgs) -> Result<()> {
    let sampling = a.step.validated()?;
    angles(a.angle_step)?;
    // A file where the directory should be is refused before any work. A run that fails leaves
    // no CSV behind, nor the directory when it made it.
    check_output_dir(&a.out, "--out")?;
    let (backend, notice) = super::gpu_env::select(a.backend.into())?;
    if let Some(n) = notice {
        eprintln!("{n}");
    }
    let start = Instant::now();
    let (runs, findings) = paper::run_to(
        &a.out,
        "--out",
        &backend,
        a.angle_step,
        sampling,
        sonarproj::stream::Stop::NEVER,
    )?;
    let computed = start.elapsed();
    let poses: u64 = runs.iter().map(|r| r.poses).sum();
    let samples: u64 = runs.iter().map(|r| r.samples).sum();
    outln!(
        "paper: {poses} poses ({} per direction, {samples} samples) on {} in {:.2} s; findings borne out: {}/{}; wrote {}",
        poses / 2,
        backend.device(),
        computed.as_secs_f64(),
        findings.iter().filter(|f| f.holds).count(),
        findings.len(),
        a.out.display()
    )?;
    Ok(())
}
