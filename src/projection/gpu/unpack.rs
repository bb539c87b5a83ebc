//! A chunk's results as read back and unpacked on the host, and where a call's poses come from
//! (a batch's items or a grid's range).

use rayon::prelude::*;

use crate::geometry::SonarKind;
use crate::metrics::{Extremes, Metrics};
use crate::occupancy::{Layout, Occupancy};
use crate::projection::columns::MetricSlices;
use crate::projection::poses::PreparedGrid;
use crate::projection::{PreparedBatch, Projection};
use crate::sampling::SamplingPlan;

use super::types::*;

/// A chunk's results as read back: what each pose's projection or metrics are made of, on the
/// host, a pose at a time (in parallel, and for a grid's columns with no per-pose object).
pub(super) struct Unpack<'a> {
    pub(super) source: &'a Source<'a>,
    pub(super) plans: &'a [SamplingPlan],
    pub(super) layout: &'a Layout,
    pub(super) raw: &'a [u32],
    pub(super) raw_bits: Option<&'a [u32]>,
    pub(super) words: usize,
    pub(super) pixel_words: usize,
    /// The chunk's first pose and its number of poses.
    pub(super) start: usize,
    pub(super) count: usize,
}

impl Unpack<'_> {
    /// Returns the metrics of the chunk's pose `c`.
    pub(super) fn metrics(&self, c: usize) -> Metrics {
        let (layout, m) = (self.layout, &self.raw[c * METRIC_STRIDE..(c + 1) * METRIC_STRIDE]);
        let total = self.plans[self.source.plan_index(self.start + c)].total() as u64;
        let extremes = Extremes {
            range_min: f64::from(from_order_key(!m[METRIC_RANGE_MIN_NOT])),
            range_max: f64::from(from_order_key(m[METRIC_RANGE_MAX])),
            azimuth_min: f64::from(from_order_key(!m[METRIC_AZIMUTH_MIN_NOT])),
            azimuth_max: f64::from(from_order_key(m[METRIC_AZIMUTH_MAX])),
        };
        let occupied = u64::from(m[METRIC_OCCUPIED]);
        let measure = match layout.kind {
            SonarKind::Sss => occupied as f64 * layout.range_bin_width,
            SonarKind::Fls => f64::from(f32::from_bits(m[METRIC_OCCUPIED_MEASURE])),
        };
        let area = layout
            .area_grid
            .map(|g| g.area(u64::from(m[METRIC_PROJECTION_AREA])));
        let visible = u64::from(m[METRIC_VISIBLE]);
        Metrics::new(visible, total, extremes, (occupied, measure), area)
    }

    /// Writes the kept columns of `rows`, the metrics of the chunk's poses `first..` (the
    /// values of [`Unpack::metrics`], bit for bit), column by column: a column not kept costs
    /// nothing, so a caller reducing one metric unpacks only that one.
    pub(super) fn fill(&self, rows: MetricSlices<'_>, first: usize) {
        let raw = &self.raw[first * METRIC_STRIDE..][..rows.len() * METRIC_STRIDE];
        let seen = |m: &[u32]| m[METRIC_VISIBLE] > 0;
        let key = |m: &[u32], slot: usize| f64::from(from_order_key(m[slot]));
        let not_key = |m: &[u32], slot: usize| f64::from(from_order_key(!m[slot]));
        // As `Metrics::new`: the extremes are none (NaN) and the span 0 where nothing is seen.
        let nan_unless = |m: &[u32], v: f64| if seen(m) { v } else { f64::NAN };
        column(rows.visible, raw, |_, m| u64::from(m[METRIC_VISIBLE]));
        column(rows.total, raw, |k, _| {
            self.plans[self.source.plan_index(self.start + first + k)].total() as u64
        });
        column(rows.occupied, raw, |_, m| u64::from(m[METRIC_OCCUPIED]));
        column(rows.range_min, raw, |_, m| {
            nan_unless(m, not_key(m, METRIC_RANGE_MIN_NOT))
        });
        column(rows.range_max, raw, |_, m| {
            nan_unless(m, key(m, METRIC_RANGE_MAX))
        });
        column(rows.span, raw, |_, m| {
            if seen(m) {
                key(m, METRIC_RANGE_MAX) - not_key(m, METRIC_RANGE_MIN_NOT)
            } else {
                0.0
            }
        });
        column(rows.azimuth_min, raw, |_, m| {
            nan_unless(m, not_key(m, METRIC_AZIMUTH_MIN_NOT).to_degrees())
        });
        column(rows.azimuth_max, raw, |_, m| {
            nan_unless(m, key(m, METRIC_AZIMUTH_MAX).to_degrees())
        });
        let layout = self.layout;
        column(rows.occupied_measure, raw, |_, m| match layout.kind {
            SonarKind::Sss => f64::from(m[METRIC_OCCUPIED]) * layout.range_bin_width,
            SonarKind::Fls => f64::from(f32::from_bits(m[METRIC_OCCUPIED_MEASURE])),
        });
        column(rows.projection_area, raw, |_, m| {
            layout
                .area_grid
                .map_or(f64::NAN, |g| g.area(u64::from(m[METRIC_PROJECTION_AREA])))
        });
    }

    /// Returns the projection of the chunk's pose `c`, with its occupancy when it was read back.
    pub(super) fn projection(&self, c: usize) -> Projection {
        let (layout, words, pixel_words) = (self.layout, self.words, self.pixel_words);
        let occupancy = self.raw_bits.map(|b| {
            let words_of = &b[c * words..][..pixel_words];
            layout.to_data_order(Occupancy::from_words(
                layout.range_bins,
                layout.beams(),
                words_of.to_vec(),
            ))
        });
        let cells = self.raw_bits.zip(layout.area_grid).map(|(b, g)| {
            let words_of = &b[c * words + pixel_words..(c + 1) * words];
            Occupancy::from_words(g.nx, g.ny, words_of.to_vec())
        });
        Projection {
            metrics: self.metrics(c),
            occupancy,
            cells,
        }
    }

    /// Returns the chunk's projections, in order, made on all cores.
    pub(super) fn projections(&self) -> Vec<Projection> {
        (0..self.count)
            .into_par_iter()
            .map(|c| self.projection(c))
            .collect()
    }
}

/// Writes `out[k] = value(k, metrics of pose k)` for the poses of `raw` (`METRIC_STRIDE` words
/// each); nothing for a column not kept (empty).
fn column<T>(out: &mut [T], raw: &[u32], value: impl Fn(usize, &[u32]) -> T) {
    for (k, (v, m)) in out.iter_mut().zip(raw.chunks_exact(METRIC_STRIDE)).enumerate() {
        *v = value(k, m);
    }
}

/// Where the poses of a projection come from.
pub(super) enum Source<'a> {
    /// A batch's items, packed by the host.
    Items(&'a PreparedBatch<'a>),
    /// Poses `first..first + count` of a grid, decoded on the device.
    Grid {
        prepared: &'a PreparedGrid<'a>,
        first: u64,
        count: usize,
    },
}

impl Source<'_> {
    pub(super) fn count(&self) -> usize {
        match self {
            Source::Items(p) => p.batch.items.len(),
            Source::Grid { count, .. } => *count,
        }
    }

    pub(super) fn layout(&self) -> &Layout {
        match self {
            Source::Items(p) => &p.layout,
            Source::Grid { prepared, .. } => &prepared.layout,
        }
    }

    pub(super) fn plans(&self) -> &[SamplingPlan] {
        match self {
            Source::Items(p) => &p.plans,
            Source::Grid { prepared, .. } => &prepared.plans,
        }
    }

    /// Returns the index of pose `k`'s plan.
    pub(super) fn plan_index(&self, k: usize) -> usize {
        match self {
            Source::Items(p) => p.plan_index(k),
            Source::Grid { prepared, first, .. } => {
                prepared.plan_of_range[prepared.range_index(first + k as u64)] as usize
            }
        }
    }

    /// Returns the plans poses `range` use, in increasing order.
    pub(super) fn plans_used(&self, range: std::ops::Range<usize>) -> Vec<usize> {
        let mut used = vec![false; self.plans().len()];
        match self {
            Source::Items(_) => {
                for k in range {
                    used[self.plan_index(k)] = true;
                }
            }
            // The range axis is the slowest: the chunk's range values are one span.
            Source::Grid { prepared, first, .. } => {
                let range_of = |k: usize| prepared.range_index(first + k as u64);
                for r in range_of(range.start)..=range_of(range.end - 1) {
                    used[prepared.plan_of_range[r] as usize] = true;
                }
            }
        }
        (0..used.len()).filter(|&p| used[p]).collect()
    }
}
