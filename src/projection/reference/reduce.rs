//! The reference's reduce stage; its twins are `shaders/reduce.wgsl` and `projection::fast`'s
//! reduce step. One pose's occupancy buffer becomes the occupied count and the occupied measure:
//! bin widths for an SSS, true pixel areas for an FLS (docs/conventions.md). Its projection-area
//! cells become the projection area.

use crate::occupancy::{Layout, Occupancy};

/// Returns `(occupied, occupied_measure)` of `occupancy` drawn in `layout`.
#[must_use]
pub fn reduce(layout: &Layout, occupancy: &Occupancy) -> (u64, f64) {
    let mut occupied = 0;
    let mut measure = 0.0;
    for (i, j) in occupancy.pixels() {
        occupied += 1;
        measure += layout.pixel_measure(i, j);
    }
    (occupied, measure)
}

/// Returns the projection area (m²) of the grid `cells` drawn in `layout`: their count times a
/// cell's area. Returns `None` for a layout without an area grid (an SSS).
#[must_use]
pub fn projection_area(layout: &Layout, cells: &Occupancy) -> Option<f64> {
    layout.area_grid.map(|g| g.area(cells.count()))
}
