// Stage 3 of a summaries-only grid sweep: one metric of each pose of the chunk, reduced on the
// device, so no per-pose metric is read back. CPU twin: SummarySpec::partial
// (crates/sonarproj-apps/src/sweep/summary/mod.rs), whose summaries these must equal byte for byte.
//
// A thread takes one pose (workgroup w, thread l: pose 256 w + l of the chunk). It derives the
// metric's value from the metric slots with the host's operations (f32 widened by integer
// operations; f64 add, sub and mul, correctly rounded; the visible fraction by an integer division
// rounded once), then:
// - counts it, bins it in the histogram and adds it to its cell of each marginal with 64-bit
//   atomics: counts, an exact fixed-point sum (128 bits as two words with a carry), the least and
//   greatest value as order keys. Integer addition, min and max are order-free, so the result does
//   not depend on which thread comes first. The workgroup adds up what would contend first: its
//   count, a histogram of at most SHARED_BINS bins, and a marginal's cell when all its values
//   fall in one, so each goes out in one atomic a workgroup;
// - sorts the workgroup's values twice (ascending, then descending; ties to the lower pose) and
//   writes the first `keep` of each order: every pose of the sweep's top k (and its extremes) is
//   among some workgroup's first k, so the host finds them among these candidates.
// Dispatch (across, rows, 1) over ceil(count / 256) workgroups.

struct SummaryParams {
    // sonar 2's range bin (m): an SSS's occupied measure is its count times this
    range_bin_width: f64,
    // the projection-area grid's cell side (m)
    cell: f64,
    // degrees per radian, as the host's f64::to_degrees multiplies
    degrees: f64,
    // the histogram's lower and upper edge
    histogram_min: f64,
    histogram_max: f64,
    // poses in this chunk
    count: u32,
    // which metric (a METRIC_ORDER_* constant)
    metric: u32,
    // 1: the exact stage's slots (the visible slot holds the visible fraction's f32 bits)
    exact: u32,
    // 1: sonar 2 is an SSS
    sss: u32,
    // 1: sonar 2 has a projection-area grid
    has_area: u32,
    // the histogram's bins (0: none)
    bins: u32,
    // marginals, each a MarginalGpu in the marginal table
    marginals: u32,
    // candidates each workgroup writes in each order
    keep: u32,
    // the chunk's first pose's index in the sweep (low and high word)
    first_lo: u32,
    first_hi: u32,
    // where the marginals' cells start among the accumulators (words)
    cells_at: u32,
    _pad: u32,
}

// One marginal: its first cell's number and its one or two axes, each a digit of the sweep's index:
// (index / stride) % len, weighted by weight in the cell's number.
struct MarginalGpu {
    cell_offset: u32,
    axes: u32,
    _pad0: u32,
    _pad1: u32,
    // per axis: stride (low, high word), len, weight
    digit: array<vec4<u32>, 2>,
}

@group(0) @binding(0) var<uniform> params: SummaryParams;
// the chunk's metric slots, slot-major (splat or exact, then reduce)
@group(0) @binding(1) var<storage, read> metrics: array<u32>;
// the chunk's poses (their plans give the samples drawn)
@group(0) @binding(2) var<storage, read> poses: array<Pose>;
// the histogram's bins + 1 edges, as the host computes them
@group(0) @binding(3) var<storage, read> edges: array<f64>;
@group(0) @binding(4) var<storage, read> marginal_table: array<MarginalGpu>;
// The block's accumulators (zero to start): [0] poses with a value, [1] NOT the first pose too
// large for exact sums, [2] below the histogram, [3] above it, [4, 4 + bins) the bins; from
// cells_at, five words a cell: count, sum (low, high word), NOT the least key, the greatest key.
@group(0) @binding(5) var<storage, read_write> acc: array<atomic<u64>>;
// Per workgroup, `keep` ascending candidates and then, after all workgroups', `keep` descending
// ones: (order key, pose index), key u64::MAX where the workgroup had no more values.
@group(0) @binding(6) var<storage, read_write> candidates: array<vec2<u64>>;

const WORKGROUP: u32 = 256u;
const NONE: u64 = 0xfffffffffffffffflu;
const SIGN: u64 = 0x8000000000000000lu;

// The metric's number: METRIC_ORDER_* (generated from the metric table, in its order).

// Histograms of at most this many bins are counted in the workgroup first.
const SHARED_BINS: u32 = 512u;
// A histogram bin number standing for below (and BELOW + 1 for above) the histogram.
const BELOW: u32 = 0xfffffffeu;
const ABOVE: u32 = 0xffffffffu;
const NO_CELL: u32 = 0xffffffffu;

// The candidates' sort, and the greatest key of a marginal's one-cell tree.
var<workgroup> sort_key: array<u64, 256>;
var<workgroup> sort_at: array<u32, 256>;
// The workgroup's poses with a value, and its histogram's bins (then below, above).
var<workgroup> seen: atomic<u32>;
var<workgroup> bin_count: array<atomic<u32>, 514>;
// A marginal's cells in the workgroup: the least and greatest, whether they are one.
var<workgroup> cell_least: atomic<u32>;
var<workgroup> cell_most: atomic<u32>;
var<workgroup> one_cell: u32;
// A marginal's one-cell tree: counts, 128-bit sums, NOT the least key.
var<workgroup> sum_count: array<u32, 256>;
var<workgroup> sum_low: array<u64, 256>;
var<workgroup> sum_high: array<u64, 256>;
var<workgroup> least_not: array<u64, 256>;

// Returns the f32 bits whose order key (shared/types.wgsl order_key) is k.
fn from_order_key(k: u32) -> u32 {
    return select(~k, k & 0x7fffffffu, (k & 0x80000000u) != 0u);
}

// Returns slot s of the chunk's pose p.
fn slot(s: u32, p: u32) -> u32 {
    return metrics[s * params.count + p];
}

// Returns a / b for 0 < a < b < 2^32, rounded once to nearest even: an integer long division.
fn fraction(a: u32, b: u32) -> f64 {
    let d = u64(b);
    var r = u64(a);
    // Skip to the first quotient bit: a / b >= 2^-32.
    var shift = 0u;
    loop {
        r <<= 1u;
        shift += 1u;
        if r >= d {
            break;
        }
    }
    // 53 bits of quotient, the first 1, then the rest.
    r -= d;
    var q = 1lu;
    for (var i = 0u; i < 52u; i++) {
        r <<= 1u;
        q <<= 1u;
        if r >= d {
            r -= d;
            q |= 1lu;
        }
    }
    // The round bit and whether anything is left below it.
    r <<= 1u;
    let round = r >= d;
    if round {
        r -= d;
    }
    if round && (r != 0lu || (q & 1lu) != 0lu) {
        q += 1lu;
    }
    // q is exact in f64 (at most 2^53); the power of two scales it exactly.
    return f64(q) * power_of_two(-i32(shift + 52u));
}

// Returns whether the chunk's pose p has a value of the metric, and the value (the host's
// MetricColumns, bit for bit).
fn value_of(p: u32) -> vec2<f64> {
    let m = params.metric;
    let visible = slot(METRIC_VISIBLE, p);
    // As the host's columns: extremes are none where nothing is seen.
    let seen = visible != 0u;
    let exact = params.exact != 0u;
    var has = true;
    var v = 0.0lf;
    switch m {
        case METRIC_ORDER_VISIBLE: {
            v = select(f64(visible), 0.0lf, exact);
        }
        case METRIC_ORDER_TOTAL, METRIC_ORDER_VISIBLE_FRACTION: {
            let plan = poses[p].plan;
            let total = plan.y * plan.w;
            if exact {
                v = select(0.0lf, widen(visible), m == METRIC_ORDER_VISIBLE_FRACTION);
            } else if m == METRIC_ORDER_TOTAL {
                v = f64(total);
            } else if total == 0u || visible == 0u {
                v = 0.0lf;
            } else if visible >= total {
                v = 1.0lf;
            } else {
                v = fraction(visible, total);
            }
        }
        case METRIC_ORDER_RANGE_MIN: {
            has = seen;
            v = widen(from_order_key(~slot(METRIC_RANGE_MIN_NOT, p)));
        }
        case METRIC_ORDER_RANGE_MAX: {
            has = seen;
            v = widen(from_order_key(slot(METRIC_RANGE_MAX, p)));
        }
        case METRIC_ORDER_SPAN: {
            let low = widen(from_order_key(~slot(METRIC_RANGE_MIN_NOT, p)));
            let high = widen(from_order_key(slot(METRIC_RANGE_MAX, p)));
            v = select(0.0lf, high - low, seen);
        }
        case METRIC_ORDER_AZIMUTH_MIN: {
            has = seen;
            v = widen(from_order_key(~slot(METRIC_AZIMUTH_MIN_NOT, p))) * params.degrees;
        }
        case METRIC_ORDER_AZIMUTH_MAX: {
            has = seen;
            v = widen(from_order_key(slot(METRIC_AZIMUTH_MAX, p))) * params.degrees;
        }
        case METRIC_ORDER_OCCUPIED: {
            v = f64(slot(METRIC_OCCUPIED, p));
        }
        case METRIC_ORDER_OCCUPIED_MEASURE: {
            if params.sss != 0u {
                v = f64(slot(METRIC_OCCUPIED, p)) * params.range_bin_width;
            } else {
                v = widen(slot(METRIC_OCCUPIED_MEASURE, p));
            }
        }
        default: {
            // the projection area: none without a grid, and none when solved exactly
            has = params.has_area != 0u && !exact;
            v = f64(slot(METRIC_PROJECTION_AREA, p)) * params.cell * params.cell;
        }
    }
    return vec2<f64>(select(0.0lf, 1.0lf, has), v);
}

// Returns the order key of v: keys compare as the IEEE total order does (f64::total_cmp).
fn key_of(v: f64) -> u64 {
    let b = bitcast<u64>(v);
    return select(b | SIGN, ~b, (b & SIGN) != 0lu);
}

// Returns whether v is a NaN.
fn is_nan(v: f64) -> bool {
    return (bitcast<u64>(v) & 0x7ffffffffffffffflu) > 0x7ff0000000000000lu;
}

// Returns the histogram bin of v within [min, max]: the last bin whose lower edge is at most v.
fn bin_of(v: f64) -> u32 {
    var low = 0u;
    var high = params.bins - 1u;
    while low < high {
        let mid = (low + high + 1u) / 2u;
        if edges[mid] <= v {
            low = mid;
        } else {
            high = mid - 1u;
        }
    }
    return low;
}

// Returns v * 2^40 rounded half away from zero, as the host's fixed-point term, and whether it is
// below 2^62 in size (else the host sums that block).
fn fixed_of(v: f64) -> vec2<i64> {
    let scaled = v * 1099511627776.0lf;
    if abs(scaled) >= 4611686018427387904.0lf {
        return vec2<i64>(0li, 0li);
    }
    let t = i64(scaled);
    let fraction = scaled - f64(t);
    var rounded = t;
    if fraction >= 0.5lf {
        rounded += 1li;
    } else if fraction <= -0.5lf {
        rounded -= 1li;
    }
    return vec2<i64>(rounded, 1li);
}

// Adds the value of key `key` and fixed-point term `term` to cell c.
fn add_to_cell(c: u32, key: u64, term: i64) {
    let at = params.cells_at + 5u * c;
    atomicAdd(&acc[at], 1lu);
    let low = bitcast<u64>(term);
    let old = atomicAdd(&acc[at + 1u], low);
    // The carry out of the low word, and the high word of the 128-bit two's complement term.
    let carry = select(0lu, 1lu, old + low < old);
    let high = select(0lu, NONE, term < 0li);
    if high + carry != 0lu {
        atomicAdd(&acc[at + 2u], high + carry);
    }
    atomicMax(&acc[at + 3u], ~key);
    atomicMax(&acc[at + 4u], key);
}

// Sorts the workgroup's (sort_key, sort_at) pairs ascending, bitonically.
fn sort(lid: u32) {
    for (var k = 2u; k <= WORKGROUP; k <<= 1u) {
        for (var j = k >> 1u; j > 0u; j >>= 1u) {
            let other = lid ^ j;
            if other > lid {
                let a = sort_key[lid];
                let b = sort_key[other];
                let ai = sort_at[lid];
                let bi = sort_at[other];
                let greater = a > b || (a == b && ai > bi);
                if greater == ((lid & k) == 0u) {
                    sort_key[lid] = b;
                    sort_key[other] = a;
                    sort_at[lid] = bi;
                    sort_at[other] = ai;
                }
            }
            workgroupBarrier();
        }
    }
}

// Adds this thread's value (when `has`: its key and fixed-point term) to its cell of marginal m.
// Where every value of the workgroup falls in one cell (a slow axis: the common case, and the one
// where threads would contend for the cell), the workgroup adds them up first and one thread
// adds the total. Else each thread adds its own.
fn add_to_marginal(m: u32, lid: u32, index: u64, has: bool, key: u64, term: i64) {
    let g = marginal_table[m];
    var c = NO_CELL;
    if has {
        c = g.cell_offset;
        for (var a = 0u; a < g.axes; a++) {
            let d = g.digit[a];
            let stride = u64(d.y) << 32u | u64(d.x);
            c += u32((index / stride) % u64(d.z)) * d.w;
        }
    }
    if lid == 0u {
        atomicStore(&cell_least, NO_CELL);
        atomicStore(&cell_most, 0u);
    }
    workgroupBarrier();
    if has {
        atomicMin(&cell_least, c);
        atomicMax(&cell_most, c);
    }
    workgroupBarrier();
    if lid == 0u {
        let least = atomicLoad(&cell_least);
        // 0: no value; 1: one cell; 2: several
        one_cell = select(select(2u, 1u, least == atomicLoad(&cell_most)), 0u, least == NO_CELL);
    }
    let shape = workgroupUniformLoad(&one_cell);
    if shape == 2u {
        if has {
            add_to_cell(c, key, term);
        }
        return;
    }
    if shape == 0u {
        return;
    }
    // One cell: a tree over the workgroup, the sum as 128 bits (low word, high word).
    sum_count[lid] = select(0u, 1u, has);
    sum_low[lid] = select(0lu, bitcast<u64>(term), has);
    sum_high[lid] = select(0lu, select(0lu, NONE, term < 0li), has);
    least_not[lid] = select(0lu, ~key, has);
    sort_key[lid] = select(0lu, key, has);
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride >>= 1u) {
        if lid < stride {
            let o = lid + stride;
            sum_count[lid] += sum_count[o];
            let low = sum_low[lid] + sum_low[o];
            sum_high[lid] += sum_high[o] + select(0lu, 1lu, low < sum_low[o]);
            sum_low[lid] = low;
            least_not[lid] = max(least_not[lid], least_not[o]);
            sort_key[lid] = max(sort_key[lid], sort_key[o]);
        }
        workgroupBarrier();
    }
    if lid == 0u {
        let at = params.cells_at + 5u * atomicLoad(&cell_least);
        atomicAdd(&acc[at], u64(sum_count[0]));
        let low = sum_low[0];
        let old = atomicAdd(&acc[at + 1u], low);
        let high = sum_high[0] + select(0lu, 1lu, old + low < old);
        if high != 0lu {
            atomicAdd(&acc[at + 2u], high);
        }
        atomicMax(&acc[at + 3u], least_not[0]);
        atomicMax(&acc[at + 4u], sort_key[0]);
    }
    workgroupBarrier();
}

@compute @workgroup_size(256)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let group = wid.x + wid.y * nwg.x;
    let p = group * WORKGROUP + lid;
    let groups = (params.count + WORKGROUP - 1u) / WORKGROUP;
    // A workgroup past the chunk's (the dispatch's rectangle) writes nothing.
    if group >= groups {
        return;
    }
    let first = u64(params.first_hi) << 32u | u64(params.first_lo);
    let index = first + u64(p);
    let small_histogram = params.bins <= SHARED_BINS;
    if lid == 0u {
        atomicStore(&seen, 0u);
    }
    for (var b = lid; b < SHARED_BINS + 2u; b += WORKGROUP) {
        atomicStore(&bin_count[b], 0u);
    }
    workgroupBarrier();
    var has = false;
    var key = NONE;
    var term = 0li;
    var exact = true;
    if p < params.count {
        let hv = value_of(p);
        let v = hv.y;
        has = hv.x != 0.0lf && !is_nan(v);
        key = key_of(v);
        if has {
            atomicAdd(&seen, 1u);
            if params.bins > 0u {
                // Below, above, or a bin: counted in the workgroup first when the bins are few.
                var b = BELOW;
                if v < params.histogram_min {
                    b = BELOW;
                } else if v > params.histogram_max {
                    b = ABOVE;
                } else {
                    b = bin_of(v);
                }
                if small_histogram {
                    atomicAdd(&bin_count[select(b, params.bins + b - BELOW, b >= BELOW)], 1u);
                } else {
                    atomicAdd(&acc[select(4u + b, 2u + b - BELOW, b >= BELOW)], 1lu);
                }
            }
            if params.marginals > 0u {
                let t = fixed_of(v);
                term = t.x;
                exact = t.y != 0li;
                if !exact {
                    atomicMax(&acc[1], ~index);
                }
            }
        }
    }
    workgroupBarrier();
    // The workgroup's counts go out once: poses with a value, and the histogram's bins.
    if lid == 0u {
        let n = atomicLoad(&seen);
        if n > 0u {
            atomicAdd(&acc[0], u64(n));
        }
    }
    if small_histogram && params.bins > 0u {
        for (var b = lid; b < params.bins + 2u; b += WORKGROUP) {
            let n = atomicLoad(&bin_count[b]);
            if n > 0u {
                atomicAdd(&acc[select(4u + b, 2u + b - params.bins, b >= params.bins)], u64(n));
            }
        }
    }
    for (var m = 0u; m < params.marginals; m++) {
        add_to_marginal(m, lid, index, has && exact, key, term);
    }
    // The candidates: ascending by key, then by descending value (the key's complement); ties and
    // poses without a value (NONE) go by their place.
    let keep = params.keep;
    sort_key[lid] = select(NONE, key, has);
    sort_at[lid] = lid;
    workgroupBarrier();
    sort(lid);
    let base = u64(group * WORKGROUP) + first;
    if lid < keep {
        let k = sort_key[lid];
        candidates[group * keep + lid] = vec2<u64>(k, base + u64(sort_at[lid]));
    }
    workgroupBarrier();
    sort_key[lid] = select(NONE, ~key, has);
    sort_at[lid] = lid;
    workgroupBarrier();
    sort(lid);
    if lid < keep {
        let k = sort_key[lid];
        candidates[(groups + group) * keep + lid] =
            vec2<u64>(select(NONE, ~k, k != NONE), base + u64(sort_at[lid]));
    }
}
