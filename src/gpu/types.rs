//! GPU-side structs. Keep in sync with `shaders/shared/types.wgsl` (sizes asserted here and
//! checked against naga's layout of the WGSL in `tests/shaders.rs`).

use bytemuck::{Pod, Zeroable};

use crate::occupancy::Layout;
use crate::sonar::SonarKind;
use std::f64::consts::{FRAC_PI_2, PI};

/// Sonar 2's field of view and layout in f32 (WGSL `TargetParams`, a uniform).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TargetParams {
    /// Minimum range (m).
    pub range_min: f32,
    /// Maximum range (m).
    pub range_max: f32,
    /// `range_min²`.
    pub range_min_sq: f32,
    /// `range_max²`.
    pub range_max_sq: f32,
    /// `range_bins / (range_max − range_min)`.
    pub inv_range_bin: f32,
    /// Number of range bins.
    pub range_bins: u32,
    /// Number of beams (1 for an SSS).
    pub beams: u32,
    /// 1 for uniform beams, 0 for explicit edges.
    pub beams_uniform: u32,
    /// `sin(h)`, h half the azimuth aperture; 0 when `h = π`.
    pub sin_half_az: f32,
    /// `cos(h)`; −1 when `h = π`.
    pub cos_half_az: f32,
    /// `sin` of half the elevation aperture; 2 when the aperture is 180°, so nothing is clipped.
    pub sin_half_el: f32,
    /// Half the azimuth aperture (rad).
    pub half_az: f32,
    /// `beams / aperture` (1/rad).
    pub inv_beam_width: f32,
    /// u32 words of one pose's bitset.
    pub words_per_pose: u32,
    /// Poses in this chunk.
    pub pose_count: u32,
    /// 1 when the GPU sums the occupied area (FLS); 0 for an SSS (measure = count × Δ on the CPU).
    pub measure_area: u32,
}
const _: () = assert!(std::mem::size_of::<TargetParams>() == 64);

/// One pose of a chunk (WGSL `Pose`): rows of `M = range · R · Rz(base azimuth)` with the
/// translation in `w`, and the plan `(azimuth offset, n_az, elevation offset, n_el)` into the
/// direction table.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PoseGpu {
    /// Rows of M, translation in the 4th component.
    pub rows: [[f32; 4]; 3],
    /// Offsets and counts of the plan's azimuth and elevation entries.
    pub plan: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<PoseGpu>() == 64);

/// A beam edge (WGSL `BeamEdge`): angle, its cos and sin (rad), width of the beam starting here.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct BeamEdgeGpu {
    /// Angle (rad).
    pub angle: f32,
    /// cos(angle).
    pub cos_angle: f32,
    /// sin(angle).
    pub sin_angle: f32,
    /// Width (rad) of the beam whose lower edge this is; 0 for the last edge.
    pub width: f32,
}
const _: () = assert!(std::mem::size_of::<BeamEdgeGpu>() == 16);

/// u32 slots per pose in the metrics buffer (WGSL `METRIC_STRIDE`).
pub const METRIC_STRIDE: usize = 8;
/// Slot of the visible count.
pub const METRIC_VISIBLE: usize = 0;
/// Slot of the occupied count.
pub const METRIC_OCCUPIED: usize = 1;
/// Slot of NOT the order key of the smallest range.
pub const METRIC_RANGE_MIN_NOT: usize = 2;
/// Slot of the order key of the largest range.
pub const METRIC_RANGE_MAX: usize = 3;
/// Slot of NOT the order key of the smallest azimuth.
pub const METRIC_AZIMUTH_MIN_NOT: usize = 4;
/// Slot of the order key of the largest azimuth.
pub const METRIC_AZIMUTH_MAX: usize = 5;
/// Slot of the f32 bits of the FLS occupied measure.
pub const METRIC_MEASURE: usize = 6;

/// Returns the f32 whose order key (WGSL `order_key`) is `key`.
pub fn from_order_key(key: u32) -> f32 {
    if key & 0x8000_0000 != 0 {
        f32::from_bits(key & 0x7fff_ffff)
    } else {
        f32::from_bits(!key)
    }
}

/// Returns the u32 words of one pose's bitset for `layout`.
pub fn words_per_pose(layout: &Layout) -> usize {
    layout.pixels().div_ceil(32)
}

impl TargetParams {
    /// Returns the parameters of `layout` for a chunk of `pose_count` poses.
    pub fn new(layout: &Layout, pose_count: u32) -> Self {
        let h = layout.half_azimuth;
        let (sin_half_az, cos_half_az) = if h >= PI { (0.0, -1.0) } else { (h.sin(), h.cos()) };
        let sin_half_el = if layout.half_elevation >= FRAC_PI_2 {
            2.0
        } else {
            layout.half_elevation.sin()
        };
        let edges = &layout.beam_edges;
        let beams = layout.beams();
        let uniform_width = 2.0 * h / beams as f64;
        let uniform = edges
            .windows(2)
            .all(|w| ((w[1] - w[0]) - uniform_width).abs() <= 1e-12 * uniform_width);
        TargetParams {
            range_min: layout.range_min as f32,
            range_max: layout.range_max as f32,
            range_min_sq: (layout.range_min * layout.range_min) as f32,
            range_max_sq: (layout.range_max * layout.range_max) as f32,
            inv_range_bin: (1.0 / layout.range_bin_width) as f32,
            range_bins: layout.range_bins as u32,
            beams: beams as u32,
            beams_uniform: u32::from(uniform),
            sin_half_az: sin_half_az as f32,
            cos_half_az: cos_half_az as f32,
            sin_half_el: sin_half_el as f32,
            half_az: h as f32,
            inv_beam_width: (1.0 / uniform_width) as f32,
            words_per_pose: words_per_pose(layout) as u32,
            pose_count,
            measure_area: u32::from(layout.kind == SonarKind::Fls),
        }
    }
}

/// Returns the beam edges of `layout` for the GPU.
pub fn beam_edges(layout: &Layout) -> Vec<BeamEdgeGpu> {
    let e = &layout.beam_edges;
    (0..e.len())
        .map(|k| BeamEdgeGpu {
            angle: e[k] as f32,
            cos_angle: e[k].cos() as f32,
            sin_angle: e[k].sin() as f32,
            width: if k + 1 < e.len() {
                (e[k + 1] - e[k]) as f32
            } else {
                0.0
            },
        })
        .collect()
}

/// Returns the per-row weights `(r_{i+1}² − r_i²)/2` of a layout: a pixel's area is its beam
/// width times its row's weight.
pub fn row_weights(layout: &Layout) -> Vec<f32> {
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
