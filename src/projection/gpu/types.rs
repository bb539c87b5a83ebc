//! GPU-side structs, internal to the engine. Keep them in sync with `shaders/shared/types.wgsl`.
//! Their sizes are asserted here, and `source_tests.rs` checks them against naga's layout of the
//! WGSL.
#![expect(
    clippy::cast_possible_truncation,
    reason = "GPU buffers hold f32 and u32: values are rounded to f32 on purpose and counts are bounded by the device limits checked before packing"
)]

use bytemuck::{Pod, Zeroable};

use crate::geometry::SonarKind;
use crate::metrics::Metric;
use crate::occupancy::Layout;

/// Sonar 2's field of view and layout (WGSL `TargetParams`, a uniform). `[f32; 2]` fields are
/// double-f32 `(hi, lo)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct TargetParams {
    /// Minimum range (m).
    pub(crate) range_min: f32,
    /// Maximum range (m).
    pub(crate) range_max: f32,
    /// `range_bins / (range_max − range_min)`.
    pub(crate) inv_range_bin: f32,
    /// Half the azimuth aperture (rad).
    pub(crate) half_az: f32,
    /// `beams / aperture` (1/rad).
    pub(crate) inv_beam_width: f32,
    pub(crate) range_bins: u32,
    /// Number of beams (1 for an SSS).
    pub(crate) beams: u32,
    /// 1 for uniform beams, 0 for explicit edges.
    pub(crate) beams_uniform: u32,
    /// u32 words of one pose's bitset.
    pub(crate) words_per_pose: u32,
    pub(crate) pose_count: u32,
    /// 1 when the GPU sums the occupied area (FLS). 0 for an SSS: measure = count × Δ on the CPU.
    pub(crate) measure_area: u32,
    /// 0 when the elevation aperture is 180° (nothing to clip), else 1.
    pub(crate) clip_elevation: u32,
    pub(crate) range_min_sq: [f32; 2],
    pub(crate) range_max_sq: [f32; 2],
    /// `sin(h)`, h half the azimuth aperture; exactly 0 when `h = π`.
    pub(crate) sin_half_az: [f32; 2],
    /// `cos(h)`; exactly −1 when `h = π`.
    pub(crate) cos_half_az: [f32; 2],
    /// `sin²` of half the elevation aperture.
    pub(crate) sin2_half_el: [f32; 2],
    /// `cos²` of half the elevation aperture.
    pub(crate) cos2_half_el: [f32; 2],
    /// The projection-area grid's corner `x0`, `y0` (m) and `1 / cell` (1/m).
    pub(crate) grid_x0: f32,
    pub(crate) grid_y0: f32,
    pub(crate) inv_cell: f32,
    /// Cells along x and along y.
    pub(crate) grid_nx: u32,
    pub(crate) grid_ny: u32,
    /// Words of a pose's bitset before its cells: the pixels' words.
    pub(crate) pixel_words: u32,
    /// Words of a pose's cells (0 without an area grid: an SSS target).
    pub(crate) cell_words: u32,
    /// Padding to a 16-byte size.
    pub(crate) _pad: u32,
}
const _: () = assert!(std::mem::size_of::<TargetParams>() == 128);

/// One pose of a chunk (WGSL `Pose`). It holds the rows of `M = range · R · Rz(base azimuth)`, with
/// the translation in `w`, as double-f32 (`hi + lo`). It also holds the plan `(azimuth offset,
/// n_az, elevation offset, n_el)` into the direction table.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct PoseGpu {
    /// High parts of the rows of M, translation in the 4th component.
    pub(crate) hi: [[f32; 4]; 3],
    /// Low parts: `value − hi`, rounded to f32.
    pub(crate) lo: [[f32; 4]; 3],
    /// Offsets and counts of the plan's azimuth and elevation entries.
    pub(crate) plan: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<PoseGpu>() == 112);

/// The grid of a chunk's poses as the poses stage decodes it (WGSL `GridParams`,
/// `shaders/poses.wgsl`). It holds the first pose's digits, the axes' lengths, and where each
/// axis's entries start in the grid table, nine each in three `vec4<u32>`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct GridParams {
    /// The digits of the chunk's first pose (mixed radix, the last axis fastest).
    pub(crate) first: [u32; 12],
    /// Values per axis.
    pub(crate) lens: [u32; 12],
    /// Where each axis's entries (value, cos, sin: three an axis value) start in the table.
    pub(crate) offsets: [u32; 12],
    pub(crate) count: u32,
    /// 1 when the second three axes are a placement, 0 for a translation.
    pub(crate) placement: u32,
    /// 1 when sonar 1 is an FLS (the arc is turned by the feature's azimuth).
    pub(crate) fls: u32,
    pub(crate) _pad: u32,
}
const _: () = assert!(std::mem::size_of::<GridParams>() == 160);

/// The summary stage's parameters for one chunk (WGSL `SummaryParams`, `shaders/summary.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct SummaryParams {
    pub(crate) range_bin_width: f64,
    pub(crate) cell: f64,
    pub(crate) degrees: f64,
    pub(crate) histogram_min: f64,
    pub(crate) histogram_max: f64,
    pub(crate) count: u32,
    /// The metric (the order of [`Metric::all`]).
    pub(crate) metric: u32,
    pub(crate) exact: u32,
    pub(crate) sss: u32,
    pub(crate) has_area: u32,
    pub(crate) bins: u32,
    pub(crate) marginals: u32,
    pub(crate) keep: u32,
    pub(crate) first_lo: u32,
    pub(crate) first_hi: u32,
    pub(crate) cells_at: u32,
    pub(crate) _pad: u32,
}
const _: () = assert!(std::mem::size_of::<SummaryParams>() == 88);

/// One set of cells of the summary stage (WGSL `MarginalGpu`): its first cell, its digits, and
/// per digit `[stride low word, stride high word, len, weight]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct MarginalGpu {
    pub(crate) cell_offset: u32,
    pub(crate) axes: u32,
    pub(crate) _pad: [u32; 2],
    pub(crate) digit: [[u32; 4]; 2],
}
const _: () = assert!(std::mem::size_of::<MarginalGpu>() == 48);

/// Returns `v` as double-f32 `(hi, lo)`: `hi = f32(v)`, `lo = f32(v − hi)`.
#[must_use]
pub(crate) fn split(v: f64) -> (f32, f32) {
    let hi = v as f32;
    (hi, (v - f64::from(hi)) as f32)
}

/// A beam edge (WGSL `BeamEdge`): its angle (rad), the width of the beam starting here, and the
/// angle's cos and sin as double-f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct BeamEdgeGpu {
    pub(crate) angle: f32,
    /// Width (rad) of the beam whose lower edge this is. 0 for the last edge.
    pub(crate) width: f32,
    /// cos(angle), double-f32.
    pub(crate) cos_angle: [f32; 2],
    /// sin(angle), double-f32.
    pub(crate) sin_angle: [f32; 2],
    /// Padding to a 16-byte stride.
    pub(crate) _pad: [f32; 2],
}
const _: () = assert!(std::mem::size_of::<BeamEdgeGpu>() == 32);

/// u32 slots per pose in the metrics buffer (WGSL `METRIC_STRIDE`).
pub(crate) const METRIC_STRIDE: usize = 8;
/// Returns the GPU slot the metric table gives `metric`. A compile-time check that it has one.
const fn slot(metric: Metric) -> usize {
    match metric.gpu_slot() {
        Some(s) => s,
        None => panic!("metric without a GPU slot"),
    }
}
/// Slot of the visible count.
pub(crate) const METRIC_VISIBLE: usize = slot(Metric::Visible);
/// Slot of the occupied count.
pub(crate) const METRIC_OCCUPIED: usize = slot(Metric::Occupied);
/// Slot of NOT the order key of the smallest range.
pub(crate) const METRIC_RANGE_MIN_NOT: usize = slot(Metric::RangeMin);
/// Slot of the order key of the largest range.
pub(crate) const METRIC_RANGE_MAX: usize = slot(Metric::RangeMax);
/// Slot of NOT the order key of the smallest azimuth.
pub(crate) const METRIC_AZIMUTH_MIN_NOT: usize = slot(Metric::AzimuthMin);
/// Slot of the order key of the largest azimuth.
pub(crate) const METRIC_AZIMUTH_MAX: usize = slot(Metric::AzimuthMax);
/// Slot of the f32 bits of the FLS occupied measure.
pub(crate) const METRIC_OCCUPIED_MEASURE: usize = slot(Metric::OccupiedMeasure);
/// Slot of the count of projection-area cells.
pub(crate) const METRIC_PROJECTION_AREA: usize = slot(Metric::ProjectionArea);

/// A set of metric slots, bit `s` for slot `s`: which slots of a chunk's metrics are copied back.
/// The metrics buffer is slot-major: one contiguous run of a chunk's poses a slot.
pub(crate) type Slots = u8;

/// Every metric slot.
pub(crate) const ALL_SLOTS: Slots = u8::MAX >> (8 - METRIC_STRIDE);

/// Returns the slots the columns of `metrics` are made of, never empty. Each extreme needs the
/// visible count too, as it is none where nothing is seen. The plan's total needs no slot.
pub(crate) fn slots_of(metrics: impl IntoIterator<Item = Metric>) -> Slots {
    let bit = |s: usize| 1 << s;
    metrics.into_iter().fold(bit(METRIC_VISIBLE), |set, m| {
        set | match m {
            Metric::Visible | Metric::Total | Metric::VisibleFraction => 0,
            Metric::RangeMin => bit(METRIC_RANGE_MIN_NOT),
            Metric::RangeMax => bit(METRIC_RANGE_MAX),
            Metric::Span => bit(METRIC_RANGE_MIN_NOT) | bit(METRIC_RANGE_MAX),
            Metric::AzimuthMin => bit(METRIC_AZIMUTH_MIN_NOT),
            Metric::AzimuthMax => bit(METRIC_AZIMUTH_MAX),
            // An SSS's measure is its count × the bin width. An FLS's is summed on the device.
            Metric::Occupied => bit(METRIC_OCCUPIED),
            Metric::OccupiedMeasure => bit(METRIC_OCCUPIED) | bit(METRIC_OCCUPIED_MEASURE),
            Metric::ProjectionArea => bit(METRIC_PROJECTION_AREA),
        }
    })
}

/// Returns the f32 whose order key (WGSL `order_key`) is `key`.
#[must_use]
pub(crate) fn from_order_key(key: u32) -> f32 {
    if key & 0x8000_0000 != 0 {
        f32::from_bits(key & 0x7fff_ffff)
    } else {
        f32::from_bits(!key)
    }
}

/// Returns the u32 words of one pose's bitset for `layout`: its pixels' words, then its
/// projection-area cells' words (an FLS with an area grid).
#[must_use]
pub(crate) fn words_per_pose(layout: &Layout) -> usize {
    pixel_words(layout) + cell_words(layout)
}

#[must_use]
pub(crate) fn pixel_words(layout: &Layout) -> usize {
    layout.pixels().div_ceil(32)
}

/// Returns the u32 words of one pose's projection-area cells (0 without an area grid).
#[must_use]
pub(crate) fn cell_words(layout: &Layout) -> usize {
    layout.area_grid.map_or(0, |g| g.cells().div_ceil(32))
}

fn df(v: f64) -> [f32; 2] {
    let (hi, lo) = split(v);
    [hi, lo]
}

impl TargetParams {
    #[must_use]
    pub(crate) fn new(layout: &Layout, pose_count: u32) -> Self {
        let (sin_half_az, cos_half_az) = layout.azimuth_clip();
        let elevation = layout.elevation_clip();
        let width = layout.uniform_beam_width();
        let beams = layout.beams();
        TargetParams {
            range_min: layout.range_min as f32,
            range_max: layout.range_max as f32,
            inv_range_bin: (1.0 / layout.range_bin_width) as f32,
            half_az: layout.half_azimuth as f32,
            inv_beam_width: width.map_or(0.0, |w| (1.0 / w) as f32),
            range_bins: layout.range_bins as u32,
            beams: beams as u32,
            beams_uniform: u32::from(width.is_some()),
            words_per_pose: words_per_pose(layout) as u32,
            pose_count,
            measure_area: u32::from(layout.kind == SonarKind::Fls),
            clip_elevation: u32::from(elevation.is_some()),
            range_min_sq: df(layout.range_min * layout.range_min),
            range_max_sq: df(layout.range_max * layout.range_max),
            sin_half_az: df(sin_half_az),
            cos_half_az: df(cos_half_az),
            sin2_half_el: df(elevation.map_or(1.0, |e| e.0)),
            cos2_half_el: df(elevation.map_or(0.0, |e| e.1)),
            grid_x0: layout.area_grid.map_or(0.0, |g| g.x0 as f32),
            grid_y0: layout.area_grid.map_or(0.0, |g| g.y0 as f32),
            inv_cell: layout.area_grid.map_or(0.0, |g| (1.0 / g.cell) as f32),
            grid_nx: layout.area_grid.map_or(0, |g| g.nx as u32),
            grid_ny: layout.area_grid.map_or(0, |g| g.ny as u32),
            pixel_words: pixel_words(layout) as u32,
            cell_words: cell_words(layout) as u32,
            _pad: 0,
        }
    }
}

#[must_use]
pub(crate) fn beam_edges(layout: &Layout) -> Vec<BeamEdgeGpu> {
    let e = &layout.beam_edges;
    (0..e.len())
        .map(|k| BeamEdgeGpu {
            angle: e[k] as f32,
            width: if k + 1 < e.len() {
                (e[k + 1] - e[k]) as f32
            } else {
                0.0
            },
            cos_angle: df(e[k].cos()),
            sin_angle: df(e[k].sin()),
            _pad: [0.0; 2],
        })
        .collect()
}

/// Returns the squared range-bin edges `(range_min + iΔ)²`, `i = 0..=range_bins`, double-f32.
#[must_use]
pub(crate) fn range_edges_sq(layout: &Layout) -> Vec<[f32; 2]> {
    (0..=layout.range_bins)
        .map(|i| df(layout.range_edge(i).powi(2)))
        .collect()
}

/// Returns the per-row weights `(r_{i+1}² − r_i²)/2` of a layout. A pixel's area is its beam width
/// times its row's weight.
#[must_use]
pub(crate) fn row_weights(layout: &Layout) -> Vec<f32> {
    (0..layout.range_bins)
        .map(|i| {
            let (a, b) = (layout.range_edge(i), layout.range_edge(i + 1));
            ((b * b - a * a) / 2.0) as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_keys_sort_like_floats() {
        let xs = [-3.5f32, -1e-30, -0.0, 0.0, 1e-30, 2.0, 7.25];
        let key = |x: f32| {
            let b = x.to_bits();
            if b & 0x8000_0000 != 0 { !b } else { b | 0x8000_0000 }
        };
        for w in xs.windows(2) {
            assert!(key(w[0]) <= key(w[1]));
        }
        for x in xs {
            assert_eq!(from_order_key(key(x)).to_bits(), x.to_bits());
        }
    }
}
