// Stage 2: one pose's bitset becomes its occupied count and occupied measure, and its
// projection-area cells (FLS) their count. CPU twin: the reduce step of
// src/projection/fast/scratch.rs, which sums counts and, for an FLS, per-row areas in row order.
// The plain reference is src/projection/reference/reduce.rs. Dispatch (across, rows, 1), across *
// rows >= poses. Workgroup (x, y) reduces pose x + y * across. Each thread takes words (SSS) or
// range rows (FLS) l, l + 64, ..., and the workgroup sums their results.

@group(0) @binding(0) var<uniform> params: TargetParams;
@group(0) @binding(1) var<storage, read> beam_edges: array<BeamEdge>;
// (r_{i+1}^2 - r_i^2) / 2 per range bin (read only when params.measure_area is 1)
@group(0) @binding(2) var<storage, read> row_weights: array<f32>;
@group(0) @binding(3) var<storage, read> bits: array<u32>;
@group(0) @binding(4) var<storage, read_write> metrics: array<u32>;

const WORKGROUP: u32 = 64u;

var<workgroup> partial_count: array<u32, 64>;
var<workgroup> partial_measure: array<f32, 64>;
var<workgroup> partial_cells: array<u32, 64>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let pose_index = wid.x + wid.y * nwg.x;
    let base_word = pose_index * params.words_per_pose;
    let beams = params.beams;
    var count = 0u;
    var measure = 0.0;
    // A workgroup past the chunk's poses reads and writes nothing.
    let valid = pose_index < params.pose_count;
    if params.measure_area == 0u {
        // SSS: the count is all. The CPU derives the measure from it exactly.
        let words = select(0u, params.pixel_words, valid);
        for (var w = lid; w < words; w += WORKGROUP) {
            count += countOneBits(bits[base_word + w]);
        }
    } else {
        // FLS: per range row, the occupied pixels' count (uniform beams) or summed beam widths,
        // times the row's area weight.
        let rows = select(0u, params.range_bins, valid);
        for (var i = lid; i < rows; i += WORKGROUP) {
            // pixels [first, last) of row i
            let first = i * beams;
            let last = first + beams;
            var row_count = 0u;
            var row_width = 0.0;
            for (var w = first >> 5u; w <= (last - 1u) >> 5u; w++) {
                var word = bits[base_word + w];
                let lo = w << 5u;
                if first > lo {
                    word &= ~0u << (first - lo);
                }
                if last < lo + 32u {
                    word &= (1u << (last - lo)) - 1u;
                }
                row_count += countOneBits(word);
                if params.beams_uniform == 0u {
                    while word != 0u {
                        let b = firstTrailingBit(word);
                        row_width += beam_edges[lo + b - first].width;
                        word &= word - 1u;
                    }
                }
            }
            if params.beams_uniform != 0u {
                row_width = f32(row_count) * beam_edges[0].width;
            }
            count += row_count;
            measure += row_width * row_weights[i];
        }
    }
    var cells = 0u;
    let cell_words = select(0u, params.cell_words, valid);
    for (var w = lid; w < cell_words; w += WORKGROUP) {
        cells += countOneBits(bits[base_word + params.pixel_words + w]);
    }
    partial_count[lid] = count;
    partial_measure[lid] = measure;
    partial_cells[lid] = cells;
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride >>= 1u) {
        if lid < stride {
            partial_count[lid] += partial_count[lid + stride];
            partial_measure[lid] += partial_measure[lid + stride];
            partial_cells[lid] += partial_cells[lid + stride];
        }
        workgroupBarrier();
    }
    if lid == 0u && pose_index < params.pose_count {
        // Slot-major: slot s of the chunk's pose p at s × pose_count + p.
        let n = params.pose_count;
        metrics[METRIC_OCCUPIED * n + pose_index] = partial_count[0];
        metrics[METRIC_OCCUPIED_MEASURE * n + pose_index] = bitcast<u32>(partial_measure[0]);
        metrics[METRIC_PROJECTION_AREA * n + pose_index] = partial_cells[0];
    }
}
