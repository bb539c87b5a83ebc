// Structs shared by every stage. Keep in sync with src/gpu/types.rs (sizes asserted there and
// checked against naga's layout in tests/shaders.rs).

// Sonar 2: field of view and data layout, f32, precomputed in f64 on the CPU.
struct TargetParams {
    range_min: f32,
    range_max: f32,
    range_min_sq: f32,
    range_max_sq: f32,
    // range_bins / (range_max - range_min)
    inv_range_bin: f32,
    range_bins: u32,
    beams: u32,
    // 1 when the beams split the aperture uniformly (direct index), 0 for explicit edges
    beams_uniform: u32,
    // azimuth clip: x sin(h) - |y| cos(h) >= 0  <=>  |az| <= h, for h in (0, pi]
    sin_half_az: f32,
    cos_half_az: f32,
    // elevation clip: |z| <= r sin(half elevation); 2.0 when the aperture is 180 deg
    sin_half_el: f32,
    half_az: f32,
    // beams / aperture (rad) for uniform beams
    inv_beam_width: f32,
    words_per_pose: u32,
    pose_count: u32,
    // 1 when the occupied measure is an area summed on the GPU (FLS); 0 for an SSS, whose
    // measure the CPU derives exactly from the count
    measure_area: u32,
}

// One pose of a chunk: rows of M = range * R * Rz(base azimuth), translation in .w, and the
// sample plan: (azimuth table offset, azimuth count, elevation table offset, elevation count).
struct Pose {
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    plan: vec4<u32>,
}

// A beam edge (angle, cos, sin in rad) and the width of the beam that starts at it.
struct BeamEdge {
    angle: f32,
    cos_angle: f32,
    sin_angle: f32,
    width: f32,
}

// Per-pose metric slots, 8 u32 each. Minima are stored as the bitwise NOT of the order key so
// that every slot starts at 0 and only atomicMax is needed.
const METRIC_STRIDE: u32 = 8u;
const METRIC_VISIBLE: u32 = 0u;
const METRIC_OCCUPIED: u32 = 1u;
const METRIC_RANGE_MIN_NOT: u32 = 2u;
const METRIC_RANGE_MAX: u32 = 3u;
const METRIC_AZIMUTH_MIN_NOT: u32 = 4u;
const METRIC_AZIMUTH_MAX: u32 = 5u;
const METRIC_MEASURE: u32 = 6u;

// Returns a u32 whose unsigned order is the order of the f32 x.
fn order_key(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    if (b & 0x80000000u) != 0u {
        return ~b;
    }
    return b | 0x80000000u;
}
