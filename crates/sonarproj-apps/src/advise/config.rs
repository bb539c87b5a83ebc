//! Advise files: a TOML description of a sonar pair, the features a rig will see, how sonar 2 is
//! placed while it turns, the objective, the rotations searched and, optionally, the pose a rig
//! has now.
//!
//! ```toml
//! from = "paper-fls"            # sonar 1: preset or sonar TOML file (relative to this file)
//! to = "paper-sss"              # sonar 2
//! step = 0.1                    # sampling step (deg); leave out for auto sampling
//! objective = "correspondence"  # or "recovery", or "mix" (with [mix])
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

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sonarproj::geometry::sonar::Sonar;
use sonarproj::sampling::Sampling;

use crate::error::{Error, Result};
use crate::sweep::config::{axis_values, resolve_sonar};

/// What the advisor minimises.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Objective {
    /// The mean projection metric over the shared features: range span for a sidescan sonar 2,
    /// projection area for an FLS sonar 2 (small: a feature's match is easy to find).
    Correspondence,
    /// The median first-order elevation sigma of the recovered coordinate (deg) over the shared
    /// features that have one (small: recovery is precise).
    Recovery,
    /// `weight · metric mean / metric_scale + (1 − weight) · sigma median / sigma_scale`.
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

/// The features candidates are scored over.
#[derive(Clone, Debug, PartialEq)]
pub enum Features {
    /// `count` features of the view both sonars share: a seeded sequence of points drawn
    /// uniformly over the view (as a volume) of the sonar with the thinner elevation aperture
    /// (sonar 1 on a tie), taken in order while the other sonar sees them, until `count` are
    /// kept — the same sequence for every candidate, so neighbouring candidates share most of
    /// their features.
    Drawn {
        /// How many to keep.
        count: usize,
        /// The draw's seed.
        seed: u64,
    },
    /// Given points of sonar 1, `[range m, azimuth deg, elevation deg]`: those sonar 2 sees.
    Points(Vec<[f64; 3]>),
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
    /// Rotations spread uniformly over SO(3) instead of the roll, pitch, yaw grid (its axes are
    /// then the single value 0): how many.
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

/// The most features an advise file may ask for.
pub const MAX_FEATURES: usize = 1_000_000;

/// The most candidate rotations the cover may have.
pub const MAX_CANDIDATES: u64 = 1_000_000;

/// The names of the search's axes: the rotation (deg), then the offsets of the rig's origin or
/// translation (m).
pub const AXES: [&str; 6] = ["roll", "pitch", "yaw", "x", "y", "z"];

/// Returns the unit of axis `k` of [`AXES`].
#[must_use]
pub fn unit(k: usize) -> &'static str {
    if k < 3 { "deg" } else { "m" }
}

fn key_error(file: &str, key: &str, value: impl std::fmt::Display, allowed: impl Into<String>) -> Error {
    Error::invalid(format!("advise file {file:?}: {key}"), value, allowed)
}

/// Returns the keys of `table` that are not in `allowed`, as an error naming the first.
fn only(file: &str, section: &str, table: &toml::Table, allowed: &[&str]) -> Result<()> {
    match table.keys().find(|k| !allowed.contains(&k.as_str())) {
        Some(k) => Err(key_error(
            file,
            &format!("{section}{k}"),
            table[k].clone(),
            format!("unknown key (allowed: {})", allowed.join(", ")),
        )),
        None => Ok(()),
    }
}

impl AdviseConfig {
    /// Returns the advise file at `path`, checked.
    ///
    /// # Errors
    /// [`Error::ReadInput`], [`Error::AdviseFile`] (TOML syntax) or
    /// [`sonarproj::Error::InvalidValue`] naming the file and the key.
    pub fn load(path: &Path) -> Result<AdviseConfig> {
        crate::report::note_input(path);
        let text = std::fs::read_to_string(path).map_err(|source| Error::ReadInput {
            path: path.to_path_buf(),
            source,
        })?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        AdviseConfig::parse(&path.display().to_string(), &text, &base)
    }

    /// Returns the advise file of TOML `text`, called `file` in messages, with relative paths
    /// taken from `base`.
    ///
    /// # Errors
    /// As [`AdviseConfig::load`].
    #[expect(clippy::too_many_lines, reason = "one key after the other, each checked")]
    pub fn parse(file: &str, text: &str, base: &Path) -> Result<AdviseConfig> {
        let top: toml::Table = text.parse().map_err(|e: toml::de::Error| Error::AdviseFile {
            path: PathBuf::from(file),
            message: sonarproj::error::parser_message(&e.to_string()),
        })?;
        only(
            file,
            "",
            &top,
            &[
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
            ],
        )?;
        let string = |k: &str| -> Result<Option<&str>> {
            match top.get(k) {
                None => Ok(None),
                Some(toml::Value::String(s)) => Ok(Some(s)),
                Some(other) => Err(key_error(file, k, other, "must be a string")),
            }
        };
        let sonar = |k: &str| -> Result<Sonar> {
            let spec = string(k)?.ok_or_else(|| {
                Error::input(
                    format!("advise file {file:?}: {k}"),
                    "missing; required: a preset name or a sonar TOML file",
                )
            })?;
            resolve_sonar(spec, base)
        };
        let (source, target) = (sonar("from")?, sonar("to")?);
        let table = |k: &str| -> Result<Option<&toml::Table>> {
            match top.get(k) {
                None => Ok(None),
                Some(toml::Value::Table(t)) => Ok(Some(t)),
                Some(other) => Err(key_error(file, k, other, "must be a table")),
            }
        };
        // One number of key `key` in `t` (named `name`), within `range`.
        let number = |t: &toml::Table, name: &str, key: &str| -> Result<Option<f64>> {
            let Some(v) = t.get(key) else { return Ok(None) };
            match axis_values(file, name, v)?.as_slice() {
                [x] => Ok(Some(*x)),
                _ => Err(key_error(file, name, v, "must be one number")),
            }
        };
        let in_range = |name: &str, v: f64, lo: f64, hi: f64, unit: &str| -> Result<f64> {
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(key_error(file, name, v, format!("must be in [{lo}, {hi}]{unit}")))
            }
        };
        let sampling = match top.get("step") {
            Some(toml::Value::String(s)) if s == "auto" => Sampling::Auto,
            Some(_) => match number(&top, "step", "step")? {
                Some(s) if s > 0.0 => Sampling::Step(s),
                other => {
                    return Err(key_error(
                        file,
                        "step",
                        format!("{other:?}"),
                        "must be > 0 (deg) or \"auto\"",
                    ));
                }
            },
            None => Sampling::Auto,
        };
        let area_grid = number(&top, "area_grid", "area_grid")?.unwrap_or(sonarproj::PAPER_AREA_GRID);
        let sigma_range = number(&top, "sigma_range", "sigma_range")?;
        if let Some(s) = sigma_range {
            sonarproj::local_precision::resolve_sigma_range(&source, &target, Some(s))?;
        }
        let min_shared = in_range(
            "min_shared",
            number(&top, "min_shared", "min_shared")?.unwrap_or(0.0),
            0.0,
            1.0,
            "",
        )?;
        let objective = match string("objective")?.unwrap_or("correspondence") {
            "correspondence" => Objective::Correspondence,
            "recovery" => Objective::Recovery,
            "mix" => {
                let mix = table("mix")?.ok_or_else(|| {
                    Error::input(
                        format!("advise file {file:?}: mix"),
                        "missing; objective \"mix\" needs [mix] with weight, metric_scale and sigma_scale",
                    )
                })?;
                only(file, "mix.", mix, &["weight", "metric_scale", "sigma_scale"])?;
                let positive = |k: &str| -> Result<f64> {
                    match number(mix, &format!("mix.{k}"), k)? {
                        Some(v) if v > 0.0 && v.is_finite() => Ok(v),
                        other => Err(key_error(
                            file,
                            &format!("mix.{k}"),
                            format!("{other:?}"),
                            "must be a number > 0",
                        )),
                    }
                };
                Objective::Mix {
                    weight: in_range(
                        "mix.weight",
                        number(mix, "mix.weight", "weight")?.unwrap_or(0.5),
                        0.0,
                        1.0,
                        "",
                    )?,
                    metric_scale: positive("metric_scale")?,
                    sigma_scale: positive("sigma_scale")?,
                }
            }
            other => {
                return Err(key_error(
                    file,
                    "objective",
                    format!("{other:?}"),
                    "must be \"correspondence\", \"recovery\" or \"mix\"",
                ));
            }
        };
        if top.contains_key("mix") && !matches!(objective, Objective::Mix { .. }) {
            return Err(key_error(file, "mix", "given", "only with objective = \"mix\""));
        }
        let features = features(file, table("features")?, &source, &number)?;
        let rig = rig(file, table("rig")?)?;
        let empty = toml::Table::new();
        let search = table("search")?.unwrap_or(&empty);
        only(
            file,
            "search.",
            search,
            &[
                "roll",
                "pitch",
                "yaw",
                "x",
                "y",
                "z",
                "refine",
                "refine_to",
                "refine_to_m",
                "landscape",
                "uniform",
            ],
        )?;
        // A uniform cover of the rotations instead of the roll, pitch and yaw grid.
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "checked range"
        )]
        let uniform = match number(search, "search.uniform", "uniform")? {
            None => None,
            Some(v) if v.fract() == 0.0 && (2.0..=1e6).contains(&v) => {
                if let Some(k) = ["roll", "pitch", "yaw"].iter().find(|k| search.contains_key(**k)) {
                    return Err(key_error(
                        file,
                        &format!("search.{k}"),
                        search[*k].clone(),
                        "give the rotations as search.uniform or as roll, pitch, yaw, not both",
                    ));
                }
                Some(v as usize)
            }
            Some(v) => {
                return Err(key_error(
                    file,
                    "search.uniform",
                    v,
                    "must be a whole number of rotations in [2, 1000000]",
                ));
            }
        };
        let axes: [Vec<f64>; 6] = {
            let mut out: [Vec<f64>; 6] = Default::default();
            for (k, name) in AXES.iter().enumerate() {
                out[k] = match search.get(*name) {
                    Some(v) => axis_values(file, &format!("search.{name}"), v)?,
                    None => vec![0.0],
                };
                if k >= 3 {
                    if matches!(rig, Rig::Place { .. }) && out[k] != [0.0] {
                        return Err(key_error(
                            file,
                            &format!("search.{name}"),
                            search[*name].clone(),
                            "only with [rig] origin or translation (a placement sets the translation)",
                        ));
                    }
                    if let Some(v) = out[k].iter().find(|v| v.abs() > 1000.0) {
                        return Err(key_error(
                            file,
                            &format!("search.{name}"),
                            v,
                            "must be within ±1000 m",
                        ));
                    }
                }
            }
            out
        };
        // Counted without overflow: every candidate and its score are held at once.
        let candidates = axes
            .iter()
            .map(|a| a.len() as u64)
            .chain(uniform.map(|n| n as u64))
            .try_fold(1u64, u64::checked_mul)
            .unwrap_or(u64::MAX);
        if candidates > MAX_CANDIDATES {
            return Err(key_error(
                file,
                "search",
                format!("{candidates} candidates"),
                format!("at most {MAX_CANDIDATES} candidates a search"),
            ));
        }
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "checked small"
        )]
        let refine = match number(search, "search.refine", "refine")? {
            None => 3,
            Some(v) if v.fract() == 0.0 && (0.0..=100.0).contains(&v) => v as usize,
            Some(v) => {
                return Err(key_error(
                    file,
                    "search.refine",
                    v,
                    "must be a whole number in [0, 100]",
                ));
            }
        };
        let refine_to = in_range(
            "search.refine_to",
            number(search, "search.refine_to", "refine_to")?.unwrap_or(0.5),
            1e-6,
            180.0,
            " deg",
        )?;
        let refine_to_m = in_range(
            "search.refine_to_m",
            number(search, "search.refine_to_m", "refine_to_m")?.unwrap_or(0.01),
            1e-6,
            100.0,
            " m",
        )?;
        let varying: Vec<usize> = (0..6).filter(|&k| axes[k].len() > 1).collect();
        if uniform.is_some() && search.contains_key("landscape") {
            return Err(key_error(
                file,
                "search.landscape",
                search["landscape"].clone(),
                "needs a grid of roll, pitch, yaw (search.uniform scatters the rotations)",
            ));
        }
        let landscape = match search.get("landscape") {
            None => (uniform.is_none() && varying.len() >= 2).then(|| [varying[0], varying[1]]),
            Some(toml::Value::Array(a)) => {
                let names: Vec<Option<usize>> = a
                    .iter()
                    .map(|v| v.as_str().and_then(|s| AXES.iter().position(|n| *n == s)))
                    .collect();
                match names.as_slice() {
                    [Some(x), Some(y)] if x != y && varying.contains(x) && varying.contains(y) => {
                        Some([*x, *y])
                    }
                    _ => {
                        return Err(key_error(
                            file,
                            "search.landscape",
                            search["landscape"].clone(),
                            "must name two different axes the search varies (roll, pitch, yaw, x, y, z)",
                        ));
                    }
                }
            }
            Some(other) => {
                return Err(key_error(
                    file,
                    "search.landscape",
                    other,
                    "must be a list of two axis names",
                ));
            }
        };
        let from_pose = match table("from_pose")? {
            None => None,
            Some(t) => {
                only(
                    file,
                    "from_pose.",
                    t,
                    &[
                        "roll",
                        "pitch",
                        "yaw",
                        "x",
                        "y",
                        "z",
                        "step",
                        "step_m",
                        "gradient_step",
                        "gradient_step_m",
                    ],
                )?;
                let get = |k: &str, lo: f64, hi: f64, unit: &str| -> Result<f64> {
                    let name = format!("from_pose.{k}");
                    in_range(&name, number(t, &name, k)?.unwrap_or(0.0), lo, hi, unit)
                };
                let rotation = [
                    get("roll", -360.0, 360.0, " deg")?,
                    get("pitch", -360.0, 360.0, " deg")?,
                    get("yaw", -360.0, 360.0, " deg")?,
                ];
                let offset = [
                    get("x", -1000.0, 1000.0, " m")?,
                    get("y", -1000.0, 1000.0, " m")?,
                    get("z", -1000.0, 1000.0, " m")?,
                ];
                if matches!(rig, Rig::Place { .. }) && offset != [0.0; 3] {
                    return Err(key_error(
                        file,
                        "from_pose",
                        format!("offset {offset:?}"),
                        "x, y, z only with [rig] origin or translation",
                    ));
                }
                let positive = |k: &str, default: f64, hi: f64, unit: &str| -> Result<f64> {
                    let name = format!("from_pose.{k}");
                    in_range(&name, number(t, &name, k)?.unwrap_or(default), 1e-6, hi, unit)
                };
                Some(FromPose {
                    rotation,
                    offset,
                    step: positive("step", 5.0, 90.0, " deg")?,
                    step_m: positive("step_m", 0.1, 100.0, " m")?,
                    gradient_step: positive("gradient_step", 0.5, 10.0, " deg")?,
                    gradient_step_m: positive("gradient_step_m", 0.01, 10.0, " m")?,
                })
            }
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
            axes,
            uniform,
            refine,
            refine_to,
            refine_to_m,
            landscape,
            from_pose,
        };
        // Every candidate's translation stays within the engine's bound: its length is at most
        // the rig's reach (the origin or translation and the largest offset the search, the
        // pose now and its moves give it; a placement's two ranges).
        let reach = crate::advise::score::reach(&config);
        if reach > sonarproj::limits::MAX_TRANSLATION {
            return Err(key_error(
                file,
                "rig",
                format!("a translation of up to {reach} m"),
                format!(
                    "must keep every candidate's translation within {} m (with the search's offsets)",
                    sonarproj::limits::MAX_TRANSLATION
                ),
            ));
        }
        // The rig and a candidate make valid poses (a placement too far, say).
        crate::advise::score::pose_of(&config, [0.0; 6])
            .map_err(|e| Error::invalid(format!("advise file {file:?}: rig"), e, "must give a valid pose"))?;
        Ok(config)
    }
}

/// Reads one number: `(table, name in messages, key)`.
type NumberOf<'a> = dyn Fn(&toml::Table, &str, &str) -> Result<Option<f64>> + 'a;

/// Returns the features of `[features]`: drawn (a count and a seed) or given as points, each
/// checked to lie in sonar 1's field of view.
fn features(file: &str, t: Option<&toml::Table>, source: &Sonar, number: &NumberOf<'_>) -> Result<Features> {
    let missing = || {
        Error::input(
            format!("advise file {file:?}: features"),
            "missing; required: [features] with count (and seed) or points",
        )
    };
    let t = t.ok_or_else(missing)?;
    only(file, "features.", t, &["count", "seed", "points"])?;
    if let Some(points) = t.get("points") {
        if t.contains_key("count") {
            return Err(key_error(
                file,
                "features.count",
                t["count"].clone(),
                "give count or points, not both",
            ));
        }
        let bad = || {
            key_error(
                file,
                "features.points",
                points.clone(),
                "must be a list of [range, azimuth, elevation]",
            )
        };
        let list = points.as_array().ok_or_else(bad)?;
        if list.is_empty() || list.len() > MAX_FEATURES {
            return Err(key_error(
                file,
                "features.points",
                format!("{} points", list.len()),
                format!("must have 1 to {MAX_FEATURES}"),
            ));
        }
        return Ok(Features::Points(
            list.iter()
                .enumerate()
                .map(|(i, p)| {
                    // Every element a number: a stray string is refused, not skipped.
                    let xyz: Vec<f64> = p
                        .as_array()
                        .and_then(|a| {
                            a.iter()
                                .map(|v| v.as_float().or(v.as_integer().map(|i| i as f64)))
                                .collect::<Option<Vec<f64>>>()
                        })
                        .unwrap_or_default();
                    let [r, az, el] = xyz.as_slice() else {
                        return Err(bad());
                    };
                    source
                        .check_point("feature", *r, *az, *el)
                        .map_err(|e| e.in_context(&format!("advise file {file:?}: features.points[{i}]")))?;
                    Ok([*r, *az, *el])
                })
                .collect::<Result<_>>()?,
        ));
    }
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "checked range"
    )]
    let count = match number(t, "features.count", "count")? {
        Some(v) if v.fract() == 0.0 && (1.0..=MAX_FEATURES as f64).contains(&v) => v as usize,
        Some(v) => {
            return Err(key_error(
                file,
                "features.count",
                v,
                format!("must be a whole number in [1, {MAX_FEATURES}]"),
            ));
        }
        None => return Err(missing()),
    };
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "checked range"
    )]
    let seed = match number(t, "features.seed", "seed")? {
        None => 1,
        Some(v) if v.fract() == 0.0 && (0.0..=9.0e15).contains(&v) => v as u64,
        Some(v) => return Err(key_error(file, "features.seed", v, "must be a whole number >= 0")),
    };
    Ok(Features::Drawn { count, seed })
}

/// Returns `count` points drawn uniformly over `sonar`'s field of view as a volume (seeded),
/// `[range m, azimuth deg, elevation deg]`:
/// the range's cube uniform between the bounds' cubes, the azimuth uniform, the elevation's sine
/// uniform, so every cell of equal volume is as likely.
#[must_use]
pub fn draw_features(source: &Sonar, count: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (lo, hi) = (source.range_min.max(1e-3), source.range_max);
    let (ha, he) = (
        source.azimuth_aperture / 2.0,
        (source.elevation_aperture / 2.0).to_radians(),
    );
    (0..count)
        .map(|_| {
            let u: f64 = rng.random();
            let r = (lo.powi(3) + u * (hi.powi(3) - lo.powi(3))).cbrt().clamp(lo, hi);
            let az = ha * (2.0 * rng.random::<f64>() - 1.0);
            let s = he.sin() * (2.0 * rng.random::<f64>() - 1.0);
            [
                r,
                az,
                s.asin().to_degrees().clamp(-he.to_degrees(), he.to_degrees()),
            ]
        })
        .collect()
}

/// Returns the `[rig]`: one of origin, translation, place.
fn rig(file: &str, t: Option<&toml::Table>) -> Result<Rig> {
    let missing = || {
        Error::input(
            format!("advise file {file:?}: rig"),
            "missing; required: [rig] with origin, translation or place",
        )
    };
    let t = t.ok_or_else(missing)?;
    only(file, "rig.", t, &["origin", "translation", "place"])?;
    if t.len() != 1 {
        return Err(key_error(
            file,
            "rig",
            toml::Value::Table(t.clone()),
            "give one of origin, translation, place",
        ));
    }
    let triple = |name: &str, v: &toml::Value| -> Result<[f64; 3]> {
        // Every element a number: a stray string is refused, not skipped.
        let xyz: Vec<f64> = v
            .as_array()
            .and_then(|a| {
                a.iter()
                    .map(|x| x.as_float().or(x.as_integer().map(|i| i as f64)))
                    .collect::<Option<Vec<f64>>>()
            })
            .unwrap_or_default();
        match xyz.as_slice() {
            [a, b, c]
                if xyz
                    .iter()
                    .all(|v| v.is_finite() && v.abs() <= sonarproj::limits::MAX_TRANSLATION) =>
            {
                Ok([*a, *b, *c])
            }
            _ => Err(key_error(
                file,
                name,
                v.clone(),
                "must be three finite numbers (m, or [range m, azimuth deg, elevation deg])",
            )),
        }
    };
    let (k, v) = t.iter().next().expect("one key");
    match k.as_str() {
        "origin" => Ok(Rig::Origin(triple("rig.origin", v)?)),
        "translation" => Ok(Rig::Translation(triple("rig.translation", v)?)),
        _ => {
            let place = v.as_table().ok_or_else(|| {
                key_error(
                    file,
                    "rig.place",
                    v.clone(),
                    "must be { feature = [r, az, el], at = [r, az, el] }",
                )
            })?;
            only(file, "rig.place.", place, &["feature", "at"])?;
            let get = |name: &str| -> Result<[f64; 3]> {
                let v = place.get(name).ok_or_else(|| {
                    Error::input(format!("advise file {file:?}: rig.place.{name}"), "missing")
                })?;
                triple(&format!("rig.place.{name}"), v)
            };
            Ok(Rig::Place {
                feature: get("feature")?,
                at: get("at")?,
            })
        }
    }
}
