//! The drawing style every picture and figure shares, and nothing else of the reports: the
//! embedded font and its sizes, the colours of the picture convention, text set in that font
//! (anchored, rotated, measured, wrapped), the figure error, and an RGB canvas written out as
//! PNG. A leaf: it imports no other drawing module.
use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::{Error, Result};
use crate::report::atomic::write_atomic;

/// The font family of every picture and figure (registered from embedded bytes by [`fonts`]).
pub(crate) const FONT: &str = "sans-serif";

/// Font size (px) of the figures' tick labels.
pub(crate) const TICKS: u32 = 17;
/// Font size (px) of the figures' axis titles.
pub(crate) const AXES: u32 = 19;
/// Font size (px) of the figures' panel captions.
pub(crate) const CAPTION: u32 = 21;
/// Font size (px) of the figures' titles.
pub(crate) const TITLE: u32 = 28;

/// Font size (px) of the pictures' notes and tick labels.
pub(crate) const SMALL: u32 = 17;
/// Font size (px) of the words "port" and "starboard" and of panel headings.
pub(crate) const MEDIUM: u32 = 20;
/// Font size (px) of a picture's title.
pub(crate) const LARGE: u32 = 26;

/// The colour of the field of view where nothing is occupied.
pub(crate) const EMPTY: (u8, u8, u8) = (235, 235, 235);
/// The colour of axes, rings and bearing lines.
pub(crate) const GREY: RGBColor = RGBColor(90, 90, 90);

/// A drawing area over an RGB buffer.
pub(crate) type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Registers the embedded font once (plotters' ab_glyph backend has no system fonts).
pub(crate) fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TTF shipped by the crate; failure would be a packaging bug.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
    });
}

/// Returns a figure error (a failure of this program, exit status 1).
pub(crate) fn plot_error(e: impl std::fmt::Display) -> Error {
    Error::Figure(e.to_string())
}

/// Draws `s` at `at` in `size` px, anchored by `h` and `v`.
pub(crate) fn text(area: &Area<'_>, s: &str, at: (i32, i32), size: u32, h: HPos, v: VPos) -> Result<()> {
    let style = TextStyle::from((FONT, size).into_font())
        .color(&BLACK)
        .pos(Pos::new(h, v));
    area.draw_text(s, &style, at).map_err(plot_error)
}

/// Draws `s` at `at` in `size` px, rotated to read upwards, centred on `at`.
pub(crate) fn text_up(area: &Area<'_>, s: &str, at: (i32, i32), size: u32) -> Result<()> {
    let style = TextStyle::from((FONT, size).into_font().transform(FontTransform::Rotate270))
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Center));
    area.draw_text(s, &style, at).map_err(plot_error)
}

/// Returns the width (px) of `s` in `size` px.
pub(crate) fn text_width(area: &Area<'_>, s: &str, size: u32) -> Result<u32> {
    let style = TextStyle::from((FONT, size).into_font());
    Ok(area.estimate_text_size(s, &style).map_err(plot_error)?.0)
}

/// Returns `s` broken into lines no wider than `width` px in `size` px, at spaces (a no-break
/// space holds a number to its unit).
pub(crate) fn wrap(area: &Area<'_>, s: &str, size: u32, width: u32) -> Result<Vec<String>> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in s.split(' ').filter(|w| !w.is_empty()) {
        let longer = if line.is_empty() {
            word.to_string()
        } else {
            format!("{line} {word}")
        };
        if !line.is_empty() && text_width(area, &longer, size)? > width {
            lines.push(std::mem::replace(&mut line, word.to_string()));
        } else {
            line = longer;
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    Ok(lines)
}

/// An RGB canvas (8 bits a channel, rows top to bottom) that plotters draws on in memory.
pub(crate) struct Canvas {
    /// Width (px).
    pub w: u32,
    /// Height (px).
    pub h: u32,
    /// The pixels, three bytes each.
    pub rgb: Vec<u8>,
}

impl Canvas {
    /// Returns a white `w × h` canvas.
    pub(crate) fn new(w: u32, h: u32) -> Self {
        Canvas {
            w,
            h,
            rgb: vec![255; (w as usize) * (h as usize) * 3],
        }
    }

    /// Paints pixel `(x, y)` with `c`.
    pub(crate) fn put(&mut self, x: u32, y: u32, c: (u8, u8, u8)) {
        let k = ((y as usize) * (self.w as usize) + x as usize) * 3;
        self.rgb[k..k + 3].copy_from_slice(&[c.0, c.1, c.2]);
    }

    /// Draws on the canvas with `draw` (text, lines, charts), then presents it.
    pub(crate) fn draw(&mut self, draw: impl FnOnce(&Area<'_>) -> Result<()>) -> Result<()> {
        fonts();
        let root = BitMapBackend::with_buffer(&mut self.rgb, (self.w, self.h)).into_drawing_area();
        draw(&root)?;
        root.present().map_err(plot_error)
    }

    /// Writes the canvas to `path` as an 8-bit RGB PNG, whole or not at all.
    pub(crate) fn write(&self, path: &Path) -> Result<()> {
        write_atomic(path, |out| {
            let mut enc = png::Encoder::new(out, self.w, self.h);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut writer = enc.write_header().map_err(plot_error)?;
            writer.write_image_data(&self.rgb).map_err(plot_error)?;
            writer.finish().map_err(plot_error)
        })
    }
}
