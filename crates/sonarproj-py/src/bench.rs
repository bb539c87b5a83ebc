//! What only the benchmark comparing the Python package with the Rust library
//! (`scripts/bench_python.py`) needs: the library's own time for a batch, measured inside the
//! module. Built with the `bench` feature alone. The shipped package does not carry it.

use std::time::Instant;

use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use sonarproj::metrics::Metrics;
use sonarproj::{Batch, BatchItem, Output};

use crate::backend;
use crate::batch::{columns_and_pair, items};
use crate::errors;
use crate::sonar::PySonar;

/// Returns the seconds the Rust library takes for the batch that `batch_columns` would compute:
/// the pair checked, items built from the columns and checked, projected in one call, metrics
/// collected. For the benchmark comparing the Python call with the library
/// (`scripts/bench_python.py`). Only in a module built with the `bench` feature.
#[pyfunction]
#[pyo3(signature = (first, second, names, columns, step, backend_name))]
pub(crate) fn bench_rust_batch<'py>(
    py: Python<'py>,
    first: &PySonar,
    second: &PySonar,
    names: Vec<String>,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    step: Option<crate::batch::Step>,
    backend_name: &str,
) -> PyResult<f64> {
    let (reading, cols, len, pair) =
        columns_and_pair(first, second, &names, &columns, step, sonarproj::PAPER_AREA_GRID)?;
    let (backend, _) = backend::get(backend_name)?;
    crate::runtime::detach(py, || -> sonarproj::Result<f64> {
        let start = Instant::now();
        let checker = pair.checker()?;
        let batch = Batch {
            items: items(&pair.source, &reading, &cols, 0..len, &checker)?
                .into_iter()
                // The metrics alone, as the timed projection computes them.
                .map(|item| BatchItem {
                    true_point: None,
                    ..item
                })
                .collect(),
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
