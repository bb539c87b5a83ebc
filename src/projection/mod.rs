//! Projects a batch of measurements into sonar 2.
//!
//! [`batch`] holds the batch and its preparation. The backends are the f64 reference
//! ([`reference`](mod@reference)), the fast CPU path ([`fast`]) and the GPU ([`gpu`]), behind one
//! [`Backend`] with one selection policy ([`backend`]). [`envelope`] bounds where an f32 result may
//! honestly lie.
//!
//! The API is [`Backend`]: a [`Batch`] of items, or a [`PoseSweep`] of a grid, a list or pairs of poses and features, into
//! projections or [`MetricColumns`]. The prepared batch ([`Batch::prepare`]) and each backend's own
//! call (`fast::project`, `reference::project`, `GpuBackend::project`) are hidden from the docs and
//! may change. Tests and benches use them to compare the backends and to time them without the
//! preparation.
//!
//! The stages are twins: `reference::splat` and `reference::reduce`, `fast::project`'s splat and
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
pub mod pairs;
pub mod poses;
pub mod reduction;
#[doc(hidden)]
pub mod reference;

pub use backend::{Backend, BackendChoice, Device, Notice, Output, cpu_device};
#[doc(hidden)]
pub use batch::PreparedBatch;
pub use batch::{Batch, BatchItem, ItemChecker, Projection};
pub use columns::{ColumnRef, MetricColumns};
pub use pairs::PosePairs;
pub use poses::{PoseGrid, PoseSource, PoseSweep};
pub use reduction::{MetricReduction, Reduction};
