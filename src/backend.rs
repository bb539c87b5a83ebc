//! One interface over the two backends, so every caller (CLI, tests, benches) can run either.

use crate::batch::{Batch, Projection};
use crate::error::{Error, Result};
use crate::gpu::{GpuBackend, GpuContext, context};
use crate::{cpu, cpu_fast};

/// Which backend a user asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendChoice {
    /// The GPU when a hardware adapter exists, else the fast CPU path (with a one-line notice;
    /// a software adapter such as lavapipe is slower than the CPU path on the same cores).
    Auto,
    /// The CPU reference (f64, one core, written to be obviously right).
    Cpu,
    /// The fast CPU path: the GPU's algorithm in f64 on every core.
    CpuFast,
    /// The GPU (WGSL through wgpu); fails when no adapter exists.
    Gpu,
}

/// A backend ready to run batches.
#[derive(Debug)]
pub enum Backend {
    /// The CPU reference.
    Cpu,
    /// The fast CPU path.
    CpuFast,
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
            BackendChoice::CpuFast => Ok((Backend::CpuFast, None)),
            BackendChoice::Gpu => Ok((Backend::gpu()?, None)),
            BackendChoice::Auto => {
                let cpu = |why: String| Ok((Backend::CpuFast, Some(format!("note: {why}"))));
                match GpuContext::new() {
                    // A software rasterizer (lavapipe, llvmpipe, WARP) runs on the same cores as
                    // the CPU path and is several times slower than it (BENCHMARKS.md).
                    Ok(ctx) if ctx.is_software() => cpu(format!(
                        "the only GPU adapter is a software one ({}), slower than the CPU path; \
                         running on the CPU (all cores; --backend gpu uses the adapter anyway)",
                        ctx.info.name
                    )),
                    Ok(ctx) => Ok((Backend::Gpu(Box::new(GpuBackend::new(ctx))), None)),
                    Err(Error::NoAdapter { .. }) => cpu(
                        "no GPU adapter found, running on the CPU (all cores; for the GPU path \
                         install a Vulkan driver)"
                            .into(),
                    ),
                    Err(e) => cpu(format!("{e}; running on the CPU (all cores)")),
                }
            }
        }
    }

    /// Returns the GPU backend on the adapter `auto` would pick.
    ///
    /// # Errors
    /// [`Error::NoAdapter`] or [`Error::Gpu`].
    pub fn gpu() -> Result<Backend> {
        Ok(Backend::Gpu(Box::new(GpuBackend::new(GpuContext::new()?))))
    }

    /// Returns `"cpu"`, `"cpu-fast"` or `"gpu"`.
    pub fn name(&self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::CpuFast => "cpu-fast",
            Backend::Gpu(_) => "gpu",
        }
    }

    /// Returns the name for tables: [`Backend::name`], with `gpu-sw` for a software adapter
    /// (lavapipe, llvmpipe, WARP), whose speed says nothing of a real GPU's.
    pub fn label(&self) -> &'static str {
        match self {
            Backend::Gpu(g) if g.context().is_software() => "gpu-sw",
            b => b.name(),
        }
    }

    /// Returns a description of the device: the adapter for the GPU.
    pub fn device(&self) -> String {
        match self {
            Backend::Cpu => "CPU reference (f64, one core)".to_string(),
            Backend::CpuFast => format!("CPU, {} threads (f64)", rayon::current_num_threads()),
            Backend::Gpu(g) => format!(
                "{}, {} transform, {}",
                context::describe(&g.context().info),
                g.context().precision.name(),
                g.options().describe()
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
            Backend::CpuFast => Ok(cpu_fast::project(&prepared, keep_occupancy)),
            Backend::Gpu(g) => g.project(&prepared, keep_occupancy),
        }
    }
}
