// Structs shared by the projection stages. Keep in sync with src/projection/gpu/types.rs. Sizes are
// asserted there and checked against naga's layout in src/projection/gpu/source_tests.rs.

// Sonar 2: field of view and data layout, precomputed in f64 on the CPU. vec2<f32> fields hold a
// value as hi + lo (about 48 significant bits), read through real() (shared/real_*.wgsl). Every
// in/out and bin decision compares such Real quantities, without trigonometry. The f32 scalars only
// serve first guesses and the reported values.
struct TargetParams {
    range_min: f32,
    range_max: f32,
    // range_bins / (range_max - range_min)
    inv_range_bin: f32,
    half_az: f32,
    // beams / aperture (rad) for uniform beams
    inv_beam_width: f32,
    range_bins: u32,
    beams: u32,
    // 1 when the beams split the aperture uniformly (direct guess), 0 for explicit edges
    beams_uniform: u32,
    words_per_pose: u32,
    pose_count: u32,
    // 1 when the occupied measure is an area summed on the GPU (FLS). 0 for an SSS, whose measure
    // the CPU derives exactly from the count.
    measure_area: u32,
    // 0 when the elevation aperture is 180 deg (nothing to clip)
    clip_elevation: u32,
    range_min_sq: vec2<f32>,
    range_max_sq: vec2<f32>,
    // azimuth clip: x sin(h) - |y| cos(h) >= 0  <=>  |az| <= h, for h in (0, pi]
    sin_half_az: vec2<f32>,
    cos_half_az: vec2<f32>,
    // elevation clip: z^2 cos^2(e) <= (x^2 + y^2) sin^2(e)  <=>  |el| <= e < 90 deg
    sin2_half_el: vec2<f32>,
    cos2_half_el: vec2<f32>,
    // the projection-area grid (FLS): corner (m), 1 / cell (1/m), cells along x and y
    grid_x0: f32,
    grid_y0: f32,
    inv_cell: f32,
    grid_nx: u32,
    grid_ny: u32,
    // a pose's bitset: pixel_words words of pixels, then cell_words words of grid cells (0 without
    // a grid: an SSS)
    pixel_words: u32,
    cell_words: u32,
    _pad: u32,
}

// One pose of a chunk: rows of M = range * R * Rz(base azimuth) with the translation in .w, as hi +
// lo pairs computed in f64 on the CPU. Then the sample plan: (azimuth table offset, azimuth count,
// elevation table offset, elevation count).
struct Pose {
    hi0: vec4<f32>,
    hi1: vec4<f32>,
    hi2: vec4<f32>,
    lo0: vec4<f32>,
    lo1: vec4<f32>,
    lo2: vec4<f32>,
    plan: vec4<u32>,
}

// A beam edge: its angle (rad, f32 for the first guess), the width of the beam that starts at it,
// and its cos and sin as hi + lo pairs.
struct BeamEdge {
    angle: f32,
    width: f32,
    cos_angle: vec2<f32>,
    sin_angle: vec2<f32>,
    _pad: vec2<f32>,
}

// The per-pose metric slots are generated from the metric table (src/metrics.rs) and put before
// this file (src/projection/gpu/source.rs). There are METRIC_STRIDE of them: METRIC_<NAME> for each
// metric the GPU reduces, with _NOT for minima. The metrics buffer is slot-major: slot s of a
// chunk's pose p is word s × pose_count + p. So the host copies back only the slots of the metrics
// it asks for, each one contiguous. Minima are stored as the bitwise NOT of the order key, so that
// every slot starts at 0 and only atomicMax is needed.

// Returns a u32 whose unsigned order is the order of the f32 x.
fn order_key(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    if (b & 0x80000000u) != 0u {
        return ~b;
    }
    return b | 0x80000000u;
}
