//! `sonarproj batch`: a CSV of poses in, a CSV of metrics out.

use sonarproj::Batch;
use sonarproj::Output;
use sonarproj_apps::Result;
use sonarproj_apps::io::{read_batch_csv, write_batch_csv};

use super::{PairArgs, read_input, write_output};

/// Options of `sonarproj batch`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub(super) struct BatchArgs {
    #[command(flatten)]
    pair: PairArgs,
    /// Input CSV ('-' for stdin). Columns (any order): range,azimuth,elevation,roll,pitch,yaw and
    /// either place_range,place_azimuth,place_elevation or tx,ty,tz.
    #[arg(long, value_name = "FILE", default_value = "-")]
    input: String,
    /// Output CSV ('-' for stdout): the input columns, then
    /// visible,total,range_min,range_max,span,azimuth_min,azimuth_max,occupied,occupied_measure.
    /// A file is written whole or not at all.
    #[arg(long, value_name = "FILE", default_value = "-")]
    output: String,
}

/// Runs `sonarproj batch`.
pub(super) fn run(a: BatchArgs) -> Result<()> {
    let (source, target, sampling) = a.pair.resolve()?;
    let text = read_input(&a.input)?;
    let input = read_batch_csv(text.as_slice(), &source)?;
    let batch = Batch {
        source,
        target,
        sampling,
        items: input.items.clone(),
    };
    // Check the sampling of every row before any device work.
    batch.prepare()?;
    let backend = a.pair.backend()?;
    let results = backend.project(&batch, Output::MetricsOnly)?;
    write_output(&a.output, |w| write_batch_csv(w, &input, &results))
}
