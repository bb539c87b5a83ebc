//! The fast CPU path: the GPU's algorithm (`shaders/splat.wgsl`, `shaders/reduce.wgsl`) in f64
//! on every core (rayon), so a machine without a GPU is still fast. Unit directions are computed
//! once per plan, a sample costs `M u + t` and trigonometry-free clip and bin decisions; only
//! visible samples take a square root and an `atan2`. The reference (`cpu`) stays the checker:
//! `tests/agreement.rs` holds this path to the same envelope as the GPU.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::batch::{PreparedBatch, Projection};
use crate::occupancy::{Extremes, Layout, Metrics, Occupancy};
use crate::sonar::SonarKind;

/// Sonar 2's field of view and layout as the decisions use them (the f64 twin of the GPU's
/// `TargetParams`).
struct Geometry<'a> {
    layout: &'a Layout,
    range_min_sq: f64,
    range_max_sq: f64,
    sin_half_az: f64,
    cos_half_az: f64,
    clip_elevation: bool,
    sin2_half_el: f64,
    cos2_half_el: f64,
    /// `(range_min + iΔ)²`, `i = 0..=range_bins`.
    range_edges_sq: Vec<f64>,
    /// `(cos, sin)` of each beam edge.
    beam_edges_cs: Vec<(f64, f64)>,
    /// `beams / aperture` when the beams are uniform.
    inv_beam_width: Option<f64>,
}

impl<'a> Geometry<'a> {
    fn new(layout: &'a Layout) -> Self {
        let (sin_half_az, cos_half_az) = layout.azimuth_clip();
        let elevation = layout.elevation_clip();
        Geometry {
            layout,
            range_min_sq: layout.range_min * layout.range_min,
            range_max_sq: layout.range_max * layout.range_max,
            sin_half_az,
            cos_half_az,
            clip_elevation: elevation.is_some(),
            sin2_half_el: elevation.map_or(1.0, |e| e.0),
            cos2_half_el: elevation.map_or(0.0, |e| e.1),
            range_edges_sq: layout.range_edges_sq(),
            beam_edges_cs: layout.beam_edges.iter().map(|a| (a.cos(), a.sin())).collect(),
            inv_beam_width: layout.uniform_beam_width().map(|w| 1.0 / w),
        }
    }

    /// Returns whether `p` (squared range `r2`) is in view: the splat shader's `in_view`.
    fn in_view(&self, p: DVec3, r2: f64) -> bool {
        r2 > 0.0
            && r2 >= self.range_min_sq
            && r2 <= self.range_max_sq
            && p.x * self.sin_half_az >= p.y.abs() * self.cos_half_az
            && (!self.clip_elevation
                || (p.x * p.x + p.y * p.y) * self.sin2_half_el >= p.z * p.z * self.cos2_half_el)
    }

    /// Returns the range bin: a first guess, then the side of the guessed bin's squared edges.
    fn range_bin(&self, r: f64, r2: f64) -> usize {
        let l = self.layout;
        let last = l.range_bins - 1;
        let mut i = (((r - l.range_min) / l.range_bin_width).floor().max(0.0) as usize).min(last);
        if i > 0 && r2 < self.range_edges_sq[i] {
            i -= 1;
        } else if i < last && r2 >= self.range_edges_sq[i + 1] {
            i += 1;
        }
        i
    }

    /// Returns the beam: a first guess from `az`, then the side of the guessed beam's edges.
    fn beam(&self, p: DVec3, az: f64) -> usize {
        let beams = self.layout.beams();
        if beams == 1 {
            return 0;
        }
        let guess = match self.inv_beam_width {
            Some(inv) => ((az + self.layout.half_azimuth) * inv).floor().max(0.0) as usize,
            None => self
                .layout
                .beam_edges
                .partition_point(|&e| e <= az)
                .saturating_sub(1),
        };
        let mut j = guess.min(beams - 1);
        let at_or_above = |k: usize| {
            let (c, s) = self.beam_edges_cs[k];
            p.y * c - p.x * s >= 0.0
        };
        if j > 0 && !at_or_above(j) {
            j -= 1;
        } else if j < beams - 1 && at_or_above(j + 1) {
            j += 1;
        }
        j
    }
}

/// Returns `(occupied, occupied_measure)`: the reduce shader's work, word by word.
fn reduce(layout: &Layout, occ: &Occupancy) -> (u64, f64) {
    let occupied = occ.count();
    let measure = match layout.kind {
        SonarKind::Sss => occupied as f64 * layout.range_bin_width,
        SonarKind::Fls => occ.pixels().map(|(i, j)| layout.pixel_measure(i, j)).sum(),
    };
    (occupied, measure)
}

/// Returns the projections of every item of `prepared` on all cores; with `keep_occupancy` each
/// carries its occupancy buffer.
pub fn project(prepared: &PreparedBatch<'_>, keep_occupancy: bool) -> Vec<Projection> {
    let layout = &prepared.layout;
    let geo = Geometry::new(layout);
    // Unit directions of every plan, azimuth index fastest (the plan's sample order).
    let directions: Vec<Vec<DVec3>> = prepared
        .plans
        .iter()
        .map(|plan| {
            let azimuths: Vec<(f64, f64)> = plan.azimuths.iter().map(|a| (a.cos(), a.sin())).collect();
            plan.elevations
                .iter()
                .flat_map(|e| {
                    let (ce, se) = (e.cos(), e.sin());
                    azimuths
                        .iter()
                        .map(move |&(ca, sa)| DVec3::new(ce * ca, ce * sa, se))
                })
                .collect()
        })
        .collect();
    prepared
        .batch
        .items
        .par_iter()
        .enumerate()
        .map(|(n, item)| {
            let dirs = &directions[prepared.plan_of[n]];
            let m = item.pose.rotation
                * DMat3::from_rotation_z(prepared.base_azimuth[n])
                * item.measurement.range;
            let t = item.pose.translation;
            let mut occ = Occupancy::new(layout.range_bins, layout.beams());
            let mut visible = 0;
            let mut extremes = Extremes::default();
            for u in dirs {
                let p = m * *u + t;
                let r2 = p.length_squared();
                if !geo.in_view(p, r2) {
                    continue;
                }
                let (r, az) = (r2.sqrt(), p.y.atan2(p.x));
                occ.set(geo.range_bin(r, r2), geo.beam(p, az));
                visible += 1;
                extremes.add(r, az);
            }
            let (occupied, measure) = reduce(layout, &occ);
            Projection {
                metrics: Metrics::new(visible, dirs.len() as u64, extremes, occupied, measure),
                occupancy: keep_occupancy.then_some(occ),
            }
        })
        .collect()
}
