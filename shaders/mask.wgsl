// Correspondence masks on the GPU: the same cells and balls as src/masks/ (read the two side by
// side), in f32. Every rounding error is absorbed by a slack the CPU adds to each job's radius
// (src/masks/gpu.rs), so a mask can only grow, never miss a pixel; beams are found without
// trigonometry by the side of each beam edge the ball lies on.
//
// Structs: keep in sync with src/masks/gpu.rs (sizes asserted there, layout checked in
// src/gpu/shader_tests.rs).

struct MaskParams {
    range_min: f32,
    range_max: f32,
    // range_bins / (range_max - range_min)
    inv_range_bin: f32,
    range_bins: u32,
    beams: u32,
    words_per_mask: u32,
    _pad0: u32,
    // 1 when sonar 2 has more than one beam (an FLS, or a two-sided sidescan), 0 for range
    // bins only
    beamed: u32,
    // tan of half the elevation aperture; < 0 when the aperture is 180 deg (no test)
    tan_half_el: f32,
    // tan of half the azimuth aperture (< 90 deg: checked on the CPU)
    tan_half_az: f32,
    // cos of half the azimuth aperture: the edge search holds while radius < rho cos(half_az)
    cos_half_az: f32,
    _pad: f32,
}

// One mask to draw: the rows of R with t in .w, the set's range, the ball radius (cell + noise +
// rounding slack), the cell tables (offsets into dirs: azimuth cells, then elevation cells) and
// the blocks of BLOCK x BLOCK cells that survived the CPU's cull (MaskEngine::blocks).
struct MaskJob {
    row0: vec4<f32>,
    row1: vec4<f32>,
    row2: vec4<f32>,
    range: f32,
    radius: f32,
    az_count: u32,
    el_count: u32,
    az_offset: u32,
    el_offset: u32,
    block_offset: u32,
    block_count: u32,
}

@group(0) @binding(0) var<uniform> params: MaskParams;
// Beam edges as (cos, sin), beams + 1 of them, increasing angle.
@group(0) @binding(1) var<storage, read> edges: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read> jobs: array<MaskJob>;
// Cell-centre angles as (cos, sin).
@group(0) @binding(3) var<storage, read> dirs: array<vec2<f32>>;
// First cells (azimuth, elevation) of the surviving blocks.
@group(0) @binding(4) var<storage, read> blocks: array<vec2<u32>>;
@group(0) @binding(5) var<storage, read_write> bits: array<atomic<u32>>;

const WORKGROUP: u32 = 64u;
// BLOCK, the cells per block side (masks::plan::BLOCK), is generated and put before this file
// (src/gpu/shaders.rs).

// Returns false only when no point within r of q lies in sonar 2's field of view: the twin of
// clip::View::may_meet (src/clip.rs).
fn may_meet_view(q: vec3<f32>, d: f32, r: f32) -> bool {
    if d - r > params.range_max || d + r < params.range_min {
        return false;
    }
    let rho = length(q.xy);
    if params.tan_half_el >= 0.0 && abs(q.z) > params.tan_half_el * (rho + r) + r {
        return false;
    }
    if q.x + r < 0.0 || abs(q.y) > params.tan_half_az * (q.x + r) + r {
        return false;
    }
    return true;
}

// Returns the number of beam edges k with cross_k(q) > limit, where cross_k = rho sin(az(q) - e_k)
// is the signed distance of q from edge k's line: a prefix of the edges while
// radius < rho cos(half_az) (then |az(q) - e_k| stays below 180 deg - asin(radius / rho)).
fn edges_with_cross_above(q: vec3<f32>, limit: f32) -> u32 {
    var lo = 0u;
    var hi = params.beams + 1u;
    loop {
        if lo >= hi {
            break;
        }
        let mid = (lo + hi) / 2u;
        let e = edges[mid];
        if e.x * q.y - e.y * q.x > limit {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// Sets bits first..=last of the mask that starts at word `base`.
fn set_bits(base: u32, first: u32, last: u32) {
    var k = first;
    loop {
        if k > last {
            break;
        }
        let b = k % 32u;
        let n = min(32u - b, last - k + 1u);
        var m = 0xffffffffu;
        if n < 32u {
            m = ((1u << n) - 1u) << b;
        }
        atomicOr(&bits[base + k / 32u], m);
        k += n;
    }
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let job = jobs[gid.y];
    let cells = job.block_count * BLOCK * BLOCK;
    let stride = groups.x * WORKGROUP;
    let base = gid.y * params.words_per_mask;
    let r = job.radius;
    for (var c = gid.x; c < cells; c += stride) {
        let block = blocks[job.block_offset + c / (BLOCK * BLOCK)];
        let w = c % (BLOCK * BLOCK);
        let ia = block.x + w % BLOCK;
        let ie = block.y + w / BLOCK;
        if ia >= job.az_count || ie >= job.el_count {
            continue;
        }
        let a = dirs[job.az_offset + ia];
        let e = dirs[job.el_offset + ie];
        let p = job.range * vec3<f32>(e.x * a.x, e.x * a.y, e.y);
        let q = vec3<f32>(
            dot(job.row0.xyz, p) + job.row0.w,
            dot(job.row1.xyz, p) + job.row1.w,
            dot(job.row2.xyz, p) + job.row2.w,
        );
        let d = length(q);
        if !may_meet_view(q, d, r) {
            continue;
        }
        let lo = max(d - r, params.range_min);
        let hi = min(d + r, params.range_max);
        let last_bin = params.range_bins - 1u;
        let i0 = min(u32(max(floor((lo - params.range_min) * params.inv_range_bin), 0.0)), last_bin);
        let i1 = min(u32(max(floor((hi - params.range_min) * params.inv_range_bin), 0.0)), last_bin);
        var j0 = 0u;
        var j1 = 0u;
        if params.beamed == 1u {
            j1 = params.beams - 1u;
            let rho = length(q.xy);
            if r < rho * params.cos_half_az {
                // Beams from the one right of the last edge wholly left of the ball to the one
                // left of the first edge wholly right of it.
                let left = edges_with_cross_above(q, r);
                let not_right = edges_with_cross_above(q, -r);
                if left > params.beams || not_right == 0u {
                    continue;
                }
                j0 = max(left, 1u) - 1u;
                j1 = min(not_right, params.beams) - 1u;
            }
        }
        for (var i = i0; i <= i1; i++) {
            set_bits(base, i * params.beams + j0, i * params.beams + j1);
        }
    }
}
