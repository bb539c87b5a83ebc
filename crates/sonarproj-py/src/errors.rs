//! Errors at the Python boundary: bad input becomes `sonarproj.InputError` (a `ValueError`),
//! every other failure a `RuntimeError`.

use pyo3::PyErr;
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use sonarproj::error::Param;
use sonarproj_apps::params;

// Defined in module `sonarproj`, which re-exports it, so pickle finds it there. An error
// raised in a multiprocessing worker then reaches the parent as itself.
create_exception!(
    sonarproj,
    InputError,
    PyValueError,
    "Bad input: the message names the parameter, the value and what is allowed."
);

/// Returns the Python exception of an engine error.
pub(crate) fn engine(e: sonarproj::Error) -> PyErr {
    apps(e.into())
}

/// Returns the Python exception of an applications error. Each front's input it names is
/// called by its Python keyword ([`name`]).
pub(crate) fn apps(e: sonarproj_apps::Error) -> PyErr {
    let message = e.render(&name);
    if e.is_input() {
        InputError::new_err(message)
    } else {
        PyRuntimeError::new_err(message)
    }
}

/// Returns the Python keyword of `param`: the applications' inputs as the package's functions
/// take them, and the GPU options by their neutral names. The package checks `configure_gpu`'s
/// keywords before they reach the engine.
pub(crate) fn name(param: Param) -> String {
    match param {
        p if p == params::OUT || p == params::SWEEP_DIR => "out_dir",
        other => other.name(),
    }
    .to_string()
}

/// Returns an `InputError` for `parameter` with `message`.
pub(crate) fn input(parameter: &str, message: impl std::fmt::Display) -> PyErr {
    InputError::new_err(format!("{parameter}: {message}"))
}
