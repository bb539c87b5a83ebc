//! Where the package's work runs: without the GIL, on a thread pool of this process. A forked
//! child inherits the pool's bookkeeping but not its threads, so work sent there would wait
//! forever. The pool therefore belongs to a process id, and a forked child makes its own on
//! its first call.

use std::sync::{Arc, Mutex, PoisonError};

use pyo3::prelude::*;

/// The pool and the process that made it.
static POOL: Mutex<Option<(u32, Arc<rayon::ThreadPool>)>> = Mutex::new(None);

/// Returns this process's pool (made on first use, or again after a fork), or `None` when no
/// thread could be started (the work then runs on rayon's global pool).
fn pool() -> Option<Arc<rayon::ThreadPool>> {
    let pid = std::process::id();
    let mut slot = POOL.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some((owner, pool)) = slot.as_ref()
        && *owner == pid
    {
        return Some(Arc::clone(pool));
    }
    // A parent's pool: its threads do not exist here, and dropping it would wait for them.
    if let Some(inherited) = slot.take() {
        std::mem::forget(inherited);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .thread_name(|i| format!("sonarproj-{i}"))
        .build()
        .ok()
        .map(Arc::new)?;
    *slot = Some((pid, Arc::clone(&pool)));
    Some(pool)
}

/// Returns whether this process is the one that made `owner` (a process id recorded when a
/// device or engine was opened).
pub(crate) fn same_process(owner: u32) -> bool {
    owner == std::process::id()
}

/// Returns `f()` run without the GIL on this process's pool. Every parallel loop inside runs
/// there too.
pub(crate) fn detach<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> T {
    match pool() {
        Some(pool) => py.detach(|| pool.install(f)),
        None => py.detach(f),
    }
}

/// Returns `work(stop)` run without the GIL on this process's pool, while the calling thread
/// checks for Ctrl-C every 50 ms. CPython delivers signals to its main thread only, where the
/// caller is, never to a pool thread. On a signal, `stop` is set so the work ends at its next
/// chance, the work is waited for, and the signal's exception is returned.
///
/// # Errors
/// The exception of a signal handler (`KeyboardInterrupt` for Ctrl-C).
pub(crate) fn detach_watching<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&std::sync::atomic::AtomicBool) -> T + Send,
) -> PyResult<T> {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::mpsc;
    let stop = AtomicBool::new(false);
    let run = || {
        let (sent, received) = mpsc::channel();
        let mut raised = None;
        let answer = match pool() {
            Some(pool) => pool.in_place_scope(|scope| {
                scope.spawn(|_| {
                    let _ = sent.send(work(&stop));
                });
                loop {
                    match received.recv_timeout(std::time::Duration::from_millis(50)) {
                        Ok(answer) => break answer,
                        Err(mpsc::RecvTimeoutError::Timeout) => {
                            if raised.is_none()
                                && let Err(e) = Python::attach(|py| py.check_signals())
                            {
                                raised = Some(e);
                                stop.store(true, Ordering::Relaxed);
                            }
                        }
                        Err(mpsc::RecvTimeoutError::Disconnected) => {
                            unreachable!("the work sends its answer before it ends")
                        }
                    }
                }
            }),
            None => work(&stop),
        };
        (answer, raised)
    };
    let (answer, raised) = py.detach(run);
    match raised {
        Some(e) => Err(e),
        None => Ok(answer),
    }
}
