//! Backends chosen by name and kept for the life of the process, so a GPU device is opened once
//! and its buffers are reused between calls. The engine reads no environment variable, so the
//! GPU options come from `sonarproj.configure_gpu`'s keyword arguments.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU32, Ordering};
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

/// The process that first opened or probed a GPU driver (a `gpu` or `auto` backend or mask
/// engine), 0 while none has. A forked child inherits the value, not the driver's threads.
static GPU_TOUCHED_BY: AtomicU32 = AtomicU32::new(0);

/// Notes that this process opened or probed a GPU driver for `choice`.
pub(crate) fn touched(choice: BackendChoice) {
    if matches!(choice, BackendChoice::Auto | BackendChoice::Gpu) {
        let _ = GPU_TOUCHED_BY.compare_exchange(0, std::process::id(), Ordering::Relaxed, Ordering::Relaxed);
    }
}

/// Returns the choice this process can open for `choice`, and the notice of a change. A
/// process forked from one that had opened a GPU driver cannot open one again (the driver's
/// threads were not copied: it would wait forever), so `gpu` is refused naming the way out and
/// `auto` runs on the CPU with a notice.
///
/// # Errors
/// An `InputError` naming `backend` for `gpu` after such a fork.
pub(crate) fn after_fork(choice: BackendChoice) -> PyResult<(BackendChoice, Option<String>)> {
    let by = GPU_TOUCHED_BY.load(Ordering::Relaxed);
    if by == 0 || crate::runtime::same_process(by) {
        return Ok((choice, None));
    }
    let why = "this process was forked from one that had opened a GPU driver, which a forked \
               child cannot use";
    match choice {
        BackendChoice::Gpu => Err(errors::input(
            "backend",
            format!(
                "\"gpu\": {why}; start workers with multiprocessing's \"spawn\" or \
                 \"forkserver\" method, or use backend=\"cpu-fast\""
            ),
        )),
        BackendChoice::Auto => Ok((
            BackendChoice::CpuFast,
            Some(format!("note: running on the CPU: {why}")),
        )),
        other => Ok((other, None)),
    }
}

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
    let (c, forked) = after_fork(choice(name)?)?;
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
        return Ok((Arc::clone(b), forked.or_else(|| notice.clone())));
    }
    touched(c);
    let (backend, notice) = Backend::select(c, &options()).map_err(errors::engine)?;
    let notice = forked.or_else(|| notice.map(|n| n.render(&errors::name)));
    let backend = Arc::new(backend);
    map.insert(key, (Arc::clone(&backend), notice.clone()));
    Ok((backend, notice))
}
