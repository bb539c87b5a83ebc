//! The CPU reference: plain f64 loops, written to be obviously right, one module per shader stage
//! (`splat` ↔ `shaders/splat.wgsl`, `reduce` ↔ `shaders/reduce.wgsl`), plus `bounds`, which says
//! how far an f32 implementation may honestly differ (README: How the GPU is checked).

pub mod bounds;
pub mod reduce;
pub mod splat;

use crate::batch::{PreparedBatch, Projection};
use crate::occupancy::{Metrics, Occupancy};

/// Returns the projections of every item of `prepared`, computed in f64 one sample at a time;
/// with `keep_occupancy` each carries its occupancy buffer.
pub fn project(prepared: &PreparedBatch<'_>, keep_occupancy: bool) -> Vec<Projection> {
    let layout = &prepared.layout;
    prepared
        .batch
        .items
        .iter()
        .enumerate()
        .map(|(n, item)| {
            let plan = &prepared.plans[prepared.plan_of[n]];
            let mut occupancy = Occupancy::new(layout.range_bins, layout.beams());
            let splat = splat::splat(
                layout,
                plan,
                prepared.base_azimuth[n],
                item.measurement.range,
                &item.pose,
                &mut occupancy,
            );
            let (occupied, measure) = reduce::reduce(layout, &occupancy);
            Projection {
                metrics: Metrics::new(
                    splat.visible,
                    plan.total() as u64,
                    splat.extremes,
                    occupied,
                    measure,
                ),
                occupancy: keep_occupancy.then_some(occupancy),
            }
        })
        .collect()
}
