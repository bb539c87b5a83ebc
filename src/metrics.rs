//! The metrics of one projection and the one table that declares them.
//!
//! [`METRICS`] lists every metric once: its name (the CSV column, the JSON key and the sweep
//! file's `metric` value), its unit and figure label for each kind of sonar 2, how it is reduced
//! over the samples, and the GPU metric slot that holds it. Outputs, figures and tests read the
//! table. Adding a metric takes a field of [`Metrics`], a row of the table, and the code that
//! computes it: the reference, the fast CPU path, the GPU stage, and its envelope in
//! [`crate::projection::envelope`] where one applies.

use serde::ser::{Serialize, SerializeStruct, Serializer};

use crate::geometry::SonarKind;

/// One metric of [`Metrics`], in table (and CSV column) order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Metric {
    /// Samples kept by the clip.
    Visible,
    /// Samples drawn.
    Total,
    /// The visible share of the back-projected set.
    VisibleFraction,
    /// Smallest range of a visible sample.
    RangeMin,
    /// Largest range of a visible sample.
    RangeMax,
    /// The paper's range span.
    Span,
    /// Smallest azimuth of a visible sample.
    AzimuthMin,
    /// Largest azimuth of a visible sample.
    AzimuthMax,
    /// Occupied bins or pixels.
    Occupied,
    /// Occupied length (SSS) or area (FLS) at sonar 2's own resolution.
    OccupiedMeasure,
    /// The paper's projection area (FLS target): cells of a Cartesian grid holding a sample.
    ProjectionArea,
}

/// How a metric is reduced over a projection's samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduce {
    /// Counted over the visible samples.
    Count,
    /// Known from the sampling plan, not reduced.
    Plan,
    /// The smallest value over the visible samples (`None` when none is visible).
    Min,
    /// The largest value over the visible samples (`None` when none is visible).
    Max,
    /// Computed from other metrics.
    Derived,
    /// Counted over the cells of a grid the visible samples fall in.
    Cells,
    /// Summed over the occupied bins or pixels (the reduce stage).
    Occupancy,
}

/// One row of the metric table.
#[derive(Clone, Copy, Debug)]
pub struct MetricInfo {
    /// The metric.
    pub metric: Metric,
    /// Its name: CSV column, JSON key, sweep `metric` value.
    pub name: &'static str,
    /// Its unit when sonar 2 is a sidescan (SSS) and when it is an imaging sonar (FLS).
    pub unit: [&'static str; 2],
    /// Its figure axis label for an SSS and an FLS sonar 2. `None` where no figure draws it: a
    /// bookkeeping count, or a metric that sonar 2's kind leaves empty.
    pub label: [Option<&'static str>; 2],
    /// How it is reduced over the samples.
    pub reduce: Reduce,
    /// The GPU metric slot that holds it (WGSL `METRIC_*` in `shaders/shared/types.wgsl`), or
    /// `None` when the CPU computes it after readback. A chunk's metrics buffer holds one u32 a
    /// pose, slot after slot.
    pub gpu_slot: Option<usize>,
}

/// The metric table: every metric once, in output order.
pub const METRICS: [MetricInfo; 11] = [
    MetricInfo {
        metric: Metric::Visible,
        name: "visible",
        unit: ["samples", "samples"],
        label: [Some("visible samples"), Some("visible samples")],
        reduce: Reduce::Count,
        gpu_slot: Some(0),
    },
    MetricInfo {
        metric: Metric::Total,
        name: "total",
        unit: ["samples", "samples"],
        label: [None, None],
        reduce: Reduce::Plan,
        gpu_slot: None,
    },
    MetricInfo {
        metric: Metric::VisibleFraction,
        name: "visible_fraction",
        unit: ["", ""],
        label: [Some("visible fraction"), Some("visible fraction")],
        reduce: Reduce::Derived,
        gpu_slot: None,
    },
    MetricInfo {
        metric: Metric::RangeMin,
        name: "range_min",
        unit: ["m", "m"],
        label: [Some("minimum range (m)"), Some("minimum range (m)")],
        reduce: Reduce::Min,
        gpu_slot: Some(2),
    },
    MetricInfo {
        metric: Metric::RangeMax,
        name: "range_max",
        unit: ["m", "m"],
        label: [Some("maximum range (m)"), Some("maximum range (m)")],
        reduce: Reduce::Max,
        gpu_slot: Some(3),
    },
    MetricInfo {
        metric: Metric::Span,
        name: "span",
        unit: ["m", "m"],
        label: [Some("range span (m)"), Some("range span (m)")],
        reduce: Reduce::Derived,
        gpu_slot: None,
    },
    MetricInfo {
        metric: Metric::AzimuthMin,
        name: "azimuth_min",
        unit: ["deg", "deg"],
        label: [Some("minimum azimuth (deg)"), Some("minimum azimuth (deg)")],
        reduce: Reduce::Min,
        gpu_slot: Some(4),
    },
    MetricInfo {
        metric: Metric::AzimuthMax,
        name: "azimuth_max",
        unit: ["deg", "deg"],
        label: [Some("maximum azimuth (deg)"), Some("maximum azimuth (deg)")],
        reduce: Reduce::Max,
        gpu_slot: Some(5),
    },
    MetricInfo {
        metric: Metric::Occupied,
        name: "occupied",
        unit: ["bins", "pixels"],
        label: [Some("occupied range bins"), Some("occupied pixels")],
        reduce: Reduce::Occupancy,
        gpu_slot: Some(1),
    },
    MetricInfo {
        metric: Metric::OccupiedMeasure,
        name: "occupied_measure",
        unit: ["m", "m²"],
        label: [Some("occupied length (m)"), Some("occupied area (m²)")],
        reduce: Reduce::Occupancy,
        // The FLS area sum. An SSS length is `occupied × bin width`, computed after readback.
        gpu_slot: Some(6),
    },
    MetricInfo {
        metric: Metric::ProjectionArea,
        name: "projection_area",
        unit: ["", "m²"],
        label: [None, Some("projection area (m²)")],
        reduce: Reduce::Cells,
        // The cell count. The area is `count × cell²`, computed after readback.
        gpu_slot: Some(7),
    },
];

/// The metric names in table order: the CSV columns of every output.
pub const METRIC_NAMES: [&str; METRICS.len()] = {
    let mut out = [""; METRICS.len()];
    let mut i = 0;
    while i < METRICS.len() {
        out[i] = METRICS[i].name;
        i += 1;
    }
    out
};

impl Metric {
    /// Returns every metric in table order.
    pub fn all() -> impl Iterator<Item = Metric> {
        METRICS.iter().map(|m| m.metric)
    }

    /// Returns this metric's row of [`METRICS`].
    #[must_use]
    pub const fn info(self) -> &'static MetricInfo {
        &METRICS[self as usize]
    }

    /// Returns this metric's name (CSV column, JSON key, sweep `metric` value).
    #[must_use]
    pub const fn name(self) -> &'static str {
        self.info().name
    }

    /// Returns the metric called `name`, if any.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Metric> {
        Metric::all().find(|m| m.name() == name)
    }

    /// Returns this metric's unit when sonar 2 is of `kind`.
    #[must_use]
    pub const fn unit(self, kind: SonarKind) -> &'static str {
        self.info().unit[kind_index(kind)]
    }

    /// Returns this metric's figure axis label when sonar 2 is of `kind`, or `None` for a metric
    /// no figure draws.
    #[must_use]
    pub const fn label(self, kind: SonarKind) -> Option<&'static str> {
        self.info().label[kind_index(kind)]
    }

    /// Returns this metric's GPU slot (see [`MetricInfo::gpu_slot`]).
    #[must_use]
    pub const fn gpu_slot(self) -> Option<usize> {
        self.info().gpu_slot
    }
}

/// Returns the column of `kind` in the table's per-kind pairs.
const fn kind_index(kind: SonarKind) -> usize {
    match kind {
        SonarKind::Sss => 0,
        SonarKind::Fls => 1,
    }
}

/// One metric's value: a count, a number, or a number that may be absent (`None`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// A count.
    Count(u64),
    /// A number.
    Real(f64),
    /// A number that may be absent: an extreme when nothing is visible, or a metric that sonar
    /// 2's kind leaves empty.
    Optional(Option<f64>),
}

impl Value {
    /// Returns the value as a number, `None` for an absent one.
    #[expect(
        clippy::cast_precision_loss,
        reason = "counts are sample and pixel counts, far below 2^53"
    )]
    #[must_use]
    pub fn as_f64(self) -> Option<f64> {
        match self {
            Value::Count(n) => Some(n as f64),
            Value::Real(v) => Some(v),
            Value::Optional(v) => v,
        }
    }
}

impl Serialize for Value {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        match *self {
            Value::Count(n) => s.serialize_u64(n),
            Value::Real(v) => s.serialize_f64(v),
            Value::Optional(v) => v.serialize(s),
        }
    }
}

/// The metrics of one projection (docs/conventions.md), ranges in metres and azimuths in degrees.
///
/// Serialised (JSON) as an object keyed by the [`METRICS`] names in table order, with `null` for
/// an extreme when nothing is visible. The default is a projection with nothing visible: zeros,
/// and no extremes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Metrics {
    /// Samples kept by the clip.
    pub visible: u64,
    /// Samples drawn; 0 in exact mode, which draws none.
    pub total: u64,
    /// The visible share of the back-projected set, in `[0, 1]`: `visible / total` when sampled
    /// (0 when nothing is drawn), the visible arc length over the arc's length in exact mode.
    pub visible_fraction: f64,
    /// Smallest range (m) of a visible sample in sonar 2; `None` when nothing is visible.
    pub range_min: Option<f64>,
    /// Largest range (m) of a visible sample in sonar 2.
    pub range_max: Option<f64>,
    /// `range_max − range_min` (m), 0 when nothing is visible: the paper's range span.
    pub span: f64,
    /// Smallest azimuth (deg) of a visible sample in sonar 2.
    pub azimuth_min: Option<f64>,
    /// Largest azimuth (deg) of a visible sample in sonar 2.
    pub azimuth_max: Option<f64>,
    /// Number of occupied bins (SSS) or pixels (FLS).
    pub occupied: u64,
    /// The occupied measure at sonar 2's own resolution: occupied bins × bin width (m, SSS), or the
    /// summed true area of occupied pixels (m², FLS).
    pub occupied_measure: f64,
    /// The paper's projection area (m², FLS target): the cells of the layout's
    /// [`AreaGrid`](crate::occupancy::AreaGrid) holding a visible sample, times the cell's area.
    /// `None` for an SSS target.
    pub projection_area: Option<f64>,
}

/// Running extremes of the visible samples' range and azimuth (m, rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extremes {
    /// Smallest range seen (`+inf` when none).
    pub range_min: f64,
    /// Largest range seen (`-inf` when none).
    pub range_max: f64,
    /// Smallest azimuth seen (rad).
    pub azimuth_min: f64,
    /// Largest azimuth seen (rad).
    pub azimuth_max: f64,
}

impl Default for Extremes {
    fn default() -> Self {
        Extremes {
            range_min: f64::INFINITY,
            range_max: f64::NEG_INFINITY,
            azimuth_min: f64::INFINITY,
            azimuth_max: f64::NEG_INFINITY,
        }
    }
}

impl Extremes {
    /// Widens the extremes to include a sample at range `r`, azimuth `az`.
    pub fn add(&mut self, r: f64, az: f64) {
        self.add_range(r);
        self.add_azimuth(az);
    }

    /// Widens the range extremes to include `r`.
    pub fn add_range(&mut self, r: f64) {
        self.range_min = self.range_min.min(r);
        self.range_max = self.range_max.max(r);
    }

    /// Widens the azimuth extremes to include `az`.
    pub fn add_azimuth(&mut self, az: f64) {
        self.azimuth_min = self.azimuth_min.min(az);
        self.azimuth_max = self.azimuth_max.max(az);
    }

    /// Widens the extremes to include `other`'s (a part of the same pose's samples).
    pub fn merge(&mut self, other: &Extremes) {
        self.range_min = self.range_min.min(other.range_min);
        self.range_max = self.range_max.max(other.range_max);
        self.azimuth_min = self.azimuth_min.min(other.azimuth_min);
        self.azimuth_max = self.azimuth_max.max(other.azimuth_max);
    }
}

impl Metrics {
    /// Returns the metrics from the sample counts, the extremes (m, rad), the occupancy summary and
    /// the projection area (m², `None` for an SSS target). With nothing visible, the extremes are
    /// `None` and the span is 0.
    #[must_use]
    pub fn new(
        visible: u64,
        total: u64,
        ex: Extremes,
        occupancy: (u64, f64),
        projection_area: Option<f64>,
    ) -> Self {
        Metrics {
            visible,
            total,
            visible_fraction: if total > 0 {
                visible as f64 / total as f64
            } else {
                0.0
            },
            ..Metrics::seen_as(visible > 0, ex, occupancy, projection_area)
        }
    }

    /// Returns the metrics of an arc solved exactly: no samples (`visible` and `total` 0), the
    /// visible fraction, the extremes (m, rad) and the occupancy summary; extremes are `None`
    /// and the span 0 when nothing is visible. The projection area, a count of grid cells
    /// holding samples, has no exact form: `None`.
    #[must_use]
    pub fn exact(visible_fraction: f64, ex: Extremes, occupancy: (u64, f64)) -> Self {
        Metrics {
            visible_fraction,
            ..Metrics::seen_as(visible_fraction > 0.0, ex, occupancy, None)
        }
    }

    /// Returns the metrics after the sample counts: the extremes (m, rad) when something is
    /// `seen` (else none, and the span 0), the occupancy summary and the projection area.
    fn seen_as(
        seen: bool,
        ex: Extremes,
        (occupied, measure): (u64, f64),
        projection_area: Option<f64>,
    ) -> Self {
        let some = |v: f64| seen.then_some(v);
        Metrics {
            visible: 0,
            total: 0,
            visible_fraction: 0.0,
            range_min: some(ex.range_min),
            range_max: some(ex.range_max),
            span: if seen { ex.range_max - ex.range_min } else { 0.0 },
            azimuth_min: some(ex.azimuth_min.to_degrees()),
            azimuth_max: some(ex.azimuth_max.to_degrees()),
            occupied,
            occupied_measure: measure,
            projection_area,
        }
    }
}

impl Metrics {
    /// Returns the value of `metric`.
    #[must_use]
    pub fn get(&self, metric: Metric) -> Value {
        match metric {
            Metric::Visible => Value::Count(self.visible),
            Metric::Total => Value::Count(self.total),
            Metric::VisibleFraction => Value::Real(self.visible_fraction),
            Metric::RangeMin => Value::Optional(self.range_min),
            Metric::RangeMax => Value::Optional(self.range_max),
            Metric::Span => Value::Real(self.span),
            Metric::AzimuthMin => Value::Optional(self.azimuth_min),
            Metric::AzimuthMax => Value::Optional(self.azimuth_max),
            Metric::Occupied => Value::Count(self.occupied),
            Metric::OccupiedMeasure => Value::Real(self.occupied_measure),
            Metric::ProjectionArea => Value::Optional(self.projection_area),
        }
    }
}

impl Serialize for Metrics {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        let mut out = s.serialize_struct("Metrics", METRICS.len())?;
        for info in &METRICS {
            out.serialize_field(info.name, &self.get(info.metric))?;
        }
        out.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_in_enum_order_with_distinct_names_and_slots() {
        for (i, info) in METRICS.iter().enumerate() {
            assert_eq!(info.metric as usize, i, "{}", info.name);
            assert_eq!(Metric::from_name(info.name), Some(info.metric));
        }
        let mut names: Vec<_> = METRICS.iter().map(|m| m.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), METRICS.len());
        let mut slots: Vec<_> = METRICS.iter().filter_map(|m| m.gpu_slot).collect();
        slots.sort_unstable();
        slots.dedup();
        assert_eq!(
            slots.len(),
            METRICS.iter().filter(|m| m.gpu_slot.is_some()).count()
        );
    }
}
