//! A summary reduced on the device ([`sonarproj::Backend::reduce_blocks`]): the spec as the
//! engine's [`MetricReduction`], and its [`Reduction`] of a chunk as the chunk's summary part,
//! the same bits as [`SummarySpec::partial`] gives from the chunk's metric values.

use sonarproj::Metric;
use sonarproj::projection::Reduction;
use sonarproj::projection::reduction::{CellAxes, Digit, HistogramBins, MAX_DEVICE_TOP, MetricReduction};

use super::{FIXED_BITS, Ranked, Summary, SummarySpec, edges};
use crate::sweep::grid::Grid;

const _: () = assert!(FIXED_BITS == sonarproj::projection::reduction::FIXED_BITS);

impl SummarySpec {
    /// Returns this spec as the engine's reduction over `grid`, or `None` where the device
    /// cannot reduce it: a `top` above [`MAX_DEVICE_TOP`], or a metric not in the table.
    pub(crate) fn reduction(&self, grid: Option<&Grid>) -> Option<MetricReduction> {
        let metric = Metric::from_name(&self.by)?;
        if self.top > MAX_DEVICE_TOP {
            return None;
        }
        let histogram = self.histogram.map(|h| HistogramBins {
            min: h.min,
            max: h.max,
            edges: edges(&h),
        });
        // A marginal's cell, as its odometer numbers it: the last axis weighs 1.
        let mut cells = Vec::with_capacity(self.marginals.len());
        for axes in &self.marginals {
            let grid = grid?;
            let mut digits = Vec::with_capacity(axes.len());
            let mut weight = 1u64;
            for a in axes.iter().rev() {
                let k = grid.axes.iter().position(|x| x.column == a)?;
                let stride = grid.axes[k + 1..].iter().map(|x| x.values.len() as u64).product();
                let len = grid.axes[k].values.len() as u64;
                digits.push(Digit { stride, len, weight });
                weight *= len;
            }
            cells.push(CellAxes { digits });
        }
        Some(MetricReduction {
            metric,
            top: self.top,
            histogram,
            cells,
        })
    }

    /// Returns the summary part (no means) of the chunk `r` reduced on the device as `reduced`:
    /// what [`SummarySpec::partial`] returns for its metric values. `None` when the device could
    /// not sum a value exactly ([`Reduction::too_large`]): the caller then reduces the values.
    pub(crate) fn part_of_reduction(&self, grid: Option<&Grid>, reduced: &Reduction) -> Option<Summary> {
        if reduced.too_large.is_some() {
            return None;
        }
        let ranked = |&(index, value): &(u64, f64)| Ranked { index, value };
        let mut s = self.empty(grid);
        s.poses = reduced.poses;
        s.with_value = reduced.with_value;
        s.min = reduced.smallest.first().map(ranked);
        s.max = reduced.largest.first().map(ranked);
        s.smallest = reduced.smallest.iter().take(self.top).map(ranked).collect();
        s.largest = reduced.largest.iter().take(self.top).map(ranked).collect();
        if let (Some(h), Some(counts)) = (&mut s.histogram, &reduced.histogram) {
            h.counts.clone_from(&counts.counts);
            h.below = counts.below;
            h.above = counts.above;
        }
        for (m, cells) in s.marginals.iter_mut().zip(&reduced.cells) {
            m.count.clone_from(&cells.count);
            m.sum.clone_from(&cells.sum);
            m.min.clone_from(&cells.min);
            m.max.clone_from(&cells.max);
        }
        Some(s)
    }
}
