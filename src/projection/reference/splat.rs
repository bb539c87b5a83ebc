//! The reference's splat stage, written to be obviously right: trigonometry, one sample at a time.
//!
//! Every sample of one pose is placed in sonar 1, moved into sonar 2 (`R p + t`), clipped to its
//! field of view and set in the occupancy buffer. `shaders/splat.wgsl` and its CPU twin
//! `projection::fast` run a faster algorithm, and tests hold them to this one.

use crate::geometry::pose::{RelativePose, cart_to_sph, sph_to_cart};
use crate::metrics::Extremes;
use crate::occupancy::{Layout, Occupancy};
use crate::sampling::SamplingPlan;

/// The result of splatting one pose, besides the occupancy bits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplatResult {
    /// Samples kept by the clip.
    pub visible: u64,
    /// Range and azimuth extremes of the kept samples (m, rad).
    pub extremes: Extremes,
}

/// Splats the samples of `plan` through `pose` into `occupancy`, and returns the visible count and
/// the extremes. The samples are measured at `range`, their azimuths offset by `base_azimuth`. For
/// a layout with an area grid, each visible sample also sets its grid cell (`x = r cos az`, `y = r
/// sin az`) in `cells`.
pub fn splat(
    layout: &Layout,
    plan: &SamplingPlan,
    base_azimuth: f64,
    range: f64,
    pose: &RelativePose,
    occupancy: &mut Occupancy,
    cells: &mut Occupancy,
) -> SplatResult {
    let mut visible = 0;
    let mut extremes = Extremes::default();
    for &el in &plan.elevations {
        for &da in &plan.azimuths {
            let p2 = pose.apply(sph_to_cart(range, base_azimuth + da, el));
            let (r, az, el2) = cart_to_sph(p2);
            if !layout.inside(r, az, el2) {
                continue;
            }
            visible += 1;
            occupancy.set(layout.range_bin(r), layout.beam(az));
            if let Some(grid) = &layout.area_grid {
                let (i, j) = grid.cell_of(r * az.cos(), r * az.sin());
                cells.set(i, j);
            }
            extremes.add(r, az);
        }
    }
    SplatResult { visible, extremes }
}
