//! The paper's figures as PNG (plotters, drawn in memory, fonts embedded): per direction a 2×3
//! grid of line plots (scenarios 1–6: metric against the swept angle, one curve per distance
//! fraction, one legend for all panels above them) and a 1×3 row of heatmaps (scenarios 7–9,
//! each with its own colour scale, said on its colour bar); and the sweep figure.
#![expect(
    clippy::cast_possible_truncation,
    reason = "pixel coordinates, palette indices and colours of images a few thousand pixels wide"
)]

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;

use plotters::style::text_anchor::{HPos, VPos};

use crate::error::{Error, Result};
use crate::paper::{DirectionRun, FRACTIONS, swept};
use crate::report::picture::{self, text};
use crate::report::write_atomic;

/// Names of the swept angles by index.
const ANGLE_NAMES: [&str; 3] = ["roll", "pitch", "yaw"];
/// The font family the figures use (registered from embedded bytes).
pub(crate) const FONT: &str = "sans-serif";
/// Font sizes (px) of the figures: tick labels, axis titles, panel captions, figure titles.
const TICKS: u32 = 17;
/// Font size (px) of axis titles.
const AXES: u32 = 19;
/// Font size (px) of panel captions.
const CAPTION: u32 = 21;
/// Font size (px) of figure titles.
const TITLE: u32 = 28;

/// Registers the embedded font once (plotters' ab_glyph backend has no system fonts).
pub(crate) fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TTF shipped by the crate; failure would be a packaging bug.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
    });
}

/// Returns a figure error (a failure of this program, exit status 1).
fn plot_error(e: impl std::fmt::Display) -> Error {
    Error::Figure(e.to_string())
}

/// Draws `draw` on a `w × h` canvas and writes it to `path` as PNG, whole or not at all.
fn render(
    path: &Path,
    (w, h): (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<()>,
) -> Result<()> {
    fonts();
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        draw(&root)?;
        root.present().map_err(plot_error)?;
    }
    write_atomic(path, |out| {
        let mut enc = png::Encoder::new(out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(plot_error)?;
        writer.write_image_data(&rgb).map_err(plot_error)?;
        writer.finish().map_err(plot_error)
    })
}

/// Returns the distances text of scenario `s` (which sonar's distance is the fraction).
fn distances_text(s: u8) -> &'static str {
    match s {
        1..=3 => "sonar 1 at 0.5 r_max, sonar 2 at f r_max",
        4..=6 => "sonar 1 at f r_max, sonar 2 at 0.5 r_max",
        _ => "both at 0.5 r_max",
    }
}

/// Writes the 2×3 grid of scenarios 1–6 to `path`.
///
/// # Errors
/// [`Error::Figure`] or [`Error::WriteOutput`].
pub fn line_grid(run: &DirectionRun, path: &Path) -> Result<()> {
    let label = run.direction.metric_label();
    let title = match run.direction {
        crate::paper::Direction::FlsToSss => "paper-fls to paper-sss: range span",
        crate::paper::Direction::SssToFls => "paper-sss to paper-fls: projection area",
    };
    render(path, (1800, 1160), |root| {
        let (top, body) = root.split_vertically(96);
        let (head, key) = top.split_vertically(50);
        head.titled(title, (FONT, TITLE)).map_err(plot_error)?;
        legend_row(&key)?;
        for (k, panel) in body.split_evenly((2, 3)).iter().enumerate() {
            let s = k as u8 + 1;
            let axis = swept(s)[0];
            let curves: Vec<(f64, Vec<(f64, f64)>)> = FRACTIONS
                .iter()
                .map(|&f| {
                    let pts = run
                        .poses
                        .iter()
                        .zip(&run.results)
                        .filter(|(p, _)| p.scenario == s && p.fraction == Some(f))
                        .map(|(p, r)| (p.angles[axis], run.direction.metric(&r.metrics)))
                        .collect();
                    (f, pts)
                })
                .collect();
            let ymax = curves
                .iter()
                .flat_map(|c| c.1.iter().map(|p| p.1))
                .fold(0.0f64, f64::max)
                .max(1e-12)
                * 1.05;
            let mut chart = ChartBuilder::on(panel)
                .caption(
                    format!(
                        "Scenario {s}: {} swept ({})",
                        ANGLE_NAMES[axis],
                        distances_text(s)
                    ),
                    (FONT, CAPTION),
                )
                .margin(12)
                .x_label_area_size(50)
                .y_label_area_size(90)
                .build_cartesian_2d(0f64..180f64, 0f64..ymax)
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .x_desc(format!("{} (deg)", ANGLE_NAMES[axis]))
                .y_desc(label)
                .x_labels(10)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .label_style((FONT, TICKS))
                .axis_desc_style((FONT, AXES))
                .draw()
                .map_err(plot_error)?;
            for (i, (_, pts)) in curves.into_iter().enumerate() {
                chart
                    .draw_series(LineSeries::new(pts, fraction_colour(i).stroke_width(2)))
                    .map_err(plot_error)?;
            }
        }
        Ok(())
    })
}

/// Returns the colour of the curve of distance fraction number `i`.
fn fraction_colour(i: usize) -> RGBColor {
    ViridisRGB::get_color_normalized(i as f32, 0.0, (FRACTIONS.len() - 1) as f32)
}

/// Draws the one legend of the line grid, centred on `area`: a line sample and `f = …` per
/// distance fraction.
fn legend_row(area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<()> {
    let lead = "distance fraction f (same in every panel):";
    let item = 110;
    let lead_w = picture::text_width(area, lead, AXES)? as i32;
    let total = lead_w + 16 + item * FRACTIONS.len() as i32;
    let (w, h) = area.dim_in_pixel();
    let (mut x, y) = ((w as i32 - total) / 2, h as i32 / 2);
    text(area, lead, (x, y), AXES, HPos::Left, VPos::Center)?;
    x += lead_w + 16;
    for (i, f) in FRACTIONS.iter().enumerate() {
        area.draw(&PathElement::new(
            vec![(x, y), (x + 28, y)],
            fraction_colour(i).stroke_width(4),
        ))
        .map_err(plot_error)?;
        text(
            area,
            &format!("{f:.1}"),
            (x + 34, y),
            AXES,
            HPos::Left,
            VPos::Center,
        )?;
        x += item;
    }
    Ok(())
}

/// Writes the 1×3 row of heatmaps of scenarios 7–9 to `path`.
///
/// # Errors
/// [`Error::Figure`] or [`Error::WriteOutput`].
pub fn heatmaps(run: &DirectionRun, angles: &[f64], path: &Path) -> Result<()> {
    let label = run.direction.metric_label();
    let title = match run.direction {
        crate::paper::Direction::FlsToSss => {
            "paper-fls to paper-sss: range span, both features at 0.5 r_max (each panel its own colour scale)"
        }
        crate::paper::Direction::SssToFls => {
            "paper-sss to paper-fls: projection area, both features at 0.5 r_max (each panel its own colour scale)"
        }
    };
    let step = if angles.len() > 1 {
        angles[1] - angles[0]
    } else {
        1.0
    };
    render(path, (2010, 700), |root| {
        let (top, body) = root.split_vertically(56);
        top.titled(title, (FONT, TITLE)).map_err(plot_error)?;
        for (k, panel) in body.split_evenly((1, 3)).iter().enumerate() {
            let s = 7 + k as u8;
            let [ax, ay] = [swept(s)[0], swept(s)[1]];
            let cells: Vec<(f64, f64, f64)> = run
                .poses
                .iter()
                .zip(&run.results)
                .filter(|(p, _)| p.scenario == s)
                .map(|(p, r)| (p.angles[ax], p.angles[ay], run.direction.metric(&r.metrics)))
                .collect();
            let vmax = cells.iter().map(|c| c.2).fold(0.0f64, f64::max).max(1e-12);
            let (map, bar) = panel.split_horizontally(panel.dim_in_pixel().0 as i32 - 170);
            let lo = -step / 2.0;
            let hi = 180.0 + step / 2.0;
            let mut chart = ChartBuilder::on(&map)
                .caption(
                    format!("Scenario {s}: {} × {}", ANGLE_NAMES[ax], ANGLE_NAMES[ay]),
                    (FONT, CAPTION),
                )
                .margin(12)
                .x_label_area_size(50)
                .y_label_area_size(64)
                .build_cartesian_2d(lo..hi, lo..hi)
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(format!("{} (deg)", ANGLE_NAMES[ax]))
                .y_desc(format!("{} (deg)", ANGLE_NAMES[ay]))
                .x_labels(7)
                .y_labels(7)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.0}"))
                .label_style((FONT, TICKS))
                .axis_desc_style((FONT, AXES))
                .draw()
                .map_err(plot_error)?;
            chart
                .draw_series(cells.iter().map(|&(x, y, v)| {
                    let c = ViridisRGB::get_color_normalized(v as f32, 0.0, vmax as f32);
                    Rectangle::new(
                        [(x - step / 2.0, y - step / 2.0), (x + step / 2.0, y + step / 2.0)],
                        c.filled(),
                    )
                }))
                .map_err(plot_error)?;
            // Colour bar: the metric from 0 to this panel's largest value (panels differ by
            // orders of magnitude: one shared scale would leave some of them one colour).
            colour_bar(
                &bar,
                0.0,
                vmax,
                &format!("colour: {label}, this panel's own scale"),
            )?;
        }
        Ok(())
    })
}

/// Draws a vertical Viridis colour bar from `lo` to `hi` on `area`, with `label` written above
/// it (not beside it, where it would read as the neighbouring plot's axis) and the values on its
/// right.
fn colour_bar(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    lo: f64,
    hi: f64,
    label: &str,
) -> Result<()> {
    let width = area.dim_in_pixel().0 - 10;
    // A unit stays with its name: "area\u{a0}(m²)".
    let lines = picture::wrap(area, &label.replace(" (", "\u{a0}("), TICKS, width)?;
    for (k, line) in lines.iter().enumerate() {
        text(area, line, (4, 14 + 22 * k as i32), TICKS, HPos::Left, VPos::Top)?;
    }
    let mut cb = ChartBuilder::on(area)
        .margin_top(30 + 22 * lines.len() as u32)
        .margin_bottom(60)
        .margin_left(8)
        .right_y_label_area_size(80)
        .build_cartesian_2d(0f64..1f64, lo..hi)
        .map_err(plot_error)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(8)
        .label_style((FONT, TICKS))
        .draw()
        .map_err(plot_error)?;
    let n = 200;
    cb.draw_series((0..n).map(|i| {
        let a = lo + (hi - lo) * i as f64 / n as f64;
        let b = lo + (hi - lo) * (i + 1) as f64 / n as f64;
        let c = ViridisRGB::get_color_normalized(a as f32, lo as f32, hi as f32);
        Rectangle::new([(0.0, a), (1.0, b)], c.filled())
    }))
    .map_err(plot_error)?;
    Ok(())
}

/// Returns the axis label of sweep column `c`, with its unit.
fn column_label(c: &str) -> String {
    let unit = match c {
        "range" | "place_range" | "tx" | "ty" | "tz" => "m",
        _ => "deg",
    };
    format!("{c} ({unit})")
}

/// Returns `(lo, hi)` of `v`, widened so that the range is never empty.
fn extent(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 * lo.abs().max(1.0) {
        return (lo - 0.5, hi + 0.5);
    }
    (lo, hi)
}

/// Returns the cell edges around sorted distinct `values`: midpoints between neighbours, and
/// half a gap beyond the ends.
fn cell_edges(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    let mut e = Vec::with_capacity(n + 1);
    let gap = |i: usize| values[i + 1] - values[i];
    e.push(values[0] - if n > 1 { gap(0) / 2.0 } else { 0.5 });
    // Midpoints between neighbours.
    e.extend(values.windows(2).map(|w| (w[0] + w[1]) / 2.0));
    e.push(values[n - 1] + if n > 1 { gap(n - 2) / 2.0 } else { 0.5 });
    e
}

/// Writes a sweep's figure to `path`: the metric (`label`) against one varying column (a line,
/// broken where nothing was visible) or two (a heatmap with a colour bar; grey where nothing was
/// visible). `points` are `(column values, metric)` per pose.
///
/// # Errors
/// [`Error::Figure`] or [`Error::WriteOutput`].
pub fn sweep(
    path: &Path,
    title: &str,
    columns: &[String],
    label: &str,
    points: &[(Vec<f64>, Option<f64>)],
) -> Result<()> {
    let (vlo, vhi) = extent(points.iter().filter_map(|p| p.1));
    if columns.len() == 1 {
        let (xlo, xhi) = extent(points.iter().map(|p| p.0[0]));
        let pad = 0.05 * (vhi - vlo);
        let (ylo, yhi) = (if vlo >= 0.0 { 0.0 } else { vlo - pad }, vhi + pad);
        return render(path, (1200, 800), |root| {
            let mut chart = ChartBuilder::on(root)
                .caption(format!("{title}: {label} against {}", columns[0]), (FONT, TITLE))
                .margin(20)
                .margin_right(40)
                .x_label_area_size(60)
                .y_label_area_size(100)
                .build_cartesian_2d(xlo..xhi, ylo..yhi)
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .x_desc(column_label(&columns[0]))
                .y_desc(label)
                .label_style((FONT, TICKS))
                .axis_desc_style((FONT, AXES))
                .draw()
                .map_err(plot_error)?;
            let mut sorted: Vec<(f64, Option<f64>)> = points.iter().map(|p| (p.0[0], p.1)).collect();
            sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
            let colour = ViridisRGB::get_color_normalized(0.2, 0.0, 1.0);
            for run in sorted.split(|p| p.1.is_none()).filter(|r| !r.is_empty()) {
                let pts: Vec<(f64, f64)> = run.iter().map(|p| (p.0, p.1.expect("split"))).collect();
                if pts.len() == 1 {
                    chart
                        .draw_series(std::iter::once(Circle::new(pts[0], 3, colour.filled())))
                        .map_err(plot_error)?;
                } else {
                    chart
                        .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                        .map_err(plot_error)?;
                }
            }
            Ok(())
        });
    }
    let distinct = |k: usize| {
        let mut v: Vec<f64> = points.iter().map(|p| p.0[k]).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let (xv, yv) = (distinct(0), distinct(1));
    let (xe, ye) = (cell_edges(&xv), cell_edges(&yv));
    let find = |v: &[f64], x: f64| v.binary_search_by(|a| a.total_cmp(&x)).unwrap_or(0);
    render(path, (1300, 1000), |root| {
        let (map, bar) = root.split_horizontally(1110);
        let mut chart = ChartBuilder::on(&map)
            .caption(format!("{title}: {label}"), (FONT, TITLE))
            .margin(20)
            .x_label_area_size(60)
            .y_label_area_size(84)
            .build_cartesian_2d(xe[0]..xe[xv.len()], ye[0]..ye[yv.len()])
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(column_label(&columns[0]))
            .y_desc(column_label(&columns[1]))
            .label_style((FONT, TICKS))
            .axis_desc_style((FONT, AXES))
            .draw()
            .map_err(plot_error)?;
        chart
            .draw_series(points.iter().map(|(c, v)| {
                let (i, j) = (find(&xv, c[0]), find(&yv, c[1]));
                let colour = match v {
                    Some(v) => ViridisRGB::get_color_normalized(*v as f32, vlo as f32, vhi as f32),
                    None => RGBColor(200, 200, 200),
                };
                Rectangle::new([(xe[i], ye[j]), (xe[i + 1], ye[j + 1])], colour.filled())
            }))
            .map_err(plot_error)?;
        colour_bar(&bar, vlo, vhi, &format!("colour: {label}; grey: nothing visible"))
    })
}
