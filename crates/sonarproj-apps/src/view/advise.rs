//! The viewer's advise panel: the rig advisor's score around the scene's pose over two
//! rotation axes, and its best small move. It runs the same code as `sonarproj advise`
//! ([`crate::advise`]).

use serde::Deserialize;
use serde_json::{Value, json};

use crate::advise::{self, AdviseConfig, Features, FromPose, Objective, Rig, config::AXES};
use crate::error::{Error, Result};
use crate::view::{Scene, Viewer};

/// The most features the panel scores over.
pub const MAX_PANEL_FEATURES: usize = 2000;
/// The most values per axis of the panel's grid.
pub const MAX_PANEL_STEPS: usize = 21;
/// The most samples a panel's answer may project (an exact arc counts as 100): a few seconds
/// of a laptop's cores. More is refused, naming what to lower.
pub const MAX_PANEL_SAMPLES: u64 = 2_000_000_000;

/// Returns an error when the panel's grid of `config`, asked by `request`, would project more
/// than [`MAX_PANEL_SAMPLES`] samples (each feature counted at sonar 1's longest range, where
/// automatic sampling is densest), naming the knobs that lower it.
fn check_cost(config: &AdviseConfig, request: &AdviseRequest) -> Result<()> {
    use sonarproj::sampling::{Measurement, Sampling, SamplingPlan};
    let s = &config.source;
    let far = Measurement::of(s, s.range_max, 0.0)?;
    let per_feature = match config.sampling {
        Sampling::Exact => 100,
        sampling => {
            let (n_az, n_el) = SamplingPlan::counts(s, &config.target, &far, sampling, None)?;
            n_az as u64 * n_el as u64
        }
    };
    let cells = (request.steps * request.steps) as u64;
    let samples = cells * request.features.max(1) as u64 * per_feature;
    if samples > MAX_PANEL_SAMPLES {
        return Err(Error::invalid(
            "features",
            request.features,
            format!(
                "with {cells} grid cells and up to {per_feature} samples a feature, the panel would \
                 project about {samples:.1e} samples, more than its {MAX_PANEL_SAMPLES:.0e} (a few \
                 seconds): lower features or steps, or sample more coarsely"
            ),
        ));
    }
    Ok(())
}

/// What the page asks the panel for (JSON).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AdviseRequest {
    /// The scene: its sonars, sampling, feature and pose. A placement or a translation is the rig
    /// while sonar 2 turns.
    pub scene: Scene,
    /// `correspondence`, `ambiguity` or `recovery`.
    #[serde(default = "default_objective")]
    pub objective: String,
    /// The two rotation axes of the grid (`roll`, `pitch`, `yaw`).
    #[serde(default = "default_axes")]
    pub axes: [String; 2],
    /// Half the grid's width on each axis (deg).
    #[serde(default = "default_span")]
    pub span: f64,
    /// Values per axis: odd, so the current pose is the centre.
    #[serde(default = "default_steps")]
    pub steps: usize,
    /// Features drawn over the view both sonars share. 0 scores the scene's feature alone.
    #[serde(default = "default_features")]
    pub features: usize,
}

fn default_objective() -> String {
    "correspondence".into()
}
fn default_axes() -> [String; 2] {
    ["roll".into(), "pitch".into()]
}
fn default_span() -> f64 {
    10.0
}
fn default_steps() -> usize {
    9
}
fn default_features() -> usize {
    200
}

impl AdviseRequest {
    /// Returns the request parsed from the JSON `body`.
    ///
    /// # Errors
    /// An input error naming what is malformed.
    pub fn parse(body: &[u8]) -> Result<AdviseRequest> {
        if body.len() > crate::view::MAX_REQUEST_BYTES {
            return Err(Error::invalid(
                "request",
                format!("{} bytes", body.len()),
                format!("at most {} bytes", crate::view::MAX_REQUEST_BYTES),
            ));
        }
        serde_json::from_slice(body).map_err(|e| Error::input("request", e.to_string()))
    }

    /// Returns the request's two axes (indices into [`AXES`]), after checking its span, steps and
    /// features.
    ///
    /// # Errors
    /// Bad input naming `axes`, `span`, `steps` or `features`.
    fn axes_checked(&self) -> Result<[usize; 2]> {
        let request = self;
        let axis = |name: &str| {
            AXES[..3]
                .iter()
                .position(|a| *a == name)
                .ok_or_else(|| Error::invalid("axes", format!("{name:?}"), "must name roll, pitch or yaw"))
        };
        let axes = [axis(&request.axes[0])?, axis(&request.axes[1])?];
        if axes[0] == axes[1] {
            return Err(Error::invalid(
                "axes",
                format!("{:?}", request.axes),
                "must be two different axes",
            ));
        }
        if !(request.span > 0.0 && request.span <= 90.0) {
            return Err(Error::invalid("span", request.span, "must be in (0, 90] deg"));
        }
        if request.steps < 3 || request.steps > MAX_PANEL_STEPS || request.steps.is_multiple_of(2) {
            return Err(Error::invalid(
                "steps",
                request.steps,
                format!("must be odd, in [3, {MAX_PANEL_STEPS}]"),
            ));
        }
        if request.features > MAX_PANEL_FEATURES {
            return Err(Error::invalid(
                "features",
                request.features,
                format!("must be in [0, {MAX_PANEL_FEATURES}]"),
            ));
        }
        Ok(axes)
    }
}

impl Viewer {
    /// Returns the advise panel's answer for `request` as JSON: the axes and their values, each
    /// grid cell's score (`null` where infeasible), the current pose's score and the best small
    /// move.
    ///
    /// # Errors
    /// Bad input naming the field (objective, axes, span, steps, features, or the scene's own), or
    /// the backend's failures.
    pub fn advise(&self, request: &AdviseRequest) -> Result<Value> {
        self.advise_until(request, sonarproj::stream::Stop::NEVER)
    }

    /// Returns the advise panel's answer as [`Viewer::advise`] does, given up once `stop` is set
    /// (a client gone), at the next batch of projections.
    ///
    /// # Errors
    /// As [`Viewer::advise`]; [`sonarproj::Error::Stopped`] when stopped.
    pub fn advise_until(&self, request: &AdviseRequest, stop: sonarproj::stream::Stop<'_>) -> Result<Value> {
        let started = std::time::Instant::now();
        let scene = &request.scene;
        let source = self.choice("from", &scene.from)?.sonar.clone();
        let target = self.choice("to", &scene.to)?.sonar.clone();
        let f = scene.feature;
        source.check_point("feature", f.range, f.azimuth, f.elevation)?;
        scene.pose()?;
        let objective = match request.objective.as_str() {
            "correspondence" => Objective::Correspondence,
            "ambiguity" => Objective::Ambiguity,
            "recovery" => Objective::Recovery,
            other => {
                return Err(Error::invalid(
                    "objective",
                    format!("{other:?}"),
                    "must be \"correspondence\", \"ambiguity\" or \"recovery\"",
                ));
            }
        };
        let axes = request.axes_checked()?;
        let now = [scene.rotation.roll, scene.rotation.pitch, scene.rotation.yaw];
        #[expect(clippy::cast_precision_loss, reason = "at most 21 steps")]
        let cell = 2.0 * request.span / (request.steps - 1) as f64;
        let values = |k: usize| -> Vec<f64> {
            #[expect(clippy::cast_precision_loss, reason = "at most 21 steps")]
            let v = (0..request.steps)
                .map(|i| now[k] - request.span + i as f64 * cell)
                .collect();
            v
        };
        let grid: [Vec<f64>; 6] = std::array::from_fn(|k| {
            if axes.contains(&k) {
                values(k)
            } else if k < 3 {
                vec![now[k]]
            } else {
                vec![0.0]
            }
        });
        let rig = match (scene.place, scene.translation) {
            (Some(p), None) => Rig::Place {
                feature: [f.range, f.azimuth, f.elevation],
                at: [p.range, p.azimuth, p.elevation],
            },
            (None, Some(t)) => Rig::Translation(t),
            _ => unreachable!("checked by the scene's pose"),
        };
        let config = AdviseConfig {
            source,
            target,
            sampling: scene.sampling()?,
            area_grid: sonarproj::PAPER_AREA_GRID,
            sigma_range: None,
            objective,
            min_shared: 0.0,
            features: if request.features == 0 {
                Features::Points(vec![[f.range, f.azimuth, f.elevation]])
            } else {
                Features::Drawn {
                    count: request.features,
                    seed: 1,
                }
            },
            rig,
            axes: grid,
            uniform: None,
            refine: 0,
            refine_to: 0.5,
            refine_to_m: 0.01,
            landscape: None,
            from_pose: Some(FromPose {
                rotation: now,
                offset: [0.0; 3],
                step: cell,
                step_m: 0.1,
                gradient_step: 0.5,
                gradient_step_m: 0.01,
            }),
        };
        check_cost(&config, request)?;
        let advice = advise::advise_until(&config, &self.backend, stop)?;
        // The cover's scores: the first axis outer (its rows), the second inner.
        let (a, b) = (axes[0], axes[1]);
        let mut scores = Vec::with_capacity(request.steps * request.steps);
        for &x in &config.axes[a] {
            for &y in &config.axes[b] {
                let s = advice
                    .candidates
                    .iter()
                    .find(|(stage, s)| {
                        *stage == advise::Stage::Cover && s.rotation[a] == x && s.rotation[b] == y
                    })
                    .and_then(|(_, s)| s.score);
                scores.push(s);
            }
        }
        Ok(json!({
            "axes": [AXES[a], AXES[b]],
            "values": [config.axes[a], config.axes[b]],
            "scores": scores,
            "metric": advice.metric,
            "objective": request.objective,
            "score_unit": advise::score_unit(&config),
            "tied": advice.ranked.iter().filter(|&&i| advice.candidates[i].1.tied).count(),
            "recommended": advice.recommended.map(|i| advice.candidates[i].1),
            "warnings": advice.warnings,
            "move": advice.next,
            "compute_ms": started.elapsed().as_secs_f64() * 1e3,
        }))
    }
}
