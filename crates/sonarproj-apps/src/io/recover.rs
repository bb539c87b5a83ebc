//! Recovery CSV files: correspondences in, candidates out, streamed row by row.
//!
//! The input header, in any order, holds `first_range,second_range,roll,pitch,yaw,tx,ty,tz`.
//! An FLS adds `first_azimuth` / `second_azimuth`, left out or empty for an SSS. The optional
//! `sigma_range,sigma_azimuth` (m, deg) give the sigmas of the recovered elevation.
//!
//! The output holds the input columns as given, then [`RECOVER_COLUMNS`], one row per
//! candidate. Without candidates, one row has `candidates` = 0 and the flags. For SSS + SSS,
//! each input row gives one row with the curve's length and point count.

use std::io::{Read, Write};

use crate::error::Result;
use crate::io::batch::{CHUNK_ROWS, no_rows};
use crate::io::field;
use crate::io::table::{CsvOut, Row, TableReader, row_error};
use sonarproj::geometry::pose::{RelativePose, Rotation};
use sonarproj::recovery::{Observation, Recovery, Sigmas};

/// Columns every recovery row must have.
pub const RECOVER_REQUIRED: [&str; 8] = [
    "first_range",
    "second_range",
    "roll",
    "pitch",
    "yaw",
    "tx",
    "ty",
    "tz",
];
/// Columns a recovery row may have besides.
pub const RECOVER_OPTIONAL: [&str; 4] = ["first_azimuth", "second_azimuth", "sigma_range", "sigma_azimuth"];
/// Columns appended to every output row.
pub const RECOVER_COLUMNS: [&str; 21] = [
    "candidates",
    "rank",
    "in_view",
    "x_first",
    "y_first",
    "z_first",
    "x_second",
    "y_second",
    "z_second",
    "range_first",
    "azimuth_first",
    "elevation_first",
    "range_second",
    "azimuth_second",
    "elevation_second",
    "range_per_elevation",
    "sigma_elevation",
    "azimuth_residual",
    "consistent",
    "curve_length",
    "flags",
];

/// One correspondence to recover.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecoverItem {
    /// The pose of sonar 2 relative to sonar 1.
    pub pose: RelativePose,
    /// What sonar 1 measured.
    pub first: Observation,
    /// What sonar 2 measured.
    pub second: Observation,
    /// Measurement sigmas, when the row gave them.
    pub sigmas: Option<Sigmas>,
}

/// A recovery CSV read row by row.
#[derive(Debug)]
pub struct RecoverReader<R: Read> {
    table: TableReader<R>,
}

impl<R: Read> RecoverReader<R> {
    /// Returns the reader of the recovery CSV `reader` with its header read and checked.
    ///
    /// # Errors
    /// [`Error::Csv`](crate::Error::Csv) for missing, unknown or duplicate columns or an empty
    /// input.
    pub fn new(reader: R) -> Result<Self> {
        let allowed: Vec<&str> = RECOVER_REQUIRED
            .iter()
            .chain(&RECOVER_OPTIONAL)
            .copied()
            .collect();
        let expected = format!(
            "{} (and first_azimuth/second_azimuth for an FLS)",
            RECOVER_REQUIRED.join(",")
        );
        let table = TableReader::new(reader, &allowed, &expected)?;
        table.require(&RECOVER_REQUIRED)?;
        Ok(RecoverReader { table })
    }

    /// Returns the header as given.
    #[must_use]
    pub fn headers(&self) -> &[String] {
        self.table.headers()
    }

    /// Returns the next row with its correspondence, or `None` at the end of the input.
    ///
    /// # Errors
    /// [`Error::Csv`](crate::Error::Csv) naming the row (1-based, with its line) for a bad
    /// number or pose, or a wrong field count.
    pub fn next_item(&mut self) -> Result<Option<(Row, RecoverItem)>> {
        self.table.next_parsed(item)
    }
}

fn item<R: Read>(table: &TableReader<R>, fields: &[String]) -> Result<RecoverItem> {
    let get = |c: &str| table.number(fields, c);
    let rotation = Rotation::RollPitchYaw {
        roll: get("roll")?,
        pitch: get("pitch")?,
        yaw: get("yaw")?,
    };
    let pose = RelativePose::new(rotation, [get("tx")?, get("ty")?, get("tz")?])?;
    let sigmas = match (
        table.optional(fields, "sigma_range")?,
        table.optional(fields, "sigma_azimuth")?,
    ) {
        (None, None) => None,
        (r, a) => Some(Sigmas {
            range: r.unwrap_or(0.0),
            azimuth: a.unwrap_or(0.0),
        }),
    };
    Ok(RecoverItem {
        pose,
        first: Observation {
            range: get("first_range")?,
            azimuth: table.optional(fields, "first_azimuth")?,
        },
        second: Observation {
            range: get("second_range")?,
            azimuth: table.optional(fields, "second_azimuth")?,
        },
        sigmas,
    })
}

/// Reads the recovery CSV `input`, recovers each row with `recover`, writes the output CSV to
/// `output` row by row, and returns the number of input rows. Memory stays bounded. At the
/// first bad row (unreadable, or refused by `recover`), the rows before it are written and its
/// error, naming it, is returned.
///
/// # Errors
/// As [`RecoverReader`], an input without rows, `recover`'s errors naming the row, or
/// [`Error::WriteOutput`](crate::Error::WriteOutput) on I/O failure.
pub fn recover_csv(
    input: impl Read,
    output: impl Write,
    mut recover: impl FnMut(&RecoverItem) -> Result<Recovery>,
) -> Result<usize> {
    let mut reader = RecoverReader::new(input)?;
    let headers = reader.headers().to_vec();
    let mut out = CsvOut::new(output, &headers, &RECOVER_COLUMNS);
    let mut rows = 0;
    while let Some((row, item)) = reader.next_item()? {
        let rec = recover(&item).map_err(|e| row_error(row.number, row.line, e))?;
        for more in recovery_rows(&rec) {
            out.row(&row.fields, &more)?;
        }
        rows += 1;
        if rows % CHUNK_ROWS == 0 {
            out.flush()?;
        }
    }
    out.flush()?;
    if rows == 0 {
        return Err(no_rows());
    }
    Ok(rows)
}

fn flags(r: &Recovery) -> String {
    r.flags.iter().map(|f| f.name()).collect::<Vec<_>>().join(";")
}

/// Returns the output rows of one recovery, the fields after the input columns.
#[must_use]
pub fn recovery_rows(r: &Recovery) -> Vec<[String; 21]> {
    let empty = || std::array::from_fn(|_| String::new());
    if let Some(curve) = &r.curve {
        let mut row: [String; 21] = empty();
        row[0] = r.candidates.len().to_string();
        row[19] = curve.length.to_string();
        row[20] = flags(r);
        return vec![row];
    }
    if r.candidates.is_empty() {
        let mut row: [String; 21] = empty();
        row[0] = "0".into();
        row[20] = flags(r);
        return vec![row];
    }
    r.candidates
        .iter()
        .map(|c| {
            let [x1, y1, z1] = c.point_first.map(|v| v.to_string());
            let [x2, y2, z2] = c.point_second.map(|v| v.to_string());
            let [r1, a1, e1] = c.first.map(|v| v.to_string());
            let [r2, a2, e2] = c.second.map(|v| v.to_string());
            [
                r.candidates.len().to_string(),
                c.rank.to_string(),
                c.in_view.to_string(),
                x1,
                y1,
                z1,
                x2,
                y2,
                z2,
                r1,
                a1,
                e1,
                r2,
                a2,
                e2,
                field(c.range_per_elevation),
                field(c.sigma_elevation),
                field(c.azimuth_residual),
                c.consistent.map(|b| b.to_string()).unwrap_or_default(),
                String::new(),
                flags(r),
            ]
        })
        .collect()
}
