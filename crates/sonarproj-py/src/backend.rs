//! Backends chosen by name and kept for the life of the process, so a GPU device is opened once
//! and its buffers are reused between calls.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use pyo3::PyResult;
use sonarproj::{Backend, BackendChoice};

use crate::errors;

/// The backend names Python accepts, as on the command line.
const NAMES: [(&str, BackendChoice); 4] = [
    ("auto", BackendChoice::Auto),
    ("gpu", BackendChoice::Gpu),
    ("cpu-fast", BackendChoice::CpuFast),
    ("cpu", BackendChoice::Cpu),
];

/// Backends opened so far, with the notice their selection gave.
type Opened = HashMap<&'static str, (Arc<Backend>, Option<String>)>;

static OPENED: Mutex<Option<Opened>> = Mutex::new(None);

/// Returns the choice named `name`.
pub(crate) fn choice(name: &str) -> PyResult<BackendChoice> {
    NAMES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, c)| *c)
        .ok_or_else(|| {
            errors::input(
                "backend",
                format!("{name:?} is not a backend; use \"auto\", \"gpu\", \"cpu-fast\" or \"cpu\""),
            )
        })
}

/// Returns the backend named `name` (opened on the first call) and the notice of its selection
/// (`auto` falling back to the CPU says why).
pub(crate) fn get(name: &str) -> PyResult<(Arc<Backend>, Option<String>)> {
    let c = choice(name)?;
    let key = NAMES
        .iter()
        .find(|(_, k)| *k == c)
        .map(|(n, _)| *n)
        .expect("known");
    let mut opened = OPENED.lock().unwrap_or_else(PoisonError::into_inner);
    let map = opened.get_or_insert_with(HashMap::new);
    if let Some((b, notice)) = map.get(key) {
        return Ok((Arc::clone(b), notice.clone()));
    }
    let (backend, notice) = Backend::select(c).map_err(errors::engine)?;
    let backend = Arc::new(backend);
    map.insert(key, (Arc::clone(&backend), notice.clone()));
    Ok((backend, notice))
}
