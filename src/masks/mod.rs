//! Correspondence masks: for each feature measured by sonar 1, the bins or pixels of sonar 2
//! where it can be.
//!
//! Masks are conservative, so the true pixel is never missed. A mask is drawn in three steps:
//!
//! 1. The back-projected set (an FLS arc or an SSS surface; docs/commands.md, `--step`) is cut
//!    into cells of an angle grid that tiles sonar 1's aperture exactly. At range `r` there are
//!    `n_e` elevation cells, and for an SSS also `n_a` azimuth cells. Every point of a cell lies
//!    within `h = r·√((Δa/2)² + (Δe/2)²)` of the cell's centre point. The path along the sphere
//!    in a straight line of the angles is at most that long, and the straight chord is shorter.
//! 2. A rigid pose keeps distances. So in sonar 2, every point of the cell lies in the ball of
//!    radius `h` around the centre's image `q`. The mask marks every bin or pixel that ball may
//!    touch inside sonar 2's field of view. That is range bins over `[|q| − h, |q| + h]`, and for
//!    an FLS beams over `az(q) ± asin(h/ρ)`, where `ρ` is the distance from sonar 2's vertical
//!    axis (every beam when `h ≥ ρ`). Balls that cannot touch the field of view are skipped. The
//!    tests only ever keep too many: `|q_z| ≤ tan(e)(ρ + h) + h`, `|q_y| ≤ tan(a)(q_x + h) + h`.
//! 3. Cells are sized so that `h` is half a range bin of sonar 2 (more under noise, below). The
//!    mask is then at most about one bin wider on each side than the exact image, and has no
//!    holes. Cells are visited in blocks, and each block's own ball is tested first. So parts of
//!    the set far outside sonar 2's view cost one test per block.
//!
//! Under noise ([`Noise`]) the ball grows by a radius `D` that holds with probability at least
//! `coverage`: see [`Noise::radius`].
//!
//! Modules: `plan` (cells, blocks, the view test), `cpu` (drawing in f64), `gpu` (drawing with
//! `shaders/mask.wgsl`), [`noise`], and [`summary`] (bounding box, run lengths). This module
//! holds the engine that picks between them.

mod cpu;
pub(crate) mod gpu;
pub mod noise;
pub(crate) mod plan;
pub mod summary;

use rayon::prelude::*;

use crate::clip::View;
use crate::error::{Error, Result};
use crate::geometry::{RelativePose, Sonar};
use crate::gpu::{GpuContext, GpuOptions};
pub use crate::limits::MAX_CELLS;
use crate::limits::{MAX_MASK_BITSET_BYTES, MAX_PING_FEATURES};
use crate::occupancy::{Layout, Occupancy};
use crate::projection::{BackendChoice, Device, Notice};
use crate::sampling::Measurement;
use crate::stream::{Flow, Stop};
use gpu::{GpuMasks, Job};
pub use noise::Noise;
use plan::Plan;
pub use summary::{BoundingBox, FeatureSummary, PingSummary, bounding_box, run_lengths};
use summary::{Reduced, mask_reduce};

/// The fewest cells a ping needs for an `auto` engine to draw it on the GPU. Below it, the CPU
/// engine answers sooner. On an H200 with 16 CPU cores (`sonarproj bench masks`), a GPU ping
/// costs at least about 0.09 ms, which the CPU engine spends on about 1000 cells on one core.
/// A 52-cell imaging-sonar feature takes 0.001–0.002 ms on the CPU and 0.09–0.12 ms on the GPU.
/// A 2172-cell sidescan feature takes 0.15–0.20 ms on the CPU and 0.10 ms on the GPU.
pub const GPU_MIN_CELLS: u64 = 1024;

/// One feature's mask in sonar 2's layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    /// The bins or pixels where the feature can be, in the order of the sonar's data. For a
    /// two-sided sidescan, one row holds both sides ([`Layout::to_data_order`]).
    pub occupancy: Occupancy,
    /// How many cells of the back-projected set may fall in each bin or pixel, in the order of the
    /// sonar's data. A prior for a matcher, present only when asked for.
    pub counts: Option<Vec<u32>>,
    /// The ball radius used (m): half a cell's diagonal plus the noise radius.
    pub radius: f64,
    /// The noise radius `D` (m), 0 without noise.
    pub noise_radius: f64,
    /// The cells the set was cut into.
    pub cells: u64,
}

impl Mask {
    /// Returns the masks the GPU drew in `layout` for `jobs`, in the order of the sonar's data.
    /// `drawn` holds one occupancy per job, in order.
    fn of_gpu(layout: &Layout, drawn: Vec<Occupancy>, jobs: &[Job]) -> Vec<Mask> {
        drawn
            .into_iter()
            .zip(jobs)
            .map(|(occupancy, Job { plan, .. })| Mask {
                occupancy: layout.to_data_order(occupancy),
                counts: None,
                radius: plan.radius,
                noise_radius: plan.noise_radius,
                cells: plan.cells.count(),
            })
            .collect()
    }
}

/// The masks of a ping's features and their union.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskSet {
    /// One mask per feature, in order.
    pub masks: Vec<Mask>,
    /// Every pixel any feature may occupy.
    pub union: Occupancy,
}

/// Whether masks carry per-pixel counts, which are drawn on the CPU only. A count says how many
/// cells of the back-projected set may fall in a pixel: a prior for a matcher.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Counts {
    /// The bits only.
    Skip,
    /// The bits and the counts.
    Draw,
}

/// The engine that draws masks for one sonar pair. It is built once and used for every ping.
///
/// ```
/// use sonarproj::masks::{Counts, MaskEngine};
/// use sonarproj::{Measurement, RelativePose, Rotation, Sonar};
///
/// let engine = MaskEngine::new(
///     Sonar::preset("holoocean-sidescan").unwrap(),
///     Sonar::preset("holoocean-imaging").unwrap(),
/// )?;
/// let pose = RelativePose::new(Rotation::RollPitchYaw { roll: 0.0, pitch: 5.0, yaw: 10.0 }, [0.3, 0.2, -0.1])?;
/// let ping = [Measurement::of(engine.source(), 4.0, 0.0)?];
/// let set = engine.masks(&pose, &ping, None, Counts::Skip)?;
/// // A few hundred of the imaging sonar's 512 × 512 pixels can hold the feature.
/// let pixels = set.masks[0].occupancy.count();
/// assert!(pixels > 100 && pixels < 5_000, "{pixels}");
/// # Ok::<(), sonarproj::Error>(())
/// ```
///
/// It draws on the CPU (all cores, f64) by default. [`MaskEngine::on_gpu`] draws with
/// `shaders/mask.wgsl` instead.
#[derive(Debug)]
pub struct MaskEngine {
    source: Sonar,
    target: Sonar,
    view: View,
    gpu: Option<Box<GpuMasks>>,
    /// Pings of fewer cells are drawn on the CPU even with a GPU. 0 means never; `auto` sets
    /// [`GPU_MIN_CELLS`].
    gpu_min_cells: u64,
    /// Cosines and sines of cell grids for the CPU's drawing, kept between pings.
    trig: cpu::TrigTables,
}

impl MaskEngine {
    /// Returns the engine for features measured by `source` and looked for in `target`,
    /// drawing on the CPU.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when either sonar is invalid ([`Sonar::validate`]).
    pub fn new(source: Sonar, target: Sonar) -> Result<MaskEngine> {
        source.validate().map_err(|e| e.in_context("sonar 1"))?;
        target.validate().map_err(|e| e.in_context("sonar 2"))?;
        Ok(MaskEngine {
            view: View::of(&target),
            source,
            target,
            gpu: None,
            gpu_min_cells: 0,
            trig: cpu::TrigTables::default(),
        })
    }

    /// Returns the engine drawing its masks on the GPU of `ctx`. The pipeline and buffers are built
    /// once and kept between pings.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when sonar 2's azimuth aperture is 180° or more. The GPU's beam
    /// search needs less; the CPU engine has no such limit.
    pub fn on_gpu(source: Sonar, target: Sonar, ctx: GpuContext) -> Result<MaskEngine> {
        let mut engine = MaskEngine::new(source, target)?;
        engine.gpu = Some(Box::new(GpuMasks::new(ctx, &engine.view.layout)?));
        Ok(engine)
    }

    /// Returns the engine `choice` asks for (a GPU opened with `gpu`), and a one-line notice when
    /// `auto` fell back to the CPU. For masks, `cpu` and `cpu-fast` are one engine (f64, every
    /// core). `auto` takes a hardware GPU, but the CPU when `counts` are wanted, since only the CPU
    /// draws them. On a GPU, `auto` still draws pings of fewer than [`GPU_MIN_CELLS`] cells on the
    /// CPU, where they finish sooner.
    ///
    /// # Errors
    /// [`Error::NoAdapter`] or [`Error::Gpu`] when `gpu` was asked for and cannot be had. Also
    /// those of [`MaskEngine::on_gpu`].
    pub fn select(
        source: Sonar,
        target: Sonar,
        choice: BackendChoice,
        counts: Counts,
        gpu: &GpuOptions,
    ) -> Result<(MaskEngine, Option<Notice>)> {
        if counts == Counts::Draw && choice == BackendChoice::Auto {
            return Ok((MaskEngine::new(source, target)?, None));
        }
        match choice.device(gpu)? {
            Device::Cpu(notice) => Ok((MaskEngine::new(source, target)?, notice)),
            Device::Gpu(ctx) if choice == BackendChoice::Gpu => {
                Ok((MaskEngine::on_gpu(source, target, *ctx)?, None))
            }
            Device::Gpu(ctx) => match MaskEngine::on_gpu(source.clone(), target.clone(), *ctx) {
                Ok(mut engine) => {
                    engine.gpu_min_cells = GPU_MIN_CELLS;
                    Ok((engine, None))
                }
                // A field of view the GPU engine does not take (180° or wider).
                Err(e) => {
                    let notice = Notice::MasksOnCpu(std::sync::Arc::new(e));
                    Ok((MaskEngine::new(source, target)?, Some(notice)))
                }
            },
        }
    }

    /// Returns this engine drawing each ping of fewer than `cells` cells on the CPU, as `auto` does
    /// with [`GPU_MIN_CELLS`]. This applies to a GPU engine only. 0, the default of
    /// [`MaskEngine::on_gpu`], sends every ping to the GPU.
    #[must_use]
    pub fn with_gpu_min_cells(mut self, cells: u64) -> MaskEngine {
        self.gpu_min_cells = cells;
        self
    }

    /// Returns whether masks are drawn on a GPU.
    #[must_use]
    pub fn draws_on_gpu(&self) -> bool {
        self.gpu.is_some()
    }

    /// Returns a description of where masks are drawn.
    #[must_use]
    pub fn device(&self) -> String {
        match &self.gpu {
            Some(g) => g.describe(),
            None => crate::projection::cpu_device(),
        }
    }

    /// Returns sonar 1.
    #[must_use]
    pub fn source(&self) -> &Sonar {
        &self.source
    }

    /// Returns sonar 2.
    #[must_use]
    pub fn target(&self) -> &Sonar {
        &self.target
    }

    /// Returns sonar 2's layout.
    #[must_use]
    pub fn layout(&self) -> &Layout {
        &self.view.layout
    }

    /// Returns the masks of `features` (measured by sonar 1) under `pose`, widened for `noise`,
    /// with per-pixel counts when `counts`. Features are drawn in parallel.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for a feature outside sonar 1's field of view, invalid noise, a
    /// set that would need more than [`MAX_CELLS`] cells, more than [`MAX_PING_FEATURES`]
    /// features, or masks past [`MAX_MASK_BITSET_BYTES`] of bitsets (summaries hold none).
    pub fn masks(
        &self,
        pose: &RelativePose,
        features: &[Measurement],
        noise: Option<&Noise>,
        counts: Counts,
    ) -> Result<MaskSet> {
        pose.validate()?;
        let noise = noise.map(|n| n.validated()).transpose()?;
        if self.gpu.is_some() && counts == Counts::Draw {
            return Err(Error::invalid(
                "counts",
                "on the GPU",
                "per-pixel counts are drawn on the CPU only",
            ));
        }
        self.check_bitsets("features", features.len(), 1, counts == Counts::Draw)?;
        let plans = self.plans(features, noise.as_ref())?;
        if let Some(gpu) = self.gpu_for(&plans) {
            let jobs = Self::jobs(pose, plans);
            let drawn = gpu.draw(&self.view.layout, &jobs, true)?;
            let layout = &self.view.layout;
            return Ok(MaskSet {
                masks: Mask::of_gpu(layout, drawn.masks.unwrap_or_default(), &jobs),
                union: layout.to_data_order(drawn.union),
            });
        }
        let masks = plans
            .par_iter()
            .map(|plan| self.draw_cpu(pose, plan, counts))
            .collect();
        Ok(self.with_union(masks))
    }

    /// Returns the masks of `features` under `pose`, widened for `noise`, reduced to what a matcher
    /// looks at first: each mask's pixel count and bounding box, and their union. On a GPU the
    /// reduction runs there (`shaders/mask_reduce.wgsl`), and only the union and 20 bytes a feature
    /// are read back. The CPU engine reduces its masks the same way. The counts, boxes and union
    /// equal those of [`MaskEngine::masks`] on the same engine.
    ///
    /// # Errors
    /// As [`MaskEngine::masks`].
    pub fn summary(
        &self,
        pose: &RelativePose,
        features: &[Measurement],
        noise: Option<&Noise>,
    ) -> Result<PingSummary> {
        pose.validate()?;
        let noise = noise.map(|n| n.validated()).transpose()?;
        let plans = self.plans(features, noise.as_ref())?;
        if let Some(gpu) = self.gpu_for(&plans) {
            let jobs = Self::jobs(pose, plans);
            let drawn = gpu.draw(&self.view.layout, &jobs, false)?;
            return Ok(self.summary_of_gpu(drawn, &jobs));
        }
        Ok(self.summary_on_cpu(pose, &plans))
    }

    /// Returns the summaries of many pings, one pose and one set of features each, as each ping's
    /// [`MaskEngine::summary`]. On a GPU two pings are in flight: the next is planned, uploaded and
    /// submitted while the GPU draws the one before. Pings go in groups of 64, and `stop` is asked
    /// before each group.
    ///
    /// # Errors
    /// As [`MaskEngine::masks`], naming the ping (counted from 1). [`Error::Stopped`] when `stop`
    /// was set.
    pub fn summaries_of_pings(
        &self,
        pings: &[(RelativePose, Vec<Measurement>)],
        noise: Option<&Noise>,
        stop: Stop<'_>,
    ) -> Result<Vec<PingSummary>> {
        self.check_bitsets("pings", 0, pings.len(), false)?;
        let mut out = Vec::with_capacity(pings.len());
        let flow = self.summaries_of_pings_each(pings, noise, stop, &mut |s| {
            out.push(s);
            Ok(Flow::Continue(()))
        })?;
        if flow.is_break() {
            return Err(Error::Stopped);
        }
        Ok(out)
    }

    /// Gives `each` each ping's summary, as [`MaskEngine::summaries_of_pings`] computes it, in
    /// order and as soon as it is read back. Stops when `each` answers `Break` or `stop` is set
    /// (asked before each group of 64 pings), and then returns `Break` ([`crate::stream`]).
    ///
    /// # Errors
    /// As [`MaskEngine::summaries_of_pings`], and `each`'s errors (which stop it).
    pub fn summaries_of_pings_each(
        &self,
        pings: &[(RelativePose, Vec<Measurement>)],
        noise: Option<&Noise>,
        stop: Stop<'_>,
        each: &mut dyn FnMut(PingSummary) -> Result<Flow>,
    ) -> Result<Flow> {
        self.of_pings(
            pings,
            noise,
            stop,
            false,
            &|drawn, jobs| self.summary_of_gpu(drawn, jobs),
            &|pose, plans| self.summary_on_cpu(pose, plans),
            each,
        )
    }

    /// Returns the masks of many pings, one pose and one set of features each, as each ping's
    /// [`MaskEngine::masks`] without counts. On a GPU two pings are in flight, as in
    /// [`MaskEngine::summaries_of_pings`]. `stop` is asked before each group of 64 pings.
    ///
    /// # Errors
    /// As [`MaskEngine::summaries_of_pings`].
    pub fn masks_of_pings(
        &self,
        pings: &[(RelativePose, Vec<Measurement>)],
        noise: Option<&Noise>,
        stop: Stop<'_>,
    ) -> Result<Vec<MaskSet>> {
        let features = pings.iter().map(|(_, f)| f.len()).sum();
        self.check_bitsets("pings", features, pings.len(), false)?;
        let mut out = Vec::with_capacity(pings.len());
        let flow = self.masks_of_pings_each(pings, noise, stop, &mut |set| {
            out.push(set);
            Ok(Flow::Continue(()))
        })?;
        if flow.is_break() {
            return Err(Error::Stopped);
        }
        Ok(out)
    }

    /// Gives `each` the masks of each ping of `pings` in order, as soon as they are read back.
    /// Masks are as [`MaskEngine::masks_of_pings`] computes them, and at most one group of 64
    /// pings' masks is held at a time. It stops when `each` answers `Break` or `stop` is set
    /// (asked before each group), and then returns `Break` ([`crate::stream`]).
    ///
    /// # Errors
    /// As [`MaskEngine::masks_of_pings`], and `each`'s errors (which stop it).
    pub fn masks_of_pings_each(
        &self,
        pings: &[(RelativePose, Vec<Measurement>)],
        noise: Option<&Noise>,
        stop: Stop<'_>,
        each: &mut dyn FnMut(MaskSet) -> Result<Flow>,
    ) -> Result<Flow> {
        let layout = &self.view.layout;
        self.of_pings(
            pings,
            noise,
            stop,
            true,
            &|drawn, jobs| MaskSet {
                masks: Mask::of_gpu(layout, drawn.masks.unwrap_or_default(), jobs),
                union: layout.to_data_order(drawn.union),
            },
            &|pose, plans| {
                let masks = plans
                    .par_iter()
                    .map(|plan| self.draw_cpu(pose, plan, Counts::Skip))
                    .collect();
                self.with_union(masks)
            },
            each,
        )
    }

    /// Gives `emit` each ping of `pings` in order, as `on_gpu` (its drawing and jobs, with masks
    /// read back when `masks`) or `on_cpu` (its pose and plans) makes it. Pings go in groups of
    /// 64, with two dispatches in flight on a GPU, and `stop` is asked before each group.
    #[expect(
        clippy::too_many_arguments,
        reason = "the two ways a ping is drawn, and where it goes"
    )]
    fn of_pings<T>(
        &self,
        pings: &[(RelativePose, Vec<Measurement>)],
        noise: Option<&Noise>,
        stop: Stop<'_>,
        masks: bool,
        on_gpu: &dyn Fn(gpu::Drawn, &[Job]) -> T,
        on_cpu: &dyn Fn(&RelativePose, &[Plan]) -> T,
        emit: &mut dyn FnMut(T) -> Result<Flow>,
    ) -> Result<Flow> {
        let noise = noise.map(|n| n.validated()).transpose()?;
        for (g, group) in pings.chunks(64).enumerate() {
            if stop.is_set() {
                return Ok(Flow::Break(()));
            }
            let mut planned = Vec::with_capacity(group.len());
            for (k, (pose, features)) in group.iter().enumerate() {
                let ping = |e: Error| e.in_context(format!("ping {}", 64 * g + k + 1));
                pose.validate().map_err(ping)?;
                if masks {
                    self.check_bitsets("features", features.len(), 1, false)
                        .map_err(ping)?;
                }
                planned.push((pose, self.plans(features, noise.as_ref()).map_err(ping)?));
            }
            // The GPU takes every ping but those too small under `auto`. Its pings become jobs.
            let gpu_takes: Vec<bool> = planned
                .iter()
                .map(|(_, plans)| self.gpu_for(plans).is_some())
                .collect();
            let jobs: Vec<Vec<Job>> = planned
                .iter_mut()
                .zip(&gpu_takes)
                .filter(|(_, gpu)| **gpu)
                .map(|((pose, plans), _)| Self::jobs(pose, std::mem::take(plans)))
                .collect();
            // Pings go out in order, each as soon as it is drawn. A GPU ping goes when it is
            // read back, while the next one draws. The CPU's pings before it go first.
            let gpu_pings: Vec<usize> = (0..planned.len()).filter(|&k| gpu_takes[k]).collect();
            let mut next = 0;
            let cpu_until =
                |end: usize, next: &mut usize, emit: &mut dyn FnMut(T) -> Result<Flow>| -> Result<Flow> {
                    while *next < end {
                        let (pose, plans) = &planned[*next];
                        *next += 1;
                        if emit(on_cpu(pose, plans))?.is_break() {
                            return Ok(Flow::Break(()));
                        }
                    }
                    Ok(Flow::Continue(()))
                };
            if let Some(gpu) = self.gpu.as_deref()
                && !jobs.is_empty()
            {
                let refs: Vec<&[Job]> = jobs.iter().map(Vec::as_slice).collect();
                let flow = gpu.draw_pings(&self.view.layout, &refs, masks, &mut |j, drawn| {
                    if cpu_until(gpu_pings[j], &mut next, emit)?.is_break() {
                        return Ok(Flow::Break(()));
                    }
                    next += 1;
                    emit(on_gpu(drawn, &jobs[j]))
                })?;
                if flow.is_break() {
                    return Ok(flow);
                }
            }
            if cpu_until(planned.len(), &mut next, emit)?.is_break() {
                return Ok(Flow::Break(()));
            }
        }
        Ok(Flow::Continue(()))
    }

    /// Returns the summary of one feature: its reduced mask with the plan's radius and cells.
    fn feature_summary(&self, reduced: &Reduced, radius: f64, plan: &Plan) -> FeatureSummary {
        FeatureSummary {
            occupied: reduced.pixels,
            bounding_box: reduced
                .bounds
                .map(|(rows, beams)| BoundingBox::of_bins(&self.view.layout, rows, beams)),
            radius,
            noise_radius: plan.noise_radius,
            cells: plan.cells.count(),
        }
    }

    /// Returns the summary of a ping the GPU drew and reduced (`drawn`, of `jobs`).
    fn summary_of_gpu(&self, drawn: gpu::Drawn, jobs: &[Job]) -> PingSummary {
        let features = drawn
            .reduced
            .iter()
            .zip(jobs)
            .map(|(r, job)| self.feature_summary(r, job.plan.radius, &job.plan))
            .collect();
        PingSummary {
            features,
            union: self.view.layout.to_data_order(drawn.union),
        }
    }

    /// Returns the summary of the ping of `plans` under `pose`, drawn and reduced on the CPU.
    fn summary_on_cpu(&self, pose: &RelativePose, plans: &[Plan]) -> PingSummary {
        let layout = &self.view.layout;
        // Each mask is reduced and OR-ed into its thread's union as soon as it is drawn. So the
        // ping holds one union per thread, not one mask per feature.
        let empty = || Occupancy::new(layout.range_bins, layout.beams());
        let or_into = |u: &mut Occupancy, o: &Occupancy| {
            for (a, b) in u.words.iter_mut().zip(&o.words) {
                *a |= b;
            }
        };
        let (features, union) = plans
            .par_iter()
            .map(|plan| {
                let d = cpu::draw(&self.view, &self.trig, pose, plan, false);
                let r = mask_reduce(&d.occupancy.words, layout.beams());
                (vec![self.feature_summary(&r, d.radius, plan)], d.occupancy)
            })
            .reduce(
                || (Vec::new(), empty()),
                |(mut a, mut ua), (b, ub)| {
                    a.extend(b);
                    or_into(&mut ua, &ub);
                    (a, ua)
                },
            );
        PingSummary {
            features,
            union: layout.to_data_order(union),
        }
    }

    /// Returns the plans of `features` under `noise` (errors name the feature).
    fn plans(&self, features: &[Measurement], noise: Option<&Noise>) -> Result<Vec<Plan>> {
        if features.len() > MAX_PING_FEATURES {
            return Err(Error::invalid(
                "features",
                features.len(),
                format!("must be at most {MAX_PING_FEATURES} a ping: split it"),
            ));
        }
        features
            .iter()
            .enumerate()
            .map(|(k, m)| {
                plan::plan(&self.source, &self.view.layout, m, noise)
                    .map_err(|e| e.in_context(format!("feature {}", k + 1)))
            })
            .collect()
    }

    /// Returns the bytes of one mask held as a bitset: a bit per pixel of sonar 2, in 32-bit words.
    /// [`MAX_MASK_BITSET_BYTES`] counts these.
    #[must_use]
    pub fn bitset_bytes(&self) -> u64 {
        (self.view.layout.pixels() as u64).div_ceil(32) * 4
    }

    /// Returns an error when the masks would hold more than [`MAX_MASK_BITSET_BYTES`]. There are
    /// `features` masks (each with a `u32` count per pixel when `counts`) and `unions` unions, one
    /// bitset each. `what` names the input.
    fn check_bitsets(&self, what: &str, features: usize, unions: usize, counts: bool) -> Result<()> {
        let per = self.bitset_bytes();
        let per_feature = per
            + if counts {
                4 * self.view.layout.pixels() as u64
            } else {
                0
            };
        let bytes = (features as u64)
            .saturating_mul(per_feature)
            .saturating_add((unions as u64).saturating_mul(per));
        if bytes > MAX_MASK_BITSET_BYTES {
            return Err(Error::invalid(
                what,
                format!("{features} masks and {unions} unions"),
                format!(
                    "make {bytes} bytes ({per} a mask{}), more than the {MAX_MASK_BITSET_BYTES} \
                     one call holds: fewer at once",
                    if counts { ", and its counts" } else { "" }
                ),
            ));
        }
        Ok(())
    }

    /// Returns the GPU to draw `plans` on, or `None` for a CPU engine or for a ping smaller than
    /// the engine's `gpu_min_cells`.
    fn gpu_for(&self, plans: &[Plan]) -> Option<&GpuMasks> {
        let gpu = self.gpu.as_deref()?;
        let cells: u64 = plans.iter().map(|p| p.cells.count()).sum();
        (cells >= self.gpu_min_cells).then_some(gpu)
    }

    /// Returns the GPU's jobs of `plans` under `pose`.
    fn jobs(pose: &RelativePose, plans: Vec<Plan>) -> Vec<Job> {
        plans.into_iter().map(|plan| Job { pose: *pose, plan }).collect()
    }

    /// Returns the masks of many scenes at once, each feature with its own pose, without noise or
    /// counts. For tests and sweeps of scenes.
    ///
    /// # Errors
    /// As [`MaskEngine::masks`].
    pub fn masks_of_scenes(&self, scenes: &[(RelativePose, Measurement)]) -> Result<Vec<Mask>> {
        for (k, (pose, _)) in scenes.iter().enumerate() {
            pose.validate()
                .map_err(|e| e.in_context(format!("scene {}", k + 1)))?;
        }
        if let Some(gpu) = &self.gpu {
            let jobs = scenes
                .iter()
                .map(|(pose, m)| {
                    Ok(Job {
                        pose: *pose,
                        plan: plan::plan(&self.source, &self.view.layout, m, None)?,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            let drawn = gpu.draw(&self.view.layout, &jobs, true)?;
            return Ok(Mask::of_gpu(
                &self.view.layout,
                drawn.masks.unwrap_or_default(),
                &jobs,
            ));
        }
        scenes
            .par_iter()
            .map(|(pose, m)| self.mask(pose, m, None, Counts::Skip))
            .collect()
    }

    /// Returns `masks` with their union.
    fn with_union(&self, masks: Vec<Mask>) -> MaskSet {
        let (rows, columns) = self.view.layout.data_shape();
        let mut union = Occupancy::new(rows, columns);
        for m in &masks {
            for (u, w) in union.words.iter_mut().zip(&m.occupancy.words) {
                *u |= w;
            }
        }
        MaskSet { masks, union }
    }

    /// Returns the mask of one feature; see [`MaskEngine::masks`].
    ///
    /// # Errors
    /// As [`MaskEngine::masks`].
    pub fn mask(
        &self,
        pose: &RelativePose,
        m: &Measurement,
        noise: Option<&Noise>,
        counts: Counts,
    ) -> Result<Mask> {
        pose.validate()?;
        let plan = plan::plan(&self.source, &self.view.layout, m, noise)?;
        Ok(self.draw_cpu(pose, &plan, counts))
    }

    /// Returns the mask of `plan` under `pose` drawn on the CPU, in the order of the sonar's
    /// data.
    fn draw_cpu(&self, pose: &RelativePose, plan: &Plan, counts: Counts) -> Mask {
        let drawn = cpu::draw(&self.view, &self.trig, pose, plan, counts == Counts::Draw);
        let layout = &self.view.layout;
        Mask {
            occupancy: layout.to_data_order(drawn.occupancy),
            counts: drawn.counts.map(|c| layout.counts_to_data_order(c)),
            radius: drawn.radius,
            noise_radius: plan.noise_radius,
            cells: plan.cells.count(),
        }
    }
}
