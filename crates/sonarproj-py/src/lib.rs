//! The native module of the `sonarproj` Python package: the engine and the applications bound
//! with PyO3. The Python package (`python/sonarproj/`) wraps these functions: it checks array
//! shapes and dtypes, turns mappings into columns and notices into warnings, and carries the
//! documentation a Python user reads. Angles are degrees and distances metres at this boundary,
//! as on the command line.

use pyo3::prelude::*;

mod advise;
mod apps;
mod arrays;
mod backend;
mod bag;
mod batch;
#[cfg(feature = "bench")]
mod bench;
mod errors;
mod masks;
mod oculus;
mod pose;
mod recover;
mod runtime;
mod sonar;
mod values;

/// Registers the module's classes, functions and exception.
#[pymodule]
fn _sonarproj(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Look up NumPy's C API here, at import, not on the first call that makes an array.
    // rust-numpy panics when that lookup meets a pending Ctrl-C ("Failed to access NumPy array API
    // capsule: PyErr { KeyboardInterrupt }"). At import the module is loaded, and an interrupted
    // import is an ordinary KeyboardInterrupt.
    let py = m.py();
    py.import("numpy")?;
    drop(numpy::PyArray1::<u8>::zeros(py, 0, false));
    m.add("InputError", m.py().get_type::<errors::InputError>())?;
    m.add("InputTypeError", values::input_type_error(m.py())?)?;
    m.add_class::<sonar::PySonar>()?;
    m.add_class::<pose::PyPose>()?;
    m.add_class::<pose::PyMount>()?;
    m.add_class::<masks::PyMaskEngine>()?;
    m.add_class::<masks::PyMaskSet>()?;
    m.add_class::<masks::PyMaskSummary>()?;
    m.add_class::<oculus::PyOculusPing>()?;
    m.add_class::<bag::PyBagPing>()?;
    m.add_class::<bag::PyBagPings>()?;
    m.add_function(wrap_pyfunction!(bag::read_bag, m)?)?;
    m.add_function(wrap_pyfunction!(bag::masks_of_bag, m)?)?;
    m.add_function(wrap_pyfunction!(oculus::read_oculus, m)?)?;
    m.add_function(wrap_pyfunction!(sonar::presets, m)?)?;
    m.add_function(wrap_pyfunction!(backend::configure_gpu, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_columns, m)?)?;
    #[cfg(feature = "bench")]
    m.add_function(wrap_pyfunction!(bench::bench_rust_batch, m)?)?;
    m.add_function(wrap_pyfunction!(batch::project_one, m)?)?;
    m.add_function(wrap_pyfunction!(recover::recover_one, m)?)?;
    m.add_function(wrap_pyfunction!(recover::recover_columns, m)?)?;
    m.add_function(wrap_pyfunction!(advise::advise_run, m)?)?;
    m.add_function(wrap_pyfunction!(apps::sweep_run, m)?)?;
    m.add_function(wrap_pyfunction!(apps::sweep_memory, m)?)?;
    m.add_function(wrap_pyfunction!(apps::sweep_merge, m)?)?;
    m.add_function(wrap_pyfunction!(apps::paper_run, m)?)?;
    m.add("METRIC_COLUMNS", sonarproj_apps::io::METRIC_COLUMNS.to_vec())?;
    m.add(
        "SPLAT_WORKGROUPS",
        sonarproj::gpu::options::SPLAT_WORKGROUPS.to_vec(),
    )?;
    m.add("DEFAULT_CHUNK_POSES", sonarproj_apps::sweep::DEFAULT_CHUNK_POSES)?;
    m.add(
        "DEFAULT_SUMMARY_CHUNK_POSES",
        sonarproj_apps::sweep::DEFAULT_SUMMARY_CHUNK_POSES,
    )?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
