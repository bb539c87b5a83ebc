//! `sonarproj paper`: the paper's simulations (README), CSV, figures and findings.

use std::path::PathBuf;

use rayon::prelude::*;
use std::time::Instant;

use super::BackendArg;
use sonarproj::{Backend, Sampling};
use sonarproj_apps::io::table::write_rows;
use sonarproj_apps::io::{METRIC_COLUMNS, metric_fields};
use sonarproj_apps::paper::{self, angles};
use sonarproj_apps::report::{check_output_dir, figures, output_dir, write_atomic};
use sonarproj_apps::{Error, Result};

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
    /// Sampling step (deg) of the arcs and surfaces, as the published code (0.1).
    #[arg(long, value_name = "DEG", default_value_t = 0.1)]
    step: f64,
    /// Where to compute.
    #[arg(long, value_enum, default_value = "auto")]
    backend: BackendArg,
}

/// Runs `sonarproj paper`.
pub(super) fn run(a: PaperArgs) -> Result<()> {
    let sampling = Sampling::Step(a.step).validated()?;
    let swept = angles(a.angle_step)?;
    // A file where the directory should be is refused before any work; the directory itself is
    // created once the results exist, so a refused run leaves nothing behind.
    check_output_dir(&a.out, "--out")?;
    let (backend, notice) = Backend::select(a.backend.into())?;
    if let Some(n) = notice {
        eprintln!("{n}");
    }
    let start = Instant::now();
    let runs = paper::run(&backend, a.angle_step, sampling)?;
    let computed = start.elapsed();
    output_dir(&a.out, "--out")?;

    let header: Vec<String> = ["scenario", "fraction", "roll", "pitch", "yaw"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    // The two directions' CSV and figures are independent: written on all cores at once.
    runs.par_iter().try_for_each(|run| -> Result<()> {
        let stem = run.direction.stem();
        let write_csv = || {
            let rows = run.poses.iter().zip(&run.results).map(|(p, r)| {
                let mut fields = vec![
                    p.scenario.to_string(),
                    p.fraction.map(|f| f.to_string()).unwrap_or_default(),
                ];
                fields.extend(p.angles.iter().map(f64::to_string));
                (fields, metric_fields(&r.metrics))
            });
            let csv = a.out.join(format!("{stem}.csv"));
            write_atomic(&csv, |w| write_rows(w, &header, &METRIC_COLUMNS, rows))
        };
        let (csv, (lines, heatmaps)) = rayon::join(write_csv, || {
            rayon::join(
                || figures::line_grid(run, &a.out.join(format!("{stem}-lines.png"))),
                || figures::heatmaps(run, &swept, &a.out.join(format!("{stem}-heatmaps.png"))),
            )
        });
        csv.and(lines).and(heatmaps)
    })?;
    let findings = paper::findings(&runs);
    let md = paper::findings_markdown(&findings, a.angle_step, sampling);
    write_atomic(&a.out.join("findings.md"), |w| {
        w.write_all(md.as_bytes()).map_err(|e| Error::WriteOutput {
            path: "findings.md".into(),
            message: e.to_string(),
        })
    })?;
    let poses: usize = runs.iter().map(|r| r.poses.len()).sum();
    let samples: u64 = runs
        .iter()
        .flat_map(|r| &r.results)
        .map(|r| r.metrics.total)
        .sum();
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
