//! The drawing style that every picture and figure shares: the embedded font and its sizes,
//! the colours of the picture convention, text in that font (anchored, rotated, measured,
//! wrapped), the figure error, and an RGB canvas written as PNG. A leaf module: it imports no
//! other drawing module.
use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind};

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
pub(crate) type Area<'a> = DrawingArea<Glyphs<'a>, Shift>;

/// The bitmap backend, with each glyph set at its pen position plus its left side bearing.
/// plotters 0.3.7's ab_glyph backend puts the ink at the pen position itself (it drops
/// `px_bounds().min.x`), so narrow and round letters drift and words run together
/// ("paper-sssto", "1 5 m"). Its layout (advances and kerning) is right and kept for anchoring.
pub(crate) struct Glyphs<'a>(BitMapBackend<'a>);

/// Returns the embedded font as ab_glyph reads it (the bytes [`fonts`] registers).
fn font() -> &'static ab_glyph::FontRef<'static> {
    static FONT_REF: std::sync::OnceLock<ab_glyph::FontRef<'static>> = std::sync::OnceLock::new();
    FONT_REF.get_or_init(|| {
        ab_glyph::FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT)
            .expect("the crate's embedded font is a valid TTF")
    })
}

impl DrawingBackend for Glyphs<'_> {
    type ErrorType = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }

    fn ensure_prepared(&mut self) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.ensure_prepared()
    }

    fn present(&mut self) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        (iw, ih): (u32, u32),
        src: &[u8],
    ) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.blit_bitmap(pos, (iw, ih), src)
    }

    /// Draws `text` anchored and turned as plotters does (layout box, anchor, transform), with
    /// each glyph's ink at the pen position plus its side bearing.
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_possible_wrap,
        reason = "font sizes and glyph pixels of pictures a few thousand pixels wide"
    )]
    fn draw_text<TStyle: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &TStyle,
        pos: BackendCoord,
    ) -> std::result::Result<(), DrawingErrorKind<Self::ErrorType>> {
        use ab_glyph::{Font, ScaleFont};
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let ((min_x, min_y), (max_x, max_y)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (max_x - min_x, max_y - min_y);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let transform = style.transform();
        let (w, h) = self.get_size();
        let size = style.size() as f32;
        let font = font().as_scaled(size);
        let mut pen = 0f32;
        let mut previous = None;
        for c in text.chars() {
            let id = font.glyph_id(c);
            if let Some(p) = previous {
                pen += font.kern(p, id);
            }
            previous = Some(id);
            // Placed at the pen, the outline's bounds carry the side bearing and the pen's
            // fraction of a pixel.
            let glyph = id.with_scale_and_position(font.scale(), ab_glyph::point(pen, 0.0));
            if let Some(outline) = font.outline_glyph(glyph) {
                let bounds = outline.px_bounds();
                // Vertically as plotters sets it, so layouts do not move.
                let (x0, y0) = (bounds.min.x as i32, (size / 2.0 + bounds.min.y) as i32);
                let mut ink = Vec::new();
                outline.draw(|x, y, coverage| ink.push((x as i32 + x0, y as i32 + y0, coverage)));
                for (x, y, coverage) in ink {
                    let (x, y) = transform.transform(x + dx - min_x, y + dy - min_y);
                    let (x, y) = (pos.0 + x, pos.1 + y);
                    if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 {
                        let shade = BackendColor {
                            alpha: color.alpha * f64::from(coverage),
                            rgb: color.rgb,
                        };
                        self.0.draw_pixel((x, y), shade)?;
                    }
                }
            }
            pen += font.h_advance(id);
        }
        Ok(())
    }
}

/// Registers the embedded font once (plotters' ab_glyph backend has no system fonts).
pub(crate) fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TTF shipped with the crate. Failure would be a packaging bug.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
    });
}

/// Returns a figure error: a failure of this program (exit status 1).
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

/// Returns `s` broken at spaces into lines no wider than `width` px in `size` px. A no-break
/// space keeps a number with its unit.
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
        let root = Glyphs(BitMapBackend::with_buffer(&mut self.rgb, (self.w, self.h))).into_drawing_area();
        draw(&root)?;
        root.present().map_err(plot_error)
    }

    /// Writes the canvas to `path` as an 8-bit RGB PNG, whole or not at all.
    pub(crate) fn write(&self, path: &Path) -> Result<()> {
        write_atomic(path, |out| {
            let mut enc = png::Encoder::new(out, self.w, self.h);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            // Deflate level 3 over rows filtered against the row above: a figure's flat colour
            // and thin lines pack as small as at the default level 6 (±6 %) in half the time.
            enc.set_deflate_compression(png::DeflateCompression::Level(3));
            enc.set_filter(png::Filter::Up);
            let mut writer = enc.write_header().map_err(plot_error)?;
            writer.write_image_data(&self.rgb).map_err(plot_error)?;
            writer.finish().map_err(plot_error)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ab_glyph::{Font, ScaleFont};

    /// Returns the first column of each run of columns in `canvas` that holds ink (a pixel darker
    /// than mid grey).
    fn ink_starts(canvas: &Canvas) -> Vec<i32> {
        let (w, h) = (canvas.w as usize, canvas.h as usize);
        let ink: Vec<bool> = (0..w)
            .map(|x| (0..h).any(|y| canvas.rgb[(y * w + x) * 3] < 128))
            .collect();
        (0..w)
            .filter(|&x| ink[x] && (x == 0 || !ink[x - 1]))
            .map(|x| i32::try_from(x).expect("a picture a few hundred pixels wide"))
            .collect()
    }

    #[test]
    fn glyphs_sit_at_their_pen_position_plus_their_side_bearing() {
        // In this font "1" has a wide left side bearing and "5" a narrow one. Set without
        // the bearing, as plotters' own renderer does, the "5" starts too early.
        let size = 200;
        let mut canvas = Canvas::new(600, 320);
        canvas
            .draw(|a| text(a, "15", (20, 160), size, HPos::Left, VPos::Center))
            .unwrap();
        let starts = ink_starts(&canvas);
        assert_eq!(starts.len(), 2, "two glyphs, two runs of ink: {starts:?}");
        let font = font().as_scaled(size as f32);
        let (one, five) = (font.glyph_id('1'), font.glyph_id('5'));
        let (lsb_one, lsb_five) = (font.h_side_bearing(one), font.h_side_bearing(five));
        assert!(
            lsb_one - lsb_five > 3.0,
            "the test needs bearings that differ: {lsb_one}, {lsb_five}"
        );
        let first = (starts[0] - 20) as f32;
        assert!(
            (first - lsb_one).abs() <= 1.5,
            "'1' inks at +{first} px, its bearing is {lsb_one}"
        );
        let gap = (starts[1] - starts[0]) as f32;
        let want = font.h_advance(one) + font.kern(one, five) + lsb_five - lsb_one;
        assert!(
            (gap - want).abs() <= 1.5,
            "'5' inks {gap} px after '1', typeset {want}"
        );
    }
}
