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

use sonarproj::geometry::sonar::Sonar;
use sonarproj::sampling::Sampling;

use crate::advise::features::Features;
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

pub(super) fn key_error(
    file: &str,
    key: &str,
    value: impl std::fmt::Display,
    allowed: impl Into<String>,
) -> Error {
    Error::invalid(format!("advise file {file:?}: {key}"), value, allowed)
}

/// Returns the keys of `table` that are not in `allowed`, as an error naming the first.
pub(super) fn only(file: &str, section: &str, table: &toml::Table, allowed: &[&str]) -> Result<()> {
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
        let (text, base) = crate::report::read_config(path)?;
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
        let features = crate::advise::features::read(file, table("features")?, &source, &number)?;
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
        #[expect(clippy::cast_possible_truncation, reason = "at most 10^6")]
        let uniform = whole(file, &number, search, "search.uniform", 2.0, 1e6)?.map(|n| n as usize);
        if uniform.is_some()
            && let Some(k) = ["roll", "pitch", "yaw"].iter().find(|k| search.contains_key(**k))
        {
            return Err(key_error(
                file,
                &format!("search.{k}"),
                search[*k].clone(),
                "give the rotations as search.uniform or as roll, pitch, yaw, not both",
            ));
        }
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
        #[expect(clippy::cast_possible_truncation, reason = "at most 100")]
        let refine = whole(file, &number, search, "search.refine", 0.0, 100.0)?.map_or(3, |n| n as usize);
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
pub(super) type NumberOf<'a> = dyn Fn(&toml::Table, &str, &str) -> Result<Option<f64>> + 'a;

/// Returns the whole number of key `key` in `t` (named `name` in messages) within `[lo, hi]`,
/// `None` when left out.
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "checked range"
)]
pub(super) fn whole(
    file: &str,
    number: &NumberOf<'_>,
    t: &toml::Table,
    name: &str,
    lo: f64,
    hi: f64,
) -> Result<Option<u64>> {
    let key = name.rsplit('.').next().unwrap_or(name);
    match number(t, name, key)? {
        None => Ok(None),
        Some(v) if v.fract() == 0.0 && (lo..=hi).contains(&v) => Ok(Some(v as u64)),
        Some(v) => Err(key_error(
            file,
            name,
            v,
            format!("must be a whole number in [{lo}, {hi}]"),
        )),
    }
}

/// Returns the numbers of TOML array `v`, `None` unless every element is one (a stray string is
/// refused, not skipped).
pub(super) fn numbers(v: &toml::Value) -> Option<Vec<f64>> {
    #[expect(clippy::cast_precision_loss, reason = "TOML integers taken as numbers")]
    let number = |x: &toml::Value| x.as_float().or(x.as_integer().map(|i| i as f64));
    v.as_array()?.iter().map(number).collect()
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
        let xyz: Vec<f64> = numbers(v).unwrap_or_default();
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
