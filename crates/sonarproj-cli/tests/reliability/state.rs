//! A run's state holds only files it wrote: a chunk, a record, the manifest or the lock that is
//! a FIFO, or a link to a device, is refused naming it at once, never waited on, written
//! through or read without end.

use super::*;

const GRID: &str = "from = \"paper-fls\"\nto = \"paper-sss\"\nstep = 0.5\n[feature]\nrange = 5\n\
                    [place]\nrange = { start = 2, stop = 18, step = 2 }\n[rotation]\nroll = { start = 0, stop = 180, step = 3 }\n";

/// Runs the sweep of `config` into `out` in chunks of 100 poses, at most `max` of them; returns
/// the exit status and stderr. The 60 s limit only guards against a hang.
fn run(config: &Path, out: &Path, max: Option<&str>) -> (Option<i32>, String) {
    run_as(config, out, max, "csv")
}

/// Runs as [`run`] does, writing `format`.
fn run_as(config: &Path, out: &Path, max: Option<&str>, format: &str) -> (Option<i32>, String) {
    let mut cmd = common::sonarproj();
    cmd.args([
        "sweep",
        "--backend",
        "cpu-fast",
        "--chunk-poses",
        "100",
        "--format",
        format,
        "--config",
    ])
    .arg(config)
    .arg("--out")
    .arg(out)
    .timeout(std::time::Duration::from_secs(60));
    if let Some(m) = max {
        cmd.args(["--max-chunks", m]);
    }
    let o = cmd.output().unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// Puts a special file at a path.
type Replace = fn(&Path);

#[test]
fn special_files_in_a_runs_state_are_refused_never_waited_on() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("s.toml");
    std::fs::write(&config, GRID).unwrap();
    // Each case: a fresh partial run, one of its files replaced, then the run resumed.
    let cases: [(&str, Replace); 5] = [
        ("chunk-00000000.csv", |p| common::mkfifo(p)),
        ("chunk-00000001.csv", |p| {
            std::os::unix::fs::symlink("/dev/zero", p).unwrap()
        }),
        ("chunk-00000000.meta.json", |p| common::mkfifo(p)),
        ("manifest.json", |p| common::mkfifo(p)),
        ("lock", |p| common::mkfifo(p)),
    ];
    for (k, (name, replace)) in cases.into_iter().enumerate() {
        let out = dir.path().join(format!("o{k}"));
        assert_eq!(run(&config, &out, Some("2")).0, Some(0));
        let target = out.join(".partial-sweep").join(name);
        assert!(target.exists(), "{name}");
        std::fs::remove_file(&target).unwrap();
        replace(&target);
        let (code, err) = run(&config, &out, None);
        assert!(!err.contains("panicked"), "{name}: {err}");
        // Refused naming the file (a state or input problem, never a hang), the result unwritten.
        assert!(matches!(code, Some(1 | 2)), "{name}: {code:?} {err}");
        assert!(
            err.contains(name) && err.contains("not a regular file"),
            "{name}: {err}"
        );
        assert!(!out.join("sweep.csv").exists(), "{name}");
    }
}

/// A Parquet chunk whose file cannot be written, in the middle of a run with writes in flight
/// behind it, stops the run with an error naming it: no hang, no panic, no result, and the
/// chunks finished around it stay for the next run.
#[test]
fn a_chunk_write_failing_while_others_are_in_flight_stops_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("s.toml");
    std::fs::write(&config, GRID).unwrap();
    let out = dir.path().join("o");
    assert_eq!(run_as(&config, &out, Some("2"), "parquet").0, Some(0));
    let state = out.join(".partial-sweep");
    // Chunk 2 of 6 is next: its file is a FIFO, so writing it fails while chunk 3 is written.
    let name = "chunk-00000002.parquet";
    common::mkfifo(&state.join(name));
    let (code, err) = run_as(&config, &out, None, "parquet");
    assert!(!err.contains("panicked"), "{err}");
    assert!(matches!(code, Some(1 | 2)), "{code:?} {err}");
    assert!(err.contains(name) && err.contains("not a regular file"), "{err}");
    assert!(!out.join("sweep.parquet").exists());
    // Chunk 3, written while chunk 2 failed, is finished and kept too.
    for kept in [
        "chunk-00000000.parquet",
        "chunk-00000001.parquet",
        "chunk-00000003.parquet",
    ] {
        assert!(state.join(kept).is_file(), "{kept}");
    }
}
