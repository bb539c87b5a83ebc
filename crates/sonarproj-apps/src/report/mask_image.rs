//! Masks as pictures and arrays: a PNG with sonar 2's image as a person looks at it (an FLS as a
//! fan in Cartesian coordinates with range rings and bearing lines; an SSS as a range strip per
//! feature) beside the raw layout (range bins × beams), each feature in its own colour; and NPY
//! arrays of the raw masks or counts.
#![expect(
    clippy::cast_possible_truncation,
    reason = "pixel coordinates, palette indices and colours of images a few thousand pixels wide"
)]

use std::path::Path;

use plotters::prelude::*;

use crate::error::{Error, Result};
use crate::report::figures::{FONT, fonts};
use crate::report::{self, write_atomic};
use sonarproj::geometry::sonar::SonarKind;
use sonarproj::masks::Mask;
use sonarproj::occupancy::Layout;

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

/// Returns the blended colour of the features whose masks hold pixel `(i, j)`, or `None`.
fn blend(masks: &[Mask], i: usize, j: usize) -> Option<(u8, u8, u8)> {
    let (mut s, mut n) = ([0u32; 3], 0u32);
    for (k, m) in masks.iter().enumerate() {
        if m.occupancy.get(i, j) {
            let (r, g, b) = PALETTE[k % PALETTE.len()];
            s = [s[0] + u32::from(r), s[1] + u32::from(g), s[2] + u32::from(b)];
            n += 1;
        }
    }
    (n > 0).then(|| ((s[0] / n) as u8, (s[1] / n) as u8, (s[2] / n) as u8))
}

fn plot_error(e: impl std::fmt::Display) -> Error {
    Error::Figure(e.to_string())
}

/// Writes the mask picture of `masks` in `layout` to `path` (PNG), whole or not at all;
/// `title` heads it and `labels` name the features in the legend.
///
/// # Errors
/// [`Error::Figure`] or [`Error::WriteOutput`].
pub fn write_png(path: &Path, layout: &Layout, masks: &[Mask], title: &str, labels: &[String]) -> Result<()> {
    fonts();
    let (w, h) = (1500u32, 900u32);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    let put = |rgb: &mut [u8], x: u32, y: u32, c: (u8, u8, u8)| {
        let k = ((y * w + x) * 3) as usize;
        rgb[k..k + 3].copy_from_slice(&[c.0, c.1, c.2]);
    };
    let empty = (235u8, 235u8, 235u8);
    // Left: the person's view, 900 × 760 below the title; right: the raw layout, 500 × 760.
    let (fan_x, fan_y, fan_w, fan_h) = (50u32, 90u32, 820u32, 760u32);
    let (raw_x, raw_y, raw_w, raw_h) = (960u32, 90u32, 440u32, 760u32);
    // An SSS target: one strip of range bins per feature, and the union.
    let strip = (fan_h / (masks.len() as u32 + 1)).clamp(4, 60);
    let rows = layout.range_bins;
    let beams = layout.beams();
    // Raw layout (FLS): range bin 0 at the bottom, beam 0 on the left.
    let raw = layout.kind == SonarKind::Fls;
    for y in (0..raw_h).filter(|_| raw) {
        let i = ((raw_h - 1 - y) as usize * rows / raw_h as usize).min(rows - 1);
        for x in 0..raw_w {
            let j = (x as usize * beams / raw_w as usize).min(beams - 1);
            put(
                &mut rgb,
                raw_x + x,
                raw_y + y,
                blend(masks, i, j).unwrap_or(empty),
            );
        }
    }
    let r_max = layout.range_max;
    let ha = layout.half_azimuth;
    // The fan (FLS): x = r sin(az) to the right, y = r cos(az) up, sonar at the bottom centre
    // (or at the centre for apertures over 180°).
    let fan_geometry = match layout.kind {
        SonarKind::Fls => {
            let half_width = r_max * ha.min(std::f64::consts::FRAC_PI_2).sin();
            let y_low = (r_max * ha.cos()).min(0.0);
            let scale = (f64::from(fan_w) / (2.0 * half_width)).min(f64::from(fan_h) / (r_max - y_low));
            let ox = f64::from(fan_x) + f64::from(fan_w) / 2.0;
            let oy = f64::from(fan_y) + f64::from(fan_h) + y_low * scale;
            for y in fan_y..fan_y + fan_h {
                for x in fan_x..fan_x + fan_w {
                    let (px, py) = (
                        (f64::from(x) + 0.5 - ox) / scale,
                        (oy - f64::from(y) - 0.5) / scale,
                    );
                    let (r, az) = (px.hypot(py), px.atan2(py));
                    if r < layout.range_min || r > r_max || az.abs() > ha {
                        continue;
                    }
                    let c = blend(masks, layout.range_bin(r), layout.beam(az)).unwrap_or(empty);
                    put(&mut rgb, x, y, c);
                }
            }
            Some((ox, oy, scale))
        }
        // An SSS: its raw layout is the picture, one strip of range bins per feature (range
        // increasing to the right, as a waterfall row), the union last.
        SonarKind::Sss => {
            let width = raw_x + raw_w - fan_x;
            for k in 0..=masks.len() {
                let y0 = fan_y + k as u32 * strip;
                for x in 0..width {
                    let i = (x as usize * rows / width as usize).min(rows - 1);
                    let c = match masks.get(k) {
                        Some(m) => m.occupancy.get(i, 0).then_some(PALETTE[k % PALETTE.len()]),
                        None => blend(masks, i, 0),
                    };
                    for y in y0..y0 + strip.saturating_sub(2) {
                        put(&mut rgb, fan_x + x, y, c.unwrap_or(empty));
                    }
                }
            }
            None
        }
    };
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        let text = |s: &str, size: u32, at: (i32, i32)| {
            root.draw(&Text::new(
                s.to_string(),
                at,
                (FONT, size).into_font().color(&BLACK),
            ))
            .map_err(plot_error)
        };
        text(title, 26, (50, 20))?;
        let mut legend_x = 50;
        for (k, l) in labels.iter().enumerate().take(12) {
            root.draw(&Rectangle::new(
                [(legend_x, 58), (legend_x + 14, 72)],
                colour(k).filled(),
            ))
            .map_err(plot_error)?;
            text(l, 15, (legend_x + 20, 56))?;
            legend_x += 30 + 8 * l.len() as i32;
        }
        let grey = RGBColor(90, 90, 90);
        match fan_geometry {
            Some((ox, oy, scale)) => {
                let at = |r: f64, az: f64| {
                    (
                        (ox + r * az.sin() * scale) as i32,
                        (oy - r * az.cos() * scale) as i32,
                    )
                };
                // Range rings at "nice" steps, bearing lines every 15° (30° beyond 180°).
                let step = nice_step(r_max / 5.0);
                let mut r = step;
                while r <= r_max + 1e-9 {
                    let pts: Vec<(i32, i32)> = (0..=200)
                        .map(|k| at(r, -ha + 2.0 * ha * k as f64 / 200.0))
                        .collect();
                    root.draw(&PathElement::new(pts, grey.stroke_width(1)))
                        .map_err(plot_error)?;
                    let (x, y) = at(r, ha.min(std::f64::consts::FRAC_PI_2));
                    text(&format!("{r} m"), 14, (x + 4, y - 8))?;
                    r += step;
                }
                let every = if ha > std::f64::consts::FRAC_PI_2 {
                    30.0
                } else {
                    15.0
                };
                let mut b = -(ha.to_degrees() / every).floor() * every;
                while b <= ha.to_degrees() + 1e-9 {
                    let (x, y) = at(r_max, b.to_radians());
                    root.draw(&PathElement::new(
                        vec![at(layout.range_min, b.to_radians()), (x, y)],
                        grey.stroke_width(1),
                    ))
                    .map_err(plot_error)?;
                    text(&format!("{b:.0}°"), 14, (x - 12, y - 20))?;
                    b += every;
                }
                text(
                    "fan view: azimuth 0 up, positive to the right; range rings labelled",
                    15,
                    (fan_x as i32, (fan_y + fan_h + 18) as i32),
                )?;
            }
            None => {
                // Range ticks under the strips.
                let n = masks.len() as u32 + 1;
                let (y, width) = ((fan_y + n * strip + 4) as i32, f64::from(raw_x + raw_w - fan_x));
                let x_of = |r: f64| {
                    fan_x as i32 + ((r - layout.range_min) / (r_max - layout.range_min) * width) as i32
                };
                let step = nice_step((r_max - layout.range_min) / 8.0);
                let mut r = (layout.range_min / step).ceil() * step;
                while r <= r_max + 1e-9 {
                    root.draw(&PathElement::new(
                        vec![(x_of(r), y), (x_of(r), y + 6)],
                        grey.stroke_width(1),
                    ))
                    .map_err(plot_error)?;
                    text(&format!("{r} m"), 14, (x_of(r) - 10, y + 8))?;
                    r += step;
                }
                text(
                    &format!(
                        "{rows} range bins from {} to {r_max} m, range increasing to the right; one strip per feature, their union last",
                        layout.range_min
                    ),
                    15,
                    (fan_x as i32, y + 30),
                )?;
                root.present().map_err(plot_error)?;
            }
        }
        if !raw {
            drop(root);
            return write_rgb(path, w, h, &rgb);
        }
        text(
            &format!("raw layout: {rows} range bins (row 0 at the bottom) × {beams} beams (beam 0 left)"),
            15,
            (raw_x as i32 - 40, (raw_y + raw_h + 18) as i32),
        )?;
        root.draw(&Rectangle::new(
            [
                (raw_x as i32 - 1, raw_y as i32 - 1),
                ((raw_x + raw_w) as i32, (raw_y + raw_h) as i32),
            ],
            grey.stroke_width(1),
        ))
        .map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    write_rgb(path, w, h, &rgb)
}

/// Writes `rgb` (`w × h`, 8-bit RGB) to `path` as PNG, whole or not at all.
fn write_rgb(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<()> {
    write_atomic(path, |out| {
        let mut enc = png::Encoder::new(out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(plot_error)?;
        writer.write_image_data(rgb).map_err(plot_error)?;
        writer.finish().map_err(plot_error)
    })
}

/// Returns 1, 2 or 5 times a power of ten, the first at least `x`.
fn nice_step(x: f64) -> f64 {
    let p = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= x)
        .unwrap_or(10.0 * p)
}

/// Writes the masks as NPY to `path`: shape `[feature, range_bin, beam]` for an FLS target or
/// `[feature, range_bin]` for an SSS target; `uint8` 0/1, or `uint32` counts with `counts`.
///
/// # Errors
/// [`Error::WriteOutput`].
pub fn write_npy(path: &Path, layout: &Layout, masks: &[Mask], counts: bool) -> Result<()> {
    let mut shape = vec![masks.len() as u64, layout.range_bins as u64];
    if layout.kind == SonarKind::Fls {
        shape.push(layout.beams() as u64);
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
