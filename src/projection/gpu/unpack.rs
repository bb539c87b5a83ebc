//! A chunk's results as read back and unpacked on the host, and where a call's poses come from: a
//! batch's items or a grid's range.

use rayon::prelude::*;

use crate::geometry::SonarKind;
use crate::metrics::{Extremes, Metrics};
use crate::occupancy::{Layout, Occupancy};
use crate::projection::columns::MetricSlices;
use crate::projection::pairs::PreparedPairs;
use crate::projection::poses::PreparedGrid;
use crate::projection::{PreparedBatch, Projection};
use crate::sampling::SamplingPlan;

use super::types::*;

/// A chunk's results as read back: what each pose's projection or metrics are made of. The host
/// unpacks them a pose at a time, in parallel. A grid's columns take no per-pose object.
pub(super) struct Unpack<'a> {
    pub(super) source: &'a Source<'a>,
    pub(super) plans: &'a [SamplingPlan],
    pub(super) layout: &'a Layout,
    /// The metric slots read back (`slots`), each a run of the chunk's `count` poses, in slot
    /// order.
    pub(super) raw: &'a [u32],
    pub(super) slots: Slots,
    pub(super) raw_bits: Option<&'a [u32]>,
    pub(super) words: usize,
    pub(super) pixel_words: usize,
    /// The chunk's first pose and its number of poses.
    pub(super) start: usize,
    pub(super) count: usize,
    /// Whether the call is solved exactly (its metric slots are the exact stage's).
    pub(super) exact: bool,
    /// In a summary run, what the chunk's summary stage read back (and no metric slot).
    pub(super) summary: Option<super::summary::ChunkSummary<'a>>,
}

impl Unpack<'_> {
    /// Returns metric slot `s` of the chunk's poses.
    ///
    /// # Panics
    /// When slot `s` was not read back (`slots_of` names every slot a column needs).
    fn slot(&self, s: usize) -> &[u32] {
        assert!(self.slots & 1 << s != 0, "metric slot {s} was not read back");
        let at = (self.slots & ((1 << s) - 1)).count_ones() as usize * self.count;
        &self.raw[at..at + self.count]
    }

    /// Returns the metrics of the chunk's pose `c` (every slot read back).
    pub(super) fn metrics(&self, c: usize) -> Metrics {
        let layout = self.layout;
        let at = |s: usize| self.slot(s)[c];
        let extremes = Extremes {
            range_min: f64::from(from_order_key(!at(METRIC_RANGE_MIN_NOT))),
            range_max: f64::from(from_order_key(at(METRIC_RANGE_MAX))),
            azimuth_min: f64::from(from_order_key(!at(METRIC_AZIMUTH_MIN_NOT))),
            azimuth_max: f64::from(from_order_key(at(METRIC_AZIMUTH_MAX))),
        };
        let occupied = u64::from(at(METRIC_OCCUPIED));
        let measure = match layout.kind {
            SonarKind::Sss => occupied as f64 * layout.range_bin_width,
            SonarKind::Fls => f64::from(f32::from_bits(at(METRIC_OCCUPIED_MEASURE))),
        };
        if self.exact {
            // The exact stage's visible slot holds the visible fraction's f32 bits.
            let fraction = f64::from(f32::from_bits(at(METRIC_VISIBLE)));
            return Metrics::exact(fraction, extremes, (occupied, measure));
        }
        let total = self.plans[self.source.plan_index(self.start + c)].total() as u64;
        let area = layout
            .area_grid
            .map(|g| g.area(u64::from(at(METRIC_PROJECTION_AREA))));
        let visible = u64::from(at(METRIC_VISIBLE));
        Metrics::new(visible, total, extremes, (occupied, measure), area)
    }

    /// Writes the kept columns of `rows`: the metrics of the chunk's poses `first..`, bit for bit
    /// the values of [`Unpack::metrics`]. It goes column by column from the slots read back. A
    /// column not kept costs nothing, so a caller reducing one metric unpacks only that one.
    pub(super) fn fill(&self, rows: MetricSlices<'_>, first: usize) {
        let n = rows.len();
        let slot = |s: usize| &self.slot(s)[first..first + n];
        let key = |k: u32| f64::from(from_order_key(k));
        let not_key = |k: u32| f64::from(from_order_key(!k));
        // As `Metrics::new`: the extremes are none (NaN) and the span 0 where nothing is seen.
        let visible = slot(METRIC_VISIBLE);
        fn extreme(out: &mut [f64], visible: &[u32], keys: &[u32], value: impl Fn(u32) -> f64) {
            for ((v, &seen), &k) in out.iter_mut().zip(visible).zip(keys) {
                *v = if seen > 0 { value(k) } else { f64::NAN };
            }
        }
        let total_of = |k: usize| self.plans[self.source.plan_index(self.start + first + k)].total();
        if self.exact {
            // As `Metrics::exact`: no samples, and the visible fraction's f32 bits in the visible
            // slot (0 exactly where nothing is seen).
            rows.visible.fill(0);
            rows.total.fill(0);
            for (v, &k) in rows.visible_fraction.iter_mut().zip(visible) {
                *v = f64::from(f32::from_bits(k));
            }
        } else {
            for (v, &k) in rows.visible.iter_mut().zip(visible) {
                *v = u64::from(k);
            }
            for (k, v) in rows.total.iter_mut().enumerate() {
                *v = total_of(k) as u64;
            }
            // As `Metrics::new`: visible over total.
            for (k, (v, &seen)) in rows.visible_fraction.iter_mut().zip(visible).enumerate() {
                let total = total_of(k);
                *v = if total > 0 {
                    f64::from(seen) / total as f64
                } else {
                    0.0
                };
            }
        }
        if !rows.occupied.is_empty() {
            for (v, &k) in rows.occupied.iter_mut().zip(slot(METRIC_OCCUPIED)) {
                *v = u64::from(k);
            }
        }
        if !rows.range_min.is_empty() {
            extreme(rows.range_min, visible, slot(METRIC_RANGE_MIN_NOT), not_key);
        }
        if !rows.range_max.is_empty() {
            extreme(rows.range_max, visible, slot(METRIC_RANGE_MAX), key);
        }
        if !rows.span.is_empty() {
            let (low, high) = (slot(METRIC_RANGE_MIN_NOT), slot(METRIC_RANGE_MAX));
            for (((v, &seen), &l), &h) in rows.span.iter_mut().zip(visible).zip(low).zip(high) {
                *v = if seen > 0 { key(h) - not_key(l) } else { 0.0 };
            }
        }
        if !rows.azimuth_min.is_empty() {
            extreme(rows.azimuth_min, visible, slot(METRIC_AZIMUTH_MIN_NOT), |k| {
                not_key(k).to_degrees()
            });
        }
        if !rows.azimuth_max.is_empty() {
            extreme(rows.azimuth_max, visible, slot(METRIC_AZIMUTH_MAX), |k| {
                key(k).to_degrees()
            });
        }
        let layout = self.layout;
        if !rows.occupied_measure.is_empty() {
            let out = rows.occupied_measure.iter_mut();
            match layout.kind {
                SonarKind::Sss => {
                    for (v, &k) in out.zip(slot(METRIC_OCCUPIED)) {
                        *v = f64::from(k) * layout.range_bin_width;
                    }
                }
                SonarKind::Fls => {
                    for (v, &k) in out.zip(slot(METRIC_OCCUPIED_MEASURE)) {
                        *v = f64::from(f32::from_bits(k));
                    }
                }
            }
        }
        if !rows.projection_area.is_empty() {
            let out = rows.projection_area.iter_mut();
            match layout.area_grid.filter(|_| !self.exact) {
                Some(g) => {
                    for (v, &k) in out.zip(slot(METRIC_PROJECTION_AREA)) {
                        *v = g.area(u64::from(k));
                    }
                }
                None => out.for_each(|v| *v = f64::NAN),
            }
        }
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
        // Exact mode has no projection area, so no grid cells (as `Metrics::exact`).
        let grid = layout.area_grid.filter(|_| !self.exact);
        let cells = self.raw_bits.zip(grid).map(|(b, g)| {
            let words_of = &b[c * words + pixel_words..(c + 1) * words];
            Occupancy::from_words(g.nx, g.ny, words_of.to_vec())
        });
        Projection {
            local: Default::default(),
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

/// Returns the index in its table of pair `k` of a call whose first pair is `first`.
pub(super) fn pair_index(first: u64, k: usize) -> usize {
    usize::try_from(first).expect("pairs are in memory") + k
}

/// Where the poses of a projection come from.
pub(super) enum Source<'a> {
    /// A batch's items, packed by the host.
    Items(&'a PreparedBatch<'a>),
    /// A grid's poses from `first` on (those a call asks for), decoded on the device.
    Grid {
        prepared: &'a PreparedGrid<'a>,
        first: u64,
    },
    /// Pairs from `first` on, their poses composed and packed by the host from the pairs' tables.
    Pairs {
        prepared: &'a PreparedPairs<'a>,
        first: u64,
    },
}

impl Source<'_> {
    pub(super) fn layout(&self) -> &Layout {
        match self {
            Source::Items(p) => &p.layout,
            Source::Grid { prepared, .. } => &prepared.layout,
            Source::Pairs { prepared, .. } => &prepared.layout,
        }
    }

    /// Returns the index in the sweep of the call's first pose (0 for items).
    pub(super) fn first_pose(&self) -> u64 {
        match self {
            Source::Items(_) => 0,
            Source::Grid { first, .. } | Source::Pairs { first, .. } => *first,
        }
    }

    /// Returns sonar 1's half elevation aperture (rad) when the call is solved exactly (it then has
    /// no plans), else `None`.
    pub(super) fn exact_half(&self) -> Option<f64> {
        match self {
            Source::Items(p) => p.is_exact().then(|| p.batch.source.half_elevation()),
            Source::Grid { prepared, .. } => prepared.exact.then(|| prepared.source.half_elevation()),
            Source::Pairs { prepared, .. } => prepared.exact.then(|| prepared.source.half_elevation()),
        }
    }

    pub(super) fn plans(&self) -> &[SamplingPlan] {
        match self {
            Source::Items(p) => &p.plans,
            Source::Grid { prepared, .. } => &prepared.plans,
            Source::Pairs { prepared, .. } => &prepared.plans,
        }
    }

    pub(super) fn plan_index(&self, k: usize) -> usize {
        match self {
            Source::Items(p) => p.plan_index(k),
            Source::Grid { prepared, first, .. } => {
                prepared.plan_of_range[prepared.range_index(first + k as u64)] as usize
            }
            Source::Pairs { prepared, first } => prepared.pose(pair_index(*first, k)).3,
        }
    }

    /// Returns the plans poses `range` use, in increasing order.
    pub(super) fn plans_used(&self, range: std::ops::Range<usize>) -> Vec<usize> {
        if self.exact_half().is_some() {
            return Vec::new();
        }
        let mut used = vec![false; self.plans().len()];
        match self {
            Source::Items(_) | Source::Pairs { .. } => {
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
