// Stage 1: transform, clip, bin, splat. CPU twin: src/projection/fast.rs (the same algorithm in f64,
// block culling included; the reference src/projection/reference/splat.rs stays plain).
// The transform and every decision use Real (f64, or double-f32 where the adapter has no f64:
// shared/real_*.wgsl), so a sample lands where the f64 reference puts it unless it lies within
// about 1e-12 (relative) of a bound or edge. With FILTER, f32 takes the decisions it cannot get
// wrong (those far from every bound and edge) and Real the rest: the same bits, fewer Real
// operations (this stage only: on a CPU, f64 costs at most twice f32).
// Dispatch (tiles, poses, 1): workgroup (x, y) handles samples x*WORKGROUP + l, stepping by
// tiles*WORKGROUP, of pose y. Each visible sample sets its pixel's bit with atomicOr; the workgroup
// then folds its visible count and range/azimuth extremes into the pose's metric slots.

@group(0) @binding(0) var<uniform> params: TargetParams;
@group(0) @binding(1) var<storage, read> beam_edges: array<BeamEdge>;
// squared range-bin edges (range_min + i * width)^2, i = 0..=range_bins, double-f32
@group(0) @binding(2) var<storage, read> range_edges_sq: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read> poses: array<Pose>;
// (cos hi, sin hi, cos lo, sin lo) of the plans' azimuth offsets and elevations; after each
// plan's elevations, one culling ball per block of BLOCK samples (centre xyz, radius w, f32),
// then per block the largest distance of its units from its chord (first unit to last), four an
// entry
@group(0) @binding(4) var<storage, read> directions: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> bits: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> metrics: array<atomic<u32>>;

// Samples per culling block (consecutive in the plan's order): projection::fast::BLOCK.
const BLOCK: u32 = 16u;
// Where a block's ball lies: projection::fast's Side.
const OUTSIDE: u32 = 0u;
const ACROSS: u32 = 1u;
const INSIDE: u32 = 2u;
// Pipeline constants (gpu::SplatOptions). WORKGROUP: threads a workgroup, a multiple of BLOCK.
// CULL false draws every sample with every clip test; FILTER false decides every sample in
// Real, true first in f32 where it can (view_f32).
override WORKGROUP: u32 = 64u;
override CULL: bool = true;
override FILTER: bool = true;
override BLOCKS_PER_STEP: u32 = WORKGROUP / BLOCK;
// What the f32 decisions return: a sample outside the view, inside it, or left to Real (which
// a bin or beam decision returns too).
const HIDDEN: u32 = 0u;
const VISIBLE: u32 = 1u;
const UNSURE: u32 = 0xffffffffu;

var<workgroup> wg_side: array<u32, BLOCKS_PER_STEP>;

var<workgroup> wg_visible: atomic<u32>;
var<workgroup> wg_range_min_not: atomic<u32>;
var<workgroup> wg_range_max: atomic<u32>;
var<workgroup> wg_azimuth_min_not: atomic<u32>;
var<workgroup> wg_azimuth_max: atomic<u32>;

// Returns the range bin of a point at range r (f32) and squared range r2: a first guess
// floor((r - range_min) / width), then the exact side of the guessed bin's squared edges.
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

// Returns the first guess of the beam at azimuth az (f32, inside the aperture; more than one
// beam): direct for uniform beams, else a binary search of the edges' f32 angles. Within a beam
// of the right one.
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

// Returns the beam of the point (x, y) (inside the aperture) at azimuth az (f32): a first guess,
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
// projection::fast's Geometry::ball_side: each clip bound is a 1-Lipschitz function of the point, so
// its value at the centre moves by at most the radius over the ball. Decided in f32 from the
// pose's hi parts, with slack the pose's f32_slack (1e-5 * (range + |t| + range_max), over a
// hundred times the f32 roundings here), so a culled sample is one the Real test rejects and a
// sample of an INSIDE block one it keeps.
fn block_side(pose: Pose, ball: vec4<f32>, slack: f32) -> u32 {
    let c = moved(pose, ball.xyz);
    let radius = length(pose.hi0.xyz) * ball.w * 1.00001 + slack;
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
// range_bin_f32, beam_f32): 1e-5 * (range + |t| + range_max). A point moved in f32 (moved, from
// the f32 unit) lies within 4e-6 * (range + |t|) of the Real one: the unit within 4e-7, each
// entry of M and t within 2^-24 of its value, and four roundings of the dot product, each within
// 2^-24 of |M| |u| + |t|. A clip or edge function evaluated there in f32 adds a few roundings of
// |p| <= range + |t|; a double-f32 Real left at f32 precision by its driver, 1e-6 * (range + |t|).
fn f32_slack(pose: Pose) -> f32 {
    let range = length(pose.hi0.xyz);
    let t = length(vec3<f32>(pose.hi0.w, pose.hi1.w, pose.hi2.w));
    return 1e-5 * (range + t + params.range_max);
}

// Returns p moved by the pose (its hi parts).
fn moved(pose: Pose, p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        dot(pose.hi0.xyz, p) + pose.hi0.w,
        dot(pose.hi1.xyz, p) + pose.hi1.w,
        dot(pose.hi2.xyz, p) + pose.hi2.w,
    );
}

// Per end of a chord: beyond the upper and the lower azimuth half-plane, the pair of them,
// above and below the elevation sheet, each by more than margin.
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

// Returns the unit direction of sample k of the pose's plan in f32 from the hi parts (within
// 4e-7 of the f64 unit; the reaches are widened by that).
fn unit_f32(pose: Pose, k: u32) -> vec3<f32> {
    let a = directions[pose.plan.x + k % pose.plan.y];
    let e = directions[pose.plan.z + k / pose.plan.y];
    return vec3<f32>(e.x * a.x, e.x * a.y, e.y);
}

// Returns whether every unit within reach of the chord from sample first's unit to sample last's,
// once the pose moves it, lies outside sonar 2's field of view (range bounds aside: block_side has
// them). Twin of projection::fast's Geometry::chord_outside: the outside is a union of parts on
// each of which a concave, 1-Lipschitz function is positive (past an azimuth half-plane, or both
// for apertures over 180 deg; above the elevation sheet, z cos e - rho sin e; below it), and a
// concave function on a segment is at least its smaller value at the ends. In f32 with
// block_side's slack.
fn chord_outside(pose: Pose, first: u32, last: u32, reach: f32, slack: f32) -> bool {
    let margin = length(pose.hi0.xyz) * reach * 1.00001 + slack;
    let a = beyond(moved(pose, unit_f32(pose, first)), margin);
    let b = beyond(moved(pose, unit_f32(pose, last)), margin);
    var azimuth = (a.upper && b.upper) || (a.lower && b.lower);
    if params.cos_half_az.x < 0.0 {
        azimuth = a.both && b.both;
    }
    let elevation = params.clip_elevation != 0u && ((a.above && b.above) || (a.below && b.below));
    return azimuth || elevation;
}

// The f32 decisions of a sample (FILTER): p is the sample moved in f32 (from the hi parts),
// within f32_slack of the Real point, and every bound and edge is a 1-Lipschitz function of the
// point (range; x sin h - |y| cos h; |z| cos e - rho sin e; y cos a - x sin a for a beam edge at
// angle a). So where f32 finds p farther than the slack from a bound or an edge, the Real point
// lies on the same side of it, and f32 decides as Real would, in far fewer operations on GPUs
// with slow f64 or in double-f32. Where it does not, the Real decisions of draw decide.

// Returns HIDDEN when p lies outside sonar 2's field of view by more than slack (beyond some
// bound), VISIBLE when it lies inside by more than slack from every bound, else UNSURE.
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

// Returns the range bin of a sample in view at f32 range r, or UNSURE when r lies within slack
// of the bin's inner edges (in bin units; the outer edges of the first and last bins are the
// range bounds, which the view decides).
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

// Returns row . u + row.w, the row given as hi + lo pairs.
fn row_dot(hi: vec4<f32>, lo: vec4<f32>, ux: Real, uy: Real, uz: Real) -> Real {
    var s = r_mul(real(vec2<f32>(hi.x, lo.x)), ux);
    s = r_add(s, r_mul(real(vec2<f32>(hi.y, lo.y)), uy));
    s = r_add(s, r_mul(real(vec2<f32>(hi.z, lo.z)), uz));
    return r_add(s, real(vec2<f32>(hi.w, lo.w)));
}

// A drawn sample: whether it is visible, and its range and azimuth (f32, from the rounded point).
struct Drawn {
    seen: bool,
    r: f32,
    az: f32,
}

// Draws sample k of the pose: transform, clip (unless its block lies wholly inside), bins, and
// the pixel's bit in the pose's bitset. With FILTER, f32 decides first where it can (view_f32,
// range_bin_f32, beam_f32, with the pose's f32_slack): a hidden sample costs no Real operation,
// a decided one only the Real point its reported range and azimuth come from.
fn draw(pose: Pose, k: u32, inside: bool, base_word: u32, slack: f32) -> Drawn {
    let n_az = pose.plan.y;
    let a = directions[pose.plan.x + k % n_az];
    let e = directions[pose.plan.z + k / n_az];
    var view = UNSURE;
    var bin = UNSURE;
    var p = vec3<f32>(0.0);
    if FILTER {
        p = moved(pose, vec3<f32>(e.x * a.x, e.x * a.y, e.y));
        let r = length(p);
        if !inside {
            view = view_f32(p, r, slack);
            if view == HIDDEN {
                return Drawn(false, 0.0, 0.0);
            }
        }
        bin = range_bin_f32(r, slack);
    }
    // unit direction (cos el cos az, cos el sin az, sin el)
    let ce = real(e.xz);
    let ux = r_mul(ce, real(a.xz));
    let uy = r_mul(ce, real(a.yw));
    let uz = real(e.yw);
    // the sample in sonar 2
    let x = row_dot(pose.hi0, pose.lo0, ux, uy, uz);
    let y = row_dot(pose.hi1, pose.lo1, ux, uy, uz);
    let z = row_dot(pose.hi2, pose.lo2, ux, uy, uz);
    let r2 = r_add(r_add(r_mul(x, x), r_mul(y, y)), r_mul(z, z));
    if !inside && view != VISIBLE && !in_view(x, y, z, r2) {
        return Drawn(false, 0.0, 0.0);
    }
    // reported values: f32 from the rounded point
    let r = sqrt(r_f32(r2));
    let az = atan2(r_f32(y), r_f32(x));
    if bin == UNSURE {
        bin = range_bin(r, r2);
    }
    var beam = UNSURE;
    if FILTER {
        beam = beam_f32(p, az, slack);
    }
    if beam == UNSURE {
        beam = beam_of(x, y, az);
    }
    let pixel = bin * params.beams + beam;
    let word = base_word + (pixel >> 5u);
    let mask = 1u << (pixel & 31u);
    if (atomicLoad(&bits[word]) & mask) == 0u {
        atomicOr(&bits[word], mask);
    }
    return Drawn(true, r, az);
}

@compute @workgroup_size(WORKGROUP)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    if lid == 0u {
        atomicStore(&wg_visible, 0u);
        atomicStore(&wg_range_min_not, 0u);
        atomicStore(&wg_range_max, 0u);
        atomicStore(&wg_azimuth_min_not, 0u);
        atomicStore(&wg_azimuth_max, 0u);
    }
    workgroupBarrier();

    let pose_index = wid.y;
    let pose = poses[min(pose_index, params.pose_count - 1u)];
    // A workgroup past the chunk's poses draws nothing.
    let n = select(0u, pose.plan.y * pose.plan.w, pose_index < params.pose_count);
    let base_word = pose_index * params.words_per_pose;
    let slack = f32_slack(pose);

    var visible = 0u;
    var r_min = 3.0e38;
    var r_max = -3.0e38;
    var az_min = 3.0e38;
    var az_max = -3.0e38;
    // The workgroup takes WORKGROUP consecutive samples at a time, BLOCKS_PER_STEP blocks: their
    // sides are decided once, by the first lanes, and shared.
    for (var base = wid.x * WORKGROUP; base < n; base += nwg.x * WORKGROUP) {
        var side = ACROSS;
        if CULL {
            if lid < BLOCKS_PER_STEP {
                var block = OUTSIDE;
                let b = base / BLOCK + lid;
                if b * BLOCK < n {
                    let balls = pose.plan.z + pose.plan.w;
                    block = block_side(pose, directions[balls + b], slack);
                    // A ball across a bound: the block's chord may still lie wholly outside.
                    if block == ACROSS {
                        let reach = directions[balls + (n + BLOCK - 1u) / BLOCK + b / 4u][b % 4u];
                        let last = min(b * BLOCK + BLOCK, n) - 1u;
                        if chord_outside(pose, b * BLOCK, last, reach, slack) {
                            block = OUTSIDE;
                        }
                    }
                }
                wg_side[lid] = block;
            }
            workgroupBarrier();
            side = wg_side[lid / BLOCK];
        }
        let k = base + lid;
        if k < n && side != OUTSIDE {
            let s = draw(pose, k, side == INSIDE, base_word, slack);
            if s.seen {
                visible += 1u;
                r_min = min(r_min, s.r);
                r_max = max(r_max, s.r);
                az_min = min(az_min, s.az);
                az_max = max(az_max, s.az);
            }
        }
        if CULL {
            workgroupBarrier();
        }
    }

    if visible > 0u {
        atomicAdd(&wg_visible, visible);
        atomicMax(&wg_range_min_not, ~order_key(r_min));
        atomicMax(&wg_range_max, order_key(r_max));
        atomicMax(&wg_azimuth_min_not, ~order_key(az_min));
        atomicMax(&wg_azimuth_max, order_key(az_max));
    }
    workgroupBarrier();
    if lid == 0u && pose_index < params.pose_count {
        let seen = atomicLoad(&wg_visible);
        if seen > 0u {
            let m = pose_index * METRIC_STRIDE;
            atomicAdd(&metrics[m + METRIC_VISIBLE], seen);
            atomicMax(&metrics[m + METRIC_RANGE_MIN_NOT], atomicLoad(&wg_range_min_not));
            atomicMax(&metrics[m + METRIC_RANGE_MAX], atomicLoad(&wg_range_max));
            atomicMax(&metrics[m + METRIC_AZIMUTH_MIN_NOT], atomicLoad(&wg_azimuth_min_not));
            atomicMax(&metrics[m + METRIC_AZIMUTH_MAX], atomicLoad(&wg_azimuth_max));
        }
    }
}
