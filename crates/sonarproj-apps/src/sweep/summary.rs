//! A sweep's summaries: reductions of one metric over every pose, computed chunk by chunk and
//! combined — the count, the extremes and the poses that reach them, the `top` smallest and
//! largest poses, a histogram, and marginals over one or two grid axes (min, mean, max of the
//! metric for each value of the axes, what the sweep figures draw).
//!
//! Every reduction is exact and independent of order: extremes and rankings break ties by the
//! lower pose index, histograms count, and means divide a sum kept in fixed point (an integer of
//! 2^-[`FIXED_BITS`] units), so the same poses give the same bits whatever the chunking, the
//! threads or the shards.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::sweep::config::Grid;

/// The fixed-point resolution of the marginals' sums: 2^-40 of the metric's unit (a picometre,
/// a millionth of a millionth of a square metre), far below any sonar's resolution; a sum of
/// 2^40 values up to 2^40 units stays within `i128`.
pub const FIXED_BITS: i32 = 40;

/// The most poses `top` may keep at each end.
pub const MAX_TOP: usize = 10_000;
/// The most bins a histogram may have.
pub const MAX_HISTOGRAM_BINS: usize = 100_000;
/// The most cells a marginal may have (the product of its axes' value counts): a 2-D marginal
/// of 316 × 316 values, or one axis of 100 000.
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
    /// The marginals: each the grid axes (one or two, by column) it is taken over.
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

/// A pose and its value of the metric.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ranked {
    /// The pose index.
    pub index: u64,
    /// The metric's value.
    pub value: f64,
}

/// A histogram of the metric.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Histogram {
    /// The bins' edges, `bins + 1` of them.
    pub edges: Vec<f64>,
    /// Poses in each bin (a bin holds its lower edge; the last also its upper edge).
    pub counts: Vec<u64>,
    /// Poses below the first edge.
    pub below: u64,
    /// Poses above the last edge.
    pub above: u64,
}

/// The metric over one or two grid axes: for each combination of their values, the poses with
/// a value and the min, mean and max of the metric over them (`null` where none has one).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Marginal {
    /// The axes (grid columns).
    pub axes: Vec<String>,
    /// The values of each axis.
    pub values: Vec<Vec<f64>>,
    /// Per cell (the last axis fastest): poses with a value.
    pub count: Vec<u64>,
    /// Per cell: the smallest value.
    pub min: Vec<Option<f64>>,
    /// Per cell: the mean value (the exact sum over `count`, then rounded: the same bits
    /// whatever the order).
    pub mean: Vec<Option<f64>>,
    /// Per cell: the largest value.
    pub max: Vec<Option<f64>>,
    /// Per cell: the exact sum, in units of 2^-[`FIXED_BITS`] (what combines exactly; `mean` is
    /// derived from it).
    pub sum: Vec<i128>,
}

/// The summaries of a sweep, or of a part of it (a chunk, a shard): what `summary.json` holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// The metric reduced.
    pub metric: String,
    /// Poses summarised.
    pub poses: u64,
    /// Poses with a value of the metric (the others see nothing, or the metric is empty there).
    pub with_value: u64,
    /// The smallest value and the first pose that has it.
    pub min: Option<Ranked>,
    /// The largest value and the first pose that has it.
    pub max: Option<Ranked>,
    /// The `top` smallest, smallest first (ties: lower index first).
    pub smallest: Vec<Ranked>,
    /// The `top` largest, largest first (ties: lower index first).
    pub largest: Vec<Ranked>,
    /// The histogram, when asked for.
    pub histogram: Option<Histogram>,
    /// The marginals asked for.
    pub marginals: Vec<Marginal>,
}

/// A part's summary as kept on disk between chunks: the marginals' cells listed only where a
/// pose fell (a chunk touches few of a large marginal's cells), without the axes' values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartSummary {
    /// The summary, its marginals without cells.
    pub summary: Summary,
    /// Per marginal, the cells with a pose.
    pub cells: Vec<Vec<Cell>>,
}

/// One marginal cell of a part: (cell, count, min, max, exact sum).
pub type Cell = (usize, u64, f64, f64, i128);

impl Summary {
    /// Returns this summary with its marginals' cells listed sparsely, for a part on disk.
    #[must_use]
    pub fn to_part(&self) -> PartSummary {
        let mut summary = self.clone();
        let mut cells = Vec::with_capacity(self.marginals.len());
        for m in &mut summary.marginals {
            cells.push(
                (0..m.count.len())
                    .filter(|&c| m.count[c] > 0)
                    .map(|c| {
                        (
                            c,
                            m.count[c],
                            m.min[c].unwrap_or(f64::NAN),
                            m.max[c].unwrap_or(f64::NAN),
                            m.sum[c],
                        )
                    })
                    .collect(),
            );
            m.values.clear();
            m.count.clear();
            m.min.clear();
            m.mean.clear();
            m.max.clear();
            m.sum.clear();
        }
        PartSummary { summary, cells }
    }
}

impl PartSummary {
    /// Returns the summary this part holds, its marginals dense again with the axis values of
    /// `template` (the empty summary of the sweep: a part does not repeat them).
    ///
    /// # Errors
    /// [`Error::Csv`] naming `context` for a cell outside its marginal or a sum that is not an
    /// integer.
    pub fn into_summary(self, template: &Summary, context: &str) -> Result<Summary> {
        let bad = |message: &str| Error::Csv {
            context: context.to_string(),
            message: message.to_string(),
        };
        let mut summary = self.summary;
        if self.cells.len() != summary.marginals.len() {
            return Err(bad("its marginals and their cells differ in number"));
        }
        if template.marginals.len() != summary.marginals.len() {
            return Err(bad("its marginals are not the [summary]'s"));
        }
        for ((m, cells), t) in summary
            .marginals
            .iter_mut()
            .zip(self.cells)
            .zip(&template.marginals)
        {
            m.values.clone_from(&t.values);
            let n = m.values.iter().map(Vec::len).product();
            m.count = vec![0; n];
            m.min = vec![None; n];
            m.mean = vec![None; n];
            m.max = vec![None; n];
            m.sum = vec![0; n];
            for (c, count, min, max, sum) in cells {
                if c >= n || count == 0 {
                    return Err(bad("a marginal's cell is outside it or empty"));
                }
                m.count[c] = count;
                m.min[c] = Some(min);
                m.max[c] = Some(max);
                m.mean[c] = mean_of(sum, count);
                m.sum[c] = sum;
            }
        }
        Ok(summary)
    }
}

/// Returns `value` in fixed point (units of 2^-FIXED_BITS, rounded to nearest), or `None` when
/// it is too large for the sums to stay exact.
fn fixed(value: f64) -> Option<i128> {
    let scaled = (value * f64::from(FIXED_BITS).exp2()).round();
    // |value| < 2^40 keeps 2^40 such terms within i128 (2^40 · 2^80 = 2^120).
    #[expect(clippy::cast_possible_truncation, reason = "bounded just above")]
    (scaled.abs() < 2f64.powi(80)).then_some(scaled as i128)
}

/// Returns the mean of a fixed-point `sum` over `count` values.
#[expect(
    clippy::cast_precision_loss,
    reason = "the quotient is rounded to f64 by design"
)]
fn mean_of(sum: i128, count: u64) -> Option<f64> {
    (count > 0).then(|| {
        // The integer quotient and remainder keep the division exact before one rounding.
        let count = i128::from(count);
        let (q, r) = (sum.div_euclid(count), sum.rem_euclid(count));
        (q as f64 + r as f64 / count as f64) / f64::from(FIXED_BITS).exp2()
    })
}

/// Returns the edges of histogram `h`: `bins + 1` of them, from `min` to `max`.
fn edges(h: &HistogramSpec) -> Vec<f64> {
    #[expect(clippy::cast_precision_loss, reason = "bin counts are small")]
    (0..=h.bins)
        .map(|k| h.min + (h.max - h.min) * (k as f64 / h.bins as f64))
        .collect()
}

/// Orders ranked poses by value, then index.
fn ascending(a: &Ranked, b: &Ranked) -> std::cmp::Ordering {
    a.value.total_cmp(&b.value).then(a.index.cmp(&b.index))
}

/// Orders ranked poses by value, largest first, then index.
fn descending(a: &Ranked, b: &Ranked) -> std::cmp::Ordering {
    b.value.total_cmp(&a.value).then(a.index.cmp(&b.index))
}

impl SummarySpec {
    /// Returns the spec with every field checked against `grid` (its marginals' axes must be
    /// grid columns; `None` for a pose list, which has none) — `file` names the sweep file.
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

    /// Returns the empty summary of this spec over `grid`.
    #[must_use]
    pub fn empty(&self, grid: Option<&Grid>) -> Summary {
        let histogram = self.histogram.map(|h| Histogram {
            edges: edges(&h),
            counts: vec![0; h.bins],
            below: 0,
            above: 0,
        });
        let marginals = self
            .marginals
            .iter()
            .map(|axes| {
                let values: Vec<Vec<f64>> = axes
                    .iter()
                    .map(|a| {
                        grid.and_then(|g| g.axes.iter().find(|x| x.column == a))
                            .map(|x| x.values.clone())
                            .unwrap_or_default()
                    })
                    .collect();
                let cells = values.iter().map(Vec::len).product();
                Marginal {
                    axes: axes.clone(),
                    values,
                    count: vec![0; cells],
                    min: vec![None; cells],
                    mean: vec![None; cells],
                    max: vec![None; cells],
                    sum: vec![0; cells],
                }
            })
            .collect();
        Summary {
            metric: self.by.clone(),
            poses: 0,
            with_value: 0,
            min: None,
            max: None,
            smallest: Vec::new(),
            largest: Vec::new(),
            histogram,
            marginals,
        }
    }

    /// Returns the summary of poses `first`, `first + 1`, … whose metric values are `values`
    /// (`None`: no value), for a sweep over `grid`.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] for a value too large for the marginals' exact sums.
    pub fn summarise(&self, grid: Option<&Grid>, first: u64, values: &[Option<f64>]) -> Result<Summary> {
        let mut s = self.empty(grid);
        s.poses = values.len() as u64;
        let present = || {
            values.iter().enumerate().filter_map(|(k, v)| {
                v.filter(|x| !x.is_nan()).map(|value| Ranked {
                    index: first + k as u64,
                    value,
                })
            })
        };
        s.with_value = present().count() as u64;
        s.min = present().min_by(ascending);
        s.max = present().min_by(descending);
        if self.top > 0 {
            let mut all: Vec<Ranked> = present().collect();
            all.sort_by(ascending);
            s.smallest = all.iter().take(self.top).copied().collect();
            s.largest = all.iter().rev().copied().collect::<Vec<_>>();
            s.largest.sort_by(descending);
            s.largest.truncate(self.top);
        }
        if let (Some(h), Some(spec)) = (&mut s.histogram, self.histogram) {
            #[expect(clippy::cast_precision_loss, reason = "bin counts are small")]
            let per = spec.bins as f64 / (spec.max - spec.min);
            for r in present() {
                if r.value < spec.min {
                    h.below += 1;
                } else if r.value > spec.max {
                    h.above += 1;
                } else {
                    #[expect(
                        clippy::cast_possible_truncation,
                        clippy::cast_sign_loss,
                        reason = "within the bins"
                    )]
                    let mut k = ((r.value - spec.min) * per) as usize;
                    // The bin holds its lower edge: settle the rounding against the edges.
                    k = k.min(spec.bins - 1);
                    while k > 0 && r.value < h.edges[k] {
                        k -= 1;
                    }
                    while k + 1 < spec.bins && r.value >= h.edges[k + 1] {
                        k += 1;
                    }
                    h.counts[k] += 1;
                }
            }
        }
        if !s.marginals.is_empty() {
            let grid = grid.expect("marginals are checked to need a grid");
            for m in &mut s.marginals {
                let mut sums = vec![0i128; m.count.len()];
                let axes: Vec<(u64, u64)> = m
                    .axes
                    .iter()
                    .map(|a| {
                        let k = grid
                            .axes
                            .iter()
                            .position(|x| x.column == a)
                            .expect("checked axis");
                        let stride: u64 = grid.axes[k + 1..].iter().map(|x| x.values.len() as u64).product();
                        (stride, grid.axes[k].values.len() as u64)
                    })
                    .collect();
                for r in present() {
                    #[expect(clippy::cast_possible_truncation, reason = "below the cell count")]
                    let cell = axes
                        .iter()
                        .fold(0u64, |c, &(stride, n)| c * n + (r.index / stride) % n)
                        as usize;
                    let f = fixed(r.value).ok_or_else(|| {
                        Error::invalid(
                            format!("summary of {} at pose {}", self.by, r.index),
                            r.value,
                            "is too large for the marginals' exact sums (at most 2^40)",
                        )
                    })?;
                    m.count[cell] += 1;
                    sums[cell] += f;
                    m.min[cell] = Some(m.min[cell].map_or(r.value, |x| x.min(r.value)));
                    m.max[cell] = Some(m.max[cell].map_or(r.value, |x| x.max(r.value)));
                }
                m.mean = sums.iter().zip(&m.count).map(|(&s, &n)| mean_of(s, n)).collect();
                m.sum = sums;
            }
        }
        Ok(s)
    }

    /// Returns `Ok` when `s`, read from a part on disk, is a summary of this spec over `rows`
    /// poses from index `first`: its metric, its counts adding up, its lists as long as `top`
    /// allows and within the part's indices, its histogram's edges and its marginals' axes and
    /// cells as the spec makes them.
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

    /// Returns `a` and `b` (summaries of this spec over disjoint poses) combined: the summary of
    /// all their poses, the same whichever order they come in.
    ///
    /// # Errors
    /// [`Error::Csv`] naming `context` when the two are not summaries of this spec (another
    /// metric, histogram or marginals) or a sum is not a number.
    pub fn combine(&self, a: &Summary, b: &Summary, context: &str) -> Result<Summary> {
        let bad = |message: &str| Error::Csv {
            context: context.to_string(),
            message: message.to_string(),
        };
        let shape = |s: &Summary| {
            (
                s.metric.clone(),
                s.histogram.as_ref().map(|h| (h.edges.clone(), h.counts.len())),
                s.marginals
                    .iter()
                    .map(|m| {
                        let lens = [m.count.len(), m.min.len(), m.mean.len(), m.max.len(), m.sum.len()];
                        (m.axes.clone(), m.values.clone(), lens)
                    })
                    .collect::<Vec<_>>(),
            )
        };
        let add = |p: u64, q: u64| p.checked_add(q).ok_or_else(|| bad("a count overflows"));
        let adds = |p: &[u64], q: &[u64]| {
            p.iter()
                .zip(q)
                .map(|(p, q)| add(*p, *q))
                .collect::<Result<Vec<u64>>>()
        };
        if shape(a) != shape(b) || a.metric != self.by {
            return Err(bad(
                "its summary is not of this sweep's [summary] (another metric, histogram or marginals)",
            ));
        }
        let pick = |x: Option<Ranked>,
                    y: Option<Ranked>,
                    order: fn(&Ranked, &Ranked) -> std::cmp::Ordering| match (x, y) {
            (Some(x), Some(y)) => Some(if order(&x, &y).is_le() { x } else { y }),
            (x, y) => x.or(y),
        };
        let merge = |x: &[Ranked], y: &[Ranked], order: fn(&Ranked, &Ranked) -> std::cmp::Ordering| {
            let mut all: Vec<Ranked> = x.iter().chain(y).copied().collect();
            all.sort_by(order);
            all.truncate(self.top);
            all
        };
        let histogram = match (&a.histogram, &b.histogram) {
            (Some(x), Some(y)) => Some(Histogram {
                edges: x.edges.clone(),
                counts: adds(&x.counts, &y.counts)?,
                below: add(x.below, y.below)?,
                above: add(x.above, y.above)?,
            }),
            _ => None,
        };
        let mut marginals = Vec::with_capacity(a.marginals.len());
        for (x, y) in a.marginals.iter().zip(&b.marginals) {
            let sums = x
                .sum
                .iter()
                .zip(&y.sum)
                .map(|(p, q)| p.checked_add(*q).ok_or_else(|| bad("a marginal's sum overflows")))
                .collect::<Result<Vec<i128>>>()?;
            let count = adds(&x.count, &y.count)?;
            let both = |p: &Option<f64>, q: &Option<f64>, f: fn(f64, f64) -> f64| match (p, q) {
                (Some(p), Some(q)) => Some(f(*p, *q)),
                (p, q) => p.or(*q),
            };
            marginals.push(Marginal {
                axes: x.axes.clone(),
                values: x.values.clone(),
                min: x
                    .min
                    .iter()
                    .zip(&y.min)
                    .map(|(p, q)| both(p, q, f64::min))
                    .collect(),
                max: x
                    .max
                    .iter()
                    .zip(&y.max)
                    .map(|(p, q)| both(p, q, f64::max))
                    .collect(),
                mean: sums.iter().zip(&count).map(|(&s, &n)| mean_of(s, n)).collect(),
                sum: sums.clone(),
                count,
            });
        }
        Ok(Summary {
            metric: a.metric.clone(),
            poses: add(a.poses, b.poses)?,
            with_value: add(a.with_value, b.with_value)?,
            min: pick(a.min, b.min, ascending),
            max: pick(a.max, b.max, descending),
            smallest: merge(&a.smallest, &b.smallest, ascending),
            largest: merge(&a.largest, &b.largest, descending),
            histogram,
            marginals,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::config::Axis;

    fn grid() -> Grid {
        Grid {
            axes: vec![
                Axis {
                    column: "roll",
                    values: vec![0.0, 10.0, 20.0],
                },
                Axis {
                    column: "pitch",
                    values: vec![0.0, 5.0, 10.0, 15.0],
                },
            ],
            placement: true,
        }
    }

    fn spec() -> SummarySpec {
        SummarySpec {
            by: "span".into(),
            top: 3,
            histogram: Some(HistogramSpec {
                min: 0.0,
                max: 1.0,
                bins: 4,
            }),
            marginals: vec![vec!["roll".into()], vec!["pitch".into(), "roll".into()]],
            rows: true,
        }
    }

    /// Values of 12 poses with ties, nulls and values off the histogram.
    fn values() -> Vec<Option<f64>> {
        vec![
            Some(0.5),
            None,
            Some(0.25),
            Some(0.1),
            Some(0.25),
            Some(1.5),
            Some(-0.2),
            Some(0.75),
            Some(1.0),
            None,
            Some(0.1),
            Some(0.3),
        ]
    }

    #[test]
    fn reductions_match_a_plain_count_and_sort() {
        let g = grid();
        let s = spec().summarise(Some(&g), 0, &values()).unwrap();
        assert_eq!((s.poses, s.with_value), (12, 10));
        assert_eq!(
            s.min,
            Some(Ranked {
                index: 6,
                value: -0.2
            })
        );
        assert_eq!(s.max, Some(Ranked { index: 5, value: 1.5 }));
        let idx = |r: &[Ranked]| r.iter().map(|x| x.index).collect::<Vec<_>>();
        // Ties broken by the lower index: 0.1 at poses 3 and 10, 0.25 at 2 and 4.
        assert_eq!(idx(&s.smallest), [6, 3, 10]);
        assert_eq!(idx(&s.largest), [5, 8, 7]);
        let h = s.histogram.as_ref().unwrap();
        // Bins [0, .25) [.25, .5) [.5, .75) [.75, 1]: 0.1 0.1 | 0.25 0.25 0.3 | 0.5 | 0.75 1.0.
        assert_eq!((h.counts.clone(), h.below, h.above), (vec![2, 3, 1, 2], 1, 1));
        // Roll is pose / 4, pitch pose % 4.
        let roll = &s.marginals[0];
        assert_eq!(roll.count, [3, 4, 3]);
        assert_eq!(roll.min, [Some(0.1), Some(-0.2), Some(0.1)]);
        assert_eq!(roll.max, [Some(0.5), Some(1.5), Some(1.0)]);
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!((roll.mean[0].unwrap() - mean(&[0.5, 0.25, 0.1])).abs() < 1e-12);
        // Pitch × roll: the cell of pitch 5°, roll 20° (1 · 3 + 2) is pose 9 (no value).
        let pr = &s.marginals[1];
        assert_eq!(pr.values, vec![vec![0.0, 5.0, 10.0, 15.0], vec![0.0, 10.0, 20.0]]);
        assert_eq!(pr.count[5], 0);
        assert_eq!(pr.mean[5], None);
        // Pitch 15°, roll 10°: pose 1 · 4 + 3 = 7.
        assert_eq!((pr.min[3 * 3 + 1], pr.count[3 * 3 + 1]), (Some(0.75), 1));
    }

    #[test]
    fn any_chunking_combines_to_the_same_bits() {
        let g = grid();
        let spec = spec();
        let v = values();
        let whole = spec.summarise(Some(&g), 0, &v).unwrap();
        for cuts in [
            vec![0, 12],
            vec![0, 1, 12],
            vec![0, 5, 6, 11, 12],
            (0..=12).collect(),
        ] {
            // Each part through its file's form (sparse cells, JSON text) and back, as on disk.
            let parts: Vec<Summary> = cuts
                .windows(2)
                .map(|w| {
                    let part = spec
                        .summarise(Some(&g), w[0] as u64, &v[w[0]..w[1]])
                        .unwrap()
                        .to_part();
                    let text = serde_json::to_string(&part).unwrap();
                    let s = serde_json::from_str::<PartSummary>(&text)
                        .unwrap()
                        .into_summary(&spec.empty(Some(&g)), "t")
                        .unwrap();
                    spec.check(&s, w[0] as u64, (w[1] - w[0]) as u64, "t").unwrap();
                    s
                })
                .collect();
            let forward = parts[1..]
                .iter()
                .fold(parts[0].clone(), |acc, p| spec.combine(&acc, p, "t").unwrap());
            let backward = parts[..parts.len() - 1]
                .iter()
                .rev()
                .fold(parts[parts.len() - 1].clone(), |acc, p| {
                    spec.combine(p, &acc, "t").unwrap()
                });
            assert_eq!(forward, whole, "{cuts:?}");
            assert_eq!(backward, whole, "{cuts:?}");
            assert_eq!(
                serde_json::to_string(&forward).unwrap(),
                serde_json::to_string(&whole).unwrap()
            );
        }
    }

    #[test]
    fn a_part_that_does_not_hold_together_is_refused() {
        let g = grid();
        let spec = spec();
        let good = spec.summarise(Some(&g), 4, &values()[4..8]).unwrap();
        spec.check(&good, 4, 4, "t").unwrap();
        let refused = |s: &Summary, words: &str| {
            let e = spec.check(s, 4, 4, "t").unwrap_err().to_string();
            assert!(e.contains(words), "{e}");
        };
        refused(
            &Summary {
                poses: 5,
                ..good.clone()
            },
            "5 poses",
        );
        refused(
            &Summary {
                smallest: good.smallest[..1].to_vec(),
                ..good.clone()
            },
            "1 smallest",
        );
        let mut moved = good.clone();
        moved.largest[0].index = 99;
        refused(&moved, "outside poses 4 to 7");
        let mut cut = good.clone();
        cut.histogram.as_mut().unwrap().counts.pop();
        refused(&cut, "histogram");
        let mut wrapped = good.clone();
        wrapped.marginals[0].count[0] = u64::MAX;
        refused(&wrapped, "marginal over [\"roll\"]");
        refused(
            &Summary {
                metric: "area".into(),
                ..good.clone()
            },
            "summarises \"area\"",
        );
        // Counts that overflow when combined are an error, not a wrap.
        let mut big = good.clone();
        big.with_value = u64::MAX;
        assert!(
            spec.combine(&big, &good, "t")
                .unwrap_err()
                .to_string()
                .contains("overflows")
        );
    }

    #[test]
    fn bad_specs_name_the_key() {
        let g = grid();
        let e = |s: SummarySpec| s.checked("s.toml", Some(&g)).unwrap_err().to_string();
        assert!(
            e(SummarySpec {
                top: MAX_TOP + 1,
                ..spec()
            })
            .contains("summary.top")
        );
        let flat = SummarySpec {
            histogram: Some(HistogramSpec {
                min: 1.0,
                max: 1.0,
                bins: 4,
            }),
            ..spec()
        };
        assert!(e(flat).contains("min < max"));
        for (min, max, bins) in [
            (-1e308, 1e308, 2),
            (1.0, 1.000_000_000_000_000_2, 1000),
            (0.0, 5e-324, 100),
        ] {
            let h = SummarySpec {
                histogram: Some(HistogramSpec { min, max, bins }),
                ..spec()
            };
            assert!(e(h).contains("non-zero width"), "{min} {max} {bins}");
        }
        let yaw = SummarySpec {
            marginals: vec![vec!["yaw".into()]],
            ..spec()
        };
        assert!(e(yaw).contains("not a grid axis (the axes: roll, pitch)"));
        let list = spec().checked("s.toml", None).unwrap_err().to_string();
        assert!(list.contains("needs a grid"), "{list}");
    }
}
