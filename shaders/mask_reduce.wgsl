// A ping's masks reduced on the GPU, so that a ping reads back their union and five words a
// feature instead of every bitset: per mask the pixels set and the range-bin and beam bounds of
// its box, and the union of all masks. Its CPU twin is masks::summary::mask_reduce
// (src/masks/summary.rs): read the two side by side. Integer atomics only (add, max, or), so
// the result does not depend on the order the GPU runs in.
//
// MaskParams is shaders/shared/mask_params.wgsl, put before this file (src/gpu/shaders.rs).

@group(0) @binding(0) var<uniform> params: MaskParams;
// The masks drawn by mask.wgsl: words_per_mask words each, pixel i * beams + j.
@group(0) @binding(1) var<storage, read> bits: array<u32>;
// Five words per mask, zeroed before the pass: pixels set, !first range bin, last range bin,
// !first beam, last beam (the firsts inverted so that one atomicMax finds every bound; a mask
// with no pixel keeps its zeros).
@group(0) @binding(2) var<storage, read_write> summaries: array<atomic<u32>>;
// The union of the ping's masks, zeroed before the pass.
@group(0) @binding(3) var<storage, read_write> union_bits: array<atomic<u32>>;

const WORKGROUP: u32 = 64u;

var<workgroup> group_sums: array<atomic<u32>, 5>;

// A mask per workgroup row (y); its words strided over the row's workgroups (x) and threads.
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    if local < 5u {
        atomicStore(&group_sums[local], 0u);
    }
    workgroupBarrier();
    let base = group.y * params.words_per_mask;
    var pixels = 0u;
    var first_row = 0xffffffffu;
    var last_row = 0u;
    var first_beam = 0xffffffffu;
    var last_beam = 0u;
    for (var w = group.x * WORKGROUP + local; w < params.words_per_mask; w += groups.x * WORKGROUP) {
        var m = bits[base + w];
        if m == 0u {
            continue;
        }
        atomicOr(&union_bits[w], m);
        pixels += countOneBits(m);
        // The word's bits row by row: the first set pixel's row, the bits of that row, their
        // first and last beams; then the rest of the word.
        loop {
            if m == 0u {
                break;
            }
            let first = w * 32u + firstTrailingBit(m);
            let row = first / params.beams;
            var in_row = m;
            let next_row = (row + 1u) * params.beams;
            if next_row < w * 32u + 32u {
                in_row = m & ((1u << (next_row - w * 32u)) - 1u);
            }
            let last = w * 32u + firstLeadingBit(in_row);
            first_row = min(first_row, row);
            last_row = max(last_row, row);
            first_beam = min(first_beam, first - row * params.beams);
            last_beam = max(last_beam, last - row * params.beams);
            m = m & ~in_row;
        }
    }
    if pixels > 0u {
        atomicAdd(&group_sums[0], pixels);
        atomicMax(&group_sums[1], ~first_row);
        atomicMax(&group_sums[2], last_row);
        atomicMax(&group_sums[3], ~first_beam);
        atomicMax(&group_sums[4], last_beam);
    }
    workgroupBarrier();
    if local == 0u {
        let total = atomicLoad(&group_sums[0]);
        if total > 0u {
            let at = group.y * 5u;
            atomicAdd(&summaries[at], total);
            atomicMax(&summaries[at + 1u], atomicLoad(&group_sums[1]));
            atomicMax(&summaries[at + 2u], atomicLoad(&group_sums[2]));
            atomicMax(&summaries[at + 3u], atomicLoad(&group_sums[3]));
            atomicMax(&summaries[at + 4u], atomicLoad(&group_sums[4]));
        }
    }
}
