//! Summaries of a drawn mask: its bounding box and its run-length encoding.

use serde::Serialize;

use crate::occupancy::{Layout, Occupancy};

/// The extent of a mask in sonar 2: range (m) and azimuth (deg) of its outermost bins' edges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BoundingBox {
    /// Lower edge of the nearest occupied range bin (m).
    pub range_min: f64,
    /// Upper edge of the farthest occupied range bin (m).
    pub range_max: f64,
    /// Lower edge of the leftmost occupied beam (deg); the aperture's edge for an SSS.
    pub azimuth_min: f64,
    /// Upper edge of the rightmost occupied beam (deg).
    pub azimuth_max: f64,
}

/// Returns the bounding box of `occ` (in the order of the sonar's data, as masks are) in
/// `layout`, or `None` when it is empty. A two-sided sidescan's box spans the sides it touches:
/// azimuth from `−A/2` (starboard) or 0 (port only) to 0 (starboard only) or `+A/2`.
#[must_use]
pub fn bounding_box(layout: &Layout, occ: &Occupancy) -> Option<BoundingBox> {
    let mut b: Option<(usize, usize, usize, usize)> = None;
    let data_columns = occ.beams;
    for (row, column) in occ.pixels() {
        let (i, j) = layout.pixel_of_data(row * data_columns + column);
        b = Some(match b {
            None => (i, i, j, j),
            Some((i0, i1, j0, j1)) => (i0.min(i), i1.max(i), j0.min(j), j1.max(j)),
        });
    }
    b.map(|(i0, i1, j0, j1)| BoundingBox {
        range_min: layout.range_edge(i0),
        range_max: layout.range_edge(i1 + 1),
        azimuth_min: layout.beam_edges[j0].to_degrees(),
        azimuth_max: layout.beam_edges[j1 + 1].to_degrees(),
    })
}

/// Returns the set runs of `occ` over its row-major layout as `[start, length]` pairs.
#[must_use]
pub fn run_lengths(occ: &Occupancy) -> Vec<[u64; 2]> {
    let mut runs: Vec<[u64; 2]> = Vec::new();
    for (i, j) in occ.pixels() {
        let k = (i * occ.beams + j) as u64;
        match runs.last_mut() {
            Some(run) if run[0] + run[1] == k => run[1] += 1,
            _ => runs.push([k, 1]),
        }
    }
    runs
}
