//! The size limits of the applications (sweep files and runs, the paper's simulations, the
//! benchmarks, line-based inputs, the Python package's dense masks); the engine's own are in
//! [`sonarproj::limits`]. Each bounds something derived from input before it is allocated; an
//! input past a limit is refused with a message naming the field, the value and the limit.

use sonarproj::limits::MAX_POSES;

/// The most parts a sweep may be cut into.
pub const MAX_SHARDS: u64 = 100_000;
/// The most chunk files one sweep run (or shard) is cut into: a larger `--chunk-poses` or more
/// shards beyond it.
pub const MAX_CHUNKS: u64 = 1_000_000;
/// The most poses of one sweep chunk (`--chunk-poses`, 2 097 152): a chunk's metrics, table and
/// summary values are held in memory together (about 0.5 KB a pose with rows).
pub const MAX_CHUNK_POSES: u64 = 1 << 21;
/// The finest angle step of the paper's simulations (deg): 18 001 angles, about 3 million poses
/// a direction, whose results are held in memory.
pub const MIN_ANGLE_STEP: f64 = 0.01;
/// The most bytes of dense masks (one byte a pixel a feature, four more with counts) one call of
/// the Python package returns: 1 GiB. More features at once take the sparse form (runs).
pub const MAX_DENSE_MASK_BYTES: u64 = 1 << 30;
/// The longest sweep or advise file read (64 MiB): a longer one is refused after that many bytes
/// (a device or FIFO included).
pub const MAX_CONFIG_BYTES: u64 = 64 << 20;
/// The most poses of a sweep's pose list (1 000 000): the list is held in memory (about 1 KB a
/// pose); longer lists are split into several sweeps, or given as a grid.
pub const MAX_LIST_POSES: usize = 1_000_000;
/// The most timed runs of one benchmark measurement.
pub const MAX_RUNS: u32 = 10_000;
/// The longest input line (a stream's JSON line) or CSV record read whole (1 MiB): a longer one
/// is refused before it is held in memory.
pub const MAX_LINE_BYTES: usize = 1 << 20;

// The largest sweep fits in a run's chunks (checked when the crate compiles).
const _: () = assert!(MAX_POSES <= MAX_CHUNKS * MAX_CHUNK_POSES);
