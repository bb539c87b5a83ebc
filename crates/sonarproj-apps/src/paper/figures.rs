//! The paper's figures as data for [`crate::report::figures`]: per direction, scenarios 1–6 as a
//! 2×3 grid of line plots (the metric against the swept angle, one curve per distance fraction)
//! and scenarios 7–9 as a row of heatmaps; titles, captions and labels are written here.

use super::{Direction, DirectionRun, FRACTIONS, swept};
use crate::report::figures::{HeatmapPanel, HeatmapRow, LineGrid, LinePanel};

const ANGLE_NAMES: [&str; 3] = ["roll", "pitch", "yaw"];

/// Returns the distances text of scenario `s` (which sonar's distance is the fraction).
fn distances_text(s: u8) -> &'static str {
    match s {
        1..=3 => "sonar 1 at 0.5 r_max, sonar 2 at f r_max",
        4..=6 => "sonar 1 at f r_max, sonar 2 at 0.5 r_max",
        _ => "both at 0.5 r_max",
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
                .map(|&f| {
                    run.poses
                        .iter()
                        .zip(&run.results)
                        .filter(|(p, _)| p.scenario == s && p.fraction == Some(f))
                        .map(|(p, r)| (p.angles[axis], run.direction.metric(&r.metrics)))
                        .collect()
                })
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
        legend_lead: "distance fraction f (same in every panel):".to_string(),
        legend: FRACTIONS.iter().map(|f| format!("{f:.1}")).collect(),
        panels,
    }
}

/// Returns scenarios 7–9 of `run` as a row of heatmaps over the swept `angles` (deg, evenly
/// spaced from 0 to 180°), each panel with its own colour scale.
pub(super) fn heatmaps(run: &DirectionRun, angles: &[f64]) -> HeatmapRow {
    let step = if angles.len() > 1 {
        angles[1] - angles[0]
    } else {
        1.0
    };
    let panels = (7..=9u8)
        .map(|s| {
            let [ax, ay] = [swept(s)[0], swept(s)[1]];
            HeatmapPanel {
                caption: format!("Scenario {s}: {} × {}", ANGLE_NAMES[ax], ANGLE_NAMES[ay]),
                x_label: format!("{} (deg)", ANGLE_NAMES[ax]),
                y_label: format!("{} (deg)", ANGLE_NAMES[ay]),
                cells: run
                    .poses
                    .iter()
                    .zip(&run.results)
                    .filter(|(p, _)| p.scenario == s)
                    .map(|(p, r)| (p.angles[ax], p.angles[ay], run.direction.metric(&r.metrics)))
                    .collect(),
            }
        })
        .collect();
    HeatmapRow {
        title: format!(
            "{}, both features at 0.5 r_max ({}; each panel its own colour scale)",
            metric_title(run.direction),
            sampling_text(run)
        ),
        step,
        axis_range: (0.0, 180.0),
        colour_label: format!("colour: {}, this panel's own scale", run.direction.metric_label()),
        panels,
    }
}
