//! Projecting a batch of measurements into sonar 2: the batch and its preparation ([`batch`]),
//! the three backends — the f64 reference ([`reference`](mod@reference)), the fast CPU path ([`fast`]) and the
//! GPU ([`gpu`]) — behind one [`Backend`] with one selection policy ([`backend`]), and the
//! envelope an f32 result may honestly lie in ([`envelope`]).
//!
//! Stages are twins: `reference::splat` and `reference::reduce`, `fast::project`'s splat and
//! reduce steps, and `shaders/splat.wgsl` and `shaders/reduce.wgsl` take the same inputs in the
//! same order.

pub mod backend;
pub mod batch;
pub mod columns;
pub(crate) mod culling;
pub mod envelope;
pub mod fast;
pub mod gpu;
pub mod poses;
pub mod reference;

pub use backend::{Backend, BackendChoice, Device, Output, cpu_device};
pub use batch::{Batch, BatchItem, ItemChecker, PreparedBatch, Projection};
pub use columns::{ColumnRef, MetricColumns};
pub use poses::{PoseGrid, PoseSource, PoseSweep};
