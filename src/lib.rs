//! sonarproj: the epipolar geometry of sonar. Given a feature measured by one sonar (FLS or
//! SSS) and the pose of a second sonar, it computes where in the second sonar's data the
//! feature can be.
//!
//! Data flows one way, and the modules follow it: [`geometry`] (sonars, poses, rigs) →
//! [`sampling`] ([`Measurement`] → [`SamplingPlan`]) → [`projection`] ([`Backend`]: the f64
//! reference, the fast CPU path, or WGSL on the GPU) → [`occupancy`] → [`metrics`] → reports.
//! Beside it sit [`masks`] (correspondence masks) and [`recovery`] (the lost coordinate). The
//! GPU plumbing is in [`gpu`]. See `ARCHITECTURE.md`.
//!
//! Units: ranges and translations are in metres. Angles are in degrees wherever a user gives or
//! reads them: sonars, measurements, rotations, mounts, noise, metrics, mask bounding boxes.
//! They are in radians only inside the computation's own types ([`Layout`]'s beam edges and
//! half apertures, [`SamplingPlan`], [`metrics::Extremes`], [`geometry::sph_to_cart`]). Every
//! field and argument says which.
//!
//! ```
//! use sonarproj::{Backend, Batch, BatchItem, Measurement, Output, RelativePose, Rotation, Sampling, Sonar};
//!
//! let fls = Sonar::preset("paper-fls").unwrap();
//! let sss = Sonar::preset("paper-sss").unwrap();
//! // A feature 5 m away at azimuth 10°; its elevation is lost.
//! let feature = Measurement::of(&fls, 5.0, 10.0)?;
//! // The sidescan pitched 90° and placed so the true point (elevation 0) is 15 m ahead of it.
//! let pitch = Rotation::RollPitchYaw { roll: 0.0, pitch: 90.0, yaw: 0.0 };
//! let pose = RelativePose::placement(pitch, [5.0, 10.0, 0.0], [15.0, 0.0, 0.0])?;
//! let batch = Batch {
//!     source: fls,
//!     target: sss,
//!     sampling: Sampling::Step(0.1),
//!     area_grid: sonarproj::PAPER_AREA_GRID,
//!     sigma_range: None,
//!     // The true point given: the projection carries the local precision there.
//!     items: vec![BatchItem { measurement: feature, pose, true_point: Some([5.0, 10.0, 0.0]) }],
//! };
//! let projection = &Backend::CpuFast.project(&batch, Output::MetricsOnly)?[0];
//! let metrics = projection.metrics;
//! // Every sample of the arc is seen; its ranges in the sidescan straddle 15 m.
//! assert_eq!(metrics.visible, metrics.total);
//! assert!(metrics.range_min.unwrap() < 15.0 && metrics.range_max.unwrap() > 15.0);
//! assert!(projection.local.sigma_elevation.is_some());
//! # Ok::<(), sonarproj::Error>(())
//! ```

pub mod clip;
pub mod error;
pub mod exact;
pub mod files;
pub mod geometry;
pub mod gpu;
pub mod limits;
pub mod local_precision;
pub mod masks;
pub mod metrics;
pub mod occupancy;
pub mod projection;
pub mod recovery;
pub mod sampling;
pub mod stream;
#[doc(hidden)]
pub mod test_support;

pub use error::{Error, Result};

/// The engine's version (its crate version). Results of one version with equal inputs and
/// backend settings are equal.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
pub use geometry::{BeamLayout, RelativePose, Rotation, Sonar, SonarKind, rig};
pub use gpu::GpuOptions;
pub use masks::{Counts, MaskEngine};
pub use metrics::{Metric, Metrics};
pub use occupancy::{AreaGrid, Layout, Occupancy, PAPER_AREA_GRID};
pub use projection::{
    Backend, BackendChoice, Batch, BatchItem, MetricColumns, Output, PoseGrid, PosePairs, PoseSource,
    PoseSweep, Projection,
};
pub use sampling::{Measurement, Sampling, SamplingPlan};

/// The README's Rust code blocks, compiled and run as doctests (with
/// `crates/sonarproj-cli/tests/docs.rs`, which runs its other blocks).
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

/// The guide's Rust code blocks (`docs/rust.md`), compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../docs/rust.md")]
struct RustGuideDoctests;
