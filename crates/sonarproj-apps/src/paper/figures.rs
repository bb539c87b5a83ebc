//! The paper's figures as data for [`crate::report::figures`]: per direction, scenarios 1–6 as a
//! 2×3 grid of line plots (the metric against the swept angle, one curve per distance fraction)
//! and scenarios 7–9 as a row of heatmaps; titles, captions and labels are written here.

use super::{Direction, DirectionRun, FRACTIONS, swept};
use crate::report::figures::{HeatmapPanel, HeatmapRow, LineGrid, LinePanel};

const ANGLE_NAMES: [&str; 3] = ["roll", "pitch", "yaw"];

/// Returns the distances text of scenario `s`: which sonar's feature distance is the fraction
/// f of its maximum range.
fn distances_text(s: u8) -> &'static str {
    match s {
        1..=3 => "f in sonar 2, 0.5 in sonar 1",
        4..=6 => "f in sonar 1, 0.5 in sonar 2",
        _ => "0.5 in both",
    }
}

/// Returns the name of the direction's plotted metric in a title.
fn metric_title(direction: Direction) -> &'static str {
    match direction {
        Direction::FlsToSss => "paper-fls to paper-sss: range span",
        Direction::SssToFls => "paper-sss to paper-fls: projection area",
    }
}

/// Returns how `run`'s arcs or surfaces were sampled, for a title: `arcs every 0.1°`.
fn sampling_text(run: &DirectionRun) -> String {
    let set = match run.direction {
        Direction::FlsToSss => "arcs",
        Direction::SssToFls => "surfaces",
    };
    match run.sampling {
        sonarproj::Sampling::Step(s) => format!("{set} every {s}°"),
        sonarproj::Sampling::Auto => format!("{set} with auto sampling"),
        sonarproj::Sampling::Exact => format!("{set} solved exactly"),
    }
}

/// Returns scenarios 1–6 of `run` as a 2×3 grid of line plots over 0–180°.
#[expect(clippy::cast_possible_truncation, reason = "a panel index below six")]
pub(super) fn lines(run: &DirectionRun) -> LineGrid {
    let panels = (0..6)
        .map(|k| {
            let s = k as u8 + 1;
            let axis = swept(s)[0];
            let curves = FRACTIONS
                .iter()
                .map(|&f| run.line(s, f).map(|l| l.points.clone()).unwrap_or_default())
                .collect();
            LinePanel {
                caption: format!(
                    "Scenario {s}: {} swept ({})",
                    ANGLE_NAMES[axis],
                    distances_text(s)
                ),
                x_label: format!("{} (deg)", ANGLE_NAMES[axis]),
                x_range: (0.0, 180.0),
                curves,
            }
        })
        .collect();
    LineGrid {
        title: format!("{} ({})", metric_title(run.direction), sampling_text(run)),
        shape: (2, 3),
        y_label: run.direction.metric_label().to_string(),
        legend_lead: "f, the feature's distance over the sonar's maximum range (every panel):".to_string(),
        legend: FRACTIONS.iter().map(|f| format!("{f:.1}")).collect(),
        panels,
    }
}

/// Returns scenarios 7–9 of `run` as a row of heatmaps over their lattice of swept angles
/// (deg, evenly spaced from 0 to 180°), each panel with its own colour scale.
pub(super) fn heatmaps(run: &DirectionRun) -> HeatmapRow {
    let mut step = 1.0;
    let panels = run
        .grids
        .iter()
        .map(|g| {
            let s = g.scenario;
            let [ax, ay] = [swept(s)[0], swept(s)[1]];
            if g.lattice.len() > 1 {
                step = g.lattice[1] - g.lattice[0];
            }
            let m = g.lattice.len();
            HeatmapPanel {
                caption: format!("Scenario {s}: {} × {}", ANGLE_NAMES[ax], ANGLE_NAMES[ay]),
                x_label: format!("{} (deg)", ANGLE_NAMES[ax]),
                y_label: format!("{} (deg)", ANGLE_NAMES[ay]),
                cells: g
                    .values
                    .iter()
                    .enumerate()
                    .map(|(k, &v)| (g.lattice[k / m], g.lattice[k % m], v))
                    .collect(),
            }
        })
        .collect();
    HeatmapRow {
        title: format!(
            "{}, both features at half their sonar's maximum range ({}; each panel its own colour scale)",
            metric_title(run.direction),
            sampling_text(run)
        ),
        step,
        axis_range: (0.0, 180.0),
        colour_label: format!("colour: {}, this panel's own scale", run.direction.metric_label()),
        panels,
    }
}

#[cfg(test)]
mod tests {
    use crate::paper::{findings, findings_markdown, run};
    use sonarproj::{Backend, Sampling};

    /// The figures and findings speak in words with units: no variable or column names.
    #[test]
    fn figures_and_findings_are_in_words_with_units() {
        let runs = run(&Backend::CpuFast, 90.0, Sampling::Step(1.0)).unwrap();
        for r in &runs {
            let lines = super::lines(r);
            let heat = super::heatmaps(r);
            let mut texts = vec![
                lines.title,
                lines.y_label,
                lines.legend_lead,
                heat.title,
                heat.colour_label,
            ];
            for p in &lines.panels {
                texts.extend([p.caption.clone(), p.x_label.clone()]);
            }
            for p in &heat.panels {
                texts.extend([p.caption.clone(), p.x_label.clone(), p.y_label.clone()]);
            }
            for t in texts {
                assert!(!t.contains('_'), "{t}");
            }
        }
        // Every row of a table of means says its metric's unit: a span in m, an area in m².
        let md = findings_markdown(&findings(&runs), 90.0, Sampling::Step(1.0));
        let rows: Vec<&str> = md
            .lines()
            .filter(|l| l.starts_with("| fls-to-sss") || l.starts_with("| sss-to-fls"))
            .collect();
        assert_eq!(rows.len(), 2 + 12, "{md}");
        for row in rows {
            let unit = if row.starts_with("| fls-to-sss") {
                "| range span (m) |"
            } else {
                "| projection area (m²) |"
            };
            assert!(row.contains(unit), "{row}");
        }
    }
}
