//! Sweeps: any sonar pair over grids of rotations, feature distances and placements, or over
//! explicit pose lists (`config`). A sweep runs in resumable chunks (`run`) and shards (`shard`)
//! into CSV or Parquet tables (`table`). Each part on disk is checked against its record
//! (`parts`, `records`). `merge` joins shards, `summary` reduces poses to summaries, `figure`
//! draws, and `in_memory` runs without writing files.

mod columns;
mod compute;
pub mod config;
mod figure;
pub mod grid;
pub mod in_memory;
pub mod merge;
pub mod parts;
pub(crate) mod plan;
pub mod records;
pub mod run;
pub mod shard;
mod state;
pub mod summary;
pub mod table;
mod writer;

pub use columns::column_kinds;
pub use config::{Axis, Grid, Poses, SweepConfig};
pub use in_memory::{InMemory, MAX_IN_MEMORY_BYTES, run_in_memory};
pub use merge::{Merged, merge};
pub use plan::{DEFAULT_CHUNK_POSES, DEFAULT_SUMMARY_CHUNK_POSES, default_chunk_poses};
pub use records::{Descriptor, Settings, descriptor, settings};
pub use run::{Event, Options, Outcome, run};
pub use shard::{MAX_SHARDS, Shard};
pub use table::Format;
