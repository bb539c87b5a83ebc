//! `sonarproj.batch` and `sonarproj.project`: projections from numpy columns and from one pose.

use std::time::Instant;

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sonarproj::metrics::Metrics;
use sonarproj::{Backend, Batch, BatchItem, Measurement, Output, Sampling, SonarKind};
use sonarproj_apps::io::batch::batch_item;

use crate::arrays::{metric_dict, slices};
use crate::pose::PyPose;
use crate::sonar::PySonar;
use crate::{backend, errors};

/// Poses projected per call of the engine: the GIL is taken back and Ctrl-C looked for between
/// chunks (about a second of work at 0.1° sampling on two cores).
const CHUNK_POSES: usize = 65_536;

/// The columns `batch_columns` takes, in order: the feature's true point, the rotation, then
/// the placement or the translation.
const PLACE_NAMES: [&str; 9] = [
    "range",
    "azimuth",
    "elevation",
    "roll",
    "pitch",
    "yaw",
    "place_range",
    "place_azimuth",
    "place_elevation",
];
const TRANSLATION_NAMES: [&str; 9] = [
    "range",
    "azimuth",
    "elevation",
    "roll",
    "pitch",
    "yaw",
    "tx",
    "ty",
    "tz",
];

/// Returns the sampling of `step` (deg; `None`: auto), checked.
pub(crate) fn sampling(step: Option<f64>) -> PyResult<Sampling> {
    step.map_or(Sampling::Auto, Sampling::Step)
        .validated()
        .map_err(|e| errors::engine(e.in_context("step")))
}

/// Returns the items of rows `rows` of `cols`, each checked: errors name the row (0-based).
fn items(
    source: &sonarproj::Sonar,
    cols: &[&[f64]],
    placement: bool,
    rows: std::ops::Range<usize>,
    checker: &sonarproj::projection::ItemChecker<'_>,
) -> sonarproj::Result<Vec<BatchItem>> {
    rows.map(|k| {
        let v = |c: usize| cols[c][k];
        let item = batch_item(
            source,
            [v(0), v(1), v(2)],
            [v(3), v(4), v(5)],
            placement,
            [v(6), v(7), v(8)],
        )
        .and_then(|item| checker.check(&item).map(|_| item));
        item.map_err(|e| e.in_context(&format!("poses row {k}")))
    })
    .collect()
}

/// Returns the column slices of `columns` (the nine of `PLACE_NAMES` when `placement`, else of
/// `TRANSLATION_NAMES`), their length, and the pair they are projected between: the sonars and
/// the sampling of `step`, no items yet.
fn columns_and_pair<'a>(
    first: &PySonar,
    second: &PySonar,
    columns: &'a [PyReadonlyArray1<'_, f64>],
    placement: bool,
    step: Option<f64>,
) -> PyResult<(Vec<&'a [f64]>, usize, Batch)> {
    let names = if placement { PLACE_NAMES } else { TRANSLATION_NAMES };
    let (cols, len) = slices(&names, columns)?;
    let pair = Batch {
        source: first.inner.clone(),
        target: second.inner.clone(),
        sampling: sampling(step)?,
        items: Vec::new(),
    };
    Ok((cols, len, pair))
}

/// Returns the metrics of every row of `columns` (see `columns_and_pair`), as a dict of arrays
/// named as the command line's metric columns, and the notice of the backend's selection.
#[pyfunction]
#[pyo3(signature = (first, second, columns, placement, step, backend_name))]
pub(crate) fn batch_columns<'py>(
    py: Python<'py>,
    first: &PySonar,
    second: &PySonar,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    placement: bool,
    step: Option<f64>,
    backend_name: &str,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    let (cols, len, pair) = columns_and_pair(first, second, &columns, placement, step)?;
    let checker = pair.checker().map_err(errors::engine)?;
    let (backend, notice) = backend::get(backend_name)?;
    let mut chunk = pair.clone();
    let mut metrics: Vec<Metrics> = Vec::with_capacity(len);
    let mut start = 0;
    while start < len {
        let end = (start + CHUNK_POSES).min(len);
        let results = py.detach(|| -> sonarproj::Result<Vec<Metrics>> {
            chunk.items = items(&pair.source, &cols, placement, start..end, &checker)?;
            let projected = backend.project(&chunk, Output::MetricsOnly)?;
            Ok(projected.into_iter().map(|p| p.metrics).collect())
        });
        metrics.extend(results.map_err(errors::engine)?);
        py.check_signals()?;
        start = end;
    }
    Ok((metric_dict(py, &metrics)?, notice))
}

/// Returns the seconds the Rust library takes for the batch `batch_columns` would compute
/// (the pair checked, items built from the columns and checked, projected in one call, metrics
/// collected), for the benchmark comparing the Python call with the library.
#[pyfunction]
#[pyo3(signature = (first, second, columns, placement, step, backend_name))]
pub(crate) fn bench_rust_batch<'py>(
    py: Python<'py>,
    first: &PySonar,
    second: &PySonar,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    placement: bool,
    step: Option<f64>,
    backend_name: &str,
) -> PyResult<f64> {
    let (cols, len, pair) = columns_and_pair(first, second, &columns, placement, step)?;
    let (backend, _) = backend::get(backend_name)?;
    py.detach(|| -> sonarproj::Result<f64> {
        let start = Instant::now();
        let checker = pair.checker()?;
        let batch = Batch {
            items: items(&pair.source, &cols, placement, 0..len, &checker)?,
            ..pair.clone()
        };
        let metrics: Vec<Metrics> = backend
            .project(&batch, Output::MetricsOnly)?
            .into_iter()
            .map(|p| p.metrics)
            .collect();
        std::hint::black_box(&metrics);
        Ok(start.elapsed().as_secs_f64())
    })
    .map_err(errors::engine)
}

/// Returns the metrics of one projection (and its occupancy as a uint8 array in sonar 2's
/// layout when `occupancy`), the sampling plan's sizes, the device, and the notice of the
/// backend's selection.
#[pyfunction]
#[pyo3(signature = (first, second, pose, range, azimuth, step, occupancy, backend_name))]
#[expect(clippy::too_many_arguments, reason = "the Python function's parameters")]
pub(crate) fn project_one<'py>(
    py: Python<'py>,
    first: &PySonar,
    second: &PySonar,
    pose: &PyPose,
    range: f64,
    azimuth: f64,
    step: Option<f64>,
    occupancy: bool,
    backend_name: &str,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    let measurement =
        Measurement::of(&first.inner, range, azimuth).map_err(|e| errors::engine(e.in_context("feature")))?;
    let batch = Batch {
        source: first.inner.clone(),
        target: second.inner.clone(),
        sampling: sampling(step)?,
        items: vec![BatchItem {
            measurement,
            pose: pose.inner,
        }],
    };
    let (backend, notice) = backend::get(backend_name)?;
    let output = if occupancy {
        Output::WithOccupancy
    } else {
        Output::MetricsOnly
    };
    let backend: &Backend = &backend;
    let mut result = py
        .detach(|| backend.project(&batch, output))
        .map_err(errors::engine)?;
    let projection = result.pop().expect("one item in, one result out");
    let dict = PyDict::new(py);
    for (k, v) in metric_dict(py, &[projection.metrics])?.iter() {
        let first = v.get_item(0)?;
        dict.set_item(k, first.call_method0("item")?)?;
    }
    if let Some(occ) = projection.occupancy {
        let bytes = occ.to_bytes(false, false);
        let array = match second.inner.kind {
            SonarKind::Fls => Array2::from_shape_vec((occ.range_bins, occ.beams), bytes)
                .expect("one byte per pixel")
                .into_pyarray(py)
                .into_any(),
            SonarKind::Sss => Array1::from_vec(bytes).into_pyarray(py).into_any(),
        };
        dict.set_item("occupancy", array)?;
    }
    dict.set_item("device", backend.device())?;
    Ok((dict, notice))
}
