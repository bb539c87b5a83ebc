//! Projecting a batch of measurements into sonar 2: the batch and its preparation ([`batch`]),
//! the three backends — the f64 reference ([`reference`](mod@reference)), the fast CPU path ([`fast`]) and the
//! GPU ([`gpu`]) — behind one [`Backend`] with one selection policy ([`backend`]), and the
//! envelope an f32 result may honestly lie in ([`envelope`]).
//!
//! The API is [`Backend`]: a [`Batch`] of items, or a [`PoseSweep`] of a grid or list, into
//! projections or [`MetricColumns`]. What lies under it — a batch prepared
//! ([`Batch::prepare`]), and each backend's own call on it (`fast::project`,
//! `reference::project`, `GpuBackend::project`) — is hidden from the documentation: the tests
//! and benches reach it to hold the backends against each other and to time them apart from the
//! preparation; its shape may change with the engine.
//!
//! Stages are twins: `reference::splat` and `reference::reduce`, `fast::project`'s splat and
//! reduce steps, and `shaders/splat.wgsl` and `shaders/reduce.wgsl` take the same inputs in the
//! same order.

pub mod backend;
pub mod batch;
pub mod columns;
pub(crate) mod culling;
pub mod envelope;
#[doc(hidden)]
pub mod fast;
pub mod gpu;
pub mod poses;
#[doc(hidden)]
pub mod reference;

pub use backend::{Backend, BackendChoice, Device, Notice, Output, cpu_device};
#[doc(hidden)]
pub use batch::PreparedBatch;
pub use batch::{Batch, BatchItem, ItemChecker, Projection};
pub use columns::{ColumnRef, MetricColumns};
pub use poses::{PoseGrid, PoseSource, PoseSweep};
