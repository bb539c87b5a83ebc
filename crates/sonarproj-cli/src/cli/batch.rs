//! `sonarproj batch`: a CSV of poses in, a CSV of metrics out.

use sonarproj::{Backend, Output};
use sonarproj_apps::Result;
use sonarproj_apps::io::project_csv;

use super::{PairArgs, open_input, write_output};

/// Options of `sonarproj batch`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub(super) struct BatchArgs {
    #[command(flatten)]
    pair: PairArgs,
    /// Input CSV ('-' for stdin). Columns (any order): range (and azimuth for an FLS sonar 1);
    /// the rotation as roll,pitch,yaw (deg), qw,qx,qy,qz (unit quaternion, scalar first) or
    /// r11,r12,...,r33 (the matrix R of p2 = R p1 + t, row-major); and either
    /// place_range,place_azimuth,place_elevation (with the feature's true point azimuth,elevation)
    /// or tx,ty,tz (elevation optional).
    #[arg(long, value_name = "FILE", default_value = "-")]
    input: String,
    /// Output CSV ('-' for stdout): the input columns, then visible,total,range_min,range_max,
    /// span,azimuth_min,azimuth_max,occupied,occupied_measure,projection_area,
    /// range_per_elevation,sigma_elevation.
    /// A file is written whole or not at all. On stdout, rows go out as they are computed, and a
    /// bad input row stops the command (exit status 2) after the rows before it.
    #[arg(long, value_name = "FILE", default_value = "-")]
    output: String,
}

/// Runs `sonarproj batch`, reading, projecting and writing a chunk of rows at a time. The device
/// is opened when the first chunk is ready, so a bad header or first row never waits for it.
pub(super) fn run(a: BatchArgs) -> Result<()> {
    let pair = a.pair.resolve()?;
    let input = open_input(&a.input)?;
    let mut backend: Option<Backend> = None;
    write_output(&a.output, |w| {
        project_csv(input, w, &pair, |chunk| {
            let backend = match &mut backend {
                Some(b) => b,
                None => backend.insert(a.pair.backend()?),
            };
            Ok(backend.project(chunk, Output::MetricsOnly)?)
        })
        .map(|_| ())
    })
}
