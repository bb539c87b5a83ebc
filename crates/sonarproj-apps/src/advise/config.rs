//! Advise files: TOML describing a sonar pair, the features a rig will see, how sonar 2 sits
//! while it turns, the objective, the rotations searched, and optionally the rig's pose now.
//!
//! ```toml
//! from = "paper-fls"            # sonar 1: preset or sonar TOML file (relative to this file)
//! to = "paper-sss"              # sonar 2
//! step = 0.1                    # sampling step (deg), "auto", or "exact"; left out: exact for an
//!                               # imaging sonar 1's arcs, auto for a sidescan's surfaces
//! objective = "correspondence"  # or "ambiguity", "recovery", or "mix" (with [mix])
//! min_shared = 0.1              # the least fraction of the features both sonars must see
//!
//! [features]                    # 1000 features both sonars see, a seeded draw ...
//! count = 1000
//! seed = 1
//! # points = [[5, 0, 0], [7.5, 10, -2]]   # ... or given in sonar 1: [range m, azimuth deg, elevation deg]
//!
//! [rig]                         # one of: where sonar 2's origin is in sonar 1's frame (m),
//! origin = [0, 0.5, 0]          # kept while sonar 2 turns; a fixed translation (p2 = R p1 + t);
//! # translation = [1, 0, 0]     # or the paper's placement: the feature appears at `at` in sonar 2
//! # place = { feature = [5, 0, 0], at = [15, 0, 0] }
//!
//! [search]                      # the candidates: roll, pitch, yaw (deg; as a sweep's keys) and
//! roll = { start = -180, stop = 170, step = 10 }   # x, y, z (m), offsets added to the rig's
//! pitch = { start = -90, stop = 90, step = 10 }    # origin or translation (not a placement)
//! yaw = 0
//! # z = [-0.5, 0, 0.5]
//! # uniform = 10000             # instead of roll, pitch, yaw: rotations spread over all of SO(3)
//! refine = 3                    # the best feasible candidates refined by pattern search (0: none)
//! refine_to = 0.5               # deg: the finest refinement step (refine_to_m: m, default 0.01)
//! landscape = ["roll", "pitch"] # the figure's two axes (default: the first two that vary)
//!
//! [from_pose]                   # the rig's pose now: its score, gradient and best small move
//! roll = 10
//! pitch = 20
//! yaw = 0
//! step = 5                      # deg: the largest move on each rotation axis (step_m: m, 0.1)
//! gradient_step = 0.5           # deg: the finite differences' step (gradient_step_m: m, 0.01)
//! ```

use std::path::{Path, PathBuf};

use sonarproj::geometry::sonar::Sonar;
use sonarproj::sampling::{Measurement, Sampling, SamplingPlan};

use glam::DVec3;
use sonarproj::geometry::pose::{RelativePose, Rotation};

use crate::advise::features::Features;
use crate::error::{Error, Result};
use crate::io::toml_keys::{ConfigFile, numbers};
use crate::sweep::config::resolve_sonar;

/// What the advisor minimises, each with its standard error over the feature draw (`score_se`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Objective {
    /// The expected cost of finding a feature's match in sonar 2's data, per point of the
    /// features' pool: a point both sonars see costs its projection metric (range span m for an
    /// SSS sonar 2, projection area m² for an FLS; at most the blind cost), one the other sonar
    /// misses (the pool is drawn over the sonar with the thinner elevation aperture) costs a
    /// blind search of sonar 2's whole data (its range extent, or its field of view's
    /// area). Sharing fewer features never lowers it: each feature lost trades its metric for the
    /// blind cost. Error: the costs' standard deviation over `√(points examined)`.
    Correspondence,
    /// The mean projection metric over the shared features alone: how hard a match is to find
    /// once both sonars see the feature. It improves when sonar 2 clips more of each arc, so it
    /// rewards sharing fewer features; use it with `min_shared`, or read it on the Pareto front.
    /// Error: the standard deviation over `√(shared features)`.
    Ambiguity,
    /// The median first-order elevation sigma (deg) of the recovered coordinate, over the shared
    /// features that have one. Small means recovery is precise. Error: the order statistics'
    /// interval for the median ([`crate::advise::Stats::median_se`]).
    Recovery,
    /// `weight · correspondence / metric_scale + (1 − weight) · sigma median / sigma_scale`.
    /// Error: the two parts' errors combined as if independent.
    Mix {
        /// The weight of correspondence, in `[0, 1]`.
        weight: f64,
        /// The metric's unit of the mix (m or m²).
        metric_scale: f64,
        /// The sigma's unit of the mix (deg).
        sigma_scale: f64,
    },
}

/// How sonar 2 sits while it turns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rig {
    /// Sonar 2's origin at this point of sonar 1's frame (m): `t = −R o`.
    Origin([f64; 3]),
    /// A fixed translation `t` (m): `p2 = R p1 + t`.
    Translation([f64; 3]),
    /// The paper's placement: the point `feature` of sonar 1 appears at `at` in sonar 2, both
    /// `[range m, azimuth deg, elevation deg]`.
    Place {
        /// The feature's true point in sonar 1.
        feature: [f64; 3],
        /// Where it appears in sonar 2.
        at: [f64; 3],
    },
}

/// The pose a rig has now, for the next-best move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FromPose {
    /// Roll, pitch, yaw (deg).
    pub rotation: [f64; 3],
    /// The offset of the rig's origin or translation, x, y, z (m).
    pub offset: [f64; 3],
    /// The largest move on each rotation axis (deg).
    pub step: f64,
    /// The largest move on each offset axis (m).
    pub step_m: f64,
    /// The finite differences' step on the rotation axes (deg).
    pub gradient_step: f64,
    /// The finite differences' step on the offset axes (m).
    pub gradient_step_m: f64,
}

/// A parsed, checked advise file.
#[derive(Clone, Debug)]
pub struct AdviseConfig {
    /// Sonar 1.
    pub source: Sonar,
    /// Sonar 2.
    pub target: Sonar,
    /// The sampling rule.
    pub sampling: Sampling,
    /// The cell side (m) of the projection-area grid (FLS sonar 2).
    pub area_grid: f64,
    /// The range error (m) of the recovery sigma (`None`: a bin width / √12).
    pub sigma_range: Option<f64>,
    /// The objective.
    pub objective: Objective,
    /// The least fraction of the features both sonars see, in `[0, 1]`.
    pub min_shared: f64,
    /// The features.
    pub features: Features,
    /// How sonar 2 sits.
    pub rig: Rig,
    /// The values covered on each axis of [`AXES`]: roll, pitch, yaw (deg), and the offsets x,
    /// y, z (m) added to the rig's origin or translation.
    pub axes: [Vec<f64>; 6],
    /// How many rotations to spread uniformly over SO(3) instead of the roll, pitch, yaw grid.
    /// The grid's axes are then the single value 0.
    pub uniform: Option<usize>,
    /// How many of the best feasible candidates are refined.
    pub refine: usize,
    /// The finest refinement step on the rotation axes (deg).
    pub refine_to: f64,
    /// The finest refinement step on the offset axes (m).
    pub refine_to_m: f64,
    /// The figure's two axes (indices into [`AXES`]), when two vary.
    pub landscape: Option<[usize; 2]>,
    /// The pose a rig has now.
    pub from_pose: Option<FromPose>,
}

/// The most candidate rotations the cover may have.
pub const MAX_CANDIDATES: u64 = 1_000_000;

/// The search's axes: the rotation (deg), then the offsets of the rig's origin or translation (m).
pub const AXES: [&str; 6] = ["roll", "pitch", "yaw", "x", "y", "z"];

/// Returns the unit of axis `k` of [`AXES`].
#[must_use]
pub fn unit(k: usize) -> &'static str {
    if k < 3 { "deg" } else { "m" }
}

/// The keys an advise file may have at its top.
const TOP_KEYS: [&str; 12] = [
    "from",
    "to",
    "step",
    "area_grid",
    "sigma_range",
    "objective",
    "min_shared",
    "mix",
    "features",
    "rig",
    "search",
    "from_pose",
];

/// The keys of `[search]`: the axes ([`AXES`]), then the refinement and the figure.
const SEARCH_KEYS: [&str; 11] = [
    AXES[0],
    AXES[1],
    AXES[2],
    AXES[3],
    AXES[4],
    AXES[5],
    "refine",
    "refine_to",
    "refine_to_m",
    "landscape",
    "uniform",
];

/// The keys of `[from_pose]`: the axes ([`AXES`]), then the moves' sizes.
const FROM_POSE_KEYS: [&str; 10] = [
    AXES[0],
    AXES[1],
    AXES[2],
    AXES[3],
    AXES[4],
    AXES[5],
    "step",
    "step_m",
    "gradient_step",
    "gradient_step_m",
];

/// What `[search]` says, as the config's fields of the same names.
struct Search {
    axes: [Vec<f64>; 6],
    uniform: Option<usize>,
    refine: usize,
    refine_to: f64,
    refine_to_m: f64,
    landscape: Option<[usize; 2]>,
}

impl AdviseConfig {
    /// Returns the advise file at `path`, checked.
    ///
    /// # Errors
    /// [`Error::ReadInput`], [`Error::AdviseFile`] (TOML syntax) or
    /// [`sonarproj::Error::InvalidValue`] naming the file and the key.
    pub fn load(path: &Path) -> Result<AdviseConfig> {
        let (text, base) = crate::report::read_config(path)?;
        AdviseConfig::parse(&path.display().to_string(), &text, &base)
    }

    /// Returns the advise file of TOML `text`, called `file` in messages, with relative paths
    /// taken from `base`.
    ///
    /// # Errors
    /// As [`AdviseConfig::load`].
    pub fn parse(file: &str, text: &str, base: &Path) -> Result<AdviseConfig> {
        let top: toml::Table = text.parse().map_err(|e: toml::de::Error| Error::AdviseFile {
            path: PathBuf::from(file),
            message: sonarproj::error::parser_message(&e.to_string()),
        })?;
        let f = ConfigFile::advise(file);
        f.only("", &top, &TOP_KEYS)?;
        let sonar = |k: &str| -> Result<Sonar> {
            let spec = f
                .string(&top, k)?
                .ok_or_else(|| f.missing(k, "required: a preset name or a sonar TOML file"))?;
            resolve_sonar(spec, base)
        };
        let (source, target) = (sonar("from")?, sonar("to")?);
        // FLS features (arcs) are solved exactly unless a step is given; a sidescan's features
        // (surfaces) have no exact form here.
        let sampling = sampling(f, &top)?.unwrap_or(if source.kind == sonarproj::SonarKind::Fls {
            Sampling::Exact
        } else {
            Sampling::Auto
        });
        check_step(f, &source, &target, sampling)?;
        if sampling == Sampling::Exact && source.kind == sonarproj::SonarKind::Sss {
            return Err(f.error(
                "step",
                "\"exact\"",
                "exact mode solves an imaging sonar 1's arcs; a sidescan sonar 1's features are \
                 surfaces, which are sampled: give a step (deg) or \"auto\"",
            ));
        }
        let area_grid = f
            .number(&top, "area_grid", "area_grid")?
            .unwrap_or(sonarproj::PAPER_AREA_GRID);
        let sigma_range = f.number(&top, "sigma_range", "sigma_range")?;
        if let Some(s) = sigma_range {
            sonarproj::local_precision::resolve_sigma_range(&source, &target, Some(s))?;
        }
        let min_shared = f.number(&top, "min_shared", "min_shared")?.unwrap_or(0.0);
        let min_shared = f.in_range("min_shared", min_shared, 0.0, 1.0, "")?;
        let objective = objective(f, &top)?;
        let features = crate::advise::features::read(f, f.table(&top, "features")?, &source)?;
        let rig = rig(f, f.table(&top, "rig")?)?;
        let empty = toml::Table::new();
        let search = Search::read(f, f.table(&top, "search")?.unwrap_or(&empty), rig)?;
        let from_pose = match f.table(&top, "from_pose")? {
            None => None,
            Some(t) => Some(from_pose(f, t, rig)?),
        };
        let config = AdviseConfig {
            source,
            target,
            sampling,
            area_grid,
            sigma_range,
            objective,
            min_shared,
            features,
            rig,
            axes: search.axes,
            uniform: search.uniform,
            refine: search.refine,
            refine_to: search.refine_to,
            refine_to_m: search.refine_to_m,
            landscape: search.landscape,
            from_pose,
        };
        config.check_reach(f)?;
        Ok(config)
    }

    /// Returns an error naming `rig` unless it makes a valid pose and every candidate's
    /// translation, at most the rig's reach long, stays within the engine's bound.
    fn check_reach(&self, f: ConfigFile<'_>) -> Result<()> {
        let reach = self.reach();
        if reach > sonarproj::limits::MAX_TRANSLATION {
            return Err(f.error(
                "rig",
                format!("a translation of up to {reach} m"),
                format!(
                    "must keep every candidate's translation within {} m (with the search's offsets)",
                    sonarproj::limits::MAX_TRANSLATION
                ),
            ));
        }
        self.pose_of([0.0; 6])
            .map_err(|e| Error::invalid(f.field("rig"), e, "must give a valid pose"))?;
        Ok(())
    }

    /// Returns the pose of candidate `c` under the rig: the rotation `c[0..3]` (roll, pitch, yaw
    /// in deg), the rig's origin or translation offset by `c[3..6]` (m).
    ///
    /// # Errors
    /// As [`RelativePose::new`] and [`RelativePose::placement`].
    pub fn pose_of(&self, c: [f64; 6]) -> sonarproj::Result<RelativePose> {
        let r = Rotation::RollPitchYaw {
            roll: c[0],
            pitch: c[1],
            yaw: c[2],
        };
        let offset = DVec3::new(c[3], c[4], c[5]);
        match self.rig {
            Rig::Translation(t) => RelativePose::new(r, DVec3::from_array(t) + offset),
            Rig::Origin(o) => {
                let m = r.to_matrix()?;
                RelativePose::new(r, -(m * (DVec3::from_array(o) + offset)))
            }
            Rig::Place { feature, at } => RelativePose::placement(r, feature, at),
        }
    }

    /// Returns the largest distance (m) any candidate can put between the sonars' origins.
    /// For an origin or translation rig: its length plus the largest offset of the cover (which
    /// refinement does not leave), the pose now, and its moves. For a placement: the feature's
    /// range plus the place's.
    #[must_use]
    pub fn reach(&self) -> f64 {
        match self.rig {
            Rig::Origin(o) | Rig::Translation(o) => {
                let far = |k: usize| {
                    let cover = self.axes[k].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                    let moved = self
                        .from_pose
                        .map_or(0.0, |p| p.offset[k - 3].abs() + p.step_m.max(p.gradient_step_m));
                    cover.max(moved)
                };
                DVec3::from_array(o).length() + DVec3::new(far(3), far(4), far(5)).length()
            }
            Rig::Place { feature, at } => feature[0].abs() + at[0].abs(),
        }
    }
}

/// Returns the sampling `step` gives: a step > 0 (deg), `"exact"`, or `"auto"`; `None` when
/// `step` is not given.
fn sampling(f: ConfigFile<'_>, top: &toml::Table) -> Result<Option<Sampling>> {
    let allowed = "must be > 0 (deg), \"auto\" or \"exact\"";
    match top.get("step") {
        Some(toml::Value::String(s)) if s == "auto" => Ok(Some(Sampling::Auto)),
        Some(toml::Value::String(s)) if s == "exact" => Ok(Some(Sampling::Exact)),
        Some(v @ (toml::Value::Integer(_) | toml::Value::Float(_))) => match f.number(top, "step", "step")? {
            Some(s) if s > 0.0 => Ok(Some(Sampling::Step(s))),
            _ => Err(f.error("step", v.clone(), allowed)),
        },
        Some(v) => Err(f.error("step", v.clone(), allowed)),
        None => Ok(None),
    }
}

/// Returns `Ok` when a step `sampling` draws no more samples a pose than a pose may (the count
/// depends on sonar 1's apertures alone), else the error naming `step`.
fn check_step(f: ConfigFile<'_>, source: &Sonar, target: &Sonar, sampling: Sampling) -> Result<()> {
    let Sampling::Step(step) = sampling else {
        return Ok(());
    };
    let m = Measurement {
        range: source.range_max,
        azimuth: 0.0,
    };
    match SamplingPlan::counts(source, target, &m, sampling, None) {
        Err(sonarproj::Error::InvalidValue { value, allowed, .. }) => {
            Err(f.error("step", step, format!("gives {value}: {allowed}")))
        }
        other => other.map(|_| ()).map_err(Into::into),
    }
}

/// Returns the objective: `objective`, with `[mix]` for a mix. Correspondence by default.
fn objective(f: ConfigFile<'_>, top: &toml::Table) -> Result<Objective> {
    let objective = match f.string(top, "objective")?.unwrap_or("correspondence") {
        "correspondence" => Objective::Correspondence,
        "ambiguity" => Objective::Ambiguity,
        "recovery" => Objective::Recovery,
        "mix" => {
            let mix = f.table(top, "mix")?.ok_or_else(|| {
                f.missing(
                    "mix",
                    "objective \"mix\" needs [mix] with weight, metric_scale and sigma_scale",
                )
            })?;
            f.only("mix.", mix, &["weight", "metric_scale", "sigma_scale"])?;
            // A scale divides the score's parts: within [1e-6, 1e6] the mix stays finite.
            let positive = |k: &str| -> Result<f64> {
                let name = format!("mix.{k}");
                match f.number(mix, &name, k)? {
                    Some(v) if (1e-6..=1e6).contains(&v) => Ok(v),
                    other => Err(f.error(
                        &name,
                        other.map_or("missing".into(), |v| v.to_string()),
                        "must be a number in [1e-6, 1e6]",
                    )),
                }
            };
            let weight = f.number(mix, "mix.weight", "weight")?.unwrap_or(0.5);
            Objective::Mix {
                weight: f.in_range("mix.weight", weight, 0.0, 1.0, "")?,
                metric_scale: positive("metric_scale")?,
                sigma_scale: positive("sigma_scale")?,
            }
        }
        other => {
            return Err(f.error(
                "objective",
                format!("{other:?}"),
                "must be \"correspondence\", \"ambiguity\", \"recovery\" or \"mix\"",
            ));
        }
    };
    if top.contains_key("mix") && !matches!(objective, Objective::Mix { .. }) {
        return Err(f.error("mix", "given", "only with objective = \"mix\""));
    }
    Ok(objective)
}

impl Search {
    /// Returns `[search]` (`search`) read for `rig`.
    fn read(f: ConfigFile<'_>, search: &toml::Table, rig: Rig) -> Result<Search> {
        f.only("search.", search, &SEARCH_KEYS)?;
        // A uniform cover of the rotations instead of the roll, pitch and yaw grid.
        #[expect(clippy::cast_possible_truncation, reason = "at most 10^6")]
        let uniform = f.whole(search, "search.uniform", 2.0, 1e6)?.map(|n| n as usize);
        if uniform.is_some()
            && let Some(k) = ["roll", "pitch", "yaw"].iter().find(|k| search.contains_key(**k))
        {
            return Err(f.error(
                &format!("search.{k}"),
                search[*k].clone(),
                "give the rotations as search.uniform or as roll, pitch, yaw, not both",
            ));
        }
        let axes = search_axes(f, search, rig)?;
        // Counted without overflow: every candidate and its score are held at once.
        let candidates = axes
            .iter()
            .map(|a| a.len() as u64)
            .chain(uniform.map(|n| n as u64))
            .try_fold(1u64, u64::checked_mul)
            .unwrap_or(u64::MAX);
        if candidates > MAX_CANDIDATES {
            return Err(f.error(
                "search",
                format!("{candidates} candidates"),
                format!("at most {MAX_CANDIDATES} candidates a search"),
            ));
        }
        #[expect(clippy::cast_possible_truncation, reason = "at most 100")]
        let refine = f
            .whole(search, "search.refine", 0.0, 100.0)?
            .map_or(3, |n| n as usize);
        let refine_to = f.number(search, "search.refine_to", "refine_to")?.unwrap_or(0.5);
        let refine_to = f.in_range("search.refine_to", refine_to, 1e-6, 180.0, " deg")?;
        let refine_to_m = f
            .number(search, "search.refine_to_m", "refine_to_m")?
            .unwrap_or(0.01);
        let refine_to_m = f.in_range("search.refine_to_m", refine_to_m, 1e-6, 100.0, " m")?;
        Ok(Search {
            refine,
            refine_to,
            refine_to_m,
            landscape: landscape(f, search, &axes, uniform.is_some())?,
            axes,
            uniform,
        })
    }
}

/// Returns the values covered on each axis of [`AXES`], 0 where left out.
/// Offsets need an origin or translation rig, and must be within ±1000 m.
fn search_axes(f: ConfigFile<'_>, search: &toml::Table, rig: Rig) -> Result<[Vec<f64>; 6]> {
    let mut out: [Vec<f64>; 6] = Default::default();
    for (k, name) in AXES.iter().enumerate() {
        let key = format!("search.{name}");
        out[k] = match search.get(*name) {
            Some(v) => f.values(&key, v)?,
            None => vec![0.0],
        };
        if k < 3 {
            continue;
        }
        if matches!(rig, Rig::Place { .. }) && out[k] != [0.0] {
            return Err(f.error(
                &key,
                search[*name].clone(),
                "only with [rig] origin or translation (a placement sets the translation)",
            ));
        }
        if let Some(v) = out[k].iter().find(|v| v.abs() > 1000.0) {
            return Err(f.error(&key, v, "must be within ±1000 m"));
        }
    }
    Ok(out)
}

/// Returns the figure's two axes: those `search.landscape` names, else the first two that vary
/// (none for a uniform cover).
fn landscape(
    f: ConfigFile<'_>,
    search: &toml::Table,
    axes: &[Vec<f64>; 6],
    uniform: bool,
) -> Result<Option<[usize; 2]>> {
    let varying: Vec<usize> = (0..6).filter(|&k| axes[k].len() > 1).collect();
    if uniform && search.contains_key("landscape") {
        return Err(f.error(
            "search.landscape",
            search["landscape"].clone(),
            "needs a grid of roll, pitch, yaw (search.uniform scatters the rotations)",
        ));
    }
    match search.get("landscape") {
        None => Ok((!uniform && varying.len() >= 2).then(|| [varying[0], varying[1]])),
        Some(toml::Value::Array(a)) => {
            let names: Vec<Option<usize>> = a
                .iter()
                .map(|v| v.as_str().and_then(|s| AXES.iter().position(|n| *n == s)))
                .collect();
            match names.as_slice() {
                [Some(x), Some(y)] if x != y && varying.contains(x) && varying.contains(y) => {
                    Ok(Some([*x, *y]))
                }
                _ => Err(f.error(
                    "search.landscape",
                    search["landscape"].clone(),
                    "must name two different axes the search varies (roll, pitch, yaw, x, y, z)",
                )),
            }
        }
        Some(other) => Err(f.error("search.landscape", other, "must be a list of two axis names")),
    }
}

/// Returns `[from_pose]` (`t`): the rig's pose now, and the sizes of its moves and finite
/// differences. Offsets need an origin or translation rig.
fn from_pose(f: ConfigFile<'_>, t: &toml::Table, rig: Rig) -> Result<FromPose> {
    f.only("from_pose.", t, &FROM_POSE_KEYS)?;
    let get = |k: &str, default: f64, lo: f64, hi: f64, unit: &str| -> Result<f64> {
        let name = format!("from_pose.{k}");
        let v = f.number(t, &name, k)?.unwrap_or(default);
        f.in_range(&name, v, lo, hi, unit)
    };
    let rotation = [
        get("roll", 0.0, -360.0, 360.0, " deg")?,
        get("pitch", 0.0, -360.0, 360.0, " deg")?,
        get("yaw", 0.0, -360.0, 360.0, " deg")?,
    ];
    let offset = [
        get("x", 0.0, -1000.0, 1000.0, " m")?,
        get("y", 0.0, -1000.0, 1000.0, " m")?,
        get("z", 0.0, -1000.0, 1000.0, " m")?,
    ];
    if matches!(rig, Rig::Place { .. }) && offset != [0.0; 3] {
        return Err(f.error(
            "from_pose",
            format!("offset {offset:?}"),
            "x, y, z only with [rig] origin or translation",
        ));
    }
    Ok(FromPose {
        rotation,
        offset,
        step: get("step", 5.0, 1e-6, 90.0, " deg")?,
        step_m: get("step_m", 0.1, 1e-6, 100.0, " m")?,
        gradient_step: get("gradient_step", 0.5, 1e-6, 10.0, " deg")?,
        gradient_step_m: get("gradient_step_m", 0.01, 1e-6, 10.0, " m")?,
    })
}

/// Returns the `[rig]`: one of origin, translation, place.
fn rig(f: ConfigFile<'_>, t: Option<&toml::Table>) -> Result<Rig> {
    let missing = || f.missing("rig", "required: [rig] with origin, translation or place");
    let t = t.ok_or_else(missing)?;
    f.only("rig.", t, &["origin", "translation", "place"])?;
    if t.len() != 1 {
        return Err(f.error(
            "rig",
            toml::Value::Table(t.clone()),
            "give one of origin, translation, place",
        ));
    }
    let triple = |name: &str, v: &toml::Value| -> Result<[f64; 3]> {
        let xyz: Vec<f64> = numbers(v).unwrap_or_default();
        match xyz.as_slice() {
            [a, b, c]
                if xyz
                    .iter()
                    .all(|v| v.is_finite() && v.abs() <= sonarproj::limits::MAX_TRANSLATION) =>
            {
                Ok([*a, *b, *c])
            }
            _ => Err(f.error(
                name,
                v.clone(),
                format!(
                    "must be three finite numbers within ±{} (m, or [range m, azimuth deg, \
                     elevation deg])",
                    sonarproj::limits::MAX_TRANSLATION
                ),
            )),
        }
    };
    let (k, v) = t.iter().next().expect("one key");
    match k.as_str() {
        "origin" => Ok(Rig::Origin(triple("rig.origin", v)?)),
        "translation" => Ok(Rig::Translation(triple("rig.translation", v)?)),
        _ => {
            let place = v.as_table().ok_or_else(|| {
                f.error(
                    "rig.place",
                    v.clone(),
                    "must be { feature = [r, az, el], at = [r, az, el] }",
                )
            })?;
            f.only("rig.place.", place, &["feature", "at"])?;
            let get = |name: &str| -> Result<[f64; 3]> {
                let key = format!("rig.place.{name}");
                let v = place
                    .get(name)
                    .ok_or_else(|| Error::input(f.field(&key), "missing"))?;
                triple(&key, v)
            };
            Ok(Rig::Place {
                feature: get("feature")?,
                at: get("at")?,
            })
        }
    }
}
