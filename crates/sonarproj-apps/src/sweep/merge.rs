//! Joining a sweep's shards into the files one run writes.

use std::collections::BTreeSet;
use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::report::check_output_file;
use crate::sweep::columns::column_kinds;
use crate::sweep::figure::{figure, figure_of_marginal};
use crate::sweep::parts::{self};
use crate::sweep::records::{
    Descriptor, Settings, first_difference, first_not_good, read_json, read_part, settings_path,
    write_summary,
};
use crate::sweep::shard::Shard;
use crate::sweep::summary::Summary;
use crate::sweep::table::Format;

/// Joins the shards in `dir` into the files one run writes, byte for byte, and draws the figure.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `DIR` when there is no sweep there, parts of
/// different counts, or a missing part. [`Error::Csv`] for a part with the wrong header or rows.
pub fn merge(dir: &Path) -> Result<Merged> {
    let desc: Descriptor = read_json(&dir.join("sweep.json"))?.ok_or_else(|| {
        Error::invalid(
            crate::params::SWEEP_DIR,
            dir.display(),
            "has no sweep.json: not the --out directory of a sharded sweep",
        )
    })?;
    // A shard's result: its table, or its summaries when the sweep writes no rows.
    let rows = desc.summary.as_ref().is_none_or(|s| s.rows);
    let (format, n) = find_shards(dir, rows)?;
    let ext = format.extension();
    let shards = check_shards(dir, &desc, rows, format, n)?;
    check_alike(&shards, n)?;
    let whole = parts::Expected {
        fingerprint: &desc.fingerprint,
        first: 0,
        rows: desc.poses,
    };
    let summary_file = dir.join("summary.json");
    // Check that both results can be written before writing either.
    if desc.summary.is_some() {
        check_output_file(&summary_file, crate::params::SWEEP_DIR)?;
    }
    if rows {
        check_output_file(&dir.join(format!("sweep.{ext}")), crate::params::SWEEP_DIR)?;
    }
    // Combine the summaries before writing anything, and write the summary last. A summary
    // beside a table then means the table is whole, as after a run.
    let combined = combine_summaries(&desc, &shards)?;
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
    let files = shards.into_iter().map(|s| s.file);
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

/// A shard found whole: its result file, its summaries' file and its poses.
struct Found {
    file: PathBuf,
    summary: PathBuf,
    poses: Range<u64>,
}

/// Returns the format of the shards in `dir` (tables when `rows`, else summaries) and their count.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `DIR` when it holds shards in both formats, none, or
/// shards of different counts.
fn find_shards(dir: &Path, rows: bool) -> Result<(Format, u64)> {
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
    let formats: BTreeSet<Format> = shards.iter().map(|s| s.1).collect();
    if formats.len() == 2 {
        return Err(Error::invalid(
            crate::params::SWEEP_DIR,
            dir.display(),
            "holds shards as CSV and as Parquet; keep one set (remove the other's shard files)",
        ));
    }
    let format = formats.first().copied().unwrap_or_default();
    let counts: BTreeSet<u64> = shards.iter().map(|s| s.0.n).collect();
    let n = match counts.len() {
        1 => *counts.first().expect("one"),
        0 => {
            return Err(Error::invalid(
                crate::params::SWEEP_DIR,
                dir.display(),
                if rows {
                    "holds no finished shard-K-of-N.csv or shard-K-of-N.parquet"
                } else {
                    "holds no finished shard-K-of-N.summary.json"
                },
            ));
        }
        _ => {
            return Err(Error::invalid(
                crate::params::SWEEP_DIR,
                dir.display(),
                format!("holds shards of different counts N ({counts:?}); keep one set"),
            ));
        }
    };
    let missing: Vec<u64> = (1..=n).filter(|k| !shards.iter().any(|s| s.0.k == *k)).collect();
    if !missing.is_empty() {
        return Err(Error::invalid(
            crate::params::SWEEP_DIR,
            dir.display(),
            format!("lacks shards {missing:?} of {n} (run them with --shard K/{n}, or finish them)"),
        ));
    }
    Ok((format, n))
}

/// Returns the `n` shards of sweep `desc` in `dir`, each checked whole against its record.
/// The check runs before anything is written, and again while each shard is copied.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `DIR` for a missing shard.
/// [`Error::Csv`] for a damaged one.
fn check_shards(dir: &Path, desc: &Descriptor, rows: bool, format: Format, n: u64) -> Result<Vec<Found>> {
    let mut found = Vec::new();
    for k in 1..=n {
        let shard = Shard { k, n };
        let stem = shard.stem();
        let file = if rows {
            dir.join(format!("{stem}.{}", format.extension()))
        } else {
            dir.join(format!("{stem}.summary.json"))
        };
        let summary = dir.join(format!("{stem}.summary.json"));
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
        let (bad, status) = first_not_good(&checked, expected);
        let bad = bad.to_path_buf();
        // A shard is read: no output (through a link, say) may replace it.
        for f in &checked {
            crate::report::note_input(f);
        }
        match status {
            parts::Status::Good => found.push(Found {
                file,
                summary,
                poses: r,
            }),
            parts::Status::Missing => {
                return Err(Error::invalid(
                    crate::params::SWEEP_DIR,
                    dir.display(),
                    format!(
                        "lacks {} (shard {k} of {n}): run `sweep --shard {k}/{n}` again",
                        bad.file_name()
                            .map_or_else(String::new, |f| f.to_string_lossy().into_owned())
                    ),
                ));
            }
            parts::Status::Damaged(reason) => {
                return Err(Error::Csv {
                    context: bad.display().to_string(),
                    message: format!(
                        "{reason}; nothing merged (run `sweep --shard {k}/{n}` again to recompute this shard)"
                    ),
                });
            }
        }
    }
    Ok(found)
}

/// Returns an error unless every shard used shard 1's engine and backend settings.
///
/// # Errors
/// [`Error::Csv`] for a shard without its settings record.
/// [`sonarproj::Error::InvalidValue`] naming the first setting that differs.
fn check_alike(shards: &[Found], n: u64) -> Result<()> {
    let mut first: Option<Settings> = None;
    for (k, shard) in shards.iter().enumerate() {
        let file = &shard.file;
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
    Ok(())
}

/// Returns the shards' summaries combined, each read once and checked against its record.
/// Returns `None` when the sweep asks for none.
///
/// # Errors
/// [`Error::Csv`] for a summary that does not fit its shard or summarises another metric.
fn combine_summaries(desc: &Descriptor, shards: &[Found]) -> Result<Option<Summary>> {
    let Some(spec) = &desc.summary else {
        return Ok(None);
    };
    let mut total: Option<Summary> = None;
    for Found {
        summary: path,
        poses: r,
        ..
    } in shards
    {
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
    Ok(Some(total.expect("at least one shard")))
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
