//! The tables the GPU stages read, built on the host in f64. They are a grid's axes for the poses
//! stage, the sampling plans' directions and culling balls for the splat stage, and an item's pose.

use std::collections::HashMap;

use glam::DMat3;

use crate::clip::{F32_CENTRE_ERROR, F32_ROUND_UP, F32_UNIT_ERROR};
use crate::occupancy::Layout;
use crate::projection::culling;
use crate::projection::poses::PoseGrid;
use crate::sampling::SamplingPlan;

use super::types::{PoseGpu, split};

/// Returns a grid's table for the poses stage, and where each axis's entries start. Each axis value
/// has three double-f32 entries built in f64: the value, and the cosine and sine of the value in
/// degrees. The axes of lengths (placement, translation) use the value alone.
pub(super) fn grid_table(grid: &PoseGrid) -> (Vec<[f32; 2]>, [u32; 9]) {
    let pair = |v: f64| {
        let (hi, lo) = split(v);
        [hi, lo]
    };
    let mut table = Vec::new();
    let mut offsets = [0; 9];
    for (k, axis) in grid.axes().iter().enumerate() {
        offsets[k] = table.len() as u32;
        for &v in axis {
            let r = v.to_radians();
            table.extend([pair(v), pair(r.cos()), pair(r.sin())]);
        }
    }
    (table, offsets)
}

/// Returns the direction table of the plans in `used`, and per plan the offsets of its azimuth and
/// elevation entries. Each plan has, in order:
/// 1. its azimuths, then its elevations: each entry `(cos hi, sin hi, cos lo, sin lo)` in
///    double-f32;
/// 2. its culling balls (`culling::block_bounds`): centre xyz and radius w, in f32, the radius
///    rounded up past the centre's rounding;
/// 3. its blocks' reaches from their chords (`culling::block_bounds`), four an entry, rounded up
///    past the shader's roundings of the chord's ends.
pub(super) fn direction_table(
    plans: &[SamplingPlan],
    used: &[usize],
) -> (Vec<[f32; 4]>, HashMap<usize, [u32; 2]>) {
    let entry = |angle: &f64| {
        let (c, s) = (split(angle.cos()), split(angle.sin()));
        [c.0, s.0, c.1, s.1]
    };
    let mut table = Vec::new();
    let mut offsets = HashMap::new();
    for &p in used {
        let plan = &plans[p];
        let az_off = table.len() as u32;
        table.extend(plan.azimuths.iter().map(entry));
        let el_off = table.len() as u32;
        table.extend(plan.elevations.iter().map(entry));
        // The shader finds block b of this plan at el_off + n_el + b. Rounding the centre to f32
        // moves it by at most F32_CENTRE_ERROR. The radius grows by that and rounds up.
        let (balls, reaches) = culling::block_bounds(&plan.azimuths, &plan.elevations);
        table.extend(balls.into_iter().map(|(c, r)| {
            [
                c.x as f32,
                c.y as f32,
                c.z as f32,
                ((r + F32_CENTRE_ERROR) * (1.0 + F32_ROUND_UP)) as f32,
            ]
        }));
        // Then the blocks' reaches, four an entry: block b's is at el_off + n_el + blocks + b / 4,
        // component b % 4. The shader computes the chord's ends in f32 from the hi parts, within
        // F32_UNIT_ERROR of the units. The reach grows by that and rounds up.
        table.extend(reaches.chunks(4).map(|r| {
            std::array::from_fn(|k| {
                r.get(k)
                    .map_or(0.0, |r| ((r + F32_UNIT_ERROR) * (1.0 + F32_ROUND_UP)) as f32)
            })
        }));
        offsets.insert(p, [az_off, el_off]);
    }
    (table, offsets)
}

/// Returns the exact stage's constants (`shaders/exact.wgsl`, binding 4) for arcs of a sonar 1
/// whose half elevation aperture is `half` (rad) into `layout`: the fast twin's
/// ([`crate::exact::SolverConstants`]), each an f32 hi + lo pair, then three flags (1 or 0).
pub(super) fn exact_table(layout: &Layout, half: f64) -> Vec<[f32; 4]> {
    let c = crate::exact::SolverConstants::new(layout, half);
    let two = |a: f64, b: f64| {
        let (a, b) = (split(a), split(b));
        [a.0, a.1, b.0, b.1]
    };
    let flag = |on: bool| f32::from(u8::from(on));
    let (sh, ch) = c.azimuth.unwrap_or((0.0, -1.0));
    vec![
        two(c.end, c.half),
        two(c.cos_half, c.sin_half),
        two(c.r2_min, c.r2_max),
        two(sh, ch),
        two(c.elevation.unwrap_or(1.0), 0.0),
        [
            flag(c.behind),
            flag(c.azimuth.is_some()),
            flag(c.elevation.is_some()),
            0.0,
        ],
    ]
}

/// Returns the GPU pose: the rows of `range · R · Rz(base_azimuth)` (computed in f64) with the
/// translation in `w`, split into f32 hi + lo pairs, and the plan.
pub(super) fn pose_gpu(r: &DMat3, t: [f64; 3], range: f64, base_azimuth: f64, plan: [u32; 4]) -> PoseGpu {
    let m = *r * DMat3::from_rotation_z(base_azimuth) * range;
    let mut pose = PoseGpu {
        hi: [[0.0; 4]; 3],
        lo: [[0.0; 4]; 3],
        plan,
    };
    for (i, ti) in t.into_iter().enumerate() {
        let v = m.row(i);
        for (j, x) in [v.x, v.y, v.z, ti].into_iter().enumerate() {
            (pose.hi[i][j], pose.lo[i][j]) = split(x);
        }
    }
    pose
}
