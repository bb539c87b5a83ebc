//! Building blocks of the pictures of sonar data drawn for people: the mask and occupancy
//! PNGs. They follow the picture convention of [`crate::report`]: near range at the bottom,
//! port on the left.
//!
//! Data are painted pixel by pixel into an RGB canvas. A screen pixel takes the colours of
//! every layer occupying any bin it covers, so a mask one bin wide is never lost between two
//! screen pixels. Text and lines are then drawn over it with plotters.
#![expect(
    clippy::cast_possible_truncation,
    clippy::cast_possible_wrap,
    clippy::cast_sign_loss,
    reason = "pixel coordinates, bin indices and colours of images a few thousand pixels wide"
)]

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::error::Result;
use crate::report::style::{Area, Canvas, EMPTY, GREY, MEDIUM, SMALL, plot_error, text, text_up};
use sonarproj::occupancy::{Layout, Occupancy};

/// Returns a sidescan's `occ`, given in data order, as named strips in range order (near range
/// first): one unnamed strip, or the port strip then the starboard strip.
pub(crate) fn sidescan_strips(layout: &Layout, occ: &Occupancy) -> Vec<(&'static str, Occupancy)> {
    if !layout.two_sided() {
        return vec![("", occ.clone())];
    }
    let mut sides: Vec<(&'static str, Occupancy)> = sidescan_sides(layout)
        .iter()
        .map(|&name| (name, Occupancy::new(layout.range_bins, 1)))
        .collect();
    for (row, column) in occ.pixels() {
        let (i, beam) = layout.pixel_of_data(row * occ.beams + column);
        sides[1 - beam].1.set(i, 0);
    }
    sides
}

/// Returns the names of a sidescan's strips, in [`sidescan_strips`]' order: one unnamed
/// strip, or "port" then "starboard".
pub(crate) fn sidescan_sides(layout: &Layout) -> &'static [&'static str] {
    if layout.two_sided() {
        &["port", "starboard"]
    } else {
        &[""]
    }
}

/// Returns the first and last set range bin of any of `strips` (range order, one column).
pub(crate) fn strips_extent<'a>(strips: impl IntoIterator<Item = &'a Occupancy>) -> Option<(usize, usize)> {
    strips
        .into_iter()
        .flat_map(|o| {
            let mut rows = o.pixels().map(|(i, _)| i);
            let first = rows.next();
            first.map(|f| (f, rows.last().unwrap_or(f)))
        })
        .fold(None, |acc: Option<(usize, usize)>, (a, b)| {
            Some(acc.map_or((a, b), |(x, y)| (x.min(a), y.max(b))))
        })
}

/// A layer whose painted extent is smaller than this (px) both ways is circled.
const SMALL_EXTENT: u32 = 8;

/// A rectangle of screen pixels: left, top, width, height.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

impl Rect {
    /// Returns the right edge (exclusive).
    pub(crate) fn right(self) -> u32 {
        self.x + self.w
    }

    /// Returns the bottom edge (exclusive).
    pub(crate) fn bottom(self) -> u32 {
        self.y + self.h
    }
}

/// The screen pixels a layer was painted on: `(x0, y0, x1, y1)`, inclusive.
pub(crate) type Extent = (u32, u32, u32, u32);

/// Grows `e` to hold `(x, y)`.
pub(crate) fn grow(e: &mut Option<Extent>, x: u32, y: u32) {
    *e = Some(match *e {
        None => (x, y, x, y),
        Some((x0, y0, x1, y1)) => (x0.min(x), y0.min(y), x1.max(x), y1.max(y)),
    });
}

/// An occupancy with a summed-area table: whether any pixel of a block is occupied, at once.
pub(crate) struct Pooled {
    beams: usize,
    /// `sums[(i * (beams + 1)) + j]`: occupied pixels in rows `< i`, beams `< j`.
    sums: Vec<u32>,
}

impl Pooled {
    /// Returns the table of `occ`. It has at most 2^26 pixels, so the counts fit in u32.
    pub(crate) fn new(occ: &Occupancy) -> Self {
        let (rows, beams) = (occ.range_bins, occ.beams);
        let mut sums = vec![0u32; (rows + 1) * (beams + 1)];
        for i in 0..rows {
            let mut row = 0u32;
            for j in 0..beams {
                row += u32::from(occ.get(i, j));
                sums[(i + 1) * (beams + 1) + j + 1] = sums[i * (beams + 1) + j + 1] + row;
            }
        }
        Pooled { beams, sums }
    }

    /// Returns true when a pixel of rows `i0..i1` and beams `j0..j1` is occupied.
    pub(crate) fn any(&self, (i0, i1): (usize, usize), (j0, j1): (usize, usize)) -> bool {
        let s = |i: usize, j: usize| self.sums[i * (self.beams + 1) + j];
        s(i1, j1) + s(i0, j0) > s(i0, j1) + s(i1, j0)
    }
}

/// Returns the bins `lo..hi` (at least one) that screen pixel `k` of `n` covers, when `bins`
/// bins are spread evenly over the `n` pixels.
pub(crate) fn cover(k: u32, n: u32, bins: usize) -> (usize, usize) {
    let (k, n) = (k as usize, n as usize);
    let lo = (k * bins / n).min(bins - 1);
    let hi = ((k + 1) * bins).div_ceil(n).clamp(lo + 1, bins);
    (lo, hi)
}

/// Returns the blend (mean) of the colours of the `layers` for which `hit` is true, or `None`.
pub(crate) fn blend<'a>(
    layers: impl Iterator<Item = &'a (Pooled, (u8, u8, u8))>,
    mut hit: impl FnMut(&Pooled) -> bool,
) -> Option<(u8, u8, u8)> {
    let (mut s, mut n) = ([0u32; 3], 0u32);
    for (p, (r, g, b)) in layers {
        if hit(p) {
            s = [s[0] + u32::from(*r), s[1] + u32::from(*g), s[2] + u32::from(*b)];
            n += 1;
        }
    }
    (n > 0).then(|| ((s[0] / n) as u8, (s[1] / n) as u8, (s[2] / n) as u8))
}

/// A sonar image drawn in grey under the layers: the ping the masks are drawn for. Its values
/// run black to white from their 0.5th to their 99.5th percentile (the brightest few pixels of a
/// sonar image would otherwise leave the rest dark).
pub(crate) struct Backdrop {
    beams: usize,
    /// `sums[(i * (beams + 1)) + j]`: summed grey levels of rows `< i`, beams `< j`.
    sums: Vec<u64>,
}

impl Backdrop {
    /// Returns the backdrop of `values`, `rows × beams` in the raw layout (row 0 the nearest
    /// range, column 0 the starboard-most beam). A value that is not finite is black.
    pub(crate) fn new(rows: usize, beams: usize, values: &[f64]) -> Self {
        let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        finite.sort_by(f64::total_cmp);
        let at = |q: f64| {
            finite
                .get(((finite.len().saturating_sub(1)) as f64 * q).round() as usize)
                .copied()
                .unwrap_or(0.0)
        };
        let (lo, hi) = (at(0.005), at(0.995));
        let span = if hi > lo { hi - lo } else { 1.0 };
        let grey = |v: f64| {
            if v.is_finite() {
                (255.0 * ((v - lo) / span).clamp(0.0, 1.0)).round() as u64
            } else {
                0
            }
        };
        let mut sums = vec![0u64; (rows + 1) * (beams + 1)];
        for i in 0..rows {
            let mut row = 0u64;
            for j in 0..beams {
                row += grey(values[i * beams + j]);
                sums[(i + 1) * (beams + 1) + j + 1] = sums[i * (beams + 1) + j + 1] + row;
            }
        }
        Backdrop { beams, sums }
    }

    /// Returns the mean grey of rows `i0..i1` and beams `j0..j1` as a colour.
    fn colour(&self, (i0, i1): (usize, usize), (j0, j1): (usize, usize)) -> (u8, u8, u8) {
        let s = |i: usize, j: usize| self.sums[i * (self.beams + 1) + j];
        let n = ((i1 - i0) * (j1 - j0)).max(1) as u64;
        let g = ((s(i1, j1) + s(i0, j0) - s(i0, j1) - s(i1, j0)) / n) as u8;
        (g, g, g)
    }
}

/// What a picture paints: the layers, each with its colour, and the image under them if any.
pub(crate) type Ground<'a> = (&'a [(Pooled, (u8, u8, u8))], Option<&'a Backdrop>);

/// Returns the colour of a pixel: the layers' blend, over the backdrop's grey when there is
/// one (three parts colour, one part image), else the layers' blend or [`EMPTY`].
fn pixel(
    layers: &[(Pooled, (u8, u8, u8))],
    backdrop: Option<&Backdrop>,
    bins: (usize, usize),
    cols: (usize, usize),
) -> (u8, u8, u8) {
    let layer = blend(layers.iter(), |p| p.any(bins, cols));
    match (layer, backdrop) {
        (Some(c), None) => c,
        (None, None) => EMPTY,
        (None, Some(b)) => b.colour(bins, cols),
        (Some(c), Some(b)) => {
            let g = b.colour(bins, cols);
            let mix = |a: u8, b: u8| ((3 * u16::from(a) + u16::from(b)) / 4) as u8;
            (mix(c.0, g.0), mix(c.1, g.1), mix(c.2, g.2))
        }
    }
}

/// Paints `layers` of a raw layout into `rect`, and returns the screen pixels each was painted
/// on. Range bins `rows` are drawn, near at the bottom, and `beams` beams with beam 0
/// (starboard-most) on the right: the NPY's columns mirrored. An SSS is a vertical strip. A
/// `backdrop` is drawn under the layers.
pub(crate) fn paint_raw(
    canvas: &mut Canvas,
    rect: Rect,
    (layers, backdrop): Ground<'_>,
    rows: std::ops::Range<usize>,
    beams: usize,
) -> Vec<Option<Extent>> {
    let mut extents = vec![None; layers.len()];
    for y in 0..rect.h {
        let (lo, hi) = cover(rect.h - 1 - y, rect.h, rows.len());
        let bins = (rows.start + lo, rows.start + hi);
        for x in 0..rect.w {
            let (lo, hi) = cover(x, rect.w, beams);
            let cols = (beams - hi, beams - lo);
            let (sx, sy) = (rect.x + x, rect.y + y);
            for (k, (p, _)) in layers.iter().enumerate() {
                if p.any(bins, cols) {
                    grow(&mut extents[k], sx, sy);
                }
            }
            canvas.put(sx, sy, pixel(layers, backdrop, bins, cols));
        }
    }
    extents
}

/// The fan of an FLS on screen, seen from above: the sonar at `(ox, oy)` (px), `scale` px per
/// metre, azimuth 0 up and positive azimuth (port, +y) to the left.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fan {
    pub ox: f64,
    pub oy: f64,
    pub scale: f64,
}

impl Fan {
    /// Returns the fan of `layout` fitted into `w × h` pixels, with its box `(w, h)`: the sonar
    /// at the bottom centre, or lower for apertures over 180°.
    pub(crate) fn fit(layout: &Layout, w: u32, h: u32) -> (f64, u32, u32) {
        let (r_max, ha) = (layout.range_max, layout.half_azimuth);
        let half_width = r_max * ha.min(std::f64::consts::FRAC_PI_2).sin();
        let y_low = (r_max * ha.cos()).min(0.0);
        let scale = (f64::from(w) / (2.0 * half_width)).min(f64::from(h) / (r_max - y_low));
        let fw = (2.0 * half_width * scale).ceil() as u32;
        let fh = ((r_max - y_low) * scale).ceil() as u32;
        (scale, fw.min(w), fh.min(h))
    }

    /// Returns the fan of `layout` drawn in the box `rect` made by [`Fan::fit`] with `scale`.
    pub(crate) fn in_box(layout: &Layout, rect: Rect, scale: f64) -> Self {
        let y_low = (layout.range_max * layout.half_azimuth.cos()).min(0.0);
        Fan {
            ox: f64::from(rect.x) + f64::from(rect.w) / 2.0,
            oy: f64::from(rect.bottom()) + y_low * scale,
            scale,
        }
    }

    /// Returns the screen point of range `r` (m) and azimuth `az` (rad).
    pub(crate) fn at(self, r: f64, az: f64) -> (i32, i32) {
        (
            (self.ox - r * az.sin() * self.scale).round() as i32,
            (self.oy - r * az.cos() * self.scale).round() as i32,
        )
    }

    /// Returns `(r, az)` of the screen point `(sx, sy)` (px, fractional).
    fn polar(self, sx: f64, sy: f64) -> (f64, f64) {
        let (fy, fx) = ((self.ox - sx) / self.scale, (self.oy - sy) / self.scale);
        (fx.hypot(fy), fy.atan2(fx))
    }

    /// Paints the field of view of `layout` in `rect` with `layers` over it, and returns the screen
    /// pixels each layer was painted on. A pixel takes the colours of the layers holding any bin
    /// and beam it covers, over the `backdrop` when there is one.
    pub(crate) fn paint(
        self,
        canvas: &mut Canvas,
        rect: Rect,
        layout: &Layout,
        (layers, backdrop): Ground<'_>,
    ) -> Vec<Option<Extent>> {
        let mut extents = vec![None; layers.len()];
        let (r_min, r_max, ha) = (layout.range_min, layout.range_max, layout.half_azimuth);
        for y in rect.y..rect.bottom() {
            for x in rect.x..rect.right() {
                let (r, az) = self.polar(f64::from(x) + 0.5, f64::from(y) + 0.5);
                if r < r_min || r > r_max || az.abs() > ha {
                    continue;
                }
                // The corners bound the bins and beams the pixel covers.
                let (mut r_lo, mut r_hi, mut a_lo, mut a_hi) = (r, r, az, az);
                for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                    let (rc, ac) = self.polar(f64::from(x) + dx, f64::from(y) + dy);
                    (r_lo, r_hi, a_lo, a_hi) = (r_lo.min(rc), r_hi.max(rc), a_lo.min(ac), a_hi.max(ac));
                }
                if a_hi - a_lo > std::f64::consts::PI {
                    (a_lo, a_hi) = (-ha, ha);
                }
                let bins = (
                    layout.range_bin(r_lo.max(r_min)),
                    layout.range_bin(r_hi.min(r_max)) + 1,
                );
                let cols = (layout.beam(a_lo.max(-ha)), layout.beam(a_hi.min(ha)) + 1);
                for (k, (p, _)) in layers.iter().enumerate() {
                    if p.any(bins, cols) {
                        grow(&mut extents[k], x, y);
                    }
                }
                canvas.put(x, y, pixel(layers, backdrop, bins, cols));
            }
        }
        extents
    }

    /// Draws range rings labelled along the starboard edge, bearing lines labelled above the arc
    /// (positive azimuths to port), and "port" and "starboard" under the fan box `rect`.
    pub(crate) fn annotate(self, area: &Area<'_>, rect: Rect, layout: &Layout) -> Result<()> {
        let (r_max, ha) = (layout.range_max, layout.half_azimuth);
        let step = nice_step(r_max / 5.0);
        let mut k = 1.0;
        while k * step <= r_max + 1e-9 {
            let r = k * step;
            // Points a few pixels apart: shorter steps draw a dotted line.
            let n = (2.0 * ha * r * self.scale / 4.0).ceil().clamp(8.0, 400.0) as u32;
            let pts: Vec<(i32, i32)> = (0..=n)
                .map(|m| self.at(r, -ha + 2.0 * ha * f64::from(m) / f64::from(n)))
                .collect();
            area.draw(&PathElement::new(pts, GREY.stroke_width(1)))
                .map_err(plot_error)?;
            let (x, y) = self.at(r, -ha.min(std::f64::consts::FRAC_PI_2));
            text(
                area,
                &format!("{} m", number(r, step)),
                (x + 6, y + 2),
                SMALL,
                HPos::Left,
                VPos::Top,
            )?;
            k += 1.0;
        }
        let every = if ha > std::f64::consts::FRAC_PI_2 {
            30.0
        } else {
            15.0
        };
        let last = ((ha.to_degrees() + 1e-6) / every).floor() as i32;
        for m in -last..=last {
            let b = f64::from(m) * every;
            let a = b.to_radians();
            let end = self.at(r_max, a);
            area.draw(&PathElement::new(
                vec![self.at(layout.range_min, a), end],
                GREY.stroke_width(1),
            ))
            .map_err(plot_error)?;
            let (lx, ly) = self.at(r_max + 14.0 / self.scale, a);
            let h = if b > 0.5 {
                HPos::Right
            } else if b < -0.5 {
                HPos::Left
            } else {
                HPos::Center
            };
            text(
                area,
                &format!("{b:+.0}°").replace("+0°", "0°"),
                (lx, ly),
                SMALL,
                h,
                VPos::Bottom,
            )?;
        }
        // Under the fan box, lower when a wide fan's bearing labels sit at its corners.
        let y = rect.bottom() as i32 + if ha > std::f64::consts::FRAC_PI_2 { 26 } else { 8 };
        text(
            area,
            "port (+azimuth)",
            (rect.x as i32, y),
            MEDIUM,
            HPos::Left,
            VPos::Top,
        )?;
        text(
            area,
            "starboard (-azimuth)",
            (rect.right() as i32, y),
            MEDIUM,
            HPos::Right,
            VPos::Top,
        )?;
        Ok(())
    }
}

/// Vertical range strips of an SSS layout, near range at the bottom, one per group of layers
/// (a feature, or all together). A second set zooms on the occupied bins when they fill a
/// small part of the range.
pub(crate) struct Strips {
    /// Layers drawn in each strip.
    groups: Vec<std::ops::Range<usize>>,
    /// Names written under the strips.
    names: Vec<String>,
    /// The strips over the whole range.
    full: Vec<Rect>,
    /// The zoomed strips and the range bins they show.
    zoom: Option<(Vec<Rect>, std::ops::Range<usize>)>,
    /// Layers painted on only a few pixel rows of a strip: where, and their colour.
    thin: Vec<(Extent, (u8, u8, u8))>,
    /// The right edge of the strips' area (px).
    pub right: u32,
}

impl Strips {
    /// Returns the strips of `groups` named `names` in a picture: the panels' top at `y`, the
    /// range axis from `x`, `h` px tall, `pitch` px per strip. `occupied` is the first and last
    /// occupied range bin of any layer, if any.
    pub(crate) fn new(
        layout: &Layout,
        groups: Vec<std::ops::Range<usize>>,
        names: Vec<String>,
        (x, y, h, pitch): (u32, u32, u32, u32),
        occupied: Option<(usize, usize)>,
    ) -> Self {
        let n = groups.len() as u32;
        let sw = (pitch * 4 / 5).max(3);
        let panel = |x0: u32| -> Vec<Rect> {
            (0..n)
                .map(|k| Rect {
                    x: x0 + k * pitch + (pitch - sw) / 2,
                    y,
                    w: sw,
                    h,
                })
                .collect()
        };
        let full = panel(x + 100);
        let mut right = x + 100 + n * pitch;
        let rows = layout.range_bins;
        let zoom = occupied.and_then(|(i0, i1)| {
            let pad = (i1 - i0 + 1).div_ceil(2).max(5);
            let window = i0.saturating_sub(pad)..(i1 + 1 + pad).min(rows);
            (window.len() * 3 <= rows).then(|| {
                let rects = panel(right + 120);
                right += 120 + n * pitch;
                (rects, window)
            })
        });
        Strips {
            groups,
            names,
            full,
            zoom,
            thin: Vec::new(),
            right,
        }
    }

    /// Paints the strips of `layers` on `canvas`.
    pub(crate) fn paint(&mut self, canvas: &mut Canvas, layers: &[(Pooled, (u8, u8, u8))], rows: usize) {
        let mut panels = vec![(self.full.clone(), 0..rows)];
        panels.extend(self.zoom.clone());
        for (rects, window) in panels {
            for (rect, group) in rects.iter().zip(&self.groups) {
                let extents = paint_raw(canvas, *rect, (&layers[group.clone()], None), window.clone(), 1);
                for (e, layer) in extents.iter().zip(&layers[group.clone()]) {
                    if let Some(e) = e.filter(|e| e.3 - e.1 < SMALL_EXTENT) {
                        self.thin.push((e, layer.1));
                    }
                }
            }
        }
    }

    /// Draws the axes, headings, strip names and the marks of thin layers.
    pub(crate) fn annotate(&self, area: &Area<'_>, layout: &Layout) -> Result<()> {
        let mut panels = vec![(
            &self.full,
            layout.range_min,
            layout.range_max,
            "whole range".to_string(),
        )];
        if let Some((rects, window)) = &self.zoom {
            let (r0, r1) = (layout.range_edge(window.start), layout.range_edge(window.end));
            panels.push((rects, r0, r1, "zoomed on the occupied bins".to_string()));
        }
        for (rects, r0, r1, heading) in panels {
            let (first, last) = (rects[0], rects[rects.len() - 1]);
            let all = Rect {
                x: first.x,
                y: first.y,
                w: last.right() - first.x,
                h: first.h,
            };
            range_axis(area, all, r0, r1)?;
            text(
                area,
                &heading,
                (all.x as i32 - 60, all.y as i32 - 12),
                MEDIUM,
                HPos::Left,
                VPos::Bottom,
            )?;
            let pitch = rects.get(1).map_or(100, |r| r.x - first.x);
            for (k, (r, name)) in rects.iter().zip(&self.names).enumerate() {
                if pitch >= 24 || k + 1 == rects.len() {
                    text(
                        area,
                        name,
                        (r.x as i32 + r.w as i32 / 2, r.bottom() as i32 + 8),
                        SMALL,
                        HPos::Center,
                        VPos::Top,
                    )?;
                }
            }
        }
        let extents: Vec<Option<Extent>> = self.thin.iter().map(|t| Some(t.0)).collect();
        let colours: Vec<(u8, u8, u8)> = self.thin.iter().map(|t| t.1).collect();
        point_at_thin(area, &extents, &colours)
    }
}

/// Draws the outline of `rect`.
pub(crate) fn frame(area: &Area<'_>, rect: Rect) -> Result<()> {
    area.draw(&Rectangle::new(
        [
            (rect.x as i32 - 1, rect.y as i32 - 1),
            (rect.right() as i32, rect.bottom() as i32),
        ],
        GREY.stroke_width(1),
    ))
    .map_err(plot_error)
}

/// Returns whether [`circle_small`] circles any of `extents`.
pub(crate) fn any_circled(extents: &[Option<Extent>]) -> bool {
    extents
        .iter()
        .flatten()
        .any(|&(x0, y0, x1, y1)| x1 - x0 < SMALL_EXTENT && y1 - y0 < SMALL_EXTENT)
}

/// Circles each layer painted on fewer than a few pixels both ways, in its colour, so a mask
/// of one bin is seen.
pub(crate) fn circle_small(
    area: &Area<'_>,
    extents: &[Option<Extent>],
    colours: &[(u8, u8, u8)],
) -> Result<()> {
    for (e, &(r, g, b)) in extents.iter().zip(colours) {
        let Some((x0, y0, x1, y1)) = *e else {
            continue;
        };
        if x1 - x0 < SMALL_EXTENT && y1 - y0 < SMALL_EXTENT {
            let c = ((x0 + x1) as i32 / 2, (y0 + y1) as i32 / 2);
            area.draw(&Circle::new(c, 11, RGBColor(r, g, b).stroke_width(2)))
                .map_err(plot_error)?;
        }
    }
    Ok(())
}

/// Points, in the layer's colour, at each layer painted on fewer than a few pixel rows of a
/// strip: a small triangle in the gap right of the strip.
pub(crate) fn point_at_thin(
    area: &Area<'_>,
    extents: &[Option<Extent>],
    colours: &[(u8, u8, u8)],
) -> Result<()> {
    for (e, &(r, g, b)) in extents.iter().zip(colours) {
        let Some((_, y0, x1, y1)) = *e else {
            continue;
        };
        if y1 - y0 < SMALL_EXTENT {
            let (x, y) = (x1 as i32 + 2, (y0 + y1) as i32 / 2);
            let tri = vec![(x, y), (x + 8, y - 5), (x + 8, y + 5)];
            area.draw(&Polygon::new(tri, RGBColor(r, g, b).filled()))
                .map_err(plot_error)?;
        }
    }
    Ok(())
}

/// Draws the range axis left of `rect`: ticks labelled in metres from `r0` at the bottom (near
/// range) to `r1` at the top, and its title.
pub(crate) fn range_axis(area: &Area<'_>, rect: Rect, r0: f64, r1: f64) -> Result<()> {
    let y_of = |r: f64| rect.bottom() as i32 - ((r - r0) / (r1 - r0) * f64::from(rect.h)).round() as i32;
    let step = nice_step((r1 - r0) / 8.0);
    let x = rect.x as i32 - 1;
    let mut k = (r0 / step - 1e-9).ceil();
    while k * step <= r1 + 1e-9 {
        let (r, y) = (k * step, y_of(k * step));
        area.draw(&PathElement::new(vec![(x - 6, y), (x, y)], GREY.stroke_width(1)))
            .map_err(plot_error)?;
        text(
            area,
            &number(r, step),
            (x - 9, y),
            SMALL,
            HPos::Right,
            VPos::Center,
        )?;
        k += 1.0;
    }
    text_up(
        area,
        "range (m), near range at the bottom",
        (rect.x as i32 - 62, (rect.y + rect.h / 2) as i32),
        SMALL,
    )
}

/// Draws the beam axis under `rect` of a raw FLS layout painted by [`paint_raw`]: beam indices
/// with beam 0 (starboard-most) at the right, and at each end the beam, its side and outer
/// azimuth edge.
pub(crate) fn beam_axis(area: &Area<'_>, rect: Rect, layout: &Layout) -> Result<()> {
    let n = layout.beams();
    let x_of = |j: usize| rect.x as i32 + (((n - 1 - j) as f64 + 0.5) / n as f64 * f64::from(rect.w)) as i32;
    let y = rect.bottom() as i32;
    let step = nice_step(n as f64 / 5.0).max(1.0) as usize;
    let ticks = (0..n).step_by(step).chain(std::iter::once(n - 1));
    let mut last = None;
    for j in ticks {
        let x = x_of(j);
        // Keep labels apart: skip an index within 40 px of the last end.
        if j != n - 1 && j != 0 && (x - x_of(n - 1)).abs() < 40 {
            continue;
        }
        if last == Some(j) {
            continue;
        }
        last = Some(j);
        area.draw(&PathElement::new(vec![(x, y), (x, y + 6)], GREY.stroke_width(1)))
            .map_err(plot_error)?;
        text(area, &j.to_string(), (x, y + 8), SMALL, HPos::Center, VPos::Top)?;
    }
    let edge = |e: f64| {
        let d = e.to_degrees();
        format!("{:+}°", (d * 10.0).round() / 10.0)
    };
    let y2 = y + 32;
    text(
        area,
        &format!("beam {} (port, {})", n - 1, edge(layout.beam_edges[n])),
        (rect.x as i32, y2),
        SMALL,
        HPos::Left,
        VPos::Top,
    )?;
    text(
        area,
        &format!("beam 0 (starboard, {})", edge(layout.beam_edges[0])),
        (rect.right() as i32, y2),
        SMALL,
        HPos::Right,
        VPos::Top,
    )
}

/// Returns 1, 2 or 5 times a power of ten, the first at least `x`.
pub(crate) fn nice_step(x: f64) -> f64 {
    let p = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= x)
        .unwrap_or(10.0 * p)
}

/// Returns `v` written with as many decimals as `step` needs; zero is never "-0.0".
pub(crate) fn number(v: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    // Adding 0.0 turns -0.0 (a tick at k = -0.0 steps) into 0.0.
    let v = v + 0.0;
    let text = format!("{v:.decimals$}");
    // A value that rounds to zero is written without its sign too.
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_zero_tick_has_no_sign() {
        // The range axis from 0 m starts at ceil(0 / step - 1e-9) = -0.0 steps.
        let k = (0.0f64 / 0.5 - 1e-9).ceil();
        assert_eq!(number(k * 0.5, 0.5), "0.0");
        assert_eq!(number(-0.0001, 0.5), "0.0");
        assert_eq!(number(-0.5, 0.5), "-0.5");
        assert_eq!(number(2.0, 1.0), "2");
    }

    #[test]
    fn cover_spreads_bins_over_pixels_without_gaps() {
        for (n, bins) in [(7u32, 3usize), (3, 7), (440, 512), (512, 512), (600, 990)] {
            let mut next = 0;
            for k in 0..n {
                let (lo, hi) = cover(k, n, bins);
                assert!(lo < hi && hi <= bins, "{n} {bins} {k}");
                assert!(lo <= next, "pixel {k} of {n} skips bins {next}..{lo} of {bins}");
                next = hi;
            }
            assert_eq!(next, bins);
        }
    }

    #[test]
    fn pooled_blocks_agree_with_the_pixels() {
        let mut occ = Occupancy::new(9, 7);
        for (i, j) in [(0, 0), (3, 4), (8, 6), (5, 1)] {
            occ.set(i, j);
        }
        let p = Pooled::new(&occ);
        for i0 in 0..9 {
            for i1 in i0 + 1..=9 {
                for j0 in 0..7 {
                    for j1 in j0 + 1..=7 {
                        let brute = (i0..i1).any(|i| (j0..j1).any(|j| occ.get(i, j)));
                        assert_eq!(p.any((i0, i1), (j0, j1)), brute, "{i0}..{i1} × {j0}..{j1}");
                    }
                }
            }
        }
    }
}
