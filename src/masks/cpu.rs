//! Drawing a mask on the CPU in f64: the twin of `shaders/mask.wgsl`, with the same cells,
//! blocks and balls. The GPU adds a rounding slack, and decides beams by the side of each beam
//! edge, walking to the edges from a guess the angle makes.

use crate::clip::{MASK_ANGLE_SLACK, MASK_F64_SLACK};
use glam::DVec3;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use crate::geometry::{RelativePose, sph_to_cart};
use crate::occupancy::Occupancy;

use super::plan::{BLOCK, Plan};
use crate::clip::View;

/// One mask drawn on the CPU.
pub(crate) struct Drawn {
    pub occupancy: Occupancy,
    /// Per-pixel counts, when asked for.
    pub counts: Option<Vec<u32>>,
    /// The ball radius used, rounding slack included (m).
    pub radius: f64,
}

/// The cosines and sines of cell-centre angles, kept between masks and pings. A grid of cells
/// depends on its count, not on the feature: `n` cells over an aperture are the same for every
/// feature that needs `n`. So pings after the first mostly find theirs here.
#[derive(Debug, Default)]
pub(crate) struct TrigTables {
    tables: Mutex<HashMap<(u64, u64, usize), Arc<Trig>>>,
}

/// The angles of one axis of cells and their cosines and sines.
#[derive(Debug)]
pub(crate) struct Trig {
    angles: Vec<f64>,
    cos: Vec<f64>,
    sin: Vec<f64>,
}

impl Trig {
    fn of(angles: &[f64]) -> Trig {
        let (cos, sin) = angles.iter().map(|a| (a.cos(), a.sin())).unzip();
        Trig {
            angles: angles.to_vec(),
            cos,
            sin,
        }
    }
}

/// The most angles the tables keep (16 MB). Past it, they start afresh.
const MAX_TABLE_ANGLES: usize = 1 << 20;

impl TrigTables {
    /// Returns the cosines and sines of `angles`, reusing the kept ones when the same angles (every
    /// bit) were asked for before.
    fn of(&self, angles: &[f64]) -> Arc<Trig> {
        if angles.len() < 8 {
            return Arc::new(Trig::of(angles));
        }
        let key = (
            angles[0].to_bits(),
            angles[angles.len() - 1].to_bits(),
            angles.len(),
        );
        let tables = || self.tables.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(t) = tables().get(&key)
            && t.angles == angles
        {
            return Arc::clone(t);
        }
        let t = Arc::new(Trig::of(angles));
        let mut kept = tables();
        if kept.values().map(|t| t.angles.len()).sum::<usize>() + angles.len() > MAX_TABLE_ANGLES {
            kept.clear();
        }
        kept.insert(key, Arc::clone(&t));
        t
    }
}

/// Returns the mask of `plan` under `pose` in `view`, with per-pixel counts when `counts`. The
/// cells' cosines and sines come from `trig`.
pub(crate) fn draw(view: &View, trig: &TrigTables, pose: &RelativePose, plan: &Plan, counts: bool) -> Drawn {
    let Plan {
        cells,
        range: r,
        radius,
        noise_radius,
    } = plan;
    let (r, noise_radius) = (*r, *noise_radius);
    let l = &view.layout;
    // Slack for the f64 rounding of q = R p + t and |q| (MASK_F64_SLACK of the distances).
    let slack = MASK_F64_SLACK * (r + pose.translation.length() + l.range_max) + MASK_F64_SLACK;
    let radius = radius + slack;
    let (na, ne) = (cells.azimuths.len(), cells.elevations.len());
    let mut occ = Occupancy::new(l.range_bins, l.beams());
    let inv_width = 1.0 / l.range_bin_width;
    let mut count = counts.then(|| vec![0u32; l.pixels()]);
    // One cos/sin per azimuth and per elevation, not per cell, kept between masks. These are
    // the same products as `sph_to_cart`, so the same bits.
    let (a, e) = (trig.of(&cells.azimuths), trig.of(&cells.elevations));
    let (ca, sa, ce, se) = (&a.cos, &a.sin, &e.cos, &e.sin);
    let point = |i: usize, j: usize| pose.apply(DVec3::new(r * ce[j] * ca[i], r * ce[j] * sa[i], r * se[j]));
    debug_assert!(
        na == 0
            || ne == 0
            || point(0, 0) == pose.apply(sph_to_cart(r, cells.azimuths[0], cells.elevations[0]))
    );
    for (bi, bj) in view.blocks(pose, cells, r, noise_radius + slack) {
        for i in bi..(bi + BLOCK).min(na) {
            for j in bj..(bj + BLOCK).min(ne) {
                mark(
                    view,
                    inv_width,
                    point(i, j),
                    radius,
                    &mut occ,
                    count.as_deref_mut(),
                );
            }
        }
    }
    Drawn {
        occupancy: occ,
        counts: count,
        radius,
    }
}

/// Marks every bin or pixel that the ball of `radius` around `q` may touch in the field of view.
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "a non-negative bin index, clamped to the table"
)]
fn mark(view: &View, inv_width: f64, q: DVec3, radius: f64, occ: &mut Occupancy, counts: Option<&mut [u32]>) {
    // `sqrt(x² + y²)` is several times faster than `hypot`, and the coordinates are far from
    // overflow. The two differ by a rounding, which the spread's angle slack covers.
    let (d, rho) = (q.length(), (q.x * q.x + q.y * q.y).sqrt());
    if !view.may_meet_at(q, d, rho, radius) {
        return;
    }
    let l = &view.layout;
    let (lo, hi) = ((d - radius).max(l.range_min), (d + radius).min(l.range_max));
    // Bins by multiplying with the width's inverse. That is within a rounding of the division,
    // which the ball's slack covers.
    let bin = |r: f64| {
        let i = (r - l.range_min) * inv_width;
        if i >= 0.0 {
            (i as usize).min(l.range_bins - 1)
        } else {
            0
        }
    };
    let (i0, i1) = (bin(lo), bin(hi));
    let beams = l.beams();
    let mut spans = [(0usize, 0usize); 3];
    let mut n = 0;
    if l.beams() == 1 {
        spans[0] = (0, 0);
        n = 1;
    } else {
        if radius >= rho {
            spans[0] = (0, beams - 1);
            n = 1;
        } else {
            let az = q.y.atan2(q.x);
            // Slack for the rounding of atan2 and asin.
            let spread = (radius / rho).asin() + MASK_ANGLE_SLACK;
            let h = l.half_azimuth;
            // The interval az ± spread, and its parts wrapped past ±π.
            let pi2 = std::f64::consts::TAU;
            for (a, b) in [
                (az - spread, az + spread),
                (az - spread + pi2, az + spread + pi2),
                (az - spread - pi2, az + spread - pi2),
            ] {
                let (a, b) = (a.max(-h), b.min(h));
                if a <= b {
                    spans[n] = (l.beam(a), l.beam(b));
                    n += 1;
                }
            }
        }
    }
    let mut counts = counts;
    for i in i0..=i1 {
        for &(j0, j1) in &spans[..n] {
            occ.set_span(i, j0, j1);
            if let Some(c) = counts.as_deref_mut() {
                for v in &mut c[i * beams + j0..=i * beams + j1] {
                    *v += 1;
                }
            }
        }
    }
}
