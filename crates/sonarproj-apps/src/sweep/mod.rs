//! Sweeps: any sonar pair over grids of rotations, feature distances and placements, or over
//! explicit pose lists (`config`), run in resumable chunks and shards (`run`), each part on disk checked against its
//! record (`parts`), reduced to summaries (`summary`).

pub mod config;
pub mod parts;
pub mod run;
pub mod summary;

pub use config::{Axis, Grid, Poses, SweepConfig};
pub use run::{Event, Format, InMemory, Merged, Options, Outcome, Shard, merge, run, run_in_memory};
