//! The per-plan tables of the fast path: a plan's unit directions block by block in
//! structure-of-arrays form, and its blocks' culling balls and chords
//! ([`crate::projection::culling`]) eight blocks at a time. Also the test of a pose's moved balls.

use glam::{DMat3, DVec3};

use super::{BALLS, Geometry, LANES};
use crate::clip::F64_WIDEN;
use crate::projection::culling::{ball_side, balls, chord_outside, chords, unit_directions};

/// A plan's unit directions (azimuth index fastest) and, per block of [`LANES`] of them, the centre
/// and radius of a ball holding them.
pub(super) struct Directions {
    pub(super) units: Vec<DVec3>,
    /// The same units block by block in structure-of-arrays form, for the lane stage.
    pub(super) lanes: Vec<BlockUnits>,
    /// The largest distance between consecutive units (0 for a single sample).
    pub(super) max_step: f64,
    /// The balls, [`BALLS`] blocks at a time in structure-of-arrays form. The last chunk is padded
    /// with copies of the last ball.
    pub(super) ball_chunks: Vec<BallChunk>,
}

/// [`BALLS`] blocks' balls: centres and radii.
#[derive(Clone)]
pub(super) struct BallChunk {
    pub(super) x: [f64; BALLS],
    pub(super) y: [f64; BALLS],
    pub(super) z: [f64; BALLS],
    pub(super) r: [f64; BALLS],
    /// The blocks' chords: their first and last units (`x`, `y`, `z` arrays), and how far the
    /// blocks' units lie from them.
    pub(super) first: [[f64; BALLS]; 3],
    pub(super) last: [[f64; BALLS]; 3],
    pub(super) reach: [f64; BALLS],
}

/// The unit directions of one block, one array per coordinate. Lanes past `len` repeat the last
/// unit and are never kept.
#[derive(Clone)]
pub(super) struct BlockUnits {
    pub(super) x: [f64; LANES],
    pub(super) y: [f64; LANES],
    pub(super) z: [f64; LANES],
    pub(super) len: usize,
}

impl Directions {
    /// Returns the tables of the plan with these azimuth offsets and elevations (rad).
    pub(super) fn of(azimuths: &[f64], elevations: &[f64]) -> Self {
        Directions::from_units(unit_directions(azimuths, elevations))
    }

    /// Returns the tables of samples `samples` (azimuth index fastest) of the plan with these
    /// azimuth offsets and elevations (rad). Each unit has the same bits as in [`Directions::of`].
    pub(super) fn of_samples(azimuths: &[f64], elevations: &[f64], samples: std::ops::Range<usize>) -> Self {
        let n = azimuths.len();
        let units = samples
            .map(|k| {
                let (a, e) = (azimuths[k % n], elevations[k / n]);
                let (ca, sa, ce, se) = (a.cos(), a.sin(), e.cos(), e.sin());
                DVec3::new(ce * ca, ce * sa, se)
            })
            .collect();
        Directions::from_units(units)
    }

    fn from_units(units: Vec<DVec3>) -> Self {
        let blocks = balls(&units, LANES);
        let lanes = units
            .chunks(LANES)
            .map(|b| {
                let at = |k: usize| b[k.min(b.len() - 1)];
                BlockUnits {
                    x: std::array::from_fn(|k| at(k).x),
                    y: std::array::from_fn(|k| at(k).y),
                    z: std::array::from_fn(|k| at(k).z),
                    len: b.len(),
                }
            })
            .collect();
        let chords = chords(&units, LANES);
        let ball_chunks = blocks
            .chunks(BALLS)
            .zip(chords.chunks(BALLS))
            .map(|(b, c)| {
                let at = |k: usize| b[k.min(b.len() - 1)];
                let ch = |k: usize| c[k.min(c.len() - 1)];
                BallChunk {
                    x: std::array::from_fn(|k| at(k).0.x),
                    y: std::array::from_fn(|k| at(k).0.y),
                    z: std::array::from_fn(|k| at(k).0.z),
                    r: std::array::from_fn(|k| at(k).1),
                    first: std::array::from_fn(|i| std::array::from_fn(|k| ch(k).0[i])),
                    last: std::array::from_fn(|i| std::array::from_fn(|k| ch(k).1[i])),
                    reach: std::array::from_fn(|k| ch(k).2),
                }
            })
            .collect();
        let max_step = units
            .windows(2)
            .map(|w| (w[1] - w[0]).length())
            .fold(0.0, f64::max);
        Directions {
            units,
            lanes,
            max_step,
            ball_chunks,
        }
    }
}

/// Returns `M u + t` in the operation order of glam's `DMat3 * DVec3`. `m` is `M`'s columns then
/// `t`.
#[inline(always)]
pub(super) fn moved(m: &[f64; 12], [ux, uy, uz]: [f64; 3]) -> [f64; 3] {
    [
        m[0] * ux + m[3] * uy + m[6] * uz + m[9],
        m[1] * ux + m[4] * uy + m[7] * uz + m[10],
        m[2] * ux + m[5] * uy + m[8] * uz + m[11],
    ]
}

/// Returns `M` (scaled by the range) and `t` as [`moved`] and the lane stage take them: `M`'s
/// columns then `t`.
#[inline]
pub(super) fn pose_columns(m: DMat3, t: DVec3) -> [f64; 12] {
    let columns = [m.x_axis, m.y_axis, m.z_axis, t].map(|c| c.to_array());
    std::array::from_fn(|k| columns[k / 3][k % 3])
}

/// Returns bit masks of the [`BALLS`] blocks of `chunk` whose balls lie wholly outside, and wholly
/// inside, the field of view ([`ball_side`]). The balls are moved by the pose (`m` is `M`'s columns
/// then `t`), their radii scaled by `range` and widened by `slack` and a relative 1e-12. They are
/// tested together so that it vectorises. When some ball lies across a bound, the blocks' chords,
/// widened the same way ([`chord_outside`]), may show more blocks wholly outside.
#[inline(always)]
pub(super) fn ball_sides(
    geo: &Geometry<'_>,
    m: &[f64; 12],
    chunk: &BallChunk,
    range: f64,
    slack: f64,
) -> (u32, u32) {
    let mut out = [false; BALLS];
    let mut ins = [false; BALLS];
    for k in 0..BALLS {
        let c = moved(m, [chunk.x[k], chunk.y[k], chunk.z[k]]);
        (out[k], ins[k]) = ball_side(geo, c, range * chunk.r[k] * (1.0 + F64_WIDEN) + slack);
    }
    let mask = |v: [bool; BALLS]| v.iter().enumerate().fold(0, |m, (k, &b)| m | u32::from(b) << k);
    let (out, ins) = (mask(out), mask(ins));
    if out | ins == (1 << BALLS) - 1 {
        return (out, ins);
    }
    // A ball across a bound: its block's chord, moved by the pose, may still show the block
    // outside, as for a thin sheet that the ball straddles while the arc stays on one side. The
    // pose is a rotation and the scale `range`, so distances scale by `range`.
    let mut far = [false; BALLS];
    for (k, far) in far.iter_mut().enumerate() {
        let end = |e: &[[f64; BALLS]; 3]| moved(m, [e[0][k], e[1][k], e[2][k]]);
        let margin = range * chunk.reach[k] * (1.0 + F64_WIDEN) + slack;
        *far = chord_outside(geo, end(&chunk.first), end(&chunk.last), margin);
    }
    let far = mask(far);
    (out | far, ins & !far)
}
