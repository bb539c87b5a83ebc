//! The paper's simulations (see docs/paper.md): builds the poses, runs them on a backend, and checks
//! the paper's qualitative findings against the numbers. Both directions (fls→sss, sss→fls) use
//! the paper presets, a feature at azimuth and elevation 0 in both sonars, placement poses, and
//! nine scenarios of swept rotations and feature distances.

mod figures;
mod findings;

pub use findings::{Finding, findings, findings_markdown};

use crate::error::{Error, Result, finite};
use sonarproj::geometry::pose::{RelativePose, Rotation};
use sonarproj::geometry::sonar::{Sonar, SonarKind};
use sonarproj::local_precision::{LocalPrecision, default_sigma_range};
use sonarproj::metrics::{Metric, Metrics};
use sonarproj::projection::Backend;
use sonarproj::projection::{Batch, BatchItem, Projection};
use sonarproj::sampling::{Measurement, Sampling};
use sonarproj::stream::Stop;

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
                 18 001 angles per scenario, millions of poses held in memory)"
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

/// Returns every pose of scenarios 1–9 at angle step `step` (deg).
/// They are ordered by scenario, then fraction (1–6), then the first and second swept angle.
///
/// # Errors
/// As [`angles`].
pub fn scenario_poses(step: f64) -> Result<Vec<ScenarioPose>> {
    let a = angles(step)?;
    let mut out = Vec::new();
    for s in 1..=9u8 {
        let axes = swept(s);
        let fractions: Vec<Option<f64>> = if s <= 6 {
            FRACTIONS.iter().map(|&f| Some(f)).collect()
        } else {
            vec![None]
        };
        for fraction in fractions {
            if axes.len() == 1 {
                for &x in &a {
                    let mut angles = [0.0; 3];
                    angles[axes[0]] = x;
                    out.push(ScenarioPose {
                        scenario: s,
                        fraction,
                        angles,
                    });
                }
            } else {
                for &x in &a {
                    for &y in &a {
                        let mut angles = [0.0; 3];
                        angles[axes[0]] = x;
                        angles[axes[1]] = y;
                        out.push(ScenarioPose {
                            scenario: s,
                            fraction,
                            angles,
                        });
                    }
                }
            }
        }
    }
    Ok(out)
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

/// One direction's poses and results.
#[derive(Clone, Debug)]
pub struct DirectionRun {
    /// The direction.
    pub direction: Direction,
    /// The sampling it ran at ([`direction_sampling`] of the one asked for).
    pub sampling: Sampling,
    /// The poses, in order.
    pub poses: Vec<ScenarioPose>,
    /// Their projections, in order, each with the local precision at its feature's true point
    /// `(d1, 0, 0)` in sonar 1, for the default range error.
    pub results: Vec<Projection>,
    /// Scenario 7's grid again, both features at [`NEAR_FRACTION`] of their sonar's maximum
    /// range. It serves the minimum-range finding and is not one of the paper's nine.
    pub near_both: Vec<Projection>,
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

/// Returns both directions run on `backend` at `angle_step`, with `sampling` mapped per
/// direction by [`direction_sampling`].
///
/// # Errors
/// As [`scenario_poses`] and [`Backend::project`].
pub fn run(backend: &Backend, angle_step: f64, sampling: Sampling) -> Result<Vec<DirectionRun>> {
    run_until(backend, angle_step, sampling, Stop::NEVER)
}

/// Returns both directions as [`run`] does, ending with [`sonarproj::Error::Stopped`] once
/// `stop` is set (polled while each grid is projected).
///
/// # Errors
/// As [`run`], and [`sonarproj::Error::Stopped`].
pub fn run_until(
    backend: &Backend,
    angle_step: f64,
    sampling: Sampling,
    stop: Stop<'_>,
) -> Result<Vec<DirectionRun>> {
    let poses = scenario_poses(angle_step)?;
    let grid: Vec<ScenarioPose> = poses.iter().filter(|p| p.scenario == 7).copied().collect();
    Direction::both()
        .into_iter()
        .map(|direction| {
            let sampling = direction_sampling(direction, sampling);
            let (source, target) = direction.sonars();
            let results = project_grids(backend, direction, &poses, sampling, stop, |p| {
                distances(p, &source, &target)
            })?;
            let near = (NEAR_FRACTION * source.range_max, NEAR_FRACTION * target.range_max);
            let near_both = project_grids(backend, direction, &grid, sampling, stop, |_| near)?;
            Ok(DirectionRun {
                direction,
                sampling,
                poses: poses.clone(),
                results,
                near_both,
            })
        })
        .collect()
}

/// Returns the projections of `poses` for `direction`, in order, with feature distances from `at`.
/// Each run of one scenario and fraction is a grid decoded where the work runs
/// ([`Backend::project_columns`]). Results, local precision included, match the batch items'.
fn project_grids(
    backend: &Backend,
    direction: Direction,
    poses: &[ScenarioPose],
    sampling: Sampling,
    stop: Stop<'_>,
    at: impl Fn(&ScenarioPose) -> (f64, f64),
) -> Result<Vec<Projection>> {
    let (source, target) = direction.sonars();
    let sigma = default_sigma_range(&source, &target);
    let mut results = Vec::with_capacity(poses.len());
    let mut columns = sonarproj::MetricColumns::default();
    let (mut rpe, mut sig) = (Vec::new(), Vec::new());
    let optional = |v: f64| Some(v).filter(|v| !v.is_nan());
    for run in poses.chunk_by(|a, b| (a.scenario, a.fraction) == (b.scenario, b.fraction)) {
        let (d1, d2) = at(&run[0]);
        // Each rotation axis over the values the run takes (sorted), the distances fixed.
        let rotations: [Vec<f64>; 3] = std::array::from_fn(|k| {
            let mut v: Vec<f64> = run.iter().map(|p| p.angles[k]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        });
        let [roll, pitch, yaw] = rotations.clone();
        let axes = [
            vec![d1],
            vec![0.0],
            vec![0.0],
            vec![d2],
            vec![0.0],
            vec![0.0],
            roll,
            pitch,
            yaw,
        ];
        let grid = sonarproj::PoseGrid::new(axes, true, &source)?;
        let sweep = sonarproj::PoseSweep {
            source: source.clone(),
            target: target.clone(),
            sampling,
            area_grid: sonarproj::PAPER_AREA_GRID,
            poses: sonarproj::PoseSource::Grid(&grid),
        };
        backend.project_columns(&sweep, 0..grid.len(), &mut columns, stop)?;
        sweep.local_precision_columns(0..grid.len(), sigma, &mut rpe, &mut sig)?;
        // A pose's place in the grid (scenario 9 sweeps yaw outside roll, the grid roll first).
        for p in run {
            let index = (0..3).fold(0, |i, k| {
                let values = &rotations[k];
                i * values.len() + values.partition_point(|&v| v < p.angles[k])
            });
            results.push(Projection {
                metrics: columns.get(index),
                occupancy: None,
                cells: None,
                local: LocalPrecision {
                    range_per_elevation: optional(rpe[index]),
                    sigma_elevation: optional(sig[index]),
                },
            });
        }
    }
    Ok(results)
}

impl DirectionRun {
    /// Returns the metric at `scenario`, `fraction` and angles (deg), if that pose was run.
    #[must_use]
    pub fn at(&self, scenario: u8, fraction: Option<f64>, angles: [f64; 3]) -> Option<f64> {
        self.poses
            .iter()
            .zip(&self.results)
            .find(|(p, _)| p.scenario == scenario && p.fraction == fraction && p.angles == angles)
            .map(|(_, r)| self.direction.metric(&r.metrics))
    }

    /// Returns the metric over every pose of `scenario` and `fraction`.
    #[must_use]
    pub fn values(&self, scenario: u8, fraction: Option<f64>) -> Vec<f64> {
        self.poses
            .iter()
            .zip(&self.results)
            .filter(|(p, _)| p.scenario == scenario && p.fraction == fraction)
            .map(|(_, r)| self.direction.metric(&r.metrics))
            .collect()
    }
}

/// Writes the results of [`run`] into directory `out` and returns the findings.
/// Files: `fls-to-sss.csv` and `sss-to-fls.csv` (scenario, fraction, roll, pitch, yaw, then the
/// metric columns), `*-lines.png` (scenarios 1–6), `*-heatmaps.png` (7–9) and `findings.md`.
/// Each is written whole or not at all, both directions at once. `out` is made when missing, and
/// `field` names it in errors. The CLI's `paper` and Python's `paper()` both end here.
///
/// # Errors
/// As [`angles`] for `angle_step`, and [`crate::report::output_dir`]'s for `out`.
/// Errors of writing files and drawing figures.
pub fn write(
    out: &std::path::Path,
    field: &str,
    runs: &[DirectionRun],
    angle_step: f64,
    sampling: Sampling,
) -> Result<Vec<Finding>> {
    use crate::io::table::write_rows;
    use crate::io::{METRIC_COLUMNS, metric_fields};
    use crate::report::{self, output_dir, write_atomic};
    use rayon::prelude::*;

    let swept = angles(angle_step)?;
    output_dir(out, field)?;
    let header: Vec<String> = ["scenario", "fraction", "roll", "pitch", "yaw"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    runs.par_iter().try_for_each(|run| -> Result<()> {
        let stem = run.direction.stem();
        let write_csv = || {
            let rows = run.poses.iter().zip(&run.results).map(|(p, r)| {
                let mut fields = vec![
                    p.scenario.to_string(),
                    p.fraction.map(|f| f.to_string()).unwrap_or_default(),
                ];
                fields.extend(p.angles.iter().map(f64::to_string));
                (fields, metric_fields(&r.metrics, &r.local))
            });
            let csv = out.join(format!("{stem}.csv"));
            write_atomic(&csv, |w| write_rows(w, &header, &METRIC_COLUMNS, rows))
        };
        let (csv, (lines, heatmaps)) = rayon::join(write_csv, || {
            rayon::join(
                || report::figures::line_grid(&figures::lines(run), &out.join(format!("{stem}-lines.png"))),
                || {
                    report::figures::heatmaps(
                        &figures::heatmaps(run, &swept),
                        &out.join(format!("{stem}-heatmaps.png")),
                    )
                },
            )
        });
        csv.and(lines).and(heatmaps)
    })?;
    let found = findings(runs);
    let md = findings_markdown(&found, angle_step, sampling);
    write_atomic(&out.join("findings.md"), |w| {
        w.write_all(md.as_bytes()).map_err(|e| Error::WriteOutput {
            path: "findings.md".into(),
            message: e.to_string(),
        })
    })?;
    Ok(found)
}
