//! `sonarproj batch`: a CSV of poses in, a CSV of metrics out.

use std::io::Read;
use std::path::PathBuf;

use sonarproj::error::Error;
use sonarproj::io::{read_batch_csv, write_batch_csv};
use sonarproj::report::write_atomic;
use sonarproj::{Batch, Result};

use super::PairArgs;

/// Options of `sonarproj batch`.
#[derive(Debug, clap::Args)]
pub struct BatchArgs {
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
pub fn run(a: BatchArgs) -> Result<()> {
    let (source, target, sampling) = a.pair.resolve()?;
    let mut text = Vec::new();
    if a.input == "-" {
        std::io::stdin()
            .read_to_end(&mut text)
            .map_err(|source| Error::ReadInput {
                path: "stdin".into(),
                source,
            })?;
    } else {
        let path = PathBuf::from(&a.input);
        text = std::fs::read(&path).map_err(|source| Error::ReadInput { path, source })?;
    }
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
    let results = backend.project(&batch, false)?;
    if a.output == "-" {
        write_batch_csv(std::io::stdout().lock(), &input, &results)
    } else {
        write_atomic(&PathBuf::from(&a.output), |w| {
            write_batch_csv(w, &input, &results)
        })
    }
}
