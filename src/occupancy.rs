//! Sonar 2's data layout (range bins and beams; docs/conventions.md) and the occupancy bitset
//! drawn in it. [`crate::clip`] decides which bin and beam a point falls in, and whether it is
//! in view.

use crate::error::{Error, Result, finite};
use crate::geometry::{Sonar, SonarKind};
use crate::limits::MAX_AREA_CELLS;

/// The cell size (m) of the paper's projection-area grid: the authors' `area_spacing`.
pub const PAPER_AREA_GRID: f64 = 0.08;

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
    /// The Cartesian grid the projection area is counted in: an FLS only, once a batch sets it
    /// ([`Layout::with_area_grid`]).
    pub area_grid: Option<AreaGrid>,
}

/// The Cartesian grid over an FLS image plane that the paper's projection area is counted in.
///
/// Cells are squares of side `cell` from `(x0, y0)`. Once the elevation is dropped, `x` points
/// forward and `y` to starboard (`x = r cos az`, `y = r sin az`). The projection area is the
/// number of cells holding a visible sample, times `cell²`. The grid is the authors'
/// (`np.arange(x0, x1, cell)` along each axis). For an azimuth aperture `A` up to 180°, `x` runs
/// from `range_min · cos(A/2)` to `range_max`, and `y` from `−range_max · sin(A/2)` to
/// `range_max · sin(A/2)`. Wider apertures cover the full disc (`±range_max` on both axes). A
/// point's cell is `floor((x − x0) / cell)` along each axis, clamped into the grid. Only a point
/// exactly on the far edge needs the clamp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaGrid {
    /// The side of a cell (m).
    pub cell: f64,
    /// The grid's near corner (m).
    pub x0: f64,
    /// The grid's port corner (m).
    pub y0: f64,
    /// Cells along `x`.
    pub nx: usize,
    /// Cells along `y`.
    pub ny: usize,
}

impl AreaGrid {
    /// Returns the grid of side `cell` (m) over the image of an FLS `layout`; `None` for an SSS.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming `area_grid` when `cell` is not finite and positive, or
    /// the grid would have more than [`MAX_AREA_CELLS`] cells.
    pub fn over(layout: &Layout, cell: f64) -> Result<Option<AreaGrid>> {
        finite("area_grid", cell)?;
        if cell <= 0.0 || cell > crate::limits::MAX_AREA_GRID {
            return Err(Error::invalid(
                "area_grid",
                cell,
                format!("must be > 0 m and at most {} m", crate::limits::MAX_AREA_GRID),
            ));
        }
        if layout.kind == SonarKind::Sss {
            return Ok(None);
        }
        let h = layout.half_azimuth;
        let (x0, x1, half_y) = if h <= std::f64::consts::FRAC_PI_2 {
            (
                layout.range_min * h.cos(),
                layout.range_max,
                layout.range_max * h.sin(),
            )
        } else {
            (-layout.range_max, layout.range_max, layout.range_max)
        };
        let count = |lo: f64, hi: f64| ((hi - lo) / cell).ceil().max(1.0);
        let (nx, ny) = (count(x0, x1), count(-half_y, half_y));
        // The GPU computes a cell's index along an axis in f32, exact below 2^24.
        let axis_limit = f64::from(1u32 << 24);
        if nx.max(ny) > axis_limit {
            return Err(Error::invalid(
                "area_grid",
                cell,
                format!(
                    "gives {:.0} cells along one axis of sonar 2's image, more than 2^24",
                    nx.max(ny)
                ),
            ));
        }
        #[expect(clippy::cast_precision_loss, reason = "a limit far below 2^53")]
        if nx * ny > MAX_AREA_CELLS as f64 {
            // The smallest allowed cell, rounded up to two significant digits.
            let least = ((x1 - x0) * 2.0 * half_y / MAX_AREA_CELLS as f64).sqrt() * 1.001;
            let magnitude = least.log10().floor() - 1.0;
            let unit = 10f64.powf(magnitude);
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "a small digit count"
            )]
            let digits = (-magnitude).max(0.0) as usize;
            return Err(Error::invalid(
                "area_grid",
                cell,
                format!(
                    "gives {:.0} cells over sonar 2's image, more than {MAX_AREA_CELLS}: use at least {:.digits$} m",
                    nx * ny,
                    (least / unit).ceil() * unit
                ),
            ));
        }
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "counts checked positive and below MAX_AREA_CELLS"
        )]
        Ok(Some(AreaGrid {
            cell,
            x0,
            y0: -half_y,
            nx: nx as usize,
            ny: ny as usize,
        }))
    }

    /// Returns the number of cells.
    #[must_use]
    pub fn cells(&self) -> usize {
        self.nx * self.ny
    }

    /// Returns the cell `(i along x, j along y)` holding the image point `(x, y)` (m):
    /// `floor((x − x0) / cell)` along each axis, clamped into the grid.
    #[inline]
    #[must_use]
    pub fn cell_of(&self, x: f64, y: f64) -> (usize, usize) {
        // Truncation is floor for the non-negative values `max` leaves (NaN becomes 0).
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "non-negative, saturating, then clamped into 0..n"
        )]
        let index = |v: f64, origin: f64, n: usize| (((v - origin) / self.cell).max(0.0) as usize).min(n - 1);
        (index(x, self.x0, self.nx), index(y, self.y0, self.ny))
    }

    /// Returns the flat index `i · ny + j` of the cell holding the point `(x, y, z)` of sonar 2's
    /// frame at range `r = |(x, y, z)|`, without trigonometry. Its image point is `(x, y)` scaled
    /// to length `r`, which is `(r cos az, r sin az)` up to rounding. On the z axis it is `(r, 0)`,
    /// where `atan2` gives azimuth 0.
    #[inline]
    #[must_use]
    pub fn flat_cell(&self, x: f64, y: f64, r: f64) -> usize {
        let rho2 = x * x + y * y;
        let (ix, iy) = if rho2 > 0.0 {
            let k = r / rho2.sqrt();
            self.cell_of(k * x, k * y)
        } else {
            self.cell_of(r, 0.0)
        };
        ix * self.ny + iy
    }

    /// Returns the area (m²) of `cells` cells.
    #[expect(clippy::cast_precision_loss, reason = "cell counts far below 2^53")]
    #[must_use]
    pub fn area(&self, cells: u64) -> f64 {
        cells as f64 * self.cell * self.cell
    }

    /// Returns an empty bitset of the grid's cells (`nx` rows of `ny`).
    #[must_use]
    pub fn bitset(&self) -> Occupancy {
        Occupancy::new(self.nx, self.ny)
    }
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
            area_grid: None,
        }
    }

    /// Returns the layout with the projection-area grid of side `cell` (m) (an FLS only; see
    /// [`AreaGrid`]).
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming `area_grid`: see [`AreaGrid::over`].
    pub fn with_area_grid(mut self, cell: f64) -> Result<Self> {
        self.area_grid = AreaGrid::over(&self, cell)?;
        Ok(self)
    }

    /// Returns an empty bitset of the projection-area grid's cells (0 × 0 without a grid).
    #[must_use]
    pub fn cell_bitset(&self) -> Occupancy {
        self.area_grid
            .map_or_else(|| Occupancy::new(0, 0), |g| g.bitset())
    }

    /// Returns the number of beams (1 for an SSS, 2 for a two-sided one).
    #[must_use]
    pub fn beams(&self) -> usize {
        self.beam_edges.len() - 1
    }

    /// Returns whether this is a two-sided sidescan's layout: an SSS with a starboard beam 0 and a
    /// port beam 1 ([`Sonar::two_sided`]). Its data is one row of both sides, not
    /// `[range_bin][beam]`.
    #[must_use]
    pub fn two_sided(&self) -> bool {
        self.kind == SonarKind::Sss && self.beams() == 2
    }

    /// Returns the shape of the sonar's data, `(rows, columns)`: `(range_bins, beams)`, or
    /// `(2 × range_bins, 1)` for a two-sided sidescan's row.
    #[must_use]
    pub fn data_shape(&self) -> (usize, usize) {
        if self.two_sided() {
            (2 * self.range_bins, 1)
        } else {
            (self.range_bins, self.beams())
        }
    }

    /// Returns the index in the sonar's data of range bin `i`, beam `j`: `i · beams + j`. For a
    /// two-sided sidescan it is `range_bins − 1 − i` to port (`j = 1`, far to near) and
    /// `range_bins + i` to starboard (`j = 0`, near to far).
    #[must_use]
    pub fn data_index(&self, i: usize, j: usize) -> usize {
        if self.two_sided() {
            if j == 1 {
                self.range_bins - 1 - i
            } else {
                self.range_bins + i
            }
        } else {
            i * self.beams() + j
        }
    }

    /// Returns the range bin and beam `(i, j)` of index `k` of the sonar's data: the inverse of
    /// [`Layout::data_index`].
    #[must_use]
    pub fn pixel_of_data(&self, k: usize) -> (usize, usize) {
        if self.two_sided() {
            if k < self.range_bins {
                (self.range_bins - 1 - k, 1)
            } else {
                (k - self.range_bins, 0)
            }
        } else {
            (k / self.beams(), k % self.beams())
        }
    }

    /// Returns `occ`, drawn `[range_bin][beam]` in this layout, in the order of the sonar's data
    /// ([`Layout::data_shape`], [`Layout::data_index`]). Only a two-sided sidescan changes: its two
    /// columns become one row of `2 × range_bins` bins. Every occupancy and mask the engine hands
    /// out passes through here.
    #[must_use]
    pub fn to_data_order(&self, occ: Occupancy) -> Occupancy {
        if !self.two_sided() {
            return occ;
        }
        let (rows, cols) = self.data_shape();
        let mut out = Occupancy::new(rows, cols);
        for (i, j) in occ.pixels() {
            out.set(self.data_index(i, j), 0);
        }
        out
    }

    /// Returns per-pixel `counts`, `[range_bin][beam]` in this layout, in the order of the
    /// sonar's data (as [`Layout::to_data_order`]).
    #[must_use]
    pub fn counts_to_data_order(&self, counts: Vec<u32>) -> Vec<u32> {
        if !self.two_sided() {
            return counts;
        }
        let mut out = vec![0; counts.len()];
        for (k, &c) in counts.iter().enumerate() {
            let (i, j) = (k / 2, k % 2);
            out[self.data_index(i, j)] = c;
        }
        out
    }

    /// Returns the number of bins (SSS) or pixels (FLS): `range_bins × beams`.
    #[must_use]
    pub fn pixels(&self) -> usize {
        self.range_bins * self.beams()
    }

    /// Returns the measure of pixel `(i, j)`: the bin width (m) for an SSS, and for an FLS the true
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
