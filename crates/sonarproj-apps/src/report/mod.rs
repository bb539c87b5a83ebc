//! Reports: files written whole or not at all (`atomic`), output directories, occupancy and
//! masks as PNG and NPY, and the figures.
//!
//! # The picture convention
//!
//! Every picture of sonar data drawn for people shows **near range at the bottom and port on
//! the left**, and says so with the words "port" and "starboard". This covers the fan of an
//! FLS, a raw-layout panel, a sidescan strip and the occupancy PNG of `project`. A sidescan
//! strip, one beam wide, says instead that it has no port–starboard axis.
//!
//! - A fan is seen from above: the sonar at the bottom, azimuth 0 straight up, positive azimuth
//!   (+y, port) to the left. Bearing lines carry their signed azimuths.
//! - A raw-layout panel (range bins × beams) puts range bin 0 (`range_min`) at the bottom and
//!   the port-most beam on the left, so beam 0 (starboard-most) is at the right. Its columns
//!   are the NPY's mirrored. Its beam axis shows beam indices, with "beam N-1 (port, +A/2)" and
//!   "beam 0 (starboard, -A/2)" at the ends.
//! - A sidescan strip is vertical, range increasing upwards.
//! - A screen pixel shows every bin it covers, so a mask one bin thin is never lost. Masks of a
//!   few pixels are circled or pointed at.
//!
//! NPY files keep their documented layout: row 0 is `range_min`, and column 0 is beam 0, the
//! starboard-most (`-aperture/2`). `project --flip-range`/`--flip-beams` flip the NPY only and
//! are refused with a PNG.
//!
//! Figures (paper, sweep) keep legends and colour-bar labels outside the data area, and say when
//! a panel's colour scale is its own.

mod atomic;
pub mod figures;
pub mod mask_image;
pub mod occupancy_image;
mod picture;
mod style;
mod writeback;

use sonarproj::error::Field;
use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};
pub use atomic::{
    check_output_file, note_input, note_stdin, read_config, remove_live_temporaries,
    remove_stale_temporaries, write_atomic, write_atomic_unsynced,
};

/// Writes `values` to `w` as an NPY array of `shape` (named `path` in errors).
///
/// # Errors
/// [`Error::WriteOutput`] on I/O failure.
pub fn write_npy<T: npyz::AutoSerialize>(
    w: &mut dyn Write,
    shape: &[u64],
    values: impl IntoIterator<Item = T>,
    path: &Path,
) -> Result<()> {
    use npyz::WriterBuilder;
    let err = |e: std::io::Error| Error::WriteOutput {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut writer = npyz::WriteOptions::<T>::new()
        .default_dtype()
        .shape(shape)
        .writer(w)
        .begin_nd()
        .map_err(err)?;
    writer.extend(values).map_err(err)?;
    writer.finish().map_err(err)
}

/// Returns `Ok` when `path`, the value of `field`, can be an output directory: a directory or
/// nothing yet. Commands call it before any work, and [`output_dir`] once there is something
/// to write, so a refused run leaves nothing behind.
///
/// # Errors
/// An input error naming `field` when `path` is empty or exists and is not a directory.
pub fn check_output_dir(path: &Path, field: impl Into<Field>) -> Result<()> {
    let field = field.into();
    if path.as_os_str().is_empty() {
        return Err(Error::invalid(field, "\"\"", "must name a directory"));
    }
    match std::fs::metadata(path) {
        Ok(m) if !m.is_dir() => Err(Error::invalid(
            field,
            path.display(),
            "is a file, not a directory; give a directory (created when missing)",
        )),
        Ok(_) => Ok(()),
        Err(_) => {
            // Missing: it is created with its parents, unless one of them is a file.
            match path
                .ancestors()
                .skip(1)
                .find(|a| !a.as_os_str().is_empty() && a.exists())
            {
                Some(a) if !a.is_dir() => Err(Error::invalid(
                    field,
                    path.display(),
                    format!("cannot be created: {} is a file, not a directory", a.display()),
                )),
                _ => Ok(()),
            }
        }
    }
}

/// Creates the output directory `path` (the value of `field`) with its parents, when missing.
///
/// # Errors
/// As [`check_output_dir`], or [`Error::WriteOutput`] when it cannot be created.
pub fn output_dir(path: &Path, field: impl Into<Field>) -> Result<()> {
    check_output_dir(path, field)?;
    std::fs::create_dir_all(path).map_err(|e| Error::WriteOutput {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}
