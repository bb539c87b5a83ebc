//! Occupancy buffers as files: PNG for a person, NPY for numpy.
//!
//! Orientation (README: Conventions): row 0 is `range_min`, column 0 is beam 0 at `-aperture/2` (starboard,
//! since +azimuth is toward +y, port). `flip_range` puts `range_max` in row 0 (near range at the
//! bottom of a picture, as most sonar viewers draw it); `flip_beams` puts the port-most beam in
//! column 0.
#![expect(
    clippy::cast_possible_truncation,
    reason = "image sides are a sonar's range bins and beams, bounded by the sonar limits"
)]

use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};
use crate::report::write_atomic;
use sonarproj::occupancy::Occupancy;

/// Width in pixels of the strip a PNG of an SSS (one beam) is drawn as.
pub const SSS_STRIP_WIDTH: usize = 32;

/// Which way the axes of a written occupancy buffer run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Orientation {
    /// Row 0 is `range_max` instead of `range_min`.
    pub flip_range: bool,
    /// Column 0 is the last beam (`+aperture/2`, port) instead of the first.
    pub flip_beams: bool,
}

/// The file formats an occupancy buffer can be written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// 8-bit grayscale PNG.
    Png,
    /// NumPy `uint8` array.
    Npy,
}

/// Returns the format named by `path`'s extension (`.png`, `.npy`).
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `--occupancy` for any other extension.
pub fn check_extension(path: &Path) -> Result<Format> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => Ok(Format::Png),
        Some("npy") => Ok(Format::Npy),
        _ => Err(Error::invalid(
            "--occupancy",
            path.display(),
            "the file name must end in .png or .npy",
        )),
    }
}

/// Writes `occ` to `path` as PNG or NPY, chosen by the extension, whole or not at all.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] for another extension; [`Error::WriteOutput`] on I/O failure.
pub fn write(path: &Path, occ: &Occupancy, orientation: Orientation) -> Result<()> {
    match check_extension(path)? {
        Format::Png => write_atomic(path, |w| write_png(w, occ, orientation, path)),
        Format::Npy => write_atomic(path, |w| write_npy(w, occ, orientation, path)),
    }
}

/// Writes an 8-bit grayscale PNG: occupied 255, empty 0; `range_bins` rows × `beams` columns
/// (an SSS as a strip [`SSS_STRIP_WIDTH`] pixels wide).
fn write_png(w: &mut dyn Write, occ: &Occupancy, o: Orientation, path: &Path) -> Result<()> {
    let bytes = occ.to_bytes(o.flip_range, o.flip_beams);
    let (width, data): (usize, Vec<u8>) = if occ.beams == 1 {
        let strip = bytes
            .iter()
            .flat_map(|&b| std::iter::repeat_n(b * 255, SSS_STRIP_WIDTH))
            .collect();
        (SSS_STRIP_WIDTH, strip)
    } else {
        (occ.beams, bytes.iter().map(|&b| b * 255).collect())
    };
    let err = |e: &dyn std::fmt::Display| Error::WriteOutput {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut enc = png::Encoder::new(w, width as u32, occ.range_bins as u32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(|e| err(&e))?;
    writer.write_image_data(&data).map_err(|e| err(&e))?;
    writer.finish().map_err(|e| err(&e))?;
    Ok(())
}

/// Writes a `uint8` NPY array of 0/1: shape `[range_bins, beams]` for an FLS image,
/// `[range_bins]` for an SSS.
fn write_npy(w: &mut dyn Write, occ: &Occupancy, o: Orientation, path: &Path) -> Result<()> {
    let shape: Vec<u64> = if occ.beams == 1 {
        vec![occ.range_bins as u64]
    } else {
        vec![occ.range_bins as u64, occ.beams as u64]
    };
    crate::report::write_npy(w, &shape, occ.to_bytes(o.flip_range, o.flip_beams), path)
}
