//! `sonarproj.sweep` and `sonarproj.paper`: the applications the command line runs, with the
//! same code.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use sonarproj::stream::Stop;
use sonarproj_apps::paper;
use sonarproj_apps::report::check_output_dir;
use sonarproj_apps::sweep::{self, Event, Options, Shard, SweepConfig};

use crate::{backend, errors};

/// Returns the error of an applications call, in Python's words.
fn error(e: sonarproj_apps::Error) -> PyErr {
    errors::apps(e)
}

/// Answers a sweep's `event`: stop once the calling thread saw Ctrl-C (`stop`) or `progress`
/// raised (kept in `raised`). Else call `progress(done, total)` with the GIL on a progress event.
fn on_event(
    event: Event,
    stop: &std::sync::atomic::AtomicBool,
    progress: Option<&Py<PyAny>>,
    raised: &mut Option<PyErr>,
) -> ControlFlow<()> {
    if stop.load(std::sync::atomic::Ordering::Relaxed) {
        return ControlFlow::Break(());
    }
    let (Event::Progress { done, total }, Some(f)) = (event, progress) else {
        return ControlFlow::Continue(());
    };
    Python::attach(|py| match f.bind(py).call1((done, total)) {
        Ok(_) => ControlFlow::Continue(()),
        Err(e) => {
            *raised = Some(e);
            ControlFlow::Break(())
        }
    })
}

/// Runs the sweep of the TOML file `config` into `out_dir`, resuming a run there. Returns what
/// was done and the notice of the backend's selection. `progress(done, total)` is called after
/// each chunk. Ctrl-C stops the run between chunks, and finished chunks stay on disk.
#[pyfunction]
#[pyo3(signature = (config, out_dir, shard, chunk_poses, max_chunks, backend_name, progress, format))]
#[expect(clippy::too_many_arguments, reason = "the Python function's parameters")]
pub(crate) fn sweep_run<'py>(
    py: Python<'py>,
    config: PathBuf,
    out_dir: PathBuf,
    shard: Option<&str>,
    chunk_poses: Option<u64>,
    max_chunks: Option<u64>,
    backend_name: &str,
    progress: Option<Py<PyAny>>,
    format: &str,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    let shard = shard.map(Shard::parse).transpose().map_err(error)?;
    let format = sweep::Format::parse(format, "format").map_err(error)?;
    let config = SweepConfig::load(&config).map_err(error)?;
    let opts = Options {
        out: out_dir,
        shard,
        chunk_poses,
        max_chunks,
        format,
    };
    let (backend, notice) = backend::get(backend_name)?;
    let start = Instant::now();
    // The run goes on without the GIL, on the pool. After each chunk it takes the GIL back to
    // report progress. It stops, keeping the finished chunks, when the progress callback raised
    // or the calling thread saw Ctrl-C.
    let mut raised: Option<PyErr> = None;
    let outcome = crate::runtime::detach_watching(py, |stop| {
        // Ctrl-C is polled inside the chunks too, not only between them.
        let signal = || stop.load(std::sync::atomic::Ordering::Relaxed);
        sweep::run(&config, &backend, &opts, Stop::when(&signal), &mut |event| {
            on_event(event, stop, progress.as_ref(), &mut raised)
        })
    })?;
    if let Some(e) = raised {
        return Err(e);
    }
    let outcome = outcome.map_err(error)?;
    let d = PyDict::new(py);
    d.set_item("file", outcome.file)?;
    d.set_item("figure", outcome.figure)?;
    // The summaries as a dict (the JSON of summary.json, parsed by Python's json module).
    let summary = match &outcome.summary {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("{}: {e}", path.display())))?;
            Some(py.import("json")?.call_method1("loads", (text,))?)
        }
        None => None,
    };
    d.set_item("summary_file", &outcome.summary)?;
    d.set_item("summary", summary)?;
    d.set_item("poses", outcome.poses)?;
    d.set_item("computed", outcome.computed)?;
    d.set_item("resumed", outcome.resumed)?;
    d.set_item("seconds", start.elapsed().as_secs_f64())?;
    d.set_item("device", backend.device())?;
    Ok((d, notice))
}

/// Runs the sweep of the TOML file `config` (or one shard of it) in memory, writing nothing.
/// Returns its columns (numpy arrays, NaN where the CSV leaves a cell empty), its summaries (a
/// dict, or None), and the notice of the backend's selection. Ctrl-C or a raising `progress`
/// stops it between chunks.
#[pyfunction]
#[pyo3(signature = (config, shard, chunk_poses, backend_name, progress))]
pub(crate) fn sweep_memory<'py>(
    py: Python<'py>,
    config: PathBuf,
    shard: Option<&str>,
    chunk_poses: Option<u64>,
    backend_name: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    use numpy::IntoPyArray;
    use sonarproj_apps::io::parquet::Column;
    let shard = shard.map(Shard::parse).transpose().map_err(error)?;
    let config = SweepConfig::load(&config).map_err(error)?;
    let (backend, notice) = backend::get(backend_name)?;
    let start = Instant::now();
    let mut raised: Option<PyErr> = None;
    let result = crate::runtime::detach_watching(py, |stop| {
        let signal = || stop.load(std::sync::atomic::Ordering::Relaxed);
        sweep::run_in_memory(
            &config,
            &backend,
            shard,
            chunk_poses,
            Stop::when(&signal),
            &mut |event| on_event(event, stop, progress.as_ref(), &mut raised),
        )
    })?;
    if let Some(e) = raised {
        return Err(e);
    }
    let Some(result) = result.map_err(errors::apps)? else {
        return Err(pyo3::exceptions::PyKeyboardInterrupt::new_err("sweep stopped"));
    };
    let d = PyDict::new(py);
    let columns = PyDict::new(py);
    if let Some(table) = result.table {
        for (name, column) in table.names.iter().zip(table.columns) {
            match column {
                Column::Int(v) => columns.set_item(name, v.into_pyarray(py))?,
                Column::Real(v) => columns.set_item(name, v.into_pyarray(py))?,
                Column::Optional(v) => columns.set_item(
                    name,
                    v.into_iter()
                        .map(|x| x.unwrap_or(f64::NAN))
                        .collect::<Vec<f64>>()
                        .into_pyarray(py),
                )?,
            }
        }
        d.set_item("columns", columns)?;
    } else {
        d.set_item("columns", py.None())?;
    }
    let summary = match &result.summary {
        Some(s) => {
            let text = serde_json::to_string(s)
                .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
            Some(py.import("json")?.call_method1("loads", (text,))?)
        }
        None => None,
    };
    d.set_item("summary", summary)?;
    d.set_item("poses", result.poses)?;
    d.set_item("seconds", start.elapsed().as_secs_f64())?;
    d.set_item("device", backend.device())?;
    Ok((d, notice))
}

/// Joins the finished shards in `out_dir` into its `sweep.csv` and draws the figure, as
/// `sonarproj merge` does. It is refused, writing nothing, when a shard is missing or damaged
/// or the shards were computed with different settings. Returns the table's, the summaries'
/// and the figure's paths (each None when not written).
#[pyfunction]
#[pyo3(signature = (out_dir))]
pub(crate) fn sweep_merge(
    py: Python<'_>,
    out_dir: PathBuf,
) -> PyResult<(Option<PathBuf>, Option<PathBuf>, Option<PathBuf>)> {
    crate::runtime::detach(py, || sweep::merge(&out_dir))
        .map(|m| (m.file, m.summary, m.figure))
        .map_err(errors::apps)
}

/// Runs the paper's simulations and writes their CSV, figures and findings into `out_dir`.
/// Returns the findings and the notice of the backend's selection.
#[pyfunction]
#[pyo3(signature = (out_dir, angle_step, step, backend_name))]
pub(crate) fn paper_run<'py>(
    py: Python<'py>,
    out_dir: PathBuf,
    angle_step: f64,
    step: Option<crate::batch::Step>,
    backend_name: &str,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    let sampling = crate::batch::sampling(step)?;
    paper::angles(angle_step).map_err(errors::apps)?;
    check_output_dir(&out_dir, "out_dir").map_err(error)?;
    let (backend, notice) = backend::get(backend_name)?;
    let start = Instant::now();
    // Ctrl-C is polled while each block of poses is projected.
    let (runs, findings) = crate::runtime::detach_watching(py, |stop| {
        let signal = || stop.load(std::sync::atomic::Ordering::Relaxed);
        paper::run_to(
            &out_dir,
            "out_dir",
            &backend,
            angle_step,
            sampling,
            Stop::when(&signal),
        )
    })?
    .map_err(error)?;
    let seconds = start.elapsed().as_secs_f64();
    let d = PyDict::new(py);
    let list = findings
        .iter()
        .map(|f| {
            let item = PyDict::new(py);
            item.set_item("claim", f.claim)?;
            item.set_item("holds", f.holds)?;
            item.set_item("evidence", &f.evidence)?;
            Ok(item)
        })
        .collect::<PyResult<Vec<_>>>()?;
    d.set_item("findings", list)?;
    d.set_item("poses", runs.iter().map(|r| r.poses).sum::<u64>())?;
    d.set_item("seconds", seconds)?;
    d.set_item("device", backend.device())?;
    d.set_item("out_dir", out_dir)?;
    Ok((d, notice))
}
