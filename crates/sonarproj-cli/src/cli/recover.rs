//! `sonarproj recover`: the coordinate each sonar loses, from one correspondence (JSON) or a
//! CSV of them (`--input`). See docs/recover.md.

use serde_json::json;
use sonarproj::recovery::{DEFAULT_CURVE_STEP, Observation, Recovery, Sigmas, recover};
use sonarproj::{Sonar, SonarKind};
use sonarproj_apps::Result;
use sonarproj_apps::io::recover::recover_csv;

use super::pose_args::PoseArgs;
use super::{open_input, write_output};
use sonarproj_apps::io::text::numbers;

/// Options of `sonarproj recover`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub(super) struct RecoverArgs {
    /// Sonar 1: a preset name or a sonar TOML file.
    #[arg(long, value_name = "SONAR")]
    from: String,
    /// Sonar 2: a preset name or a sonar TOML file.
    #[arg(long, value_name = "SONAR")]
    to: String,
    /// What sonar 1 measured: R (SSS) or R,A (FLS), metres and degrees.
    #[arg(
        long,
        value_name = "R[,A]",
        required_unless_present = "input",
        allow_hyphen_values = true
    )]
    first: Option<String>,
    /// What sonar 2 measured: R (SSS) or R,A (FLS).
    #[arg(
        long,
        value_name = "R[,A]",
        required_unless_present = "input",
        allow_hyphen_values = true
    )]
    second: Option<String>,
    #[command(flatten)]
    pose: PoseArgs,
    /// Placement only: the feature's azimuth (deg) in sonar 1 when sonar 1 is an SSS.
    #[arg(long, value_name = "DEG", default_value_t = 0.0)]
    feature_azimuth: f64,
    /// Placement only: the feature's elevation (deg) in sonar 1 (the pose is built from it).
    #[arg(long, value_name = "DEG", default_value_t = 0.0)]
    feature_elevation: f64,
    /// Standard deviation of a range measurement (m), for sigma_elevation.
    #[arg(long, value_name = "M")]
    sigma_range: Option<f64>,
    /// Standard deviation of an azimuth measurement (deg), for sigma_elevation.
    #[arg(long, value_name = "DEG")]
    sigma_azimuth: Option<f64>,
    /// SSS + SSS: spacing (m) of the points returned along the curve.
    #[arg(long, value_name = "M", default_value_t = DEFAULT_CURVE_STEP)]
    curve_step: f64,
    /// Batch mode: a CSV of correspondences ('-' for stdin); columns in docs/recover.md.
    #[arg(long, value_name = "FILE",
          conflicts_with_all = ["first", "second", "translation", "place_range", "quaternion", "matrix"])]
    input: Option<String>,
    /// Batch mode: the output CSV ('-', the default, for stdout), written whole or not at all.
    #[arg(long, value_name = "FILE", requires = "input")]
    output: Option<String>,
}

/// Returns the observation `text` (`R` or `R,A`) of `which` sonar.
fn observation(which: &str, text: &str) -> Result<Observation> {
    let field = format!("--{which}");
    // Checked here, before a placement built from --first could name its own option.
    if text
        .split(',')
        .any(|v| v.trim().parse::<f64>().is_ok_and(|v| !v.is_finite()))
    {
        return Err(sonarproj_apps::Error::invalid(
            field,
            text,
            "must be finite numbers",
        ));
    }
    match text.split(',').count() {
        1 => Ok(Observation {
            range: numbers::<1>(&field, text)?[0],
            azimuth: None,
        }),
        _ => {
            let [range, azimuth] = numbers::<2>(&field, text)?;
            Ok(Observation {
                range,
                azimuth: Some(azimuth),
            })
        }
    }
}

/// Runs `sonarproj recover`.
pub(super) fn run(a: RecoverArgs) -> Result<()> {
    let source = super::resolve_sonar(&a.from)?;
    let target = super::resolve_sonar(&a.to)?;
    if let Some(input) = &a.input {
        return run_batch(&a, &source, &target, input);
    }
    let first = observation("first", a.first.as_deref().expect("clap requires it"))?;
    let second = observation("second", a.second.as_deref().expect("clap requires it"))?;
    let feature_azimuth = match source.kind {
        SonarKind::Fls => first.azimuth.unwrap_or(0.0),
        SonarKind::Sss => a.feature_azimuth,
    };
    let pose = a.pose.pose([first.range, feature_azimuth, a.feature_elevation])?;
    let sigmas = match (a.sigma_range, a.sigma_azimuth) {
        (None, None) => None,
        (r, az) => Some(Sigmas {
            range: r.unwrap_or(0.0),
            azimuth: az.unwrap_or(0.0),
        }),
    };
    let rec: Recovery = recover(&source, &target, &pose, first, second, sigmas, a.curve_step)?;
    let out = json!({
        "from": source.name,
        "to": target.name,
        "first": { "range": first.range, "azimuth": first.azimuth },
        "second": { "range": second.range, "azimuth": second.azimuth },
        "pose": {
            "rotation": pose.rotation.transpose().to_cols_array_2d(),
            "translation": pose.translation.to_array(),
        },
        "sigmas": sigmas,
        "flags": rec.flags,
        "candidates": rec.candidates,
        "curve": rec.curve,
    });
    outln!(
        "{}",
        serde_json::to_string_pretty(&out).expect("plain JSON values")
    )?;
    Ok(())
}

/// Runs the batch mode: every row of `input` recovered, written as CSV row by row.
fn run_batch(a: &RecoverArgs, source: &Sonar, target: &Sonar, input: &str) -> Result<()> {
    let input = open_input(input)?;
    write_output(a.output.as_deref().unwrap_or("-"), |w| {
        recover_csv(input, w, |item| {
            Ok(recover(
                source,
                target,
                &item.pose,
                item.first,
                item.second,
                item.sigmas,
                a.curve_step,
            )?)
        })
        .map(|_| ())
    })
}
