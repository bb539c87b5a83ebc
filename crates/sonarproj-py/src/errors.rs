//! Errors at the Python boundary: bad input becomes `sonarproj.InputError` (a `ValueError`),
//! every other failure a `RuntimeError`.

use pyo3::PyErr;
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};

// Defined in module `sonarproj` (which re-exports it), so that pickle finds it there: an error
// raised in a multiprocessing worker reaches the parent as itself.
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

/// Returns the Python exception of an applications error.
pub(crate) fn apps(e: sonarproj_apps::Error) -> PyErr {
    if e.is_input() {
        InputError::new_err(e.to_string())
    } else {
        PyRuntimeError::new_err(e.to_string())
    }
}

/// Returns the Python exception of an applications error whose message names command-line
/// flags, with each flag replaced by the Python parameter that stands for it (`names`: pairs of
/// flag and parameter).
pub(crate) fn apps_renamed(e: sonarproj_apps::Error, names: &[(&str, &str)]) -> PyErr {
    let input = e.is_input();
    let message = rename_flags(&e.to_string(), names);
    if input {
        InputError::new_err(message)
    } else {
        PyRuntimeError::new_err(message)
    }
}

/// Returns `text` with each whole flag of `names` (not followed by another letter, digit or
/// hyphen) replaced by its parameter.
fn rename_flags(text: &str, names: &[(&str, &str)]) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    'outer: while !rest.is_empty() {
        for (flag, param) in names {
            if let Some(after) = rest.strip_prefix(flag) {
                let whole = !after
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_alphanumeric() || c == '-' || c == '_');
                if whole {
                    out.push_str(param);
                    rest = after;
                    continue 'outer;
                }
            }
        }
        let c = rest.chars().next().expect("not empty");
        out.push(c);
        rest = &rest[c.len_utf8()..];
    }
    out
}

/// Returns an `InputError` for `parameter` with `message`.
pub(crate) fn input(parameter: &str, message: impl std::fmt::Display) -> PyErr {
    InputError::new_err(format!("{parameter}: {message}"))
}
