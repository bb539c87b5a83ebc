//! `sonarproj project`: one feature, one pose; metrics as JSON, occupancy optionally to a file.

use sonarproj::Output;
use std::path::PathBuf;

use serde_json::json;
use sonarproj::occupancy::Layout;
use sonarproj::sampling::SamplingPlan;
use sonarproj::{BatchItem, Measurement, Sampling};
use sonarproj_apps::io::batch::metrics_json;
use sonarproj_apps::report::occupancy_image::{self, Format, Orientation};
use sonarproj_apps::{Error, Result};

use super::PairArgs;
use super::pose_args::PoseArgs;

/// Options of `sonarproj project`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub(super) struct ProjectArgs {
    #[command(flatten)]
    pair: PairArgs,
    /// Range (m) of the feature in sonar 1 (its measurement).
    #[arg(long, value_name = "M")]
    range: f64,
    /// Azimuth (deg) of the feature in sonar 1 (measured by an FLS; used by the placement).
    #[arg(long, value_name = "DEG", default_value_t = 0.0)]
    azimuth: f64,
    /// Elevation (deg) of the feature's true point in sonar 1: used by the placement, and for
    /// range_per_elevation and sigma_elevation (default 0 with a placement; without one, those
    /// two are empty unless it is given).
    #[arg(long, value_name = "DEG")]
    elevation: Option<f64>,
    #[command(flatten)]
    pose: PoseArgs,
    /// Also write the occupancy buffer, as FILE.png or FILE.npy. FILE.png is a labelled picture
    /// for a person, near range at the bottom and port on the left: an FLS as its range × beam
    /// layout with beam 0 (the starboard-most) at the right, an SSS as a vertical range strip.
    /// FILE.npy is uint8 0/1 for numpy: [range_bin, beam] for an FLS, [range_bin] for an SSS, and
    /// the row of 2 x range_bins for a two-sided one. Row 0 is range_min and column 0 is beam 0
    /// at -aperture/2 (starboard), unless flipped.
    #[arg(long, value_name = "FILE")]
    occupancy: Option<PathBuf>,
    /// NPY only: write range_max in row 0 instead of range_min (refused with a .png, which
    /// always draws near range at the bottom).
    #[arg(long, requires = "occupancy")]
    flip_range: bool,
    /// NPY only: write the last beam (+aperture/2, port) in column 0 instead of beam 0 (refused
    /// with a .png, which always draws port on the left).
    #[arg(long, requires = "occupancy")]
    flip_beams: bool,
}

/// Runs `sonarproj project`.
pub(super) fn run(a: ProjectArgs) -> Result<()> {
    let mut batch = a.pair.resolve()?;
    // The true point is known with a placement (elevation 0 unless given) or a given elevation.
    let elevation = a.elevation.unwrap_or(0.0);
    let true_point =
        (a.pose.is_placement() || a.elevation.is_some()).then_some([a.range, a.azimuth, elevation]);
    let (source, target, sampling) = (&batch.source, &batch.target, batch.sampling);
    source.check_point("feature", a.range, a.azimuth, elevation)?;
    let measurement = Measurement::of(source, a.range, a.azimuth)?;
    let pose = a.pose.pose([a.range, a.azimuth, elevation])?;
    let plan = SamplingPlan::new(source, target, &measurement, sampling)?;
    let png = match &a.occupancy {
        Some(path) => occupancy_image::check_extension(path)? == Format::Png,
        None => false,
    };
    if let Some(path) = a.occupancy.as_ref().filter(|_| png) {
        for (flag, given) in [("--flip-range", a.flip_range), ("--flip-beams", a.flip_beams)] {
            if given {
                return Err(Error::input(
                    flag,
                    format!(
                        "applies to a .npy occupancy only; {} is a picture, always drawn with near range at the bottom and port on the left",
                        path.display()
                    ),
                ));
            }
        }
    }
    if target.two_sided() {
        for (flag, given) in [("--flip-range", a.flip_range), ("--flip-beams", a.flip_beams)] {
            if given {
                return Err(Error::input(
                    flag,
                    format!(
                        "sonar 2 ({}) is a two-sided sidescan, whose data is one row (port far to near, then starboard near to far): there is no range axis or beam axis to flip",
                        target.name
                    ),
                ));
            }
        }
    }
    let backend = a.pair.backend()?;
    batch.items.push(BatchItem {
        true_point,
        measurement,
        pose,
    });
    let result = backend
        .project(
            &batch,
            if a.occupancy.is_some() {
                Output::WithOccupancy
            } else {
                Output::MetricsOnly
            },
        )?
        .pop()
        .expect("one item in, one result out");
    if let (Some(path), Some(occ)) = (&a.occupancy, &result.occupancy) {
        let orientation = Orientation {
            flip_range: a.flip_range,
            flip_beams: a.flip_beams,
        };
        let title = format!(
            "{} to {}: occupancy of the feature at {} m",
            batch.source.name, batch.target.name, measurement.range
        );
        occupancy_image::write(path, occ, &Layout::of(&batch.target), &title, orientation)?;
    }
    let rows = pose.rotation.transpose().to_cols_array_2d();
    let local = result.local;
    let out = json!({
        "from": batch.source.name,
        "to": batch.target.name,
        "backend": backend.name(),
        "device": backend.device(),
        "measurement": {
            "range": measurement.range,
            "azimuth": match batch.source.kind {
                sonarproj::SonarKind::Fls => Some(measurement.azimuth),
                sonarproj::SonarKind::Sss => None,
            },
        },
        "pose": { "rotation": rows, "translation": pose.translation.to_array() },
        "sampling": {
            "mode": match sampling {
                Sampling::Step(_) => "step",
                Sampling::Auto => "auto",
                Sampling::Exact => "exact",
            },
            "step_deg": match sampling { Sampling::Step(s) => Some(s), _ => None },
            "azimuth_samples": plan.azimuths.len(),
            "elevation_samples": plan.elevations.len(),
        },
        "metrics": metrics_json(&result.metrics, &local),
        "occupancy_file": a.occupancy,
    });
    outln!(
        "{}",
        serde_json::to_string_pretty(&out).expect("plain JSON values")
    )?;
    Ok(())
}
