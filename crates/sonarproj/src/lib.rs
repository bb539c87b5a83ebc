//! sonarproj: the epipolar geometry of sonar. Given a feature measured by one sonar (FLS or SSS)
//! and the pose of a second sonar, compute where in the second sonar's data the feature can be.
//!
//! Data flows one way: [`Measurement`] + sonars → [`SamplingPlan`] → [`Backend`] (CPU reference
//! or WGSL on the GPU) → [`Occupancy`] → [`Metrics`] → reports. See `ARCHITECTURE.md`.

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
pub mod sonar;

pub use ambiguity::{Measurement, Sampling, SamplingPlan};
pub use backend::{Backend, BackendChoice};
pub use batch::{Batch, BatchItem, Projection};
pub use error::{Error, Result};
pub use occupancy::{Layout, Metrics, Occupancy};
pub use pose::{RelativePose, Rotation};
pub use sonar::{BeamLayout, Sonar, SonarKind};
