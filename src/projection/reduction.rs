//! Reductions of one metric over a sweep's poses, computed where the poses are projected: what a
//! summaries-only sweep asks of the GPU ([`Backend::reduce_blocks`](crate::Backend::reduce_blocks)).
//! No per-pose metric leaves the device; each block of poses comes back as a [`Reduction`]:
//! counts, a histogram, cells of one or two grid axes, and the smallest and largest poses.
//!
//! Every part is exact and does not depend on the order the poses are taken in. Cell sums are
//! integers of 2^-[`FIXED_BITS`] units, so a caller adds blocks up exactly.

use crate::error::{Error, Result};
use crate::metrics::Metric;

/// The fixed-point resolution of cell sums: 2^-40 of the metric's unit.
pub const FIXED_BITS: i32 = 40;

/// The most poses [`MetricReduction::top`] may ask for at each end. The device hands back that
/// many candidates each way for every 256 poses, 16 bytes each: `top / 8` bytes a pose, at most
/// 4 here, no more than reading back the metric itself (4 to 12 bytes a pose).
pub const MAX_DEVICE_TOP: usize = 32;

/// What to reduce: one metric's values over a sweep's poses.
#[derive(Clone, Debug, PartialEq)]
pub struct MetricReduction {
    /// The metric reduced.
    pub metric: Metric,
    /// How many of the smallest and of the largest poses to return (at most
    /// [`MAX_DEVICE_TOP`]); at least the one at each end is always returned.
    pub top: usize,
    /// The histogram's bins, if any.
    pub histogram: Option<HistogramBins>,
    /// The cells to add the values up in, one set each.
    pub cells: Vec<CellAxes>,
}

/// A histogram's bins: a value `v` with `min <= v <= max` goes to the last bin whose lower edge
/// is at most `v`; values outside count below or above.
#[derive(Clone, Debug, PartialEq)]
pub struct HistogramBins {
    /// The lowest value binned.
    pub min: f64,
    /// The highest value binned.
    pub max: f64,
    /// The bins' edges, non-decreasing: one more than the bins.
    pub edges: Vec<f64>,
}

/// A set of cells over one or two digits of the pose index: pose `i` goes to the cell
/// `sum((i / stride) % len * weight)` over the digits.
#[derive(Clone, Debug, PartialEq)]
pub struct CellAxes {
    /// The digits: one or two.
    pub digits: Vec<Digit>,
}

/// One digit of the pose index: `(index / stride) % len`, weighted by `weight` in a cell's number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Digit {
    /// Poses a value of the digit lasts.
    pub stride: u64,
    /// The digit's values.
    pub len: u64,
    /// The digit's weight in the cell number.
    pub weight: u64,
}

impl CellAxes {
    /// Returns the number of cells: the product of the digits' lengths.
    #[must_use]
    pub fn cells(&self) -> u64 {
        self.digits.iter().map(|d| d.len).product()
    }
}

/// One block of poses reduced.
#[derive(Clone, Debug, PartialEq)]
pub struct Reduction {
    /// Poses in the block.
    pub poses: u64,
    /// Poses with a value of the metric.
    pub with_value: u64,
    /// The smallest values and their poses, smallest first (ties: lower pose first): the first
    /// `max(top, 1)` of the block, fewer when fewer poses have a value.
    pub smallest: Vec<(u64, f64)>,
    /// The largest values and their poses, largest first (ties: lower pose first).
    pub largest: Vec<(u64, f64)>,
    /// The histogram's counts, when one was asked for.
    pub histogram: Option<HistogramCounts>,
    /// The cells, one set per [`MetricReduction::cells`].
    pub cells: Vec<CellTotals>,
    /// The first pose whose value times 2^[`FIXED_BITS`] is 2^62 or more in size, when cells
    /// were asked for. The device does not sum it exactly, so `cells` is then empty and the caller
    /// reduces this block itself.
    pub too_large: Option<u64>,
}

/// A histogram's counts.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HistogramCounts {
    /// Values in each bin.
    pub counts: Vec<u64>,
    /// Values below `min`.
    pub below: u64,
    /// Values above `max`.
    pub above: u64,
}

/// One set of cells: per cell, the values' count, exact sum, least and greatest.
#[derive(Clone, Debug, PartialEq)]
pub struct CellTotals {
    /// Values in each cell.
    pub count: Vec<u64>,
    /// Their exact sum, in units of 2^-[`FIXED_BITS`].
    pub sum: Vec<i128>,
    /// The least value (IEEE total order), `None` in a cell without one.
    pub min: Vec<Option<f64>>,
    /// The greatest value.
    pub max: Vec<Option<f64>>,
}

/// The most cells, over all sets, a reduction may ask for: with [`MAX_BINS`], the accumulators
/// (40 bytes a cell, 8 a bin) fit in a 128 MiB binding, the least a device offers.
pub const MAX_CELLS: u64 = 1 << 21;
/// The most histogram bins a reduction may ask for.
pub const MAX_BINS: usize = 1 << 20;

impl MetricReduction {
    /// Checks the reduction's bounds.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the field: `top` above [`MAX_DEVICE_TOP`], a histogram
    /// without bins, past [`MAX_BINS`] or with edges not non-decreasing, cells with no digit or
    /// more than two, a digit with a zero stride or length, or more than [`MAX_CELLS`] cells.
    pub fn validate(&self) -> Result<()> {
        if self.top > MAX_DEVICE_TOP {
            return Err(Error::invalid(
                "reduction top",
                self.top,
                format!("at most {MAX_DEVICE_TOP} on the device"),
            ));
        }
        if let Some(h) = &self.histogram {
            let bins = h.edges.len().saturating_sub(1);
            if bins == 0 || bins > MAX_BINS {
                return Err(Error::invalid(
                    "reduction histogram edges",
                    h.edges.len(),
                    format!("2 to {} edges", MAX_BINS + 1),
                ));
            }
            if h.edges
                .windows(2)
                .any(|w| w[0].is_nan() || w[1].is_nan() || w[0] > w[1])
                || h.min.is_nan()
                || h.max.is_nan()
            {
                return Err(Error::invalid(
                    "reduction histogram edges",
                    format!("{:?}..", &h.edges[..h.edges.len().min(4)]),
                    "non-decreasing numbers",
                ));
            }
        }
        let mut cells = 0u64;
        for (k, c) in self.cells.iter().enumerate() {
            if c.digits.is_empty() || c.digits.len() > 2 {
                return Err(Error::invalid(
                    format!("reduction cells[{k}] digits"),
                    c.digits.len(),
                    "one or two",
                ));
            }
            for d in &c.digits {
                if d.stride == 0
                    || d.len == 0
                    || d.len > u64::from(u32::MAX)
                    || d.weight > u64::from(u32::MAX)
                {
                    return Err(Error::invalid(
                        format!("reduction cells[{k}] digit"),
                        format!("{d:?}"),
                        "a stride of at least 1 and a length from 1 to 2^32 - 1",
                    ));
                }
            }
            cells = cells.saturating_add(c.cells());
        }
        if cells > MAX_CELLS {
            return Err(Error::invalid(
                "reduction cells",
                cells,
                format!("at most {MAX_CELLS} cells in all"),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reduction() -> MetricReduction {
        MetricReduction {
            metric: Metric::Span,
            top: 3,
            histogram: Some(HistogramBins {
                min: 0.0,
                max: 1.0,
                edges: vec![0.0, 0.5, 1.0],
            }),
            cells: vec![CellAxes {
                digits: vec![Digit {
                    stride: 1,
                    len: 4,
                    weight: 1,
                }],
            }],
        }
    }

    /// Each bound names its field; a reduction within them passes.
    #[test]
    fn bad_reductions_name_their_field() {
        assert!(reduction().validate().is_ok());
        let message = |r: MetricReduction| r.validate().unwrap_err().to_string();
        let mut r = reduction();
        r.top = MAX_DEVICE_TOP + 1;
        assert!(message(r).contains("reduction top = 33"));
        let mut r = reduction();
        r.histogram.as_mut().unwrap().edges = vec![0.0];
        assert!(message(r).contains("reduction histogram edges = 1"));
        let mut r = reduction();
        r.histogram.as_mut().unwrap().edges = vec![0.0, 1.0, 0.5];
        assert!(message(r).contains("non-decreasing"));
        let mut r = reduction();
        r.histogram.as_mut().unwrap().edges = vec![0.0, f64::NAN];
        assert!(message(r).contains("non-decreasing"));
        let mut r = reduction();
        r.cells[0].digits.clear();
        assert!(message(r).contains("reduction cells[0] digits = 0"));
        let mut r = reduction();
        r.cells[0].digits[0].stride = 0;
        assert!(message(r).contains("reduction cells[0] digit"));
        let mut r = reduction();
        r.cells[0].digits[0].len = MAX_CELLS + 1;
        assert!(message(r).contains("reduction cells = "));
    }
}
