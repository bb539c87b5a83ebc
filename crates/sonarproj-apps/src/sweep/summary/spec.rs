//! A sweep file's `[summary]`: read from TOML and checked against the grid.
//! Also checks a part's summary read back from disk.

use serde::{Deserialize, Serialize};
use sonarproj::geometry::sonar::SonarKind;
use sonarproj::metrics::Metric;

use super::{Ranked, Summary};
use crate::error::{Error, Result};
use crate::io::toml_keys::ConfigFile;
use crate::sweep::grid::Grid;

/// The most poses `top` may keep at each end.
pub const MAX_TOP: usize = 10_000;
/// The most bins a histogram may have.
pub const MAX_HISTOGRAM_BINS: usize = 100_000;
/// The most cells a marginal may have: 316 × 316 values in 2-D, or 100 000 on one axis.
pub const MAX_MARGINAL_CELLS: usize = 100_000;

/// What a sweep file's `[summary]` table asks for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SummarySpec {
    /// The metric reduced (its name in the metric table).
    pub by: String,
    /// How many of the smallest and of the largest poses to keep.
    pub top: usize,
    /// The histogram, if any.
    pub histogram: Option<HistogramSpec>,
    /// The marginals, each given by its one or two grid axes (column names).
    pub marginals: Vec<Vec<String>>,
    /// Whether the per-pose table is written too (`false`: summaries only).
    pub rows: bool,
}

/// A histogram's bins: `bins` equal bins from `min` to `max`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HistogramSpec {
    /// The lower edge.
    pub min: f64,
    /// The upper edge.
    pub max: f64,
    /// The number of bins.
    pub bins: usize,
}

/// Returns the edges of histogram `h`: `bins + 1` of them, from `min` to `max`.
pub(super) fn edges(h: &HistogramSpec) -> Vec<f64> {
    #[expect(clippy::cast_precision_loss, reason = "bin counts are small")]
    (0..=h.bins)
        .map(|k| h.min + (h.max - h.min) * (k as f64 / h.bins as f64))
        .collect()
}

/// Returns the `[summary]` table `t` of sweep file `f`, not yet checked against the grid.
/// Keys: `by`, a metric of sonar 2's kind (default: the figure's `metric`), `top` (default 10),
/// `histogram = { min, max, bins }`, `marginals` (axis names or pairs), `rows` (default true).
pub(crate) fn from_toml(
    f: ConfigFile<'_>,
    t: &toml::Table,
    metric: Metric,
    target: SonarKind,
) -> Result<SummarySpec> {
    f.only("summary.", t, &["by", "top", "histogram", "marginals", "rows"])?;
    let by = match t.get("by") {
        None => metric,
        Some(toml::Value::String(m)) => {
            let drawn = |m: &Metric| m.label(target).is_some();
            Metric::from_name(m).filter(drawn).ok_or_else(|| {
                let names: Vec<&str> = Metric::all().filter(drawn).map(Metric::name).collect();
                f.error(
                    "summary.by",
                    format!("{m:?}"),
                    format!("must be one of {}", names.join(", ")),
                )
            })?
        }
        Some(other) => return Err(f.error("summary.by", other, "must be a metric's name")),
    };
    let top = t
        .get("top")
        .map(|v| count(f, "summary.top", v, 0, MAX_TOP))
        .transpose()?
        .unwrap_or(10);
    let histogram = match t.get("histogram") {
        None => None,
        Some(toml::Value::Table(h)) => Some(histogram(f, h)?),
        Some(other) => {
            return Err(f.error("summary.histogram", other, "must be a table { min, max, bins }"));
        }
    };
    let marginals = marginals(f, t.get("marginals"))?;
    let rows = match t.get("rows") {
        None => true,
        Some(toml::Value::Boolean(b)) => *b,
        Some(other) => return Err(f.error("summary.rows", other, "must be true or false")),
    };
    Ok(SummarySpec {
        by: by.name().to_string(),
        top,
        histogram,
        marginals,
        rows,
    })
}

/// Returns the whole number `v` of key `name` in `[min, max]`.
fn count(f: ConfigFile<'_>, name: &str, v: &toml::Value, min: usize, max: usize) -> Result<usize> {
    match v {
        toml::Value::Integer(i) => usize::try_from(*i)
            .ok()
            .filter(|&n| (min..=max).contains(&n))
            .ok_or_else(|| f.error(name, i, format!("must be {min} to {max}"))),
        other => Err(f.error(name, other, "must be a whole number")),
    }
}

/// Returns the histogram of table `h` (`summary.histogram`: min, max and bins, all required).
#[expect(clippy::cast_precision_loss, reason = "TOML integers taken as numbers")]
fn histogram(f: ConfigFile<'_>, h: &toml::Table) -> Result<HistogramSpec> {
    f.only("summary.histogram.", h, &["min", "max", "bins"])?;
    let needed = "a histogram needs min, max and bins";
    let number = |k: &str| -> Result<f64> {
        let name = format!("summary.histogram.{k}");
        match h.get(k) {
            Some(toml::Value::Integer(i)) => Ok(*i as f64),
            Some(toml::Value::Float(x)) => Ok(*x),
            Some(other) => Err(f.error(&name, other, "must be a number")),
            None => Err(f.missing(&name, needed)),
        }
    };
    let bins = match h.get("bins") {
        Some(v) => count(f, "summary.histogram.bins", v, 1, MAX_HISTOGRAM_BINS)?,
        None => return Err(f.missing("summary.histogram.bins", needed)),
    };
    Ok(HistogramSpec {
        min: number("min")?,
        max: number("max")?,
        bins,
    })
}

/// Returns the marginals `v` asks for (`summary.marginals`): axis names, or pairs of them.
fn marginals(f: ConfigFile<'_>, v: Option<&toml::Value>) -> Result<Vec<Vec<String>>> {
    let shape = "must be a list of axis names or pairs of them, e.g. [\"roll\", [\"roll\", \"pitch\"]]";
    let bad = |other: &toml::Value| f.error("summary.marginals", other, shape);
    let name = |a: &toml::Value| match a {
        toml::Value::String(a) => Ok(a.clone()),
        other => Err(bad(other)),
    };
    match v {
        None => Ok(Vec::new()),
        Some(toml::Value::Array(list)) => list
            .iter()
            .map(|m| match m {
                toml::Value::String(a) => Ok(vec![a.clone()]),
                toml::Value::Array(pair) => pair.iter().map(name).collect(),
                other => Err(bad(other)),
            })
            .collect(),
        Some(other) => Err(bad(other)),
    }
}

impl SummarySpec {
    /// Returns the spec with every field checked against `grid`, for sweep file `file`.
    /// Marginal axes must be grid columns. A pose list (`None`) has no axes.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming `summary.KEY`.
    pub fn checked(self, file: &str, grid: Option<&Grid>) -> Result<SummarySpec> {
        let key = |k: &str| format!("sweep file {file:?}: summary.{k}");
        if self.top > MAX_TOP {
            return Err(Error::invalid(
                key("top"),
                self.top,
                format!("must be 0 to {MAX_TOP}"),
            ));
        }
        if let Some(h) = self.histogram {
            if !(h.min.is_finite() && h.max.is_finite() && h.min < h.max) {
                return Err(Error::invalid(
                    key("histogram"),
                    format!("{{ min = {}, max = {} }}", h.min, h.max),
                    "min and max must be finite numbers with min < max",
                ));
            }
            if h.bins == 0 || h.bins > MAX_HISTOGRAM_BINS {
                return Err(Error::invalid(
                    key("histogram.bins"),
                    h.bins,
                    format!("must be 1 to {MAX_HISTOGRAM_BINS}"),
                ));
            }
            // The width must be a finite number, and every bin wider than nothing.
            if !(h.max - h.min).is_finite() || edges(&h).windows(2).any(|w| w[1] <= w[0]) {
                return Err(Error::invalid(
                    key("histogram"),
                    format!("{{ min = {}, max = {}, bins = {} }}", h.min, h.max, h.bins),
                    "its bins must have a finite, non-zero width: max - min finite and above min's precision",
                ));
            }
        }
        for axes in &self.marginals {
            let Some(grid) = grid else {
                return Err(Error::invalid(
                    key("marginals"),
                    format!("{axes:?}"),
                    "needs a grid (a pose list has no axes)",
                ));
            };
            let names: Vec<&str> = grid.axes.iter().map(|a| a.column).collect();
            if axes.is_empty() || axes.len() > 2 {
                return Err(Error::invalid(
                    key("marginals"),
                    format!("{axes:?}"),
                    "each must be one axis or a pair, e.g. \"roll\" or [\"roll\", \"pitch\"]",
                ));
            }
            let mut cells = 1usize;
            for a in axes {
                let Some(axis) = grid.axes.iter().find(|x| x.column == a) else {
                    return Err(Error::invalid(
                        key("marginals"),
                        format!("{a:?}"),
                        format!("is not a grid axis (the axes: {})", names.join(", ")),
                    ));
                };
                cells = cells.saturating_mul(axis.values.len());
            }
            if axes.len() == 2 && axes[0] == axes[1] {
                return Err(Error::invalid(
                    key("marginals"),
                    format!("{axes:?}"),
                    "names one axis twice",
                ));
            }
            if cells > MAX_MARGINAL_CELLS {
                return Err(Error::invalid(
                    key("marginals"),
                    format!("{axes:?}"),
                    format!("has {cells} cells, more than {MAX_MARGINAL_CELLS}"),
                ));
            }
        }
        Ok(self)
    }

    /// Returns `Ok` when `s`, read from a part on disk, summarises `rows` poses from `first`.
    /// Checks the metric, that counts add up, that the lists are as long as `top` allows and
    /// within the part, and that the histogram and marginals have this spec's shape.
    ///
    /// # Errors
    /// [`Error::Csv`] naming `context` and what does not hold.
    pub fn check(&self, s: &Summary, first: u64, rows: u64, context: &str) -> Result<()> {
        let fail = |what: String| {
            Err(Error::Csv {
                context: context.to_string(),
                message: format!("its summary does not hold together: {what}"),
            })
        };
        let end = first.saturating_add(rows);
        let inside = |r: &Ranked| (first..end).contains(&r.index) && !r.value.is_nan();
        if s.metric != self.by {
            return fail(format!(
                "it summarises {:?}, this sweep's [summary] {:?}",
                s.metric, self.by
            ));
        }
        if s.poses != rows || s.with_value > rows {
            return fail(format!(
                "{} poses ({} with a value) where the part holds {rows}",
                s.poses, s.with_value
            ));
        }
        let ranked = usize::try_from(s.with_value).unwrap_or(usize::MAX).min(self.top);
        if s.smallest.len() != ranked || s.largest.len() != ranked {
            return fail(format!(
                "{} smallest and {} largest where top = {} and {} poses have a value",
                s.smallest.len(),
                s.largest.len(),
                self.top,
                s.with_value
            ));
        }
        if !s
            .smallest
            .iter()
            .chain(&s.largest)
            .chain(&s.min)
            .chain(&s.max)
            .all(inside)
            || s.min.is_some() != (s.with_value > 0)
            || s.max.is_some() != (s.with_value > 0)
        {
            return fail(format!(
                "a ranked pose outside poses {first} to {}",
                end.saturating_sub(1)
            ));
        }
        match (&s.histogram, &self.histogram) {
            (None, None) => {}
            (Some(h), Some(spec)) => {
                let total = h
                    .counts
                    .iter()
                    .chain([&h.below, &h.above])
                    .try_fold(0u64, |t, c| t.checked_add(*c));
                if h.edges != edges(spec) || h.counts.len() != spec.bins || total != Some(s.with_value) {
                    return fail("its histogram is not the [summary]'s, or does not count its poses".into());
                }
            }
            _ => return fail("a histogram where the [summary] has none, or none where it has one".into()),
        }
        if s.marginals.len() != self.marginals.len() {
            return fail(format!(
                "{} marginals where the [summary] has {}",
                s.marginals.len(),
                self.marginals.len()
            ));
        }
        for (m, axes) in s.marginals.iter().zip(&self.marginals) {
            let cells: usize = m.values.iter().map(Vec::len).product();
            let lens = [m.count.len(), m.min.len(), m.mean.len(), m.max.len(), m.sum.len()];
            let total = m.count.iter().try_fold(0u64, |t, c| t.checked_add(*c));
            if m.axes != *axes
                || m.values.len() != axes.len()
                || lens.iter().any(|&l| l != cells)
                || total != Some(s.with_value)
            {
                return fail(format!(
                    "its marginal over {axes:?} is not the [summary]'s, or does not count its poses"
                ));
            }
        }
        Ok(())
    }
}
