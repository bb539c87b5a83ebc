//! Drawing a mask on the CPU in f64: the twin of `shaders/mask.wgsl` (same cells, same blocks,
//! same balls; the GPU adds a rounding slack and finds beams without trigonometry).

use crate::clip::{MASK_ANGLE_SLACK, MASK_F64_SLACK};
use glam::DVec3;

use crate::geometry::{RelativePose, sph_to_cart};
use crate::occupancy::Occupancy;

use super::plan::{BLOCK, Plan};
use crate::clip::View;

/// One mask drawn on the CPU.
pub(crate) struct Drawn {
    /// The bins or pixels marked.
    pub occupancy: Occupancy,
    /// Per-pixel counts, when asked for.
    pub counts: Option<Vec<u32>>,
    /// The ball radius used, rounding slack included (m).
    pub radius: f64,
}

/// Returns the mask of `plan` under `pose` in `view`, with per-pixel counts when `counts`.
pub(crate) fn draw(view: &View, pose: &RelativePose, plan: &Plan, counts: bool) -> Drawn {
    let Plan {
        cells,
        range: r,
        radius,
        noise_radius,
    } = plan;
    let (r, noise_radius) = (*r, *noise_radius);
    let l = &view.layout;
    // Slack for the rounding of q = R p + t and |q| in f64 (MASK_F64_SLACK of the distances).
    let slack = MASK_F64_SLACK * (r + pose.translation.length() + l.range_max) + MASK_F64_SLACK;
    let radius = radius + slack;
    let (na, ne) = (cells.azimuths.len(), cells.elevations.len());
    let mut occ = Occupancy::new(l.range_bins, l.beams());
    let mut count = counts.then(|| vec![0u32; l.pixels()]);
    let point = |i: usize, j: usize| pose.apply(sph_to_cart(r, cells.azimuths[i], cells.elevations[j]));
    for (bi, bj) in view.blocks(pose, cells, r, noise_radius + slack) {
        for i in bi..(bi + BLOCK).min(na) {
            for j in bj..(bj + BLOCK).min(ne) {
                mark(view, point(i, j), radius, &mut occ, count.as_deref_mut());
            }
        }
    }
    Drawn {
        occupancy: occ,
        counts: count,
        radius,
    }
}

/// Marks every bin or pixel that the ball of `radius` around `q` may touch in the field of
/// view.
fn mark(view: &View, q: DVec3, radius: f64, occ: &mut Occupancy, counts: Option<&mut [u32]>) {
    if !view.may_meet(q, radius) {
        return;
    }
    let l = &view.layout;
    let d = q.length();
    let (lo, hi) = ((d - radius).max(l.range_min), (d + radius).min(l.range_max));
    let (i0, i1) = (l.range_bin(lo), l.range_bin(hi));
    let beams = l.beams();
    let mut spans = [(0usize, 0usize); 3];
    let mut n = 0;
    if l.beams() == 1 {
        spans[0] = (0, 0);
        n = 1;
    } else {
        let rho = q.x.hypot(q.y);
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
