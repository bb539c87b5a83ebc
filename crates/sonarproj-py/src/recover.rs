//! `sonarproj.recover`: the lost coordinate of one correspondence, or of arrays of them.

use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use sonarproj::recovery::{self, Observation, Recovery, Sigmas};

use crate::arrays::slices;
use crate::errors;
use crate::pose::PyPose;
use crate::sonar::PySonar;
use sonarproj::RelativePose;

/// Returns the observation of `range` and `azimuth` (NaN: none, for a sidescan).
fn observation(range: f64, azimuth: f64) -> Observation {
    Observation {
        range,
        azimuth: (!azimuth.is_nan()).then_some(azimuth),
    }
}

/// Returns the sigmas when either is given (the other 0).
fn sigmas(range: Option<f64>, azimuth: Option<f64>) -> Option<Sigmas> {
    (range.is_some() || azimuth.is_some()).then(|| Sigmas {
        range: range.unwrap_or(0.0),
        azimuth: azimuth.unwrap_or(0.0),
    })
}

/// Returns the recovery of one correspondence as the command line's JSON (candidates, flags,
/// curve).
#[pyfunction]
#[pyo3(signature = (first, second, pose, first_obs, second_obs, sigma_range, sigma_azimuth, curve_step))]
#[expect(clippy::too_many_arguments, reason = "the Python function's parameters")]
pub(crate) fn recover_one(
    first: &PySonar,
    second: &PySonar,
    pose: &PyPose,
    first_obs: (f64, f64),
    second_obs: (f64, f64),
    sigma_range: Option<f64>,
    sigma_azimuth: Option<f64>,
    curve_step: f64,
) -> PyResult<String> {
    let r = recovery::recover(
        &first.inner,
        &second.inner,
        &pose.inner,
        observation(first_obs.0, first_obs.1),
        observation(second_obs.0, second_obs.1),
        sigmas(sigma_range, sigma_azimuth),
        curve_step,
    )
    .map_err(errors::engine)?;
    serde_json::to_string(&r).map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
}

/// The columns of `recover_columns`' input, in order.
const NAMES: [&str; 4] = ["first_range", "first_azimuth", "second_range", "second_azimuth"];

/// Rows recovered between two checks for Ctrl-C: a few tens of milliseconds on one core.
const RECOVER_CHUNK_ROWS: usize = 16_384;

/// Returns, per correspondence of the columns, the number of candidates, the best one (NaN
/// where there is none), the curve length (sidescan pairs) and the flags. `poses` holds one
/// pose for every correspondence, or one per correspondence.
#[pyfunction]
#[pyo3(signature = (first, second, poses, columns, sigma_range, sigma_azimuth))]
pub(crate) fn recover_columns<'py>(
    py: Python<'py>,
    first: &PySonar,
    second: &PySonar,
    poses: Vec<PyRef<'py, PyPose>>,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    sigma_range: Option<f64>,
    sigma_azimuth: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let (cols, len) = slices(&NAMES, &columns)?;
    let poses: Vec<RelativePose> = poses.iter().map(|p| p.inner).collect();
    if poses.len() != 1 && poses.len() != len {
        return Err(errors::input(
            "pose",
            format!(
                "{} poses given for {len} correspondences: give one pose, or one per correspondence",
                poses.len()
            ),
        ));
    }
    let pose_of = |k: usize| &poses[if poses.len() == 1 { 0 } else { k }];
    let s = sigmas(sigma_range, sigma_azimuth);
    // Chunks of rows run on all cores without the GIL. Ctrl-C is watched while a chunk runs,
    // and each row asks whether it was pressed (a row can take milliseconds).
    let mut results: Vec<Recovery> = Vec::with_capacity(len);
    let mut start = 0;
    while start < len {
        let end = (start + RECOVER_CHUNK_ROWS).min(len);
        let part = crate::runtime::detach_watching(py, |stop| {
            (start..end)
                .into_par_iter()
                .map(|k| {
                    if stop.load(std::sync::atomic::Ordering::Relaxed) {
                        return Err(sonarproj::Error::Stopped);
                    }
                    recovery::recover(
                        &first.inner,
                        &second.inner,
                        pose_of(k),
                        observation(cols[0][k], cols[1][k]),
                        observation(cols[2][k], cols[3][k]),
                        s,
                        recovery::DEFAULT_CURVE_STEP,
                    )
                    .map_err(|e| e.in_context(format!("row {k}")))
                })
                .collect::<Vec<_>>()
                // In row order, so the error is the first bad row's whatever the threads did.
                .into_iter()
                .collect::<sonarproj::Result<Vec<_>>>()
        })?
        .map_err(errors::engine)?;
        results.extend(part);
        start = end;
    }
    let dict = PyDict::new(py);
    let count: Vec<i64> = results
        .iter()
        .map(|r| i64::try_from(r.candidates.len()).unwrap_or(i64::MAX))
        .collect();
    dict.set_item("candidates", count.into_pyarray(py))?;
    // The best candidate, unless a sidescan pair gave a curve.
    let best = |r: &Recovery| r.curve.is_none().then(|| r.candidates.first()).flatten().cloned();
    let bests: Vec<_> = results.iter().map(best).collect();
    let in_view: Vec<bool> = bests
        .iter()
        .map(|b| b.as_ref().is_some_and(|c| c.in_view))
        .collect();
    dict.set_item("in_view", in_view.into_pyarray(py))?;
    let nan = f64::NAN;
    type Pick = fn(&recovery::Candidate) -> f64;
    let picks: [(&str, Pick); 16] = [
        ("x_first", |c| c.point_first[0]),
        ("y_first", |c| c.point_first[1]),
        ("z_first", |c| c.point_first[2]),
        ("x_second", |c| c.point_second[0]),
        ("y_second", |c| c.point_second[1]),
        ("z_second", |c| c.point_second[2]),
        ("range_first", |c| c.first[0]),
        ("azimuth_first", |c| c.first[1]),
        ("elevation_first", |c| c.first[2]),
        ("range_second", |c| c.second[0]),
        ("azimuth_second", |c| c.second[1]),
        ("elevation_second", |c| c.second[2]),
        ("range_per_elevation", |c| {
            c.range_per_elevation.unwrap_or(f64::NAN)
        }),
        ("sigma_elevation", |c| c.sigma_elevation.unwrap_or(f64::NAN)),
        ("azimuth_residual", |c| c.azimuth_residual.unwrap_or(f64::NAN)),
        ("consistent", |c| {
            c.consistent.map_or(f64::NAN, |b| if b { 1.0 } else { 0.0 })
        }),
    ];
    for (name, pick) in picks {
        let v: Vec<f64> = bests.iter().map(|b| b.as_ref().map_or(nan, pick)).collect();
        dict.set_item(name, v.into_pyarray(py))?;
    }
    let length: Vec<f64> = results
        .iter()
        .map(|r| r.curve.as_ref().map_or(nan, |c| c.length))
        .collect();
    dict.set_item("curve_length", length.into_pyarray(py))?;
    let flags: Vec<String> = results
        .iter()
        .map(|r| r.flags.iter().map(|f| f.name()).collect::<Vec<_>>().join(";"))
        .collect();
    dict.set_item("flags", flags)?;
    Ok(dict)
}
