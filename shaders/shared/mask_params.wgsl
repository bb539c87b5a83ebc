// Sonar 2 as both mask stages see it (mask.wgsl draws, mask_reduce.wgsl reduces). Keep in sync with
// MaskParams in src/masks/gpu/mod.rs. Size and offsets are checked in
// src/masks/gpu/source_tests.rs.
struct MaskParams {
    range_min: f32,
    range_max: f32,
    // range_bins / (range_max - range_min)
    inv_range_bin: f32,
    range_bins: u32,
    beams: u32,
    words_per_mask: u32,
    _pad0: u32,
    // 1 when sonar 2 has more than one beam (an FLS, or a two-sided sidescan), 0 for range bins
    // only
    beamed: u32,
    // tan of half the elevation aperture; < 0 when the aperture is 180 deg (no test)
    tan_half_el: f32,
    // tan of half the azimuth aperture (< 90 deg: checked on the CPU)
    tan_half_az: f32,
    // cos of half the azimuth aperture: the edge search holds while radius < rho cos(half_az)
    cos_half_az: f32,
    _pad: f32,
}
