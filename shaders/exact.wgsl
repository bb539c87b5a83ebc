// Stage 1 of an exact call: each thread solves one pose's arc in closed form, with no samples. CPU
// twin: src/exact/fast.rs (Solver), the same steps in the same order; read them side by side:
// screen, cuts (quadratic_roots, quartic_roots), stationary, piece_inside, side_of, the pieces'
// extremes and the staircase of cells. Two steps differ in form, not in answer away from edges: a
// point's range bin and beam are decided as the splat stage decides them (shared/clip.wgsl:
// squared edges, and the sides of beam edges by cross products, where the CPU compares the range
// and the azimuth), and a staircase's bin and beam crossings are merged as two ordered streams
// (a range edge first on a tie), where the CPU sorts them together. The arc of a pose is q(s) = (u (1 - s^2) + 2 w s) / (1 + s^2)
// + t with s = tan(phi / 2): u and w are columns 0 and 2 of the pose's M (range * R * Rz(azimuth)),
// t its translation.
//
// It needs f64 (SHADER_F64): the roots are polished by Newton's method to about 1e-16, which
// double-f32 cannot hold. WGSL has no f64 trigonometry, so the two angles the CPU takes with atan
// (the visible fraction, from each run's half-angle, and the azimuths) come from fdlibm's atan,
// in shared/roots_f64.wgsl: a GPU's f32 atan may err by thousands of ulps (Vulkan allows 4096).
// Every number and decision (a piece in or out of view, a bin, a beam, the order of edge
// crossings) is computed in f64, from a pose and constants that arrive as f32 hi + lo pairs
// (about 1e-14 relative), so a decision within that of a tie may go the other way. The reported
// values are then rounded to f32, as every GPU metric.
//
// Writes the pose's metric slots: METRIC_VISIBLE holds the bits of the visible fraction (f32, 0
// exactly when nothing is seen), the extremes their order keys; and sets the bits of the cells the
// visible arc passes through, which the reduce stage counts. Dispatch (across, rows, 1) with
// across * rows * WORKGROUP >= poses: thread x + y * across * WORKGROUP solves that pose.

// Bindings 0-2 (params, beam_edges, range_edges_sq: sonar 2) are declared by shared/clip.wgsl,
// which is put before this file.
@group(0) @binding(3) var<storage, read> poses: array<Pose>;
// The solver's constants, built in f64 on the host (projection/gpu/tables.rs, exact_table), each a
// hi + lo pair: [0] tan(H/2), H (sonar 1's half elevation aperture); [1] cos H, sin H;
// [2] range_min^2 (0 without a minimum), range_max^2; [3] sin h, cos h (h half the azimuth
// aperture); [4] sin^2 e (e half the elevation aperture), 0, 0; [5] three flags (1 or 0): the
// field of view reaches behind sonar 2 (h >= pi/2), the azimuth clips (h < pi), the elevation clips
// (e < pi/2).
@group(0) @binding(4) var<storage, read> directions: array<vec4<f32>>;
// A pose's bitset and metric slots are its thread's alone: plain loads and stores, no atomics.
@group(0) @binding(5) var<storage, read_write> bits: array<u32>;
@group(0) @binding(6) var<storage, read_write> metrics: array<u32>;

// The arc (sonar 2's frame) and the solver's constants, set once a thread.
var<private> U: vec3<f64>;
var<private> W: vec3<f64>;
var<private> T: vec3<f64>;
var<private> END: f64;
var<private> HALF: f64;
var<private> COS_HALF: f64;
var<private> SIN_HALF: f64;
var<private> R2_MIN: f64;
var<private> R2_MAX: f64;
var<private> SH: f64;
var<private> CH: f64;
var<private> SE2: f64;
var<private> BEHIND: bool;
var<private> AZIMUTH: bool;
var<private> ELEVATION: bool;

// Which bounds an arc may cross (screen); MISS: it surely misses the field of view.
const CROSS_RANGE_MIN: u32 = 1u;
const CROSS_RANGE_MAX: u32 = 2u;
const CROSS_SIDE_POS: u32 = 4u;
const CROSS_SIDE_NEG: u32 = 8u;
const CROSS_ELEVATION: u32 = 16u;
const MISS: u32 = 0xffffffffu;

// The margin (relative) by which a bound must be missed over the whole arc for a cull.
fn cull_margin() -> f64 {
    return f64(1e-12);
}

// The fractions of a piece where its verdicts are taken (the middle first).
fn vote(k: u32) -> f64 {
    switch k {
        case 0u: { return f64(0.5); }
        case 1u: { return f64(0.309017); }
        default: { return f64(0.723607); }
    }
}

// (1 + s^2)(a + b cos phi + c sin phi) as the coefficients of 1, s, s^2.
fn quadratic(a: f64, b: f64, c: f64) -> vec3<f64> {
    return vec3<f64>(a + b, 2.0 * c, a - b);
}

fn dot3(a: vec3<f64>, b: vec3<f64>) -> f64 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// |q|^2 = a + b cos phi + c sin phi, as (a, b, c).
fn range_sq() -> vec3<f64> {
    return vec3<f64>(dot3(U, U) + dot3(T, T), 2.0 * dot3(T, U), 2.0 * dot3(T, W));
}

// Returns the least and the largest value of a + b cos phi + c sin phi over [-H, H].
fn bounds(a: f64, b: f64, c: f64) -> vec2<f64> {
    let m = sqrt(b * b + c * c);
    let e0 = a + b * COS_HALF - c * SIN_HALF;
    let e1 = a + b * COS_HALF + c * SIN_HALF;
    var hi = max(e0, e1);
    if b >= m * COS_HALF {
        hi = a + m;
    }
    var lo = min(e0, e1);
    if -b >= m * COS_HALF {
        lo = a - m;
    }
    return vec2<f64>(lo, hi);
}

fn surely_below(hi: f64, scale: f64) -> bool {
    return hi < -cull_margin() * scale;
}

fn surely_above(lo: f64, scale: f64) -> bool {
    return lo > cull_margin() * scale;
}

// Returns MISS when the arc surely misses the field of view, else which bounds it may cross
// (CROSS_*): from bounds of its range, its height and the azimuth's half-planes over the arc.
fn screen() -> u32 {
    let rs = range_sq();
    let r2 = bounds(rs.x, rs.y, rs.z);
    let scale = abs(rs.x) + sqrt(rs.y * rs.y + rs.z * rs.z);
    if surely_below(r2.y - R2_MIN, scale) || surely_above(r2.x - R2_MAX, scale) || r2.y <= 0.0 {
        return MISS;
    }
    var s = 0u;
    if R2_MIN > 0.0 && !surely_above(r2.x - R2_MIN, scale) {
        s |= CROSS_RANGE_MIN;
    }
    if !surely_below(r2.y - R2_MAX, scale) {
        s |= CROSS_RANGE_MAX;
    }
    if AZIMUTH {
        var missed = array<bool, 2>(false, false);
        for (var k = 0u; k < 2u; k++) {
            let side = select(f64(1.0), f64(-1.0), k == 1u);
            let fa = T.x * SH - side * T.y * CH;
            let fb = U.x * SH - side * U.y * CH;
            let fc = W.x * SH - side * W.y * CH;
            let b = bounds(fa, fb, fc);
            let sc = abs(fa) + sqrt(fb * fb + fc * fc);
            missed[k] = surely_below(b.y, sc);
            if !missed[k] && !surely_above(b.x, sc) {
                s |= select(CROSS_SIDE_POS, CROSS_SIDE_NEG, k == 1u);
            }
        }
        // Within pi/2 the bound is both half-planes; beyond, either.
        var miss = missed[0] && missed[1];
        if CH > 0.0 {
            miss = missed[0] || missed[1];
        }
        if miss {
            return MISS;
        }
    }
    if ELEVATION {
        let z = bounds(T.z, U.z, W.z);
        let z2_max = max(z.x * z.x, z.y * z.y);
        var z2_min = min(z.x * z.x, z.y * z.y);
        if z.x <= 0.0 && z.y >= 0.0 {
            z2_min = f64(0.0);
        }
        let sc = r2.y * SE2 + z2_max;
        if surely_below(r2.y * SE2 - z2_min, sc) {
            return MISS;
        }
        if !surely_above(r2.x * SE2 - z2_max, sc) {
            s |= CROSS_ELEVATION;
        }
    }
    return s;
}

// Returns the elevations (as s) where the arc may enter or leave the field of view, or cross
// sonar 2's x = 0 or y = 0 plane, with both ends; sorted, without repeats.
fn cuts(screened: u32) -> List {
    let lo = -END;
    let hi = END;
    var list = List(array<f64, 32>(), 0u);
    push(&list, lo);
    let rs = range_sq();
    if (screened & CROSS_RANGE_MIN) != 0u {
        push_roots(&list, quadratic(rs.x - R2_MIN, rs.y, rs.z), lo, hi);
    }
    if (screened & CROSS_RANGE_MAX) != 0u {
        push_roots(&list, quadratic(rs.x - R2_MAX, rs.y, rs.z), lo, hi);
    }
    let qx = quadratic(T.x, U.x, W.x);
    let qy = quadratic(T.y, U.y, W.y);
    let qz = quadratic(T.z, U.z, W.z);
    if BEHIND {
        push_roots(&list, qx, lo, hi);
        push_roots(&list, qy, lo, hi);
    }
    if AZIMUTH {
        if (screened & CROSS_SIDE_POS) != 0u {
            push_roots(&list, qx * SH - qy * CH, lo, hi);
        }
        if (screened & CROSS_SIDE_NEG) != 0u {
            push_roots(&list, qx * SH - (-qy) * CH, lo, hi);
        }
    }
    if ELEVATION && (screened & CROSS_ELEVATION) != 0u {
        // (1 + s^2)^2 (r^2 sin^2 e - z^2) = sin^2 e (1 + s^2) R(s) - Z(s)^2.
        let r = quadratic(rs.x, rs.y, rs.z);
        let r1 = array<f64, 5>(r.x, r.y, r.x + r.z, r.y, r.z);
        let z2 = array<f64, 5>(
            qz.x * qz.x,
            2.0 * qz.x * qz.y,
            qz.y * qz.y + 2.0 * qz.x * qz.z,
            2.0 * qz.y * qz.z,
            qz.z * qz.z,
        );
        var g: array<f64, 5>;
        for (var k = 0; k < 5; k++) {
            g[k] = SE2 * r1[k] - z2[k];
        }
        quartic_roots(&list, g, lo, hi, closed_form(qz));
    }
    push(&list, hi);
    sort(&list);
    return list;
}

fn add_turns(list: ptr<function, List>, c: vec3<f64>) {
    let g = closed_form(c);
    if g.ok0 && g.x0 > -END && g.x0 < END {
        (*list).v[(*list).n] = g.x0;
        (*list).n += 1u;
    }
    if g.ok1 && g.x1 > -END && g.x1 < END {
        (*list).v[(*list).n] = g.x1;
        (*list).n += 1u;
    }
}

// Returns the stationary points (as s) of the range and the azimuth over the arc, sorted.
fn stationary() -> List {
    var list = List(array<f64, 32>(), 0u);
    let rs = range_sq();
    // d|q|^2/dphi = -b sin phi + c cos phi.
    add_turns(&list, quadratic(f64(0.0), rs.z, -rs.y));
    add_turns(&list, quadratic(U.x * W.y - U.y * W.x, T.x * W.y - T.y * W.x, T.y * U.x - T.x * U.y));
    sort(&list);
    return list;
}

// Returns the point of the arc at s.
fn point(s: f64) -> vec3<f64> {
    let k = 1.0 / (1.0 + s * s);
    return U * ((1.0 - s * s) * k) + W * (2.0 * s * k) + T;
}

// Returns whether the arc's point at s lies in the field of view (x), and whether that verdict is
// clear (y): every bound held, or one failed, by more than 1e-9 of its terms. The point is taken
// times k = 1 + s^2.
fn inside_scaled(s: f64) -> vec2<bool> {
    let clear_by = f64(1e-9);
    let k = 1.0 + s * s;
    let q = U * (1.0 - s * s) + W * (2.0 * s) + T * k;
    let r2 = dot3(q, q);
    let k2 = k * k;
    let lo = R2_MIN * k2;
    let hi = R2_MAX * k2;
    var v = array<f64, 4>(r2 - lo, hi - r2, f64(1.0), f64(1.0));
    var m = array<f64, 4>(r2 + lo, hi + r2, f64(1.0), f64(1.0));
    if AZIMUTH {
        v[2] = q.x * SH - abs(q.y) * CH;
        m[2] = abs(q.x) + abs(q.y);
    }
    if ELEVATION {
        let z2 = q.z * q.z;
        v[3] = r2 * SE2 - z2;
        m[3] = r2 * SE2 + z2;
    }
    var inside = r2 > 0.0;
    var all_clear = true;
    var any_failed = false;
    for (var i = 0; i < 4; i++) {
        inside = inside && v[i] >= 0.0;
        all_clear = all_clear && v[i] > clear_by * m[i];
        any_failed = any_failed || v[i] < -clear_by * m[i];
    }
    var clear = r2 > 0.0 && any_failed;
    if inside {
        clear = all_clear;
    }
    return vec2<bool>(inside, clear);
}

// Returns whether the piece [a, b] is in view: a clear verdict at its middle, else three votes.
fn piece_inside(a: f64, b: f64) -> bool {
    let middle = inside_scaled(a + vote(0u) * (b - a));
    if middle.y {
        return middle.x;
    }
    let second = inside_scaled(a + vote(1u) * (b - a)).x;
    if middle.x == second {
        return second;
    }
    return inside_scaled(a + vote(2u) * (b - a)).x;
}

// Returns the sign of y along the piece [a, b]: that of whichever of the three vote points lies
// farthest from y = 0 (+1 when all lie on it, as the CPU's signum of 0).
fn side_of(a: f64, b: f64) -> f64 {
    var far = f64(0.0);
    for (var k = 0u; k < 3u; k++) {
        let y = point(a + vote(k) * (b - a)).y;
        if abs(y) > abs(far) {
            far = y;
        }
    }
    if far < 0.0 {
        return f64(-1.0);
    }
    return f64(1.0);
}

// Returns the azimuth (rad) of the point q as seen from a piece whose y has the sign of side: a
// point on the y = 0 plane behind sonar 2 reads +pi from y > 0 and -pi from y < 0.
fn azimuth_of(q: vec3<f64>, side: f64) -> f64 {
    if q.x >= 0.0 || side == 0.0 || q.y * side > 0.0 {
        return atan2_f64(q.y, q.x);
    }
    return select(-pi_hi(), pi_hi(), side > 0.0);
}

// Returns atan e - atan s, half the elevation from s to e (both in (-1, 1]), with one atan.
fn arc_angle(s: f64, e: f64) -> f64 {
    return atan_f64((e - s) / (1.0 + s * e));
}

// Sets cell (range bin i, beam j) in the bitset at base_word.
fn set_pixel(base_word: u32, i: u32, j: u32) {
    let pixel = i * params.beams + j;
    let word = base_word + (pixel >> 5u);
    bits[word] |= 1u << (pixel & 31u);
}

// Returns the end of [a, b] where the quadratic c is nearer 0.
fn nearer_end(c: vec3<f64>, a: f64, b: f64) -> f64 {
    let fa = abs((c.z * a + c.y) * a + c.x);
    let fb = abs((c.z * b + c.y) * b + c.x);
    return select(b, a, fa <= fb);
}

// Returns where in [a, b] the arc crosses range edge e (its first root, else the nearer end).
fn range_crossing(e: u32, a: f64, b: f64) -> f64 {
    let rs = range_sq();
    let c = quadratic(rs.x - real(range_edges_sq[e]), rs.y, rs.z);
    let r = quadratic_roots(c, a, b);
    if r.n > 0u {
        return r.x0;
    }
    return nearer_end(c, a, b);
}

// Returns where in [a, b] the arc crosses beam edge e: the root in front of sonar 2 of the plane
// through the edge, else the nearer end.
fn beam_crossing(e: u32, a: f64, b: f64) -> f64 {
    let se = real(beam_edges[e].sin_angle);
    let ce = real(beam_edges[e].cos_angle);
    let c = quadratic(T.x * se - T.y * ce, U.x * se - U.y * ce, W.x * se - W.y * ce);
    let r = quadratic_roots(c, a, b);
    for (var k = 0u; k < r.n; k++) {
        let s = select(r.x1, r.x0, k == 0u);
        let q = point(s);
        if q.x * ce + q.y * se > 0.0 {
            return s;
        }
    }
    return nearer_end(c, a, b);
}

// Sets the cells of the arc between two points where its range and azimuth are both monotone: at s
// = a in cell (i0, j0), at s = b in (i1, j1). Where both change, the bin and beam edges are crossed
// in the order of their roots (a range edge first on a tie, as the CPU's stable sort).
fn staircase(base_word: u32, a: f64, i0: u32, j0: u32, b: f64, i1: u32, j1: u32) {
    if i0 == i1 || j0 == j1 {
        for (var i = min(i0, i1); i <= max(i0, i1); i++) {
            for (var j = min(j0, j1); j <= max(j0, j1); j++) {
                set_pixel(base_word, i, j);
            }
        }
        return;
    }
    let up_i = i1 > i0;
    let up_j = j1 > j0;
    var i = i0;
    var j = j0;
    set_pixel(base_word, i, j);
    var ri = range_crossing(select(i, i + 1u, up_i), a, b);
    var rj = beam_crossing(select(j, j + 1u, up_j), a, b);
    // Each step crosses one edge: as many steps as bins and beams between the ends.
    let steps = max(i0, i1) - min(i0, i1) + max(j0, j1) - min(j0, j1);
    for (var step = 0u; step < steps; step++) {
        let more_i = i != i1;
        let more_j = j != j1;
        if more_i && (!more_j || ri <= rj) {
            i = select(i - 1u, i + 1u, up_i);
            if i != i1 {
                ri = range_crossing(select(i, i + 1u, up_i), a, b);
            }
        } else {
            j = select(j - 1u, j + 1u, up_j);
            if j != j1 {
                rj = beam_crossing(select(j, j + 1u, up_j), a, b);
            }
        }
        set_pixel(base_word, i, j);
    }
}

fn pair(v: vec4<f32>, second: bool) -> f64 {
    if second {
        return real(v.zw);
    }
    return real(v.xy);
}

// Sets the arc of pose p and the solver's constants.
fn load(p: u32) {
    let pose = poses[p];
    U = vec3<f64>(real(vec2<f32>(pose.hi0.x, pose.lo0.x)), real(vec2<f32>(pose.hi1.x, pose.lo1.x)), real(vec2<f32>(pose.hi2.x, pose.lo2.x)));
    W = vec3<f64>(real(vec2<f32>(pose.hi0.z, pose.lo0.z)), real(vec2<f32>(pose.hi1.z, pose.lo1.z)), real(vec2<f32>(pose.hi2.z, pose.lo2.z)));
    T = vec3<f64>(real(vec2<f32>(pose.hi0.w, pose.lo0.w)), real(vec2<f32>(pose.hi1.w, pose.lo1.w)), real(vec2<f32>(pose.hi2.w, pose.lo2.w)));
    END = pair(directions[0], false);
    HALF = pair(directions[0], true);
    COS_HALF = pair(directions[1], false);
    SIN_HALF = pair(directions[1], true);
    R2_MIN = pair(directions[2], false);
    R2_MAX = pair(directions[2], true);
    SH = pair(directions[3], false);
    CH = pair(directions[3], true);
    SE2 = pair(directions[4], false);
    BEHIND = directions[5].x != 0.0;
    AZIMUTH = directions[5].y != 0.0;
    ELEVATION = directions[5].z != 0.0;
}

// Threads a workgroup (gpu::EXACT_WORKGROUP): 64 on hardware, 1 on a software adapter. Observed
// on lavapipe (Mesa 22.3.6, which runs a workgroup's invocations as lanes of 8-wide SIMD loops):
// with 64, a pose's answer changed with the poses that shared its group (a batch of poses 56-63
// of one test lost most of pose 59's cells; pose 59 alone, with copies of itself, or with any one
// of the others, was right), although no invocation reads what another writes. With one
// invocation a workgroup every test pose agrees with the CPU twin. CI runs that setting; the
// hardware's 64 runs only where a real GPU runs the tests (scripts/gpu-remote.sh).
override WORKGROUP: u32 = 64u;

@compute @workgroup_size(WORKGROUP)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = gid.x + gid.y * groups.x * WORKGROUP;
    if p >= params.pose_count {
        return;
    }
    load(p);
    let screened = screen();
    if screened == MISS {
        return;
    }
    var cut = cuts(screened);
    var turns = stationary();
    let base_word = p * params.words_per_pose;
    let beams = params.beams > 1u;
    var range_min = f64(3.0e300);
    var range_max = f64(-3.0e300);
    var azimuth_min = f64(4.0);
    var azimuth_max = f64(-4.0);
    var length = f64(0.0);
    var run = false;
    var run_s = f64(0.0);
    var run_e = f64(0.0);
    for (var k = 0u; k + 1u < cut.n; k++) {
        let a = cut.v[k];
        let b = cut.v[k + 1u];
        if b > a && piece_inside(a, b) {
            // Touching visible pieces make one run of the arc: one atan for its length.
            if run && run_e == a {
                run_e = b;
            } else {
                if run {
                    length += arc_angle(run_s, run_e);
                }
                run = true;
                run_s = a;
                run_e = b;
            }
            var side = f64(0.0);
            if BEHIND {
                side = side_of(a, b);
            }
            // The piece's ends and inner turning points, in order: the range and the azimuth are
            // monotone between them, taken one by one from the turns.
            var prev_s = a;
            var prev_i = 0u;
            var prev_j = 0u;
            var lo_r = f64(3.0e300);
            var lo_r2 = f64(0.0);
            var hi_r = f64(-3.0e300);
            var hi_r2 = f64(0.0);
            for (var t = 0u; t < turns.n + 2u; t++) {
                var s = a;
                if t > 0u && t <= turns.n {
                    s = turns.v[t - 1u];
                } else if t > 0u {
                    s = b;
                }
                // An inner turning point, or the end, once each.
                let take = t == 0u || (s != prev_s && (t > turns.n || (s > a && s < b)));
                if take {
                    let q = point(s);
                    let r2 = dot3(q, q);
                    let r = sqrt(r2);
                    range_min = min(range_min, r);
                    range_max = max(range_max, r);
                    if r < lo_r {
                        lo_r = r;
                        lo_r2 = r2;
                    }
                    if r > hi_r {
                        hi_r = r;
                        hi_r2 = r2;
                    }
                    let az = azimuth_of(q, side);
                    azimuth_min = min(azimuth_min, az);
                    azimuth_max = max(azimuth_max, az);
                    if beams {
                        let i = range_bin(f32(r), r2);
                        let j = beam_of(q.x, q.y, f32(az));
                        if t > 0u {
                            staircase(base_word, prev_s, prev_i, prev_j, s, i, j);
                        }
                        prev_i = i;
                        prev_j = j;
                    }
                    prev_s = s;
                }
            }
            if !beams {
                let i1 = range_bin(f32(hi_r), hi_r2);
                for (var i = range_bin(f32(lo_r), lo_r2); i <= i1; i++) {
                    set_pixel(base_word, i, 0u);
                }
            }
        }
    }
    if !run {
        return;
    }
    var fraction = f32(1.0);
    if !(run_s == -END && run_e == END) {
        // phi = 2 atan s: each run's length over the arc's 2H.
        fraction = f32(min((length + arc_angle(run_s, run_e)) / HALF, f64(1.0)));
    }
    let n = params.pose_count;
    // Something is seen: the fraction's bits are never 0.
    metrics[METRIC_VISIBLE * n + p] = max(bitcast<u32>(fraction), 1u);
    metrics[METRIC_RANGE_MIN_NOT * n + p] = ~order_key(f32(range_min));
    metrics[METRIC_RANGE_MAX * n + p] = order_key(f32(range_max));
    metrics[METRIC_AZIMUTH_MIN_NOT * n + p] = ~order_key(f32(azimuth_min));
    metrics[METRIC_AZIMUTH_MAX * n + p] = order_key(f32(azimuth_max));
}
