//! `bench sweep --pyarrow PYTHON`: pyarrow writing the benchmark sweep's Parquet table again,
//! the peer the Parquet sweep is set against.

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use sonarproj::{Backend, Sampling};
use sonarproj_apps::bench;
use sonarproj_apps::{Error, Result};

/// The script `python` runs: `TABLE OUT RUNS` in, the median write's seconds out.
const SCRIPT: &str = include_str!("pyarrow_peer.py");

/// Returns the median time of `runs` pyarrow writes (after a warm-up) of the table of the
/// benchmark sweep of about `poses` poses at `step`, projected once on `backend`, with
/// interpreter `python`.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming `--pyarrow` when `python` cannot be run or cannot
/// write the table with pyarrow (its last words of error quoted); the sweep's errors; and
/// [`Error::WriteOutput`] without a temporary folder.
pub(super) fn pyarrow_write(
    python: &Path,
    backend: &Backend,
    poses: u64,
    step: Sampling,
    runs: u32,
) -> Result<Duration> {
    let scratch = tempfile::tempdir().map_err(|e| Error::write_output(&std::env::temp_dir(), e))?;
    let table = bench::parquet_table(backend, poses, step, &scratch.path().join("table"))?;
    let out = scratch.path().join("pyarrow.parquet");
    let bad = |why: String| {
        Error::invalid(
            "--pyarrow",
            python.display(),
            format!("must be a Python interpreter that has pyarrow: {why}"),
        )
    };
    let done = Command::new(python)
        .arg("-c")
        .arg(SCRIPT)
        .arg(&table)
        .arg(&out)
        .arg(runs.to_string())
        .output()
        .map_err(|e| bad(format!("cannot run it ({e})")))?;
    let stdout = String::from_utf8_lossy(&done.stdout);
    if !done.status.success() {
        let stderr = String::from_utf8_lossy(&done.stderr);
        let last = stderr.trim().lines().last().unwrap_or("no message").to_string();
        return Err(bad(format!("it exited with {} ({last})", done.status)));
    }
    stdout
        .trim()
        .parse::<f64>()
        .ok()
        .filter(|s| s.is_finite() && *s >= 0.0)
        .map(Duration::from_secs_f64)
        .ok_or_else(|| {
            bad(format!(
                "it printed {:?}, not the seconds of a write",
                stdout.trim()
            ))
        })
}
