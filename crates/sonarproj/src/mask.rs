//! Correspondence masks: for each feature measured by sonar 1, the set of sonar 2's bins or
//! pixels where it can be, conservative so that the true pixel is never missed.
//!
//! How a mask is drawn (and why it cannot miss):
//! 1. The back-projected set (an FLS arc or an SSS surface, README: Commands, `--step`) is cut into cells of the
//!    angle grid that tile sonar 1's aperture exactly: `n_e` elevation cells (and for an SSS `n_a`
//!    azimuth cells) at range `r`. Every point of a cell lies within `h = r·√((Δa/2)² + (Δe/2)²)`
//!    of the cell's centre point (the path along the sphere in a straight line of the angles is at
//!    most that long, and the straight chord is shorter).
//! 2. A rigid pose keeps distances, so in sonar 2 every point of the cell lies in the ball of
//!    radius `h` around the centre's image `q`. The mask marks every bin or pixel that ball may
//!    touch inside sonar 2's field of view: range bins over `[|q| − h, |q| + h]`, and for an FLS
//!    beams over `az(q) ± asin(h/ρ)` (`ρ` the distance from sonar 2's vertical axis; every beam
//!    when `h ≥ ρ`). Balls that cannot touch the field of view are skipped, tested with bounds
//!    that only ever keep too many (`|q_z| ≤ tan(e)(ρ + h) + h`, `|q_y| ≤ tan(a)(q_x + h) + h`).
//! 3. Cells are sized so that `h` is half a range bin of sonar 2 (more under noise, below); the
//!    mask is then at most about one bin wider on each side than the exact image, and has no
//!    holes. Cells are visited in blocks whose own ball is tested first, so parts of the set far
//!    outside sonar 2's view cost one test per block.
//!
//! Under noise ([`Noise`]) the ball grows by a radius `D` that holds with probability at least
//! `coverage`: see [`Noise::radius`].

use rayon::prelude::*;
use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

use crate::ambiguity::Measurement;
use crate::backend::{BackendChoice, Device};
use crate::error::{Error, Result, finite};
use crate::gpu::GpuContext;
use crate::gpu::mask::{GpuMasks, Job, slack};
use crate::occupancy::{Layout, Occupancy};
use crate::pose::{RelativePose, sph_to_cart};
use crate::sonar::{Sonar, SonarKind};

/// Cells per block side (blocks are culled as a whole before their cells are visited). Keep in
/// sync with BLOCK in shaders/mask.wgsl.
pub(crate) const BLOCK: usize = 8;
/// The most cells one mask may visit.
pub const MAX_CELLS: u64 = 1 << 26;

/// Standard deviations of the pose and the measurement, and the probability the widened mask
/// must reach.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Noise {
    /// Roll, pitch, yaw (deg), or any small rotation about sonar 1's axes (per axis).
    pub rotation: [f64; 3],
    /// Translation x, y, z (m).
    pub translation: [f64; 3],
    /// Measured range (m).
    pub range: f64,
    /// Measured azimuth (deg); ignored for an SSS feature.
    pub azimuth: f64,
    /// The probability that the true pixel lies in the widened mask, in `(0, 1)`.
    pub coverage: f64,
}

impl Noise {
    /// Returns the noise checked: sigmas finite and `>= 0`, coverage in `(0, 1)`.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the sigma or `coverage`.
    pub fn validated(self) -> Result<Self> {
        let named = [
            ("sigma roll", self.rotation[0]),
            ("sigma pitch", self.rotation[1]),
            ("sigma yaw", self.rotation[2]),
            ("sigma tx", self.translation[0]),
            ("sigma ty", self.translation[1]),
            ("sigma tz", self.translation[2]),
            ("sigma range", self.range),
            ("sigma azimuth", self.azimuth),
        ];
        for (field, v) in named {
            finite(field, v)?;
            if v < 0.0 {
                return Err(Error::invalid(field, v, "must be >= 0"));
            }
        }
        finite("coverage", self.coverage)?;
        if !(self.coverage > 0.0 && self.coverage < 1.0) {
            return Err(Error::invalid(
                "coverage",
                self.coverage,
                "must be in (0, 1), e.g. 0.99",
            ));
        }
        Ok(self)
    }

    /// Returns the radius `D` (m) by which the true point's image in sonar 2 can lie away from
    /// the noise-free back-projection of measured range `r` (m), with probability at least
    /// `coverage`.
    ///
    /// The true point `P` and the point `P'` of the measured arc at `P`'s own elevation differ
    /// by at most `|δr| + (r + |δr|)·|δa|` (azimuth only for an FLS); the true pose moves `P` by
    /// at most `|δt| + (r + |δr|)·|δθ|` from where the nominal pose puts it, with
    /// `|δθ| ≤ |δroll| + |δpitch| + |δyaw|` (a telescoped product of small rotations). Each of
    /// the groups with a non-zero sigma (translation, rotation, range, azimuth) is bounded at
    /// probability `1 − (1 − coverage)/k` for `k` groups, so all bounds hold together with
    /// probability at least `coverage` (union bound): `|δt| ≤ max σ_t · χ₃`,
    /// `Σ|δθ_i| ≤ ‖σ_θ‖ · χ₃` (Cauchy–Schwarz), `|δr| ≤ σ_r · z`, `|δa| ≤ σ_a · z`, with `χ₃`
    /// and `z` the quantiles of the chi distribution with 3 degrees of freedom and of `|N(0,1)|`.
    /// The result is conservative: simulated coverage is higher than stated (tests/masks.rs).
    pub fn radius(&self, r: f64, source: SonarKind) -> f64 {
        let rot_norm = self
            .rotation
            .iter()
            .map(|s| s.to_radians().powi(2))
            .sum::<f64>()
            .sqrt();
        let t_max = self.translation.iter().fold(0.0f64, |a, &b| a.max(b));
        let az = match source {
            SonarKind::Fls => self.azimuth.to_radians(),
            SonarKind::Sss => 0.0,
        };
        let groups = [t_max, rot_norm, self.range, az]
            .iter()
            .filter(|s| **s > 0.0)
            .count();
        if groups == 0 {
            return 0.0;
        }
        let q = 1.0 - (1.0 - self.coverage) / groups as f64;
        let chi3 = ChiSquared::new(3.0).expect("3 dof").inverse_cdf(q).sqrt();
        let z = Normal::standard().inverse_cdf(0.5 + q / 2.0);
        let dr = self.range * z;
        let far = r + dr;
        t_max * chi3 + far * rot_norm * chi3 + dr + far * az * z
    }
}

/// One feature's mask in sonar 2's layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    /// The bins or pixels where the feature can be.
    pub occupancy: Occupancy,
    /// Per bin or pixel, how many cells of the back-projected set may fall there (a prior for a
    /// matcher), row-major; only when asked for.
    pub counts: Option<Vec<u32>>,
    /// The ball radius used (m): half a cell's diagonal plus the noise radius.
    pub radius: f64,
    /// The noise radius `D` (m), 0 without noise.
    pub noise_radius: f64,
    /// The cells the set was cut into.
    pub cells: u64,
}

/// The masks of a ping's features and their union.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskSet {
    /// One mask per feature, in order.
    pub masks: Vec<Mask>,
    /// Every pixel any feature may occupy.
    pub union: Occupancy,
}

/// Whether masks carry per-pixel counts (how many cells of the back-projected set may fall in
/// each pixel, a prior for a matcher), drawn on the CPU only.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Counts {
    /// The bits only.
    Skip,
    /// The bits and the counts.
    Draw,
}

/// Draws masks for one sonar pair; built once, used for every ping.
///
/// ```
/// use sonarproj::mask::{Counts, MaskEngine};
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
/// On the CPU (all cores, f64) by default; [`MaskEngine::on_gpu`] draws them with
/// `shaders/mask.wgsl` instead.
#[derive(Debug)]
pub struct MaskEngine {
    source: Sonar,
    target: Sonar,
    layout: Layout,
    tan_elevation: Option<f64>,
    tan_azimuth: Option<f64>,
    gpu: Option<Box<GpuMasks>>,
}

/// What one mask is drawn from: the cells of the set, their ball radius and the noise part of it.
pub(crate) struct Plan {
    /// The cells.
    pub cells: Cells,
    /// The set's range in sonar 1 (m).
    pub range: f64,
    /// Cell ball radius plus noise radius (m), without rounding slack.
    pub radius: f64,
    /// The noise radius (m).
    pub noise_radius: f64,
}

/// The cells of one back-projected set: angle grid and the radius of a cell's ball.
pub(crate) struct Cells {
    /// Cell-centre azimuths (rad, absolute in sonar 1).
    pub azimuths: Vec<f64>,
    /// Cell-centre elevations (rad).
    pub elevations: Vec<f64>,
    /// Half the cell's angular sizes `(Δa/2, Δe/2)` (rad).
    pub half: (f64, f64),
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
        let layout = Layout::of(&target);
        let tan = |h: f64| (h < std::f64::consts::FRAC_PI_2 - 1e-9).then(|| h.tan());
        Ok(MaskEngine {
            tan_elevation: tan(layout.half_elevation),
            tan_azimuth: tan(layout.half_azimuth),
            source,
            target,
            layout,
            gpu: None,
        })
    }

    /// Returns the engine drawing its masks on the GPU of `ctx` (pipeline and buffers built
    /// once, kept between pings).
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when sonar 2's azimuth aperture is 180° or more (the GPU's beam
    /// search needs less; the CPU engine has no such limit).
    pub fn on_gpu(source: Sonar, target: Sonar, ctx: GpuContext) -> Result<MaskEngine> {
        let mut engine = MaskEngine::new(source, target)?;
        engine.gpu = Some(Box::new(GpuMasks::new(ctx, &engine.layout)?));
        Ok(engine)
    }

    /// Returns the engine `choice` asks for and, when `auto` fell back to the CPU, a one-line
    /// notice saying so. `cpu` and `cpu-fast` are the same engine for masks (f64, every core);
    /// `auto` takes a hardware GPU, and the CPU when `counts` are wanted (drawn there only).
    ///
    /// # Errors
    /// [`Error::NoAdapter`] or [`Error::Gpu`] when `gpu` was asked for and cannot be had; as
    /// [`MaskEngine::on_gpu`].
    pub fn select(
        source: Sonar,
        target: Sonar,
        choice: BackendChoice,
        counts: Counts,
    ) -> Result<(MaskEngine, Option<String>)> {
        if counts == Counts::Draw && choice == BackendChoice::Auto {
            return Ok((MaskEngine::new(source, target)?, None));
        }
        match choice.device()? {
            Device::Cpu(notice) => Ok((MaskEngine::new(source, target)?, notice)),
            Device::Gpu(ctx) if choice == BackendChoice::Gpu => {
                Ok((MaskEngine::on_gpu(source, target, *ctx)?, None))
            }
            Device::Gpu(ctx) => match MaskEngine::on_gpu(source.clone(), target.clone(), *ctx) {
                Ok(engine) => Ok((engine, None)),
                // A field of view the GPU engine does not take (180° or wider).
                Err(e) => {
                    let notice = format!("note: {e}; drawing masks on the CPU");
                    Ok((MaskEngine::new(source, target)?, Some(notice)))
                }
            },
        }
    }

    /// Returns a description of where masks are drawn.
    pub fn device(&self) -> String {
        match &self.gpu {
            Some(g) => g.describe(),
            None => format!("CPU, {} threads (f64)", rayon::current_num_threads()),
        }
    }

    /// Returns sonar 1.
    pub fn source(&self) -> &Sonar {
        &self.source
    }

    /// Returns sonar 2.
    pub fn target(&self) -> &Sonar {
        &self.target
    }

    /// Returns sonar 2's layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Returns the masks of `features` (measured by sonar 1) under `pose`, widened for `noise`,
    /// with per-pixel counts when `counts`; features are drawn in parallel.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for a feature outside sonar 1's field of view, invalid noise, or a
    /// set that would need more than [`MAX_CELLS`] cells.
    pub fn masks(
        &self,
        pose: &RelativePose,
        features: &[Measurement],
        noise: Option<&Noise>,
        counts: Counts,
    ) -> Result<MaskSet> {
        pose.validate()?;
        let noise = noise.map(|n| n.validated()).transpose()?;
        if let Some(gpu) = &self.gpu {
            if counts == Counts::Draw {
                return Err(Error::invalid(
                    "counts",
                    "on the GPU",
                    "per-pixel counts are drawn on the CPU only",
                ));
            }
            let jobs = features
                .iter()
                .enumerate()
                .map(|(k, m)| {
                    let plan = self
                        .plan(m, noise.as_ref())
                        .map_err(|e| e.in_context(&format!("feature {}", k + 1)))?;
                    Ok(self.gpu_job(*pose, plan))
                })
                .collect::<Result<Vec<_>>>()?;
            let masks = gpu.draw(&self.layout, &jobs)?;
            return Ok(self.with_union(masks));
        }
        let masks = features
            .par_iter()
            .enumerate()
            .map(|(k, m)| {
                self.mask(pose, m, noise.as_ref(), counts)
                    .map_err(|e| e.in_context(&format!("feature {}", k + 1)))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(self.with_union(masks))
    }

    /// Returns the masks of many scenes at once, each feature with its own pose (for tests and
    /// sweeps of scenes); no noise, no counts.
    ///
    /// # Errors
    /// As [`MaskEngine::masks`].
    pub fn masks_of_scenes(&self, scenes: &[(RelativePose, Measurement)]) -> Result<Vec<Mask>> {
        for (k, (pose, _)) in scenes.iter().enumerate() {
            pose.validate()
                .map_err(|e| e.in_context(&format!("scene {}", k + 1)))?;
        }
        if let Some(gpu) = &self.gpu {
            let jobs = scenes
                .iter()
                .map(|(pose, m)| Ok(self.gpu_job(*pose, self.plan(m, None)?)))
                .collect::<Result<Vec<_>>>()?;
            return gpu.draw(&self.layout, &jobs);
        }
        scenes
            .par_iter()
            .map(|(pose, m)| self.mask(pose, m, None, Counts::Skip))
            .collect()
    }

    /// Returns the GPU's job for `plan` under `pose`: the blocks culled here, with the GPU's
    /// rounding slack.
    fn gpu_job(&self, pose: RelativePose, plan: Plan) -> Job {
        let extra = plan.noise_radius + slack(plan.range, &pose, &self.layout);
        let blocks = self.blocks(&pose, &plan.cells, plan.range, extra);
        Job { pose, plan, blocks }
    }

    /// Returns `masks` with their union.
    fn with_union(&self, masks: Vec<Mask>) -> MaskSet {
        let mut union = Occupancy::new(self.layout.range_bins, self.layout.beams());
        for m in &masks {
            for (u, w) in union.words.iter_mut().zip(&m.occupancy.words) {
                *u |= w;
            }
        }
        MaskSet { masks, union }
    }

    /// Returns the cells and radius of the mask of `m` (checked against sonar 1) under `noise`.
    pub(crate) fn plan(&self, m: &Measurement, noise: Option<&Noise>) -> Result<Plan> {
        let m = Measurement::of(&self.source, m.range, m.azimuth)?;
        let noise_radius = noise.map_or(0.0, |n| n.radius(m.range, self.source.kind));
        // Half a range bin, or a quarter of the noise radius when that is larger (a finer cell
        // would not make the widened mask noticeably smaller).
        let h_target = (self.layout.range_bin_width / 2.0).max(noise_radius / 4.0);
        let cells = self.cells(&m, h_target)?;
        let h = m.range * cells.half.0.hypot(cells.half.1);
        Ok(Plan {
            cells,
            range: m.range,
            radius: h + noise_radius,
            noise_radius,
        })
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
        let counts = counts == Counts::Draw;
        let Plan {
            cells,
            range: r,
            radius,
            noise_radius,
        } = self.plan(m, noise)?;
        // Slack for the rounding of q = R p + t and |q| in f64 (relative 1e-12 of the distances).
        let slack = 1e-12 * (r + pose.translation.length() + self.layout.range_max) + 1e-12;
        let radius = radius + slack;
        let (na, ne) = (cells.azimuths.len(), cells.elevations.len());
        let mut occ = Occupancy::new(self.layout.range_bins, self.layout.beams());
        let mut count = counts.then(|| vec![0u32; self.layout.pixels()]);
        let point = |i: usize, j: usize| pose.apply(sph_to_cart(r, cells.azimuths[i], cells.elevations[j]));
        for (bi, bj) in self.blocks(pose, &cells, r, noise_radius + slack) {
            for i in bi..(bi + BLOCK).min(na) {
                for j in bj..(bj + BLOCK).min(ne) {
                    self.mark(point(i, j), radius, &mut occ, count.as_deref_mut());
                }
            }
        }
        Ok(Mask {
            occupancy: occ,
            counts: count,
            radius,
            noise_radius,
            cells: (na * ne) as u64,
        })
    }

    /// Returns the first cells `(azimuth, elevation)` of the blocks of `BLOCK × BLOCK` cells whose
    /// ball (around the block's middle point, covering all its cells, grown by `extra`) may meet
    /// sonar 2's field of view under `pose`: the only cells worth visiting.
    pub(crate) fn blocks(
        &self,
        pose: &RelativePose,
        cells: &Cells,
        r: f64,
        extra: f64,
    ) -> Vec<(usize, usize)> {
        let (na, ne) = (cells.azimuths.len(), cells.elevations.len());
        let mut out = Vec::new();
        for bi in (0..na).step_by(BLOCK) {
            for bj in (0..ne).step_by(BLOCK) {
                let (ei, ej) = ((bi + BLOCK).min(na), (bj + BLOCK).min(ne));
                let (a0, a1) = (
                    cells.azimuths[bi] - cells.half.0,
                    cells.azimuths[ei - 1] + cells.half.0,
                );
                let (e0, e1) = (
                    cells.elevations[bj] - cells.half.1,
                    cells.elevations[ej - 1] + cells.half.1,
                );
                let centre = pose.apply(sph_to_cart(r, (a0 + a1) / 2.0, (e0 + e1) / 2.0));
                let radius = r * ((a1 - a0) / 2.0).hypot((e1 - e0) / 2.0) + extra;
                if self.may_meet_view(centre, radius) {
                    out.push((bi, bj));
                }
            }
        }
        out
    }

    /// Returns the cells of the set measured by `m`, sized so that a cell's ball radius is at
    /// most `h` (m).
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a saturating float-to-count conversion of a finite, validated extent"
    )]
    fn cells(&self, m: &Measurement, h: f64) -> Result<Cells> {
        let r = m.range;
        let el = 2.0 * self.source.half_elevation();
        let split = |extent: f64, size: f64| ((extent / size).ceil().max(1.0)) as usize;
        let centres = |lo: f64, extent: f64, n: usize| -> Vec<f64> {
            (0..n)
                .map(|k| lo + extent * (k as f64 + 0.5) / n as f64)
                .collect()
        };
        let (azimuths, ne, half_a) = match self.source.kind {
            // An arc: one azimuth, the cell's half-size all in elevation.
            SonarKind::Fls => (vec![m.azimuth.to_radians()], split(el * r, 2.0 * h), 0.0),
            // A surface: square cells of diagonal 2h (side h√2).
            SonarKind::Sss => {
                let az = 2.0 * self.source.half_azimuth();
                let side = h * std::f64::consts::SQRT_2;
                let na = split(az * r, side);
                let total = na as u64 * split(el * r, side) as u64;
                if total > MAX_CELLS {
                    return Err(Error::invalid(
                        "mask cells",
                        total,
                        format!("at most {MAX_CELLS}: sonar 2's range bins are too fine for this surface"),
                    ));
                }
                (
                    centres(-az / 2.0, az, na),
                    split(el * r, side),
                    az / na as f64 / 2.0,
                )
            }
        };
        if ne as u64 > MAX_CELLS {
            return Err(Error::invalid("mask cells", ne, format!("at most {MAX_CELLS}")));
        }
        Ok(Cells {
            azimuths,
            elevations: centres(-el / 2.0, el, ne),
            half: (half_a, el / ne as f64 / 2.0),
        })
    }

    /// Returns false only when no point within `radius` of `q` lies in sonar 2's field of view.
    fn may_meet_view(&self, q: glam::DVec3, radius: f64) -> bool {
        let l = &self.layout;
        let d = q.length();
        if d - radius > l.range_max || d + radius < l.range_min {
            return false;
        }
        let rho = q.x.hypot(q.y);
        let outside_elevation = self
            .tan_elevation
            .is_some_and(|t| q.z.abs() > t * (rho + radius) + radius);
        let outside_azimuth = self
            .tan_azimuth
            .is_some_and(|t| q.x + radius < 0.0 || q.y.abs() > t * (q.x + radius) + radius);
        !(outside_elevation || outside_azimuth)
    }

    /// Marks every bin or pixel that the ball of `radius` around `q` may touch in the field of
    /// view.
    fn mark(&self, q: glam::DVec3, radius: f64, occ: &mut Occupancy, counts: Option<&mut [u32]>) {
        if !self.may_meet_view(q, radius) {
            return;
        }
        let l = &self.layout;
        let d = q.length();
        let (lo, hi) = ((d - radius).max(l.range_min), (d + radius).min(l.range_max));
        let (i0, i1) = (l.range_bin(lo), l.range_bin(hi));
        let beams = l.beams();
        let mut spans = [(0usize, 0usize); 3];
        let mut n = 0;
        if l.kind == SonarKind::Sss {
            spans[0] = (0, 0);
            n = 1;
        } else {
            let rho = q.x.hypot(q.y);
            if radius >= rho {
                spans[0] = (0, beams - 1);
                n = 1;
            } else {
                let az = q.y.atan2(q.x);
                // Slack for the rounding of atan2 and asin.
                let spread = (radius / rho).asin() + 1e-12;
                let h = l.half_azimuth;
                // The interval az ± spread, and its parts wrapped past ±π.
                let pi2 = std::f64::consts::TAU;
                for (a, b) in [
                    (az - spread, az + spread),
                    (az - spread + pi2, az + spread + pi2),
                    (az - spread - pi2, az + spread - pi2),
                ] {
                    let (a, b) = (a.max(-h), b.min(h));
                    if a <= b {
                        spans[n] = (l.beam(a), l.beam(b));
                        n += 1;
                    }
                }
            }
        }
        let mut counts = counts;
        for i in i0..=i1 {
            for &(j0, j1) in &spans[..n] {
                occ.set_span(i, j0, j1);
                if let Some(c) = counts.as_deref_mut() {
                    for v in &mut c[i * beams + j0..=i * beams + j1] {
                        *v += 1;
                    }
                }
            }
        }
    }
}

/// The extent of a mask in sonar 2: range (m) and azimuth (deg) of its outermost bins' edges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BoundingBox {
    /// Lower edge of the nearest occupied range bin (m).
    pub range_min: f64,
    /// Upper edge of the farthest occupied range bin (m).
    pub range_max: f64,
    /// Lower edge of the leftmost occupied beam (deg); the aperture's edge for an SSS.
    pub azimuth_min: f64,
    /// Upper edge of the rightmost occupied beam (deg).
    pub azimuth_max: f64,
}

/// Returns the bounding box of `occ` in `layout`, or `None` when it is empty.
pub fn bounding_box(layout: &Layout, occ: &Occupancy) -> Option<BoundingBox> {
    let mut b: Option<(usize, usize, usize, usize)> = None;
    for (i, j) in occ.pixels() {
        b = Some(match b {
            None => (i, i, j, j),
            Some((i0, i1, j0, j1)) => (i0.min(i), i1.max(i), j0.min(j), j1.max(j)),
        });
    }
    b.map(|(i0, i1, j0, j1)| BoundingBox {
        range_min: layout.range_edge(i0),
        range_max: layout.range_edge(i1 + 1),
        azimuth_min: layout.beam_edges[j0].to_degrees(),
        azimuth_max: layout.beam_edges[j1 + 1].to_degrees(),
    })
}

/// Returns the set runs of `occ` over its row-major layout as `[start, length]` pairs.
pub fn run_lengths(occ: &Occupancy) -> Vec<[u64; 2]> {
    let mut runs: Vec<[u64; 2]> = Vec::new();
    for (i, j) in occ.pixels() {
        let k = (i * occ.beams + j) as u64;
        match runs.last_mut() {
            Some(run) if run[0] + run[1] == k => run[1] += 1,
            _ => runs.push([k, 1]),
        }
    }
    runs
}
