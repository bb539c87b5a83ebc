//! Checks the paper's four qualitative findings against both directions' numbers, and writes
//! them up as `findings.md`.

use std::fmt::Write as _;

use super::{Direction, DirectionRun, NEAR_FRACTION};
use sonarproj::sampling::Sampling;

/// Returns the `q`-quantile (0–1) of `v` (nearest rank).
#[expect(
    clippy::cast_possible_truncation,
    reason = "a count of angle steps or a quantile index, finite and bounded by the checked input"
)]
fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((s.len() - 1) as f64 * q).round() as usize]
}

/// Returns the words that say a grid's percentiles are taken on its lattice (empty when the
/// lattice is the whole grid): ` (on a 1801 × 1801 lattice, one swept angle in 10, of its
/// 18001 × 18001 poses)`.
#[expect(clippy::cast_precision_loss, reason = "a count of poses, far below 2^53")]
fn lattice_words(run: &DirectionRun, scenario: u8) -> String {
    match run.grid(scenario) {
        Some(g) if g.stride > 1 => {
            let (m, n) = (g.lattice.len(), (g.count as f64).sqrt().round());
            format!(
                " (on a {m} × {m} lattice, one swept angle in {}, of its {n} × {n} poses)",
                g.stride
            )
        }
        _ => String::new(),
    }
}

/// The verdict on one of the paper's qualitative findings.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    /// The finding in the paper's words (docs/paper.md).
    pub claim: &'static str,
    /// Whether the numbers bear it out.
    pub holds: bool,
    /// The numbers that show it, in Markdown.
    pub evidence: String,
}

/// Returns the paper's four findings (docs/paper.md) checked against `runs`.
/// `runs` holds both directions, with every fraction and 0°, 90° and 180° among the angles.
#[must_use]
pub fn findings(runs: &[DirectionRun]) -> Vec<Finding> {
    let get = |d: Direction| {
        runs.iter()
            .find(|r| r.direction == d)
            .expect("both directions run")
    };
    let (fs, sf) = (get(Direction::FlsToSss), get(Direction::SssToFls));
    vec![
        short_spans(fs),
        long_spans(fs),
        small_areas(sf),
        near_minimum_range(fs, sf),
    ]
}

/// Finding 1: fls→sss spans are short with all angles 0 or 180° (the corners of scenario 7's grid).
fn short_spans(fs: &DirectionRun) -> Finding {
    let grid = fs.values(7, None);
    let (p10, p90) = (quantile(&grid, 0.1), quantile(&grid, 0.9));
    let over = lattice_words(fs, 7);
    let corners: Vec<(f64, f64, f64)> = [(0.0, 0.0), (0.0, 180.0), (180.0, 0.0), (180.0, 180.0)]
        .iter()
        .filter_map(|&(r, p)| fs.at(7, None, [r, p, 0.0]).map(|v| (r, p, v)))
        .collect();
    let mut ev = format!(
        "Scenario 7 (roll × pitch, yaw 0): 10th percentile of the span over the grid{over} \
         {p10:.4} m, 90th {p90:.4} m.\n\n| roll | pitch | span (m) |\n|---|---|---|\n"
    );
    for (r, p, v) in &corners {
        let _ = writeln!(ev, "| {r} | {p} | {v:.6} |");
    }
    Finding {
        claim: "fls→sss: range spans are short when all angles are 0 or 180°",
        holds: !corners.is_empty() && corners.iter().all(|c| c.2 <= p10),
        evidence: ev,
    }
}

/// Finding 2: fls→sss spans are long for roll 0° or 180° with pitch 90°.
fn long_spans(fs: &DirectionRun) -> Finding {
    let grid = fs.values(7, None);
    let p90 = quantile(&grid, 0.9);
    let long: Vec<(f64, f64)> = [0.0, 180.0]
        .iter()
        .filter_map(|&r| fs.at(7, None, [r, 90.0, 0.0]).map(|v| (r, v)))
        .collect();
    let max = grid.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let over = lattice_words(fs, 7);
    let mut ev = format!(
        "Scenario 7 (roll × pitch): largest span over the grid{over} {max:.4} m, 90th \
         percentile {p90:.4} m.\n\n| roll | pitch | span (m) |\n|---|---|---|\n"
    );
    for (r, v) in &long {
        let _ = writeln!(ev, "| {r} | 90 | {v:.6} |");
    }
    Finding {
        claim: "fls→sss: range spans are long for roll 0° or 180° with pitch 90°",
        holds: long.len() == 2 && long.iter().all(|l| l.1 >= p90),
        evidence: ev,
    }
}

/// Finding 3: sss→fls areas are smallest for roll 90° with pitch and yaw at 0 or 180°.
fn small_areas(sf: &DirectionRun) -> Finding {
    let rp = sf.values(7, None);
    let yr = sf.values(9, None);
    let (rp10, yr10) = (quantile(&rp, 0.1), quantile(&yr, 0.1));
    let (o7, o9) = (lattice_words(sf, 7), lattice_words(sf, 9));
    let mut ev = format!(
        "10th percentile of the area: scenario 7 (roll × pitch){o7} {rp10:.6} m², scenario 9 \
         (yaw × roll){o9} {yr10:.6} m².\n\n| scenario | roll | pitch | yaw | area (m²) |\n|---|---|---|---|---|\n"
    );
    let mut all_small = true;
    let mut seen = 0;
    for (s, angles, p10) in [
        (7, [90.0, 0.0, 0.0], rp10),
        (7, [90.0, 180.0, 0.0], rp10),
        (9, [90.0, 0.0, 0.0], yr10),
        (9, [90.0, 0.0, 180.0], yr10),
    ] {
        if let Some(v) = sf.at(s, None, angles) {
            seen += 1;
            all_small &= v <= p10;
            let _ = writeln!(
                ev,
                "| {s} | {} | {} | {} | {v:.6} |",
                angles[0], angles[1], angles[2]
            );
        }
    }
    Finding {
        claim: "sss→fls: projection areas are smallest for roll 90° with pitch and yaw at 0 or 180°",
        holds: seen == 4 && all_small,
        evidence: ev,
    }
}

/// Finding 4: both metrics shrink near the minimum range of both sonars.
fn near_minimum_range(fs: &DirectionRun, sf: &DirectionRun) -> Finding {
    // 4. Both shrink when the feature is near the minimum range of both sonars: scenario 7's
    // grid with both features at NEAR_FRACTION of r_max against the same grid at 0.5 r_max.
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let mut ev = format!(
        "Mean over scenario 7's roll × pitch grid with both features at {NEAR_FRACTION} of their \
         sonar's maximum range, against the same grid at 0.5 (scenario 7 itself):\n\n\
         | direction | metric | mean, both near | mean, both at 0.5 |\n|---|---|---|---|\n"
    );
    let mut shrinks = true;
    for run in [fs, sf] {
        let half = run.grid(7).map_or(f64::NAN, super::Grid::mean);
        let near = run.near_both.mean();
        shrinks &= near < half;
        let _ = writeln!(
            ev,
            "| {} | {} | {near:.6} | {half:.6} |",
            run.direction.stem(),
            run.direction.metric_label()
        );
    }
    ev.push_str(
        "\nWith one feature distance moved at a time (scenarios 1–3 move it in sonar 2, 4–6 in \
         sonar 1), the mean over the swept angle at f = 0.1 and f = 0.9:\n\n\
         | direction | metric | scenario | mean at f = 0.1 | mean at f = 0.9 |\n|---|---|---|---|---|\n",
    );
    for run in [fs, sf] {
        for s in 1..=6u8 {
            let (lo, hi) = (mean(&run.values(s, Some(0.1))), mean(&run.values(s, Some(0.9))));
            let _ = writeln!(
                ev,
                "| {} | {} | {s} | {lo:.6} | {hi:.6} |",
                run.direction.stem(),
                run.direction.metric_label()
            );
        }
    }
    Finding {
        claim: "both metrics shrink when the feature is near the minimum range of both sonars",
        holds: shrinks,
        evidence: ev,
    }
}

/// Returns `findings.md`: each finding, whether the numbers bear it out, and the numbers.
#[must_use]
pub fn findings_markdown(findings: &[Finding], angle_step: f64, sampling: Sampling) -> String {
    let mut md = String::from("# The paper's qualitative findings, checked\n\n");
    let sampling = match sampling {
        Sampling::Step(s) => format!("step sampling {s}°"),
        Sampling::Auto => format!(
            "the smooth version's sampling (`--step auto`: FLS arcs every {}°, SSS surfaces with \
             auto sampling)",
            super::SMOOTH_ARC_STEP
        ),
        Sampling::Exact => "exact arcs (`--step exact`: FLS arcs solved in closed form, SSS \
                            surfaces with auto sampling)"
            .to_string(),
    };
    let _ = writeln!(
        md,
        "Computed by `sonarproj paper` at an angle step of {angle_step}° with {sampling}. \
         \"Short\" means at or below the 10th percentile of the scenario's grid, \"long\" at or \
         above the 90th, \"smallest\" at or below the 10th percentile.\n"
    );
    for f in findings {
        let _ = writeln!(
            md,
            "## {}\n\n**{}**\n\n{}",
            f.claim,
            if f.holds { "Borne out." } else { "Not borne out." },
            f.evidence
        );
    }
    md
}
