//! sonarproj: the epipolar geometry of sonar. Given a feature measured by one sonar (FLS or SSS)
//! and the pose of a second sonar, compute where in the second sonar's data the feature can be.
//!
//! Data flows one way: [`Measurement`] + sonars → [`SamplingPlan`] → [`Backend`] (CPU reference
//! or WGSL on the GPU) → [`Occupancy`] → [`Metrics`] → reports. See `ARCHITECTURE.md`.
//!
//! Units: ranges and translations in metres; angles of sonars, measurements, rotations and
//! reported metrics in degrees (sampling plans and [`occupancy::Extremes`] in radians, as
//! their docs say).
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
//!     items: vec![BatchItem { measurement: feature, pose }],
//! };
//! let metrics = Backend::CpuFast.project(&batch, Output::MetricsOnly)?[0].metrics;
//! // Every sample of the arc is seen; its ranges in the sidescan straddle 15 m.
//! assert_eq!(metrics.visible, metrics.total);
//! assert!(metrics.range_min.unwrap() < 15.0 && metrics.range_max.unwrap() > 15.0);
//! # Ok::<(), sonarproj::Error>(())
//! ```

pub mod ambiguity;
pub mod backend;
pub mod batch;
pub mod cpu;
pub mod cpu_fast;
pub mod error;
pub mod gpu;
pub mod mask;
pub mod occupancy;
pub mod pose;
pub mod recover;
pub mod rig;
pub mod sonar;

pub use ambiguity::{Measurement, Sampling, SamplingPlan};
pub use backend::{Backend, BackendChoice, Output};
pub use batch::{Batch, BatchItem, Projection};
pub use error::{Error, Result};
pub use occupancy::{Layout, Metrics, Occupancy};
pub use pose::{RelativePose, Rotation};
pub use sonar::{BeamLayout, Sonar, SonarKind};
