//! The records a sweep's directory keeps besides its tables: `sweep.json` and each part's
//! settings `NAME.run.json`. Also the checks runs and merges make of them and of the parts.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sonarproj::projection::Backend;

use crate::error::{Error, Result};
use crate::sweep::SweepConfig;
use crate::sweep::parts::{self, write_json};
use crate::sweep::summary::{Summary, SummarySpec};

/// What a sweep is: written to `DIR/sweep.json` by every run and shard.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Descriptor {
    /// [`SweepConfig::fingerprint`].
    pub fingerprint: String,
    /// The number of poses of the whole sweep.
    pub poses: u64,
    /// The CSV header.
    pub columns: Vec<String>,
    /// The grid columns that vary (a figure is drawn for one or two).
    pub varying: Vec<String>,
    /// The metric the figure draws.
    pub metric: String,
    /// The metric's axis label.
    pub metric_label: String,
    /// The figure title.
    pub title: String,
    /// The summaries asked for. Left out when none, so such sweeps' descriptors stay unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub summary: Option<SummarySpec>,
}

/// The settings that decide a run's numbers, besides the sweep file the fingerprint covers.
/// They are the engine's version and [`Backend::settings`], by name. Written beside each shard
/// (`shard-K-of-N.run.json`) so that `merge` joins only shards computed alike.
pub type Settings = std::collections::BTreeMap<String, String>;

/// Returns the settings of a run on `backend`.
#[must_use]
pub fn settings(backend: &Backend) -> Settings {
    let mut out: Settings = backend
        .settings()
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    out.insert("engine version".into(), sonarproj::VERSION.into());
    out
}

/// Returns the first setting (in name order) whose values differ between `a` and `b`, with both
/// values (`(none)` where one lacks it).
pub(crate) fn first_difference(a: &Settings, b: &Settings) -> Option<(String, String, String)> {
    let none = || "(none)".to_string();
    a.keys()
        .chain(b.keys())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .find(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            (
                k.clone(),
                a.get(k).cloned().unwrap_or_else(none),
                b.get(k).cloned().unwrap_or_else(none),
            )
        })
}

/// Returns the path of part `file`'s settings: `NAME.run.json` or `NAME.parquet.run.json`.
pub(crate) fn settings_path(file: &Path) -> PathBuf {
    parts::beside(file, "run.json")
}

/// The most bytes a run's JSON record (a manifest, a part's record or settings) may have.
pub(crate) const MAX_RECORD_BYTES: u64 = 64 << 20;
/// The most bytes a part read whole may have.
const MAX_PART_BYTES: u64 = 1 << 30;

/// Returns the JSON in `path`, or `None` when the file does not exist.
pub(crate) fn read_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<Option<T>> {
    // Only a regular file, bounded: a FIFO or a device there is refused, never waited on.
    match sonarproj::files::read_regular(path, MAX_RECORD_BYTES) {
        Ok(bytes) => serde_json::from_slice(&bytes).map(Some).map_err(|e| Error::Csv {
            context: path.display().to_string(),
            message: format!(
                "not a sonarproj sweep file ({e}); remove it or choose another output directory"
            ),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(Error::ReadInput {
            path: path.to_path_buf(),
            source,
        }),
    }
}

/// Returns the descriptor of `config`.
pub fn descriptor(config: &SweepConfig) -> Result<Descriptor> {
    let mut columns = config.columns();
    columns.extend(config.result_columns.iter().map(|c| c.to_string()));
    Ok(Descriptor {
        fingerprint: config.fingerprint(),
        poses: config.count()?,
        columns,
        varying: config.varying(),
        metric: config.metric.name().to_string(),
        metric_label: config.metric_label().to_string(),
        title: format!("{} to {}", config.source.name, config.target.name),
        summary: config.summary.clone(),
    })
}

/// Writes `DIR/sweep.json`, or checks that the one there describes the same sweep.
pub(crate) fn claim(dir: &Path, d: &Descriptor) -> Result<()> {
    let path = dir.join("sweep.json");
    match read_json::<Descriptor>(&path)? {
        Some(old) if old == *d => Ok(()),
        Some(_) => Err(Error::invalid(
            crate::params::OUT,
            dir.display(),
            "holds results of a different sweep (its sweep.json differs); choose another directory or empty this one",
        )),
        None => write_json(&path, d),
    }
}

/// Writes the summaries `total` to `path` as pretty JSON, with its record for `expected`.
pub(crate) fn write_summary(path: &Path, expected: parts::Expected<'_>, total: &Summary) -> Result<()> {
    // Encoded whole first: serde_json writes token by token, and small writes through the
    // checksumming writer cost more than the encoding (the benchmark's 1.25 MB summary, written
    // and synced: about 8 ms that way, 4 this way).
    let mut bytes = serde_json::to_vec_pretty(total).map_err(|e| Error::write_output(path, e))?;
    bytes.push(b'\n');
    parts::write(path, expected, |w| {
        w.write_all(&bytes).map_err(|e| Error::write_output(path, e))
    })
}

/// Returns the first of `files` not good for `expected`, with its status.
/// When all are good, returns the last file and [`parts::Status::Good`].
pub(crate) fn first_not_good<'f>(
    files: &[&'f Path],
    expected: parts::Expected<'_>,
) -> (&'f Path, parts::Status) {
    for f in files {
        let status = parts::check(f, expected);
        if status != parts::Status::Good {
            return (f, status);
        }
    }
    (files[files.len() - 1], parts::Status::Good)
}

/// Returns the JSON part `path`, its bytes checked against its record for `expected`.
/// It is read once, so what is checked is what is parsed.
pub(crate) fn read_part<T: for<'de> Deserialize<'de>>(
    path: &Path,
    expected: parts::Expected<'_>,
) -> Result<T> {
    let bytes = sonarproj::files::read_regular(path, MAX_PART_BYTES).map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })?;
    let damaged = |message: String| Error::Csv {
        context: path.display().to_string(),
        message,
    };
    parts::check_bytes(path, &bytes, expected).map_err(damaged)?;
    serde_json::from_slice(&bytes).map_err(|e| damaged(format!("not a sweep summary ({e})")))
}
