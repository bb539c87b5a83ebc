//! The CPU reference: plain f64 loops, written to be obviously right. Each module twins a shader
//! stage: `splat` ↔ `shaders/splat.wgsl`, `reduce` ↔ `shaders/reduce.wgsl`. How far an f32
//! implementation may honestly differ from it is [`crate::projection::envelope`].

pub mod reduce;
pub mod splat;

use crate::metrics::Metrics;
use crate::occupancy::Occupancy;
use crate::projection::{Output, PreparedBatch, Projection};
use crate::stream::Stop;

/// Returns the projections of every item of `prepared`, computed in f64 one sample at a time. With
/// [`Output::WithOccupancy`] each carries its occupancy buffer.
#[must_use]
pub fn project(prepared: &PreparedBatch<'_>, output: Output) -> Vec<Projection> {
    project_until(prepared, output, Stop::NEVER).expect("never stopped")
}

/// Returns the projections as [`project`] does, or `None` once `stop` is set (asked before each
/// item: one item of a fine sampling can take a millisecond).
#[must_use]
pub fn project_until(
    prepared: &PreparedBatch<'_>,
    output: Output,
    stop: Stop<'_>,
) -> Option<Vec<Projection>> {
    let keep_occupancy = output == Output::WithOccupancy;
    let layout = &prepared.layout;
    prepared
        .batch
        .items
        .iter()
        .enumerate()
        .map(|(n, item)| {
            if stop.is_set() {
                return None;
            }
            let plan = prepared.plan(n);
            let mut occupancy = Occupancy::new(layout.range_bins, layout.beams());
            let mut cells = layout.cell_bitset();
            let splat = splat::splat(
                layout,
                plan,
                prepared.base_azimuth(n),
                item.measurement.range,
                &item.pose,
                &mut occupancy,
                &mut cells,
            );
            let occupied = reduce::reduce(layout, &occupancy);
            let area = reduce::projection_area(layout, &cells);
            Some(Projection {
                local: Default::default(),
                metrics: Metrics::new(splat.visible, plan.total() as u64, splat.extremes, occupied, area),
                occupancy: keep_occupancy.then(|| layout.to_data_order(occupancy)),
                cells: (keep_occupancy && layout.area_grid.is_some()).then_some(cells),
            })
        })
        .collect()
}
