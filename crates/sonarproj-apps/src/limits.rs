//! The applications' size limits. The engine's own are in [`sonarproj::limits`]. Each bounds
//! something derived from input before it is allocated. Input past a limit is refused with a
//! message naming the field, the value and the limit.

use sonarproj::limits::MAX_POSES;

/// The most parts a sweep may be cut into.
pub const MAX_SHARDS: u64 = 100_000;
/// The most chunk files one sweep run or shard is cut into. Past it, use a larger
/// `--chunk-poses` or more shards.
pub const MAX_CHUNKS: u64 = 1_000_000;
/// The most poses of one sweep chunk (`--chunk-poses`, 2 097 152). A chunk's metrics, table and
/// summary values are held in memory together, about 0.5 KB a pose with rows; with chunks of
/// up to two row groups, two chunks are written while the next is computed, so up to three.
pub const MAX_CHUNK_POSES: u64 = 1 << 21;
/// The finest angle step of the paper's simulations (deg). It gives 18 001 angles, about a
/// billion poses a direction, run a block at a time in bounded memory.
pub const MIN_ANGLE_STEP: f64 = 0.01;
/// The most bytes of dense masks one Python call returns (1 GiB), at one byte a pixel a
/// feature plus four with counts. More features at once take the sparse form (runs).
pub const MAX_DENSE_MASK_BYTES: u64 = 1 << 30;
/// The longest sweep or advise file read (8 MiB: an axis of a million values listed one by one
/// fits; `{ start, stop, step }` takes a few bytes). A longer one, even a device or FIFO, is
/// refused after that many bytes. The TOML parser holds about a hundred times the file while it
/// reads it, so this bounds a run's memory to about 1 GB.
pub const MAX_CONFIG_BYTES: u64 = 8 << 20;
/// The most poses of a sweep's pose list (1 000 000), held in memory at about 1 KB a pose.
/// Split longer lists into several sweeps, or give a grid.
pub const MAX_LIST_POSES: usize = 1_000_000;
/// The most timed runs of one benchmark measurement.
pub const MAX_RUNS: u32 = 10_000;
/// The longest input line (a stream's JSON line) or CSV record read whole (1 MiB). A longer one
/// is refused before it is held in memory.
pub const MAX_LINE_BYTES: usize = 1 << 20;

// The largest sweep fits in a run's chunks, checked at compile time.
const _: () = assert!(MAX_POSES <= MAX_CHUNKS * MAX_CHUNK_POSES);
