//! `sonarproj.advise`: the rig advisor the command line runs, with the same code. Every
//! candidate comes back as numpy columns.

use std::path::PathBuf;
use std::time::Instant;

use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sonarproj_apps::advise::{self, AdviseConfig, Score};

use crate::{backend, errors};

/// Returns the error of an advise call, with the command line's flags renamed.
fn error(e: sonarproj_apps::Error) -> PyErr {
    errors::apps(e)
}

/// Returns `value` as a Python object through JSON (parsed by Python's json module).
fn json<'py>(py: Python<'py>, value: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text =
        serde_json::to_string(value).map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// Runs the advisor of the TOML file `config` on the backend named `backend_name`, writing its
/// files into `out_dir` when given. Returns every candidate's columns (numpy), the ranking, the
/// best candidate and the next-best move, and the notice of the backend's selection.
#[pyfunction]
#[pyo3(signature = (config, out_dir, backend_name))]
pub(crate) fn advise_run<'py>(
    py: Python<'py>,
    config: PathBuf,
    out_dir: Option<PathBuf>,
    backend_name: &str,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    let config = AdviseConfig::load(&config).map_err(error)?;
    if let Some(dir) = &out_dir {
        sonarproj_apps::report::check_output_dir(dir, sonarproj_apps::params::OUT).map_err(error)?;
    }
    let (backend, notice) = backend::get(backend_name)?;
    let start = Instant::now();
    // Ctrl-C is looked at before each batch of projections.
    let (advice, written) = crate::runtime::detach_watching(py, |stop| -> sonarproj_apps::Result<_> {
        let signal = || stop.load(std::sync::atomic::Ordering::Relaxed);
        let advice = advise::advise_until(&config, &backend, sonarproj::stream::Stop::when(&signal))?;
        let written = match &out_dir {
            Some(dir) => Some(advise::write(&config, &advice, dir)?),
            None => None,
        };
        Ok((advice, written))
    })?
    .map_err(error)?;
    let columns = candidate_columns(py, &advice.candidates)?;
    let d = PyDict::new(py);
    d.set_item("candidates", columns)?;
    d.set_item(
        "ranked",
        advice
            .ranked
            .iter()
            .map(|&i| i as u64)
            .collect::<Vec<u64>>()
            .into_pyarray(py),
    )?;
    d.set_item("best", advice.best().map(|b| json(py, b)).transpose()?)?;
    d.set_item(
        "next_move",
        advice.next.as_ref().map(|m| json(py, m)).transpose()?,
    )?;
    d.set_item("metric", advice.metric)?;
    d.set_item(
        "recommended",
        advice
            .recommended
            .map(|i| json(py, &advice.candidates[i].1))
            .transpose()?,
    )?;
    d.set_item("recommended_index", advice.recommended.map(|i| i as u64))?;
    d.set_item(
        "tied",
        advice
            .ranked
            .iter()
            .filter(|&&i| advice.candidates[i].1.tied)
            .count(),
    )?;
    d.set_item(
        "pareto",
        advice
            .pareto
            .iter()
            .map(|&i| i as u64)
            .collect::<Vec<u64>>()
            .into_pyarray(py),
    )?;
    d.set_item("score_unit", advise::score_unit(&config))?;
    d.set_item("recommended_because", advise::recommended_rule(&config))?;
    d.set_item("warnings", advice.warnings.clone())?;
    let files = PyDict::new(py);
    if let Some(w) = written {
        files.set_item("best", w.best)?;
        files.set_item("candidates", w.candidates)?;
        files.set_item("features", w.features)?;
        files.set_item("pareto", w.pareto)?;
        files.set_item("landscape", w.landscape)?;
    }
    d.set_item("files", files)?;
    d.set_item("seconds", start.elapsed().as_secs_f64())?;
    d.set_item("device", backend.device())?;
    Ok((d, notice))
}

/// Returns every candidate's columns as numpy arrays (NaN where there is no value), the
/// candidates file's columns but its index.
fn candidate_columns<'py>(py: Python<'py>, c: &[(advise::Stage, Score)]) -> PyResult<Bound<'py, PyDict>> {
    let real = |f: &dyn Fn(&Score) -> f64| c.iter().map(|(_, s)| f(s)).collect::<Vec<f64>>();
    let nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
    let columns = PyDict::new(py);
    columns.set_item(
        "stage",
        c.iter()
            .map(|(stage, _)| stage.code())
            .collect::<Vec<i64>>()
            .into_pyarray(py),
    )?;
    for (k, name) in ["roll", "pitch", "yaw"].iter().enumerate() {
        columns.set_item(name, real(&|s| s.rotation[k]).into_pyarray(py))?;
    }
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        columns.set_item(name, real(&|s| s.offset[k]).into_pyarray(py))?;
    }
    for (k, name) in ["tx", "ty", "tz"].iter().enumerate() {
        columns.set_item(name, real(&|s| s.translation[k]).into_pyarray(py))?;
    }
    columns.set_item("shared", real(&|s| s.shared).into_pyarray(py))?;
    columns.set_item("shared_se", real(&|s| s.shared_se).into_pyarray(py))?;
    columns.set_item(
        "examined",
        c.iter()
            .map(|(_, s)| s.examined as u64)
            .collect::<Vec<u64>>()
            .into_pyarray(py),
    )?;
    columns.set_item(
        "features",
        c.iter()
            .map(|(_, s)| s.features as u64)
            .collect::<Vec<u64>>()
            .into_pyarray(py),
    )?;
    for (prefix, stats) in [("metric", 0), ("sigma", 1)] {
        let get = move |s: &Score| if stats == 0 { s.metric } else { s.sigma };
        columns.set_item(
            format!("{prefix}_mean"),
            real(&|s| nan(get(s).mean)).into_pyarray(py),
        )?;
        columns.set_item(
            format!("{prefix}_median"),
            real(&|s| nan(get(s).median)).into_pyarray(py),
        )?;
        columns.set_item(
            format!("{prefix}_p10"),
            real(&|s| nan(get(s).p10)).into_pyarray(py),
        )?;
        columns.set_item(
            format!("{prefix}_p90"),
            real(&|s| nan(get(s).p90)).into_pyarray(py),
        )?;
    }
    columns.set_item("score", real(&|s| nan(s.score)).into_pyarray(py))?;
    columns.set_item("score_se", real(&|s| nan(s.score_se)).into_pyarray(py))?;
    columns.set_item(
        "tied",
        c.iter()
            .map(|(_, s)| s.tied)
            .collect::<Vec<bool>>()
            .into_pyarray(py),
    )?;
    Ok(columns)
}
