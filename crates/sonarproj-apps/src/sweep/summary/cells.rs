//! A marginal's cells while poses are added to it, and the odometer that walks a chunk's poses
//! through them.
//!
//! Adding a value costs no branch on whether its cell had one: the extremes are kept as keys of
//! the IEEE total order (integers), and a value's exact term is taken without a library call
//! where it is small enough, as every real metric is. The rare large value goes the checked way.

use super::Marginal;
#[cfg(test)]
use super::fixed;
use crate::error::Result;
use crate::sweep::grid::Grid;

/// Returns the key of `v` in the IEEE total order (`f64::total_cmp`): keys compare as `v` does.
#[inline]
#[expect(clippy::cast_sign_loss, clippy::cast_possible_wrap, reason = "bit casts")]
pub(super) fn key(v: f64) -> i64 {
    let b = v.to_bits() as i64;
    b ^ (((b >> 63) as u64) >> 1) as i64
}

/// Returns the value whose [`key`] is `k`.
#[inline]
#[expect(clippy::cast_sign_loss, clippy::cast_possible_wrap, reason = "bit casts")]
fn value_of(k: i64) -> f64 {
    // The sign is kept, so the same flip undoes it.
    f64::from_bits((k ^ (((k >> 63) as u64) >> 1) as i64) as u64)
}

/// Returns `value`'s exact term as [`fixed`] does, and whether it is right: only where the
/// value times 2^FIXED_BITS is below 2^62 in size (not for NaN or infinities).
#[inline]
fn fixed_small(value: f64) -> (i64, bool) {
    let scaled = value * f64::from(super::FIXED_BITS).exp2();
    let small = scaled.abs() < 2f64.powi(62);
    // As `fixed`: the truncation and its fraction are exact when small. When not, the cast
    // saturates and the wrapping arithmetic's result is thrown away.
    #[expect(clippy::cast_possible_truncation, reason = "used only when small")]
    let t = scaled as i64;
    #[expect(clippy::cast_precision_loss, reason = "t is scaled truncated: a double")]
    let fraction = scaled - t as f64;
    let rounded = t
        .wrapping_add(i64::from(fraction >= 0.5))
        .wrapping_sub(i64::from(fraction <= -0.5));
    (rounded, small)
}

/// A marginal's cells while poses are added: counts, exact sums, and the least and greatest
/// value as total-order keys ([`i64::MAX`] and [`i64::MIN`] in a cell with none).
#[derive(Clone)]
pub(super) struct Cells {
    count: Vec<u64>,
    sum: Vec<i128>,
    low: Vec<i64>,
    high: Vec<i64>,
}

impl Cells {
    /// Returns `n` empty cells.
    pub(super) fn new(n: usize) -> Cells {
        Cells {
            count: vec![0; n],
            sum: vec![0; n],
            low: vec![i64::MAX; n],
            high: vec![i64::MIN; n],
        }
    }

    /// Adds `other`'s cells, over poses disjoint from these, to these.
    /// Counts and sums must not overflow (a chunk's poses cannot make them).
    pub(super) fn add(&mut self, other: &Cells) {
        for (p, q) in self.count.iter_mut().zip(&other.count) {
            *p += q;
        }
        for (p, q) in self.sum.iter_mut().zip(&other.sum) {
            *p += q;
        }
        for (p, q) in self.low.iter_mut().zip(&other.low) {
            *p = (*p).min(*q);
        }
        for (p, q) in self.high.iter_mut().zip(&other.high) {
            *p = (*p).max(*q);
        }
    }

    /// Returns marginal `m`, which has no poses yet, holding these cells.
    pub(super) fn into_marginal(self, mut m: Marginal) -> Marginal {
        let extremes = |keys: &[i64]| -> Vec<Option<f64>> {
            keys.iter()
                .zip(&self.count)
                .map(|(&k, &n)| (n > 0).then(|| value_of(k)))
                .collect()
        };
        m.min = extremes(&self.low);
        m.max = extremes(&self.high);
        m.count = self.count;
        m.sum = self.sum;
        m
    }
}

/// A marginal's cell over consecutive poses, stepped without a division per pose.
/// Each axis is a digit: `[poses a value lasts, values, weight in the cell, place within the
/// value, the value]`.
pub(super) struct Odometer(Vec<[u64; 5]>);

impl Odometer {
    pub(super) fn new(grid: &Grid, axes: &[String], first: u64) -> Odometer {
        let mut digits = Vec::with_capacity(axes.len());
        let mut weight = 1u64;
        for a in axes.iter().rev() {
            let k = grid
                .axes
                .iter()
                .position(|x| x.column == a)
                .expect("checked axis");
            let stride: u64 = grid.axes[k + 1..].iter().map(|x| x.values.len() as u64).product();
            let n = grid.axes[k].values.len() as u64;
            digits.push([stride, n, weight, first % stride, (first / stride) % n]);
            weight *= n;
        }
        Odometer(digits)
    }

    /// Returns the cell of the current pose.
    fn cell(&self) -> usize {
        let cell: u64 = self.0.iter().map(|d| d[4] * d[2]).sum();
        #[expect(clippy::cast_possible_truncation, reason = "below the cell count")]
        let cell = cell as usize;
        cell
    }

    /// Returns the length (1 to `left`) of the run of poses from the current one whose cell
    /// rises by a fixed step per pose, and that step (0: one cell). Within the run, slow axes
    /// hold their value and per-pose axes do not wrap.
    fn segment(&self, left: usize) -> (usize, usize) {
        let mut len = left as u64;
        let mut step = 0;
        for d in &self.0 {
            if d[0] == 1 {
                len = len.min(d[1] - d[4]);
                step += d[2];
            } else {
                len = len.min(d[0] - d[3]);
            }
        }
        #[expect(
            clippy::cast_possible_truncation,
            reason = "at most left, and below the cell count"
        )]
        let out = (len as usize, step as usize);
        out
    }

    /// Steps `by` poses: the length of the current [`Odometer::segment`] or less.
    fn advance(&mut self, by: u64) {
        for d in &mut self.0 {
            if d[0] == 1 {
                d[4] += by;
                if d[4] == d[1] {
                    d[4] = 0;
                }
            } else {
                d[3] += by;
                if d[3] == d[0] {
                    d[3] = 0;
                    d[4] = if d[4] + 1 == d[1] { 0 } else { d[4] + 1 };
                }
            }
        }
    }
}

/// Adds poses with metric `values` (NaN: no value), from `odometer`'s pose, to `cells`.
/// A segment in one cell (slow axes) is reduced first and added once. A segment whose cell steps
/// every pose is added value by value. `fixed_of(k, v)` is value `k`'s exact term, or the error
/// naming it; it is called only where a value is too large for the quick term: for that value
/// in a stepping segment, for every value of a one-cell segment holding one.
pub(super) fn add_to_marginal(
    cells: &mut Cells,
    mut odometer: Odometer,
    values: &[f64],
    fixed_of: impl Fn(usize, f64) -> Result<i128>,
) -> Result<()> {
    let mut k = 0;
    while k < values.len() {
        let (len, step) = odometer.segment(values.len() - k);
        let base = odometer.cell();
        let segment = &values[k..k + len];
        if step == 0 {
            // No branch per value: a value not seen adds nothing.
            let (mut count, mut sum, mut low, mut high, mut large) = (0u64, 0i128, i64::MAX, i64::MIN, false);
            for &v in segment {
                let seen = !v.is_nan();
                let (term, small) = fixed_small(v);
                let key = key(v);
                large |= seen && !small;
                count += u64::from(seen);
                sum += i128::from(if seen { term } else { 0 });
                low = if seen { low.min(key) } else { low };
                high = if seen { high.max(key) } else { high };
            }
            if large {
                // Again, the checked way: the first value too large is the error.
                sum = 0;
                for (i, &v) in segment.iter().enumerate() {
                    if !v.is_nan() {
                        sum += fixed_of(k + i, v)?;
                    }
                }
            }
            cells.count[base] += count;
            cells.sum[base] += sum;
            cells.low[base] = cells.low[base].min(low);
            cells.high[base] = cells.high[base].max(high);
        } else {
            for (i, &v) in segment.iter().enumerate() {
                if v.is_nan() {
                    continue;
                }
                let (term, small) = fixed_small(v);
                let term = if small {
                    i128::from(term)
                } else {
                    fixed_of(k + i, v)?
                };
                let (c, key) = (base + i * step, key(v));
                cells.count[c] += 1;
                cells.sum[c] += term;
                cells.low[c] = cells.low[c].min(key);
                cells.high[c] = cells.high[c].max(key);
            }
        }
        odometer.advance(len as u64);
        k += len;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks the keys against `f64::total_cmp`, and the quick term against `fixed`, on values
    /// at the edges: zeros, halves, the 2^62 bound, infinities and NaN.
    #[test]
    fn keys_order_as_total_cmp_and_quick_terms_are_fixed() {
        let unit = f64::from(super::super::FIXED_BITS).exp2();
        let mut values = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5 / unit,
            -0.5 / unit,
            1.5 / unit,
            -2.5 / unit,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            2f64.powi(22),
            -(2f64.powi(22)),
            2f64.powi(22) * (1.0 - f64::EPSILON),
            2f64.powi(30),
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            0.1,
            -0.3,
            1.045_280_700_883_168_4,
        ];
        values.extend((1..200).map(|i| f64::from(i) * 0.37 - 30.0));
        for &a in &values {
            assert_eq!(value_of(key(a)).to_bits(), a.to_bits(), "{a}");
            for &b in &values {
                assert_eq!(key(a).cmp(&key(b)), a.total_cmp(&b), "{a} against {b}");
            }
            let (term, small) = fixed_small(a);
            let scaled = a * unit;
            assert_eq!(small, scaled.abs() < 2f64.powi(62), "{a}");
            if small {
                assert_eq!(Some(i128::from(term)), fixed(a), "{a}");
            }
        }
    }
}
