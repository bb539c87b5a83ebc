//! The columns of a sweep's table: which result columns a sweep file keeps (`columns`), the
//! default figure metric, each column's kind, and what fills it.

use sonarproj::geometry::sonar::SonarKind;
use sonarproj::metrics::Metric;

use crate::error::Result;
use crate::io::METRIC_COLUMNS;
use crate::io::batch::LOCAL_COLUMNS;
use crate::io::parquet::Kind;
use crate::io::toml_keys::ConfigFile;
use crate::sweep::summary::SummarySpec;

/// Returns the result columns sweep file `f` keeps, in table order, from its `columns` value `v`.
/// `v` must be a non-empty list of distinct names from [`METRIC_COLUMNS`].
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `columns` (or `columns[i]`) otherwise.
pub(crate) fn result_columns(f: ConfigFile<'_>, v: &toml::Value) -> Result<Vec<&'static str>> {
    let allowed = || format!("must be one of {}", METRIC_COLUMNS.join(", "));
    let toml::Value::Array(names) = v else {
        return Err(f.error("columns", v, "must be a list of column names"));
    };
    if names.is_empty() {
        return Err(f.error(
            "columns",
            "[]",
            format!("must name at least one column: {}", METRIC_COLUMNS.join(", ")),
        ));
    }
    let mut kept = [false; METRIC_COLUMNS.len()];
    for (i, name) in names.iter().enumerate() {
        let key = format!("columns[{i}]");
        let toml::Value::String(name) = name else {
            return Err(f.error(&key, name, allowed()));
        };
        let Some(k) = METRIC_COLUMNS.iter().position(|c| c == name) else {
            return Err(f.error(&key, format!("{name:?}"), allowed()));
        };
        if std::mem::replace(&mut kept[k], true) {
            return Err(f.error(&key, format!("{name:?}"), "is named twice"));
        }
    }
    Ok(METRIC_COLUMNS
        .iter()
        .zip(kept)
        .filter_map(|(c, k)| k.then_some(*c))
        .collect())
}

/// Returns the metric a sweep's figure draws when its file names none.
/// Prefers the span for an SSS sonar 2 and the projection area for an FLS, if kept. Else the
/// first kept metric with a figure label. Else the preferred one, and no figure is drawn.
pub(crate) fn default_metric(target: SonarKind, kept: &[&str]) -> Metric {
    let preferred = match target {
        SonarKind::Sss => Metric::Span,
        SonarKind::Fls => Metric::ProjectionArea,
    };
    if kept.contains(&preferred.name()) {
        return preferred;
    }
    kept.iter()
        .filter_map(|c| Metric::from_name(c))
        .find(|m| m.label(target).is_some())
        .unwrap_or(preferred)
}

/// Checks sweep file `f`'s `columns` (`kept`) against the rest of it (`top`).
/// A table must be written (no `[summary]` with `rows = false`), and it must keep the figure's
/// `metric` when the file names one.
pub(crate) fn check_columns(
    f: ConfigFile<'_>,
    top: &toml::Table,
    kept: &[&str],
    metric: Metric,
    summary: Option<&SummarySpec>,
) -> Result<()> {
    let Some(columns) = top.get("columns") else {
        return Ok(());
    };
    if summary.is_some_and(|s| !s.rows) {
        return Err(f.error(
            "columns",
            columns,
            "has no table to choose from: [summary] says rows = false (leave columns out)",
        ));
    }
    if top.contains_key("metric") && !kept.contains(&metric.name()) {
        return Err(f.error(
            "metric",
            format!("{:?}", metric.name()),
            format!(
                "is drawn from the table, so columns must keep it (columns keeps {})",
                kept.join(", ")
            ),
        ));
    }
    Ok(())
}

/// Returns the kinds of a sweep table's `columns`, as its descriptor lists them.
/// The index is an integer and pose columns are numbers. Result columns follow the metric table:
/// counts are integers; extremes, the projection area and local precision are nullable.
#[must_use]
pub fn column_kinds(columns: &[String]) -> Vec<Kind> {
    let metrics = sonarproj::Metrics::default();
    columns
        .iter()
        .enumerate()
        .map(|(j, name)| match Metric::from_name(name) {
            _ if j == 0 => Kind::Int,
            Some(m) => match metrics.get(m) {
                sonarproj::metrics::Value::Count(_) => Kind::Int,
                sonarproj::metrics::Value::Real(_) => Kind::Real,
                sonarproj::metrics::Value::Optional(_) => Kind::Optional,
            },
            None if LOCAL_COLUMNS.contains(&name.as_str()) => Kind::Optional,
            None => Kind::Real,
        })
        .collect()
}

/// Returns the number of pose columns of a sweep table's `columns`: those between the index and
/// the first result column.
#[must_use]
pub(crate) fn pose_column_count(columns: &[String]) -> usize {
    columns
        .iter()
        .skip(1)
        .take_while(|c| !METRIC_COLUMNS.contains(&c.as_str()))
        .count()
}

/// What fills a result column of a sweep table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Fill {
    Metric(Metric),
    /// The local precision's range per elevation.
    RangePerElevation,
    /// The local precision's sigma elevation.
    SigmaElevation,
}

/// Returns what fills result column `name` (one of [`METRIC_COLUMNS`]).
pub(crate) fn fill_of(name: &str) -> Fill {
    match Metric::from_name(name) {
        Some(m) => Fill::Metric(m),
        None if name == LOCAL_COLUMNS[0] => Fill::RangePerElevation,
        None => {
            debug_assert_eq!(name, LOCAL_COLUMNS[1], "a result column");
            Fill::SigmaElevation
        }
    }
}

pub(crate) fn kept_metrics(columns: &[&str]) -> Vec<Metric> {
    columns.iter().filter_map(|c| Metric::from_name(c)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pose and result columns are told apart by name, and each result column has its own fill.
    #[test]
    fn result_columns_are_told_from_pose_columns_by_name() {
        let poses = crate::io::pose_columns::allowed_columns();
        for name in METRIC_COLUMNS {
            assert!(!poses.contains(&name), "{name} is both");
        }
        let mut names: Vec<String> = ["index", "range", "roll"].map(String::from).to_vec();
        names.extend(["sigma_elevation", "visible", "span", "range_per_elevation"].map(String::from));
        assert_eq!(pose_column_count(&names), 2);
        assert_eq!(
            column_kinds(&names),
            [
                Kind::Int,
                Kind::Real,
                Kind::Real,
                Kind::Optional,
                Kind::Int,
                Kind::Real,
                Kind::Optional
            ]
        );
        assert_eq!(fill_of("span"), Fill::Metric(Metric::Span));
        assert_eq!(fill_of("range_per_elevation"), Fill::RangePerElevation);
        assert_eq!(fill_of("sigma_elevation"), Fill::SigmaElevation);
    }
}
