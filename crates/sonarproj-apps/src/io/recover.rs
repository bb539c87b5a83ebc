//! Recovery CSV files: correspondences in, candidates out.
//!
//! Input header (any order): `first_range,second_range,roll,pitch,yaw,tx,ty,tz`, plus
//! `first_azimuth` / `second_azimuth` for an FLS (left out, or empty, for an SSS), and optionally
//! `sigma_range,sigma_azimuth` (m, deg) for the sigmas of the recovered elevation. Output: the
//! input columns as given, then [`RECOVER_COLUMNS`], one row per candidate (one row with
//! `candidates` = 0 and the flags when there is none; for SSS + SSS one row per input row with
//! the curve's length and point count).

use std::io::{Read, Write};

use crate::error::Result;
use crate::io::field;
use crate::io::table::{Table, row_error, write_rows};
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

/// A parsed recovery CSV: the rows as given (for echoing) and the correspondences.
#[derive(Clone, Debug)]
pub struct RecoverInput {
    /// The header as given.
    pub headers: Vec<String>,
    /// Each row's fields as given, with its row number and line.
    pub rows: Vec<(usize, u64, Vec<String>)>,
    /// Each row's correspondence.
    pub items: Vec<RecoverItem>,
}

/// Returns the correspondences read from CSV `reader`.
///
/// # Errors
/// [`Error::Csv`](crate::Error::Csv) naming the header or the row for missing, unknown or duplicate columns, an
/// empty input, a bad number or pose.
pub fn read_recover_csv(reader: impl Read) -> Result<RecoverInput> {
    let allowed: Vec<&str> = RECOVER_REQUIRED
        .iter()
        .chain(&RECOVER_OPTIONAL)
        .copied()
        .collect();
    let expected = format!(
        "{} (and first_azimuth/second_azimuth for an FLS)",
        RECOVER_REQUIRED.join(",")
    );
    let table = Table::read(reader, &allowed, &expected)?;
    table.require(&RECOVER_REQUIRED)?;
    table.require_rows()?;
    let mut items = Vec::with_capacity(table.rows.len());
    for (row, line, fields) in &table.rows {
        let get = |c: &str| table.number(fields, c);
        let item = (|| -> Result<RecoverItem> {
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
        })()
        .map_err(|e| row_error(*row, *line, e))?;
        items.push(item);
    }
    Ok(RecoverInput {
        headers: table.headers,
        rows: table.rows,
        items,
    })
}

/// Returns the flags joined with `;`.
fn flags(r: &Recovery) -> String {
    r.flags.iter().map(|f| f.name()).collect::<Vec<_>>().join(";")
}

/// Returns the output rows (after the input columns) of one recovery.
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

/// Writes the output CSV: each input row's columns as given, then its recovery's rows.
///
/// # Errors
/// [`Error::WriteOutput`](crate::Error::WriteOutput) (named `output`) on I/O failure.
pub fn write_recover_csv(w: impl Write, input: &RecoverInput, results: &[Recovery]) -> Result<()> {
    let rows = input.rows.iter().zip(results).flat_map(|((_, _, fields), rec)| {
        recovery_rows(rec)
            .into_iter()
            .map(move |out| (fields.as_slice(), out.to_vec()))
    });
    write_rows(w, &input.headers, &RECOVER_COLUMNS, rows)
}
