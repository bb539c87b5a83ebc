//! Metrics as columns: one vector per metric of the metric table, so a sweep's results leave
//! the engine without a per-pose object. Counts are `u64`; reals are `f64`, with NaN where a
//! metric has no value (nothing visible: the extremes; an SSS target: the projection area).

use crate::metrics::{Metric, Metrics};

/// The metrics of many poses, one column per metric (README: Conventions), in pose order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MetricColumns {
    /// Samples kept by the clip.
    pub visible: Vec<u64>,
    /// Samples drawn.
    pub total: Vec<u64>,
    /// Smallest range (m) of a visible sample; NaN when nothing is visible.
    pub range_min: Vec<f64>,
    /// Largest range (m) of a visible sample; NaN when nothing is visible.
    pub range_max: Vec<f64>,
    /// The range span (m), 0 when nothing is visible.
    pub span: Vec<f64>,
    /// Smallest azimuth (deg) of a visible sample; NaN when nothing is visible.
    pub azimuth_min: Vec<f64>,
    /// Largest azimuth (deg) of a visible sample; NaN when nothing is visible.
    pub azimuth_max: Vec<f64>,
    /// Occupied bins (SSS) or pixels (FLS).
    pub occupied: Vec<u64>,
    /// The occupied measure (m or m²).
    pub occupied_measure: Vec<f64>,
    /// The projection area (m², FLS target); NaN for an SSS target.
    pub projection_area: Vec<f64>,
}

/// One metric's column, borrowed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColumnRef<'a> {
    /// A count.
    Count(&'a [u64]),
    /// A real, NaN where the metric has no value.
    Real(&'a [f64]),
}

impl ColumnRef<'_> {
    /// Returns the value of row `k` as a float (`None` for NaN).
    ///
    /// # Panics
    /// When `k` is past the column's end.
    #[must_use]
    #[expect(
        clippy::cast_precision_loss,
        reason = "counts are below 2^53 (MAX_SAMPLES_PER_POSE)"
    )]
    pub fn f64(&self, k: usize) -> Option<f64> {
        match self {
            ColumnRef::Count(c) => Some(c[k] as f64),
            ColumnRef::Real(c) => Some(c[k]).filter(|v| !v.is_nan()),
        }
    }
}

/// The NaN-for-none form of an optional metric.
fn real(v: Option<f64>) -> f64 {
    v.unwrap_or(f64::NAN)
}

/// The optional form of a NaN-for-none value.
fn optional(v: f64) -> Option<f64> {
    Some(v).filter(|v| !v.is_nan())
}

impl MetricColumns {
    /// Returns empty columns with room for `n` rows.
    #[must_use]
    pub fn with_capacity(n: usize) -> Self {
        let mut out = MetricColumns::default();
        out.reserve(n);
        out
    }

    fn reserve(&mut self, n: usize) {
        for c in [&mut self.visible, &mut self.total, &mut self.occupied] {
            c.reserve(n);
        }
        for c in [
            &mut self.range_min,
            &mut self.range_max,
            &mut self.span,
            &mut self.azimuth_min,
            &mut self.azimuth_max,
            &mut self.occupied_measure,
            &mut self.projection_area,
        ] {
            c.reserve(n);
        }
    }

    /// Returns the number of rows.
    #[must_use]
    pub fn len(&self) -> usize {
        self.visible.len()
    }

    /// Returns whether there are no rows.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.visible.is_empty()
    }

    /// Empties every column, keeping its memory (so a caller reusing the columns block after
    /// block allocates once).
    pub fn clear(&mut self) {
        self.resize(0);
    }

    /// Sets the number of rows to `n` (new rows are zero).
    pub(crate) fn resize(&mut self, n: usize) {
        for c in [&mut self.visible, &mut self.total, &mut self.occupied] {
            c.resize(n, 0);
        }
        for c in [
            &mut self.range_min,
            &mut self.range_max,
            &mut self.span,
            &mut self.azimuth_min,
            &mut self.azimuth_max,
            &mut self.occupied_measure,
            &mut self.projection_area,
        ] {
            c.resize(n, 0.0);
        }
    }

    /// Appends the metrics of one pose.
    pub fn push(&mut self, m: &Metrics) {
        let k = self.len();
        self.resize(k + 1);
        self.slices(0..k + 1).set(k, m);
    }

    /// Returns the metrics of row `k`.
    ///
    /// # Panics
    /// When `k` is past the end.
    #[must_use]
    pub fn get(&self, k: usize) -> Metrics {
        Metrics {
            visible: self.visible[k],
            total: self.total[k],
            range_min: optional(self.range_min[k]),
            range_max: optional(self.range_max[k]),
            span: self.span[k],
            azimuth_min: optional(self.azimuth_min[k]),
            azimuth_max: optional(self.azimuth_max[k]),
            occupied: self.occupied[k],
            occupied_measure: self.occupied_measure[k],
            projection_area: optional(self.projection_area[k]),
        }
    }

    /// Returns the column of `metric`.
    #[must_use]
    pub fn column(&self, metric: Metric) -> ColumnRef<'_> {
        match metric {
            Metric::Visible => ColumnRef::Count(&self.visible),
            Metric::Total => ColumnRef::Count(&self.total),
            Metric::RangeMin => ColumnRef::Real(&self.range_min),
            Metric::RangeMax => ColumnRef::Real(&self.range_max),
            Metric::Span => ColumnRef::Real(&self.span),
            Metric::AzimuthMin => ColumnRef::Real(&self.azimuth_min),
            Metric::AzimuthMax => ColumnRef::Real(&self.azimuth_max),
            Metric::Occupied => ColumnRef::Count(&self.occupied),
            Metric::OccupiedMeasure => ColumnRef::Real(&self.occupied_measure),
            Metric::ProjectionArea => ColumnRef::Real(&self.projection_area),
        }
    }

    /// Returns rows `range` of every column, mutably.
    pub(crate) fn slices(&mut self, range: std::ops::Range<usize>) -> MetricSlices<'_> {
        MetricSlices {
            visible: &mut self.visible[range.clone()],
            total: &mut self.total[range.clone()],
            range_min: &mut self.range_min[range.clone()],
            range_max: &mut self.range_max[range.clone()],
            span: &mut self.span[range.clone()],
            azimuth_min: &mut self.azimuth_min[range.clone()],
            azimuth_max: &mut self.azimuth_max[range.clone()],
            occupied: &mut self.occupied[range.clone()],
            occupied_measure: &mut self.occupied_measure[range.clone()],
            projection_area: &mut self.projection_area[range],
        }
    }
}

/// Consecutive rows of [`MetricColumns`], mutably: what one thread of a backend fills.
pub(crate) struct MetricSlices<'a> {
    visible: &'a mut [u64],
    total: &'a mut [u64],
    range_min: &'a mut [f64],
    range_max: &'a mut [f64],
    span: &'a mut [f64],
    azimuth_min: &'a mut [f64],
    azimuth_max: &'a mut [f64],
    occupied: &'a mut [u64],
    occupied_measure: &'a mut [f64],
    projection_area: &'a mut [f64],
}

impl<'a> MetricSlices<'a> {
    /// Returns the number of rows.
    pub(crate) fn len(&self) -> usize {
        self.visible.len()
    }

    /// Writes row `k`.
    #[inline]
    pub(crate) fn set(&mut self, k: usize, m: &Metrics) {
        self.visible[k] = m.visible;
        self.total[k] = m.total;
        self.range_min[k] = real(m.range_min);
        self.range_max[k] = real(m.range_max);
        self.span[k] = m.span;
        self.azimuth_min[k] = real(m.azimuth_min);
        self.azimuth_max[k] = real(m.azimuth_max);
        self.occupied[k] = m.occupied;
        self.occupied_measure[k] = m.occupied_measure;
        self.projection_area[k] = real(m.projection_area);
    }

    /// Returns these rows cut into pieces of `n` (the last shorter).
    pub(crate) fn chunks(self, n: usize) -> Vec<MetricSlices<'a>> {
        let mut out = Vec::with_capacity(self.len().div_ceil(n.max(1)));
        let mut rest = self;
        while rest.len() > n {
            let (head, tail) = rest.split_at(n);
            out.push(head);
            rest = tail;
        }
        if rest.len() > 0 || out.is_empty() {
            out.push(rest);
        }
        out
    }

    fn split_at(self, n: usize) -> (MetricSlices<'a>, MetricSlices<'a>) {
        macro_rules! split {
            ($($f:ident),*) => {{
                $(let $f = self.$f.split_at_mut(n);)*
                (
                    MetricSlices { $($f: $f.0,)* },
                    MetricSlices { $($f: $f.1,)* },
                )
            }};
        }
        split!(
            visible,
            total,
            range_min,
            range_max,
            span,
            azimuth_min,
            azimuth_max,
            occupied,
            occupied_measure,
            projection_area
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::Extremes;

    fn metrics_of(visible: u64, total: u64, extremes: Extremes) -> Metrics {
        Metrics::new(visible, total, extremes, (0, 0.0), None)
    }

    /// A row written and read back is the same metrics, nothing visible included (NaN stands
    /// for none and comes back as none).
    #[test]
    fn rows_round_trip() {
        let mut c = MetricColumns::with_capacity(4);
        let none = metrics_of(0, 10, Extremes::default());
        let some = Metrics {
            projection_area: Some(2.5),
            ..metrics_of(
                3,
                10,
                Extremes {
                    range_min: 1.0,
                    range_max: 2.0,
                    azimuth_min: -0.1,
                    azimuth_max: 0.2,
                },
            )
        };
        c.push(&none);
        c.push(&some);
        assert_eq!(c.len(), 2);
        assert_eq!(c.get(0), none);
        assert_eq!(c.get(1), some);
        assert_eq!(c.column(Metric::RangeMin).f64(0), None);
        assert_eq!(c.column(Metric::Visible).f64(1), Some(3.0));
        let mut cut = c.clone();
        let pieces = cut.slices(0..2).chunks(1);
        assert_eq!(pieces.len(), 2);
        c.clear();
        assert!(c.is_empty());
    }
}
