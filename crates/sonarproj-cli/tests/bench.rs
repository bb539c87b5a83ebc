//! `sonarproj bench` from the outside: the backends asked for, every backend on the same
//! batches, and the sweep's measures.

use sonarproj_testkit as common;

#[test]
fn bench_times_the_backends_asked_for() {
    let out = common::sonarproj()
        .args(["bench", "--runs", "1", "--backends", "cpu-fast"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    let rows: Vec<&str> = text.lines().filter(|l| l.contains(" -> ")).collect();
    assert_eq!(rows.len(), 2, "{text}");
    assert!(
        rows.iter()
            .all(|l| l.split_whitespace().nth(3) == Some("cpu-fast")),
        "{text}"
    );
    assert!(!text.contains(" 1 threads"), "{text}");
    // A GPU asked for where there is none is an error, not a silent skip.
    common::sonarproj()
        .args(["bench", "--runs", "1", "--backends", "gpu"])
        .env("WGPU_BACKEND", "none")
        .assert()
        .failure();
}

#[test]
fn bench_times_every_backend_on_the_same_batches() {
    let out = common::sonarproj()
        .args(["bench", "--runs", "1"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    for needle in [
        "samples/s",
        "poses/s",
        "cpu-fast",
        "paper-fls -> paper-sss",
        "paper-sss -> paper-fls",
    ] {
        assert!(text.contains(needle), "{needle} missing:\n{text}");
    }
    // The reference row of each batch is the 1.0x baseline (another backend may also land near
    // 1.0x by chance: only the reference rows are checked, never a timing).
    let reference_rows: Vec<&str> = text
        .lines()
        .filter(|l| l.split_whitespace().nth(3) == Some("cpu"))
        .collect();
    assert_eq!(reference_rows.len(), 2, "{text}");
    assert!(reference_rows.iter().all(|l| l.ends_with("1.0x")), "{text}");
    if let Some(g) = common::gpu() {
        // A software adapter (lavapipe in CI) is named as such in every row, a real GPU is not.
        let label = if g.context().is_software() {
            "gpu-sw "
        } else {
            "gpu "
        };
        assert!(text.lines().any(|l| l.starts_with(label)), "{text}");
        let rows = text
            .lines()
            .filter(|l| l.contains(" -> ") && l.contains(&format!(" {label}")));
        assert_eq!(rows.count(), 2, "{text}");
    }
}

/// `bench sweep` times every measure on each backend asked for, and on the GPU the summaries
/// sweep once more on the device's clock and the host's (what a lease reads to see where a
/// sweep's time goes).
#[test]
fn bench_sweep_times_each_measure_and_the_gpus_summary_sweep() {
    let backends = common::cli_backends("cpu-fast").join(",");
    let out = common::sonarproj()
        .args([
            "bench",
            "sweep",
            "--runs",
            "1",
            "--poses",
            "1000",
            "--backends",
            &backends,
        ])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    let row = |label: &str| {
        text.lines()
            .map(|l| l.split_whitespace().collect::<Vec<_>>())
            .find(|c| c.first() == Some(&label) && c.get(1).is_some_and(|p| p.parse::<u64>().is_ok()))
    };
    // The grid's smallest size: roll × pitch 100 × 100 and one yaw.
    let cpu = row("cpu-fast").unwrap_or_else(|| panic!("no cpu-fast row:\n{text}"));
    assert_eq!(cpu[1], "10000", "{text}");
    // Every column of the header, the span's projection and Parquet sweep among them.
    assert_eq!(cpu.len(), 16, "{text}");
    assert!(
        text.contains("span proj (s)") && text.contains("span pq (s)"),
        "{text}"
    );
    assert!(
        cpu.iter().filter(|c| **c == "-").count() == 3,
        "cpu: no device, wait, unpack\n{text}"
    );
    if let Some(g) = common::gpu() {
        let label = if g.context().is_software() {
            "gpu-sw"
        } else {
            "gpu"
        };
        let gpu = row(label).unwrap_or_else(|| panic!("no {label} row:\n{text}"));
        // Every measure taken: no "-" left but where the adapter has no timestamp queries.
        let device = g.device_time().is_some();
        assert_eq!(
            gpu.iter().filter(|c| **c == "-").count(),
            usize::from(!device),
            "{text}"
        );
        let note = format!("{label} summary sweep, one more timed run: device ");
        let line = text
            .lines()
            .find(|l| l.starts_with(&note))
            .unwrap_or_else(|| panic!("{text}"));
        assert!(line.contains(", wait ") && line.contains(", unpack "), "{line}");
        // The projection's timed run, split by stage, where the adapter has timestamp queries.
        let note = format!("{label} project, one more timed run: device ");
        let line = text.lines().find(|l| l.starts_with(&note));
        assert_eq!(line.is_some(), device, "{text}");
        if let Some(line) = line {
            assert!(
                line.contains("(poses ") && line.contains(", splat ") && line.contains(", reduce "),
                "{line}"
            );
        }
    } else {
        assert!(!text.contains("summary sweep, one more timed run"), "{text}");
    }
}

/// Returns an executable shell script in `dir` named `name` with body `body`: a stand-in for the
/// Python interpreter `--pyarrow` runs as `PYTHON -c SCRIPT TABLE OUT RUNS`.
fn stand_in(dir: &std::path::Path, name: &str, body: &str) -> std::path::PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let path = dir.join(name);
    std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    path
}

/// `bench sweep --pyarrow PYTHON` hands the interpreter the sweep's Parquet table and sets the
/// Parquet sweep against the projection plus the write it reports; an interpreter that cannot
/// run, fails (no pyarrow) or prints no seconds is bad input naming `--pyarrow`. (The real
/// pyarrow runs in the Python tests, where it is installed.)
#[test]
fn bench_sweep_sets_parquet_against_the_peer_writer() {
    let dir = tempfile::tempdir().unwrap();
    // Reports 0.25 s, after checking that it was handed a Parquet file and one run.
    let peer = stand_in(
        dir.path(),
        "peer",
        r#"[ "$1" = -c ] && [ "$(head -c 4 "$3")" = PAR1 ] && [ "$5" = 1 ] || exit 3
echo 0.25"#,
    );
    let args = [
        "bench",
        "sweep",
        "--backends",
        "cpu-fast",
        "--poses",
        "2000",
        "--runs",
        "1",
    ];
    let out = common::sonarproj()
        .args(args)
        .args(["--measures", "parquet", "--pyarrow"])
        .arg(&peer)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    let row: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("cpu-fast  "))
        .unwrap_or_else(|| panic!("{text}"))
        .split_whitespace()
        .collect();
    let line = text
        .lines()
        .find(|l| l.starts_with("cpu-fast parquet against pyarrow: "))
        .unwrap_or_else(|| panic!("{text}"));
    // "Q s, Rx of project P s + pyarrow's write of the same table W s", from the table's row.
    let words: Vec<&str> = line.split_whitespace().collect();
    let number = |w: &str| w.trim_end_matches(['x', ',']).parse::<f64>().unwrap();
    let (q, ratio, p, w) = (
        number(words[4]),
        number(words[6]),
        number(words[9]),
        number(words[18]),
    );
    assert_eq!((words[4], words[9]), (row[9], row[3]), "{line}\n{text}");
    assert_eq!(w, 0.25, "{line}");
    // Each figure is printed to 0.5 ms (the ratio to 0.005): the ratio lies within what those
    // roundings allow.
    let (low, high) = ((q - 5e-4) / (p + w + 1e-3), (q + 5e-4) / (p + w - 1e-3));
    assert!(low - 0.005 <= ratio && ratio <= high + 0.005, "{line}");
    // Bad interpreters, and the peer without the Parquet measure.
    let failing = stand_in(
        dir.path(),
        "no-pyarrow",
        "echo \"ModuleNotFoundError: No module named 'pyarrow'\" >&2; exit 1",
    );
    let talking = stand_in(dir.path(), "talking", "echo hello");
    let missing = dir.path().join("missing");
    for (python, why) in [
        (&missing, "cannot run it"),
        (&failing, "No module named 'pyarrow'"),
        (&talking, "it printed \"hello\""),
    ] {
        let err = common::sonarproj()
            .args(args)
            .args(["--measures", "parquet", "--pyarrow"])
            .arg(python)
            .assert()
            .code(2)
            .get_output()
            .stderr
            .clone();
        let err = String::from_utf8(err).unwrap();
        assert!(err.contains("--pyarrow") && err.contains(why), "{err}");
    }
    let err = common::sonarproj()
        .args(args)
        .args(["--measures", "summary", "--pyarrow"])
        .arg(&peer)
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    assert!(
        String::from_utf8(err)
            .unwrap()
            .contains("needs the parquet measure")
    );
}
