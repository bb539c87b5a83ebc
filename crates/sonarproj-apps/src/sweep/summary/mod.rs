//! A sweep's summaries: reductions of one metric over every pose, computed chunk by chunk.
//!
//! They are the count, the extremes and their poses, the `top` smallest and largest poses, a
//! histogram, and marginals: min, mean and max per value of one or two grid axes (as figures draw).
//!
//! Every reduction is exact and order-independent, so the same poses give the same bits whatever
//! the chunking, threads or shards. Ties go to the lower pose index, histograms count, and means
//! divide a fixed-point sum (an integer of 2^-[`FIXED_BITS`] units).

mod cells;
mod device;
#[cfg(test)]
mod device_tests;
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
use crate::sweep::grid::Grid;
use cells::{Cells, Odometer, add_to_marginal};
use spec::edges;

/// The fixed-point resolution of the marginals' sums: 2^-40 of the metric's unit.
///
/// That is a picometre, or 10^-12 m², far below any sonar's resolution. A sum of 2^40 values up
/// to 2^40 units stays within `i128`.
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
    /// Poses in each bin. A bin holds its lower edge; the last bin also holds its upper edge.
    pub counts: Vec<u64>,
    /// Poses below the first edge.
    pub below: u64,
    /// Poses above the last edge.
    pub above: u64,
}

/// The metric over one or two grid axes: count, min, mean and max per cell of their values.
/// Min, mean and max are `null` in a cell where no pose has a value.
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
    /// Per cell: the mean, the exact sum over `count` rounded once (the same bits in any order).
    pub mean: Vec<Option<f64>>,
    /// Per cell: the largest value.
    pub max: Vec<Option<f64>>,
    /// Per cell: the exact sum, in units of 2^-[`FIXED_BITS`].
    /// Sums combine exactly, and `mean` is derived from them.
    pub sum: Vec<i128>,
}

/// The summaries of a sweep, or of a part of it (a chunk, a shard): what `summary.json` holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// The metric reduced.
    pub metric: String,
    /// Poses summarised.
    pub poses: u64,
    /// Poses with a value of the metric. The others see nothing, or the metric is empty there.
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

/// Returns `value` in units of 2^-FIXED_BITS, rounded half away from zero.
/// Returns `None` when it is too large for the sums to stay exact.
fn fixed(value: f64) -> Option<i128> {
    let scaled = value * f64::from(FIXED_BITS).exp2();
    if scaled.abs() < 2f64.powi(62) {
        // Here the truncation and its fraction are exact in 64 bits, so this is
        // `scaled.round()` without a library call.
        #[expect(clippy::cast_possible_truncation, reason = "bounded just above")]
        let t = scaled as i64;
        #[expect(clippy::cast_precision_loss, reason = "t is scaled truncated: a double")]
        let fraction = scaled - t as f64;
        let rounded = if fraction >= 0.5 {
            t + 1
        } else if fraction <= -0.5 {
            t - 1
        } else {
            t
        };
        return Some(i128::from(rounded));
    }
    let scaled = scaled.round();
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
        // The integer quotient and remainder keep the division exact until one final rounding.
        // Where the sum fits in 64 bits, divide there: the same result in a fraction of the time.
        let (q, r, n) = match (i64::try_from(sum), i64::try_from(count)) {
            (Ok(s), Ok(n)) => (
                i128::from(s.div_euclid(n)),
                i128::from(s.rem_euclid(n)),
                i128::from(n),
            ),
            _ => {
                let n = i128::from(count);
                (sum.div_euclid(n), sum.rem_euclid(n), n)
            }
        };
        (q as f64 + r as f64 / n as f64) / f64::from(FIXED_BITS).exp2()
    })
}

/// Sets the marginals' means in `s` from their exact sums, once every part is in.
pub(crate) fn fill_means(s: &mut Summary) {
    for m in &mut s.marginals {
        m.mean = m.sum.iter().zip(&m.count).map(|(&s, &n)| mean_of(s, n)).collect();
    }
}

fn ascending(a: &Ranked, b: &Ranked) -> std::cmp::Ordering {
    a.value.total_cmp(&b.value).then(a.index.cmp(&b.index))
}

fn descending(a: &Ranked, b: &Ranked) -> std::cmp::Ordering {
    b.value.total_cmp(&a.value).then(a.index.cmp(&b.index))
}

/// Returns the lesser of `a` and `b` in IEEE total order (-0 below +0).
/// Unlike `f64::min`, which may return either zero, the result does not depend on the order.
fn least(a: f64, b: f64) -> f64 {
    if b.total_cmp(&a).is_lt() { b } else { a }
}

/// Returns the greater of `a` and `b` in IEEE total order (+0 above -0).
fn greatest(a: f64, b: f64) -> f64 {
    if b.total_cmp(&a).is_gt() { b } else { a }
}

/// Returns the first `k` (> 0) of `all` in the total `order`, sorted.
/// It selects them first, so only `k` are sorted.
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

/// The first `k` poses offered: smallest first when `ASCENDING`, else largest (ties: lower index).
/// A pose behind the `k`-th at the last trim is not stored.
struct Best<const ASCENDING: bool> {
    list: Vec<Ranked>,
    k: usize,
    /// The `k`-th after the last trim, when there were `k`.
    bound: Option<Ranked>,
    /// The bound's total-order key ([`cells::key`]), or the key no value passes without a bound.
    /// A pose whose key is past it is behind the bound: the caller need not offer it.
    cut: i64,
}

impl<const ASCENDING: bool> Best<ASCENDING> {
    fn order(a: &Ranked, b: &Ranked) -> std::cmp::Ordering {
        if ASCENDING {
            ascending(a, b)
        } else {
            descending(a, b)
        }
    }

    /// Returns the best `k`, starting from `list`, itself the best of earlier poses.
    fn new(list: Vec<Ranked>, k: usize) -> Self {
        let cut = if ASCENDING { i64::MAX } else { i64::MIN };
        let mut best = Best {
            list,
            k,
            bound: None,
            cut,
        };
        best.trim();
        best
    }

    #[inline]
    fn offer(&mut self, r: Ranked) {
        // A value behind the bound is out at once; a tie goes by the total order.
        // No NaN reaches here, and -0 == +0 only ties.
        let behind = |b: Ranked| {
            let by_value = if ASCENDING {
                r.value > b.value
            } else {
                r.value < b.value
            };
            by_value || (r.value == b.value && Self::order(&r, &b).is_ge())
        };
        if self.k == 0 || self.bound.is_some_and(behind) {
            return;
        }
        self.list.push(r);
        if self.list.len() >= 2 * self.k + 64 {
            self.trim();
        }
    }

    /// Keeps the first `k` only.
    fn trim(&mut self) {
        if self.k == 0 {
            self.list.clear();
            return;
        }
        self.list = first_in_order(std::mem::take(&mut self.list), self.k, Self::order);
        if self.list.len() == self.k {
            self.bound = self.list.last().copied();
            self.cut = self.bound.map_or(self.cut, |b| cells::key(b.value));
        }
    }

    /// Returns the first `k` offered, in order.
    fn finish(mut self) -> Vec<Ranked> {
        self.trim();
        self.list
    }
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
        let values: Vec<f64> = values.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
        let mut s = self.partial(grid, first, &values)?;
        fill_means(&mut s);
        Ok(s)
    }

    /// Returns [`SummarySpec::summarise`]'s summary of `values` (NaN: no value), without means.
    /// Parts keep this form and [`SummarySpec::merge_into`] adds it up. [`fill_means`] derives
    /// the means once at the end.
    pub(crate) fn partial(&self, grid: Option<&Grid>, first: u64, values: &[f64]) -> Result<Summary> {
        // The marginals and the rest (counts, extremes, top, histogram) are tasks of their own.
        // The rest runs in small pieces, each piece's summary a few hundred bytes. A marginal's
        // pieces each hold all its cells, so they are only as many as the cores and at least
        // eight poses a cell: before, every small piece held them all, 1.4 MB for two 10 000-cell
        // marginals, a hundred times a chunk on 16 cores. Every reduction is exact and
        // order-independent, so the result is the same.
        let mut s = self.empty(grid);
        let marginals = std::mem::take(&mut s.marginals);
        let (marginals, rest) = rayon::join(
            || {
                marginals
                    .into_par_iter()
                    .map(|m| self.marginal(m, grid, first, values))
                    .collect::<Result<Vec<Marginal>>>()
            },
            || self.rest(first, values),
        );
        let marginals = marginals?;
        let mut rest = rest?;
        rest.marginals = marginals;
        Ok(rest)
    }

    /// Returns empty marginal `m` with poses `first`, `first + 1`, … of metric `values` added,
    /// in pieces of at least eight poses a cell, at most one a core.
    fn marginal(&self, m: Marginal, grid: Option<&Grid>, first: u64, values: &[f64]) -> Result<Marginal> {
        let grid = grid.expect("marginals are checked to need a grid");
        let cells = m.count.len().max(1);
        let pieces = (values.len() / (8 * cells).max(1 << 14)).clamp(1, rayon::current_num_threads());
        let piece = values.len().div_ceil(pieces).max(1);
        let n = m.count.len();
        let one = |k: usize, v: &[f64]| -> Result<Cells> {
            let mut c = Cells::new(n);
            let from = first + (k * piece) as u64;
            let odometer = Odometer::new(grid, &m.axes, from);
            add_to_marginal(&mut c, odometer, v, |i, x| self.fixed_of(from, i, x))?;
            Ok(c)
        };
        if pieces == 1 {
            return Ok(one(0, values)?.into_marginal(m));
        }
        // The first error in pose order, whichever piece finds it first.
        let parts: Vec<Result<Cells>> = values
            .par_chunks(piece)
            .enumerate()
            .map(|(k, v)| one(k, v))
            .collect();
        let mut total = Cells::new(n);
        for part in parts {
            total.add(&part?);
        }
        Ok(total.into_marginal(m))
    }

    /// Returns the summary of `values` from pose `first`, but for its marginals (left empty):
    /// pieces on all cores, each added to its thread's running summary, those then combined.
    fn rest(&self, first: u64, values: &[f64]) -> Result<Summary> {
        const PIECE: usize = 1 << 14;
        // Without a grid, the marginals have no cells: a piece's summary is a few hundred bytes
        // and a histogram.
        let bare = || self.empty(None);
        if values.len() <= 2 * PIECE {
            let mut s = bare();
            self.add_rest(&mut s, first, values);
            return Ok(s);
        }
        values
            .par_chunks(PIECE)
            .enumerate()
            .fold(bare, |mut s, (k, v)| {
                self.add_rest(&mut s, first + (k * PIECE) as u64, v);
                s
            })
            .map(Ok)
            .try_reduce(bare, |mut a, b| {
                self.merge_into(&mut a, &b, "summary")?;
                Ok(a)
            })
    }

    /// Returns value `k`'s exact term for a marginal's sum, of poses from `first`.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the pose when it is too large for exact sums.
    fn fixed_of(&self, first: u64, k: usize, value: f64) -> Result<i128> {
        fixed(value).ok_or_else(|| {
            Error::invalid(
                format!("summary of {} at pose {}", self.by, first + k as u64),
                value,
                "is too large for the marginals' exact sums (at most 2^40)",
            )
        })
    }

    /// Adds poses `first`, `first + 1`, … with metric `values` (NaN: no value) to `s`, which
    /// holds none of them yet. One thread: a pass per marginal, then one for the rest.
    #[cfg(test)]
    fn add(&self, s: &mut Summary, grid: Option<&Grid>, first: u64, values: &[f64]) -> Result<()> {
        for (k, m) in s.marginals.iter_mut().enumerate() {
            let grid = grid.expect("marginals are checked to need a grid");
            let odometer = Odometer::new(grid, &m.axes, first);
            let mut cells = Cells::new(m.count.len());
            add_to_marginal(&mut cells, odometer, values, |k, v| self.fixed_of(first, k, v))?;
            let empty = self.empty(Some(grid)).marginals.swap_remove(k);
            add_cells(m, &cells.into_marginal(empty));
        }
        self.add_rest(s, first, values);
        Ok(())
    }

    /// Adds poses `first`, `first + 1`, … with metric `values` (NaN: no value) to `s`, which
    /// holds none of them yet: all but the marginals, in one pass.
    fn add_rest(&self, s: &mut Summary, first: u64, values: &[f64]) {
        s.poses += values.len() as u64;
        let mut smallest = Best::<true>::new(std::mem::take(&mut s.smallest), self.top);
        let mut largest = Best::<false>::new(std::mem::take(&mut s.largest), self.top);
        #[expect(clippy::cast_precision_loss, reason = "bin counts are small")]
        let histogram = self.histogram.map(|h| (h, h.bins as f64 / (h.max - h.min)));
        // This piece's extremes: the first pose with the least key, and with the greatest.
        let (mut low, mut low_at, mut high, mut high_at) = (i64::MAX, 0, i64::MIN, 0);
        let mut seen = 0u64;
        for (k, &value) in values.iter().enumerate() {
            if value.is_nan() {
                continue;
            }
            seen += 1;
            let key = cells::key(value);
            if key < low {
                (low, low_at) = (key, k);
            }
            if key > high {
                (high, high_at) = (key, k);
            }
            let r = || Ranked {
                index: first + k as u64,
                value,
            };
            if key <= smallest.cut {
                smallest.offer(r());
            }
            if key >= largest.cut {
                largest.offer(r());
            }
            if let (Some(h), Some((spec, per))) = (&mut s.histogram, histogram) {
                if value < spec.min {
                    h.below += 1;
                } else if value > spec.max {
                    h.above += 1;
                } else {
                    #[expect(
                        clippy::cast_possible_truncation,
                        clippy::cast_sign_loss,
                        reason = "within the bins"
                    )]
                    let mut b = ((value - spec.min) * per) as usize;
                    // The bin holds its lower edge: settle the rounding against the edges.
                    b = b.min(spec.bins - 1);
                    while b > 0 && value < h.edges[b] {
                        b -= 1;
                    }
                    while b + 1 < spec.bins && value >= h.edges[b + 1] {
                        b += 1;
                    }
                    h.counts[b] += 1;
                }
            }
        }
        s.smallest = smallest.finish();
        s.largest = largest.finish();
        if seen > 0 {
            // No value's key is i64::MAX or MIN (those are NaNs), so both were found.
            let at = |k: usize| first + k as u64;
            let (min, max) = (values[low_at], values[high_at]);
            let (min, max) = (
                Ranked {
                    index: at(low_at),
                    value: min,
                },
                Ranked {
                    index: at(high_at),
                    value: max,
                },
            );
            s.with_value += seen;
            if s.min.is_none_or(|m| ascending(&min, &m).is_lt()) {
                s.min = Some(min);
            }
            if s.max.is_none_or(|m| descending(&max, &m).is_lt()) {
                s.max = Some(max);
            }
        }
    }

    /// Returns `a` and `b`, summaries of this spec over disjoint poses, combined.
    /// The result is the same whichever order they come in.
    ///
    /// # Errors
    /// [`Error::Csv`] naming `context` when the two are not summaries of this spec (another
    /// metric, histogram or marginals) or a sum is not a number.
    pub fn combine(&self, a: &Summary, b: &Summary, context: &str) -> Result<Summary> {
        let mut total = a.clone();
        self.merge_into(&mut total, b, context)?;
        fill_means(&mut total);
        Ok(total)
    }

    /// Adds `b` to `total` like [`SummarySpec::combine`], but in place and without the means.
    /// It costs only the cells; [`fill_means`] derives the means at the end.
    ///
    /// # Errors
    /// As [`SummarySpec::combine`]. `total` is unchanged on error.
    pub(crate) fn merge_into(&self, total: &mut Summary, b: &Summary, context: &str) -> Result<()> {
        let bad = |message: &str| Error::Csv {
            context: context.to_string(),
            message: message.to_string(),
        };
        let a = &*total;
        let same_shape = a.metric == b.metric
            && a.histogram.as_ref().map(|h| (&h.edges, h.counts.len()))
                == b.histogram.as_ref().map(|h| (&h.edges, h.counts.len()))
            && a.marginals.len() == b.marginals.len()
            && a.marginals.iter().zip(&b.marginals).all(|(x, y)| {
                let lens = |m: &Marginal| [m.count.len(), m.min.len(), m.max.len(), m.sum.len()];
                x.axes == y.axes && x.values == y.values && lens(x) == lens(y)
            });
        if !same_shape || a.metric != self.by {
            return Err(bad(
                "its summary is not of this sweep's [summary] (another metric, histogram or marginals)",
            ));
        }
        let add = |p: u64, q: u64| p.checked_add(q).ok_or_else(|| bad("a count overflows"));
        // Everything that can fail is checked before `total` changes.
        let poses = add(a.poses, b.poses)?;
        let with_value = add(a.with_value, b.with_value)?;
        if let (Some(x), Some(y)) = (&a.histogram, &b.histogram) {
            for (p, q) in x
                .counts
                .iter()
                .chain([&x.below, &x.above])
                .zip(y.counts.iter().chain([&y.below, &y.above]))
            {
                add(*p, *q)?;
            }
        }
        for (x, y) in a.marginals.iter().zip(&b.marginals) {
            for (p, q) in x.count.iter().zip(&y.count) {
                add(*p, *q)?;
            }
            if x.sum.iter().zip(&y.sum).any(|(p, q)| p.checked_add(*q).is_none()) {
                return Err(bad("a marginal's sum overflows"));
            }
        }
        let pick = |x: Option<Ranked>,
                    y: Option<Ranked>,
                    order: fn(&Ranked, &Ranked) -> std::cmp::Ordering| match (x, y) {
            (Some(x), Some(y)) => Some(if order(&x, &y).is_le() { x } else { y }),
            (x, y) => x.or(y),
        };
        let merge = |x: &mut Vec<Ranked>, y: &[Ranked], order: fn(&Ranked, &Ranked) -> std::cmp::Ordering| {
            x.extend_from_slice(y);
            x.sort_by(order);
            x.truncate(self.top);
        };
        let total = &mut *total;
        total.poses = poses;
        total.with_value = with_value;
        total.min = pick(total.min, b.min, ascending);
        total.max = pick(total.max, b.max, descending);
        merge(&mut total.smallest, &b.smallest, ascending);
        merge(&mut total.largest, &b.largest, descending);
        if let (Some(x), Some(y)) = (&mut total.histogram, &b.histogram) {
            for (p, q) in x.counts.iter_mut().zip(&y.counts) {
                *p += q;
            }
            x.below += y.below;
            x.above += y.above;
        }
        for (x, y) in total.marginals.iter_mut().zip(&b.marginals) {
            add_cells(x, y);
        }
        Ok(())
    }
}

/// Adds marginal `y`'s cells, over poses disjoint from `x`'s, to `x` (of the same cells).
/// Counts and sums must not overflow (checked by the caller where they could).
fn add_cells(x: &mut Marginal, y: &Marginal) {
    let both = |p: &mut Option<f64>, q: Option<f64>, f: fn(f64, f64) -> f64| {
        *p = match (*p, q) {
            (Some(p), Some(q)) => Some(f(p, q)),
            (p, q) => p.or(q),
        };
    };
    for (p, q) in x.sum.iter_mut().zip(&y.sum) {
        *p += q;
    }
    for (p, q) in x.count.iter_mut().zip(&y.count) {
        *p += q;
    }
    for (p, q) in x.min.iter_mut().zip(&y.min) {
        both(p, *q, least);
    }
    for (p, q) in x.max.iter_mut().zip(&y.max) {
        both(p, *q, greatest);
    }
}
