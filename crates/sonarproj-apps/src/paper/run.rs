//! Runs the paper's scenarios a block of poses at a time and keeps what the figures and findings
//! need: every curve of scenarios 1–6, and for the grids of 7–9 their metric on a lattice of at
//! most [`LATTICE_ANGLES`] angles an axis, their sums and the poses the findings name. The
//! results of each block go to a sink (the CSV) and are dropped, so memory stays bounded at
//! every allowed angle step.

use std::io::Write;
use std::path::Path;

use super::{
    Direction, FRACTIONS, Finding, NEAR_FRACTION, ScenarioPose, angles, direction_sampling, distances,
    figures, findings, findings_markdown, run_poses, swept,
};
use crate::error::{Error, Result};
use sonarproj::local_precision::{LocalPrecision, default_sigma_range};
use sonarproj::projection::{Backend, Projection};
use sonarproj::sampling::Sampling;
use sonarproj::stream::Stop;

/// The most poses projected at once: whole rows of a scenario's grid.
const BLOCK_POSES: usize = 1 << 16;

/// The most swept angles an axis of a grid keeps for its heatmap and percentiles: every angle
/// down to 0.1° steps, every k-th below (0.1° apart at 0.01°).
pub const LATTICE_ANGLES: usize = 1801;

/// The swept angles at which a grid's metric is kept for the findings, on every axis.
const PROBE_ANGLES: [f64; 3] = [0.0, 90.0, 180.0];

/// Where [`project_direction`] sends each block: its poses and their projections.
pub type Sink<'a> = dyn FnMut(&[ScenarioPose], &[Projection]) -> Result<()> + 'a;

/// One curve of scenarios 1–6: the metric against the swept angle at one distance fraction.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Scenario 1–6.
    pub scenario: u8,
    /// The distance fraction f.
    pub fraction: f64,
    /// (swept angle in deg, metric), in the order of the angles.
    pub points: Vec<(f64, f64)>,
}

/// One grid of scenarios 7–9 (or scenario 7's grid with both features near), reduced.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Scenario 7–9.
    pub scenario: u8,
    /// Every `stride`-th swept angle of each axis is on the lattice (1 down to 0.1° steps).
    pub stride: usize,
    /// The lattice's angles (deg), the same on both swept axes.
    pub lattice: Vec<f64>,
    /// The metric on the lattice, the first swept angle outer.
    pub values: Vec<f64>,
    /// The sum of the metric over every pose of the grid, in order.
    pub sum: f64,
    /// The number of poses of the grid.
    pub count: u64,
    /// (angles in deg, metric) of the poses whose swept angles are each 0, 90 or 180°.
    pub probes: Vec<([f64; 3], f64)>,
}

impl Grid {
    /// Returns an empty grid of scenario `s` over the swept `angles`.
    fn new(s: u8, angles: &[f64]) -> Grid {
        let stride = lattice_stride(angles.len());
        Grid {
            scenario: s,
            stride,
            lattice: angles.iter().copied().step_by(stride).collect(),
            values: Vec::new(),
            sum: 0.0,
            count: 0,
            probes: Vec::new(),
        }
    }

    /// Adds the metric `v` of pose `p`, at indices `(i, j)` of its first and second swept angle.
    fn add(&mut self, i: usize, j: usize, p: &ScenarioPose, v: f64) {
        self.sum += v;
        self.count += 1;
        if i.is_multiple_of(self.stride) && j.is_multiple_of(self.stride) {
            self.values.push(v);
        }
        let axes = swept(self.scenario);
        if axes.iter().all(|&k| PROBE_ANGLES.contains(&p.angles[k])) {
            self.probes.push((p.angles, v));
        }
    }

    /// Returns the mean of the metric over every pose of the grid.
    #[must_use]
    #[expect(clippy::cast_precision_loss, reason = "a count of poses, far below 2^53")]
    pub fn mean(&self) -> f64 {
        self.sum / self.count.max(1) as f64
    }
}

/// Returns the stride that keeps at most [`LATTICE_ANGLES`] of `n` swept angles.
#[must_use]
pub fn lattice_stride(n: usize) -> usize {
    n.saturating_sub(1).div_ceil(LATTICE_ANGLES - 1).max(1)
}

/// One direction's results, reduced to what the figures and findings need.
#[derive(Clone, Debug)]
pub struct DirectionRun {
    /// The direction.
    pub direction: Direction,
    /// The sampling it ran at ([`direction_sampling`] of the one asked for).
    pub sampling: Sampling,
    /// The number of poses run (scenarios 1–9).
    pub poses: u64,
    /// The samples over those poses.
    pub samples: u64,
    /// Scenarios 1–6, each fraction's curve, in order.
    pub lines: Vec<Line>,
    /// Scenarios 7–9, in order.
    pub grids: Vec<Grid>,
    /// Scenario 7's grid again, both features at [`NEAR_FRACTION`] of their sonar's maximum
    /// range. It serves the minimum-range finding and is not one of the paper's nine.
    pub near_both: Grid,
}

impl DirectionRun {
    /// Returns the metric at `scenario`, `fraction` and angles (deg), if it was kept: any pose
    /// of scenarios 1–6, and those of 7–9 whose swept angles are each 0, 90 or 180°.
    #[must_use]
    pub fn at(&self, scenario: u8, fraction: Option<f64>, angles: [f64; 3]) -> Option<f64> {
        if let Some(g) = self.grid(scenario) {
            return g.probes.iter().find(|(a, _)| *a == angles).map(|p| p.1);
        }
        let line = self.line(scenario, fraction?)?;
        let axis = swept(scenario)[0];
        let fixed = (0..3).all(|k| k == axis || angles[k] == 0.0);
        line.points
            .iter()
            .find(|(x, _)| fixed && *x == angles[axis])
            .map(|p| p.1)
    }

    /// Returns the metric over the poses of `scenario` and `fraction`: every pose of scenarios
    /// 1–6, the lattice of 7–9.
    #[must_use]
    pub fn values(&self, scenario: u8, fraction: Option<f64>) -> Vec<f64> {
        if let Some(g) = self.grid(scenario) {
            return g.values.clone();
        }
        fraction
            .and_then(|f| self.line(scenario, f))
            .map(|l| l.points.iter().map(|p| p.1).collect())
            .unwrap_or_default()
    }

    /// Returns the grid of `scenario` (7–9).
    #[must_use]
    pub fn grid(&self, scenario: u8) -> Option<&Grid> {
        self.grids.iter().find(|g| g.scenario == scenario)
    }

    /// Returns the curve of `scenario` (1–6) at `fraction`.
    #[must_use]
    pub fn line(&self, scenario: u8, fraction: f64) -> Option<&Line> {
        self.lines
            .iter()
            .find(|l| l.scenario == scenario && l.fraction == fraction)
    }
}

/// Runs every pose of `direction`'s scenarios 1–9 and scenario 7's grid with both features
/// near, a block at a time, and returns them reduced. `sink` receives each block of scenarios
/// 1–9 in order (poses and their projections, local precision included), never the near grid.
///
/// # Errors
/// As [`angles`] for `angle_step`, [`Backend::project_columns`] (with `stop`), and `sink`'s.
pub fn project_direction(
    backend: &Backend,
    direction: Direction,
    angle_step: f64,
    sampling: Sampling,
    stop: Stop<'_>,
    sink: &mut Sink<'_>,
) -> Result<DirectionRun> {
    in_blocks(backend, direction, angle_step, sampling, stop, BLOCK_POSES, sink)
}

/// Returns [`project_direction`]'s run, projecting at most `block` poses at once (whole rows
/// of a grid, one row at least).
fn in_blocks(
    backend: &Backend,
    direction: Direction,
    angle_step: f64,
    sampling: Sampling,
    stop: Stop<'_>,
    block: usize,
    sink: &mut Sink<'_>,
) -> Result<DirectionRun> {
    let a = angles(angle_step)?;
    let sampling = direction_sampling(direction, sampling);
    let (source, target) = direction.sonars();
    let mut run = DirectionRun {
        direction,
        sampling,
        poses: 0,
        samples: 0,
        lines: Vec::new(),
        grids: Vec::new(),
        near_both: Grid::new(7, &a),
    };
    let at = |p: &ScenarioPose| distances(p, &source, &target);
    // Scenarios 1–6: the curves of as many fractions as a block holds go as one grid (a call
    // of 181 poses leaves cores idle: 6 µs a pose, against 2 µs in a grid's call).
    let per_call = (block / a.len()).clamp(1, FRACTIONS.len());
    for s in 1..=6 {
        for fractions in FRACTIONS.chunks(per_call) {
            let poses: Vec<ScenarioPose> = fractions
                .iter()
                .flat_map(|&f| run_poses(s, Some(f), &a, 0..1))
                .collect();
            let results = project_block(backend, direction, &poses, sampling, stop, &at)?;
            let curves = poses.chunks(a.len()).zip(results.chunks(a.len()));
            for (&fraction, (poses, results)) in fractions.iter().zip(curves) {
                sink(poses, results)?;
                let mut line = Line {
                    scenario: s,
                    fraction,
                    points: Vec::with_capacity(a.len()),
                };
                for (p, r) in poses.iter().zip(results) {
                    run.poses += 1;
                    run.samples += r.metrics.total;
                    line.points
                        .push((p.angles[swept(s)[0]], direction.metric(&r.metrics)));
                }
                run.lines.push(line);
            }
        }
    }
    for s in 7..=9 {
        let mut grid = Grid::new(s, &a);
        each_block(
            backend,
            direction,
            (s, block),
            &a,
            sampling,
            stop,
            &at,
            |r0, poses, results| {
                sink(poses, results)?;
                for (k, (p, r)) in poses.iter().zip(results).enumerate() {
                    run.poses += 1;
                    run.samples += r.metrics.total;
                    grid.add(r0 + k / a.len(), k % a.len(), p, direction.metric(&r.metrics));
                }
                Ok(())
            },
        )?;
        run.grids.push(grid);
    }
    let near = (NEAR_FRACTION * source.range_max, NEAR_FRACTION * target.range_max);
    let mut near_both = Grid::new(7, &a);
    each_block(
        backend,
        direction,
        (7, block),
        &a,
        sampling,
        stop,
        &|_| near,
        |r0, poses, results| {
            for (k, (p, r)) in poses.iter().zip(results).enumerate() {
                near_both.add(r0 + k / a.len(), k % a.len(), p, direction.metric(&r.metrics));
            }
            Ok(())
        },
    )?;
    run.near_both = near_both;
    Ok(run)
}

/// Projects the poses of grid scenario `s` (7–9) over the swept angles `a`, at most `block`
/// poses (whole rows, one at least) at a time, with feature distances from `at`. Calls
/// `each(first row, poses, projections)` per block, in order.
#[expect(clippy::too_many_arguments, reason = "one run of a scenario, named in full")]
fn each_block(
    backend: &Backend,
    direction: Direction,
    (s, block): (u8, usize),
    a: &[f64],
    sampling: Sampling,
    stop: Stop<'_>,
    at: &dyn Fn(&ScenarioPose) -> (f64, f64),
    mut each: impl FnMut(usize, &[ScenarioPose], &[Projection]) -> Result<()>,
) -> Result<()> {
    let (rows, per_block) = (a.len(), (block / a.len()).max(1));
    for r0 in (0..rows).step_by(per_block) {
        let poses = run_poses(s, None, a, r0..(r0 + per_block).min(rows));
        let results = project_block(backend, direction, &poses, sampling, stop, at)?;
        each(r0, &poses, &results)?;
    }
    Ok(())
}

/// Returns the projections of `poses` (one scenario, whole rows of its angles, one fraction or
/// several) for `direction`, in order, with feature distances from `at`. They run as a grid
/// decoded where the work runs ([`Backend::project_columns`]): its axes are the values the
/// poses take of each distance and angle. Results, local precision included, match the batch
/// items' ([`super::batch`]).
fn project_block(
    backend: &Backend,
    direction: Direction,
    poses: &[ScenarioPose],
    sampling: Sampling,
    stop: Stop<'_>,
    at: &dyn Fn(&ScenarioPose) -> (f64, f64),
) -> Result<Vec<Projection>> {
    if poses.is_empty() {
        return Ok(Vec::new());
    }
    let (source, target) = direction.sonars();
    let sigma = default_sigma_range(&source, &target);
    let mut columns = sonarproj::MetricColumns::default();
    let (mut rpe, mut sig) = (Vec::new(), Vec::new());
    let optional = |v: f64| Some(v).filter(|v| !v.is_nan());
    // A pose's varying values: its two feature distances, roll, pitch and yaw.
    let key = |p: &ScenarioPose| {
        let (d1, d2) = at(p);
        [d1, d2, p.angles[0], p.angles[1], p.angles[2]]
    };
    let keys: Vec<[f64; 5]> = poses.iter().map(key).collect();
    // Each over the values the block takes (sorted).
    let values: [Vec<f64>; 5] = std::array::from_fn(|k| {
        let mut v: Vec<f64> = keys.iter().map(|key| key[k]).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    });
    let [d1, d2, roll, pitch, yaw] = values.clone();
    let axes = [
        d1,
        vec![0.0],
        vec![0.0],
        d2,
        vec![0.0],
        vec![0.0],
        roll,
        pitch,
        yaw,
    ];
    let grid = sonarproj::PoseGrid::new(axes, true, &source)?;
    let sweep = sonarproj::PoseSweep {
        source: source.clone(),
        target,
        sampling,
        area_grid: sonarproj::PAPER_AREA_GRID,
        poses: sonarproj::PoseSource::Grid(&grid),
    };
    backend.project_columns(&sweep, 0..grid.len(), &mut columns, stop)?;
    sweep.local_precision_columns(0..grid.len(), sigma, &mut rpe, &mut sig)?;
    // A pose's place in the grid (scenario 9 sweeps yaw outside roll, the grid roll first).
    Ok(keys
        .iter()
        .map(|key| {
            let index = (0..5).fold(0, |i, k| {
                i * values[k].len() + values[k].partition_point(|&v| v < key[k])
            });
            Projection {
                metrics: columns.get(index),
                occupancy: None,
                cells: None,
                local: LocalPrecision {
                    range_per_elevation: optional(rpe[index]),
                    sigma_elevation: optional(sig[index]),
                },
            }
        })
        .collect())
}

/// Returns both directions run on `backend` at `angle_step`, reduced, with `sampling` mapped
/// per direction by [`direction_sampling`].
///
/// # Errors
/// As [`project_direction`].
pub fn run(backend: &Backend, angle_step: f64, sampling: Sampling) -> Result<Vec<DirectionRun>> {
    run_until(backend, angle_step, sampling, Stop::NEVER)
}

/// Returns both directions as [`run`] does, ending with [`sonarproj::Error::Stopped`] once
/// `stop` is set (polled while each block is projected).
///
/// # Errors
/// As [`run`], and [`sonarproj::Error::Stopped`].
pub fn run_until(
    backend: &Backend,
    angle_step: f64,
    sampling: Sampling,
    stop: Stop<'_>,
) -> Result<Vec<DirectionRun>> {
    Direction::both()
        .into_iter()
        .map(|d| project_direction(backend, d, angle_step, sampling, stop, &mut |_, _| Ok(())))
        .collect()
}

/// Runs both directions on `backend` into directory `out` and returns them, reduced, with the
/// findings. Files: `fls-to-sss.csv` and `sss-to-fls.csv` (scenario, fraction, roll, pitch,
/// yaw, then the metric columns), `*-lines.png` (scenarios 1–6), `*-heatmaps.png` (7–9) and
/// `findings.md`. The CSVs are written as the poses run, each whole or not at all: a run that
/// fails or is stopped leaves neither, nor `out` when it made it. `field` names `out` in
/// errors. The CLI's `paper` and Python's `paper()` both end here.
///
/// # Errors
/// As [`angles`] for `angle_step`, [`crate::report::check_output_dir`]'s for `out`, and
/// [`run_until`]'s. Errors of writing files and drawing figures.
pub fn run_to(
    out: &Path,
    field: &str,
    backend: &Backend,
    angle_step: f64,
    sampling: Sampling,
    stop: Stop<'_>,
) -> Result<(Vec<DirectionRun>, Vec<Finding>)> {
    use crate::report::{check_output_dir, write_atomic};
    angles(angle_step)?;
    check_output_dir(out, field)?;
    let [first, second] = Direction::both();
    let csv = |d: Direction| out.join(format!("{}.csv", d.stem()));
    // A direction's rows go to its file from a thread of their own, while the next block is
    // projected: at most two blocks of rows queued, so four in memory (one being written, one
    // being formatted).
    let csv_run = |d: Direction, w: &mut (dyn Write + Send)| {
        write_header(w)?;
        std::thread::scope(|scope| {
            let (rows, to_write) = std::sync::mpsc::sync_channel::<Vec<String>>(2);
            let writer = std::thread::Builder::new()
                .name("paper-csv".into())
                .spawn_scoped(scope, move || {
                    to_write
                        .iter()
                        .try_for_each(|pieces| pieces.iter().try_for_each(|p| w.write_all(p.as_bytes())))
                        .map_err(csv_error)
                })
                .map_err(csv_error)?;
            let run = project_direction(backend, d, angle_step, sampling, stop, &mut |poses, results| {
                // A send fails only when the writer has stopped on an error, reported below.
                rows.send(format_block(poses, results))
                    .map_err(|_| csv_error("the writer stopped"))
            });
            drop(rows);
            let written = writer
                .join()
                .unwrap_or_else(|_| Err(csv_error("the writer panicked")));
            written.and(run)
        })
    };
    let mut runs = Vec::with_capacity(2);
    let mut found = Vec::new();
    // The second CSV, figures and findings are written inside the first CSV's write: a failure
    // anywhere leaves neither CSV.
    write_atomic(&csv(first), |w| {
        runs.push(csv_run(first, w)?);
        write_atomic(&csv(second), |w| {
            runs.push(csv_run(second, w)?);
            found = draw(out, &runs, angle_step, sampling)?;
            Ok(())
        })
    })?;
    Ok((runs, found))
}

/// The CSV's columns before the metrics.
const POSE_COLUMNS: [&str; 5] = ["scenario", "fraction", "roll", "pitch", "yaw"];

/// Writes the CSV's header.
fn write_header(w: &mut (dyn Write + Send)) -> Result<()> {
    let mut wtr = csv::Writer::from_writer(w);
    let header = POSE_COLUMNS.iter().chain(crate::io::METRIC_COLUMNS.iter());
    wtr.write_record(header).map_err(csv_error)?;
    wtr.flush().map_err(csv_error)
}

/// Writes one block of rows ([`format_block`]).
#[cfg(test)]
fn write_block(w: &mut (dyn Write + Send), poses: &[ScenarioPose], results: &[Projection]) -> Result<()> {
    format_block(poses, results)
        .iter()
        .try_for_each(|piece| w.write_all(piece.as_bytes()))
        .map_err(csv_error)
}

/// Returns one block of rows, formatted in parallel, in pieces. Every field is a number or
/// empty, which CSV never quotes, so each piece of rows is plain text written straight into a
/// string sized for it (a test holds the rows to the `csv` crate's).
fn format_block(poses: &[ScenarioPose], results: &[Projection]) -> Vec<String> {
    use rayon::prelude::*;
    use std::fmt::Write as _;
    /// Room for a typical row (at 1° they are 206 bytes on average, 226 at most); a longer one
    /// grows the string.
    const ROW_BYTES: usize = 256;
    poses
        .par_chunks(4096)
        .zip(results.par_chunks(4096))
        .map(|(poses, results)| {
            let mut rows = String::with_capacity(poses.len() * ROW_BYTES);
            for (p, r) in poses.iter().zip(results) {
                write!(rows, "{},", p.scenario).expect("a String takes every write");
                if let Some(f) = p.fraction {
                    write!(rows, "{f}").expect("a String takes every write");
                }
                for a in p.angles {
                    rows.push(',');
                    write!(rows, "{a}").expect("a String takes every write");
                }
                for k in 0..crate::io::METRIC_COLUMNS.len() {
                    rows.push(',');
                    crate::io::batch::push_metric_field(&mut rows, &r.metrics, &r.local, k);
                }
                rows.push('\n');
            }
            rows
        })
        .collect()
}

fn csv_error(e: impl std::fmt::Display) -> Error {
    Error::WriteOutput {
        path: "output".into(),
        message: e.to_string(),
    }
}

/// Draws both directions' figures into `out`, writes `findings.md` and returns the findings.
fn draw(out: &Path, runs: &[DirectionRun], angle_step: f64, sampling: Sampling) -> Result<Vec<Finding>> {
    use crate::report::{self, write_atomic};
    use rayon::prelude::*;
    runs.par_iter().try_for_each(|run| -> Result<()> {
        let stem = run.direction.stem();
        let (lines, heatmaps) = rayon::join(
            || report::figures::line_grid(&figures::lines(run), &out.join(format!("{stem}-lines.png"))),
            || report::figures::heatmaps(&figures::heatmaps(run), &out.join(format!("{stem}-heatmaps.png"))),
        );
        lines.and(heatmaps)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Returns the run of `direction` at 20° projected `block` poses at a time, with every
    /// row its sink received.
    fn rows(direction: Direction, block: usize) -> (DirectionRun, Vec<u8>) {
        let (run, csv, _) = rows_and_results(direction, block);
        (run, csv)
    }

    /// Returns [`rows`]'s run and rows, with the poses and projections the sink received.
    fn rows_and_results(
        direction: Direction,
        block: usize,
    ) -> (DirectionRun, Vec<u8>, Vec<(ScenarioPose, Projection)>) {
        let (mut csv, mut received) = (Vec::new(), Vec::new());
        let run = in_blocks(
            &Backend::CpuFast,
            direction,
            20.0,
            Sampling::Step(1.0),
            Stop::NEVER,
            block,
            &mut |poses, results| {
                received.extend(poses.iter().copied().zip(results.iter().cloned()));
                write_block(&mut csv, poses, results)
            },
        )
        .unwrap();
        (run, csv, received)
    }

    /// Blocks of one row (scenario 9's yaw-outside-roll order rebuilt in each) give the rows,
    /// reductions and findings of one block per grid.
    #[test]
    fn blocks_of_any_size_give_the_same_rows_and_reductions() {
        for direction in Direction::both() {
            let (whole, whole_csv) = rows(direction, BLOCK_POSES);
            let (split, split_csv) = rows(direction, 1);
            assert_eq!(whole_csv, split_csv, "{direction:?}");
            assert_eq!(whole.grids, split.grids);
            assert_eq!(whole.lines, split.lines);
            assert_eq!(whole.near_both, split.near_both);
            assert_eq!((whole.poses, whole.samples), (split.poses, split.samples));
            // 10 angles an axis: 6 scenarios × 9 fractions of 10, 3 grids of 100.
            assert_eq!(whole.poses, 6 * 9 * 10 + 3 * 100);
            assert_eq!(
                whole_csv.iter().filter(|&&b| b == b'\n').count() as u64,
                whole.poses
            );
        }
    }

    /// The rows are those the `csv` crate writes for the same fields: the poses' numbers and
    /// [`crate::io::metric_fields`], empty ones included.
    #[test]
    fn rows_are_the_csv_writers() {
        for direction in Direction::both() {
            let (_, csv, received) = rows_and_results(direction, BLOCK_POSES);
            let mut wtr = csv::Writer::from_writer(Vec::new());
            for (p, r) in &received {
                let mut fields = vec![
                    p.scenario.to_string(),
                    p.fraction.map(|f| f.to_string()).unwrap_or_default(),
                ];
                fields.extend(p.angles.iter().map(f64::to_string));
                fields.extend(crate::io::metric_fields(&r.metrics, &r.local));
                wtr.write_record(&fields).unwrap();
            }
            let expected = wtr.into_inner().unwrap();
            // Empty fields: the grids' fraction, and the local precision off its true point's view.
            assert!(received.iter().any(|(p, _)| p.fraction.is_none()));
            assert!(received.iter().any(|(_, r)| r.local.sigma_elevation.is_none()));
            assert_eq!(
                String::from_utf8(csv).unwrap(),
                String::from_utf8(expected).unwrap()
            );
        }
    }

    /// The lattice keeps every angle down to 0.1° steps and at most 1801 below, 0, 90 and 180°
    /// among them wherever the step divides 90°.
    #[test]
    fn the_lattice_is_bounded_and_keeps_the_round_angles() {
        for (step, stride) in [(90.0, 1), (1.0, 1), (0.1, 1), (0.09, 2), (0.05, 2), (0.01, 10)] {
            let a = angles(step).unwrap();
            let g = Grid::new(7, &a);
            assert_eq!(g.stride, stride, "{step}");
            assert!(g.lattice.len() <= LATTICE_ANGLES, "{step}");
            for round in [0.0, 90.0, 180.0] {
                assert!(g.lattice.contains(&round), "{step}: {round}");
            }
        }
        assert_eq!(lattice_stride(0), 1);
        assert_eq!(lattice_stride(1), 1);
        assert_eq!(lattice_stride(LATTICE_ANGLES + 1), 2);
    }
}
