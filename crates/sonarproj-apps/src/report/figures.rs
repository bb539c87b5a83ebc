//! Figures as PNG, drawn in memory by plotters with embedded fonts. They take neutral data
//! (series, grids of cells, labels) and know nothing of what they show. The paper and the sweep
//! build titles and data and call:
//! - [`line_grid`]: a grid of line plots with one legend above the panels;
//! - [`heatmaps`]: a row of heatmaps, each with its own colour scale shown on its colour bar;
//! - [`sweep`]: a sweep's line or heatmap.
#![expect(
    clippy::cast_possible_truncation,
    reason = "pixel coordinates, palette indices and colours of images a few thousand pixels wide"
)]

use std::path::Path;

use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;

use plotters::style::text_anchor::{HPos, VPos};

use crate::error::Result;
use crate::report::style::{
    AXES, Area, CAPTION, Canvas, FONT, TICKS, TITLE, plot_error, text, text_width, wrap,
};

/// A grid of line plots sharing one legend: every panel has one curve per legend entry, in the
/// legend's order and colours.
#[derive(Clone, Debug, PartialEq)]
pub struct LineGrid {
    /// The figure's title.
    pub title: String,
    /// `(rows, columns)` of panels.
    pub shape: (usize, usize),
    /// The y axis label of every panel.
    pub y_label: String,
    /// The words before the legend's entries.
    pub legend_lead: String,
    /// The legend's entries, one per curve of each panel.
    pub legend: Vec<String>,
    /// The panels, row by row.
    pub panels: Vec<LinePanel>,
}

/// One panel of a [`LineGrid`].
#[derive(Clone, Debug, PartialEq)]
pub struct LinePanel {
    /// The caption above the panel.
    pub caption: String,
    /// The x axis label.
    pub x_label: String,
    /// The x axis range.
    pub x_range: (f64, f64),
    /// The curves, `(x, y)` points each, in the legend's order.
    pub curves: Vec<Vec<(f64, f64)>>,
}

/// A row of heatmaps over square cells of one size. Each panel has its own colour scale, from
/// 0 to its largest value.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatmapRow {
    /// The figure's title.
    pub title: String,
    /// The cells' side in axis units. Cells are centred on their coordinates.
    pub step: f64,
    /// The range of cell centres on both axes.
    pub axis_range: (f64, f64),
    /// The colour bar's label.
    pub colour_label: String,
    /// The panels, left to right.
    pub panels: Vec<HeatmapPanel>,
}

/// One panel of a [`HeatmapRow`].
#[derive(Clone, Debug, PartialEq)]
pub struct HeatmapPanel {
    /// The caption above the panel.
    pub caption: String,
    /// The x axis label.
    pub x_label: String,
    /// The y axis label.
    pub y_label: String,
    /// The cells: `(x, y, value)`.
    pub cells: Vec<(f64, f64, f64)>,
}

/// Draws `draw` on a white `w × h` canvas and writes it to `path` as PNG, whole or not at all.
fn render(path: &Path, (w, h): (u32, u32), draw: impl FnOnce(&Area<'_>) -> Result<()>) -> Result<()> {
    let mut canvas = Canvas::new(w, h);
    canvas.draw(draw)?;
    canvas.write(path)
}

/// Writes the grid of line plots `grid` to `path`.
///
/// # Errors
/// [`crate::Error::Figure`] or [`crate::Error::WriteOutput`].
pub fn line_grid(grid: &LineGrid, path: &Path) -> Result<()> {
    render(path, (1800, 1160), |root| {
        let (top, body) = root.split_vertically(96);
        let (head, key) = top.split_vertically(50);
        head.titled(&grid.title, (FONT, TITLE)).map_err(plot_error)?;
        legend_row(&key, &grid.legend_lead, &grid.legend)?;
        for (panel, data) in body.split_evenly(grid.shape).iter().zip(&grid.panels) {
            let ymax = data
                .curves
                .iter()
                .flat_map(|c| c.iter().map(|p| p.1))
                .fold(0.0f64, f64::max)
                .max(1e-12)
                * 1.05;
            let (x0, x1) = data.x_range;
            let mut chart = ChartBuilder::on(panel)
                .caption(&data.caption, (FONT, CAPTION))
                .margin(12)
                .x_label_area_size(50)
                .y_label_area_size(90)
                .build_cartesian_2d(x0..x1, 0f64..ymax)
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .x_desc(&data.x_label)
                .y_desc(&grid.y_label)
                .x_labels(10)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .label_style((FONT, TICKS))
                .axis_desc_style((FONT, AXES))
                .draw()
                .map_err(plot_error)?;
            for (i, pts) in data.curves.iter().enumerate() {
                chart
                    .draw_series(LineSeries::new(
                        pts.iter().copied(),
                        series_colour(i, grid.legend.len()).stroke_width(2),
                    ))
                    .map_err(plot_error)?;
            }
        }
        Ok(())
    })
}

/// Returns the colour of curve `i` of `n`: Viridis, evenly spread.
#[expect(clippy::cast_precision_loss, reason = "a figure's few curves")]
fn series_colour(i: usize, n: usize) -> RGBColor {
    viridis(i as f64, 0.0, n.saturating_sub(1) as f64)
}

/// Returns Viridis's colour of `v` on the scale `lo..=hi`, worked out in f64 (a scale narrower
/// than f32 resolves is still a scale). A value off the scale takes its nearer end; a scale of
/// no width, or a value that is not a number, takes the low end.
fn viridis(v: f64, lo: f64, hi: f64) -> RGBColor {
    let t = (v - lo) / (hi - lo);
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    #[expect(clippy::cast_possible_truncation, reason = "a fraction in 0..=1")]
    ViridisRGB::get_color_normalized(t as f32, 0.0, 1.0)
}

/// Draws one legend centred on `area`: `lead`, then a line sample and its label per entry.
fn legend_row(area: &Area<'_>, lead: &str, labels: &[String]) -> Result<()> {
    let item = 110;
    let lead_w = text_width(area, lead, AXES)? as i32;
    let total = lead_w + 16 + item * labels.len() as i32;
    let (w, h) = area.dim_in_pixel();
    let (mut x, y) = ((w as i32 - total) / 2, h as i32 / 2);
    text(area, lead, (x, y), AXES, HPos::Left, VPos::Center)?;
    x += lead_w + 16;
    for (i, label) in labels.iter().enumerate() {
        area.draw(&PathElement::new(
            vec![(x, y), (x + 28, y)],
            series_colour(i, labels.len()).stroke_width(4),
        ))
        .map_err(plot_error)?;
        text(area, label, (x + 34, y), AXES, HPos::Left, VPos::Center)?;
        x += item;
    }
    Ok(())
}

/// Writes the row of heatmaps `row` to `path`.
///
/// # Errors
/// [`crate::Error::Figure`] or [`crate::Error::WriteOutput`].
pub fn heatmaps(row: &HeatmapRow, path: &Path) -> Result<()> {
    let step = row.step;
    render(path, (2010, 700), |root| {
        let (top, body) = root.split_vertically(56);
        top.titled(&row.title, (FONT, TITLE)).map_err(plot_error)?;
        for (panel, data) in body.split_evenly((1, row.panels.len())).iter().zip(&row.panels) {
            let vmax = data.cells.iter().map(|c| c.2).fold(0.0f64, f64::max).max(1e-12);
            let (map, bar) = panel.split_horizontally(panel.dim_in_pixel().0 as i32 - 170);
            let lo = row.axis_range.0 - step / 2.0;
            let hi = row.axis_range.1 + step / 2.0;
            // Ticks from end to end of the cell centres: 0 to 180° shows 180.
            let ticks = even_ticks(row.axis_range.0, row.axis_range.1);
            let mut chart = ChartBuilder::on(&map)
                .caption(&data.caption, (FONT, CAPTION))
                .margin(12)
                .x_label_area_size(50)
                .y_label_area_size(64)
                .build_cartesian_2d(Ticked::new(lo..hi, &ticks), Ticked::new(lo..hi, &ticks))
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(&data.x_label)
                .y_desc(&data.y_label)
                .x_labels(ticks.len())
                .y_labels(ticks.len())
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.0}"))
                .label_style((FONT, TICKS))
                .axis_desc_style((FONT, AXES))
                .draw()
                .map_err(plot_error)?;
            chart
                .draw_series(data.cells.iter().map(|&(x, y, v)| {
                    let c = viridis(v, 0.0, vmax);
                    Rectangle::new(
                        [(x - step / 2.0, y - step / 2.0), (x + step / 2.0, y + step / 2.0)],
                        c.filled(),
                    )
                }))
                .map_err(plot_error)?;
            // Each colour bar runs from 0 to its panel's largest value. Panels may differ by orders
            // of magnitude: one shared scale would leave some of them a single colour.
            colour_bar(&bar, 0.0, vmax, &row.colour_label)?;
        }
        Ok(())
    })
}

/// Returns `label` without its trailing unit: "range span (m)" is "range span".
pub(crate) fn without_unit(label: &str) -> &str {
    match label.rfind(" (") {
        Some(i) if label.ends_with(')') => &label[..i],
        _ => label,
    }
}

/// A linear f64 axis whose ticks are given, not chosen by plotters.
struct Ticked {
    inner: plotters::coord::types::RangedCoordf64,
    ticks: Vec<f64>,
}

impl Ticked {
    /// Returns the axis over `range` ticked at `ticks`.
    fn new(range: std::ops::Range<f64>, ticks: &[f64]) -> Self {
        Ticked {
            inner: range.into(),
            ticks: ticks.to_vec(),
        }
    }
}

impl plotters::coord::ranged1d::Ranged for Ticked {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

/// Returns ticks from `lo` to `hi`, both included, at most 7, spaced by a step that divides
/// the span (angles: 30° over 0–180°); the two ends alone when none does.
fn even_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = hi - lo;
    let steps = [
        1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 90.0, 100.0, 180.0, 360.0,
    ];
    let divides = |s: f64| ((span / s) - (span / s).round()).abs() < 1e-9;
    match steps.iter().find(|&&s| span / s <= 6.0 + 1e-9 && divides(s)) {
        Some(&s) => {
            let n = (span / s).round() as usize;
            (0..=n).map(|k| lo + s * k as f64).collect()
        }
        None => vec![lo, hi],
    }
}

/// Draws a vertical Viridis colour bar from `lo` to `hi` on `area`, with values on its right.
/// `label` goes above it, since beside it would read as the neighbouring plot's axis.
fn colour_bar(area: &Area<'_>, lo: f64, hi: f64, label: &str) -> Result<()> {
    let width = area.dim_in_pixel().0 - 10;
    // A unit stays with its name: "area\u{a0}(m²)".
    let lines = wrap(area, &label.replace(" (", "\u{a0}("), TICKS, width)?;
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
        let c = viridis(a, lo, hi);
        Rectangle::new([(0.0, a), (1.0, b)], c.filled())
    }))
    .map_err(plot_error)?;
    Ok(())
}

/// Returns `(lo, hi)` of `v`, widened so the range is never empty.
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
    e.extend(values.windows(2).map(|w| (w[0] + w[1]) / 2.0));
    e.push(values[n - 1] + if n > 1 { gap(n - 2) / 2.0 } else { 0.5 });
    e
}

/// Writes a sweep's figure to `path`: the metric `label` against one or two varying quantities,
/// with axis labels `axes` and caption `caption`. `points` are `(coordinates, metric)` per pose.
///
/// One quantity draws a line, broken where a point has no value. Two draw a heatmap with a
/// colour bar, grey where a point has no value. The bar's note says what that means: `missing`,
/// such as "nothing visible".
///
/// # Errors
/// [`crate::Error::Figure`] or [`crate::Error::WriteOutput`].
pub fn sweep(
    path: &Path,
    caption: &str,
    axes: &[String],
    label: &str,
    missing: &str,
    points: &[(Vec<f64>, Option<f64>)],
) -> Result<()> {
    sweep_marked(path, caption, axes, label, missing, points, &[])
}

/// A point marked on a heatmap, with its legend entry.
#[derive(Clone, Debug, PartialEq)]
pub enum Mark {
    /// A filled white disc ringed in black.
    Disc {
        /// The legend's words.
        label: String,
        /// Where, in the axes' units.
        at: [f64; 2],
    },
    /// An open square.
    Square {
        /// The legend's words.
        label: String,
        /// Where.
        at: [f64; 2],
    },
    /// An arrow from one point to another.
    Arrow {
        /// The legend's words.
        label: String,
        /// Where it starts and ends.
        from: [f64; 2],
        /// Where it ends.
        to: [f64; 2],
    },
}

/// As [`sweep`], with `marks` drawn over a heatmap (and listed in its legend); a mark outside
/// the heatmap is drawn at its edge. A line plot (one quantity) draws none.
///
/// # Errors
/// As [`sweep`].
pub fn sweep_marked(
    path: &Path,
    caption: &str,
    axes: &[String],
    label: &str,
    missing: &str,
    points: &[(Vec<f64>, Option<f64>)],
    marks: &[Mark],
) -> Result<()> {
    let (vlo, vhi) = extent(points.iter().filter_map(|p| p.1));
    if axes.len() == 1 {
        return sweep_line(path, caption, &axes[0], label, points, (vlo, vhi));
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
            .caption(caption, (FONT, TITLE))
            .margin(20)
            .x_label_area_size(60)
            .y_label_area_size(84)
            .build_cartesian_2d(xe[0]..xe[xv.len()], ye[0]..ye[yv.len()])
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(&axes[0])
            .y_desc(&axes[1])
            .label_style((FONT, TICKS))
            .axis_desc_style((FONT, AXES))
            .draw()
            .map_err(plot_error)?;
        chart
            .draw_series(points.iter().map(|(c, v)| {
                let (i, j) = (find(&xv, c[0]), find(&yv, c[1]));
                let colour = match v {
                    Some(v) => viridis(*v, vlo, vhi),
                    None => RGBColor(200, 200, 200),
                };
                Rectangle::new([(xe[i], ye[j]), (xe[i + 1], ye[j + 1])], colour.filled())
            }))
            .map_err(plot_error)?;
        let clamp = |p: [f64; 2]| (p[0].clamp(xe[0], xe[xv.len()]), p[1].clamp(ye[0], ye[yv.len()]));
        let ring = BLACK.stroke_width(3);
        for mark in marks {
            match mark {
                Mark::Disc { label, at } => {
                    let at = clamp(*at);
                    chart
                        .draw_series([Circle::new(at, 11, WHITE.filled()), Circle::new(at, 11, ring)])
                        .map_err(plot_error)?
                        .label(label)
                        .legend(move |(x, y)| Circle::new((x + 10, y), 8, ring));
                }
                Mark::Square { label, at } => {
                    let (x, y) = clamp(*at);
                    let square = EmptyElement::at((x, y))
                        + Rectangle::new([(-10, -10), (10, 10)], RED.stroke_width(4));
                    chart
                        .draw_series([square])
                        .map_err(plot_error)?
                        .label(label)
                        .legend(|(x, y)| {
                            Rectangle::new([(x + 2, y - 8), (x + 18, y + 8)], RED.stroke_width(3))
                        });
                }
                Mark::Arrow { label, from, to } => {
                    let (a, b) = (clamp(*from), clamp(*to));
                    chart
                        .draw_series([PathElement::new(vec![a, b], RED.stroke_width(4))])
                        .map_err(plot_error)?
                        .label(label)
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(4)));
                    chart
                        .draw_series([Circle::new(b, 7, RED.filled())])
                        .map_err(plot_error)?;
                }
            }
        }
        if !marks.is_empty() {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, TICKS))
                .draw()
                .map_err(plot_error)?;
        }
        colour_bar(&bar, vlo, vhi, &format!("colour: {label}; grey: {missing}"))
    })
}

/// Draws [`sweep`]'s line of the metric `label` against one quantity, values `(vlo, vhi)`,
/// broken where a point has no value.
fn sweep_line(
    path: &Path,
    caption: &str,
    axis: &str,
    label: &str,
    points: &[(Vec<f64>, Option<f64>)],
    (vlo, vhi): (f64, f64),
) -> Result<()> {
    let (xlo, xhi) = extent(points.iter().map(|p| p.0[0]));
    let pad = 0.05 * (vhi - vlo);
    let (ylo, yhi) = (if vlo >= 0.0 { 0.0 } else { vlo - pad }, vhi + pad);
    render(path, (1200, 800), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(caption, (FONT, TITLE))
            .margin(20)
            .margin_right(40)
            .x_label_area_size(60)
            .y_label_area_size(100)
            .build_cartesian_2d(xlo..xhi, ylo..yhi)
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc(axis)
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
    })
}

#[cfg(test)]
mod tests {
    use super::{even_ticks, viridis, without_unit};

    #[test]
    fn a_colour_scale_of_any_width_gives_a_colour() {
        // A part in 10⁸ apart: one value as f32, two ends of the scale in f64.
        let (lo, hi) = (52.302_287_544_094_135, 52.302_288_567_157_056);
        assert_ne!(viridis(lo, lo, hi), viridis(hi, lo, hi));
        assert_eq!(viridis(hi, lo, hi), viridis(1.0, 0.0, 1.0));
        // No width, not a number, off the scale: an end, no panic.
        assert_eq!(viridis(3.0, 3.0, 3.0), viridis(0.0, 0.0, 1.0));
        assert_eq!(viridis(f64::NAN, 0.0, 1.0), viridis(0.0, 0.0, 1.0));
        assert_eq!(viridis(5.0, 0.0, 1.0), viridis(1.0, 0.0, 1.0));
        assert_eq!(viridis(-5.0, 0.0, 1.0), viridis(0.0, 0.0, 1.0));
    }

    #[test]
    fn a_unit_is_taken_off_a_label() {
        assert_eq!(without_unit("mean range span (m)"), "mean range span");
        assert_eq!(without_unit("mixed score"), "mixed score");
    }

    #[test]
    fn angle_axes_are_ticked_to_their_ends() {
        assert_eq!(
            even_ticks(0.0, 180.0),
            [0.0, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0]
        );
        assert_eq!(even_ticks(0.0, 90.0), [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]);
        assert_eq!(
            even_ticks(-90.0, 90.0),
            [-90.0, -60.0, -30.0, 0.0, 30.0, 60.0, 90.0]
        );
        assert_eq!(even_ticks(0.0, 7.3), [0.0, 7.3]);
    }
}
