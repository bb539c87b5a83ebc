//! Summaries of drawn masks: a mask's bounding box and run-length encoding, and a ping reduced
//! to what a matcher needs first (each mask's pixel count and box, and their union).
//! `mask_reduce` is the CPU twin of `shaders/mask_reduce.wgsl`. The shader reads only the rows
//! of the box that the draw stage kept as it set each span, which is the box this walk finds.

use serde::Serialize;

use crate::occupancy::{Layout, Occupancy};

/// The extent of a mask in sonar 2: range (m) and azimuth (deg) of its outermost bins' edges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BoundingBox {
    /// Lower edge of the nearest occupied range bin (m).
    pub range_min: f64,
    /// Upper edge of the farthest occupied range bin (m).
    pub range_max: f64,
    /// Lower edge of the leftmost occupied beam (deg), or the aperture's edge for an SSS.
    pub azimuth_min: f64,
    /// Upper edge of the rightmost occupied beam (deg).
    pub azimuth_max: f64,
}

impl BoundingBox {
    /// Returns the box of range bins `i0..=i1` and beams `j0..=j1` of `layout` (sonar 2's own
    /// beam order, beam 0 starboard-most).
    #[must_use]
    pub fn of_bins(layout: &Layout, (i0, i1): (usize, usize), (j0, j1): (usize, usize)) -> BoundingBox {
        BoundingBox {
            range_min: layout.range_edge(i0),
            range_max: layout.range_edge(i1 + 1),
            azimuth_min: layout.beam_edges[j0].to_degrees(),
            azimuth_max: layout.beam_edges[j1 + 1].to_degrees(),
        }
    }
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
    b.map(|(i0, i1, j0, j1)| BoundingBox::of_bins(layout, (i0, i1), (j0, j1)))
}

/// One mask reduced: the pixels set, and the range bins and beams of its box (`None` when no
/// pixel is set). Pixel `i · beams + j` is in sonar 2's layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub(crate) struct Reduced {
    pub pixels: u64,
    /// First and last range bin, first and last beam.
    pub bounds: Option<((usize, usize), (usize, usize))>,
}

/// Returns the pixels set in the bitset `words` (`beams` beams a range bin) and their bounds.
/// The CPU twin of `shaders/mask_reduce.wgsl`, with the same walk over each word's rows.
pub(crate) fn mask_reduce(words: &[u32], beams: usize) -> Reduced {
    let mut out = Reduced::default();
    for (w, &word) in words.iter().enumerate() {
        let mut m = word;
        if m == 0 {
            continue;
        }
        out.pixels += u64::from(m.count_ones());
        // Walk the word row by row: the first set pixel's row, that row's bits, their first
        // and last beams. Then go on with the rest of the word.
        while m != 0 {
            let first = w * 32 + m.trailing_zeros() as usize;
            let row = first / beams;
            let next_row = (row + 1) * beams;
            let in_row = if next_row < w * 32 + 32 {
                m & ((1u32 << (next_row - w * 32)) - 1)
            } else {
                m
            };
            let last = w * 32 + 31 - in_row.leading_zeros() as usize;
            let (i, j0, j1) = (row, first - row * beams, last - row * beams);
            out.bounds = Some(match out.bounds {
                None => ((i, i), (j0, j1)),
                Some(((a0, a1), (b0, b1))) => ((a0.min(i), a1.max(i)), (b0.min(j0), b1.max(j1))),
            });
            m &= !in_row;
        }
    }
    out
}

/// A mask reduced to what a matcher looks at first, without its bits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FeatureSummary {
    /// Bins or pixels where the feature can be.
    pub occupied: u64,
    /// Their bounding box, `None` when the feature cannot be seen by sonar 2.
    pub bounding_box: Option<BoundingBox>,
    /// The ball radius used (m), as [`super::Mask::radius`].
    pub radius: f64,
    /// The noise radius (m), 0 without noise.
    pub noise_radius: f64,
    /// The cells the set was cut into.
    pub cells: u64,
}

/// A ping's masks reduced: each feature's summary and the union of their masks. It is what
/// [`super::MaskEngine::summary`] returns, and on a GPU all that is read back.
#[derive(Clone, Debug, PartialEq)]
pub struct PingSummary {
    /// One summary per feature, in order.
    pub features: Vec<FeatureSummary>,
    /// Every bin or pixel any feature may occupy, in the order of the sonar's data.
    pub union: Occupancy,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Sonar;

    /// The word walk finds what a walk over the pixels finds (`bounding_box`, `count`), on
    /// layouts whose rows end inside words (beams 1, 2, 7, 33) and on word boundaries (32, 64).
    #[test]
    fn mask_reduce_agrees_with_the_pixels() {
        // A xorshift: values below `n`.
        let mut seed = 0x2545_f491_u64;
        let mut below = move |n: usize| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            usize::try_from(seed % n as u64).expect("below n")
        };
        for beams in [1usize, 2, 7, 32, 33, 64] {
            for trial in 0..50 {
                let rows = 1 + below(40);
                let mut occ = Occupancy::new(rows, beams);
                let set = if trial == 0 { 0 } else { 1 + below(12) };
                for _ in 0..set {
                    let (i, j) = (below(rows), below(beams));
                    let j1 = (j + below(3)).min(beams - 1);
                    occ.set_span(i, j, j1);
                }
                let got = mask_reduce(&occ.words, beams);
                assert_eq!(got.pixels, occ.count());
                let mut want: Option<((usize, usize), (usize, usize))> = None;
                for (i, j) in occ.pixels() {
                    want = Some(match want {
                        None => ((i, i), (j, j)),
                        Some(((a, b), (c, d))) => ((a.min(i), b.max(i)), (c.min(j), d.max(j))),
                    });
                }
                assert_eq!(got.bounds, want, "beams {beams}, trial {trial}");
            }
        }
        // And in a sonar's units, as `bounding_box` reports them.
        let layout = Layout::of(&Sonar::preset("paper-fls").unwrap());
        let mut occ = Occupancy::new(layout.range_bins, layout.beams());
        occ.set_span(10, 3, 9);
        occ.set_span(12, 1, 2);
        let r = mask_reduce(&occ.words, layout.beams());
        let ((i0, i1), (j0, j1)) = r.bounds.unwrap();
        assert_eq!(
            Some(BoundingBox::of_bins(&layout, (i0, i1), (j0, j1))),
            bounding_box(&layout, &layout.to_data_order(occ))
        );
    }
}
