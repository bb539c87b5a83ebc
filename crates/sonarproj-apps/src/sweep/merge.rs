//! Joining a sweep's shards into the files one run writes.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::report::check_output_file;
use crate::sweep::figure::{figure, figure_of_marginal};
use crate::sweep::parts::{self};
use crate::sweep::records::{
    Descriptor, Settings, first_difference, first_not_good, read_json, read_part, settings_path,
    write_summary,
};
use crate::sweep::shard::Shard;
use crate::sweep::summary::Summary;
use crate::sweep::table::{Format, column_kinds};

/// Joins the shard files `shard-K-of-N.csv` in `dir` into `dir/sweep.csv` (byte for byte the
/// file one run would have written) and draws the figure; returns both paths.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `DIR` when there is no sweep there, parts of different
/// counts, or a missing part; [`Error::Csv`] for a part with the wrong header or row count.
pub fn merge(dir: &Path) -> Result<Merged> {
    let desc: Descriptor = read_json(&dir.join("sweep.json"))?.ok_or_else(|| {
        Error::invalid(
            "DIR",
            dir.display(),
            "has no sweep.json: not the --out directory of a sharded sweep",
        )
    })?;
    // A shard's result: its table, or its summaries when the sweep writes no rows.
    let rows = desc.summary.as_ref().is_none_or(|s| s.rows);
    let suffixes: &[(&str, Format)] = if rows {
        &[(".csv", Format::Csv), (".parquet", Format::Parquet)]
    } else {
        &[(".summary.json", Format::Csv)]
    };
    let mut shards: Vec<(Shard, Format)> = Vec::new();
    let entries = std::fs::read_dir(dir).map_err(|source| Error::ReadInput {
        path: dir.to_path_buf(),
        source,
    })?;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        for &(suffix, format) in suffixes {
            if let Some(s) = name
                .strip_prefix("shard-")
                .and_then(|s| s.strip_suffix(suffix))
                .and_then(|s| Shard::parse(&s.replace("-of-", "/")).ok())
            {
                shards.push((s, format));
            }
        }
    }
    let format = match shards
        .iter()
        .map(|s| s.1)
        .collect::<std::collections::BTreeSet<_>>()
    {
        f if f.len() == 2 => {
            return Err(Error::invalid(
                "DIR",
                dir.display(),
                "holds shards as CSV and as Parquet; keep one set (remove the other's shard files)",
            ));
        }
        f => f.first().copied().unwrap_or_default(),
    };
    let ext = format.extension();
    let main = |stem: &str| {
        if rows {
            dir.join(format!("{stem}.{ext}"))
        } else {
            dir.join(format!("{stem}.summary.json"))
        }
    };
    let shards: Vec<Shard> = shards.into_iter().map(|s| s.0).collect();
    let n = match shards
        .iter()
        .map(|s| s.n)
        .collect::<std::collections::BTreeSet<_>>()
    {
        ns if ns.len() == 1 => *ns.first().expect("one"),
        ns if ns.is_empty() => {
            return Err(Error::invalid(
                "DIR",
                dir.display(),
                if rows {
                    "holds no finished shard-K-of-N.csv or shard-K-of-N.parquet"
                } else {
                    "holds no finished shard-K-of-N.summary.json"
                },
            ));
        }
        ns => {
            return Err(Error::invalid(
                "DIR",
                dir.display(),
                format!("holds shards of different counts N ({ns:?}); keep one set"),
            ));
        }
    };
    let missing: Vec<u64> = (1..=n).filter(|k| !shards.iter().any(|s| s.k == *k)).collect();
    if !missing.is_empty() {
        return Err(Error::invalid(
            "DIR",
            dir.display(),
            format!("lacks shards {missing:?} of {n} (run them with --shard K/{n}, or finish them)"),
        ));
    }
    // Every shard must be this sweep's part K, whole: checked against its record before
    // anything is written, and again while it is copied.
    let mut files = Vec::new();
    let mut summaries = Vec::new();
    for k in 1..=n {
        let shard = Shard { k, n };
        let file = main(&shard.stem());
        let summary = dir.join(format!("{}.summary.json", shard.stem()));
        let r = shard.range(desc.poses);
        let expected = parts::Expected {
            fingerprint: &desc.fingerprint,
            first: r.start,
            rows: r.end - r.start,
        };
        let mut checked: Vec<&Path> = vec![&file];
        if rows && desc.summary.is_some() {
            checked.push(&summary);
        }
        let (file, status) = first_not_good(&checked, expected);
        let file = file.to_path_buf();
        match status {
            parts::Status::Good => {
                files.push(main(&shard.stem()));
                summaries.push((summary, r));
            }
            parts::Status::Missing => {
                return Err(Error::invalid(
                    "DIR",
                    dir.display(),
                    format!(
                        "lacks {} (shard {k} of {n}): run `sweep --shard {k}/{n}` again",
                        file.file_name()
                            .map_or_else(String::new, |f| f.to_string_lossy().into_owned())
                    ),
                ));
            }
            parts::Status::Damaged(reason) => {
                return Err(Error::Csv {
                    context: file.display().to_string(),
                    message: format!(
                        "{reason}; nothing merged (run `sweep --shard {k}/{n}` again to recompute this shard)"
                    ),
                });
            }
        }
    }
    // Every shard computed alike: the same engine and backend settings as shard 1, else nothing
    // is written.
    let mut first: Option<Settings> = None;
    for (k, file) in files.iter().enumerate() {
        let path = settings_path(file);
        let record: Settings = read_json(&path)?.ok_or_else(|| Error::Csv {
            context: file.display().to_string(),
            message: format!(
                "has no record of how it was computed ({} is missing); nothing merged (remove it and run `sweep --shard {}/{n}` again)",
                path.display(),
                k + 1
            ),
        })?;
        match &first {
            None => first = Some(record),
            Some(one) => {
                if let Some((name, a, b)) = first_difference(one, &record) {
                    return Err(Error::invalid(
                        name.clone(),
                        format!("{b:?} in shard {} of {n}", k + 1),
                        format!(
                            "differs from {a:?} in shard 1: shards computed with different {name} would merge into a table no single run writes; nothing merged (recompute one set alike)"
                        ),
                    ));
                }
            }
        }
    }
    let whole = parts::Expected {
        fingerprint: &desc.fingerprint,
        first: 0,
        rows: desc.poses,
    };
    let summary_file = dir.join("summary.json");
    // Both results can be written before either is.
    if desc.summary.is_some() {
        check_output_file(&summary_file, "DIR")?;
    }
    if rows {
        check_output_file(&dir.join(format!("sweep.{ext}")), "DIR")?;
    }
    // The shards' summaries combined (each read once and checked against its record) before
    // anything is written, the summary written last: a summary beside a table means the table
    // is whole, as after a run.
    let mut combined: Option<Summary> = None;
    if let Some(spec) = &desc.summary {
        let mut total: Option<Summary> = None;
        for (path, r) in &summaries {
            let expected = parts::Expected {
                fingerprint: &desc.fingerprint,
                first: r.start,
                rows: r.end - r.start,
            };
            let part: Summary = read_part(path, expected)?;
            let context = path.display().to_string();
            spec.check(&part, r.start, r.end - r.start, &context)?;
            total = Some(match total {
                None if part.metric == spec.by => part,
                None => {
                    return Err(Error::Csv {
                        context,
                        message: format!("summarises {:?}, not this sweep's {:?}", part.metric, spec.by),
                    });
                }
                Some(t) => spec.combine(&t, &part, &context)?,
            });
        }
        combined = Some(total.expect("at least one shard"));
    }
    let summary = desc.summary.as_ref().map(|_| summary_file.clone());
    if !rows {
        if let Some(total) = &combined {
            write_summary(&summary_file, whole, total)?;
        }
        let figure = figure_of_marginal(dir, &desc, &summary_file)?;
        return Ok(Merged {
            file: None,
            summary,
            figure,
        });
    }
    let out = dir.join(format!("sweep.{ext}"));
    match format {
        Format::Csv => parts::join(files, &desc.columns, &out, whole)?,
        Format::Parquet => {
            parts::join_parquet(files, &desc.columns, &column_kinds(&desc.columns), &out, whole)?;
        }
    }
    if let Some(total) = &combined {
        write_summary(&summary_file, whole, total)?;
    }
    let figure = figure(&out, format, &desc)?;
    Ok(Merged {
        file: Some(out),
        summary,
        figure,
    })
}

/// What [`merge`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Merged {
    /// The table (`sweep.csv` or `sweep.parquet`), unless the sweep writes no rows.
    pub file: Option<PathBuf>,
    /// `summary.json`, when the sweep has a `[summary]`.
    pub summary: Option<PathBuf>,
    /// The figure, when the sweep draws one.
    pub figure: Option<PathBuf>,
}
