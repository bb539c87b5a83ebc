//! One interface over the three backends, so every caller (CLI, Python, tests, benches) can run any
//! of them, and the one policy that picks where a choice runs.

use crate::error::{Error, Param, Result};
use crate::gpu::{GpuContext, GpuOptions, context};
use crate::projection::gpu::{GpuBackend, SplatOptions};
use crate::projection::reduction::{MetricReduction, Reduction};
use crate::projection::{Batch, MetricColumns, PoseSource, PoseSweep, Projection, fast, reference};
use crate::sampling::Sampling;
use crate::stream::{Flow, Stop};

/// Which backend a user asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendChoice {
    /// The GPU when a hardware adapter exists, else the fast CPU path with a one-line notice. A
    /// software adapter such as lavapipe is slower than the CPU path on the same cores.
    Auto,
    /// The CPU reference (f64, one core, written to be obviously right).
    Cpu,
    /// The fast CPU path: the GPU's algorithm in f64 on every core.
    CpuFast,
    /// The GPU (WGSL through wgpu). Fails when no adapter exists.
    Gpu,
}

/// Where a [`BackendChoice`] runs: the CPU, or a GPU device that projections ([`Backend`]) and
/// masks ([`crate::masks::MaskEngine`]) can share. When `auto` fell back to the CPU, it says why.
#[derive(Debug)]
pub enum Device {
    /// The CPU, with the notice when `auto` found no usable GPU.
    Cpu(Option<Notice>),
    /// A GPU device.
    Gpu(Box<GpuContext>),
}

impl BackendChoice {
    /// Returns the device this choice runs on: the one selection policy of projections and masks.
    ///
    /// `auto` takes a hardware GPU adapter, else the CPU and says why. A software adapter
    /// (lavapipe, llvmpipe, WARP) runs on the same cores as the CPU path and measured several times
    /// slower than it (BENCHMARKS.md). A GPU is the process's one context for `gpu`
    /// ([`GpuContext::open`]). The CPU choices never look at `gpu`.
    ///
    /// # Errors
    /// [`Error::NoAdapter`], [`Error::InvalidValue`] (an option) or [`Error::Gpu`] when `Gpu`
    /// was chosen and cannot be had; an invalid option also with `Auto`.
    pub fn device(self, gpu: &GpuOptions) -> Result<Device> {
        match self {
            BackendChoice::Cpu | BackendChoice::CpuFast => Ok(Device::Cpu(None)),
            BackendChoice::Gpu => Ok(Device::Gpu(Box::new(GpuContext::open(gpu)?))),
            BackendChoice::Auto => {
                gpu.validate()?;
                let cpu = |why: Notice| Ok(Device::Cpu(Some(why)));
                match GpuContext::open(gpu) {
                    Ok(ctx) if ctx.is_software() => cpu(Notice::SoftwareAdapter(ctx.info().name.clone())),
                    Ok(ctx) => Ok(Device::Gpu(Box::new(ctx))),
                    Err(Error::NoAdapter { .. }) => cpu(Notice::NoAdapter),
                    Err(e) => cpu(Notice::GpuUnavailable(std::sync::Arc::new(e))),
                }
            }
        }
    }
}

/// Why a choice runs on the CPU although `auto` looked for a GPU. Each front says it in one line
/// its own way ([`Notice::render`]). `Display` names the GPU options neutrally.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub enum Notice {
    /// The only GPU adapter is a software one (named), slower than the CPU path.
    SoftwareAdapter(String),
    /// wgpu found no adapter.
    NoAdapter,
    /// The GPU could not be had: an adapter name that matches none, or a device that failed.
    GpuUnavailable(std::sync::Arc<Error>),
    /// The GPU mask engine does not take this sonar pair (a field of view of 180° or wider).
    MasksOnCpu(std::sync::Arc<Error>),
}

impl Notice {
    /// Returns the notice's line, `note: …`, short, with each GPU option named by `name`. Each
    /// front adds how its user chooses the CPU and so silences it.
    #[must_use]
    pub fn render(&self, name: &dyn Fn(Param) -> String) -> String {
        match self {
            // The adapter's name without its details: `llvmpipe (LLVM 15.0.6, 256 bits)` is
            // llvmpipe.
            Notice::SoftwareAdapter(adapter) => format!(
                "note: running on the CPU: the only GPU adapter ({}) is a software one, slower",
                adapter.split(" (").next().unwrap_or(adapter)
            ),
            Notice::NoAdapter => "note: running on the CPU: no GPU adapter found".to_string(),
            Notice::GpuUnavailable(e) => format!("note: running on the CPU: {}", e.render(name)),
            Notice::MasksOnCpu(e) => format!("note: drawing masks on the CPU: {}", e.render(name)),
        }
    }
}

impl std::fmt::Display for Notice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render(&|p| p.name().to_string()))
    }
}

/// What a projection returns besides its metrics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    /// The metrics only. The occupancy buffers are not kept, nor read back from the GPU.
    MetricsOnly,
    /// The metrics and each item's occupancy buffer.
    WithOccupancy,
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
    /// Returns the backend for `choice` (a GPU opened with `gpu`). When `auto` fell back to the
    /// CPU, it also returns a one-line notice saying why.
    ///
    /// # Errors
    /// As [`BackendChoice::device`]; [`Error::Gpu`] when the device refuses a stage.
    pub fn select(choice: BackendChoice, gpu: &GpuOptions) -> Result<(Backend, Option<Notice>)> {
        let backend = match choice.device(gpu)? {
            Device::Gpu(ctx) => {
                let variant = SplatOptions::for_adapter(&ctx, gpu);
                Backend::on(*ctx, variant)?
            }
            Device::Cpu(_) if choice == BackendChoice::Cpu => Backend::Cpu,
            Device::Cpu(notice) => return Ok((Backend::CpuFast, notice)),
        };
        Ok((backend, None))
    }

    /// Returns the GPU backend on the process's context for `gpu`, with the splat stage's
    /// variant `gpu` asks for.
    ///
    /// # Errors
    /// As [`GpuContext::open`] and [`GpuBackend::with_options`].
    pub fn gpu(gpu: &GpuOptions) -> Result<Backend> {
        let ctx = GpuContext::open(gpu)?;
        let variant = SplatOptions::for_adapter(&ctx, gpu);
        Backend::on(ctx, variant)
    }

    /// Returns the GPU backend on `ctx` (a device it may share with a mask engine), its splat
    /// stage built as `variant`.
    ///
    /// # Errors
    /// As [`GpuBackend::with_options`].
    pub fn on(ctx: GpuContext, variant: SplatOptions) -> Result<Backend> {
        Ok(Backend::Gpu(Box::new(GpuBackend::with_options(ctx, variant)?)))
    }

    /// Returns `"cpu"`, `"cpu-fast"` or `"gpu"`.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::CpuFast => "cpu-fast",
            Backend::Gpu(_) => "gpu",
        }
    }

    /// Returns the name for tables: [`Backend::name`], or `gpu-sw` for a software adapter
    /// (lavapipe, llvmpipe, WARP), whose speed says nothing of a real GPU's.
    #[must_use]
    pub fn label(&self) -> &'static str {
        match self {
            Backend::Gpu(g) if g.context().is_software() => "gpu-sw",
            b => b.name(),
        }
    }

    /// Returns a description of the device: the adapter for the GPU, the thread count for the
    /// fast CPU path ([`cpu_device`]).
    #[must_use]
    pub fn device(&self) -> String {
        match self {
            Backend::Cpu => "CPU reference (f64, one core)".to_string(),
            Backend::CpuFast => cpu_device(),
            Backend::Gpu(g) => format!(
                "{}, {} transform, {}",
                context::describe(g.context().info()),
                g.context().precision().name(),
                g.options().describe()
            ),
        }
    }

    /// Returns the settings that decide this backend's numbers, as `(name, value)` pairs. They are
    /// the backend and, for a GPU, its adapter (name, API, driver), the splat stage's precision and
    /// its options. Equal settings and equal inputs give equal results. The fast CPU path's results
    /// do not depend on its thread count.
    #[must_use]
    pub fn settings(&self) -> Vec<(&'static str, String)> {
        let mut out = vec![("backend", self.name().to_string())];
        if let Backend::Gpu(g) = self {
            let info = g.context().info();
            out.push((
                "adapter",
                format!("{} ({:?}, driver {})", info.name, info.backend, info.driver),
            ));
            out.push(("precision", g.context().precision().name().to_string()));
            out.push(("gpu options", g.options().describe()));
        }
        out
    }

    /// Returns the projections of every item of `batch`, in order.
    ///
    /// With [`Output::WithOccupancy`] each carries its occupancy buffer. An item that gives its
    /// feature's true point gets the local precision there ([`Projection::local`]).
    ///
    /// # Errors
    /// As [`Batch::prepare`]; [`Error::Gpu`] on device failure.
    pub fn project(&self, batch: &Batch, output: Output) -> Result<Vec<Projection>> {
        self.project_until(batch, output, Stop::NEVER)
    }

    /// Returns [`Backend::project`]'s projections, or gives up once `stop` is set.
    ///
    /// The fast CPU path asks `stop` before each pose and each tile of a large sampling; the
    /// reference and the GPU ask it before and after their work.
    ///
    /// # Errors
    /// As [`Backend::project`]; [`Error::Stopped`] when stopped.
    pub fn project_until(&self, batch: &Batch, output: Output, stop: Stop<'_>) -> Result<Vec<Projection>> {
        let prepared = batch.prepare()?;
        stop.check()?;
        let mut projected = match self {
            // Exact mode: the reference's solver on one core, its fast twin on every core, and the
            // GPU's exact stage where the device has f64 (else the fast twin).
            _ if prepared.is_exact() => match self {
                Backend::Cpu => crate::exact::project(&prepared, output, false, stop),
                Backend::Gpu(g) if g.solves_exact() => Some(g.project(&prepared, output)?),
                _ => crate::exact::project_fast(&prepared, output, stop),
            }
            .ok_or(Error::Stopped)?,
            Backend::Cpu => reference::project_until(&prepared, output, stop).ok_or(Error::Stopped)?,
            Backend::CpuFast => fast::project_until(&prepared, output, stop).ok_or(Error::Stopped)?,
            Backend::Gpu(g) => g.project(&prepared, output)?,
        };
        stop.check()?;
        prepared.add_local_precision(&mut projected);
        Ok(projected)
    }
}

/// Poses the per-item backends (the reference, the GPU) take at a time from a pose source in
/// [`Backend::project_columns`]. Their items and results stay small whatever the range.
const ITEMS_AT_ONCE: u64 = 1 << 16;

impl Backend {
    /// Writes the metrics of poses `range` of `sweep` into `out`, as columns.
    ///
    /// `out`'s rows are replaced and its memory kept: a caller going block by block allocates
    /// once. A grid's poses are decoded from their index where the work runs, with no per-pose
    /// object:
    /// - the fast CPU path decodes them in its loop (the same bits as [`Backend::project`] on
    ///   the poses' items);
    /// - the GPU decodes them in its poses stage (within the envelope of its per-item results);
    /// - the reference, and every backend for a list, takes the items 65 536 at a time.
    ///
    /// Pairs of poses and features ([`PosePairs`](crate::PosePairs)) take no per-pair object on
    /// the fast path and its exact twin, which compose each pose from the tables in their loops,
    /// nor on the GPU, which packs them a chunk at a time for its splat or exact stage (all the
    /// same bits as the pairs' items); the reference takes their items 65 536 at a time.
    ///
    /// # Errors
    /// As [`Backend::project`]; [`Error::InvalidValue`] for a range past the sweep's poses;
    /// [`Error::Stopped`] when `stop` was set (asked as [`Backend::project_until`] asks it).
    pub fn project_columns(
        &self,
        sweep: &PoseSweep<'_>,
        range: std::ops::Range<u64>,
        out: &mut MetricColumns,
        stop: Stop<'_>,
    ) -> Result<()> {
        let n = sweep.poses.len();
        if range.start > range.end || range.end > n {
            return Err(Error::invalid(
                "pose range",
                format!("{}..{}", range.start, range.end),
                format!("must lie within the sweep's {n} poses"),
            ));
        }
        // Exact mode on a grid: the fast twin decodes the poses on the CPU's cores, the GPU's
        // poses stage on the device (as sampled); the reference takes the items path.
        if let (PoseSource::Grid(grid), true) = (sweep.poses, sweep.sampling == Sampling::Exact) {
            match self {
                Backend::Gpu(g) if g.solves_exact() => {}
                Backend::Gpu(_) | Backend::CpuFast => {
                    let prepared = sweep.prepare_grid(grid)?;
                    return crate::exact::project_grid(&prepared, range, out, stop).ok_or(Error::Stopped);
                }
                Backend::Cpu => {}
            }
        }
        if let PoseSource::Grid(grid) = sweep.poses {
            match self {
                Backend::CpuFast => {
                    let prepared = sweep.prepare_grid(grid)?;
                    return fast::project_grid(&prepared, range, out, stop).ok_or(Error::Stopped);
                }
                Backend::Gpu(g) => {
                    let prepared = sweep.prepare_grid(grid)?;
                    stop.check()?;
                    g.project_grid(&prepared, range, out)?;
                    return stop.check();
                }
                Backend::Cpu => {}
            }
        }
        // Pairs from their tables: sampled, or solved exactly by a GPU with f64 and elsewhere by
        // the exact fast twin (as a grid); the reference takes the items path.
        if let PoseSource::Pairs(pairs) = sweep.poses {
            let exact = sweep.sampling == Sampling::Exact;
            match self {
                Backend::Gpu(g) if !exact || g.solves_exact() => {
                    let prepared = sweep.prepare_pairs(pairs)?;
                    stop.check()?;
                    g.project_pairs(&prepared, range, out)?;
                    return stop.check();
                }
                Backend::Gpu(_) | Backend::CpuFast => {
                    let prepared = sweep.prepare_pairs(pairs)?;
                    let done = if exact {
                        crate::exact::project_pairs(&prepared, range, out, stop)
                    } else {
                        fast::project_pairs(&prepared, range, out, stop)
                    };
                    return done.ok_or(Error::Stopped);
                }
                Backend::Cpu => {}
            }
        }
        out.clear();
        let mut start = range.start;
        while start < range.end {
            let end = range.end.min(start + ITEMS_AT_ONCE);
            // Metrics alone: a list's true points would cost a local precision the columns lack.
            let mut batch = sweep.batch(start..end)?;
            batch.items.iter_mut().for_each(|i| i.true_point = None);
            for p in self.project_until(&batch, Output::MetricsOnly, stop)? {
                out.push(&p.metrics);
            }
            start = end;
        }
        Ok(())
    }
}

impl Backend {
    /// Projects poses `blocks` of `sweep` block by block, and hands each block's columns to
    /// `each` as soon as they are done: what a sweep does chunk after chunk.
    ///
    /// `blocks` are ranges in increasing order, none empty. `out` holds each block's rows in
    /// turn; they are [`Backend::project_columns`]'s for the same block. The stream ends early,
    /// returning `Break`, when `each` answers `Break` or `stop` is set ([`crate::stream`]). On
    /// the GPU the next block of a grid or of pairs is already on the device while `each` runs
    /// (when the device does the work: sampled, or exact on a device with f64): the device does
    /// not wait for the host between blocks. Pairs are prepared once a call.
    ///
    /// # Errors
    /// As [`Backend::project_columns`], but a set `stop` returns `Break` instead of
    /// [`Error::Stopped`]; [`Error::InvalidValue`] for blocks empty, out of order or past the
    /// sweep's poses.
    pub fn project_blocks(
        &self,
        sweep: &PoseSweep<'_>,
        blocks: &[std::ops::Range<u64>],
        out: &mut MetricColumns,
        stop: Stop<'_>,
        each: &mut dyn FnMut(std::ops::Range<u64>, &MetricColumns) -> Flow,
    ) -> Result<Flow> {
        check_blocks(sweep, blocks)?;
        if blocks.is_empty() {
            return Ok(Flow::Continue(()));
        }
        if let (Backend::Gpu(g), PoseSource::Grid(grid)) = (self, sweep.poses)
            && (sweep.sampling != Sampling::Exact || g.solves_exact())
        {
            let prepared = sweep.prepare_grid(grid)?;
            if stop.is_set() {
                return Ok(Flow::Break(()));
            }
            return g.project_grid_blocks(&prepared, blocks, out, &mut |b, columns| {
                stop.flow()?;
                each(b, columns)
            });
        }
        if let (Backend::Gpu(g), PoseSource::Pairs(pairs)) = (self, sweep.poses)
            && (sweep.sampling != Sampling::Exact || g.solves_exact())
        {
            let prepared = sweep.prepare_pairs(pairs)?;
            if stop.is_set() {
                return Ok(Flow::Break(()));
            }
            return g.project_pairs_blocks(&prepared, blocks, out, &mut |b, columns| {
                stop.flow()?;
                each(b, columns)
            });
        }
        // The CPU's twins prepare pairs once, not once a block.
        if let (Backend::CpuFast | Backend::Gpu(_), PoseSource::Pairs(pairs)) = (self, sweep.poses) {
            let prepared = sweep.prepare_pairs(pairs)?;
            let exact = sweep.sampling == Sampling::Exact;
            for b in blocks {
                let done = if exact {
                    crate::exact::project_pairs(&prepared, b.clone(), out, stop)
                } else {
                    fast::project_pairs(&prepared, b.clone(), out, stop)
                };
                if done.is_none() || each(b.clone(), out).is_break() {
                    return Ok(Flow::Break(()));
                }
            }
            return Ok(Flow::Continue(()));
        }
        for b in blocks {
            match self.project_columns(sweep, b.clone(), out, stop) {
                Err(Error::Stopped) => return Ok(Flow::Break(())),
                other => other?,
            }
            if each(b.clone(), out).is_break() {
                return Ok(Flow::Break(()));
            }
        }
        Ok(Flow::Continue(()))
    }
}

impl Backend {
    /// Returns whether [`Backend::reduce_blocks`] reduces `sweep` here: on a GPU whose device has
    /// f64, 64-bit integers and their atomics in shaders, over a grid (solved exactly only where the
    /// GPU solves exact calls itself). Elsewhere a caller projects columns and reduces them.
    #[must_use]
    pub fn reduces_on_device(&self, sweep: &PoseSweep<'_>) -> bool {
        match (self, sweep.poses) {
            (Backend::Gpu(g), PoseSource::Grid(_)) => {
                g.reduces() && (sweep.sampling != Sampling::Exact || g.solves_exact())
            }
            _ => false,
        }
    }

    /// Reduces one metric over poses `blocks` of `sweep` on the device, block by block, and hands
    /// each block's [`Reduction`] to `each` as soon as it is done. No per-pose metric is read back:
    /// only the block's counts, histogram, cells and its smallest and largest poses.
    ///
    /// `blocks` are as [`Backend::project_blocks`] takes them. The stream ends early, returning
    /// `Break`, when `each` answers `Break` or `stop` is set (looked at between blocks).
    ///
    /// # Errors
    /// [`Error::Input`] where [`Backend::reduces_on_device`] is false; as
    /// [`MetricReduction::validate`]; as [`Backend::project_blocks`].
    pub fn reduce_blocks(
        &self,
        sweep: &PoseSweep<'_>,
        blocks: &[std::ops::Range<u64>],
        reduction: &MetricReduction,
        stop: Stop<'_>,
        each: &mut dyn FnMut(std::ops::Range<u64>, &Reduction) -> Flow,
    ) -> Result<Flow> {
        let (Backend::Gpu(g), PoseSource::Grid(grid), true) =
            (self, sweep.poses, self.reduces_on_device(sweep))
        else {
            return Err(Error::Input {
                field: "reduce_blocks".into(),
                message: format!(
                    "{} cannot reduce this sweep on the device: project its columns and reduce them",
                    self.device()
                ),
            });
        };
        check_blocks(sweep, blocks)?;
        if blocks.is_empty() {
            return Ok(Flow::Continue(()));
        }
        let prepared = sweep.prepare_grid(grid)?;
        if stop.is_set() {
            return Ok(Flow::Break(()));
        }
        g.reduce_grid_blocks(&prepared, blocks, reduction, &mut |b, r| {
            stop.flow()?;
            each(b, r)
        })
    }
}

/// Checks that `blocks` are non-empty, in increasing order and within `sweep`'s poses.
///
/// # Errors
/// [`Error::InvalidValue`] naming the first block that is not.
fn check_blocks(sweep: &PoseSweep<'_>, blocks: &[std::ops::Range<u64>]) -> Result<()> {
    let n = sweep.poses.len();
    let mut end = 0;
    for b in blocks {
        if b.start < end || b.start >= b.end || b.end > n {
            return Err(Error::invalid(
                "pose blocks",
                format!("{}..{}", b.start, b.end),
                format!("must be non-empty, in increasing order and within the sweep's {n} poses"),
            ));
        }
        end = b.end;
    }
    Ok(())
}

/// Returns the description of the CPU cores the fast path and the CPU mask engine run on:
/// "CPU, 2 threads (f64)" ("1 thread" on one).
#[must_use]
pub fn cpu_device() -> String {
    let n = rayon::current_num_threads();
    format!("CPU, {n} thread{} (f64)", if n == 1 { "" } else { "s" })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bad option is an input error naming it, before any adapter is looked for. This holds for
    /// `gpu` and for `auto` alike: `auto` falls back to the CPU only when no usable GPU exists, not
    /// on bad input. The CPU choices never look at the options.
    #[test]
    fn bad_gpu_options_are_input_errors() {
        let bad = GpuOptions {
            workgroup: Some(100),
            ..GpuOptions::default()
        };
        for choice in [BackendChoice::Gpu, BackendChoice::Auto] {
            let e = choice.device(&bad).unwrap_err();
            assert!(
                e.is_input() && e.to_string().contains("workgroup"),
                "{choice:?}: {e}"
            );
        }
        for choice in [BackendChoice::Cpu, BackendChoice::CpuFast] {
            assert!(matches!(choice.device(&bad), Ok(Device::Cpu(None))));
        }
    }
}
