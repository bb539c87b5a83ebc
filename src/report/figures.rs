//! The paper's figures as PNG (plotters, drawn in memory, fonts embedded): per direction a 2×3
//! grid of line plots (scenarios 1–6: metric against the swept angle, one curve per distance
//! fraction) and a 1×3 row of heatmaps (scenarios 7–9, colour bar with units).

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;

use crate::error::{Error, Result};
use crate::paper::{DirectionRun, FRACTIONS, swept};
use crate::report::write_atomic;

/// Names of the swept angles by index.
const ANGLE_NAMES: [&str; 3] = ["roll", "pitch", "yaw"];
/// The font family the figures use (registered from embedded bytes).
const FONT: &str = "sans-serif";

/// Registers the embedded font once (plotters' ab_glyph backend has no system fonts).
fn fonts() {
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
    render(path, (1800, 1100), |root| {
        let (top, body) = root.split_vertically(50);
        top.titled(title, (FONT, 28)).map_err(plot_error)?;
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
                    (FONT, 18),
                )
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(0f64..180f64, 0f64..ymax)
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .x_desc(format!("{} (deg)", ANGLE_NAMES[axis]))
                .y_desc(label)
                .x_labels(10)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .label_style((FONT, 14))
                .draw()
                .map_err(plot_error)?;
            for (i, (f, pts)) in curves.into_iter().enumerate() {
                let color = ViridisRGB::get_color_normalized(i as f32, 0.0, 9.0);
                chart
                    .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                    .map_err(plot_error)?
                    .label(format!("f = {f:.1}"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
            }
            chart
                .configure_series_labels()
                .label_font((FONT, 13))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(plot_error)?;
        }
        Ok(())
    })
}

/// Writes the 1×3 row of heatmaps of scenarios 7–9 to `path`.
///
/// # Errors
/// [`Error::Figure`] or [`Error::WriteOutput`].
pub fn heatmaps(run: &DirectionRun, angles: &[f64], path: &Path) -> Result<()> {
    let label = run.direction.metric_label();
    let title = match run.direction {
        crate::paper::Direction::FlsToSss => "paper-fls to paper-sss: range span, both features at 0.5 r_max",
        crate::paper::Direction::SssToFls => {
            "paper-sss to paper-fls: projection area, both features at 0.5 r_max"
        }
    };
    let step = if angles.len() > 1 {
        angles[1] - angles[0]
    } else {
        1.0
    };
    render(path, (1950, 640), |root| {
        let (top, body) = root.split_vertically(50);
        top.titled(title, (FONT, 28)).map_err(plot_error)?;
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
            let (map, bar) = panel.split_horizontally(panel.dim_in_pixel().0 as i32 - 120);
            let lo = -step / 2.0;
            let hi = 180.0 + step / 2.0;
            let mut chart = ChartBuilder::on(&map)
                .caption(
                    format!("Scenario {s}: {} × {}", ANGLE_NAMES[ax], ANGLE_NAMES[ay]),
                    (FONT, 18),
                )
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(50)
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
                .label_style((FONT, 14))
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
            // Colour bar: the metric from 0 to the panel's largest value.
            let mut cb = ChartBuilder::on(&bar)
                .margin_top(40)
                .margin_bottom(52)
                .margin_right(8)
                .y_label_area_size(70)
                .build_cartesian_2d(0f64..1f64, 0f64..vmax)
                .map_err(plot_error)?;
            cb.configure_mesh()
                .disable_mesh()
                .disable_x_axis()
                .y_desc(label)
                .y_labels(8)
                .label_style((FONT, 13))
                .draw()
                .map_err(plot_error)?;
            let n = 200;
            cb.draw_series((0..n).map(|i| {
                let (a, b) = (vmax * i as f64 / n as f64, vmax * (i + 1) as f64 / n as f64);
                let c = ViridisRGB::get_color_normalized(a as f32, 0.0, vmax as f32);
                Rectangle::new([(0.0, a), (1.0, b)], c.filled())
            }))
            .map_err(plot_error)?;
        }
        Ok(())
    })
}
