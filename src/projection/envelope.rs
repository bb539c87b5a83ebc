//! How far the GPU may honestly differ from the f64 reference (docs/gpu.md).
//!
//! 1. Each sample gets a range tolerance of [`RELATIVE_TOLERANCE`] × its range in sonar 2. Add
//!    [`INPUT_TOLERANCE`] × (`range + |t|`), since the pose and directions reach the GPU as f32
//!    hi + lo pairs. A GPU deciding in double-f32 uses [`DOUBLE_F32_TOLERANCE`] instead.
//! 2. The matching azimuth interval divides it by the distance from sonar 2's z axis, and the
//!    elevation interval by the range. An azimuth interval reaching ±π wraps: such a sample, near a
//!    full circle's seam or the z axis, may be reported anywhere from −π to π.
//! 3. The GPU transforms and decides in f64 (or double-f32), far inside this. It reports ranges and
//!    azimuths rounded to f32 (1e-7 relative).
//! 4. A sample whose intervals straddle a clip bound or a bin edge may land either way. Every other
//!    sample must land exactly where the reference puts it.
//!
//! For one pose, this module returns the *certain* occupancy (pixels set by samples far from every
//! edge), the *possible* occupancy (every pixel a sample could reach within its tolerance), and
//! matching intervals for every metric. A correct GPU result lies inside all of them.

use crate::geometry::pose::{RelativePose, cart_to_sph, sph_to_cart};
use crate::gpu::Precision;
use crate::occupancy::{Layout, Occupancy};
use crate::sampling::SamplingPlan;
use std::f64::consts::{FRAC_PI_2, PI};

pub use crate::clip::{CELL_SLACK, DOUBLE_F32_TOLERANCE, INPUT_TOLERANCE, RELATIVE_TOLERANCE};

/// Returns the input tolerance ([`INPUT_TOLERANCE`] or [`DOUBLE_F32_TOLERANCE`]) of results
/// decided at `precision`.
#[must_use]
pub fn input_tolerance(precision: Precision) -> f64 {
    match precision {
        Precision::F64 => INPUT_TOLERANCE,
        Precision::DoubleF32 => DOUBLE_F32_TOLERANCE,
    }
}

/// The envelope a correct f32 projection of one pose lies in.
#[derive(Clone, Debug)]
pub struct Bounds {
    /// Samples certainly visible (lower bound of `visible`).
    pub visible_min: u64,
    /// Samples possibly visible (upper bound of `visible`).
    pub visible_max: u64,
    /// Samples within tolerance of a clip bound or bin edge.
    pub near_edge: u64,
    /// Pixels set by samples far from every edge: a correct result sets all of them. In the order
    /// of the sonar's data, as the backends' occupancy.
    pub certain: Occupancy,
    /// Pixels any sample could reach: a correct result sets none outside.
    pub possible: Occupancy,
    /// Interval of the smallest visible range (m).
    pub range_min: (f64, f64),
    /// Interval of the largest visible range (m).
    pub range_max: (f64, f64),
    /// Interval of the smallest visible azimuth (deg).
    pub azimuth_min: (f64, f64),
    /// Interval of the largest visible azimuth (deg).
    pub azimuth_max: (f64, f64),
    /// Projection-area cells set by samples far from every cell edge and clip bound: a correct
    /// result counts at least these. Empty without an area grid.
    pub cells_certain: Occupancy,
    /// Projection-area cells any sample could reach: a correct result counts no more.
    pub cells_possible: Occupancy,
}

/// Returns the envelope of one pose for results decided in f64 (the CPU paths, a GPU with f64). See
/// the module documentation.
#[must_use]
pub fn bounds(
    layout: &Layout,
    plan: &SamplingPlan,
    base_azimuth: f64,
    range: f64,
    pose: &RelativePose,
) -> Bounds {
    bounds_with(layout, plan, base_azimuth, range, pose, INPUT_TOLERANCE)
}

/// Returns the envelope of one pose with `input_tolerance` (relative to `range + |t|`) in place of
/// [`INPUT_TOLERANCE`]. [`input_tolerance`] gives it for a GPU's precision.
#[must_use]
pub fn bounds_with(
    layout: &Layout,
    plan: &SamplingPlan,
    base_azimuth: f64,
    range: f64,
    pose: &RelativePose,
    input_tolerance: f64,
) -> Bounds {
    let mut b = Bounds {
        visible_min: 0,
        visible_max: 0,
        near_edge: 0,
        certain: Occupancy::new(layout.range_bins, layout.beams()),
        possible: Occupancy::new(layout.range_bins, layout.beams()),
        range_min: (f64::INFINITY, f64::INFINITY),
        range_max: (f64::NEG_INFINITY, f64::NEG_INFINITY),
        azimuth_min: (f64::INFINITY, f64::INFINITY),
        azimuth_max: (f64::NEG_INFINITY, f64::NEG_INFINITY),
        cells_certain: layout.cell_bitset(),
        cells_possible: layout.cell_bitset(),
    };
    let input_tol = input_tolerance * (range + pose.translation.length());
    let full_azimuth = layout.half_azimuth >= PI;
    let full_elevation = layout.half_elevation >= FRAC_PI_2;
    for &el in &plan.elevations {
        for &da in &plan.azimuths {
            let p2 = pose.apply(sph_to_cart(range, base_azimuth + da, el));
            let (r, az, el2) = cart_to_sph(p2);
            let tol = RELATIVE_TOLERANCE * r + input_tol;
            let d_el = if r > 0.0 { tol / r } else { PI };
            let rho = r * el2.cos();
            let d_az = if rho > tol { (tol / rho).min(PI) } else { PI };
            let (r_lo, r_hi) = (r - tol, r + tol);
            let az_ok_all = full_azimuth || az.abs() + d_az <= layout.half_azimuth;
            let az_ok_any = full_azimuth || az.abs() - d_az <= layout.half_azimuth;
            let el_ok_all = full_elevation || el2.abs() + d_el <= layout.half_elevation;
            let el_ok_any = full_elevation || el2.abs() - d_el <= layout.half_elevation;
            let certainly_in =
                r_lo > 0.0 && r_lo >= layout.range_min && r_hi <= layout.range_max && az_ok_all && el_ok_all;
            let possibly_in = r_hi >= layout.range_min && r_lo <= layout.range_max && az_ok_any && el_ok_any;
            if !possibly_in {
                continue;
            }
            let bins =
                layout.range_bin(r_lo.max(layout.range_min))..=layout.range_bin(r_hi.min(layout.range_max));
            let beams = candidate_beams(layout, az, d_az);
            // Reported azimuths lie in [−π, π]. An interval reaching ±π wraps (a sample near the
            // seam of a full circle, or near the z axis). For the extremes, such a sample may be
            // reported anywhere from −π to π, within its tolerance, which covers an f32 π.
            let (az_lo, az_hi) = if az - d_az <= -PI || az + d_az >= PI {
                (-PI - d_az, PI + d_az)
            } else {
                (az - d_az, az + d_az)
            };
            if certainly_in {
                b.visible_min += 1;
                b.range_min.1 = b.range_min.1.min(r_hi);
                b.range_max.0 = b.range_max.0.max(r_lo);
                b.azimuth_min.1 = b.azimuth_min.1.min(az_hi);
                b.azimuth_max.0 = b.azimuth_max.0.max(az_lo);
            }
            b.visible_max += 1;
            b.range_min.0 = b.range_min.0.min(r_lo);
            b.range_max.1 = b.range_max.1.max(r_hi);
            b.azimuth_min.0 = b.azimuth_min.0.min(az_lo);
            b.azimuth_max.1 = b.azimuth_max.1.max(az_hi);
            let single = bins.start() == bins.end() && beams.len() == 1;
            if certainly_in && single {
                b.certain.set(*bins.start(), beams[0]);
            } else {
                b.near_edge += 1;
            }
            for i in bins {
                for &j in &beams {
                    b.possible.set(i, j);
                }
            }
            if let Some(grid) = &layout.area_grid {
                // The image point r (cos az, sin az) moves by at most tol along the range and r ·
                // d_az across it, plus the GPU's f32 cell arithmetic (CELL_SLACK).
                let e = tol + r * d_az + CELL_SLACK * layout.range_max;
                let (x, y) = (r * az.cos(), r * az.sin());
                let (i0, j0) = grid.cell_of(x - e, y - e);
                let (i1, j1) = grid.cell_of(x + e, y + e);
                if certainly_in && i0 == i1 && j0 == j1 {
                    b.cells_certain.set(i0, j0);
                }
                for i in i0..=i1 {
                    for j in j0..=j1 {
                        b.cells_possible.set(i, j);
                    }
                }
            }
        }
    }
    for v in [&mut b.azimuth_min, &mut b.azimuth_max] {
        *v = (v.0.to_degrees(), v.1.to_degrees());
    }
    // In the order of the sonar's data, as every backend hands its occupancy out.
    Bounds {
        certain: layout.to_data_order(b.certain),
        possible: layout.to_data_order(b.possible),
        ..b
    }
}

/// Returns the beams a sample at azimuth `az` ± `d_az` (rad) can fall in. It wraps around ±π when
/// the aperture is the full circle.
fn candidate_beams(layout: &Layout, az: f64, d_az: f64) -> Vec<usize> {
    let h = layout.half_azimuth;
    let span = |lo: f64, hi: f64| -> Vec<usize> {
        let (lo, hi) = (lo.max(-h), hi.min(h));
        if lo > hi {
            return Vec::new();
        }
        (layout.beam(lo)..=layout.beam(hi)).collect()
    };
    if d_az >= PI {
        return (0..layout.beams()).collect();
    }
    let (lo, hi) = (az - d_az, az + d_az);
    let mut beams = span(lo, hi);
    if h >= PI {
        if lo < -PI {
            beams.extend(span(lo + 2.0 * PI, PI));
        }
        if hi > PI {
            beams.extend(span(-PI, hi - 2.0 * PI));
        }
        beams.sort_unstable();
        beams.dedup();
    }
    beams
}

impl Bounds {
    /// Returns the interval `(certain, possible)` of the occupied measure under `layout`.
    #[must_use]
    pub fn measure(&self, layout: &Layout) -> (f64, f64) {
        let sum = |o: &Occupancy| o.pixels().map(|(i, j)| layout.pixel_measure(i, j)).sum();
        (sum(&self.certain), sum(&self.possible))
    }

    /// Returns the interval `(certain, possible)` of the projection area (m²) under `layout`, or
    /// `None` without an area grid.
    #[must_use]
    pub fn projection_area(&self, layout: &Layout) -> Option<(f64, f64)> {
        let grid = layout.area_grid?;
        Some((
            grid.area(self.cells_certain.count()),
            grid.area(self.cells_possible.count()),
        ))
    }
}
