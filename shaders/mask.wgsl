// Correspondence masks on the GPU, in f32: the same cells and balls as src/masks/ (read the two
// side by side). Blocks of cells are culled by their ball, then each cell's ball is marked. Each
// mask's bounds (its first and last range bin and beam) are kept as the spans are set. They are
// exactly what the CPU twin of the reduce stage finds walking the bits, so the reduce stage
// (mask_reduce.wgsl) reads only the rows between them. A slack the CPU adds to each job's radii
// (src/masks/gpu/mod.rs) absorbs every rounding error, so a mask can only grow, never miss a pixel.
// Beams are decided by the side of each beam edge the ball lies on (cross products, no
// trigonometry). The edges compared are walked to from a guess that an angle makes
// (edges_with_cross_above): the guess saves steps, the comparisons decide.
//
// Structs: keep in sync with src/masks/gpu/mod.rs. Sizes are asserted there, and the layout is
// checked in src/masks/gpu/source_tests.rs.

// MaskParams is shaders/shared/mask_params.wgsl, put before this file (src/masks/gpu/source.rs).

// One mask to draw: the rows of R with t in .w, and the set's range. Then the ball radius of a cell
// (cell + noise + rounding slack), and of a block of cells around its middle point (block + noise +
// rounding slack). Then the cell tables: offsets into dirs of the azimuth and elevation cells'
// directions. Each table is followed by the directions of its blocks' middles, one per block_a
// azimuths or 64 / block_a elevations. Last, block_a, the block's cells along the azimuth (64 /
// block_a along the elevation: src/masks/gpu/tables.rs, block_shape).
struct MaskJob {
    row0: vec4<f32>,
    row1: vec4<f32>,
    row2: vec4<f32>,
    range: f32,
    radius: f32,
    block_radius: f32,
    az_count: u32,
    el_count: u32,
    az_offset: u32,
    el_offset: u32,
    block_a: u32,
}

@group(0) @binding(0) var<uniform> params: MaskParams;
// Beam edges as (cos, sin), beams + 1 of them, increasing angle.
@group(0) @binding(1) var<storage, read> edges: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read> jobs: array<MaskJob>;
// Cell-centre and block-middle angles as (cos, sin), kept between pings (src/masks/gpu/tables.rs).
@group(0) @binding(3) var<storage, read> dirs: array<vec2<f32>>;
// One bitset of words_per_mask words per job, in sonar 2's layout (pixel i * beams + j).
@group(0) @binding(4) var<storage, read_write> bits: array<atomic<u32>>;
// Five words per job, zeroed before the pass, laid out as mask_reduce.wgsl's. This stage sets the
// bounds (words 1 to 4: !first range bin, last range bin, !first beam, last beam). The reduce stage
// adds the pixel count (word 0).
@group(0) @binding(5) var<storage, read_write> summaries: array<atomic<u32>>;

// The workgroup (CELLS threads) is one block of block_a x (CELLS / block_a) cells: BLOCK x BLOCK,
// unless the grid is thin along one axis. CELLS (BLOCK x BLOCK, from masks::plan::BLOCK) is
// generated and put before this file (src/masks/gpu/source.rs).

// Returns false only when no point within r of q lies in sonar 2's field of view. The twin of
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

// Returns the number of beam edges k with cross_k(q) > limit. Here cross_k = rho sin(az(q) - e_k)
// is the signed distance of q from edge k's line. These edges are a prefix of the edges while
// radius < rho cos(half_az): then |az(q) - e_k| stays below 180 deg - asin(radius / rho). The count
// is first guessed from `guess`, the angle az(q) - asin(limit / rho) the edges are compared with,
// on edges spread evenly from `first` (rad) by 1 / `per` (the beams' mean spacing). It is then
// walked to the exact count by the same comparisons a binary search makes. The guess only saves
// steps (a software adapter pays for each, all lanes together); it never changes the answer.
fn edges_with_cross_above(q: vec3<f32>, limit: f32, guess: f32, first: f32, per: f32) -> u32 {
    let n = params.beams + 1u;
    // Within 0..=n whatever the guess (NaN included: the comparison is false).
    let g = (guess - first) * per;
    var k = 0u;
    if g > 0.0 {
        k = u32(min(ceil(g), f32(n)));
    }
    loop {
        if k == 0u {
            break;
        }
        let e = edges[k - 1u];
        if e.x * q.y - e.y * q.x > limit {
            break;
        }
        k -= 1u;
    }
    loop {
        if k >= n {
            break;
        }
        let e = edges[k];
        if !(e.x * q.y - e.y * q.x > limit) {
            break;
        }
        k += 1u;
    }
    return k;
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
        // Neighbouring cells mostly mark pixels already marked. A load is cheaper than the
        // read-modify-write, which only runs when a bit is still missing.
        let at = base + k / 32u;
        if (atomicLoad(&bits[at]) & m) != m {
            atomicOr(&bits[at], m);
        }
        k += n;
    }
}

// Returns the point at range `range` in the direction of azimuth `a` and elevation `e` (cos, sin),
// moved into sonar 2 by the job's pose.
fn moved(job: MaskJob, a: vec2<f32>, e: vec2<f32>) -> vec3<f32> {
    let p = job.range * vec3<f32>(e.x * a.x, e.x * a.y, e.y);
    return vec3<f32>(
        dot(job.row0.xyz, p) + job.row0.w,
        dot(job.row1.xyz, p) + job.row1.w,
        dot(job.row2.xyz, p) + job.row2.w,
    );
}

// Marks the pixels of the ball of radius `r` around cell (ia, ie) of `job` in the mask at word
// `base`, when it may meet the view. `first` and `per` place the beam edges for the searches'
// guesses. `bounds` (first and last range bin, first and last beam) takes in the spans set. It uses
// nested conditions rather than early exits: a software adapter runs a workgroup's lanes together,
// and skips a branch only when no lane takes it.
fn draw_cell(job: MaskJob, base: u32, ia: u32, ie: u32, r: f32, first: f32, per: f32,
             bounds: ptr<function, vec4<u32>>) {
    let q = moved(job, dirs[job.az_offset + ia], dirs[job.el_offset + ie]);
    let d = length(q);
    if may_meet_view(q, d, r) {
        let lo = max(d - r, params.range_min);
        let hi = min(d + r, params.range_max);
        let last_bin = params.range_bins - 1u;
        let i0 = min(u32(max(floor((lo - params.range_min) * params.inv_range_bin), 0.0)), last_bin);
        let i1 = min(u32(max(floor((hi - params.range_min) * params.inv_range_bin), 0.0)), last_bin);
        var j0 = 0u;
        var j1 = 0u;
        var seen = true;
        if params.beamed == 1u {
            j1 = params.beams - 1u;
            let rho = length(q.xy);
            if r < rho * params.cos_half_az {
                // Beams from the one right of the last edge wholly left of the ball to the one
                // left of the first edge wholly right of it.
                let az = atan2(q.y, q.x);
                let half = asin(r / rho);
                let left = edges_with_cross_above(q, r, az - half, first, per);
                let not_right = edges_with_cross_above(q, -r, az + half, first, per);
                seen = left <= params.beams && not_right > 0u;
                j0 = max(left, 1u) - 1u;
                j1 = min(max(not_right, 1u), params.beams) - 1u;
            }
        }
        if seen {
            for (var i = i0; i <= i1; i++) {
                set_bits(base, i * params.beams + j0, i * params.beams + j1);
            }
            *bounds = vec4<u32>(min((*bounds).x, i0), max((*bounds).y, i1), min((*bounds).z, j0),
                                max((*bounds).w, j1));
        }
    }
}

// A workgroup per block of cells (blocks strided by the workgroups along x), a job per workgroup
// row (y). The block's ball is tested first. Every thread computes the same test, so the branch is
// uniform. When the ball may meet the view, each thread draws one cell.
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    // No span yet: the firsts above every bin and beam, the lasts at 0.
    var bounds = vec4<u32>(0xffffffffu, 0u, 0xffffffffu, 0u);
    let job = jobs[group.y];
    let block_e = CELLS / job.block_a;
    let blocks_a = (job.az_count + job.block_a - 1u) / job.block_a;
    let blocks = blocks_a * ((job.el_count + block_e - 1u) / block_e);
    let base = group.y * params.words_per_mask;
    let r = job.radius;
    // The beam edges' first angle and mean spacing, for the searches' first guesses.
    let first_edge = atan2(edges[0].y, edges[0].x);
    let per_edge = f32(params.beams) / (atan2(edges[params.beams].y, edges[params.beams].x) - first_edge);
    // The block's place and the thread's cell in it, stepped without a division a block (a software
    // adapter divides lane by lane).
    let lane_a = local % job.block_a;
    let lane_e = local / job.block_a;
    let step_a = groups.x % blocks_a;
    let step_e = groups.x / blocks_a;
    var ba = group.x % blocks_a;
    var be = group.x / blocks_a;
    var b = group.x;
    loop {
        if b >= blocks {
            break;
        }
        let middle = moved(job, dirs[job.az_offset + job.az_count + ba], dirs[job.el_offset + job.el_count + be]);
        let ia = ba * job.block_a + lane_a;
        let ie = be * block_e + lane_e;
        if ia < job.az_count && ie < job.el_count
            && may_meet_view(middle, length(middle), job.block_radius) {
            draw_cell(job, base, ia, ie, r, first_edge, per_edge, &bounds);
        }
        continuing {
            b += groups.x;
            ba += step_a;
            be += step_e;
            if ba >= blocks_a {
                ba -= blocks_a;
                be += 1u;
            }
        }
    }
    // The thread's bounds into the job's summary. The firsts are inverted, so that atomicMax finds
    // every bound.
    if bounds.x <= bounds.y {
        let at = group.y * 5u;
        atomicMax(&summaries[at + 1u], ~bounds.x);
        atomicMax(&summaries[at + 2u], bounds.y);
        atomicMax(&summaries[at + 3u], ~bounds.z);
        atomicMax(&summaries[at + 4u], bounds.w);
    }
}
