//! The applications built on the [`sonarproj`] engine:
//! - the paper's simulations ([`paper`]);
//! - pose sweeps in chunks, shards and merges ([`sweep`]);
//! - speed comparisons ([`bench`](mod@bench));
//! - figures and images ([`report`]);
//! - the CSV formats of batches and recoveries ([`io`]);
//! - the viewer's scenes ([`view`]).
//!
//! The command line and the Python package are thin fronts on this crate and the engine.

pub mod advise;
pub mod bench;
pub mod error;
pub mod gpu_env;
pub mod io;
pub mod limits;
pub mod paper;
pub mod params;
pub mod report;
pub mod sweep;
pub mod view;

pub use error::{Error, Result};
