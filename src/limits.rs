//! Every size limit of the engine in one place. The applications keep theirs in
//! `sonarproj_apps::limits`. Each limit bounds something derived from input before it is
//! allocated, so that no input can exhaust memory or overflow a count. An input past a limit is
//! refused with a message naming the field, the value and the limit.

/// The longest range a sonar may have (m): 10 km covers every real sonar and keeps every
/// derived length, area and count far from overflow.
pub const MAX_RANGE: f64 = 10_000.0;
/// The largest translation between two sonars, per axis (m): 1 000 km. Two sonars of
/// [`MAX_RANGE`] share nothing beyond 20 km, and every squared length stays far from overflow.
pub const MAX_TRANSLATION: f64 = 1_000_000.0;
/// The largest standard deviation of an angle (deg): half a turn. A wider one means nothing.
pub const MAX_SIGMA_ANGLE: f64 = 180.0;
/// The largest standard deviation of a range (m): 1 000 km, a hundred times the longest range.
/// It keeps every sigma derived from it finite.
pub const MAX_SIGMA_RANGE: f64 = 1_000_000.0;
/// The largest cell of the projection area's grid (m): 20 km, a sonar image's widest extent
/// (twice [`MAX_RANGE`]); a larger cell is one cell still, and its area could overflow.
pub const MAX_AREA_GRID: f64 = 20_000.0;
/// The largest number of range bins a sonar may have.
pub const MAX_RANGE_BINS: u32 = 1 << 20;
/// The largest number of beams a sonar may have.
pub const MAX_BEAMS: u32 = 1 << 16;
/// The largest number of pixels (range bins × beams) a sonar image may have (an occupancy of
/// 8 MiB of bits).
pub const MAX_PIXELS: u64 = 1 << 26;
/// The most samples one pose may draw.
pub const MAX_SAMPLES_PER_POSE: u64 = 1 << 26;
/// The most cells of the projection-area grid over sonar 2's image (8 MiB of bits a pose).
pub const MAX_AREA_CELLS: u64 = 1 << 26;
/// The most cells one mask may visit.
pub const MAX_CELLS: u64 = 1 << 26;
/// The most points returned along an SSS + SSS recovery curve (the spacing grows past it).
pub const MAX_CURVE_POINTS: usize = 10_000;
/// The most poses one sweep may have (they are streamed in chunks, never held at once).
pub const MAX_POSES: u64 = 1 << 40;
/// The most values one sweep grid axis may take, held in memory at 8 bytes each. Grids reach
/// [`MAX_POSES`] through the product of their axes.
pub const MAX_AXIS_VALUES: u64 = 1_000_000;
/// The most features of one ping a mask engine takes (65 536). Their plans and results are held
/// together, so the caller splits a larger ping.
pub const MAX_PING_FEATURES: usize = 1 << 16;
/// The most bytes of masks as bitsets (one bit a pixel) that one call of the mask engine holds:
/// 1 GiB, whatever the sonar's size. Per-pixel counts add four bytes a pixel to each mask. A
/// call that would need more is refused, naming its features or its pings.
pub const MAX_MASK_BITSET_BYTES: u64 = 1 << 30;
/// The largest sonar file read (bytes): a sonar file is a few hundred bytes, one with
/// [`MAX_BEAMS`] beam edges about 1.5 MB.
pub const MAX_SONAR_FILE_BYTES: u64 = 4 << 20;
/// The most characters of input text (a column name, a field) an error quotes whole. Longer
/// text is cut and marked with its length.
pub const EXCERPT_CHARS: usize = 40;
/// The most characters of a value an error shows whole.
pub const MAX_VALUE_CHARS: usize = 200;

// The limits keep derived sizes far from overflow, checked when the crate compiles:
// - a whole image of bits fits in 8 MiB and a u32 word index;
// - sample and cell counts fit the GPU's u32 indices;
// - a sweep's pose index is exact in an f64 (CSV columns print it);
// - a square grid of full axes stays within a sweep.
const _: () = {
    assert!(MAX_PIXELS / 8 <= 8 << 20);
    assert!(MAX_PIXELS <= u32::MAX as u64);
    assert!(MAX_RANGE_BINS as u64 * MAX_BEAMS as u64 >= MAX_PIXELS);
    assert!(MAX_SAMPLES_PER_POSE <= u32::MAX as u64);
    assert!(MAX_CELLS <= u32::MAX as u64);
    assert!(MAX_AREA_CELLS / 8 <= 8 << 20);
    assert!(MAX_POSES < 1 << 53);
    assert!(MAX_AXIS_VALUES * MAX_AXIS_VALUES <= MAX_POSES);
};
