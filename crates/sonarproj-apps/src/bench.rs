//! The batches speed is measured on, shared by `sonarproj bench` and `cargo bench`: placement
//! poses of the paper's kind (features at half range in both sonars, rotations spread over the
//! sphere), step sampling 0.1° as the published code.

use sonarproj::Output;
use std::time::{Duration, Instant};

use crate::error::{Error, Result};
use sonarproj::geometry::pose::{RelativePose, Rotation};
use sonarproj::geometry::sonar::Sonar;
use sonarproj::projection::Backend;
use sonarproj::projection::{Batch, BatchItem};
use sonarproj::sampling::{Measurement, Sampling};

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
        area_grid: sonarproj::PAPER_AREA_GRID,
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
    #[must_use]
    pub fn poses_per_second(&self) -> f64 {
        self.poses as f64 / self.median.as_secs_f64()
    }

    /// Returns samples per second.
    #[must_use]
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.median.as_secs_f64()
    }
}

pub use sonarproj::limits::MAX_RUNS;

/// Returns the median time of `runs` runs (after one warm-up run) of `batch` on `backend`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] unless `1 <= runs <= MAX_RUNS`; as [`Backend::project`].
pub fn time(backend: &Backend, batch: &Batch, runs: u32) -> Result<Timing> {
    if !(1..=MAX_RUNS).contains(&runs) {
        return Err(Error::invalid(
            "runs",
            runs,
            format!("must be in [1, {MAX_RUNS}]"),
        ));
    }
    let first = backend.project(batch, Output::MetricsOnly)?;
    let samples = first.iter().map(|p| p.metrics.total).sum();
    let mut times = Vec::with_capacity(runs as usize);
    for _ in 0..runs {
        let start = Instant::now();
        backend.project(batch, Output::MetricsOnly)?;
        times.push(start.elapsed());
    }
    times.sort();
    Ok(Timing {
        median: times[times.len() / 2],
        poses: batch.items.len(),
        samples,
    })
}

/// The mask latency cases: `(from, to)`, a sidescan to an imaging sonar and back.
pub const MASK_CASES: [(&str, &str); 2] = [
    ("holoocean-sidescan", "holoocean-imaging"),
    ("holoocean-imaging", "holoocean-sidescan"),
];

/// Returns the pose and `n` features of a mask benchmark ping: the two sonars side by side
/// (0.3 m apart, 0.1 m in height), nearly aligned (pitch 5°, yaw 10°), so that a sidescan's
/// fan lies inside the imaging sonar's elevation aperture (the largest masks, the slowest case)
/// and each imaging-sonar arc crosses the sidescan's beam; features spread evenly over the
/// ranges both sonars see and (for an FLS) over 90 % of the azimuths.
///
/// # Errors
/// None for valid sonars.
pub fn mask_ping(source: &Sonar, target: &Sonar, n: usize) -> Result<(RelativePose, Vec<Measurement>)> {
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 5.0,
            yaw: 10.0,
        },
        [0.3, 0.2, -0.1],
    )?;
    let far = source.range_max.min(0.95 * target.range_max);
    let features = (0..n)
        .map(|k| {
            let f = (k as f64 + 0.5) / n as f64;
            let range = source.range_min + f * (far - source.range_min);
            // A golden-ratio walk over the aperture, decorrelated from the range.
            let g = (k as f64 * 0.618_033_988_749_895).fract();
            Measurement::of(source, range, (g - 0.5) * 0.9 * source.azimuth_aperture)
        })
        .collect::<sonarproj::Result<Vec<_>>>()?;
    Ok((pose, features))
}
