//! The one shape of streaming in sonarproj: a call hands each result to a sink as soon as it
//! is ready. The sink answers whether to go on ([`Flow`]): `Continue`, or `Break` to end the
//! call there. A [`Stop`] signal, polled by the engine's threads while a result is computed,
//! ends a call the same way. A streaming call returns the flow it ended with: `Break` when its
//! sink or its stop ended it early. A call that returns its results whole fails with
//! [`Error::Stopped`] instead when its stop is set.
//!
//! ```
//! use sonarproj::stream::{Flow, Stop};
//! use std::sync::atomic::{AtomicBool, Ordering};
//!
//! let ctrl_c = AtomicBool::new(false);
//! let signal = || ctrl_c.load(Ordering::Relaxed);
//! let stop = Stop::when(&signal);
//! assert!(!stop.is_set() && stop.flow() == Flow::Continue(()));
//! ctrl_c.store(true, Ordering::Relaxed);
//! assert!(stop.is_set() && stop.check().is_err());
//! assert!(!Stop::NEVER.is_set());
//! ```

use crate::error::{Error, Result};

/// What a sink answers after each result, and what a streaming call returns: `Continue` (go
/// on, or the call ran to its end) or `Break` (stop there, or the call ended early).
pub type Flow = std::ops::ControlFlow<()>;

/// A signal that a call should end early, such as a Ctrl-C seen by a front or a client that
/// went away. The engine's threads poll it between (and inside) the results they compute.
#[derive(Clone, Copy)]
pub struct Stop<'a>(Option<&'a (dyn Fn() -> bool + Sync)>);

impl Stop<'static> {
    /// The signal that is never set.
    pub const NEVER: Stop<'static> = Stop(None);
}

impl<'a> Stop<'a> {
    /// Returns the signal that is set whenever `signal` returns true.
    #[must_use]
    pub fn when(signal: &'a (dyn Fn() -> bool + Sync)) -> Self {
        Stop(Some(signal))
    }

    /// Returns whether the signal is set.
    #[must_use]
    pub fn is_set(self) -> bool {
        self.0.is_some_and(|signal| signal())
    }

    /// Returns `Break` when the signal is set, else `Continue`.
    pub fn flow(self) -> Flow {
        if self.is_set() {
            Flow::Break(())
        } else {
            Flow::Continue(())
        }
    }

    /// Returns [`Error::Stopped`] when the signal is set.
    ///
    /// # Errors
    /// [`Error::Stopped`] when set.
    pub fn check(self) -> Result<()> {
        if self.is_set() {
            Err(Error::Stopped)
        } else {
            Ok(())
        }
    }
}

impl std::fmt::Debug for Stop<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() {
            "Stop(signal)"
        } else {
            "Stop::NEVER"
        })
    }
}
