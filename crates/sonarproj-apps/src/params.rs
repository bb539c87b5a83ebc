//! The applications' inputs that each front names its own way, as their errors name them
//! ([`Param`]). The command line renders them as flags and Python as keywords
//! ([`crate::Error::render`]). `Display` writes the neutral names below.

use sonarproj::error::Param;

/// The output directory (`--out`; Python's `out_dir`).
pub const OUT: Param = Param::new("out");
/// A sharded sweep's directory, as `merge` takes it (`DIR`; Python's `out_dir`).
pub const SWEEP_DIR: Param = Param::new("dir");
/// Poses per sweep chunk (`--chunk-poses`).
pub const CHUNK_POSES: Param = Param::new("chunk_poses");
/// A sweep's table format (`--format`).
pub const FORMAT: Param = Param::new("format");
/// The backend (`--backend`).
pub const BACKEND: Param = Param::new("backend");
/// The sweep or advise file (`--config`).
pub const CONFIG: Param = Param::new("config");
/// One part of a sweep (`--shard`).
pub const SHARD: Param = Param::new("shard");
/// The paper's angle step (`--angle-step`).
pub const ANGLE_STEP: Param = Param::new("angle_step");
/// The occupancy picture's file (`--occupancy`).
pub const OCCUPANCY: Param = Param::new("occupancy");
/// A feature given as text (`--feature`).
pub const FEATURE: Param = Param::new("feature");

/// Every param of the applications. Each front's table names all of them.
pub const ALL: [Param; 10] = [
    OUT,
    SWEEP_DIR,
    CHUNK_POSES,
    FORMAT,
    BACKEND,
    CONFIG,
    SHARD,
    ANGLE_STEP,
    OCCUPANCY,
    FEATURE,
];
