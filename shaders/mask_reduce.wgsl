// A ping's masks reduced on the GPU, so that a ping reads back their union and five words a feature
// instead of every bitset. Per mask: the pixels set, and the range-bin and beam bounds of its box.
// Also the union of all masks. Its CPU twin is masks::summary::mask_reduce (src/masks/summary.rs),
// which walks every word of a mask for its bounds. Here the draw stage (mask.wgsl) has already set
// them exactly, from the spans it set. So this stage reads only the words of the rows between them
// (a mask is a few rows of sonar 2's image), and adds the count and the union. It uses integer
// atomics only (add, or), so the result does not depend on the order the GPU runs in.
//
// MaskParams is shaders/shared/mask_params.wgsl, put before this file (src/masks/gpu/source.rs).

@group(0) @binding(0) var<uniform> params: MaskParams;
// The masks drawn by mask.wgsl: words_per_mask words each, pixel i * beams + j.
@group(0) @binding(1) var<storage, read> bits: array<u32>;
// Five words per mask, zeroed before the draw stage: pixels set (added here), !first range bin,
// last range bin, !first beam, last beam. The draw stage sets the bounds. The firsts are inverted
// so that one atomicMax finds every bound. A mask with no pixel keeps its zeros.
@group(0) @binding(2) var<storage, read_write> summaries: array<atomic<u32>>;
// The union of the ping's masks, zeroed before the pass.
@group(0) @binding(3) var<storage, read_write> union_bits: array<atomic<u32>>;

const WORKGROUP: u32 = 64u;

// A mask per workgroup row (y). The words of its rows are strided over the row's workgroups (x) and
// threads.
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let at = group.y * 5u;
    let first_row = ~atomicLoad(&summaries[at + 1u]);
    let last_row = atomicLoad(&summaries[at + 2u]);
    // The words holding pixels first_row * beams ..= last_row * beams + beams - 1. None for a mask
    // with no pixel: its first row reads as 0xffffffff.
    var start = 0u;
    var end = 0u;
    if first_row <= last_row {
        start = first_row * params.beams / 32u;
        end = min(((last_row + 1u) * params.beams + 31u) / 32u, params.words_per_mask);
    }
    let base = group.y * params.words_per_mask;
    var pixels = 0u;
    for (var w = start + group.x * WORKGROUP + local; w < end; w += groups.x * WORKGROUP) {
        let m = bits[base + w];
        if m != 0u {
            atomicOr(&union_bits[w], m);
            pixels += countOneBits(m);
        }
    }
    // Each thread's count goes straight into the mask's, with no workgroup barrier. A software
    // adapter pays for each barrier, and the threads that add are only those of the mask's few
    // rows.
    if pixels > 0u {
        atomicAdd(&summaries[at], pixels);
    }
}
