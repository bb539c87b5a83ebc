//! What a mask is drawn from, shared by the CPU and GPU drawings: the cells that tile the
//! back-projected set and their ball radius (`Plan`). Blocks of cells are tested against
//! sonar 2's field of view (`crate::clip::View`) before their cells are visited.

use crate::clip::View;

use crate::error::{Error, Result};
use crate::geometry::{RelativePose, Sonar, SonarKind, sph_to_cart};
use crate::limits::MAX_CELLS;
use crate::occupancy::Layout;
use crate::sampling::Measurement;

use super::noise::Noise;

/// Cells per block side. Blocks are culled as a whole before their cells are visited. The mask
/// stage's WGSL `BLOCK` is generated from it (`masks/gpu/source.rs`).
pub(crate) const BLOCK: usize = 8;

/// What one mask is drawn from: the set's cells, their ball radius and its noise part.
pub(crate) struct Plan {
    pub cells: Cells,
    /// The set's range in sonar 1 (m).
    pub range: f64,
    /// Cell ball radius plus noise radius (m), without rounding slack.
    pub radius: f64,
    /// The noise radius (m).
    pub noise_radius: f64,
}

/// The cells of one back-projected set: angle grid and the radius of a cell's ball.
pub(crate) struct Cells {
    /// Cell-centre azimuths (rad, absolute in sonar 1).
    pub azimuths: Vec<f64>,
    /// Cell-centre elevations (rad).
    pub elevations: Vec<f64>,
    /// Half the cell's angular sizes `(Δa/2, Δe/2)` (rad).
    pub half: (f64, f64),
}

impl Cells {
    /// Returns the number of cells.
    pub(crate) fn count(&self) -> u64 {
        (self.azimuths.len() * self.elevations.len()) as u64
    }
}

impl View {
    /// Returns the first cells `(azimuth, elevation)` of the `BLOCK × BLOCK` blocks worth visiting:
    /// those whose ball may meet sonar 2's field of view under `pose`. A block's ball is centred on
    /// its middle point, covers all its cells and grows by `extra`.
    pub(crate) fn blocks(
        &self,
        pose: &RelativePose,
        cells: &Cells,
        r: f64,
        extra: f64,
    ) -> Vec<(usize, usize)> {
        let (na, ne) = (cells.azimuths.len(), cells.elevations.len());
        let mut out = Vec::new();
        for bi in (0..na).step_by(BLOCK) {
            for bj in (0..ne).step_by(BLOCK) {
                let (ei, ej) = ((bi + BLOCK).min(na), (bj + BLOCK).min(ne));
                let (a0, a1) = (
                    cells.azimuths[bi] - cells.half.0,
                    cells.azimuths[ei - 1] + cells.half.0,
                );
                let (e0, e1) = (
                    cells.elevations[bj] - cells.half.1,
                    cells.elevations[ej - 1] + cells.half.1,
                );
                let centre = pose.apply(sph_to_cart(r, (a0 + a1) / 2.0, (e0 + e1) / 2.0));
                let radius = r * ((a1 - a0) / 2.0).hypot((e1 - e0) / 2.0) + extra;
                if self.may_meet(centre, radius) {
                    out.push((bi, bj));
                }
            }
        }
        out
    }
}

/// Returns the cells and radius of the mask of `m` (checked against sonar 1, `source`) in
/// sonar 2's `layout` under `noise`.
pub(crate) fn plan(source: &Sonar, layout: &Layout, m: &Measurement, noise: Option<&Noise>) -> Result<Plan> {
    let m = Measurement::of(source, m.range, m.azimuth)?;
    let noise_radius = noise.map_or(0.0, |n| n.radius(m.range, source.kind));
    // Half a range bin, or a quarter of the noise radius when that is larger. A finer cell
    // would not make the widened mask noticeably smaller.
    let h_target = (layout.range_bin_width / 2.0).max(noise_radius / 4.0);
    let cells = cells(source, &m, h_target)?;
    let h = m.range * cells.half.0.hypot(cells.half.1);
    Ok(Plan {
        cells,
        range: m.range,
        radius: h + noise_radius,
        noise_radius,
    })
}

/// Returns the cells of the set measured by `m`, sized so that a cell's ball radius is at
/// most `h` (m).
#[expect(
    clippy::cast_possible_truncation,
    reason = "a saturating float-to-count conversion of a finite, validated extent"
)]
fn cells(source: &Sonar, m: &Measurement, h: f64) -> Result<Cells> {
    let r = m.range;
    let el = 2.0 * source.half_elevation();
    let split = |extent: f64, size: f64| ((extent / size).ceil().max(1.0)) as usize;
    let centres = |lo: f64, extent: f64, n: usize| -> Vec<f64> {
        (0..n)
            .map(|k| lo + extent * (k as f64 + 0.5) / n as f64)
            .collect()
    };
    let (azimuths, ne, half_a) = match source.kind {
        // An arc: one azimuth, the cell's half-size all in elevation.
        SonarKind::Fls => (vec![m.azimuth.to_radians()], split(el * r, 2.0 * h), 0.0),
        // A surface: square cells of diagonal 2h (side h√2).
        SonarKind::Sss => {
            let az = 2.0 * source.half_azimuth();
            let side = h * std::f64::consts::SQRT_2;
            let na = split(az * r, side);
            let total = na as u64 * split(el * r, side) as u64;
            if total > MAX_CELLS {
                return Err(Error::invalid(
                    "mask cells",
                    total,
                    format!("at most {MAX_CELLS}: sonar 2's range bins are too fine for this surface"),
                ));
            }
            (
                centres(-az / 2.0, az, na),
                split(el * r, side),
                az / na as f64 / 2.0,
            )
        }
    };
    if ne as u64 > MAX_CELLS {
        return Err(Error::invalid("mask cells", ne, format!("at most {MAX_CELLS}")));
    }
    Ok(Cells {
        azimuths,
        elevations: centres(-el / 2.0, el, ne),
        half: (half_a, el / ne as f64 / 2.0),
    })
}
