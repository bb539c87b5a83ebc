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
