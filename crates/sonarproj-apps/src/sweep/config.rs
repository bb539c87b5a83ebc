//! Sweep files: TOML describing a sonar pair, a sampling rule, and the poses to run.
//!
//! The poses are a grid over the feature, its placement (or translation) and roll/pitch/yaw, or
//! an explicit list in a batch CSV.
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
//! Every grid key takes a number, a list of numbers, or `{ start, stop, step }` (start, start +
//! step, … up to stop). Keys left out are 0, but `feature.range` and `place.range` are required.
//! Instead of the grid, `poses = "poses.csv"` names a batch CSV with `sonarproj batch`'s columns.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::io::toml_keys::ConfigFile;
use crate::io::{BatchInput, read_batch_csv_at_most};
use crate::sweep::columns;
use crate::sweep::summary::{self, SummarySpec};
use sonarproj::geometry::sonar::{Sonar, SonarKind};
use sonarproj::metrics::Metric;
use sonarproj::projection::{Batch, BatchItem};
use sonarproj::sampling::Sampling;

use crate::limits::MAX_LIST_POSES;
pub use crate::sweep::grid::{Axis, Grid};
pub use sonarproj::limits::{MAX_AXIS_VALUES, MAX_POSES};

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
    /// The range error (m) `sigma_elevation` is computed for.
    /// `None` uses [`sonarproj::local_precision::default_sigma_range`].
    pub sigma_range: Option<f64>,
    /// The metric the figure draws (one with a figure label in the metric table).
    pub metric: Metric,
    /// The result columns kept after the pose columns, in table order. Some of
    /// [`METRIC_COLUMNS`](crate::io::METRIC_COLUMNS): all unless the file's `columns` names fewer.
    pub result_columns: Vec<&'static str>,
    /// The poses.
    pub poses: Poses,
    /// The summaries asked for (`[summary]`), if any.
    pub summary: Option<SummarySpec>,
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
    /// [`Error::ReadInput`], [`Error::SweepFile`] (TOML syntax), or
    /// [`sonarproj::Error::InvalidValue`] naming the file and the key.
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
        let f = ConfigFile::sweep(file);
        f.only("", &top, &TOP_KEYS)?;
        let sonar = |k: &str| -> Result<Sonar> {
            let spec = f
                .string(&top, k)?
                .ok_or_else(|| f.missing(k, "required: a preset name or a sonar TOML file"))?;
            resolve_sonar(spec, base)
        };
        let (source, target) = (sonar("from")?, sonar("to")?);
        let sampling = match top.get("step") {
            Some(toml::Value::String(s)) if s == "auto" => Sampling::Auto,
            Some(toml::Value::String(s)) if s == "exact" => Sampling::Exact,
            _ => positive(f, &top, "step", "deg, \"auto\" or \"exact\"")?
                .map_or(Sampling::Auto, Sampling::Step),
        };
        let area_grid = positive(f, &top, "area_grid", "m")?.unwrap_or(sonarproj::PAPER_AREA_GRID);
        let sigma_range = positive(f, &top, "sigma_range", "m")?;
        let result_columns = match top.get("columns") {
            None => crate::io::METRIC_COLUMNS.to_vec(),
            Some(v) => columns::result_columns(f, v)?,
        };
        let named = named_metric(f, &top, target.kind)?;
        let exact = sampling == Sampling::Exact;
        if exact && named == Some(Metric::ProjectionArea) {
            return Err(f.error(
                "metric",
                "\"projection_area\"",
                "has no value with step = \"exact\" (it counts grid cells holding samples): \
                 choose span, occupied_measure or another metric, or a sampling step",
            ));
        }
        // Exact mode leaves the projection area empty: an FLS sonar 2's figure draws the span.
        let default = |kept: &[&str]| match columns::default_metric(target.kind, kept) {
            Metric::ProjectionArea if exact => Metric::Span,
            m => m,
        };
        // The figure draws from the table, so a metric the file does not name must be kept.
        // A summary reduces any metric: by default the file's metric, or the sonar's.
        let metric = named.unwrap_or_else(|| default(&result_columns));
        let by = named.unwrap_or_else(|| default(&crate::io::METRIC_COLUMNS));
        let poses = match f.string(&top, "poses")? {
            Some(list) => Poses::List(pose_list(f, &top, base, list, &source)?),
            None => Poses::Grid(Grid::read(f, &top, &source)?),
        };
        let summary = match top.get("summary") {
            None => None,
            Some(toml::Value::Table(t)) => {
                let grid = match &poses {
                    Poses::Grid(g) => Some(g),
                    Poses::List(_) => None,
                };
                Some(summary::from_toml(f, t, by, target.kind)?.checked(f.path(), grid)?)
            }
            Some(other) => return Err(f.error("summary", other, "must be a table: [summary]")),
        };
        columns::check_columns(f, &top, &result_columns, metric, summary.as_ref())?;
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

    /// Returns `Ok` when no pose would draw more samples than a pose may, before anything is made.
    /// Each listed pose is checked. A grid checks its largest feature range only: a plan's sample
    /// count grows with it and depends on nothing else a grid varies.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] for the sampling, naming the list row when there is one.
    fn check_sampling(&self) -> Result<()> {
        let pair = Batch {
            sigma_range: None,
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

    /// Returns the output columns before the metrics: `index`, then the grid's or list's columns.
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

    /// Returns the poses with indices in `range`: batch items and their index and pose fields.
    /// An item has the feature's true point when the list gives it. A grid always does.
    ///
    /// # Errors
    /// Invalid poses, such as a rotation that is not one. Grids of finite angles have none.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "grid sizes are checked against MAX_POSES before they are used as indices"
    )]
    pub fn items(&self, range: std::ops::Range<u64>) -> Result<(Vec<BatchItem>, Vec<Vec<String>>)> {
        // In parallel: formatting the fields costs as much as projecting some batches.
        let pairs = range
            .into_par_iter()
            .map(|i| {
                let mut row = vec![i.to_string()];
                let pose = match &self.poses {
                    Poses::List(l) => {
                        row.extend(l.rows[i as usize].iter().cloned());
                        l.items[i as usize]
                    }
                    Poses::Grid(g) => {
                        let v = g.values(i);
                        row.extend(v.iter().map(f64::to_string));
                        g.item(&self.source, &v)?
                    }
                };
                Ok((pose, row))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(pairs.into_iter().unzip())
    }

    /// Returns the poses in `range` like [`SweepConfig::items`], with pose columns as numbers.
    /// The numbers run row after row, in [`SweepConfig::columns`]' order after `index`.
    ///
    /// # Errors
    /// As [`SweepConfig::items`], and a list field that is not a number.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "grid sizes are checked against MAX_POSES before they are used as indices"
    )]
    pub fn items_numeric(&self, range: std::ops::Range<u64>) -> Result<(Vec<BatchItem>, Vec<f64>)> {
        let n = (range.end - range.start) as usize;
        let width = self.columns().len() - 1;
        // Write each pose's numbers in place and build its item from them. This runs for every
        // pose of a sweep, so nothing is allocated per pose.
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
                        Ok(l.items[i as usize])
                    }
                    Poses::Grid(g) => {
                        g.values_into(i, v);
                        g.item(&self.source, v)
                    }
                }
            })
            .collect::<Result<Vec<_>>>()?;
        Ok((poses, values))
    }

    /// Returns a fingerprint of everything in the file that decides the output.
    /// It is FNV-1a over the full debug form of the sonars, sampling, area grid, range error,
    /// poses and so on. A resumed or merged sweep uses it to tell its own parts.
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

/// The keys a sweep file may have at its top.
const TOP_KEYS: [&str; 13] = [
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

/// Returns key `key` of `top` holding one positive number (in `unit`), `None` when left out.
fn positive(f: ConfigFile<'_>, top: &toml::Table, key: &str, unit: &str) -> Result<Option<f64>> {
    let Some(v) = top.get(key) else { return Ok(None) };
    match f.values(key, v)?.as_slice() {
        [x] if *x > 0.0 => Ok(Some(*x)),
        _ => Err(f.error(key, v, format!("must be one number > 0 ({unit})"))),
    }
}

/// Returns the metric the file names for its figure (`metric`), or `None` when it names none.
/// The metric must have a label for sonar 2's `kind`.
fn named_metric(f: ConfigFile<'_>, top: &toml::Table, kind: SonarKind) -> Result<Option<Metric>> {
    let Some(m) = f.string(top, "metric")? else {
        return Ok(None);
    };
    let drawn = |m: &Metric| m.label(kind).is_some();
    Metric::from_name(m).filter(drawn).map(Some).ok_or_else(|| {
        let names: Vec<&str> = Metric::all().filter(drawn).map(Metric::name).collect();
        f.error(
            "metric",
            format!("{m:?}"),
            format!("must be one of {}", names.join(", ")),
        )
    })
}

/// Returns the pose list `list` names, a batch CSV relative to `base`.
/// It is read as a stream, holding at most [`MAX_LIST_POSES`] rows.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] when the file has grid keys too.
/// Errors of reading the list, named by its path.
fn pose_list(
    f: ConfigFile<'_>,
    top: &toml::Table,
    base: &Path,
    list: &str,
    source: &Sonar,
) -> Result<BatchInput> {
    for k in ["feature", "place", "translation", "rotation"] {
        if top.contains_key(k) {
            return Err(f.error(
                k,
                top[k].clone(),
                "cannot be combined with poses (the list gives every pose)",
            ));
        }
    }
    let path = base.join(list);
    // An input: no output of the sweep may replace it, whatever its name or place.
    crate::report::note_input(&path);
    let opened = sonarproj::files::open_regular(&path).map_err(|source| Error::ReadInput {
        path: path.clone(),
        source,
    })?;
    let reader = std::io::BufReader::with_capacity(1 << 16, opened);
    let context = format!("{}: poses {list:?}", f.path());
    read_batch_csv_at_most(reader, source, MAX_LIST_POSES, &context).map_err(|e| match e {
        Error::Csv { context, message } => Error::Csv {
            context: format!("{}: {context}", path.display()),
            message,
        },
        other => other,
    })
}
