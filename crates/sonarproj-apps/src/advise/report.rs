//! Writes the advisor's files: `best.json` (ranked poses, scores, next-best move),
//! `candidates.parquet` (every candidate evaluated), `landscape.png` (the score over two axes),
//! and `features.csv`: the best pose's features and pose in `batch`'s columns, so `batch` can
//! give each one's metric.

use std::path::{Path, PathBuf};

use serde_json::json;

use crate::advise::Advice;
use crate::advise::config::{AXES, AdviseConfig, Objective, Rig, unit};
use crate::advise::features::Features;
use crate::advise::pool::Pool;
use crate::advise::score::{Params, Score};
use crate::advise::search::Stage;
use crate::error::{Error, Result};
use crate::io::parquet::{Column, Encoding, Kind, Table, TableWriter};
use crate::report::figures::Mark;
use crate::report::{check_output_file, output_dir, write_atomic};

/// The files [`write()`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    /// `DIR/best.json`.
    pub best: PathBuf,
    /// `DIR/candidates.parquet`.
    pub candidates: PathBuf,
    /// `DIR/features.csv`.
    pub features: PathBuf,
    /// `DIR/pareto.csv`.
    pub pareto: PathBuf,
    /// `DIR/landscape.png`, when two axes vary.
    pub landscape: Option<PathBuf>,
}

/// How many ranked poses `best.json` lists.
pub(crate) const RANKED: usize = 10;

const COLUMNS: [&str; 26] = [
    "index",
    "stage",
    "roll",
    "pitch",
    "yaw",
    "x",
    "y",
    "z",
    "tx",
    "ty",
    "tz",
    "shared",
    "shared_se",
    "examined",
    "features",
    "metric_mean",
    "metric_median",
    "metric_p10",
    "metric_p90",
    "sigma_mean",
    "sigma_median",
    "sigma_p10",
    "sigma_p90",
    "score",
    "score_se",
    "tied",
];

/// Writes the advisor's files into `dir` (created when missing), each whole or not at all.
///
/// # Errors
/// As [`output_dir`] and [`write_atomic`]. [`Error::Figure`] when the landscape cannot be drawn.
pub fn write(config: &AdviseConfig, advice: &Advice, dir: &Path) -> Result<Written> {
    let written = Written {
        best: dir.join("best.json"),
        candidates: dir.join("candidates.parquet"),
        features: dir.join("features.csv"),
        pareto: dir.join("pareto.csv"),
        landscape: config.landscape.map(|_| dir.join("landscape.png")),
    };
    for f in [
        &written.best,
        &written.candidates,
        &written.features,
        &written.pareto,
    ]
    .into_iter()
    .chain(written.landscape.as_ref())
    {
        check_output_file(f, crate::params::OUT)?;
    }
    output_dir(dir, crate::params::OUT)?;
    write_atomic(&written.best, |w| {
        serde_json::to_writer_pretty(&mut *w, &best_json(config, advice))
            .map_err(|e| Error::write_output(&written.best, e))?;
        w.write_all(b"\n")
            .map_err(|e| Error::write_output(&written.best, e))
    })?;
    write_atomic(&written.candidates, |w| {
        let names: Vec<String> = COLUMNS.iter().map(ToString::to_string).collect();
        let kinds: Vec<Kind> = COLUMNS
            .iter()
            .map(|c| match *c {
                "index" | "stage" | "features" | "examined" | "tied" => Kind::Int,
                c if c.starts_with("metric") || c.starts_with("sigma") || c.starts_with("score") => {
                    Kind::Optional
                }
                _ => Kind::Real,
            })
            .collect();
        let mut t = TableWriter::new(
            w,
            &names,
            &kinds,
            0,
            Encoding {
                dictionary: &[],
                delta: &[],
            },
            &written.candidates,
        )?;
        t.push(candidates_table(&names, &kinds, advice))?;
        t.finish()
    })?;
    let best = advice.best().copied().unwrap_or(advice.candidates[0].1);
    write_atomic(&written.features, |w| {
        let mut out = csv::Writer::from_writer(w);
        let err = |e: csv::Error| Error::write_output(&written.features, e);
        out.write_record([
            "range",
            "azimuth",
            "elevation",
            "roll",
            "pitch",
            "yaw",
            "tx",
            "ty",
            "tz",
        ])
        .map_err(err)?;
        // The best pose's own features: those it was scored over.
        let pose = config.pose_of(best.params())?;
        let pool = Pool::new(config);
        for (f, _) in &crate::advise::pool::kept(&config.source, &pool, &pose).1 {
            let row: Vec<String> = f
                .iter()
                .chain(&best.rotation)
                .chain(&best.translation)
                .map(ToString::to_string)
                .collect();
            out.write_record(&row).map_err(err)?;
        }
        out.flush().map_err(|e| Error::write_output(&written.features, e))
    })?;
    write_atomic(&written.pareto, |w| {
        pareto_csv(config, advice, w, &written.pareto)
    })?;
    if let (Some(path), Some(axes)) = (&written.landscape, config.landscape) {
        landscape(config, advice, axes, &best, path)?;
    }
    Ok(written)
}

#[expect(
    clippy::cast_possible_wrap,
    reason = "candidate and feature counts below 2^63"
)]
fn candidates_table(names: &[String], kinds: &[Kind], advice: &Advice) -> Table {
    let mut t = Table::new(names, kinds);
    let c = &advice.candidates;
    let real = |f: &dyn Fn(&Score) -> f64| Column::Real(c.iter().map(|(_, s)| f(s)).collect());
    let optional =
        |f: &dyn Fn(&Score) -> Option<f64>| Column::Optional(c.iter().map(|(_, s)| f(s)).collect());
    t.columns = vec![
        Column::Int((0..c.len() as i64).collect()),
        Column::Int(c.iter().map(|(stage, _)| stage.code()).collect()),
        real(&|s| s.rotation[0]),
        real(&|s| s.rotation[1]),
        real(&|s| s.rotation[2]),
        real(&|s| s.offset[0]),
        real(&|s| s.offset[1]),
        real(&|s| s.offset[2]),
        real(&|s| s.translation[0]),
        real(&|s| s.translation[1]),
        real(&|s| s.translation[2]),
        real(&|s| s.shared),
        real(&|s| s.shared_se),
        Column::Int(c.iter().map(|(_, s)| s.examined as i64).collect()),
        Column::Int(c.iter().map(|(_, s)| s.features as i64).collect()),
        optional(&|s| s.metric.mean),
        optional(&|s| s.metric.median),
        optional(&|s| s.metric.p10),
        optional(&|s| s.metric.p90),
        optional(&|s| s.sigma.mean),
        optional(&|s| s.sigma.median),
        optional(&|s| s.sigma.p10),
        optional(&|s| s.sigma.p90),
        optional(&|s| s.score),
        optional(&|s| s.score_se),
        Column::Int(c.iter().map(|(_, s)| i64::from(s.tied)).collect()),
    ];
    t
}

/// Returns the unit of the projection metric (`m` for a sidescan's span, `m²` for an imaging
/// sonar's area) and of the score.
pub(crate) fn units(config: &AdviseConfig) -> (&'static str, &'static str) {
    let metric = match config.target.kind {
        sonarproj::SonarKind::Sss => "m",
        sonarproj::SonarKind::Fls => "m²",
    };
    let score = match config.objective {
        Objective::Correspondence | Objective::Ambiguity => metric,
        Objective::Recovery => "deg",
        Objective::Mix { .. } => "1",
    };
    (metric, score)
}

fn best_json(config: &AdviseConfig, advice: &Advice) -> serde_json::Value {
    let (metric_unit, unit) = units(config);
    let blind = crate::advise::Scorer::blind_cost(&config.target);
    let correspondence = format!(
        "mean search cost per point examined: its {} ({metric_unit}) when both sonars see it, else a blind search of sonar 2 ({blind} {metric_unit})",
        advice.metric
    );
    let objective = match config.objective {
        Objective::Correspondence => {
            json!({ "name": "correspondence", "minimises": correspondence, "unit": unit, "blind_cost": blind })
        }
        Objective::Ambiguity => {
            json!({ "name": "ambiguity", "minimises": format!("mean {} of the shared features ({metric_unit})", advice.metric), "unit": unit })
        }
        Objective::Recovery => {
            json!({ "name": "recovery", "minimises": "median sigma_elevation (deg)", "unit": unit })
        }
        Objective::Mix {
            weight,
            metric_scale,
            sigma_scale,
        } => json!({
            "name": "mix",
            "minimises": format!("{weight} * ({correspondence}) / {metric_scale} {metric_unit} + {} * median sigma_elevation / {sigma_scale} deg", 1.0 - weight),
            "unit": unit,
            "blind_cost": blind,
            "weight": weight, "metric_scale": metric_scale, "sigma_scale": sigma_scale,
        }),
    };
    let rig = match config.rig {
        Rig::Origin(o) => json!({ "origin": o }),
        Rig::Translation(t) => json!({ "translation": t }),
        Rig::Place { feature, at } => json!({ "place": { "feature": feature, "at": at } }),
    };
    let count = |stage: Stage| advice.candidates.iter().filter(|(s, _)| *s == stage).count();
    json!({
        "from": config.source.name,
        "to": config.target.name,
        "metric": advice.metric,
        "objective": objective,
        "min_shared": config.min_shared,
        "rig": rig,
        "features": match &config.features {
            Features::Drawn { count, seed } => json!({
                "count": count,
                "seed": seed,
                "drawn_over": if Pool::new(config).in_target() { "sonar 2's view" } else { "sonar 1's view" },
            }),
            Features::Points(p) => json!({ "points": p.len() }),
        },
        "candidates": { "cover": count(Stage::Cover), "refine": count(Stage::Refine), "move": count(Stage::Move) },
        "feasible": advice.ranked.len(),
        "tied": advice.ranked.iter().filter(|&&i| advice.candidates[i].1.tied).count(),
        "recommended": advice.recommended.map(|i| advice.candidates[i].1),
        "recommended_because": recommended_rule(config),
        "pareto": advice.pareto.len(),
        "score_unit": unit,
        "metric_unit": metric_unit,
        "ranked": advice.ranked.iter().take(RANKED).map(|&i| advice.candidates[i].1).collect::<Vec<_>>(),
        "next_move": advice.next,
        "warnings": advice.warnings,
    })
}

/// Returns the rule that picked the recommended candidate among the ties, in words.
pub(crate) fn recommended_rule(config: &AdviseConfig) -> &'static str {
    if config.from_pose.is_some() {
        "of the candidates tied with the best (within 2 standard errors), the nearest to from_pose"
    } else {
        "of the candidates tied with the best (within 2 standard errors), the one with the roundest angles and offsets"
    }
}

/// Writes `pareto.csv`: the candidates of the Pareto front ([`crate::advise::pareto`]) with the
/// three quantities, their standard errors and their score.
fn pareto_csv(config: &AdviseConfig, advice: &Advice, w: &mut dyn std::io::Write, path: &Path) -> Result<()> {
    let mut out = csv::Writer::from_writer(w);
    let err = |e: csv::Error| Error::write_output(path, e);
    let (metric_unit, unit) = units(config);
    let header = [
        "index".to_string(),
        "roll".into(),
        "pitch".into(),
        "yaw".into(),
        "x".into(),
        "y".into(),
        "z".into(),
        "shared".into(),
        "shared_se".into(),
        format!("ambiguity_{metric_unit}"),
        format!("ambiguity_se_{metric_unit}"),
        "sigma_median_deg".into(),
        "sigma_median_se_deg".into(),
        format!("score_{unit}"),
        format!("score_se_{unit}"),
        "tied".into(),
    ];
    out.write_record(&header).map_err(err)?;
    let text = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for &i in &advice.pareto {
        let s = &advice.candidates[i].1;
        let mut row: Vec<String> = vec![i.to_string()];
        row.extend(s.params().iter().map(ToString::to_string));
        row.extend([
            s.shared.to_string(),
            s.shared_se.to_string(),
            text(s.metric.mean),
            text(s.metric.mean_se),
            text(s.sigma.median),
            text(s.sigma.median_se),
            text(s.score),
            text(s.score_se),
            u8::from(s.tied).to_string(),
        ]);
        out.write_record(&row).map_err(err)?;
    }
    out.flush().map_err(|e| Error::write_output(path, e))
}

/// Draws the score over `axes` (of [`AXES`]), each other axis at the cover value nearest the
/// best's. It shows the cover's candidates there, grey where infeasible.
fn landscape(
    config: &AdviseConfig,
    advice: &Advice,
    axes: [usize; 2],
    best: &Score,
    path: &Path,
) -> Result<()> {
    let at = best.params();
    // Each other axis at the cover's value nearest the best's (refinement may move off it).
    let fixed: [f64; 6] = std::array::from_fn(|k| {
        config.axes[k]
            .iter()
            .copied()
            .min_by(|a, b| (a - at[k]).abs().total_cmp(&(b - at[k]).abs()))
            .unwrap_or(0.0)
    });
    let others: Vec<usize> = (0..6).filter(|k| !axes.contains(k)).collect();
    let points: Vec<(Vec<f64>, Option<f64>)> = advice
        .candidates
        .iter()
        .filter(|(stage, s)| *stage == Stage::Cover && others.iter().all(|&k| s.params()[k] == fixed[k]))
        .map(|(_, s)| (vec![s.params()[axes[0]], s.params()[axes[1]]], s.score))
        .collect();
    let what = landscape_quantity(config, advice);
    let held: Vec<String> = others
        .iter()
        .filter(|&&k| config.axes[k].len() > 1 || k < 3)
        .map(|&k| axis_value(k, fixed[k]))
        .collect();
    let caption = format!(
        "{} -> {}: {} at {} (best {})",
        config.source.name,
        config.target.name,
        crate::report::figures::without_unit(&what),
        held.join(", "),
        (0..6)
            .filter(|&k| k < 3 || config.axes[k].len() > 1)
            .map(|k| axis_value(k, (at[k] * 100.0).round() / 100.0))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let missing = format!("infeasible (under {} % shared)", 100.0 * config.min_shared);
    let on = |p: Params| [p[axes[0]], p[axes[1]]];
    let mut marks = vec![Mark::Disc {
        label: "best".into(),
        at: on(at),
    }];
    if let Some(m) = &advice.next {
        // The pose now and its move may lie off this slice (another value of a held axis).
        let now = m.now.params();
        let on_slice = others.iter().all(|&k| (now[k] - fixed[k]).abs() < 1e-9);
        marks.push(Mark::Square {
            label: if on_slice {
                "pose now".into()
            } else {
                "pose now (off this slice)".into()
            },
            at: on(m.now.params()),
        });
        if let (Some(b), false) = (&m.best, m.stay) {
            marks.push(Mark::Arrow {
                label: "next move".into(),
                from: on(m.now.params()),
                to: on(b.params()),
            });
        }
    }
    crate::report::figures::sweep_marked(
        path,
        &caption,
        &[axis_words(axes[0]), axis_words(axes[1])],
        &what,
        &missing,
        &points,
        &marks,
    )
}

/// Returns axis `k` of [`AXES`] in words with its unit: "roll (deg)", "offset x (m)".
fn axis_words(k: usize) -> String {
    if k < 3 {
        format!("{} ({})", AXES[k], unit(k))
    } else {
        format!("offset {} ({})", AXES[k], unit(k))
    }
}

/// Returns axis `k` at `value` in words: "roll 90°", "offset x 0.5 m".
fn axis_value(k: usize, value: f64) -> String {
    if k < 3 {
        format!("{} {value}°", AXES[k])
    } else {
        format!("offset {} {value} {}", AXES[k], unit(k))
    }
}

/// Returns what the landscape's colour shows, in words with its unit: "mean search cost (m²)".
fn landscape_quantity(config: &AdviseConfig, advice: &Advice) -> String {
    let (metric_unit, _) = units(config);
    match config.objective {
        Objective::Correspondence => format!("mean search cost ({metric_unit})"),
        Objective::Ambiguity => {
            let label = sonarproj::Metric::from_name(advice.metric)
                .and_then(|m| m.label(config.target.kind))
                .unwrap_or(advice.metric);
            format!("mean {label} of the shared features")
        }
        Objective::Recovery => "median elevation sigma (deg)".to_string(),
        Objective::Mix { .. } => "mixed score (no unit)".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::{axis_value, axis_words};

    #[test]
    fn landscape_axes_are_words_with_units() {
        assert_eq!(axis_words(1), "pitch (deg)");
        assert_eq!(axis_words(3), "offset x (m)");
        assert_eq!(axis_value(2, 45.0), "yaw 45°");
        assert_eq!(axis_value(5, 0.25), "offset z 0.25 m");
    }
}
