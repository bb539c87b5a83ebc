// Stage 1: transform, clip, bin, splat. The CPU twin is src/projection/fast/, the same algorithm in
// f64, block culling included. The reference src/projection/reference/splat.rs stays plain. The
// decisions (field of view, bins, beams, culling, f32 slack) are those of the prelude
// shared/clip.wgsl. The transform and every decision use Real: f64, or double-f32 where the adapter
// has no f64 (shared/real_*.wgsl). So a sample lands where the f64 reference puts it, unless it
// lies within about 1e-12 (relative) of a bound or edge. With FILTER, f32 takes the decisions it
// cannot get wrong (those far from every bound and edge) and Real the rest. The bits are the same,
// with fewer Real operations. This helps this stage only: on a CPU, f64 costs at most twice f32.
// Dispatch (tiles, across, rows), across * rows >= poses. Workgroup (x, y, z) handles samples
// x*WORKGROUP + l, stepping by tiles*WORKGROUP, of pose y + z * across. Each visible sample sets
// its pixel's bit with atomicOr. The workgroup then folds its visible count and range/azimuth
// extremes into the pose's metric slots.

// Bindings 0-2 (params, beam_edges, range_edges_sq: sonar 2) are declared by shared/clip.wgsl,
// which is put before this file.
@group(0) @binding(3) var<storage, read> poses: array<Pose>;
// (cos hi, sin hi, cos lo, sin lo) of the plans' azimuth offsets and elevations. After each plan's
// elevations: one culling ball per block of BLOCK samples (centre xyz, radius w, f32), then per
// block the largest distance of its units from its chord (first unit to last), four an entry.
@group(0) @binding(4) var<storage, read> directions: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> bits: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> metrics: array<atomic<u32>>;

// Pipeline constants (gpu::SplatOptions). WORKGROUP: threads a workgroup, a multiple of BLOCK. CULL
// false draws every sample with every clip test. FILTER false decides every sample in Real; true
// decides first in f32 where it can (view_f32).
override WORKGROUP: u32 = 64u;
override CULL: bool = true;
override FILTER: bool = true;
override BLOCKS_PER_STEP: u32 = WORKGROUP / BLOCK;

var<workgroup> wg_side: array<u32, BLOCKS_PER_STEP>;

var<workgroup> wg_visible: atomic<u32>;
var<workgroup> wg_range_min_not: atomic<u32>;
var<workgroup> wg_range_max: atomic<u32>;
var<workgroup> wg_azimuth_min_not: atomic<u32>;
var<workgroup> wg_azimuth_max: atomic<u32>;

// Returns the unit direction of sample k of the pose's plan in f32, from the hi parts. It is within
// 4e-7 of the f64 unit, and the reaches are widened by that.
fn unit_f32(pose: Pose, k: u32) -> vec3<f32> {
    let a = directions[pose.plan.x + k % pose.plan.y];
    let e = directions[pose.plan.z + k / pose.plan.y];
    return vec3<f32>(e.x * a.x, e.x * a.y, e.y);
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

// Draws sample k of the pose: transform, clip (unless its block lies wholly inside), bins, and the
// pixel's bit in the pose's bitset. With FILTER, f32 decides first where it can (view_f32,
// range_bin_f32, beam_f32, with the pose's f32_slack). A hidden sample then costs no Real
// operation, and a decided one only the Real point its reported range and azimuth come from.
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
    if params.cell_words != 0u {
        set_cell(r, r_f32(x), r_f32(y), base_word);
    }
    return Drawn(true, r, az);
}

// Sets the projection-area cell of a visible sample at range r (f32) whose point has x, y (rounded
// to f32). The image point is (x, y) scaled to length r, or (r, 0) on the z axis, in f32. It is
// within clip.rs's CELL_SLACK of the f64 cell decision. CPU twin: AreaGrid::flat_cell.
fn set_cell(r: f32, x: f32, y: f32, base_word: u32) {
    let rho = sqrt(x * x + y * y);
    var cx = r;
    var cy = 0.0;
    if rho > 0.0 {
        cx = r * (x / rho);
        cy = r * (y / rho);
    }
    let i = u32(clamp(floor((cx - params.grid_x0) * params.inv_cell), 0.0, f32(params.grid_nx - 1u)));
    let j = u32(clamp(floor((cy - params.grid_y0) * params.inv_cell), 0.0, f32(params.grid_ny - 1u)));
    let cell = i * params.grid_ny + j;
    let word = base_word + params.pixel_words + (cell >> 5u);
    let mask = 1u << (cell & 31u);
    if (atomicLoad(&bits[word]) & mask) == 0u {
        atomicOr(&bits[word], mask);
    }
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

    let pose_index = wid.y + wid.z * nwg.y;
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
    // The workgroup takes WORKGROUP consecutive samples at a time, BLOCKS_PER_STEP blocks. The
    // first lanes decide the blocks' sides once and share them.
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
                        if chord_outside(pose, unit_f32(pose, b * BLOCK), unit_f32(pose, last), reach, slack) {
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
            // Slot-major: slot s of the chunk's pose p at s × pose_count + p.
            let n = params.pose_count;
            atomicAdd(&metrics[METRIC_VISIBLE * n + pose_index], seen);
            atomicMax(&metrics[METRIC_RANGE_MIN_NOT * n + pose_index], atomicLoad(&wg_range_min_not));
            atomicMax(&metrics[METRIC_RANGE_MAX * n + pose_index], atomicLoad(&wg_range_max));
            atomicMax(&metrics[METRIC_AZIMUTH_MIN_NOT * n + pose_index], atomicLoad(&wg_azimuth_min_not));
            atomicMax(&metrics[METRIC_AZIMUTH_MAX * n + pose_index], atomicLoad(&wg_azimuth_max));
        }
    }
}
