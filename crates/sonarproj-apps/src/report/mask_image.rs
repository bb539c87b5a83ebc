//! Masks as pictures and arrays, each feature in its own colour.
//! - A PNG of sonar 2's image as a person looks at it, by the picture convention of
//!   [`crate::report`]. An FLS is a fan seen from above, with range rings and bearing lines,
//!   beside its raw layout. An SSS is one vertical range strip per feature, plus their union.
//! - NPY arrays of the raw masks or counts: row 0 = `range_min`, beam 0 = starboard-most.
#![expect(
    clippy::cast_possible_truncation,
    clippy::cast_possible_wrap,
    reason = "pixel coordinates and palette indices of images a few thousand pixels wide"
)]

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::error::Result;
use crate::report;
use crate::report::picture::{self, Backdrop, Fan, Pooled, Rect};
use crate::report::style::{Area, Canvas, LARGE, MEDIUM, SMALL, plot_error, text, text_width, wrap};
use crate::report::write_atomic;
use sonarproj::geometry::sonar::SonarKind;
use sonarproj::masks::Mask;
use sonarproj::occupancy::{Layout, Occupancy};

/// Feature colours (Tableau 10), cycled.
const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// Returns the colour of feature `k`.
#[must_use]
pub fn colour(k: usize) -> RGBColor {
    let (r, g, b) = PALETTE[k % PALETTE.len()];
    RGBColor(r, g, b)
}

fn rgb(k: usize) -> (u8, u8, u8) {
    PALETTE[k % PALETTE.len()]
}

/// Width (px) of a mask picture of an FLS target.
const FLS_WIDTH: u32 = 1500;

/// An image of an imaging sonar 2 to draw its masks over: the ping they are drawn for, read
/// from an NPY file in the raw layout (`sonar from-oculus` writes one beside its sonar file).
pub struct PingImage {
    backdrop: Backdrop,
    /// The file, for the picture's notes.
    source: String,
}

impl PingImage {
    /// Returns the image in the NPY file `path` for the imaging sonar of `layout`: a 2-D array
    /// `(range_bins, beams)` of integers (8 to 64 bits) or floats, row 0 the nearest range and
    /// column 0 the starboard-most beam. `field` names the input in errors.
    ///
    /// # Errors
    /// [`crate::Error::ReadInput`] when the file cannot be read or is not NPY. An input error
    /// naming `field` when sonar 2 is a sidescan, or the array's shape or type does not fit.
    pub fn read(path: &Path, layout: &Layout, field: &str) -> Result<PingImage> {
        use npyz::{DType, TypeChar};
        let invalid = |why: String| crate::Error::invalid(field, path.display(), why);
        if layout.kind != SonarKind::Fls {
            return Err(invalid(
                "sonar 2 is a sidescan: an image is drawn under an imaging sonar's masks only".into(),
            ));
        }
        let read_err = |source: std::io::Error| crate::Error::ReadInput {
            path: path.to_path_buf(),
            source,
        };
        // A FIFO or device is refused unread, never waited on.
        let file = sonarproj::files::open_regular(path).map_err(read_err)?;
        let npy = npyz::NpyFile::new(std::io::BufReader::new(file)).map_err(read_err)?;
        let (rows, beams) = (layout.range_bins, layout.beams());
        let shape = npy.shape().to_vec();
        if shape != [rows as u64, beams as u64] {
            let shape: Vec<String> = shape.iter().map(ToString::to_string).collect();
            return Err(invalid(format!(
                "has shape ({}); sonar 2's image is (range_bins, beams) = ({rows}, {beams})",
                shape.join(", ")
            )));
        }
        let fortran = npy.order() == npyz::Order::Fortran;
        let kind = match npy.dtype() {
            DType::Plain(t) => Some((t.type_char(), t.size_field())),
            _ => None,
        };
        let values: Vec<f64> = match kind {
            Some((TypeChar::Uint, 1)) => widen(npy.into_vec::<u8>(), f64::from),
            Some((TypeChar::Uint, 2)) => widen(npy.into_vec::<u16>(), f64::from),
            Some((TypeChar::Uint, 4)) => widen(npy.into_vec::<u32>(), f64::from),
            Some((TypeChar::Uint, 8)) => widen(npy.into_vec::<u64>(), |v| v as f64),
            Some((TypeChar::Int, 1)) => widen(npy.into_vec::<i8>(), f64::from),
            Some((TypeChar::Int, 2)) => widen(npy.into_vec::<i16>(), f64::from),
            Some((TypeChar::Int, 4)) => widen(npy.into_vec::<i32>(), f64::from),
            Some((TypeChar::Int, 8)) => widen(npy.into_vec::<i64>(), |v| v as f64),
            Some((TypeChar::Float, 4)) => widen(npy.into_vec::<f32>(), f64::from),
            Some((TypeChar::Float, 8)) => widen(npy.into_vec::<f64>(), |v| v),
            _ => {
                return Err(invalid(format!(
                    "holds {}: an image is integers (8 to 64 bits) or floats (32 or 64 bits)",
                    npy.dtype().descr()
                )));
            }
        }
        .map_err(read_err)?;
        // A Fortran-ordered array lists its columns one after the other.
        let values = if fortran {
            (0..rows * beams)
                .map(|k| values[(k % beams) * rows + k / beams])
                .collect()
        } else {
            values
        };
        Ok(PingImage {
            backdrop: Backdrop::new(rows, beams, &values),
            source: path.display().to_string(),
        })
    }
}

/// Returns `values` read from an NPY file as f64.
fn widen<T>(values: std::io::Result<Vec<T>>, f: impl Fn(T) -> f64) -> std::io::Result<Vec<f64>> {
    values.map(|v| v.into_iter().map(f).collect())
}

/// Writes the mask picture of `masks` in `layout` to `path` as PNG, whole or not at all.
/// `title` heads it and `labels` name the features. It follows the convention of
/// [`crate::report`]: an FLS target as the fan beside the raw layout, drawn over `image` when
/// given, an SSS target as one vertical strip per feature plus their union.
///
/// # Errors
/// [`crate::Error::Figure`] or [`crate::Error::WriteOutput`].
pub fn write_png(
    path: &Path,
    layout: &Layout,
    masks: &[Mask],
    (title, labels): (&str, &[String]),
    image: Option<&PingImage>,
) -> Result<()> {
    let canvas = match layout.kind {
        SonarKind::Fls => {
            let layers: Vec<(Pooled, (u8, u8, u8))> = masks
                .iter()
                .enumerate()
                .map(|(k, m)| (Pooled::new(&m.occupancy), rgb(k)))
                .collect();
            fls_picture(layout, &layers, (title, labels), image)?
        }
        SonarKind::Sss => sss_picture(layout, masks, title, labels)?,
    };
    canvas.write(path)
}

/// Draws the legend, a swatch and a label per feature, in rows from `(x, y)` within `width`
/// px. Returns the y under it.
fn legend_rows(area: &Area<'_>, labels: &[String], (x, y): (i32, i32), width: i32) -> Result<i32> {
    let (mut lx, mut ly) = (x, y);
    for (k, l) in labels.iter().enumerate() {
        let w = text_width(area, l, SMALL)? as i32 + 44;
        if lx > x && lx + w > x + width {
            (lx, ly) = (x, ly + 26);
        }
        area.draw(&Rectangle::new(
            [(lx, ly + 2), (lx + 16, ly + 18)],
            colour(k).filled(),
        ))
        .map_err(plot_error)?;
        text(area, l, (lx + 22, ly + 10), SMALL, HPos::Left, VPos::Center)?;
        lx += w;
    }
    Ok(ly + 26)
}

/// The mask picture of an FLS target: the fan and the raw layout, over `image` when given.
fn fls_picture(
    layout: &Layout,
    layers: &[(Pooled, (u8, u8, u8))],
    (title, labels): (&str, &[String]),
    image: Option<&PingImage>,
) -> Result<Canvas> {
    // Measure the legend on a scratch canvas first: it may take several rows.
    let mut scratch = Canvas::new(FLS_WIDTH, 200);
    let mut legend_bottom = 0;
    scratch.draw(|a| {
        legend_bottom = legend_rows(a, labels, (40, 56), FLS_WIDTH as i32 - 80)?;
        Ok(())
    })?;
    // Room above the fan for the bearing labels.
    let top = legend_bottom as u32 + 44;
    let (scale, fw, fh) = Fan::fit(layout, 800, 720);
    let fan_rect = Rect {
        x: 60 + (800 - fw) / 2,
        y: top,
        w: fw,
        h: fh,
    };
    let raw = Rect {
        x: 1000,
        y: top,
        w: 440,
        h: fh.clamp(480, 720),
    };
    let bottom = fan_rect.bottom().max(raw.bottom());
    // A line more of notes under a picture drawn over an image.
    let notes = if image.is_some() { 186 } else { 160 };
    let mut canvas = Canvas::new(FLS_WIDTH, bottom + notes);
    let fan = Fan::in_box(layout, fan_rect, scale);
    let backdrop = image.map(|i| &i.backdrop);
    let fan_extents = fan.paint(&mut canvas, fan_rect, layout, (layers, backdrop));
    let raw_extents = picture::paint_raw(
        &mut canvas,
        raw,
        (layers, backdrop),
        0..layout.range_bins,
        layout.beams(),
    );
    let colours: Vec<(u8, u8, u8)> = layers.iter().map(|l| l.1).collect();
    canvas.draw(|a| {
        text(a, title, (40, 16), LARGE, HPos::Left, VPos::Top)?;
        legend_rows(a, labels, (40, 56), FLS_WIDTH as i32 - 80)?;
        fan.annotate(a, fan_rect, layout)?;
        picture::circle_small(a, &fan_extents, &colours)?;
        picture::frame(a, raw)?;
        text(
            a,
            "raw layout (range bin × beam)",
            (raw.x as i32 + raw.w as i32 / 2, raw.y as i32 - 10),
            MEDIUM,
            HPos::Center,
            VPos::Bottom,
        )?;
        picture::range_axis(a, raw, layout.range_min, layout.range_max)?;
        picture::beam_axis(a, raw, layout)?;
        picture::circle_small(a, &raw_extents, &colours)?;
        let y = bottom as i32 + 74;
        let sonar_at = if layout.half_azimuth > std::f64::consts::FRAC_PI_2 {
            "the sonar at the centre"
        } else {
            "the sonar at the bottom"
        };
        text(
            a,
            &format!(
                "Fan seen from above: {sonar_at}, azimuth 0 up, port (+azimuth) on the left, starboard on the right."
            ),
            (40, y),
            SMALL,
            HPos::Left,
            VPos::Top,
        )?;
        text(
            a,
            &format!(
                "Raw layout: range bin 0 ({} m) at the bottom; beam 0 (starboard-most) at the right, so the columns are the NPY's mirrored.",
                layout.range_min
            ),
            (40, y + 26),
            SMALL,
            HPos::Left,
            VPos::Top,
        )?;
        let circled = picture::any_circled(&fan_extents) || picture::any_circled(&raw_extents);
        let colours = format!(
            "One colour per feature, mixed where masks overlap{}",
            if circled {
                "; masks of a few pixels are circled."
            } else {
                "."
            }
        );
        let lines = match image {
            Some(i) => vec![
                format!(
                    "Under the masks: the ping's image {} (black to white: its 0.5th to 99.5th percentile).",
                    i.source
                ),
                colours,
            ],
            None => vec![format!("Light grey: the field of view, empty. {colours}")],
        };
        for (k, line) in lines.iter().enumerate() {
            text(a, line, (40, y + 52 + 26 * k as i32), SMALL, HPos::Left, VPos::Top)?;
        }
        Ok(())
    })?;
    Ok(canvas)
}

/// The mask picture of an SSS target: one vertical range strip per feature plus their union,
/// over the whole range and zoomed on the masks, with the legend and notes beside them. A
/// two-sided sidescan shows the port strips, then the starboard strips.
fn sss_picture(layout: &Layout, masks: &[Mask], title: &str, labels: &[String]) -> Result<Canvas> {
    let n = masks.len();
    // Each mask's strips in range order: one, or port and starboard.
    let sides: Vec<Vec<(&str, Occupancy)>> = masks
        .iter()
        .map(|m| picture::sidescan_strips(layout, &m.occupancy))
        .collect();
    let side_names = picture::sidescan_sides(layout);
    let two = side_names.len();
    // Layers side by side: side s of feature k is layer s · n + k.
    let layers: Vec<(Pooled, (u8, u8, u8))> = (0..two)
        .flat_map(|s| {
            sides
                .iter()
                .enumerate()
                .map(move |(k, m)| (Pooled::new(&m[s].1), rgb(k)))
        })
        .collect();
    let pitch = (300 / (two * (n + 1)) as u32).clamp(4, 90);
    let mut groups: Vec<std::ops::Range<usize>> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for (s, side) in side_names.iter().enumerate() {
        groups.extend((0..n).map(|k| s * n + k..s * n + k + 1));
        groups.push(s * n..(s + 1) * n);
        names.extend((1..=n).map(|k| k.to_string()));
        // Short names keep narrow strips' labels apart: "all P", "all S".
        names.push(match side.chars().next() {
            Some(c) => format!("all {}", c.to_ascii_uppercase()),
            None => "all".to_string(),
        });
    }
    let extents: Vec<Option<(usize, usize)>> = sides
        .iter()
        .map(|m| picture::strips_extent(m.iter().map(|s| &s.1)))
        .collect();
    let occupied = extents
        .iter()
        .flatten()
        .fold(None, |acc: Option<(usize, usize)>, &(a, b)| {
            Some(acc.map_or((a, b), |(x, y)| (x.min(a), y.max(b))))
        });
    let (top, strip_h) = (110u32, 600u32);
    let mut strips = picture::Strips::new(layout, groups, names, (20, top, strip_h, pitch), occupied);
    let side_x = strips.right + 50;
    let (w, h) = ((side_x + 380).max(760), top + strip_h + 80);
    let mut canvas = Canvas::new(w, h);
    strips.paint(&mut canvas, &layers, layout.range_bins);
    canvas.draw(|a| {
        text(a, title, (40, 16), LARGE, HPos::Left, VPos::Top)?;
        strips.annotate(a, layout)?;
        text(
            a,
            if two == 2 {
                "port: one strip per feature and their union (all P), then the same to starboard (all S)"
            } else {
                "one strip per feature, their union (all) last"
            },
            (120, (top + strip_h) as i32 + 40),
            SMALL,
            HPos::Left,
            VPos::Top,
        )?;
        // Beside the strips: the features, where each mask lies, and the convention.
        let (x, mut y) = (side_x as i32, top as i32 - 30);
        text(a, "features, and where their masks lie", (x, y), MEDIUM, HPos::Left, VPos::Top)?;
        y += 34;
        let shown = n.min(14);
        for (k, e) in extents.iter().enumerate().take(shown) {
            let extent = match e {
                Some((i0, i1)) => format!(
                    "{:.2}–{:.2} m",
                    layout.range_edge(*i0),
                    layout.range_edge(i1 + 1)
                ),
                None => "not seen".to_string(),
            };
            a.draw(&Rectangle::new([(x, y + 2), (x + 16, y + 18)], colour(k).filled()))
                .map_err(plot_error)?;
            let label = labels.get(k).map_or_else(|| (k + 1).to_string(), Clone::clone);
            text(a, &format!("{label}  ->  {extent}"), (x + 24, y + 10), SMALL, HPos::Left, VPos::Center)?;
            y += 28;
        }
        if n > shown {
            text(a, &format!("and {} more", n - shown), (x, y), SMALL, HPos::Left, VPos::Top)?;
            y += 28;
        }
        y += 16;
        let notes = [
            format!(
                "Near range at the bottom: {} range bins{} from {}\u{a0}m to {}\u{a0}m.",
                layout.range_bins,
                if two == 2 { " a side" } else { "" },
                layout.range_min,
                layout.range_max
            ),
            if two == 2 {
                "A two-sided sidescan: each side's strips have range only, and a strip's width means nothing; the port strips are on the left.".to_string()
            } else {
                "A sidescan sonar has one beam: a strip has range only, no port or starboard axis, and its width means nothing. (A port and a starboard channel are two sonars.)".to_string()
            },
            "Light grey: range bins, empty. One colour per feature, mixed where masks overlap; masks a few pixels thin are marked by triangles.".to_string(),
        ];
        for note in notes {
            for line in wrap(a, &note, SMALL, w - side_x - 20)? {
                text(a, &line, (x, y), SMALL, HPos::Left, VPos::Top)?;
                y += 24;
            }
            y += 8;
        }
        Ok(())
    })?;
    Ok(canvas)
}

/// Writes the masks as NPY to `path`: `uint8` 0/1, or `uint32` counts with `counts`. The shape
/// is `[feature, range_bin, beam]` for an FLS target and `[feature, range_bin]` for an SSS
/// target. A two-sided one has `[feature, 2 × range_bins]`: port far to near, then starboard
/// near to far.
///
/// # Errors
/// [`crate::Error::WriteOutput`].
pub fn write_npy(path: &Path, layout: &Layout, masks: &[Mask], counts: bool) -> Result<()> {
    let (rows, columns) = layout.data_shape();
    let mut shape = vec![masks.len() as u64, rows as u64];
    if layout.kind == SonarKind::Fls {
        shape.push(columns as u64);
    }
    write_atomic(path, |w| {
        if counts {
            let counts = masks
                .iter()
                .flat_map(|m| m.counts.as_ref().expect("counts asked for").iter().copied());
            report::write_npy(w, &shape, counts, path)
        } else {
            report::write_npy(
                w,
                &shape,
                masks.iter().flat_map(|m| m.occupancy.to_bytes(false, false)),
                path,
            )
        }
    })
}
