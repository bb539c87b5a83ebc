//! One thread's working state (occupancy buffer, its summary, the lanes of the block being drawn),
//! and the reduce stage over it: the fast path's twin of `shaders/reduce.wgsl`.

use glam::DMat3;

use super::Geometry;
use super::lanes::{Lanes, RunLanes, Running};
use crate::geometry::sonar::SonarKind;
use crate::occupancy::Occupancy;

/// A visible sample of the pose being drawn, for the exact azimuth extremes: its `x`, `y` and
/// azimuth key (see [`Lanes::key`]).
#[derive(Clone, Copy, Default)]
pub(super) struct Seen {
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) key: f64,
}

/// One thread's occupancy buffer and a summary of it: one bit per occupancy word, set when the word
/// is. So counting, summing and clearing visit the touched words only, in row-major order, without
/// sorting.
pub(super) struct Scratch {
    pub(super) occ: Occupancy,
    pub(super) summary: Vec<u64>,
    /// The visible samples of the pose being drawn, with as many slots as the longest plan drawn so
    /// far has samples.
    pub(super) seen: Vec<Seen>,
    /// The block being drawn.
    pub(super) lanes: Box<Lanes>,
    pub(super) running: Box<Running>,
    /// The blocks of a pose drawn by runs.
    pub(super) runs: RunLanes,
    /// The bins `lo..=hi` a pose drawn as one run covers, not yet set in `occ`. They are counted
    /// without touching it unless the occupancy is kept.
    pub(super) span: Option<(usize, usize)>,
    /// The last base azimuth's bits and its rotation `Rz`. Neighbouring items mostly share it.
    pub(super) rz: Option<(u64, DMat3)>,
    /// The projection-area cells of the pose being drawn (an FLS target), and their summary.
    pub(super) cells: Occupancy,
    pub(super) cell_summary: Vec<u64>,
}

impl Scratch {
    pub(super) fn new(layout: &crate::occupancy::Layout) -> Self {
        let occ = Occupancy::new(layout.range_bins, layout.beams());
        let summary = vec![0; occ.words.len().div_ceil(64)];
        let cells = layout.cell_bitset();
        let cell_summary = vec![0; cells.words.len().div_ceil(64)];
        Scratch {
            cells,
            cell_summary,
            occ,
            summary,
            seen: Vec::new(),
            lanes: Box::default(),
            running: Box::default(),
            runs: RunLanes::default(),
            span: None,
            rz: None,
        }
    }

    /// Sets the bins of a pose drawn as one run into the occupancy buffer, so that the next tile of
    /// the same pose adds to them.
    pub(super) fn settle_span(&mut self) {
        if let Some((lo, hi)) = self.span.take() {
            set_span(&mut self.occ, &mut self.summary, lo, hi);
        }
    }

    /// Returns `Rz(azimuth)`, computed only when the azimuth differs from the last one's bits.
    #[inline]
    pub(super) fn rotation_z(&mut self, azimuth: f64) -> DMat3 {
        match self.rz {
            Some((bits, rz)) if bits == azimuth.to_bits() => rz,
            _ => {
                let rz = DMat3::from_rotation_z(azimuth);
                self.rz = Some((azimuth.to_bits(), rz));
                rz
            }
        }
    }

    /// Returns `(occupied, occupied_measure)`, and the occupancy when asked for, leaving the buffer
    /// empty. This is the reduce shader's work. It runs over the touched words in row-major order,
    /// so the area sums in the order of the plain loop.
    #[inline]
    pub(super) fn reduce(&mut self, geo: &Geometry<'_>, keep: bool) -> (u64, f64, Option<Occupancy>) {
        let layout = geo.layout;
        if let Some((lo, hi)) = self.span.take() {
            if keep {
                set_span(&mut self.occ, &mut self.summary, lo, hi);
            } else {
                let occupied = (hi - lo + 1) as u64;
                return (occupied, occupied as f64 * layout.range_bin_width, None);
            }
        }
        let beams = layout.beams();
        let kept = keep.then(|| self.occ.clone());
        let (mut occupied, mut area) = (0, 0.0);
        for (s, summary) in self.summary.iter_mut().enumerate() {
            let mut touched = std::mem::take(summary);
            while touched != 0 {
                let w = 64 * s + touched.trailing_zeros() as usize;
                touched &= touched - 1;
                let mut bits = std::mem::take(&mut self.occ.words[w]);
                occupied += u64::from(bits.count_ones());
                if layout.kind == SonarKind::Fls {
                    // One division per word: pixels follow each other along the rows.
                    let k0 = 32 * w;
                    let (mut i, mut row_start) = (k0 / beams, k0 / beams * beams);
                    while bits != 0 {
                        let k = k0 + bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        while k >= row_start + beams {
                            i += 1;
                            row_start += beams;
                        }
                        area += geo.half_beam_widths[k - row_start] * geo.row_areas[i];
                    }
                }
            }
        }
        let measure = match layout.kind {
            SonarKind::Sss => occupied as f64 * layout.range_bin_width,
            SonarKind::Fls => area,
        };
        (occupied, measure, kept)
    }
}

impl Scratch {
    /// Returns the projection area (m²) of the cells drawn, and the cells when asked for, leaving
    /// the cells empty. It counts over the touched words. `None` without an area grid (an SSS
    /// target).
    #[inline]
    pub(super) fn reduce_cells(
        &mut self,
        geo: &Geometry<'_>,
        keep: bool,
    ) -> (Option<f64>, Option<Occupancy>) {
        let Some(grid) = geo.layout.area_grid else {
            return (None, None);
        };
        let kept = keep.then(|| self.cells.clone());
        let mut count = 0;
        for (s, summary) in self.cell_summary.iter_mut().enumerate() {
            let mut touched = std::mem::take(summary);
            while touched != 0 {
                let w = 64 * s + touched.trailing_zeros() as usize;
                touched &= touched - 1;
                count += u64::from(std::mem::take(&mut self.cells.words[w]).count_ones());
            }
        }
        (Some(grid.area(count)), kept)
    }
}

/// Sets the bits of pixels `lo..=hi` in `occ`, marking their words in `summary`.
#[inline(always)]
pub(super) fn set_span(occ: &mut Occupancy, summary: &mut [u64], lo: usize, hi: usize) {
    for w in lo / 32..=hi / 32 {
        let from = if w == lo / 32 { lo % 32 } else { 0 };
        let to = if w == hi / 32 { hi % 32 } else { 31 };
        set(occ, summary, w, (u32::MAX >> (31 - to)) & (u32::MAX << from));
    }
}

/// Sets `bits` in word `w` of `occ`, and marks the word in `summary` when any bit is set.
#[inline(always)]
pub(super) fn set(occ: &mut Occupancy, summary: &mut [u64], w: usize, bits: u32) {
    if bits != 0 {
        occ.words[w] |= bits;
        summary[w / 64] |= 1 << (w % 64);
    }
}
