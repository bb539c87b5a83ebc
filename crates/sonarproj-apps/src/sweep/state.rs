//! A run's files on disk: its results, and its `.partial-*` state while unfinished.
//! The state holds the manifest, the lock, and one file per finished chunk, each with a record.
//! Also writes the chunks and joins the Parquet result from them.

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::io::parquet::{Table, TableWriter};
use crate::params;
use crate::report::{check_output_file, remove_stale_temporaries};
use crate::sweep::parts::{self, final_encoding, write_json};
use crate::sweep::plan::Plan;
use crate::sweep::records::{Settings, first_difference, first_not_good, read_json};
use crate::sweep::shard::Shard;
use crate::sweep::summary::Summary;
use crate::sweep::table::Format;
use sonarproj::error::Field;

/// The state of an unfinished run, in its `.partial-*` directory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Manifest {
    pub(crate) fingerprint: String,
    /// CSV when absent, as in manifests written before Parquet existed.
    #[serde(default)]
    pub(crate) format: Format,
    pub(crate) chunk_poses: u64,
    pub(crate) shard: Option<Shard>,
    pub(crate) settings: Settings,
}

/// Returns the name a run's files take: `sweep` for a whole run, `shard-K-of-N` for a shard.
pub(crate) fn stem(shard: Option<Shard>) -> String {
    shard.map_or_else(|| "sweep".to_string(), |s| s.stem())
}

/// Returns the manifest of the unfinished run `stem` in `dir`, if one is there and readable.
pub(crate) fn unfinished(dir: &Path, stem: &str) -> Option<Manifest> {
    read_json::<Manifest>(&dir.join(format!(".partial-{stem}")).join("manifest.json"))
        .ok()
        .flatten()
}

/// The paths of a run's files: results, state and chunks.
pub(crate) struct Files<'a> {
    pub(crate) plan: &'a Plan<'a>,
    pub(crate) stem: String,
    /// The result: the table, or the summaries alone when no rows are written.
    pub(crate) file: PathBuf,
    pub(crate) summary: PathBuf,
    /// The unfinished run's `.partial-*` directory.
    pub(crate) state: PathBuf,
    format: Format,
}

/// What writing a chunk returns: its encoded Parquet table and its summary, when present.
#[derive(Default)]
pub(crate) struct Written {
    pub(crate) table: Option<bytes::Bytes>,
    pub(crate) summary: Option<Summary>,
}

impl<'a> Files<'a> {
    /// Returns the files of `plan` run into `dir` in `format`, for `shard` or the whole sweep.
    pub(crate) fn new(plan: &'a Plan<'a>, dir: &Path, shard: Option<Shard>, format: Format) -> Self {
        let stem = stem(shard);
        let summary = match shard {
            Some(_) => dir.join(format!("{stem}.summary.json")),
            None => dir.join("summary.json"),
        };
        let file = if plan.rows {
            dir.join(format!("{stem}.{}", format.extension()))
        } else {
            summary.clone()
        };
        Files {
            plan,
            state: dir.join(format!(".partial-{stem}")),
            stem,
            file,
            summary,
            format,
        }
    }

    /// Returns the result files this run writes: the table, the summaries, or both.
    pub(crate) fn results(&self) -> Vec<&Path> {
        match (self.plan.rows, self.plan.spec.is_some()) {
            (true, true) => vec![&self.file, &self.summary],
            (false, _) => vec![&self.summary],
            (true, false) => vec![&self.file],
        }
    }

    /// Returns an error naming `--out` unless every result file can be written.
    pub(crate) fn check_writable(&self) -> Result<()> {
        self.results()
            .iter()
            .try_for_each(|f| check_output_file(f, crate::params::OUT))
    }

    /// Returns what the record of the whole run's result must say.
    pub(crate) fn whole(&self) -> parts::Expected<'_> {
        self.expected(&self.plan.range)
    }

    /// Returns what the record of a part holding poses `r` must say.
    pub(crate) fn expected(&self, r: &Range<u64>) -> parts::Expected<'_> {
        parts::Expected {
            fingerprint: &self.plan.desc.fingerprint,
            first: r.start,
            rows: r.end - r.start,
        }
    }

    pub(crate) fn chunk_path(&self, c: u64) -> PathBuf {
        self.state
            .join(format!("chunk-{c:08}.{}", self.format.extension()))
    }

    pub(crate) fn chunk_summary(&self, c: u64) -> PathBuf {
        self.state.join(format!("chunk-{c:08}.summary.json"))
    }

    /// Returns the files chunk `c` leaves: its table, its summary, or both.
    pub(crate) fn chunk_files(&self, c: u64) -> Vec<PathBuf> {
        let mut out = Vec::with_capacity(2);
        if self.plan.rows {
            out.push(self.chunk_path(c));
        }
        if self.plan.spec.is_some() {
            out.push(self.chunk_summary(c));
        }
        out
    }

    /// Returns whether chunk `c`'s files, left by an earlier run, are all good.
    /// For a damaged chunk it also returns the bad file and why.
    pub(crate) fn checked(&self, c: u64) -> (bool, Option<(PathBuf, String)>) {
        let files = self.chunk_files(c);
        let (damaged, status) = first_not_good(
            &files.iter().map(PathBuf::as_path).collect::<Vec<_>>(),
            self.expected(&self.plan.chunk(c)),
        );
        match status {
            parts::Status::Good => (true, None),
            parts::Status::Damaged(reason) => (false, Some((damaged.to_path_buf(), reason))),
            parts::Status::Missing => (false, None),
        }
    }

    /// Makes and locks the run's state directory, checks or writes `manifest`, returns the lock.
    /// The lock, released when dropped, stops a second run (the same shard submitted twice, say)
    /// from racing over the chunks.
    ///
    /// # Errors
    /// [`Error::WriteOutput`] when the directory cannot be made or another run holds it.
    /// [`sonarproj::Error::InvalidValue`] naming a setting that differs from the unfinished run.
    pub(crate) fn open_state(&self, manifest: &Manifest) -> Result<Option<std::fs::File>> {
        let state = &self.state;
        std::fs::create_dir_all(state).map_err(|e| Error::write_output(state, e))?;
        let lock = lock_state(state)?;
        remove_stale_temporaries(state);
        let manifest_path = state.join("manifest.json");
        match read_json::<Manifest>(&manifest_path)? {
            None => write_json(&manifest_path, manifest)?,
            Some(old) if old == *manifest => {}
            Some(old) => {
                let (field, was, now) = first_manifest_difference(&old, manifest);
                return Err(Error::invalid(
                    field,
                    now,
                    format!(
                        "the unfinished run in {} used {was}; re-run with the same settings to resume, or remove that directory to start over",
                        state.display()
                    ),
                ));
            }
        }
        Ok(lock)
    }

    /// Writes chunk `c` (poses `r`): its Parquet table, if any, and the summary of its `values`,
    /// if asked. Returns both: the table encoded for the result's join, the summary for the total.
    /// Unless `keep`, neither is kept on disk in the run's state, only returned.
    pub(crate) fn write_chunk(
        &self,
        c: u64,
        r: Range<u64>,
        table: Option<Table>,
        values: Option<crate::sweep::plan::ForSummary>,
        keep: bool,
    ) -> Result<Written> {
        let plan = self.plan;
        let mut written = Written::default();
        if let Some(table) = table {
            let path = self.chunk_path(c);
            let columns = &plan.desc.columns;
            // Room for the table uncompressed, 8 bytes a value (at most 256 MiB, the size of the
            // table in memory at the largest chunk): the encoded chunk grows into it without a
            // copy, and pages the encoding leaves untouched cost no memory.
            let raw = usize::try_from(r.end - r.start)
                .unwrap_or(usize::MAX)
                .saturating_mul(8 * columns.len());
            let mut bytes = Vec::with_capacity(raw.saturating_add(1 << 16).min(1 << 28));
            let mut t = TableWriter::new(
                &mut bytes,
                columns,
                &plan.kinds,
                r.start,
                final_encoding(columns),
                &path,
            )?;
            t.push(table)?;
            t.finish()?;
            if keep {
                parts::write_chunk(&path, self.expected(&r), |w| {
                    w.write_all(&bytes).map_err(|e| Error::write_output(&path, e))
                })?;
            } else {
                // A damaged part of this chunk from an earlier run goes: the chunk now lives in
                // memory until the results hold it.
                parts::remove_stale(&path)?;
            }
            written.table = Some(bytes::Bytes::from(bytes));
        }
        if let (Some(spec), Some(values)) = (plan.spec, values) {
            let summary = values.into_part(spec, plan.grid, r.start)?;
            let sum_path = self.chunk_summary(c);
            if keep {
                let part = summary.to_part();
                // Encoded whole first, as the summary is (records::write_summary).
                let bytes = serde_json::to_vec(&part).map_err(|e| Error::write_output(&sum_path, e))?;
                parts::write_chunk(&sum_path, self.expected(&r), |w| {
                    w.write_all(&bytes).map_err(|e| Error::write_output(&sum_path, e))
                })?;
            } else {
                parts::remove_stale(&sum_path)?;
            }
            written.summary = Some(summary);
        }
        Ok(written)
    }

    /// Joins the Parquet chunks into the result, in order, as `rx` hands them over.
    /// The result's temporary file grows during the run and is renamed at [`ToJoin::Finish`].
    /// A run that stops drops the sender, and the temporary file is removed.
    ///
    /// # Errors
    /// Errors of reading the chunks and writing the result.
    /// [`sonarproj::Error::Stopped`] when the sender is dropped first.
    pub(crate) fn join_chunks(&self, rx: std::sync::mpsc::Receiver<ToJoin>) -> Result<()> {
        let (columns, kinds) = (&self.plan.desc.columns, &self.plan.kinds);
        let (file, whole, last) = (&self.file, self.whole(), self.plan.chunks);
        parts::write(file, whole, |w| {
            let mut join = parts::ParquetJoin::new(w, columns, kinds, file, whole)?;
            for message in rx {
                match message {
                    ToJoin::Bytes(c, bytes) => join.add_bytes(bytes, &self.chunk_path(c), c + 1 == last)?,
                    ToJoin::File(c) => join.add_file(&self.chunk_path(c), c + 1 == last)?,
                    ToJoin::Finish => return join.finish(),
                }
            }
            Err(sonarproj::Error::Stopped.into())
        })
    }
}

/// A message to the thread joining a run's Parquet chunks into its result.
pub(crate) enum ToJoin {
    /// Chunk `c`, just written from these bytes.
    Bytes(u64, bytes::Bytes),
    /// Chunk `c`, on disk from an earlier run.
    File(u64),
    /// Every chunk is in: the result is finished and renamed into place.
    Finish,
}

/// Returns the first setting where manifest `old` differs from `new`: option, old and new value.
fn first_manifest_difference(old: &Manifest, new: &Manifest) -> (Field, String, String) {
    if old.format != new.format {
        (
            Field::from(params::FORMAT),
            old.format.extension().to_string(),
            new.format.extension().to_string(),
        )
    } else if old.chunk_poses != new.chunk_poses {
        (
            Field::from(params::CHUNK_POSES),
            old.chunk_poses.to_string(),
            new.chunk_poses.to_string(),
        )
    } else if let Some((name, was, now)) = first_difference(&old.settings, &new.settings) {
        (
            if name == "backend" {
                Field::from(params::BACKEND)
            } else {
                Field::from(name)
            },
            was,
            now,
        )
    } else {
        (
            Field::from(params::CONFIG),
            "another sweep".into(),
            "this one".into(),
        )
    }
}

/// Returns the lock on run state `state`: an open file, unlocked when dropped.
/// Returns `None` where the file system has no locks.
///
/// # Errors
/// [`Error::WriteOutput`] when another process holds it, or the lock file cannot be made.
fn lock_state(state: &Path) -> Result<Option<std::fs::File>> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        let path = state.join("lock");
        crate::sweep::parts::state_file(&path)?;
        // Without waiting on a FIFO; anything but a regular file is refused.
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .custom_flags(rustix::fs::OFlags::NONBLOCK.bits().cast_signed())
            .open(&path)
            .map_err(|e| Error::write_output(&path, e))?;
        if !file.metadata().is_ok_and(|m| m.is_file()) {
            return Err(Error::write_output(
                &path,
                std::io::Error::other(sonarproj::files::NOT_REGULAR),
            ));
        }
        match rustix::fs::flock(&file, rustix::fs::FlockOperation::NonBlockingLockExclusive) {
            Ok(()) => Ok(Some(file)),
            Err(e) if e == rustix::io::Errno::WOULDBLOCK => Err(Error::WriteOutput {
                path: state.to_path_buf(),
                message: "another run of this sweep (or shard) is working in it; wait for it to finish, \
                          or run this one into another output directory"
                    .into(),
            }),
            // No locks on this file system (Lustre without `flock`, some NFS setups): run unlocked.
            Err(_) => Ok(None),
        }
    }
    #[cfg(not(unix))]
    {
        let _ = state;
        Ok(None)
    }
}
