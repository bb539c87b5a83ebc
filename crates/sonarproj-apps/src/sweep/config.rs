//! Sweep files: a TOML description of a sonar pair, a sampling rule and the poses to run — a
//! grid over the feature, its placement (or the translation) and roll/pitch/yaw, or an explicit
//! list of poses in a batch CSV.
//!
//! ```toml
//! from = "paper-fls"          # sonar 1: preset or sonar TOML file (relative to this file)
//! to = "paper-sss"            # sonar 2
//! step = 0.1                  # sampling step (deg); leave out for auto sampling
//! metric = "span"             # metric drawn in the figure (default: span for an SSS target,
//!                             # projection_area for an FLS target, when `columns` keeps it)
//! area_grid = 0.08            # cell side (m) of the projection-area grid (default: the paper's)
//! sigma_range = 0.003         # range error (m) of sigma_elevation (default: a bin width / √12)
//! columns = ["span", "projection_area"]  # the result columns the table keeps (default: all)
//!
//! [feature]                   # the feature's true point in sonar 1 (m, deg, deg)
//! range = { start = 10, stop = 50, step = 10 }
//! azimuth = 0
//! elevation = 0
//!
//! [place]                     # where it appears in sonar 2 (or [translation] x, y, z in m)
//! range = 25
//!
//! [rotation]                  # roll, pitch, yaw (deg), R = (Rz Ry Rx)ᵀ
//! roll = { start = 0, stop = 180, step = 1 }
//! yaw = [0, 45, 90]
//! ```
//!
//! Every grid key takes a number, a list of numbers or `{ start, stop, step }` (start, start +
//! step, … up to stop); keys left out are 0 (`feature.range` and `place.range` are required).
//! Instead of the grid, `poses = "poses.csv"` names a batch CSV (the columns of `sonarproj batch`).

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::io::batch::PoseRow;
use crate::io::{BatchInput, read_batch_csv_at_most};
use crate::sweep::summary::{self, SummarySpec};
use crate::sweep::table;
use sonarproj::geometry::sonar::Sonar;
use sonarproj::metrics::Metric;
use sonarproj::projection::Batch;
use sonarproj::sampling::Sampling;

use crate::limits::MAX_LIST_POSES;
pub use sonarproj::limits::{MAX_AXIS_VALUES, MAX_POSES};

/// One grid axis: a column of the output and the values it takes.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The output column (also the batch CSV column).
    pub column: &'static str,
    /// The values, in order.
    pub values: Vec<f64>,
}

/// A full grid: every combination of the axes' values, the last axis fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// The axes in column order: range, azimuth, elevation, then place_range, place_azimuth,
    /// place_elevation (or tx, ty, tz), then roll, pitch, yaw.
    pub axes: Vec<Axis>,
    /// Whether the translation is a placement (else tx, ty, tz).
    pub placement: bool,
}

/// Where a sweep's poses come from.
#[derive(Clone, Debug)]
pub enum Poses {
    /// A grid.
    Grid(Grid),
    /// An explicit list (a batch CSV).
    List(BatchInput),
}

/// A parsed, checked sweep file.
#[derive(Clone, Debug)]
pub struct SweepConfig {
    /// Sonar 1.
    pub source: Sonar,
    /// Sonar 2.
    pub target: Sonar,
    /// The sampling rule.
    pub sampling: Sampling,
    /// The cell side (m) of the projection-area grid (FLS target).
    pub area_grid: f64,
    /// The range error (m) `sigma_elevation` is computed for (`None`: the default of
    /// [`sonarproj::local_precision::default_sigma_range`]).
    pub sigma_range: Option<f64>,
    /// The metric the figure draws (one with a figure label in the metric table).
    pub metric: Metric,
    /// The result columns the table keeps after the pose columns, in table order: some of
    /// [`METRIC_COLUMNS`](crate::io::METRIC_COLUMNS) (all unless the file's `columns` names
    /// fewer).
    pub result_columns: Vec<&'static str>,
    /// The poses.
    pub poses: Poses,
    /// The summaries asked for (`[summary]`), if any.
    pub summary: Option<SummarySpec>,
}

/// Returns the error for key `key` of sweep file `file`.
pub(crate) fn key_error(
    file: &str,
    key: &str,
    value: impl std::fmt::Display,
    allowed: impl Into<String>,
) -> Error {
    Error::invalid(format!("sweep file {file:?}: {key}"), value, allowed)
}

/// Returns the error of sweep file `file` for the missing key `key`, which `needed` explains.
pub(crate) fn missing_key(file: &str, key: &str, needed: &str) -> Error {
    Error::input(
        format!("sweep file {file:?}: {key}"),
        format!("missing; {needed}"),
    )
}

/// Returns the values of grid key `key` given as `v`: a number, a list or `{start, stop, step}`.
#[expect(
    clippy::cast_possible_truncation,
    reason = "grid sizes are checked against MAX_POSES before they are used as indices"
)]
pub(crate) fn axis_values(file: &str, key: &str, v: &toml::Value) -> Result<Vec<f64>> {
    let shape = "must be a number, a list of numbers or { start, stop, step }";
    let number = |v: &toml::Value, k: &str| -> Result<f64> {
        let x = match v {
            toml::Value::Integer(i) => *i as f64,
            toml::Value::Float(f) => *f,
            other => return Err(key_error(file, k, other, "must be a number")),
        };
        if x.is_finite() {
            Ok(x)
        } else {
            Err(key_error(file, k, x, "must be a finite number"))
        }
    };
    match v {
        toml::Value::Integer(_) | toml::Value::Float(_) => Ok(vec![number(v, key)?]),
        toml::Value::Array(a) if !a.is_empty() => a
            .iter()
            .enumerate()
            .map(|(i, x)| number(x, &format!("{key}[{i}]")))
            .collect(),
        toml::Value::Array(_) => Err(key_error(file, key, "[]", "must list at least one value")),
        toml::Value::Table(t) => {
            for k in t.keys() {
                if !["start", "stop", "step"].contains(&k.as_str()) {
                    return Err(key_error(
                        file,
                        &format!("{key}.{k}"),
                        t[k].clone(),
                        "unknown key (allowed: start, stop, step)",
                    ));
                }
            }
            let get = |k: &str| -> Result<f64> {
                let full = format!("{key}.{k}");
                match t.get(k) {
                    Some(x) => number(x, &full),
                    None => Err(missing_key(file, &full, "required with start, stop, step")),
                }
            };
            let (start, stop, step) = (get("start")?, get("stop")?, get("step")?);
            if step <= 0.0 {
                return Err(key_error(file, &format!("{key}.step"), step, "must be > 0"));
            }
            if stop < start {
                return Err(key_error(
                    file,
                    &format!("{key}.stop"),
                    stop,
                    format!("must be >= start ({start})"),
                ));
            }
            let n = ((stop - start) / step + 1e-9).floor();
            if n >= MAX_AXIS_VALUES as f64 {
                return Err(key_error(
                    file,
                    &format!("{key}.step"),
                    step,
                    format!(
                        "gives {} values from {start} to {stop}; at most {MAX_AXIS_VALUES} per axis",
                        n + 1.0
                    ),
                ));
            }
            Ok((0..=n as u64).map(|i| start + i as f64 * step).collect())
        }
        other => Err(key_error(file, key, other, shape)),
    }
}

/// Returns the table under `key` (empty when missing), checking its keys against `allowed`.
fn section<'a>(
    file: &str,
    top: &'a toml::Table,
    key: &str,
    allowed: &[&str],
) -> Result<Option<&'a toml::Table>> {
    match top.get(key) {
        None => Ok(None),
        Some(toml::Value::Table(t)) => {
            for k in t.keys() {
                if !allowed.contains(&k.as_str()) {
                    return Err(key_error(
                        file,
                        &format!("{key}.{k}"),
                        t[k].clone(),
                        format!("unknown key (allowed: {})", allowed.join(", ")),
                    ));
                }
            }
            Ok(Some(t))
        }
        Some(other) => Err(key_error(file, key, other, "must be a table ([{key}])")),
    }
}

/// Returns the axis `column` read from `table.name` (0 when left out, an error when `required`).
fn axis(
    file: &str,
    table: Option<&toml::Table>,
    prefix: &str,
    name: &str,
    column: &'static str,
    required: bool,
) -> Result<Axis> {
    let key = format!("{prefix}.{name}");
    let values = match table.and_then(|t| t.get(name)) {
        Some(v) => axis_values(file, &key, v)?,
        None if required => return Err(missing_key(file, &key, "required")),
        None => vec![0.0],
    };
    Ok(Axis { column, values })
}

/// Returns the sonar `spec` names from a sweep file in `base`: a preset, or a file relative to
/// the sweep file.
pub(crate) fn resolve_sonar(spec: &str, base: &Path) -> Result<Sonar> {
    let joined = base.join(spec);
    let sonar = if Sonar::preset(spec).is_some() || Path::new(spec).is_absolute() {
        Sonar::resolve(spec)?
    } else if joined.is_file() {
        crate::report::note_input(&joined);
        Sonar::from_toml_file(&joined)?
    } else {
        Sonar::resolve(spec)?
    };
    if Sonar::preset(spec).is_none() && Path::new(spec).is_absolute() {
        crate::report::note_input(Path::new(spec));
    }
    Ok(sonar)
}

impl SweepConfig {
    /// Returns the sweep described by the file at `path`, checked.
    ///
    /// # Errors
    /// [`Error::ReadInput`], [`Error::SweepFile`] (TOML syntax) or [`sonarproj::Error::InvalidValue`] naming
    /// the file and the key.
    pub fn load(path: &Path) -> Result<SweepConfig> {
        let (text, base) = crate::report::read_config(path)?;
        SweepConfig::parse(&path.display().to_string(), &text, &base)
    }

    /// Returns the sweep described by TOML `text`, called `file` in messages, with relative
    /// paths taken from `base`.
    ///
    /// # Errors
    /// As [`SweepConfig::load`].
    pub fn parse(file: &str, text: &str, base: &Path) -> Result<SweepConfig> {
        let top: toml::Table = text.parse().map_err(|e: toml::de::Error| Error::SweepFile {
            path: PathBuf::from(file),
            message: sonarproj::error::parser_message(&e.to_string()),
        })?;
        const TOP: [&str; 13] = [
            "from",
            "to",
            "step",
            "metric",
            "columns",
            "area_grid",
            "sigma_range",
            "feature",
            "place",
            "translation",
            "rotation",
            "poses",
            "summary",
        ];
        for k in top.keys() {
            if !TOP.contains(&k.as_str()) {
                return Err(key_error(
                    file,
                    k,
                    top[k].clone(),
                    format!("unknown key (allowed: {})", TOP.join(", ")),
                ));
            }
        }
        let string = |k: &str| -> Result<Option<&str>> {
            match top.get(k) {
                None => Ok(None),
                Some(toml::Value::String(s)) => Ok(Some(s)),
                Some(other) => Err(key_error(file, k, other, "must be a string")),
            }
        };
        let sonar = |k: &str| -> Result<Sonar> {
            let spec = string(k)?
                .ok_or_else(|| missing_key(file, k, "required: a preset name or a sonar TOML file"))?;
            resolve_sonar(spec, base)
        };
        let (source, target) = (sonar("from")?, sonar("to")?);
        // A key holding one positive number (in `unit`), `None` when left out.
        let positive = |key: &str, unit: &str| -> Result<Option<f64>> {
            let Some(v) = top.get(key) else { return Ok(None) };
            match axis_values(file, key, v)?.as_slice() {
                [x] if *x > 0.0 => Ok(Some(*x)),
                _ => Err(key_error(
                    file,
                    key,
                    v,
                    format!("must be one number > 0 ({unit})"),
                )),
            }
        };
        let sampling = match top.get("step") {
            Some(toml::Value::String(s)) if s == "auto" => Sampling::Auto,
            _ => positive("step", "deg, or \"auto\"")?.map_or(Sampling::Auto, Sampling::Step),
        };
        let area_grid = positive("area_grid", "m")?.unwrap_or(sonarproj::PAPER_AREA_GRID);
        let sigma_range = positive("sigma_range", "m")?;
        let result_columns = match top.get("columns") {
            None => crate::io::METRIC_COLUMNS.to_vec(),
            Some(v) => table::result_columns(file, v)?,
        };
        let named = match string("metric")? {
            None => None,
            Some(m) => Some(
                Metric::from_name(m)
                    .filter(|m| m.label(target.kind).is_some())
                    .ok_or_else(|| {
                        let names: Vec<&str> = Metric::all()
                            .filter(|m| m.label(target.kind).is_some())
                            .map(Metric::name)
                            .collect();
                        key_error(
                            file,
                            "metric",
                            format!("{m:?}"),
                            format!("must be one of {}", names.join(", ")),
                        )
                    })?,
            ),
        };
        // The figure draws from the table: a metric the file does not name is one it keeps. A
        // summary reduces any metric: its default is the file's metric, or the sonar's.
        let metric = named.unwrap_or_else(|| table::default_metric(target.kind, &result_columns));
        let by = named.unwrap_or_else(|| table::default_metric(target.kind, &crate::io::METRIC_COLUMNS));
        let poses = if let Some(list) = string("poses")? {
            for k in ["feature", "place", "translation", "rotation"] {
                if top.contains_key(k) {
                    return Err(key_error(
                        file,
                        k,
                        top[k].clone(),
                        "cannot be combined with poses (the list gives every pose)",
                    ));
                }
            }
            let path = base.join(list);
            // Read as a stream, at most MAX_LIST_POSES rows held.
            let opened = std::fs::File::open(&path).map_err(|source| Error::ReadInput {
                path: path.clone(),
                source,
            })?;
            let reader = std::io::BufReader::with_capacity(1 << 16, opened);
            let input = read_batch_csv_at_most(
                reader,
                &source,
                MAX_LIST_POSES,
                &format!("{file}: poses {list:?}"),
            )
            .map_err(|e| match e {
                Error::Csv { context, message } => Error::Csv {
                    context: format!("{}: {context}", path.display()),
                    message,
                },
                other => other,
            })?;
            Poses::List(input)
        } else {
            Poses::Grid(Self::grid(file, &top, &source)?)
        };
        let summary = match top.get("summary") {
            None => None,
            Some(toml::Value::Table(t)) => {
                let grid = match &poses {
                    Poses::Grid(g) => Some(g),
                    Poses::List(_) => None,
                };
                Some(summary::from_toml(file, t, by, target.kind)?.checked(file, grid)?)
            }
            Some(other) => return Err(key_error(file, "summary", other, "must be a table: [summary]")),
        };
        table::check_columns(file, &top, &result_columns, metric, summary.as_ref())?;
        let config = SweepConfig {
            source,
            target,
            sampling,
            area_grid,
            sigma_range,
            metric,
            result_columns,
            poses,
            summary,
        };
        config.count()?;
        config.check_sampling()?;
        Ok(config)
    }

    /// Returns `Ok` when no pose would draw more samples than a pose may, so that a sweep is
    /// refused before it creates anything: each listed pose is checked; for a grid, the pose with
    /// its largest feature range (a plan's sample count grows with the feature's range and depends
    /// on nothing else a grid varies).
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] for the sampling, naming the list row when there is one.
    fn check_sampling(&self) -> Result<()> {
        let pair = Batch {
            source: self.source.clone(),
            target: self.target.clone(),
            sampling: self.sampling,
            area_grid: self.area_grid,
            items: Vec::new(),
        };
        let checker = pair.checker()?;
        match &self.poses {
            Poses::List(l) => {
                for (k, item) in l.items.iter().enumerate() {
                    checker.check(item).map_err(|e| Error::Csv {
                        context: format!("pose list row {}", k + 1),
                        message: e.to_string(),
                    })?;
                }
            }
            Poses::Grid(g) if g.axes.iter().all(|a| !a.values.is_empty()) => {
                let mut v: Vec<f64> = g.axes.iter().map(|a| a.values[0]).collect();
                v[0] = g.axes[0].values.iter().copied().fold(f64::MIN, f64::max);
                checker.check(&g.item(&self.source, &v)?)?;
            }
            Poses::Grid(_) => {}
        }
        Ok(())
    }

    /// Returns the grid of sweep file `file`, the feature checked against sonar 1.
    fn grid(file: &str, top: &toml::Table, source: &Sonar) -> Result<Grid> {
        let rae = ["range", "azimuth", "elevation"];
        let feature = section(file, top, "feature", &rae)?;
        let place = section(file, top, "place", &rae)?;
        let translation = section(file, top, "translation", &["x", "y", "z"])?;
        let rotation = section(file, top, "rotation", &["roll", "pitch", "yaw"])?;
        if feature.is_none() {
            return Err(missing_key(
                file,
                "feature",
                "required: [feature] with range (or poses = \"FILE.csv\")",
            ));
        }
        let mut axes = vec![
            axis(file, feature, "feature", "range", "range", true)?,
            axis(file, feature, "feature", "azimuth", "azimuth", false)?,
            axis(file, feature, "feature", "elevation", "elevation", false)?,
        ];
        let placement = match (place, translation) {
            (Some(_), Some(_)) => {
                return Err(key_error(
                    file,
                    "translation",
                    "given",
                    "give [place] or [translation], not both",
                ));
            }
            (None, None) => {
                return Err(missing_key(
                    file,
                    "place",
                    "required: [place] with range, or [translation]",
                ));
            }
            (Some(_), None) => {
                let a = axis(file, place, "place", "range", "place_range", true)?;
                if let Some(r) = a.values.iter().find(|r| **r < 0.0) {
                    return Err(key_error(file, "place.range", r, "must be >= 0 m"));
                }
                axes.extend([
                    a,
                    axis(file, place, "place", "azimuth", "place_azimuth", false)?,
                    axis(file, place, "place", "elevation", "place_elevation", false)?,
                ]);
                true
            }
            (None, Some(_)) => {
                axes.extend([
                    axis(file, translation, "translation", "x", "tx", false)?,
                    axis(file, translation, "translation", "y", "ty", false)?,
                    axis(file, translation, "translation", "z", "tz", false)?,
                ]);
                false
            }
        };
        for name in ["roll", "pitch", "yaw"] {
            axes.push(axis(file, rotation, "rotation", name, name, false)?);
        }
        // Every feature point must lie in sonar 1's field of view.
        for (k, a) in axes[..3].iter().enumerate() {
            for &v in &a.values {
                let mut p = [axes[0].values[0], axes[1].values[0], axes[2].values[0]];
                p[k] = v;
                // Bounds are per coordinate, so checking each value with the others at their
                // first values covers every combination.
                source
                    .check_point("feature", p[0], p[1], p[2])
                    .map_err(|e| e.in_context(&format!("sweep file {file:?}: feature.{}", rae[k])))?;
            }
        }
        let grid = Grid { axes, placement };
        // The engine's checks too (a placement's reach), named in the file's terms.
        grid.pose_grid(source)
            .map_err(|e| e.in_context(&format!("sweep file {file:?}")))?;
        Ok(grid)
    }

    /// Returns the number of poses.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] when the grid has more than [`MAX_POSES`].
    pub fn count(&self) -> Result<u64> {
        match &self.poses {
            Poses::List(l) => Ok(l.items.len() as u64),
            Poses::Grid(g) => g
                .axes
                .iter()
                .try_fold(1u64, |n, a| n.checked_mul(a.values.len() as u64))
                .filter(|&n| n <= MAX_POSES)
                .ok_or_else(|| {
                    let axes: Vec<(&str, usize)> =
                        g.axes.iter().map(|a| (a.column, a.values.len())).collect();
                    sonarproj::projection::poses::too_many_poses("sweep grid", &axes).into()
                }),
        }
    }

    /// Returns the output columns before the metrics: `index`, then the grid's columns (or the
    /// list's columns as given).
    #[must_use]
    pub fn columns(&self) -> Vec<String> {
        let mut out = vec!["index".to_string()];
        match &self.poses {
            Poses::Grid(g) => out.extend(g.axes.iter().map(|a| a.column.to_string())),
            Poses::List(l) => out.extend(l.headers.iter().cloned()),
        }
        out
    }

    /// Returns the grid columns that take more than one value (none for a list).
    #[must_use]
    pub fn varying(&self) -> Vec<String> {
        match &self.poses {
            Poses::Grid(g) => g
                .axes
                .iter()
                .filter(|a| a.values.len() > 1)
                .map(|a| a.column.to_string())
                .collect(),
            Poses::List(_) => Vec::new(),
        }
    }

    /// Returns the poses with indices in `range`: each as a batch item with the feature's true
    /// point (when the list gives it; a grid always does) and its leading output fields (index
    /// and pose columns).
    ///
    /// # Errors
    /// Invalid poses (a rotation that is not one; none for grids of finite angles).
    #[expect(
        clippy::cast_possible_truncation,
        reason = "grid sizes are checked against MAX_POSES before they are used as indices"
    )]
    pub fn items(&self, range: std::ops::Range<u64>) -> Result<(Vec<PoseRow>, Vec<Vec<String>>)> {
        // In parallel: formatting the fields costs as much as projecting some batches.
        let pairs = range
            .into_par_iter()
            .map(|i| {
                let mut row = vec![i.to_string()];
                let pose = match &self.poses {
                    Poses::List(l) => {
                        row.extend(l.rows[i as usize].iter().cloned());
                        PoseRow {
                            item: l.items[i as usize],
                            true_point: l.true_points[i as usize],
                        }
                    }
                    Poses::Grid(g) => {
                        let v = g.values(i);
                        row.extend(v.iter().map(f64::to_string));
                        PoseRow {
                            true_point: Some([v[0], v[1], v[2]]),
                            item: g.item(&self.source, &v)?,
                        }
                    }
                };
                Ok((pose, row))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(pairs.into_iter().unzip())
    }

    /// Returns the poses with indices in `range` as [`SweepConfig::items`] does, with their pose
    /// columns as numbers (row after row, the columns of [`SweepConfig::columns`] after
    /// `index`) instead of text.
    ///
    /// # Errors
    /// As [`SweepConfig::items`]; a list's field that is not a number.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "grid sizes are checked against MAX_POSES before they are used as indices"
    )]
    pub fn items_numeric(&self, range: std::ops::Range<u64>) -> Result<(Vec<PoseRow>, Vec<f64>)> {
        let n = (range.end - range.start) as usize;
        let width = self.columns().len() - 1;
        // Each pose's numbers written in place, its item built from them: nothing is allocated
        // per pose (this runs for every pose of a sweep).
        let mut values = vec![0.0; n * width];
        let poses = values
            .par_chunks_mut(width.max(1))
            .enumerate()
            .map(|(k, v)| {
                let i = range.start + k as u64;
                match &self.poses {
                    Poses::List(l) => {
                        for (out, t) in v.iter_mut().zip(&l.rows[i as usize]) {
                            *out = t.trim().parse::<f64>().map_err(|_| {
                                Error::invalid(format!("poses row {i}"), format!("{t:?}"), "must be a number")
                            })?;
                        }
                        Ok(PoseRow {
                            item: l.items[i as usize],
                            true_point: l.true_points[i as usize],
                        })
                    }
                    Poses::Grid(g) => {
                        g.values_into(i, v);
                        Ok(PoseRow {
                            true_point: Some([v[0], v[1], v[2]]),
                            item: g.item(&self.source, v)?,
                        })
                    }
                }
            })
            .collect::<Result<Vec<_>>>()?;
        Ok((poses, values))
    }

    /// Returns a fingerprint of everything in the file that decides the output (sonars,
    /// sampling, area grid, range error, poses):
    /// FNV-1a over their full debug form, so a resumed or merged sweep can tell its own parts.
    #[must_use]
    pub fn fingerprint(&self) -> String {
        let mut text = format!(
            "{:?}|{:?}|{:?}|{:?}|{:?}|{}|{:?}",
            self.source,
            self.target,
            self.sampling,
            self.area_grid,
            self.sigma_range,
            self.metric.name(),
            match &self.poses {
                Poses::Grid(g) => format!("{g:?}"),
                Poses::List(l) => format!("{:?}{:?}", l.headers, l.rows),
            }
        );
        // Only when asked for, so the sweeps of files without one keep their fingerprints.
        if let Some(s) = &self.summary {
            text.push_str(&format!("|{s:?}"));
        }
        if self.result_columns != crate::io::METRIC_COLUMNS {
            text.push_str(&format!("|columns {:?}", self.result_columns));
        }
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in text.bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        format!("{h:016x}")
    }

    /// Returns the figure's axis label for the metric (it depends on sonar 2's kind).
    #[must_use]
    pub fn metric_label(&self) -> &'static str {
        // Checked when read: only metrics with a label are accepted.
        self.metric.label(self.target.kind).unwrap_or(self.metric.name())
    }
}

impl Grid {
    /// Returns the axis values of pose `i` (mixed radix, the last axis fastest).
    #[must_use]
    pub fn values(&self, i: u64) -> Vec<f64> {
        let mut out = vec![0.0; self.axes.len()];
        self.values_into(i, &mut out);
        out
    }

    /// Writes the axis values of pose `i` into `out` (one per axis), as [`Grid::values`].
    #[expect(
        clippy::cast_possible_truncation,
        reason = "grid sizes are checked against MAX_POSES before they are used as indices"
    )]
    pub fn values_into(&self, mut i: u64, out: &mut [f64]) {
        for (k, a) in self.axes.iter().enumerate().rev() {
            let n = a.values.len() as u64;
            out[k] = a.values[(i % n) as usize];
            i /= n;
        }
    }
}
