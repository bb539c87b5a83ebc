//! Sweeps: any sonar pair over grids of rotations, feature distances and placements, or over
//! explicit pose lists (`config`), run in resumable chunks and shards (`run`).

pub mod config;
pub mod run;

pub use config::{Axis, Grid, Poses, SweepConfig};
pub use run::{Options, Outcome, Shard, merge, run};
