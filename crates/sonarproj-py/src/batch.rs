//! `sonarproj.batch` and `sonarproj.project`: projections from numpy columns and from one pose.

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sonarproj::local_precision::{LocalPrecision, resolve_sigma_range};
use sonarproj::metrics::Metrics;
use sonarproj::{Backend, Batch, BatchItem, Measurement, Output, Sampling, SonarKind};
use sonarproj_apps::io::pose_columns::{PoseColumns, allowed_columns, expected_columns};

use crate::arrays::{metric_dict, slices};
use crate::pose::PyPose;
use crate::sonar::PySonar;
use crate::{backend, errors};

/// Poses projected per engine call: about a second of work at 0.1° sampling on two cores.
/// Between chunks the GIL is taken back and Ctrl-C checked.
const CHUNK_POSES: usize = 65_536;

/// A sampling as Python gives it: a step in degrees, or a name (`"auto"`, `"exact"`).
#[derive(Clone, Debug, FromPyObject)]
pub(crate) enum Step {
    /// A step (deg).
    Degrees(f64),
    /// `"auto"` or `"exact"`.
    Named(String),
}

/// Returns the sampling of `step` (`None`: auto), checked.
pub(crate) fn sampling(step: Option<Step>) -> PyResult<Sampling> {
    let sampling = match step {
        None => Sampling::Auto,
        Some(Step::Degrees(s)) => Sampling::Step(s),
        Some(Step::Named(name)) => name.parse::<Sampling>().map_err(errors::engine)?,
    };
    sampling
        .validated()
        .map_err(|e| errors::engine(e.in_context("step")))
}

/// Returns the items of rows `rows` of `cols` (in `columns`' order), each checked and with its
/// feature's true point when the columns give it. Errors name the row (0-based).
pub(crate) fn items(
    source: &sonarproj::Sonar,
    columns: &PoseColumns,
    cols: &[&[f64]],
    rows: std::ops::Range<usize>,
    checker: &sonarproj::projection::ItemChecker<'_>,
) -> sonarproj::Result<Vec<BatchItem>> {
    let mut values = vec![0.0; cols.len()];
    rows.map(|k| {
        for (v, c) in values.iter_mut().zip(cols) {
            *v = c[k];
        }
        let item = columns
            .item(source, &values)
            .and_then(|item| checker.check(&item).map(|_| item));
        item.map_err(|e| e.in_context(format!("poses row {k}")))
    })
    .collect()
}

/// Returns the pose table's reading (its columns `names`, checked against sonar 1), the column
/// slices in the order it reads them, their length, and the pair to project between: the
/// sonars, the sampling of `step` and the area grid, with no items yet.
pub(crate) fn columns_and_pair<'a>(
    first: &PySonar,
    second: &PySonar,
    names: &[String],
    columns: &'a [PyReadonlyArray1<'_, f64>],
    step: Option<Step>,
    area_grid: f64,
) -> PyResult<(PoseColumns, Vec<&'a [f64]>, usize, Batch)> {
    let allowed = allowed_columns();
    if let Some(unknown) = names.iter().find(|n| !allowed.contains(&n.as_str())) {
        return Err(errors::input(
            "poses",
            format!(
                "unknown column {unknown:?}; the columns are {}",
                expected_columns()
            ),
        ));
    }
    let given: Vec<&str> = names.iter().map(String::as_str).collect();
    let reading = PoseColumns::of(&given, first.inner.kind).map_err(|m| errors::input("poses", m))?;
    let (all, len) = slices(&given, columns)?;
    let cols = reading
        .columns()
        .iter()
        .map(|c| {
            all[given
                .iter()
                .position(|n| n == c)
                .expect("a column the reading found")]
        })
        .collect();
    let pair = Batch {
        sigma_range: None,
        source: first.inner.clone(),
        target: second.inner.clone(),
        sampling: sampling(step)?,
        area_grid,
        items: Vec::new(),
    };
    pair.checker().map_err(errors::engine)?;
    Ok((reading, cols, len, pair))
}

/// Returns the metrics of every row of `columns` (see `columns_and_pair`), as a dict of arrays
/// named as the command line's metric columns, and the notice of the backend's selection.
#[pyfunction]
#[pyo3(signature = (first, second, names, columns, step, area_grid, sigma_range, backend_name))]
#[expect(clippy::too_many_arguments, reason = "the Python function's parameters")]
pub(crate) fn batch_columns<'py>(
    py: Python<'py>,
    first: &PySonar,
    second: &PySonar,
    names: Vec<String>,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    step: Option<Step>,
    area_grid: f64,
    sigma_range: Option<f64>,
    backend_name: &str,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    let (reading, cols, len, pair) = columns_and_pair(first, second, &names, &columns, step, area_grid)?;
    let checker = pair.checker().map_err(errors::engine)?;
    resolve_sigma_range(&pair.source, &pair.target, sigma_range).map_err(errors::engine)?;
    let (backend, notice) = backend::get(backend_name)?;
    let mut chunk = Batch {
        sigma_range,
        ..pair.clone()
    };
    let mut metrics: Vec<Metrics> = Vec::with_capacity(len);
    let mut locals: Vec<LocalPrecision> = Vec::with_capacity(len);
    let mut start = 0;
    while start < len {
        let end = (start + CHUNK_POSES).min(len);
        // Ctrl-C is watched while the chunk runs: the backend stops within an item or a tile.
        let results = crate::runtime::detach_watching(py, |stop| -> sonarproj::Result<()> {
            let signal = || stop.load(std::sync::atomic::Ordering::Relaxed);
            chunk.items = items(&pair.source, &reading, &cols, start..end, &checker)?;
            let projected = backend.project_until(
                &chunk,
                Output::MetricsOnly,
                sonarproj::stream::Stop::when(&signal),
            )?;
            for p in projected {
                metrics.push(p.metrics);
                locals.push(p.local);
            }
            Ok(())
        })?;
        results.map_err(errors::engine)?;
        start = end;
    }
    Ok((metric_dict(py, &metrics, &locals)?, notice))
}

/// Returns the metrics of one projection (and its occupancy as a uint8 array in sonar 2's
/// layout when `occupancy`), the sampling plan's sizes, the device, and the notice of the
/// backend's selection.
#[pyfunction]
#[pyo3(signature = (first, second, pose, range, azimuth, elevation, step, area_grid, sigma_range, occupancy, backend_name))]
#[expect(clippy::too_many_arguments, reason = "the Python function's parameters")]
pub(crate) fn project_one<'py>(
    py: Python<'py>,
    first: &PySonar,
    second: &PySonar,
    pose: &PyPose,
    range: f64,
    azimuth: f64,
    elevation: Option<f64>,
    step: Option<Step>,
    area_grid: f64,
    sigma_range: Option<f64>,
    occupancy: bool,
    backend_name: &str,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    let measurement =
        Measurement::of(&first.inner, range, azimuth).map_err(|e| errors::engine(e.in_context("feature")))?;
    if let Some(el) = elevation {
        first
            .inner
            .check_point("feature", range, azimuth, el)
            .map_err(errors::engine)?;
    }
    // With the elevation given, the true point is known, and the projection carries the local
    // precision there.
    let batch = Batch {
        sigma_range,
        source: first.inner.clone(),
        target: second.inner.clone(),
        sampling: sampling(step)?,
        area_grid,
        items: vec![BatchItem {
            true_point: elevation.map(|el| [range, azimuth, el]),
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
    let mut result =
        crate::runtime::detach(py, || backend.project(&batch, output)).map_err(errors::engine)?;
    let projection = result.pop().expect("one item in, one result out");
    let dict = PyDict::new(py);
    for (k, v) in metric_dict(py, &[projection.metrics], &[projection.local])?.iter() {
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
