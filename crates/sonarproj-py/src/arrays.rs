//! numpy arrays in and out.

use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sonarproj::local_precision::LocalPrecision;
use sonarproj::metrics::{METRICS, Metric, Metrics, Value};
use sonarproj_apps::io::batch::LOCAL_COLUMNS;

use crate::errors;

/// Returns the slices of `columns`, which must all hold `len` values. The Python layer already
/// made them contiguous float64 arrays of one length, but this checks again.
pub(crate) fn slices<'a>(
    names: &[&str],
    columns: &'a [PyReadonlyArray1<'_, f64>],
) -> PyResult<(Vec<&'a [f64]>, usize)> {
    if columns.len() != names.len() {
        return Err(errors::input(
            "columns",
            format!(
                "{} arrays given, {} expected ({})",
                columns.len(),
                names.len(),
                names.join(", ")
            ),
        ));
    }
    let slices = columns
        .iter()
        .zip(names)
        .map(|(c, name)| {
            c.as_slice()
                .map_err(|_| errors::input(name, "must be a contiguous 1-D float64 array"))
        })
        .collect::<PyResult<Vec<_>>>()?;
    let len = slices.first().map_or(0, |s| s.len());
    if let Some((s, name)) = slices.iter().zip(names).find(|(s, _)| s.len() != len) {
        return Err(errors::input(
            name,
            format!(
                "has {} values where {} has {len}: every column must have the same length",
                s.len(),
                names[0]
            ),
        ));
    }
    Ok((slices, len))
}

/// Returns a dict of metric arrays, named as the command line's metric columns, from `metrics`
/// and the local precision `locals` of the same rows. Counts are int64, and numbers float64
/// with NaN where nothing was visible or there is no value.
pub(crate) fn metric_dict<'py>(
    py: Python<'py>,
    metrics: &[Metrics],
    locals: &[LocalPrecision],
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for info in METRICS {
        match info.metric {
            Metric::Visible | Metric::Total | Metric::Occupied => {
                let v: Vec<i64> = metrics
                    .iter()
                    .map(|m| match m.get(info.metric) {
                        Value::Count(n) => i64::try_from(n).unwrap_or(i64::MAX),
                        _ => -1,
                    })
                    .collect();
                dict.set_item(info.name, v.into_pyarray(py))?;
            }
            _ => {
                let v: Vec<f64> = metrics
                    .iter()
                    .map(|m| match m.get(info.metric) {
                        Value::Count(n) => n as f64,
                        Value::Real(x) => x,
                        Value::Optional(x) => x.unwrap_or(f64::NAN),
                    })
                    .collect();
                dict.set_item(info.name, v.into_pyarray(py))?;
            }
        }
    }
    let column = |f: fn(&LocalPrecision) -> Option<f64>| -> Vec<f64> {
        locals.iter().map(|l| f(l).unwrap_or(f64::NAN)).collect()
    };
    let [slope, sigma] = LOCAL_COLUMNS;
    dict.set_item(slope, column(|l| l.range_per_elevation).into_pyarray(py))?;
    dict.set_item(sigma, column(|l| l.sigma_elevation).into_pyarray(py))?;
    Ok(dict)
}
