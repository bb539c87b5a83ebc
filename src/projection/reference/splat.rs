//! The reference's splat stage, written to be obviously right (trigonometry, one sample at a
//! time): every sample of one pose is placed in sonar 1, moved into sonar 2 (`R p + t`),
//! clipped to its field of view and set in the occupancy buffer. The GPU's `shaders/splat.wgsl`
//! and its CPU twin `projection::fast` run a faster algorithm that tests hold to this one.
//! Arguments: sonar 2's layout, the plan (sample directions), the feature's base azimuth and
//! range, the pose, and the occupancy and projection-area cells it writes; it returns what the
//! shader accumulates in `metrics` (visible count, extremes).

use crate::geometry::pose::{RelativePose, cart_to_sph, sph_to_cart};
use crate::metrics::Extremes;
use crate::occupancy::{Layout, Occupancy};
use crate::sampling::SamplingPlan;

/// What splatting one pose produced besides the occupancy bits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplatResult {
    /// Samples kept by the clip.
    pub visible: u64,
    /// Range and azimuth extremes of the kept samples (m, rad).
    pub extremes: Extremes,
}

/// Splats the samples of `plan` (measured at `range`, azimuths offset by `base_azimuth`) through
/// `pose` into `occupancy` (and, for a layout with an area grid, each visible sample's grid cell
/// at `x = r cos az`, `y = r sin az` into `cells`), and returns the visible count and the
/// extremes.
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
