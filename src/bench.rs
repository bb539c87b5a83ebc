//! The batches speed is measured on, shared by `sonarproj bench` and `cargo bench`: placement
//! poses of the paper's kind (features at half range in both sonars, rotations spread over the
//! sphere), step sampling 0.1° as the published code.

use std::time::{Duration, Instant};

use crate::ambiguity::{Measurement, Sampling};
use crate::backend::Backend;
use crate::batch::{Batch, BatchItem};
use crate::error::Result;
use crate::pose::{RelativePose, Rotation};
use crate::sonar::Sonar;

/// The standard batches: `(from, to, poses)`, sized so each takes about as long on the reference.
pub const STANDARD: [(&str, &str, usize); 2] =
    [("paper-fls", "paper-sss", 2000), ("paper-sss", "paper-fls", 200)];

/// Returns `n` placement poses from `source` to `target`: the feature at half of each sonar's
/// maximum range, on the boresight, under rotations spread over the sphere.
///
/// # Errors
/// None for valid sonars; invalid ones as [`RelativePose::placement`].
pub fn batch(source: &Sonar, target: &Sonar, n: usize) -> Result<Batch> {
    let f = [source.range_max / 2.0, 0.0, 0.0];
    let place = [target.range_max / 2.0, 0.0, 0.0];
    let items = (0..n)
        .map(|k| {
            let a = k as f64 * 360.0 / n as f64;
            let rot = Rotation::RollPitchYaw {
                roll: a,
                pitch: a * 0.5 - 90.0,
                yaw: 180.0 - a,
            };
            Ok(BatchItem {
                measurement: Measurement::of(source, f[0], 0.0)?,
                pose: RelativePose::placement(rot, f, place)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Batch {
        source: source.clone(),
        target: target.clone(),
        sampling: Sampling::Step(0.1),
        items,
    })
}

/// One backend's speed on one batch.
#[derive(Clone, Debug)]
pub struct Timing {
    /// Median wall time of one run.
    pub median: Duration,
    /// Poses in the batch.
    pub poses: usize,
    /// Samples drawn in the batch.
    pub samples: u64,
}

impl Timing {
    /// Returns poses per second.
    pub fn poses_per_second(&self) -> f64 {
        self.poses as f64 / self.median.as_secs_f64()
    }

    /// Returns samples per second.
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.median.as_secs_f64()
    }
}

/// Returns the median time of `runs` runs (after one warm-up run) of `batch` on `backend`.
///
/// # Errors
/// As [`Backend::project`].
pub fn time(backend: &Backend, batch: &Batch, runs: usize) -> Result<Timing> {
    let first = backend.project(batch, false)?;
    let samples = first.iter().map(|p| p.metrics.total).sum();
    let mut times = Vec::with_capacity(runs.max(1));
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        backend.project(batch, false)?;
        times.push(start.elapsed());
    }
    times.sort();
    Ok(Timing {
        median: times[times.len() / 2],
        poses: batch.items.len(),
        samples,
    })
}
