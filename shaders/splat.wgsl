// Stage 1: transform, clip, bin, splat. CPU mirror: src/cpu/splat.rs.
// Dispatch (tiles, poses, 1): workgroup (x, y) handles samples x*64 + l, stepping by tiles*64,
// of pose y. Each visible sample sets its pixel's bit with atomicOr; the workgroup then folds its
// visible count and range/azimuth extremes into the pose's metric slots.

@group(0) @binding(0) var<uniform> params: TargetParams;
@group(0) @binding(1) var<storage, read> beam_edges: array<BeamEdge>;
@group(0) @binding(2) var<storage, read> poses: array<Pose>;
// (cos, sin) of the plans' azimuth offsets and elevations
@group(0) @binding(3) var<storage, read> directions: array<vec2<f32>>;
@group(0) @binding(4) var<storage, read_write> bits: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> metrics: array<atomic<u32>>;

const WORKGROUP: u32 = 64u;

var<workgroup> wg_visible: atomic<u32>;
var<workgroup> wg_range_min_not: atomic<u32>;
var<workgroup> wg_range_max: atomic<u32>;
var<workgroup> wg_azimuth_min_not: atomic<u32>;
var<workgroup> wg_azimuth_max: atomic<u32>;

// Returns the range bin of r: floor((r - range_min) / width), clamped to the bins.
fn range_bin(r: f32) -> u32 {
    let i = floor((r - params.range_min) * params.inv_range_bin);
    return u32(clamp(i, 0.0, f32(params.range_bins - 1u)));
}

// Returns true when az(p) >= the edge's angle, for p within a beam or two of the edge:
// sin(az - e) * rho = y cos(e) - x sin(e), free of atan2's error.
fn at_or_above(p: vec3<f32>, e: BeamEdge) -> bool {
    return p.y * e.cos_angle - p.x * e.sin_angle >= 0.0;
}

// Returns the beam of p (inside the aperture): a first guess from atan2, then the exact side of
// the guessed beam's edges.
fn beam_of(p: vec3<f32>, az: f32) -> u32 {
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
    if j > 0 && !at_or_above(p, beam_edges[j]) {
        j -= 1;
    } else if j < beams - 1 && at_or_above(p, beam_edges[j + 1]) {
        j += 1;
    }
    return u32(j);
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
        let u = vec3<f32>(e.x * a.x, e.x * a.y, e.y);
        let p = vec3<f32>(
            dot(pose.m0.xyz, u) + pose.m0.w,
            dot(pose.m1.xyz, u) + pose.m1.w,
            dot(pose.m2.xyz, u) + pose.m2.w,
        );
        let r2 = dot(p, p);
        if !(r2 > 0.0 && r2 >= params.range_min_sq && r2 <= params.range_max_sq) {
            continue;
        }
        let r = sqrt(r2);
        if abs(p.z) > r * params.sin_half_el {
            continue;
        }
        if p.x * params.sin_half_az - abs(p.y) * params.cos_half_az < 0.0 {
            continue;
        }
        let az = atan2(p.y, p.x);
        let pixel = range_bin(r) * params.beams + beam_of(p, az);
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
