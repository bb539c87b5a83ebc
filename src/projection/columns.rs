//! Metrics as columns: one vector per metric of the metric table, so a sweep's results leave the
//! engine without a per-pose object. Counts are `u64` and reals `f64`. NaN marks a metric without a
//! value: the extremes when nothing is visible, the projection area for an SSS target. A caller may
//! keep only the metrics it asks for ([`MetricColumns::only`]). The others stay empty, and the
//! backends neither write nor (on the GPU) unpack them.

use crate::metrics::{Metric, Metrics};

/// The metrics of many poses, one column per metric (docs/conventions.md), in pose order. Every
/// column is kept unless the columns were made by [`MetricColumns::only`]. A column not kept stays
/// empty whatever the rows.
#[derive(Clone, Debug, PartialEq)]
pub struct MetricColumns {
    /// Samples kept by the clip.
    pub visible: Vec<u64>,
    /// Samples drawn.
    pub total: Vec<u64>,
    /// The visible share of the back-projected set.
    pub visible_fraction: Vec<f64>,
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
    rows: usize,
    /// Which columns are kept, bit `metric as usize` for each metric.
    kept: u16,
}

const ALL: u16 = (1 << crate::metrics::METRICS.len()) - 1;

fn has(kept: u16, metric: Metric) -> bool {
    kept & 1 << metric as u16 != 0
}

impl Default for MetricColumns {
    /// Returns empty columns, every one kept.
    fn default() -> Self {
        MetricColumns {
            visible: Vec::new(),
            total: Vec::new(),
            visible_fraction: Vec::new(),
            range_min: Vec::new(),
            range_max: Vec::new(),
            span: Vec::new(),
            azimuth_min: Vec::new(),
            azimuth_max: Vec::new(),
            occupied: Vec::new(),
            occupied_measure: Vec::new(),
            projection_area: Vec::new(),
            rows: 0,
            kept: ALL,
        }
    }
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

    /// Returns empty columns that keep only `metrics`; every other column stays empty. A caller
    /// that reduces one metric asks for this, so that the backends write, and the GPU unpacks, only
    /// that one.
    #[must_use]
    pub fn only(metrics: &[Metric]) -> Self {
        MetricColumns {
            kept: metrics.iter().fold(0, |k, &m| k | 1 << m as u16),
            ..MetricColumns::default()
        }
    }

    /// Returns whether the column of `metric` is kept.
    #[must_use]
    pub fn keeps(&self, metric: Metric) -> bool {
        has(self.kept, metric)
    }

    fn reserve(&mut self, n: usize) {
        let kept = self.kept;
        for (m, c) in self.counts_mut() {
            c.reserve(if has(kept, m) { n } else { 0 });
        }
        for (m, c) in self.reals_mut() {
            c.reserve(if has(kept, m) { n } else { 0 });
        }
    }

    fn counts_mut(&mut self) -> [(Metric, &mut Vec<u64>); 3] {
        [
            (Metric::Visible, &mut self.visible),
            (Metric::Total, &mut self.total),
            (Metric::Occupied, &mut self.occupied),
        ]
    }

    fn reals_mut(&mut self) -> [(Metric, &mut Vec<f64>); 8] {
        [
            (Metric::VisibleFraction, &mut self.visible_fraction),
            (Metric::RangeMin, &mut self.range_min),
            (Metric::RangeMax, &mut self.range_max),
            (Metric::Span, &mut self.span),
            (Metric::AzimuthMin, &mut self.azimuth_min),
            (Metric::AzimuthMax, &mut self.azimuth_max),
            (Metric::OccupiedMeasure, &mut self.occupied_measure),
            (Metric::ProjectionArea, &mut self.projection_area),
        ]
    }

    /// Returns the number of rows.
    #[must_use]
    pub fn len(&self) -> usize {
        self.rows
    }

    /// Returns whether there are no rows.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.rows == 0
    }

    /// Empties every column but keeps its memory, so a caller reusing the columns block after block
    /// allocates once.
    pub fn clear(&mut self) {
        self.resize(0);
    }

    /// Sets the number of rows to `n`. New rows of the kept columns are zero.
    pub(crate) fn resize(&mut self, n: usize) {
        let kept = self.kept;
        for (m, c) in self.counts_mut() {
            c.resize(if has(kept, m) { n } else { 0 }, 0);
        }
        for (m, c) in self.reals_mut() {
            c.resize(if has(kept, m) { n } else { 0 }, 0.0);
        }
        self.rows = n;
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
    /// When `k` is past the end, or a column is not kept ([`MetricColumns::only`]).
    #[must_use]
    pub fn get(&self, k: usize) -> Metrics {
        Metrics {
            visible: self.visible[k],
            total: self.total[k],
            visible_fraction: self.visible_fraction[k],
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

    /// Returns the column of `metric`: empty when it is not kept ([`MetricColumns::keeps`]).
    #[must_use]
    pub fn column(&self, metric: Metric) -> ColumnRef<'_> {
        match metric {
            Metric::Visible => ColumnRef::Count(&self.visible),
            Metric::Total => ColumnRef::Count(&self.total),
            Metric::VisibleFraction => ColumnRef::Real(&self.visible_fraction),
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

    /// Returns rows `range` of every kept column, mutably (the others empty).
    ///
    /// # Panics
    /// When `range` is past the end.
    pub(crate) fn slices(&mut self, range: std::ops::Range<usize>) -> MetricSlices<'_> {
        assert!(
            range.start <= range.end && range.end <= self.rows,
            "rows past the end"
        );
        let len = range.len();
        fn rows<'s, T>(c: &'s mut [T], range: &std::ops::Range<usize>) -> &'s mut [T] {
            if c.is_empty() { c } else { &mut c[range.clone()] }
        }
        MetricSlices {
            len,
            visible: rows(&mut self.visible, &range),
            total: rows(&mut self.total, &range),
            visible_fraction: rows(&mut self.visible_fraction, &range),
            range_min: rows(&mut self.range_min, &range),
            range_max: rows(&mut self.range_max, &range),
            span: rows(&mut self.span, &range),
            azimuth_min: rows(&mut self.azimuth_min, &range),
            azimuth_max: rows(&mut self.azimuth_max, &range),
            occupied: rows(&mut self.occupied, &range),
            occupied_measure: rows(&mut self.occupied_measure, &range),
            projection_area: rows(&mut self.projection_area, &range),
        }
    }
}

/// Consecutive rows of [`MetricColumns`], mutably: what one thread of a backend fills. A column not
/// kept is an empty slice, and writes to it are skipped.
pub(crate) struct MetricSlices<'a> {
    len: usize,
    pub(crate) visible: &'a mut [u64],
    pub(crate) total: &'a mut [u64],
    pub(crate) visible_fraction: &'a mut [f64],
    pub(crate) range_min: &'a mut [f64],
    pub(crate) range_max: &'a mut [f64],
    pub(crate) span: &'a mut [f64],
    pub(crate) azimuth_min: &'a mut [f64],
    pub(crate) azimuth_max: &'a mut [f64],
    pub(crate) occupied: &'a mut [u64],
    pub(crate) occupied_measure: &'a mut [f64],
    pub(crate) projection_area: &'a mut [f64],
}

impl<'a> MetricSlices<'a> {
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Writes row `k` of the kept columns.
    #[inline]
    pub(crate) fn set(&mut self, k: usize, m: &Metrics) {
        // A column not kept is empty. A kept one has every row, so an index past it panics.
        fn put<T>(c: &mut [T], k: usize, v: T) {
            if !c.is_empty() {
                c[k] = v;
            }
        }
        put(self.visible, k, m.visible);
        put(self.total, k, m.total);
        put(self.visible_fraction, k, m.visible_fraction);
        put(self.range_min, k, real(m.range_min));
        put(self.range_max, k, real(m.range_max));
        put(self.span, k, m.span);
        put(self.azimuth_min, k, real(m.azimuth_min));
        put(self.azimuth_max, k, real(m.azimuth_max));
        put(self.occupied, k, m.occupied);
        put(self.occupied_measure, k, m.occupied_measure);
        put(self.projection_area, k, real(m.projection_area));
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
                // A column not kept stays empty on both sides.
                $(let $f = if self.$f.is_empty() {
                    self.$f.split_at_mut(0)
                } else {
                    self.$f.split_at_mut(n)
                };)*
                (
                    MetricSlices { len: n, $($f: $f.0,)* },
                    MetricSlices { len: self.len - n, $($f: $f.1,)* },
                )
            }};
        }
        split!(
            visible,
            total,
            visible_fraction,
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

    /// A row written and read back is the same metrics, nothing visible included. NaN stands for
    /// none and comes back as none.
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

    /// Columns kept alone take their rows; the others stay empty through resizing, slicing,
    /// cutting and writing.
    #[test]
    fn columns_not_kept_stay_empty() {
        let mut c = MetricColumns::only(&[Metric::Span, Metric::Total]);
        assert!(c.keeps(Metric::Span) && c.keeps(Metric::Total) && !c.keeps(Metric::Visible));
        c.resize(5);
        assert_eq!((c.len(), c.span.len(), c.total.len()), (5, 5, 5));
        assert!(c.visible.is_empty() && c.range_min.is_empty() && c.projection_area.is_empty());
        let m = metrics_of(
            2,
            7,
            Extremes {
                range_min: 1.0,
                range_max: 3.5,
                azimuth_min: 0.0,
                azimuth_max: 0.1,
            },
        );
        for (p, mut piece) in c.slices(1..5).chunks(3).into_iter().enumerate() {
            assert_eq!(piece.len(), [3, 1][p]);
            for k in 0..piece.len() {
                piece.set(k, &m);
            }
        }
        assert_eq!(c.span, [0.0, 2.5, 2.5, 2.5, 2.5]);
        assert_eq!(c.total, [0, 7, 7, 7, 7]);
        assert!(c.visible.is_empty());
        c.push(&m);
        assert_eq!((c.len(), c.span.len()), (6, 6));
        assert!(c.column(Metric::Visible) == ColumnRef::Count(&[]));
        assert!(MetricColumns::default().keeps(Metric::ProjectionArea));
    }
}
