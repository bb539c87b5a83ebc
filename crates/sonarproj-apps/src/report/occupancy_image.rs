//! Occupancy buffers as files: PNG for a person, NPY for numpy.
//!
//! The NPY keeps the layout of docs/conventions.md. Row 0 is `range_min`, and column 0 is beam
//! 0 at `-aperture/2`: starboard, since +azimuth points to +y, port. `flip_range` puts
//! `range_max` in row 0, and `flip_beams` the port-most beam in column 0.
//!
//! The PNG follows the picture convention of [`crate::report`], whatever the NPY's orientation:
//! near range at the bottom, port on the left. An FLS is drawn as its raw layout, an SSS as a
//! vertical range strip.
#![expect(
    clippy::cast_possible_truncation,
    clippy::cast_possible_wrap,
    reason = "image sides are a sonar's range bins and beams, bounded by the sonar limits"
)]

use std::io::Write;
use std::path::Path;

use plotters::style::text_anchor::{HPos, VPos};

use crate::error::{Error, Result};
use crate::report::picture::{self, Pooled, Rect};
use crate::report::style::{Area, Canvas, MEDIUM, SMALL, text, wrap};
use crate::report::write_atomic;
use sonarproj::geometry::sonar::SonarKind;
use sonarproj::occupancy::{Layout, Occupancy};

/// The colour of occupied pixels in the PNG.
pub const OCCUPIED: (u8, u8, u8) = (31, 119, 180);

/// Which way the axes of a written NPY occupancy buffer run. The PNG always follows the
/// picture convention.
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
    /// A labelled RGB picture.
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
            crate::params::OCCUPANCY,
            path.display(),
            "the file name must end in .png or .npy",
        )),
    }
}

/// Writes `occ`, drawn in `layout`, to `path` as PNG or NPY by the extension, whole or not at
/// all. `orientation` applies to the NPY only. The PNG, headed by `title`, always shows near
/// range at the bottom and port on the left.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] for another extension. [`Error::Figure`] or
/// [`Error::WriteOutput`] on failure.
pub fn write(
    path: &Path,
    occ: &Occupancy,
    layout: &Layout,
    title: &str,
    orientation: Orientation,
) -> Result<()> {
    match check_extension(path)? {
        Format::Png => picture_of(occ, layout, title)?.write(path),
        Format::Npy => write_atomic(path, |w| write_npy(w, occ, orientation, path)),
    }
}

/// Returns the labelled picture of `occ`. An FLS shows its raw layout with a range axis and a
/// beam axis, beam 0 (starboard-most) at the right. An SSS shows a vertical range strip with a
/// range axis. Near range is at the bottom.
fn picture_of(occ: &Occupancy, layout: &Layout, title: &str) -> Result<Canvas> {
    let layers = [(Pooled::new(occ), OCCUPIED)];
    let occupied = format!(
        "Blue: occupied ({} of {}); light grey: empty",
        occ.count(),
        layout.pixels()
    );
    if layout.kind == SonarKind::Sss {
        let sides = picture::sidescan_strips(layout, occ);
        let extent = picture::strips_extent(sides.iter().map(|s| &s.1));
        let layers: Vec<_> = sides.iter().map(|s| (Pooled::new(&s.1), OCCUPIED)).collect();
        let (top, h) = (96u32, 480u32);
        let mut strips = picture::Strips::new(
            layout,
            (0..sides.len()).map(|k| k..k + 1).collect(),
            sides.iter().map(|s| s.0.to_string()).collect(),
            (0, top, h, 80),
            extent,
        );
        let x = strips.right + 40;
        let (w, canvas_h) = (x + 340, top + h + 40);
        let mut canvas = Canvas::new(w, canvas_h);
        strips.paint(&mut canvas, &layers, layout.range_bins);
        canvas.draw(|a| {
            title_lines(a, title, w)?;
            strips.annotate(a, layout)?;
            let notes = [
                format!(
                    "Sidescan range strip: near range at the bottom; {} range bins{} from {}\u{a0}m to {}\u{a0}m.",
                    layout.range_bins,
                    if layout.two_sided() { " a side" } else { "" },
                    layout.range_min,
                    layout.range_max
                ),
                match extent {
                    Some((i0, i1)) => format!(
                        "Occupied: {:.2}–{:.2} m.",
                        layout.range_edge(i0),
                        layout.range_edge(i1 + 1)
                    ),
                    None => "Nothing occupied.".to_string(),
                },
                if layout.two_sided() {
                    "Two sides: the port strip left, the starboard strip right; a strip's width means nothing.".to_string()
                } else {
                    "One beam: the strip has no port or starboard axis, and its width means nothing.".to_string()
                },
                format!("{occupied}; a few bins thin are marked by triangles."),
            ];
            notes_at(a, &notes, (x as i32, top as i32), w - x - 20)
        })?;
        return Ok(canvas);
    }
    let (pw, ph) = (
        (occ.beams as u32).clamp(360, 600),
        (occ.range_bins as u32).clamp(400, 600),
    );
    let plot = Rect {
        x: 110,
        y: 96,
        w: pw,
        h: ph,
    };
    let (w, h) = ((plot.right() + 60).max(660), plot.bottom() + 140);
    let mut canvas = Canvas::new(w, h);
    let extents = picture::paint_raw(&mut canvas, plot, (&layers, None), 0..occ.range_bins, occ.beams);
    canvas.draw(|a| {
        title_lines(a, title, w)?;
        text(
            a,
            "raw layout (range bin × beam)",
            (plot.x as i32 + plot.w as i32 / 2, plot.y as i32 - 10),
            MEDIUM,
            HPos::Center,
            VPos::Bottom,
        )?;
        picture::frame(a, plot)?;
        picture::range_axis(a, plot, layout.range_min, layout.range_max)?;
        picture::beam_axis(a, plot, layout)?;
        picture::circle_small(a, &extents, &[OCCUPIED])?;
        let notes = [
            "Near range at the bottom, port on the left: beam 0 (starboard-most, the NPY's column 0) at the right."
                .to_string(),
            if picture::any_circled(&extents) {
                format!("{occupied}; circled: it is only a few pixels across.")
            } else {
                format!("{occupied}.")
            },
        ];
        notes_at(a, &notes, (20, plot.bottom() as i32 + 62), w - 40)
    })?;
    Ok(canvas)
}

/// Draws `title` at the top in up to two lines.
fn title_lines(a: &Area<'_>, title: &str, w: u32) -> Result<()> {
    let mut y = 14;
    for line in wrap(a, title, MEDIUM, w - 40)?.iter().take(2) {
        text(a, line, (20, y), MEDIUM, HPos::Left, VPos::Top)?;
        y += 26;
    }
    Ok(())
}

/// Draws `notes` from `(x, y)` down, each wrapped to `width` px.
fn notes_at(a: &Area<'_>, notes: &[String], (x, mut y): (i32, i32), width: u32) -> Result<()> {
    for note in notes {
        for line in wrap(a, note, SMALL, width)? {
            text(a, &line, (x, y), SMALL, HPos::Left, VPos::Top)?;
            y += 24;
        }
        y += 8;
    }
    Ok(())
}

/// Writes a `uint8` NPY array of 0/1, of shape `[range_bins, beams]` for an FLS image and
/// `[range_bins]` for an SSS.
fn write_npy(w: &mut dyn Write, occ: &Occupancy, o: Orientation, path: &Path) -> Result<()> {
    let shape: Vec<u64> = if occ.beams == 1 {
        vec![occ.range_bins as u64]
    } else {
        vec![occ.range_bins as u64, occ.beams as u64]
    };
    crate::report::write_npy(w, &shape, occ.to_bytes(o.flip_range, o.flip_beams), path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sonarproj::Sonar;

    /// Returns the occupancy of `layout` with the pixel at range `r` (m), azimuth `az` (deg).
    fn one_pixel(layout: &Layout, r: f64, az: f64) -> Occupancy {
        let mut occ = Occupancy::new(layout.range_bins, layout.beams());
        occ.set(layout.range_bin(r), layout.beam(az.to_radians()));
        occ
    }

    #[test]
    fn npy_keeps_its_layout_and_flips() {
        let layout = Layout::of(&Sonar::preset("paper-fls").unwrap());
        let (rows, beams) = (layout.range_bins, layout.beams());
        let occ = one_pixel(&layout, 2.0, 20.0);
        let (i, j) = (layout.range_bin(2.0), layout.beam(20f64.to_radians()));
        // Port (+azimuth) is in the upper half of the beams, since column 0 is starboard.
        assert!(j > beams / 2);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("o.npy");
        for (flip_range, flip_beams, want) in [
            (false, false, (i, j)),
            (true, false, (rows - 1 - i, j)),
            (false, true, (i, beams - 1 - j)),
            (true, true, (rows - 1 - i, beams - 1 - j)),
        ] {
            let o = Orientation {
                flip_range,
                flip_beams,
            };
            write(&path, &occ, &layout, "test", o).unwrap();
            let bytes = std::fs::read(&path).unwrap();
            let npy = npyz::NpyFile::new(bytes.as_slice()).unwrap();
            assert_eq!(npy.shape(), &[rows as u64, beams as u64]);
            let data: Vec<u8> = npy.into_vec().unwrap();
            let set: Vec<usize> = (0..data.len()).filter(|&k| data[k] == 1).collect();
            assert_eq!(
                set,
                vec![want.0 * beams + want.1],
                "flips {flip_range} {flip_beams}"
            );
        }
    }
}
