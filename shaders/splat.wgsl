// Stage 1: transform, clip, bin, splat. CPU mirror: src/cpu/splat.rs.
// The transform and every decision use Real (f64, or double-f32 where the adapter has no f64:
// shared/real_*.wgsl), so a sample lands where the f64 reference puts it unless it lies within
// about 1e-12 (relative) of a bound or edge.
// Dispatch (tiles, poses, 1): workgroup (x, y) handles samples x*64 + l, stepping by tiles*64,
// of pose y. Each visible sample sets its pixel's bit with atomicOr; the workgroup then folds its
// visible count and range/azimuth extremes into the pose's metric slots.

@group(0) @binding(0) var<uniform> params: TargetParams;
@group(0) @binding(1) var<storage, read> beam_edges: array<BeamEdge>;
// squared range-bin edges (range_min + i * width)^2, i = 0..=range_bins, double-f32
@group(0) @binding(2) var<storage, read> range_edges_sq: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read> poses: array<Pose>;
// (cos hi, sin hi, cos lo, sin lo) of the plans' azimuth offsets and elevations
@group(0) @binding(4) var<storage, read> directions: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> bits: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> metrics: array<atomic<u32>>;

const WORKGROUP: u32 = 64u;

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

// Returns the beam of the point (x, y) (inside the aperture) at azimuth az (f32): a first guess,
// then the exact side of the guessed beam's edges.
fn beam_of(x: Real, y: Real, az: f32) -> u32 {
    let beams = i32(params.beams);
    if beams == 1 {
        return 0u;
    }
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
    j = clamp(j, 0, beams - 1);
    if j > 0 && !at_or_above(x, y, beam_edges[j]) {
        j -= 1;
    } else if j < beams - 1 && at_or_above(x, y, beam_edges[j + 1]) {
        j += 1;
    }
    return u32(j);
}

// Returns true when the point (x, y, z) with squared range r2 lies in sonar 2's field of view:
// SPEC section 6, bounds inclusive, the origin outside.
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

// Returns row . u + row.w, the row given as hi + lo pairs.
fn row_dot(hi: vec4<f32>, lo: vec4<f32>, ux: Real, uy: Real, uz: Real) -> Real {
    var s = r_mul(real(vec2<f32>(hi.x, lo.x)), ux);
    s = r_add(s, r_mul(real(vec2<f32>(hi.y, lo.y)), uy));
    s = r_add(s, r_mul(real(vec2<f32>(hi.z, lo.z)), uz));
    return r_add(s, real(vec2<f32>(hi.w, lo.w)));
}

@compute @workgroup_size(64)
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
    let n_az = pose.plan.y;
    // A workgroup past the chunk's poses draws nothing.
    let n = select(0u, n_az * pose.plan.w, pose_index < params.pose_count);
    let base_word = pose_index * params.words_per_pose;

    var visible = 0u;
    var r_min = 3.0e38;
    var r_max = -3.0e38;
    var az_min = 3.0e38;
    var az_max = -3.0e38;
    for (var k = wid.x * WORKGROUP + lid; k < n; k += nwg.x * WORKGROUP) {
        let a = directions[pose.plan.x + k % n_az];
        let e = directions[pose.plan.z + k / n_az];
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
        if !in_view(x, y, z, r2) {
            continue;
        }
        // reported values: f32 from the rounded point
        let r = sqrt(r_f32(r2));
        let az = atan2(r_f32(y), r_f32(x));
        let pixel = range_bin(r, r2) * params.beams + beam_of(x, y, az);
        let word = base_word + (pixel >> 5u);
        let mask = 1u << (pixel & 31u);
        if (atomicLoad(&bits[word]) & mask) == 0u {
            atomicOr(&bits[word], mask);
        }
        visible += 1u;
        r_min = min(r_min, r);
        r_max = max(r_max, r);
        az_min = min(az_min, az);
        az_max = max(az_max, az);
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
