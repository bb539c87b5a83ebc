//! Draws a sweep's figure: the metric against the grid's one or two varying axes.
//! The points come from the result table, or from a summary's marginal.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::io::parquet::read_groups;
use crate::io::pose_columns::column_words;
use crate::report::figures;
use crate::sweep::columns::column_kinds;
use crate::sweep::parts::is_regular;
use crate::sweep::records::Descriptor;
use crate::sweep::summary::Summary;
use crate::sweep::table::Format;

/// Draws `DIR/sweep-METRIC.png` from `summary` when the sweep writes no rows, returning its path.
/// It needs a marginal over exactly the varying axes, so each cell is one pose, as in the table.
pub(crate) fn figure_of_marginal(dir: &Path, d: &Descriptor, summary: &Path) -> Result<Option<PathBuf>> {
    if d.varying.is_empty() || d.varying.len() > 2 || !is_regular(summary) {
        return Ok(None);
    }
    let bytes = sonarproj::files::read_regular(summary, crate::sweep::records::MAX_RECORD_BYTES).map_err(
        |source| Error::ReadInput {
            path: summary.to_path_buf(),
            source,
        },
    )?;
    let s: Summary = serde_json::from_slice(&bytes).map_err(|e| Error::Csv {
        context: summary.display().to_string(),
        message: e.to_string(),
    })?;
    if s.metric != d.metric {
        return Ok(None);
    }
    let Some(m) = s.marginals.iter().find(|m| m.axes == d.varying) else {
        return Ok(None);
    };
    let points: Vec<(Vec<f64>, Option<f64>)> = match m.values.as_slice() {
        [x] => x.iter().zip(&m.mean).map(|(&x, &v)| (vec![x], v)).collect(),
        [x, y] => x
            .iter()
            .flat_map(|&a| y.iter().map(move |&b| vec![a, b]))
            .zip(&m.mean)
            .map(|(c, &v)| (c, v))
            .collect(),
        _ => return Ok(None),
    };
    draw(dir, d, &points).map(Some)
}

/// Draws `DIR/sweep-METRIC.png` from the result `table` and returns its path.
/// It needs one or two varying axes and a table that keeps the metric.
pub(crate) fn figure(table: &Path, format: Format, d: &Descriptor) -> Result<Option<PathBuf>> {
    let kept = d.columns.contains(&d.metric);
    if d.varying.is_empty() || d.varying.len() > 2 || !kept || !is_regular(table) {
        return Ok(None);
    }
    let dir = table.parent().unwrap_or(Path::new("."));
    let col = |name: &str| {
        d.columns
            .iter()
            .position(|c| c == name)
            .expect("descriptor column")
    };
    let xs: Vec<usize> = d.varying.iter().map(|v| col(v)).collect();
    let m = col(&d.metric);
    let mut points = Vec::new();
    match format {
        Format::Csv => {
            let mut rdr = csv::Reader::from_path(table).map_err(|e| Error::Csv {
                context: table.display().to_string(),
                message: e.to_string(),
            })?;
            for rec in rdr.records() {
                let rec = rec.map_err(|e| Error::Csv {
                    context: table.display().to_string(),
                    message: e.to_string(),
                })?;
                let num = |i: usize| rec.get(i).and_then(|s| s.parse::<f64>().ok());
                let coords: Vec<f64> = xs.iter().map(|&i| num(i).unwrap_or(f64::NAN)).collect();
                points.push((coords, num(m)));
            }
        }
        Format::Parquet => {
            for group in read_groups(table, &d.columns, &column_kinds(&d.columns))? {
                let group = group?;
                for i in 0..group.rows() {
                    let coords: Vec<f64> = xs
                        .iter()
                        .map(|&j| group.columns[j].get(i).unwrap_or(f64::NAN))
                        .collect();
                    points.push((coords, group.columns[m].get(i)));
                }
            }
        }
    }
    if points.is_empty() {
        // A table written through a link to a device reads back empty: nothing to draw.
        return Ok(None);
    }
    draw(dir, d, &points).map(Some)
}

/// Draws `DIR/sweep-METRIC.png` of `points` (axis values, metric) and returns its path. Axes
/// and caption name the columns in words, with units.
fn draw(dir: &Path, d: &Descriptor, points: &[(Vec<f64>, Option<f64>)]) -> Result<PathBuf> {
    let path = dir.join(format!("sweep-{}.png", d.metric));
    let axes: Vec<String> = d.varying.iter().map(|c| column_words(c)).collect();
    let caption = match axes.as_slice() {
        [x] => format!(
            "{}: {} against {}",
            d.title,
            figures::without_unit(&d.metric_label),
            figures::without_unit(x)
        ),
        _ => format!("{}: {}", d.title, d.metric_label),
    };
    figures::sweep(&path, &caption, &axes, &d.metric_label, "nothing visible", points)?;
    Ok(path)
}
