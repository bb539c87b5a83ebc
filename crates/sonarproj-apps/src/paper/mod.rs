//! The paper's simulations (see docs/paper.md): builds the poses, runs them on a backend, and checks
//! the paper's qualitative findings against the numbers. Both directions (fls→sss, sss→fls) use
//! the paper presets, a feature at azimuth and elevation 0 in both sonars, placement poses, and
//! nine scenarios of swept rotations and feature distances.

mod figures;
mod findings;
mod run;

pub use findings::{Finding, findings, findings_markdown};
pub use run::{
    DirectionRun, Grid, LATTICE_ANGLES, Line, Sink, lattice_stride, project_direction, run, run_to, run_until,
};

use crate::error::{Error, Result, finite};
use sonarproj::geometry::pose::{RelativePose, Rotation};
use sonarproj::geometry::sonar::{Sonar, SonarKind};
use sonarproj::metrics::{Metric, Metrics};
use sonarproj::projection::{Batch, BatchItem};
use sonarproj::sampling::{Measurement, Sampling};

/// The distance fractions of scenarios 1–6.
pub const FRACTIONS: [f64; 9] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9];

/// Which sonar measures and which one looks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// A paper-fls feature looked for in the paper-sss: range span is the metric.
    FlsToSss,
    /// A paper-sss feature looked for in the paper-fls: projection area is the metric.
    SssToFls,
}

impl Direction {
    /// Returns both directions.
    #[must_use]
    pub fn both() -> [Direction; 2] {
        [Direction::FlsToSss, Direction::SssToFls]
    }

    /// Returns the file stem: `fls-to-sss` or `sss-to-fls`.
    #[must_use]
    pub fn stem(self) -> &'static str {
        match self {
            Direction::FlsToSss => "fls-to-sss",
            Direction::SssToFls => "sss-to-fls",
        }
    }

    /// Returns (sonar 1, sonar 2): the paper presets.
    #[must_use]
    pub fn sonars(self) -> (Sonar, Sonar) {
        let (a, b) = match self {
            Direction::FlsToSss => ("paper-fls", "paper-sss"),
            Direction::SssToFls => ("paper-sss", "paper-fls"),
        };
        (
            Sonar::preset(a).expect("preset"),
            Sonar::preset(b).expect("preset"),
        )
    }

    /// Returns the metric the paper plots for this direction: the range span for an SSS target,
    /// the projection area (the authors' 0.08 m grid) for an FLS target.
    #[must_use]
    pub fn plotted(self) -> (Metric, SonarKind) {
        match self {
            Direction::FlsToSss => (Metric::Span, SonarKind::Sss),
            Direction::SssToFls => (Metric::ProjectionArea, SonarKind::Fls),
        }
    }

    /// Returns the value of the plotted metric in `m` (both are numbers, never empty).
    #[must_use]
    pub fn metric(self, m: &Metrics) -> f64 {
        m.get(self.plotted().0).as_f64().unwrap_or(0.0)
    }

    /// Returns the plotted metric's axis label, from the metric table.
    #[must_use]
    pub fn metric_label(self) -> &'static str {
        let (metric, kind) = self.plotted();
        metric.label(kind).unwrap_or(metric.name())
    }
}

/// One pose of a scenario.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScenarioPose {
    /// Scenario 1–9.
    pub scenario: u8,
    /// The distance fraction f (scenarios 1–6).
    pub fraction: Option<f64>,
    /// Roll, pitch, yaw (deg).
    pub angles: [f64; 3],
}

pub use crate::limits::MIN_ANGLE_STEP;

/// Returns the swept angles `0, s, 2s, …` up to 180° (deg).
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `--angle-step` unless in `[MIN_ANGLE_STEP, 180]`.
#[expect(
    clippy::cast_possible_truncation,
    reason = "a count of angle steps or a quantile index, finite and bounded by the checked input"
)]
pub fn angles(step: f64) -> Result<Vec<f64>> {
    finite(crate::params::ANGLE_STEP, step)?;
    if !(MIN_ANGLE_STEP..=180.0).contains(&step) {
        return Err(Error::invalid(
            crate::params::ANGLE_STEP,
            step,
            format!(
                "must be in [{MIN_ANGLE_STEP}, 180] degrees (a finer step makes more than \
                 18 001 angles per scenario, over a billion poses)"
            ),
        ));
    }
    let n = (180.0 / step + 1e-9).floor() as usize;
    Ok((0..=n).map(|i| i as f64 * step).collect())
}

/// Returns the swept angle indices (0 roll, 1 pitch, 2 yaw) of scenario `s` (1–9).
#[must_use]
pub fn swept(s: u8) -> &'static [usize] {
    match s {
        1 | 4 => &[0],
        2 | 5 => &[1],
        3 | 6 => &[2],
        7 => &[0, 1],
        8 => &[1, 2],
        _ => &[2, 0],
    }
}

/// Returns the runs of scenarios 1–9 in order: each scenario with its distance fraction
/// (scenarios 1–6 once per fraction of [`FRACTIONS`], 7–9 once without).
pub fn scenario_runs() -> impl Iterator<Item = (u8, Option<f64>)> {
    (1..=9u8).flat_map(|s| {
        let fractions: Vec<Option<f64>> = if s <= 6 {
            FRACTIONS.iter().map(|&f| Some(f)).collect()
        } else {
            vec![None]
        };
        fractions.into_iter().map(move |f| (s, f))
    })
}

/// Returns the poses of scenario `s` at `fraction` whose first swept angle is `angles[rows]`
/// (every one for a scenario with one swept angle), in order: the first swept angle outer.
#[must_use]
pub fn run_poses(
    s: u8,
    fraction: Option<f64>,
    angles: &[f64],
    rows: std::ops::Range<usize>,
) -> Vec<ScenarioPose> {
    let axes = swept(s);
    let at = |x: f64, y: Option<f64>| {
        let mut a = [0.0; 3];
        a[axes[0]] = x;
        if let Some(y) = y {
            a[axes[1]] = y;
        }
        ScenarioPose {
            scenario: s,
            fraction,
            angles: a,
        }
    };
    if axes.len() == 1 {
        angles.iter().map(|&x| at(x, None)).collect()
    } else {
        angles[rows]
            .iter()
            .flat_map(|&x| angles.iter().map(move |&y| at(x, Some(y))))
            .collect()
    }
}

/// Returns every pose of scenarios 1–9 at angle step `step` (deg), in memory: for tests and
/// small steps (the paper's run itself goes a block of poses at a time).
/// They are ordered by scenario, then fraction (1–6), then the first and second swept angle.
///
/// # Errors
/// As [`angles`].
pub fn scenario_poses(step: f64) -> Result<Vec<ScenarioPose>> {
    let a = angles(step)?;
    Ok(scenario_runs()
        .flat_map(|(s, f)| run_poses(s, f, &a, 0..a.len()))
        .collect())
}

/// Returns the feature distances `(in sonar 1, in sonar 2)` (m) of a scenario pose.
#[must_use]
pub fn distances(p: &ScenarioPose, source: &Sonar, target: &Sonar) -> (f64, f64) {
    let f = p.fraction.unwrap_or(0.5);
    match p.scenario {
        1..=3 => (0.5 * source.range_max, f * target.range_max),
        4..=6 => (f * source.range_max, 0.5 * target.range_max),
        _ => (0.5 * source.range_max, 0.5 * target.range_max),
    }
}

/// Returns the batch of `poses` for `direction`: placement poses of a feature at azimuth and
/// elevation 0 in both sonars.
///
/// # Errors
/// Invalid poses (none for angles from [`angles`]).
pub fn batch(direction: Direction, poses: &[ScenarioPose], sampling: Sampling) -> Result<Batch> {
    let (source, target) = direction.sonars();
    batch_at(direction, poses, sampling, |p| distances(p, &source, &target))
}

/// Returns the batch of `poses` for `direction`, with feature distances (m) from `at`.
fn batch_at(
    direction: Direction,
    poses: &[ScenarioPose],
    sampling: Sampling,
    at: impl Fn(&ScenarioPose) -> (f64, f64),
) -> Result<Batch> {
    let (source, target) = direction.sonars();
    let items = poses
        .iter()
        .map(|p| {
            let (d1, d2) = at(p);
            let [roll, pitch, yaw] = p.angles;
            let pose = RelativePose::placement(
                Rotation::RollPitchYaw { roll, pitch, yaw },
                [d1, 0.0, 0.0],
                [d2, 0.0, 0.0],
            )?;
            Ok(BatchItem {
                true_point: None,
                measurement: Measurement::of(&source, d1, 0.0)?,
                pose,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Batch {
        sigma_range: None,
        source,
        target,
        sampling,
        area_grid: sonarproj::PAPER_AREA_GRID,
        items,
    })
}

/// The distance fraction taken as "near the minimum range" of both sonars.
pub const NEAR_FRACTION: f64 = 0.1;

/// The sampling step (deg) of the published code, and `paper`'s default.
pub const PUBLISHED_STEP: f64 = 0.1;

/// The arc step (deg) of `paper --step auto`: a hundred times the published code's density.
/// A span's steps come from one arc sample at a time entering sonar 2's view, so they shrink
/// with the step. At 0.001° they fall below a pixel of the figures.
pub const SMOOTH_ARC_STEP: f64 = 0.001;

/// Returns the sampling `direction` runs at when the command asks for `sampling`.
/// A step stays as given. `auto` samples FLS arcs every [`SMOOTH_ARC_STEP`] and SSS surfaces at
/// the engine's auto sampling. The projection area counts 8 cm cells, so its curves keep the
/// cells' steps anyway; denser samples only fill the cells the surface really crosses. `exact`
/// solves FLS arcs exactly and samples SSS surfaces, which have no exact mode, at the published
/// code's [`PUBLISHED_STEP`] (`auto` would take tens of times longer on them).
#[must_use]
pub fn direction_sampling(direction: Direction, sampling: Sampling) -> Sampling {
    match (sampling, direction) {
        (Sampling::Auto, Direction::FlsToSss) => Sampling::Step(SMOOTH_ARC_STEP),
        (Sampling::Exact, Direction::SssToFls) => Sampling::Step(PUBLISHED_STEP),
        (s, _) => s,
    }
}
