//! Block culling: the geometry the fast CPU path and the splat shader share.
//!
//! A plan's samples are cut into blocks of consecutive samples. Each block's unit directions are
//! held in a ball (centre, radius) and near a chord (its first and last unit, and how far the
//! others lie from it). Tests then put a moved block wholly outside or wholly inside sonar 2's
//! field of view. They are sound because:
//!
//! 1. Each clip bound is a 1-Lipschitz function of the point: the range, the azimuth half-planes'
//!    signed distances, and the elevation cone's `|z| cos e − ρ sin e`. So its value at a ball's
//!    centre moves by at most the radius over the ball ([`ball_side`]).
//! 2. A ball is often wider than a thin field of view (a sidescan's sheet), while its samples, on
//!    an arc, stay within a hair of the chord. The outside is a union of convex parts, on each of
//!    which a concave, 1-Lipschitz function is positive. A concave function on a segment is at
//!    least its smaller end value. So a chord whose two ends lie beyond one part by more than the
//!    samples' reach lies wholly in it ([`chord_outside`]).
//! 3. The slacks that keep these tests safe under rounding are [`crate::clip::CULL_SLACK`] (f64)
//!    and [`crate::clip::F32_SLACK`] (the shader's f32).
//!
//! The shader's twins are `block_side` and `chord_outside` in `shaders/shared/clip.wgsl`. Its table
//! of balls and reaches is built by [`block_bounds`].

use glam::DVec3;

use crate::clip::Clip;

/// Samples per culling block of the splat shader (WGSL `BLOCK`). A block's samples are consecutive
/// in the plan's order, azimuth index fastest. The fast path's blocks have as many.
pub(crate) const BLOCK: usize = 16;

/// Returns the splat shader's culling balls and chords, per block of [`BLOCK`] consecutive samples
/// of the plan with these azimuth offsets and elevations (rad). Each block gets the centre and
/// radius of a ball holding its unit directions, and the largest distance of those from its chord
/// (the segment from its first unit direction to its last).
pub(crate) fn block_bounds(azimuths: &[f64], elevations: &[f64]) -> (Vec<(DVec3, f64)>, Vec<f64>) {
    // Block by block: a plan may have 2^26 samples, whose unit directions alone would take 1.6 GB.
    let azimuths: Vec<(f64, f64)> = azimuths.iter().map(|a| (a.cos(), a.sin())).collect();
    let elevations: Vec<(f64, f64)> = elevations.iter().map(|e| (e.cos(), e.sin())).collect();
    let n = azimuths.len() * elevations.len();
    let unit = |k: usize| {
        let ((ca, sa), (ce, se)) = (azimuths[k % azimuths.len()], elevations[k / azimuths.len()]);
        DVec3::new(ce * ca, ce * sa, se)
    };
    let mut bounds = (
        Vec::with_capacity(n.div_ceil(BLOCK)),
        Vec::with_capacity(n.div_ceil(BLOCK)),
    );
    let mut block = Vec::with_capacity(BLOCK);
    for start in (0..n).step_by(BLOCK) {
        block.clear();
        block.extend((start..(start + BLOCK).min(n)).map(unit));
        bounds.0.push(ball(&block));
        bounds.1.push(chord(&block).2);
    }
    bounds
}

/// Returns the unit directions of the plan with these azimuth offsets and elevations (rad),
/// azimuth index fastest.
pub(crate) fn unit_directions(azimuths: &[f64], elevations: &[f64]) -> Vec<DVec3> {
    let azimuths: Vec<(f64, f64)> = azimuths.iter().map(|a| (a.cos(), a.sin())).collect();
    elevations
        .iter()
        .flat_map(|e| {
            let (ce, se) = (e.cos(), e.sin());
            azimuths
                .iter()
                .map(move |&(ca, sa)| DVec3::new(ce * ca, ce * sa, se))
        })
        .collect()
}

/// Returns, per block of `size` of `units`, the centre (their mean) and radius of a ball
/// holding them.
pub(crate) fn balls(units: &[DVec3], size: usize) -> Vec<(DVec3, f64)> {
    units.chunks(size).map(ball).collect()
}

/// Returns the centre (the mean) and radius of a ball holding the units of block `b`.
fn ball(b: &[DVec3]) -> (DVec3, f64) {
    let centre = b.iter().sum::<DVec3>() / b.len() as f64;
    let radius = b.iter().map(|u| (*u - centre).length()).fold(0.0, f64::max);
    (centre, radius)
}

fn distance_to_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let s = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + s * ab)).length()
}

/// Returns, per block of `size` of `units`, its chord (first and last unit) and the largest
/// distance of its units from the chord. A block of a plan's arc (one azimuth, or one elevation
/// row) lies within its sagitta of the chord, far closer than to its ball's centre.
pub(crate) fn chords(units: &[DVec3], size: usize) -> Vec<(DVec3, DVec3, f64)> {
    units.chunks(size).map(chord).collect()
}

/// Returns the chord of block `b` (its first and last unit) and the largest distance of its
/// units from it.
fn chord(b: &[DVec3]) -> (DVec3, DVec3, f64) {
    let (first, last) = (b[0], b[b.len() - 1]);
    let reach = b
        .iter()
        .map(|u| distance_to_segment(*u, first, last))
        .fold(0.0, f64::max);
    (first, last, reach)
}

/// Returns whether the ball of `radius` around `c` lies wholly outside the field of view, and
/// whether wholly inside it (else it straddles a bound). Each clip bound is taken at `c`, less and
/// plus the radius. The splat shader's `block_side`. It is branch-free so that it vectorises over
/// blocks.
#[inline(always)]
pub(crate) fn ball_side(clip: &Clip<'_>, c: [f64; 3], radius: f64) -> (bool, bool) {
    let l = clip.layout;
    let [x, y, z] = c;
    let d = (x * x + y * y + z * z).sqrt();
    // Azimuth: the wedge is {x sin h − y cos h ≥ 0} ∩ {x sin h + y cos h ≥ 0} for h ≤ 90°,
    // their union beyond; both normals are unit vectors.
    let upper = x * clip.sin_half_az - y * clip.cos_half_az;
    let lower = x * clip.sin_half_az + y * clip.cos_half_az;
    let wedge = if clip.cos_half_az >= 0.0 {
        upper.min(lower)
    } else {
        upper.max(lower)
    };
    let (az_out, az_in) = (wedge < -radius, wedge > radius);
    // Elevation: |z| cos e − ρ sin e > 0 outside.
    let (s, co) = clip.sin_cos_half_el;
    let cone = z.abs() * co - (x * x + y * y).sqrt() * s;
    let el_out = clip.clip_elevation & (cone > radius);
    let el_in = !clip.clip_elevation | (cone < -radius);
    let outside = (d - radius > l.range_max) | (d + radius < l.range_min) | az_out | el_out;
    let inside = (d - radius > 0.0) & (d - radius > l.range_min) & (d + radius < l.range_max) & az_in & el_in;
    (outside, inside & !outside)
}

/// Returns whether every point within `margin` of the segment `[a, b]` lies outside the field of
/// view, range bounds aside (the ball test has them). It holds when both ends lie beyond `margin`
/// of one of:
///
/// - one azimuth half-plane, by its signed distance (for apertures over 180°, the larger of both);
/// - above the elevation sheet, `z cos e − ρ sin e` (concave, as `ρ` is convex);
/// - below it, `−z cos e − ρ sin e`.
///
/// The splat shader's `chord_outside`. It is branch-free so that it vectorises over blocks.
#[inline(always)]
pub(crate) fn chord_outside(clip: &Clip<'_>, a: [f64; 3], b: [f64; 3], margin: f64) -> bool {
    let (s, co) = clip.sin_cos_half_el;
    // Per end: beyond the upper and the lower half-plane, the pair of them, above, below.
    let beyond = |[x, y, z]: [f64; 3]| {
        let upper = x * clip.sin_half_az - y * clip.cos_half_az;
        let lower = x * clip.sin_half_az + y * clip.cos_half_az;
        let rho = (x * x + y * y).sqrt() * s;
        [
            upper < -margin,
            lower < -margin,
            upper.max(lower) < -margin,
            z * co - rho > margin,
            -z * co - rho > margin,
        ]
    };
    let (ea, eb) = (beyond(a), beyond(b));
    let both = |k: usize| ea[k] & eb[k];
    let azimuth = if clip.cos_half_az >= 0.0 {
        both(0) | both(1)
    } else {
        both(2)
    };
    azimuth | (clip.clip_elevation & (both(3) | both(4)))
}

#[cfg(test)]
mod tests {
    use super::{BLOCK, balls, block_bounds, chords, unit_directions};

    /// The bounds built block by block are those of the plan's unit directions built whole,
    /// bit for bit, whether or not the samples fill the last block.
    #[test]
    fn block_bounds_are_those_of_the_whole_plan() {
        for (na, ne) in [(1, 1), (1, 121), (7, 3), (16, 16), (33, 17), (130, 1)] {
            let azimuths: Vec<f64> = (0..na).map(|k| -0.5 + 0.013 * f64::from(k)).collect();
            let elevations: Vec<f64> = (0..ne).map(|k| -0.3 + 0.007 * f64::from(k)).collect();
            let units = unit_directions(&azimuths, &elevations);
            let reaches: Vec<f64> = chords(&units, BLOCK).into_iter().map(|c| c.2).collect();
            assert_eq!(
                block_bounds(&azimuths, &elevations),
                (balls(&units, BLOCK), reaches),
                "{na} × {ne}"
            );
        }
    }
}
