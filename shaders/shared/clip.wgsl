// The splat stage's decisions: field of view, range bin and beam (in Real, and first in f32 with
// the f32 filter), block culling, and the slack of every f32 decision. Read it side by side with
// its Rust twins: src/clip.rs (Clip: in_view, range_bin, at_or_above, beam; the tolerances, with
// their derivations) and src/projection/culling.rs (ball_side, chord_outside). A prelude of
// splat.wgsl, after types.wgsl and real_*.wgsl. It declares the splat stage's first three bindings,
// sonar 2 as its decisions read it (params, beam_edges, range_edges_sq), so that no part reads a
// global declared after it. The mask stage (mask.wgsl) tests balls instead and is self-contained.

// Generated from src/clip.rs and src/projection/culling.rs and put before this file
// (src/projection/gpu/source.rs):
// - F32_SLACK: the relative slack of the f32 decisions against range + |t| + range_max. A point
//   moved in f32 lies within 4e-6 * (range + |t|) of the Real one. A clip or edge function adds a
//   few roundings. A double-f32 Real left at f32 precision by its driver adds 1e-6 * (range + |t|).
// - F32_WIDEN: the relative widening of an f32 culling radius or reach.
// - BLOCK: the samples of a culling block, consecutive in the plan's order.

// Sonar 2: bindings 0-2 of the splat stage (see splat.wgsl for the others).
@group(0) @binding(0) var<uniform> params: TargetParams;
@group(0) @binding(1) var<storage, read> beam_edges: array<BeamEdge>;
// squared range-bin edges (range_min + i * width)^2, i = 0..=range_bins, double-f32
@group(0) @binding(2) var<storage, read> range_edges_sq: array<vec2<f32>>;

// Where a block's ball lies.
const OUTSIDE: u32 = 0u;
const ACROSS: u32 = 1u;
const INSIDE: u32 = 2u;
// What the f32 decisions return: a sample outside the view, inside it, or left to Real. A bin or
// beam decision returns UNSURE too.
const HIDDEN: u32 = 0u;
const VISIBLE: u32 = 1u;
const UNSURE: u32 = 0xffffffffu;

// Returns the range bin of a point at range r (f32) and squared range r2. A first guess floor((r -
// range_min) / width), then the exact side of the guessed bin's squared edges.
fn range_bin(r: f32, r2: Real) -> u32 {
    let last = i32(params.range_bins) - 1;
    var i = clamp(i32(floor((r - params.range_min) * params.inv_range_bin)), 0, last);
    if i > 0 && !r_ge(r2, real(range_edges_sq[i])) {
        i -= 1;
    } else if i < last && r_ge(r2, real(range_edges_sq[i + 1])) {
        i += 1;
    }
    return u32(i);
}

// Returns true when az(p) >= the edge's angle, for p within a beam or two of the edge:
// sin(az - e) * rho = y cos(e) - x sin(e) >= 0.
fn at_or_above(x: Real, y: Real, e: BeamEdge) -> bool {
    return r_ge(r_mul(y, real(e.cos_angle)), r_mul(x, real(e.sin_angle)));
}

// Returns the first guess of the beam at azimuth az (f32, inside the aperture, more than one beam).
// Direct for uniform beams, else a binary search of the edges' f32 angles. It is within a beam of
// the right one.
fn beam_guess(az: f32) -> i32 {
    let beams = i32(params.beams);
    var j: i32;
    if params.beams_uniform != 0u {
        j = i32(floor((az + params.half_az) * params.inv_beam_width));
    } else {
        var lo = 0;
        var hi = beams;
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if beam_edges[mid].angle <= az {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        j = lo;
    }
    return clamp(j, 0, beams - 1);
}

// Returns the beam of the point (x, y) (inside the aperture) at azimuth az (f32). A first guess,
// then the exact side of the guessed beam's edges.
fn beam_of(x: Real, y: Real, az: f32) -> u32 {
    let beams = i32(params.beams);
    if beams == 1 {
        return 0u;
    }
    var j = beam_guess(az);
    if j > 0 && !at_or_above(x, y, beam_edges[j]) {
        j -= 1;
    } else if j < beams - 1 && at_or_above(x, y, beam_edges[j + 1]) {
        j += 1;
    }
    return u32(j);
}

// Returns true when the point (x, y, z) with squared range r2 lies in sonar 2's field of view:
// the README's conventions, bounds inclusive, the origin outside.
fn in_view(x: Real, y: Real, z: Real, r2: Real) -> bool {
    if !r_positive(r2) || !r_ge(r2, real(params.range_min_sq)) || !r_ge(real(params.range_max_sq), r2) {
        return false;
    }
    var abs_y = y;
    if r_negative(y) {
        abs_y = r_neg(y);
    }
    if !r_ge(r_mul(x, real(params.sin_half_az)), r_mul(abs_y, real(params.cos_half_az))) {
        return false;
    }
    if params.clip_elevation != 0u {
        let rho2 = r_add(r_mul(x, x), r_mul(y, y));
        let lhs = r_mul(rho2, real(params.sin2_half_el));
        if !r_ge(lhs, r_mul(r_mul(z, z), real(params.cos2_half_el))) {
            return false;
        }
    }
    return true;
}

// Returns where the block's ball (unit directions within ball.w of ball.xyz) lies once the pose
// moves it: wholly outside sonar 2's field of view, wholly inside, or across a bound. Twin of
// projection::culling's ball_side. Each clip bound is a 1-Lipschitz function of the point, so its
// value at the centre moves by at most the radius over the ball. It is decided in f32 from the
// pose's hi parts, with slack the pose's f32_slack: F32_SLACK * (range + |t| + range_max), over a
// hundred times the f32 roundings here. So a culled sample is one the Real test rejects, and a
// sample of an INSIDE block one it keeps.
fn block_side(pose: Pose, ball: vec4<f32>, slack: f32) -> u32 {
    let c = moved(pose, ball.xyz);
    let radius = length(pose.hi0.xyz) * ball.w * (1.0 + F32_WIDEN) + slack;
    let d = length(c);
    // azimuth: the two half-planes' signed distances, intersected for h <= 90 deg, else united
    let upper = c.x * params.sin_half_az.x - c.y * params.cos_half_az.x;
    let lower = c.x * params.sin_half_az.x + c.y * params.cos_half_az.x;
    var az = max(upper, lower);
    if params.cos_half_az.x >= 0.0 {
        az = min(upper, lower);
    }
    // elevation: |z| cos e - rho sin e, positive outside
    var cone = -3.0e38;
    if params.clip_elevation != 0u {
        cone = abs(c.z) * sqrt(params.cos2_half_el.x) - length(c.xy) * sqrt(params.sin2_half_el.x);
    }
    if d - radius > params.range_max || d + radius < params.range_min || az < -radius || cone > radius {
        return OUTSIDE;
    }
    if d - radius > max(params.range_min, 0.0) && d + radius < params.range_max && az > radius
        && cone < -radius {
        return INSIDE;
    }
    return ACROSS;
}

// Returns the slack of the pose's f32 decisions (block_side, chord_outside, view_f32,
// range_bin_f32, beam_f32): F32_SLACK * (range + |t| + range_max), derived at F32_SLACK.
fn f32_slack(pose: Pose) -> f32 {
    let range = length(pose.hi0.xyz);
    let t = length(vec3<f32>(pose.hi0.w, pose.hi1.w, pose.hi2.w));
    return F32_SLACK * (range + t + params.range_max);
}

// Returns p moved by the pose (its hi parts).
fn moved(pose: Pose, p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        dot(pose.hi0.xyz, p) + pose.hi0.w,
        dot(pose.hi1.xyz, p) + pose.hi1.w,
        dot(pose.hi2.xyz, p) + pose.hi2.w,
    );
}

// Per end of a chord: beyond the upper and the lower azimuth half-plane, the pair of them, above
// and below the elevation sheet, each by more than margin.
struct Beyond {
    upper: bool,
    lower: bool,
    both: bool,
    above: bool,
    below: bool,
}

fn beyond(p: vec3<f32>, margin: f32) -> Beyond {
    let upper = p.x * params.sin_half_az.x - p.y * params.cos_half_az.x;
    let lower = p.x * params.sin_half_az.x + p.y * params.cos_half_az.x;
    let rho = length(p.xy) * sqrt(params.sin2_half_el.x);
    let z = p.z * sqrt(params.cos2_half_el.x);
    return Beyond((upper < -margin), (lower < -margin), (max(upper, lower) < -margin),
        (z - rho > margin), (-z - rho > margin));
}

// Returns whether every unit within reach of the chord from the unit first to the unit last lies
// outside sonar 2's field of view once the pose moves it. Range bounds aside: block_side has them.
// The ends are f32, from the direction table's hi parts (unit_f32 in splat.wgsl). Twin of
// projection::culling's chord_outside, in f32 with block_side's slack. The outside is a union of
// parts, on each of which a concave, 1-Lipschitz function is positive: past an azimuth half-plane
// (or both, for apertures over 180 deg), above the elevation sheet (z cos e - rho sin e), or below
// it. A concave function on a segment is at least its smaller value at the ends.
fn chord_outside(pose: Pose, first: vec3<f32>, last: vec3<f32>, reach: f32, slack: f32) -> bool {
    let margin = length(pose.hi0.xyz) * reach * (1.0 + F32_WIDEN) + slack;
    let a = beyond(moved(pose, first), margin);
    let b = beyond(moved(pose, last), margin);
    var azimuth = (a.upper && b.upper) || (a.lower && b.lower);
    if params.cos_half_az.x < 0.0 {
        azimuth = a.both && b.both;
    }
    let elevation = params.clip_elevation != 0u && ((a.above && b.above) || (a.below && b.below));
    return azimuth || elevation;
}

// The f32 decisions of a sample (FILTER). p is the sample moved in f32 (from the hi parts), within
// f32_slack of the Real point. Every bound and edge is a 1-Lipschitz function of the point: range;
// x sin h - |y| cos h; |z| cos e - rho sin e; y cos a - x sin a for a beam edge at angle a. So
// where f32 finds p farther than the slack from a bound or an edge, the Real point lies on the same
// side of it. Then f32 decides as Real would, in far fewer operations on GPUs with slow f64 or in
// double-f32. Elsewhere the Real decisions of draw decide.

// Returns HIDDEN when p lies outside sonar 2's field of view by more than slack (beyond some
// bound). Returns VISIBLE when it lies inside, more than slack from every bound. Else UNSURE.
fn view_f32(p: vec3<f32>, r: f32, slack: f32) -> u32 {
    let az = p.x * params.sin_half_az.x - abs(p.y) * params.cos_half_az.x;
    var el = -3.0e38;
    if params.clip_elevation != 0u {
        el = abs(p.z) * sqrt(params.cos2_half_el.x) - length(p.xy) * sqrt(params.sin2_half_el.x);
    }
    if r < params.range_min - slack || r > params.range_max + slack || az < -slack || el > slack {
        return HIDDEN;
    }
    if r > params.range_min + slack && r < params.range_max - slack && az > slack && el < -slack {
        return VISIBLE;
    }
    return UNSURE;
}

// Returns the range bin of a sample in view at f32 range r, or UNSURE when r lies within slack of
// the bin's inner edges (in bin units). The outer edges of the first and last bins are the range
// bounds, which the view decides.
fn range_bin_f32(r: f32, slack: f32) -> u32 {
    let u = (r - params.range_min) * params.inv_range_bin;
    let last = i32(params.range_bins) - 1;
    let i = clamp(i32(floor(u)), 0, last);
    let margin = slack * params.inv_range_bin;
    if (i > 0 && u - f32(i) <= margin) || (i < last && f32(i + 1) - u <= margin) {
        return UNSURE;
    }
    return u32(i);
}

// Returns the beam of a sample in view at p, guessed from its reported azimuth az, or UNSURE
// when p lies within slack of the guessed beam's inner edges.
fn beam_f32(p: vec3<f32>, az: f32, slack: f32) -> u32 {
    if params.beams == 1u {
        return 0u;
    }
    let j = beam_guess(az);
    if j > 0 {
        let e = beam_edges[j];
        if p.y * e.cos_angle.x - p.x * e.sin_angle.x <= slack {
            return UNSURE;
        }
    }
    if j < i32(params.beams) - 1 {
        let e = beam_edges[j + 1];
        if p.y * e.cos_angle.x - p.x * e.sin_angle.x >= -slack {
            return UNSURE;
        }
    }
    return u32(j);
}
