//! The viewer's computation: one scene in, everything the viewer page draws out.
//!
//! A scene is a sonar pair, a feature seen by sonar 1 and the relative pose, with an optional
//! second measurement and noise. Out come the metrics, sonar 2's occupancy and widened mask,
//! the sampled arc or surface in 3-D, the recovered points, and the scene as a command line,
//! a sweep file and Python. The server of `sonarproj view` is a thin front on
//! [`Viewer::scene`]. The page never names a file.

pub mod advise;
pub mod copy_as;

use sonarproj::stream::Stop;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use serde::Deserialize;
use serde_json::{Value, json};
use sonarproj::geometry::{cart_to_sph, sph_to_cart};
use sonarproj::gpu::GpuOptions;
use sonarproj::masks::{Counts, MaskEngine, Noise, run_lengths};
use sonarproj::recovery::{DEFAULT_CURVE_STEP, Observation, Sigmas, recover};
use sonarproj::sampling::{SamplingPlan, base_azimuth};
use sonarproj::{
    Backend, BackendChoice, Batch, BatchItem, Layout, Measurement, Output, RelativePose, Rotation, Sampling,
    Sonar, SonarKind,
};

use crate::error::{Error, Result};
use crate::io::batch::metrics_json;

/// The most sample points a scene returns for the 3-D view (the metrics count all of them).
pub const MAX_SHOWN_SAMPLES: usize = 8192;
/// The largest request body the server reads, in bytes. A scene takes a few hundred.
pub const MAX_REQUEST_BYTES: usize = 64 * 1024;

/// A sonar the viewer offers: a preset, or a file named on the command line.
#[derive(Clone, Debug)]
pub struct Choice {
    /// What the page shows and sends back: the preset name, or the file's name.
    pub label: String,
    /// The sonar.
    pub sonar: Sonar,
    /// The file it was read from, for the "copy as" texts. `None` for a preset.
    pub path: Option<PathBuf>,
}

impl Choice {
    /// Returns the choice for `spec`: a preset name or a sonar TOML file, as in `--from`/`--to`.
    ///
    /// # Errors
    /// The engine's error for an unknown preset or a bad file.
    pub fn resolve(spec: &str) -> Result<Choice> {
        let sonar = Sonar::resolve(spec)?;
        let path = Sonar::preset(spec)
            .is_none()
            .then(|| std::fs::canonicalize(spec).unwrap_or_else(|_| PathBuf::from(spec)));
        let label = match &path {
            Some(p) => format!(
                "file: {}",
                p.file_name().map_or(spec.into(), |n| n.to_string_lossy())
            ),
            None => spec.to_string(),
        };
        Ok(Choice { label, sonar, path })
    }
}

/// The feature's true point in sonar 1. Sonar 1 measures its range, and for an FLS its
/// azimuth. The placement uses the rest.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Feature {
    /// Range (m).
    pub range: f64,
    /// Azimuth (deg).
    #[serde(default)]
    pub azimuth: f64,
    /// Elevation (deg).
    #[serde(default)]
    pub elevation: f64,
}

/// Roll, pitch and yaw (deg) of the relative rotation, `R = (Rz(yaw) Ry(pitch) Rx(roll))ᵀ`.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Rpy {
    /// Roll (deg).
    #[serde(default)]
    pub roll: f64,
    /// Pitch (deg).
    #[serde(default)]
    pub pitch: f64,
    /// Yaw (deg).
    #[serde(default)]
    pub yaw: f64,
}

/// Where the feature's true point appears in sonar 2 (the paper's placement).
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Place {
    /// Range (m).
    pub range: f64,
    /// Azimuth (deg).
    #[serde(default)]
    pub azimuth: f64,
    /// Elevation (deg).
    #[serde(default)]
    pub elevation: f64,
}

/// What sonar 2 measured of the feature, for recovery: range (m), azimuth (deg) for an FLS.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Second {
    /// Range (m).
    pub range: f64,
    /// Azimuth (deg), FLS only.
    #[serde(default)]
    pub azimuth: Option<f64>,
}

/// Standard deviations of the pose and the measurements; any non-zero widens the mask.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Sigma {
    /// Roll (deg).
    #[serde(default)]
    pub roll: f64,
    /// Pitch (deg).
    #[serde(default)]
    pub pitch: f64,
    /// Yaw (deg).
    #[serde(default)]
    pub yaw: f64,
    /// Translation x (m).
    #[serde(default)]
    pub tx: f64,
    /// Translation y (m).
    #[serde(default)]
    pub ty: f64,
    /// Translation z (m).
    #[serde(default)]
    pub tz: f64,
    /// Measured range (m).
    #[serde(default)]
    pub range: f64,
    /// Measured azimuth (deg).
    #[serde(default)]
    pub azimuth: f64,
}

/// One scene as the page sends it (JSON). Exactly one of `place` and `translation`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Sonar 1: a [`Choice::label`].
    pub from: String,
    /// Sonar 2: a [`Choice::label`].
    pub to: String,
    /// The feature's true point in sonar 1.
    pub feature: Feature,
    /// The relative rotation.
    #[serde(default)]
    pub rotation: Rpy,
    /// The placement: where the true point appears in sonar 2.
    #[serde(default)]
    pub place: Option<Place>,
    /// Or the translation `t` (m): `p2 = R p1 + t`.
    #[serde(default)]
    pub translation: Option<[f64; 3]>,
    /// Sampling step (deg); auto sampling when `None`.
    #[serde(default)]
    pub step: Option<f64>,
    /// Solves an FLS sonar 1's arc exactly instead of sampling it (no `step` then).
    #[serde(default)]
    pub exact: bool,
    /// What sonar 2 measured, to recover the lost coordinates.
    #[serde(default)]
    pub second: Option<Second>,
    /// Noise: widens the mask drawn beside the exact occupancy.
    #[serde(default)]
    pub sigma: Option<Sigma>,
    /// Probability that the widened mask holds the true pixel, in `(0, 1)`.
    #[serde(default = "default_coverage")]
    pub coverage: f64,
}

fn default_coverage() -> f64 {
    0.99
}

impl Scene {
    /// Returns the scene parsed from the JSON `body`.
    ///
    /// # Errors
    /// [`Error::Engine`] input error naming what is malformed.
    pub fn parse(body: &[u8]) -> Result<Scene> {
        if body.len() > MAX_REQUEST_BYTES {
            return Err(Error::invalid(
                "request",
                format!("{} bytes", body.len()),
                format!("at most {MAX_REQUEST_BYTES} bytes"),
            ));
        }
        serde_json::from_slice(body).map_err(|e| Error::input("request", e.to_string()))
    }

    /// Returns the relative pose of the scene.
    ///
    /// # Errors
    /// Input errors for a missing or doubled translation, and the engine's checks.
    pub fn pose(&self) -> Result<RelativePose> {
        let rotation = Rotation::RollPitchYaw {
            roll: self.rotation.roll,
            pitch: self.rotation.pitch,
            yaw: self.rotation.yaw,
        };
        let f = self.feature;
        match (self.place, self.translation) {
            (Some(p), None) => Ok(RelativePose::placement(
                rotation,
                [f.range, f.azimuth, f.elevation],
                [p.range, p.azimuth, p.elevation],
            )?),
            (None, Some(t)) => Ok(RelativePose::new(rotation, t)?),
            (None, None) => Err(Error::input(
                "pose",
                "no translation given; give a placement or a translation",
            )),
            (Some(_), Some(_)) => Err(Error::input(
                "pose",
                "both a placement and a translation given; give one",
            )),
        }
    }

    /// Returns the sampling of the scene, checked.
    ///
    /// # Errors
    /// An invalid step.
    pub fn sampling(&self) -> Result<Sampling> {
        Ok(match (self.step, self.exact) {
            (Some(_), true) => {
                return Err(Error::input("step", "a step and exact given; give one"));
            }
            (Some(s), false) => Sampling::Step(s),
            (None, true) => Sampling::Exact,
            (None, false) => Sampling::Auto,
        }
        .validated()?)
    }

    /// Returns the noise of the scene, `None` when every sigma is 0.
    ///
    /// # Errors
    /// Invalid sigmas or coverage.
    pub fn noise(&self) -> Result<Option<Noise>> {
        let Some(s) = self.sigma else { return Ok(None) };
        let all = [s.roll, s.pitch, s.yaw, s.tx, s.ty, s.tz, s.range, s.azimuth];
        let noise = Noise {
            rotation: [s.roll, s.pitch, s.yaw],
            translation: [s.tx, s.ty, s.tz],
            range: s.range,
            azimuth: s.azimuth,
            coverage: self.coverage,
        }
        .validated()?;
        Ok(all.iter().any(|v| *v != 0.0).then_some(noise))
    }
}

/// The viewer: the sonars it offers, its backend, and one kept mask engine per sonar pair.
pub struct Viewer {
    choices: Vec<Choice>,
    backend: Backend,
    choice: BackendChoice,
    gpu: GpuOptions,
    engines: Mutex<HashMap<(String, String), Arc<MaskEngine>>>,
}

impl std::fmt::Debug for Viewer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewer")
            .field("choices", &self.choices.len())
            .field("backend", &self.backend.name())
            .finish_non_exhaustive()
    }
}

impl Viewer {
    /// Returns a viewer offering every preset plus `extra`, the files named on the command line.
    /// The caller opened `backend` as `choice` with GPU options `gpu`. Mask engines use them too.
    #[must_use]
    pub fn new(extra: Vec<Choice>, backend: Backend, choice: BackendChoice, gpu: GpuOptions) -> Viewer {
        let mut choices: Vec<Choice> = Sonar::preset_names()
            .into_iter()
            .filter_map(|n| Choice::resolve(n).ok())
            .collect();
        for c in extra {
            if !choices.iter().any(|k| k.label == c.label) {
                choices.push(c);
            }
        }
        Viewer {
            choices,
            backend,
            choice,
            gpu,
            engines: Mutex::new(HashMap::new()),
        }
    }

    /// Returns the sonars on offer.
    #[must_use]
    pub fn choices(&self) -> &[Choice] {
        &self.choices
    }

    /// Returns the backend's name and device, for the page.
    #[must_use]
    pub fn device(&self) -> (String, String) {
        (self.backend.name().to_string(), self.backend.device())
    }

    /// Returns the sonar chosen by `label` for `field` (`from` or `to`).
    fn choice(&self, field: &str, label: &str) -> Result<&Choice> {
        self.choices.iter().find(|c| c.label == label).ok_or_else(|| {
            let names: Vec<&str> = self.choices.iter().map(|c| c.label.as_str()).collect();
            Error::invalid(
                field,
                format!("{label:?}"),
                format!("one of {}", names.join(", ")),
            )
        })
    }

    /// Returns what the page needs at start: the sonars on offer (with their fields of view and
    /// layouts) and the device.
    #[must_use]
    pub fn init(&self) -> Value {
        let (backend, device) = self.device();
        json!({
            "sonars": self.choices.iter().map(|c| sonar_json(&c.label, &c.sonar)).collect::<Vec<_>>(),
            "backend": backend,
            "device": device,
        })
    }

    /// Returns everything the page draws for `scene`, as JSON.
    ///
    /// # Errors
    /// Bad input, naming the field: unknown sonar labels, a feature outside sonar 1's view, a pose,
    /// sampling or noise out of range, or a second measurement outside sonar 2's view. Also the
    /// backend's failures.
    pub fn scene(&self, scene: &Scene) -> Result<Value> {
        self.scene_until(scene, Stop::NEVER)
    }

    /// Returns [`Viewer::scene`], but gives up once `stop` is set, as when a client went away.
    /// `stop` is checked between the stages (projection, mask, recovery) and inside the
    /// projection, as in [`Backend::project_until`].
    ///
    /// # Errors
    /// As [`Viewer::scene`]; [`sonarproj::Error::Stopped`] when stopped.
    pub fn scene_until(&self, scene: &Scene, stop: Stop<'_>) -> Result<Value> {
        let check = || {
            if stop.is_set() {
                Err(Error::from(sonarproj::Error::Stopped))
            } else {
                Ok(())
            }
        };
        check()?;
        let started = Instant::now();
        let first = self.choice("from", &scene.from)?.clone();
        let second = self.choice("to", &scene.to)?.clone();
        let (source, target) = (&first.sonar, &second.sonar);
        let f = scene.feature;
        source.check_point("feature", f.range, f.azimuth, f.elevation)?;
        let measurement = Measurement::of(source, f.range, f.azimuth)?;
        let pose = scene.pose()?;
        let sampling = scene.sampling()?;
        let noise = scene.noise()?;
        // The picture's points: exact mode draws no samples, so its arc is shown at auto spacing.
        let shown = if sampling == Sampling::Exact {
            Sampling::Auto
        } else {
            sampling
        };
        let plan = SamplingPlan::new(source, target, &measurement, shown)?;

        let batch = Batch {
            sigma_range: None,
            source: source.clone(),
            target: target.clone(),
            sampling,
            area_grid: sonarproj::PAPER_AREA_GRID,
            // With the true point, the metrics carry the local precision there at the default range
            // error, as `project` prints them.
            items: vec![BatchItem {
                true_point: Some([f.range, f.azimuth, f.elevation]),
                measurement,
                pose,
            }],
        };
        let result = self
            .backend
            .project_until(&batch, Output::WithOccupancy, stop)?
            .pop()
            .expect("one item in, one result out");
        let occupancy = result.occupancy.as_ref().expect("occupancy was asked for");
        check()?;

        let mask = match &noise {
            Some(n) => Some(self.mask_json(&first, &second, &pose, &measurement, n)?),
            None => None,
        };
        check()?;
        let recovery = match scene.second {
            Some(s) => Some(recovery_json(scene, s, source, target, &pose, &measurement)?),
            None => None,
        };

        let truth = pose.apply(sph_to_cart(
            f.range,
            f.azimuth.to_radians(),
            f.elevation.to_radians(),
        ));
        let (tr, taz, tel) = cart_to_sph(truth);
        let (backend, device) = self.device();
        let r = pose.rotation;
        Ok(json!({
            "from": sonar_json(&first.label, source),
            "to": sonar_json(&second.label, target),
            "backend": backend,
            "device": device,
            "metrics": metrics_json(&result.metrics, &result.local),
            "occupancy": {
                "range_bins": occupancy.range_bins,
                "beams": occupancy.beams,
                "runs": run_lengths(occupancy),
            },
            "mask": mask,
            "samples": samples(target, &measurement, &plan, &pose, base_azimuth(source, &measurement)),
            "truth_second": [tr, taz.to_degrees(), tel.to_degrees()],
            "pose": {
                "rotation": r.transpose().to_cols_array_2d(),
                "translation": pose.translation.to_array(),
            },
            "recovery": recovery,
            "copy": {
                "command": copy_as::command(scene, &first, &second, &pose),
                "toml": copy_as::sweep_toml(scene, &first, &second),
                "python": copy_as::python(scene, &first, &second),
            },
            "compute_ms": started.elapsed().as_secs_f64() * 1e3,
        }))
    }

    /// Returns the mask of `measurement` under `pose` with noise `n`, as JSON: runs, pixel count
    /// and radii. Each pair's engine is made once and kept.
    ///
    /// # Errors
    /// As [`MaskEngine::select`] and [`MaskEngine::mask`].
    fn mask_json(
        &self,
        first: &Choice,
        second: &Choice,
        pose: &RelativePose,
        measurement: &Measurement,
        n: &Noise,
    ) -> Result<Value> {
        let (source, target) = (&first.sonar, &second.sonar);
        let key = (first.label.clone(), second.label.clone());
        let known = self
            .engines
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .get(&key)
            .cloned();
        let engine = match known {
            Some(e) => e,
            None => {
                let (engine, _) = MaskEngine::select(
                    source.clone(),
                    target.clone(),
                    self.choice,
                    Counts::Skip,
                    &self.gpu,
                )?;
                let engine = Arc::new(engine);
                self.engines
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .insert(key, Arc::clone(&engine));
                engine
            }
        };
        let m = engine.mask(pose, measurement, Some(n), Counts::Skip)?;
        Ok(json!({
            "runs": run_lengths(&m.occupancy),
            "count": m.occupancy.count(),
            "radius": m.radius,
            "noise_radius": m.noise_radius,
        }))
    }
}

/// Returns a sonar as the page needs it: field of view, layout and beam edges (deg).
fn sonar_json(label: &str, s: &Sonar) -> Value {
    let layout = Layout::of(s);
    json!({
        "label": label,
        "kind": s.kind.name(),
        "range_min": s.range_min,
        "range_max": s.range_max,
        "azimuth_aperture": s.azimuth_aperture,
        "elevation_aperture": s.elevation_aperture,
        "range_bins": s.range_bins,
        "beams": layout.beams(),
        "beam_edges": layout.beam_edges.iter().map(|e| e.to_degrees()).collect::<Vec<_>>(),
    })
}

/// Returns up to [`MAX_SHOWN_SAMPLES`] points of the sampled arc or surface, with whether
/// sonar 2 sees each. One stride thins both angles. Points are in sonar 1's frame, in m
/// rounded to 0.1 mm.
fn samples(target: &Sonar, m: &Measurement, plan: &SamplingPlan, pose: &RelativePose, base: f64) -> Value {
    let layout = Layout::of(target);
    let (n_az, n_el) = (plan.azimuths.len(), plan.elevations.len());
    let mut stride = 1;
    while n_az.div_ceil(stride) * n_el.div_ceil(stride) > MAX_SHOWN_SAMPLES {
        stride += 1;
    }
    let round = |v: f64| (v * 1e4).round() / 1e4;
    let (mut points, mut visible) = (Vec::new(), Vec::new());
    for el in plan.elevations.iter().step_by(stride) {
        for az in plan.azimuths.iter().step_by(stride) {
            let p1 = sph_to_cart(m.range, base + az, *el);
            let (r, a, e) = cart_to_sph(pose.apply(p1));
            points.extend([round(p1.x), round(p1.y), round(p1.z)]);
            visible.push(u8::from(layout.inside(r, a, e)));
        }
    }
    json!({
        "total": plan.total(),
        "shown": visible.len(),
        "first": points,
        "visible": visible,
    })
}

/// Returns the JSON of the recovery from `measurement` in `source` and the second observation
/// `s` in `target` under `pose`, with the scene's sigmas when it gives any.
///
/// # Errors
/// As [`recover`], named `second`.
fn recovery_json(
    scene: &Scene,
    s: Second,
    source: &Sonar,
    target: &Sonar,
    pose: &RelativePose,
    measurement: &Measurement,
) -> Result<Value> {
    let sigmas = scene.sigma.and_then(|g| {
        (g.range != 0.0 || g.azimuth != 0.0).then_some(Sigmas {
            range: g.range,
            azimuth: g.azimuth,
        })
    });
    let obs = |range: f64, azimuth: Option<f64>| Observation { range, azimuth };
    let first_obs = obs(
        measurement.range,
        (source.kind == SonarKind::Fls).then_some(measurement.azimuth),
    );
    let second_obs = obs(s.range, s.azimuth.filter(|_| target.kind == SonarKind::Fls));
    let r = recover(
        source,
        target,
        pose,
        first_obs,
        second_obs,
        sigmas,
        DEFAULT_CURVE_STEP,
    )
    .map_err(|e| Error::from(e).in_context("second"))?;
    Ok(serde_json::to_value(&r).expect("plain values"))
}
