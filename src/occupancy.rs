//! Sonar 2's data layout (range bins, beams: README: Conventions) and the occupancy bitset drawn
//! in it. Which bin and beam a point falls in, and whether it is in view, is [`crate::clip`]'s.

use crate::geometry::{Sonar, SonarKind};

/// The geometry of sonar 2's data: field of view, range bins, beam edges, all in radians/metres.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// FLS (polar image) or SSS (range bins).
    pub kind: SonarKind,
    /// Minimum range (m).
    pub range_min: f64,
    /// Maximum range (m).
    pub range_max: f64,
    /// Number of range bins.
    pub range_bins: usize,
    /// Width of one range bin (m).
    pub range_bin_width: f64,
    /// Beam edges (rad), increasing, `beams + 1` values from `-half_azimuth` to `half_azimuth`.
    pub beam_edges: Vec<f64>,
    /// Half the azimuth aperture (rad).
    pub half_azimuth: f64,
    /// Half the elevation aperture (rad).
    pub half_elevation: f64,
}

impl Layout {
    /// Returns the layout of `sonar`'s data.
    #[must_use]
    pub fn of(sonar: &Sonar) -> Self {
        Layout {
            kind: sonar.kind,
            range_min: sonar.range_min,
            range_max: sonar.range_max,
            range_bins: sonar.range_bins as usize,
            range_bin_width: sonar.range_bin_width(),
            beam_edges: sonar.beam_edges_rad(),
            half_azimuth: sonar.half_azimuth(),
            half_elevation: sonar.half_elevation(),
        }
    }

    /// Returns the number of beams (1 for an SSS).
    #[must_use]
    pub fn beams(&self) -> usize {
        self.beam_edges.len() - 1
    }

    /// Returns the number of bins (SSS) or pixels (FLS): `range_bins × beams`.
    #[must_use]
    pub fn pixels(&self) -> usize {
        self.range_bins * self.beams()
    }

    /// Returns the measure of pixel `(i, j)`: the bin width (m) for an SSS; for an FLS the true
    /// area `Δa_j/2 · (r_{i+1}² − r_i²)` (m², Δa in radians).
    #[must_use]
    pub fn pixel_measure(&self, i: usize, j: usize) -> f64 {
        match self.kind {
            SonarKind::Sss => self.range_bin_width,
            SonarKind::Fls => {
                let (r0, r1) = (self.range_edge(i), self.range_edge(i + 1));
                let da = self.beam_edges[j + 1] - self.beam_edges[j];
                da / 2.0 * (r1 * r1 - r0 * r0)
            }
        }
    }
}

/// A set of occupied bins or pixels, row-major `[range_bin][beam]`, one bit each.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Occupancy {
    /// Number of range bins (rows).
    pub range_bins: usize,
    /// Number of beams (columns; 1 for an SSS).
    pub beams: usize,
    /// The bits, 32 per word, pixel `k = i·beams + j` at bit `k % 32` of word `k / 32`.
    pub words: Vec<u32>,
}

impl Occupancy {
    /// Returns an empty occupancy of `range_bins × beams`.
    #[must_use]
    pub fn new(range_bins: usize, beams: usize) -> Self {
        Occupancy {
            range_bins,
            beams,
            words: vec![0; (range_bins * beams).div_ceil(32)],
        }
    }

    /// Returns the occupancy with the given words (as read back from the GPU).
    #[must_use]
    pub fn from_words(range_bins: usize, beams: usize, words: Vec<u32>) -> Self {
        debug_assert_eq!(words.len(), (range_bins * beams).div_ceil(32));
        Occupancy {
            range_bins,
            beams,
            words,
        }
    }

    /// Sets pixel `(i, j)`.
    pub fn set(&mut self, i: usize, j: usize) {
        let k = i * self.beams + j;
        self.words[k / 32] |= 1 << (k % 32);
    }

    /// Sets pixels `(i, j0..=j1)`, a word at a time.
    pub fn set_span(&mut self, i: usize, j0: usize, j1: usize) {
        let (mut k, end) = (i * self.beams + j0, i * self.beams + j1 + 1);
        while k < end {
            let (w, b) = (k / 32, k % 32);
            let n = (32 - b).min(end - k);
            let bits = if n == 32 { u32::MAX } else { ((1u32 << n) - 1) << b };
            self.words[w] |= bits;
            k += n;
        }
    }

    /// Returns whether pixel `(i, j)` is set.
    #[must_use]
    pub fn get(&self, i: usize, j: usize) -> bool {
        let k = i * self.beams + j;
        self.words[k / 32] >> (k % 32) & 1 == 1
    }

    /// Returns the number of set pixels.
    #[must_use]
    pub fn count(&self) -> u64 {
        self.words.iter().map(|w| u64::from(w.count_ones())).sum()
    }

    /// Returns the set pixels as `(range_bin, beam)` pairs, row-major (empty words skipped).
    pub fn pixels(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.words
            .iter()
            .enumerate()
            .filter(|(_, w)| **w != 0)
            .flat_map(|(k, &w)| (0..32).filter(move |b| w >> b & 1 == 1).map(move |b| 32 * k + b))
            .map(|k| (k / self.beams, k % self.beams))
    }

    /// Returns true when every pixel set here is also set in `other`.
    #[must_use]
    pub fn is_subset_of(&self, other: &Occupancy) -> bool {
        self.words.iter().zip(&other.words).all(|(a, b)| a & !b == 0)
    }

    /// Returns the occupancy as bytes, 0 or 1, row-major, optionally flipped along each axis.
    #[must_use]
    pub fn to_bytes(&self, flip_range: bool, flip_beams: bool) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.range_bins * self.beams);
        for row in 0..self.range_bins {
            let i = if flip_range {
                self.range_bins - 1 - row
            } else {
                row
            };
            for col in 0..self.beams {
                let j = if flip_beams { self.beams - 1 - col } else { col };
                out.push(u8::from(self.get(i, j)));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_areas_sum_to_the_fan() {
        let f = Layout::of(&Sonar::preset("paper-fls").unwrap());
        let total: f64 = (0..f.range_bins)
            .flat_map(|i| (0..f.beams()).map(move |j| (i, j)))
            .map(|(i, j)| f.pixel_measure(i, j))
            .sum();
        let fan = (60f64).to_radians() / 2.0 * (10.0f64.powi(2) - 0.1f64.powi(2));
        assert!((total - fan).abs() < 1e-9 * fan);
    }

    #[test]
    fn occupancy_bits_round_trip() {
        let mut o = Occupancy::new(3, 5);
        o.set(2, 4);
        o.set(0, 1);
        assert!(o.get(2, 4) && o.get(0, 1) && !o.get(1, 1));
        assert_eq!(o.count(), 2);
        assert_eq!(o.pixels().collect::<Vec<_>>(), vec![(0, 1), (2, 4)]);
        let flipped = o.to_bytes(true, true);
        assert_eq!(flipped[0], 1, "pixel (2,4) flipped to (0,0)");
    }
}
