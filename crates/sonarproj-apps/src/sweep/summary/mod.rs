//! A sweep's summaries: reductions of one metric over every pose, computed chunk by chunk and
//! combined — the count, the extremes and the poses that reach them, the `top` smallest and
//! largest poses, a histogram, and marginals over one or two grid axes (min, mean, max of the
//! metric for each value of the axes, what the sweep figures draw).
//!
//! Every reduction is exact and independent of order: extremes and rankings break ties by the
//! lower pose index, histograms count, and means divide a sum kept in fixed point (an integer of
//! 2^-[`FIXED_BITS`] units), so the same poses give the same bits whatever the chunking, the
//! threads or the shards.
//!
//! The spec a sweep file's `[summary]` gives and its checks are `spec`, a part's sparse form on
//! disk `part`.

mod part;
mod spec;
#[cfg(test)]
mod tests;

pub use part::{Cell, PartSummary};
pub(crate) use spec::from_toml;
pub use spec::{HistogramSpec, MAX_HISTOGRAM_BINS, MAX_MARGINAL_CELLS, MAX_TOP, SummarySpec};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::sweep::config::Grid;
use spec::edges;

/// The fixed-point resolution of the marginals' sums: 2^-40 of the metric's unit (a picometre,
/// a millionth of a millionth of a square metre), far below any sonar's resolution; a sum of
/// 2^40 values up to 2^40 units stays within `i128`.
pub const FIXED_BITS: i32 = 40;

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

/// Orders ranked poses by value, then index.
fn ascending(a: &Ranked, b: &Ranked) -> std::cmp::Ordering {
    a.value.total_cmp(&b.value).then(a.index.cmp(&b.index))
}

/// Orders ranked poses by value, largest first, then index.
fn descending(a: &Ranked, b: &Ranked) -> std::cmp::Ordering {
    b.value.total_cmp(&a.value).then(a.index.cmp(&b.index))
}

/// Returns the lesser of `a` and `b` in IEEE total order (-0 below +0), so that the result does
/// not depend on which comes first (`f64::min` may return either zero).
fn least(a: f64, b: f64) -> f64 {
    if b.total_cmp(&a).is_lt() { b } else { a }
}

/// Returns the greater of `a` and `b` in IEEE total order (+0 above -0).
fn greatest(a: f64, b: f64) -> f64 {
    if b.total_cmp(&a).is_gt() { b } else { a }
}

/// Returns the first `k` (> 0) of `all` in `order` (a total order), in that order: selected,
/// then only they sorted.
fn first_in_order(
    mut all: Vec<Ranked>,
    k: usize,
    order: fn(&Ranked, &Ranked) -> std::cmp::Ordering,
) -> Vec<Ranked> {
    if all.len() > k {
        all.select_nth_unstable_by(k, order);
        all.truncate(k);
    }
    all.sort_by(order);
    all
}

impl SummarySpec {
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
        // Pieces on all cores, each added to its thread's running summary, the few running
        // summaries combined: the same summary (every reduction is exact and independent of
        // order), in a fraction of the time and without a full-size summary a piece.
        const PIECE: usize = 1 << 14;
        if values.len() <= 2 * PIECE {
            let mut s = self.empty(grid);
            self.add(&mut s, grid, first, values)?;
            return Ok(s);
        }
        values
            .par_chunks(PIECE)
            .enumerate()
            .try_fold(
                || self.empty(grid),
                |mut s, (k, v)| {
                    self.add(&mut s, grid, first + (k * PIECE) as u64, v)?;
                    Ok(s)
                },
            )
            .try_reduce(|| self.empty(grid), |a, b| self.combine(&a, &b, "summary"))
    }

    /// Adds poses `first`, `first + 1`, … with metric `values` (none of them in `s` yet) to the
    /// summary `s`, on one thread.
    fn add(&self, s: &mut Summary, grid: Option<&Grid>, first: u64, values: &[Option<f64>]) -> Result<()> {
        s.poses += values.len() as u64;
        let present = || {
            values.iter().enumerate().filter_map(|(k, v)| {
                v.filter(|x| !x.is_nan()).map(|value| Ranked {
                    index: first + k as u64,
                    value,
                })
            })
        };
        for r in present() {
            s.with_value += 1;
            if s.min.is_none_or(|m| ascending(&r, &m).is_lt()) {
                s.min = Some(r);
            }
            if s.max.is_none_or(|m| descending(&r, &m).is_lt()) {
                s.max = Some(r);
            }
        }
        if self.top > 0 {
            let mut all: Vec<Ranked> = present().collect();
            let mut smallest = std::mem::take(&mut s.smallest);
            smallest.extend_from_slice(&all);
            s.smallest = first_in_order(smallest, self.top, ascending);
            all.append(&mut s.largest);
            s.largest = first_in_order(all, self.top, descending);
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
                let sums = &mut m.sum;
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
                    m.min[cell] = Some(m.min[cell].map_or(r.value, |x| least(x, r.value)));
                    m.max[cell] = Some(m.max[cell].map_or(r.value, |x| greatest(x, r.value)));
                }
                m.mean = m.sum.iter().zip(&m.count).map(|(&s, &n)| mean_of(s, n)).collect();
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
                min: x.min.iter().zip(&y.min).map(|(p, q)| both(p, q, least)).collect(),
                max: x
                    .max
                    .iter()
                    .zip(&y.max)
                    .map(|(p, q)| both(p, q, greatest))
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
