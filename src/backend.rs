//! One interface over the two backends, so every caller (CLI, tests, benches) can run either.

use crate::batch::{Batch, Projection};
use crate::cpu;
use crate::error::{Error, Result};
use crate::gpu::{GpuBackend, GpuContext, context};

/// Which backend a user asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendChoice {
    /// The GPU when an adapter exists, else the CPU reference (with a notice).
    Auto,
    /// The CPU reference (f64).
    Cpu,
    /// The GPU (WGSL through wgpu); fails when no adapter exists.
    Gpu,
}

/// A backend ready to run batches.
#[derive(Debug)]
pub enum Backend {
    /// The CPU reference.
    Cpu,
    /// The GPU, with its pipelines built.
    Gpu(Box<GpuBackend>),
}

impl Backend {
    /// Returns the backend for `choice` and, when `auto` fell back to the CPU, a one-line notice
    /// saying so.
    ///
    /// # Errors
    /// [`Error::NoAdapter`] or [`Error::Gpu`] when `gpu` was asked for and cannot be had.
    pub fn select(choice: BackendChoice) -> Result<(Backend, Option<String>)> {
        match choice {
            BackendChoice::Cpu => Ok((Backend::Cpu, None)),
            BackendChoice::Gpu => Ok((Backend::gpu()?, None)),
            BackendChoice::Auto => match Backend::gpu() {
                Ok(b) => Ok((b, None)),
                Err(Error::NoAdapter { .. }) => Ok((
                    Backend::Cpu,
                    Some(
                        "note: no GPU adapter found, running on the CPU reference (for the GPU \
                         path install a Vulkan driver; apt-get install mesa-vulkan-drivers gives \
                         lavapipe)"
                            .into(),
                    ),
                )),
                Err(e) => Ok((
                    Backend::Cpu,
                    Some(format!("note: {e}; running on the CPU reference")),
                )),
            },
        }
    }

    /// Returns the GPU backend on the adapter `auto` would pick.
    ///
    /// # Errors
    /// [`Error::NoAdapter`] or [`Error::Gpu`].
    pub fn gpu() -> Result<Backend> {
        Ok(Backend::Gpu(Box::new(GpuBackend::new(GpuContext::new()?))))
    }

    /// Returns `"cpu"` or `"gpu"`.
    pub fn name(&self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::Gpu(_) => "gpu",
        }
    }

    /// Returns a description of the device: the adapter for the GPU.
    pub fn device(&self) -> String {
        match self {
            Backend::Cpu => "CPU reference (f64)".to_string(),
            Backend::Gpu(g) => format!(
                "{}, {} transform",
                context::describe(&g.context().info),
                g.context().precision.name()
            ),
        }
    }

    /// Returns the projections of every item of `batch`, in order; with `keep_occupancy` each
    /// carries its occupancy buffer.
    ///
    /// # Errors
    /// Invalid sampling; [`Error::Gpu`] on device failure.
    pub fn project(&self, batch: &Batch, keep_occupancy: bool) -> Result<Vec<Projection>> {
        let prepared = batch.prepare()?;
        match self {
            Backend::Cpu => Ok(cpu::project(&prepared, keep_occupancy)),
            Backend::Gpu(g) => g.project(&prepared, keep_occupancy),
        }
    }
}
