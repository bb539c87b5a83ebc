//! Backends chosen by name and kept for the life of the process, so a GPU device is opened once
//! and its buffers are reused between calls. The engine reads no environment variable, so the
//! GPU options come from `sonarproj.configure_gpu`'s keyword arguments.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use pyo3::prelude::*;
use sonarproj::gpu::{GpuOptions, Precision};
use sonarproj::{Backend, BackendChoice};

use crate::errors;

/// The backend names Python accepts, as on the command line.
const NAMES: [(&str, BackendChoice); 4] = [
    ("auto", BackendChoice::Auto),
    ("gpu", BackendChoice::Gpu),
    ("cpu-fast", BackendChoice::CpuFast),
    ("cpu", BackendChoice::Cpu),
];

/// Backends opened so far by one process (its id), with the notice their selection gave.
type Opened = (u32, HashMap<&'static str, (Arc<Backend>, Option<String>)>);

static OPENED: Mutex<Option<Opened>> = Mutex::new(None);

/// The GPU options every backend and mask engine of this process is opened with.
static OPTIONS: Mutex<Option<GpuOptions>> = Mutex::new(None);

/// Returns the GPU options set by [`configure_gpu`] (the engine's defaults until then).
pub(crate) fn options() -> GpuOptions {
    OPTIONS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clone()
        .unwrap_or_default()
}

/// Sets the GPU options of the backends and mask engines opened from now on, and forgets those
/// opened before, so the next call opens them again with these. The Python package checks the
/// arguments, and each bad one raises `InputError` naming it.
#[pyfunction]
#[pyo3(signature = (backends, adapter, precision, cull, filter, workgroup))]
pub(crate) fn configure_gpu(
    backends: Option<Vec<String>>,
    adapter: Option<String>,
    precision: Option<String>,
    cull: Option<bool>,
    filter: Option<bool>,
    workgroup: Option<u32>,
) -> PyResult<String> {
    let backends = match backends {
        None => None,
        Some(names) => {
            let mut all = wgpu::Backends::empty();
            for n in &names {
                let one = wgpu::Backends::from_comma_list(n);
                if one.is_empty() || n.contains(',') {
                    return Err(errors::input(
                        "backends",
                        format!("{n:?} is not a backend; use \"vulkan\", \"metal\", \"dx12\" or \"gl\""),
                    ));
                }
                all |= one;
            }
            Some(all)
        }
    };
    let precision = match precision.as_deref() {
        None => None,
        Some(p) => Some(Precision::parse(p).ok_or_else(|| {
            errors::input(
                "precision",
                format!("{p:?} is not a precision; use \"f64\", \"double-f32\" or None"),
            )
        })?),
    };
    let options = GpuOptions {
        backends,
        adapter,
        precision,
        cull,
        filter,
        workgroup,
    };
    options.validate().map_err(|e| {
        let text = e.to_string();
        let name = if text.contains("workgroup") {
            "workgroup"
        } else {
            "adapter"
        };
        errors::input(name, text)
    })?;
    let described = options.describe();
    *OPTIONS.lock().unwrap_or_else(PoisonError::into_inner) = Some(options);
    *OPENED.lock().unwrap_or_else(PoisonError::into_inner) = None;
    Ok(described)
}

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
    // A forked child inherits its parent's devices but can neither use nor safely close them.
    // Leave them alone, and let the child open its own.
    if opened
        .as_ref()
        .is_some_and(|(owner, _)| !crate::runtime::same_process(*owner))
        && let Some(inherited) = opened.take()
    {
        std::mem::forget(inherited);
    }
    let (_, map) = opened.get_or_insert_with(|| (std::process::id(), HashMap::new()));
    if let Some((b, notice)) = map.get(key) {
        return Ok((Arc::clone(b), notice.clone()));
    }
    let (backend, notice) = Backend::select(c, &options()).map_err(errors::engine)?;
    let notice = notice.map(|n| n.render(&errors::name));
    let backend = Arc::new(backend);
    map.insert(key, (Arc::clone(&backend), notice.clone()));
    Ok((backend, notice))
}
