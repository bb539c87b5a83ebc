//! `sweep --format parquet`: the CSV's values typed, the same bytes however the run is cut,
//! resumed and merged.

use super::*;

/// Returns the rows of the Parquet file `path` (columns `names`) as numbers, `None` for null.
pub(super) fn parquet_cells(path: &Path, names: &[String]) -> Vec<Vec<Option<f64>>> {
    use sonarproj_apps::io::parquet::read_groups;
    let kinds = sonarproj_apps::sweep::column_kinds(names);
    let mut rows = Vec::new();
    for group in read_groups(path, names, &kinds).unwrap() {
        let group = group.unwrap();
        for i in 0..group.rows() {
            rows.push(group.columns.iter().map(|c| c.get(i)).collect());
        }
    }
    rows
}

#[test]
fn parquet_holds_the_csv_values_and_merges_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text, png) in [
        ("2d", GRID_2D, "sweep-span.png"),
        ("1d", GRID_1D, "sweep-projection_area.png"),
    ] {
        let cfg = file(dir.path(), &format!("{name}.toml"), text);
        let csv_dir = dir.path().join(format!("{name}-csv"));
        let csv = sweep(&cfg, &csv_dir, &["--backend", "cpu-fast"], "sweep.csv");
        let one = dir.path().join(format!("{name}-one"));
        let parquet = sweep(
            &cfg,
            &one,
            &["--backend", "cpu-fast", "--format", "parquet"],
            "sweep.parquet",
        );
        // Every cell the CSV's: the same number (integers as integers), null where it is empty.
        let (header, want) = csv_cells(&csv);
        let got = parquet_cells(&one.join("sweep.parquet"), &header);
        assert_eq!(got.len(), want.len(), "{name}: rows");
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g, w, "{name}: row {i}");
        }
        assert!(
            want.iter().any(|r| r.contains(&None)),
            "{name}: the grid should have empty cells for nulls to be tested"
        );
        // The same figure as from the CSV (drawn from the Parquet file).
        assert!(std::fs::read(one.join(png)).unwrap() == std::fs::read(csv_dir.join(png)).unwrap());
        // Small chunks, and shards merged: the same bytes.
        let small = sweep(
            &cfg,
            &dir.path().join(format!("{name}-small")),
            &[
                "--backend",
                "cpu-fast",
                "--format",
                "parquet",
                "--chunk-poses",
                "7",
            ],
            "sweep.parquet",
        );
        assert!(small == parquet, "{name}: chunk size changed the file");
        let out = dir.path().join(format!("{name}-sharded"));
        for k in [2, 3, 1] {
            let shard = format!("{k}/3");
            let args = [
                "--backend",
                "cpu-fast",
                "--format",
                "parquet",
                "--shard",
                &shard,
                "--chunk-poses",
                "9",
            ];
            sweep(&cfg, &out, &args, &format!("shard-{k}-of-3.parquet"));
            assert!(out.join(format!("shard-{k}-of-3.parquet.meta.json")).exists());
        }
        common::sonarproj().arg("merge").arg(&out).assert().success();
        assert!(
            std::fs::read(out.join("sweep.parquet")).unwrap() == parquet,
            "{name}: merged file differs"
        );
        assert!(std::fs::read(out.join(png)).unwrap() == std::fs::read(one.join(png)).unwrap());
    }
}

/// A Parquet sweep is the same bytes whatever its chunks, on every backend (the GPU's chunks
/// projected block after block with `Backend::project_blocks`).
#[test]
fn parquet_does_not_depend_on_the_chunk_size_on_any_backend() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "2d.toml", GRID_2D);
    for backend in common::cli_backends("cpu-fast") {
        let args = |chunk: &'static str| {
            [
                "--backend",
                backend,
                "--format",
                "parquet",
                "--chunk-poses",
                chunk,
            ]
        };
        let whole = sweep(
            &cfg,
            &dir.path().join(format!("{backend}-all")),
            &args("1000"),
            "sweep.parquet",
        );
        for chunk in ["1", "7", "100"] {
            let part = sweep(
                &cfg,
                &dir.path().join(format!("{backend}-{chunk}")),
                &args(chunk),
                "sweep.parquet",
            );
            assert!(
                whole == part,
                "{backend}: chunk size {chunk} changed sweep.parquet"
            );
        }
    }
}

#[test]
fn a_parquet_sweep_resumes_redoes_damaged_chunks_and_keeps_its_format() {
    use predicates::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "2d.toml", GRID_2D);
    // On the GPU too: a resumed run's chunks are projected block after block around the ones
    // kept (`Backend::project_blocks`), the same bytes as one run.
    for backend in common::cli_backends("cpu-fast") {
        let reference = sweep(
            &cfg,
            &dir.path().join(format!("{backend}-one")),
            &["--backend", backend, "--format", "parquet"],
            "sweep.parquet",
        );
        let out = dir.path().join(format!("{backend}-o"));
        let args = [
            "--backend",
            backend,
            "--format",
            "parquet",
            "--chunk-poses",
            "100",
        ];
        common::sonarproj()
            .args(["sweep", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&out)
            .args(args)
            .args(["--max-chunks", "3"])
            .assert()
            .success();
        // Stopped: no result, and the result's temporary file (joined while the chunks were
        // computed) is gone.
        let left: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("sweep.parquet") || n.ends_with(".tmp"))
            .collect();
        assert!(left.is_empty(), "{backend}: {left:?}");
        assert!(
            out.join(".partial-sweep/chunk-00000002.parquet").exists(),
            "{backend}"
        );
        assert!(
            !out.join(".partial-sweep/chunk-00000003.parquet").exists(),
            "{backend}"
        );
        // Resuming as CSV is refused naming --format; the unfinished run is kept.
        common::sonarproj()
            .args(["sweep", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&out)
            .args(["--backend", backend, "--chunk-poses", "100"])
            .assert()
            .code(2)
            .stderr(predicates::str::contains("--format").and(predicates::str::contains("parquet")));
        // One byte of chunk 1 changed: computed again; chunks 0 and 2 kept.
        let chunk = out.join(".partial-sweep/chunk-00000001.parquet");
        let mut bytes = std::fs::read(&chunk).unwrap();
        let at = bytes.len() / 2;
        bytes[at] ^= 0x55;
        std::fs::write(&chunk, bytes).unwrap();
        let stderr = sweep_stderr(&cfg, &out, &args);
        assert!(
            stderr.contains("chunk-00000001.parquet is damaged"),
            "{backend}: {stderr}"
        );
        assert!(!stderr.contains("chunk-00000000.parquet"), "{backend}: {stderr}");
        assert!(
            std::fs::read(out.join("sweep.parquet")).unwrap() == reference,
            "{backend}: resumed file differs"
        );
    }

    // Shards in both formats are not merged.
    let mixed = dir.path().join("mixed");
    sweep(
        &cfg,
        &mixed,
        &["--backend", "cpu-fast", "--shard", "1/2"],
        "shard-1-of-2.csv",
    );
    sweep(
        &cfg,
        &mixed,
        &["--backend", "cpu-fast", "--shard", "2/2", "--format", "parquet"],
        "shard-2-of-2.parquet",
    );
    common::sonarproj()
        .arg("merge")
        .arg(&mixed)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("as CSV and as Parquet"));
}

/// A Parquet table into a FIFO is joined from the chunk files at the end, not as chunks finish,
/// so every chunk's file is kept, the last one too: what comes through the FIFO is, byte for
/// byte, the table a run into a regular file writes.
#[test]
fn a_parquet_table_into_a_fifo_holds_every_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "1d.toml", GRID_1D);
    let args = [
        "--backend",
        "cpu-fast",
        "--format",
        "parquet",
        "--chunk-poses",
        "10",
    ];
    let want = sweep(&cfg, &dir.path().join("file"), &args, "sweep.parquet");
    let out = dir.path().join("fifo");
    std::fs::create_dir(&out).unwrap();
    let fifo = out.join("sweep.parquet");
    common::mkfifo(&fifo);
    let reader = common::read_fifo_bytes(&fifo);
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .args(args)
        .timeout(std::time::Duration::from_secs(60))
        .assert()
        .success();
    let got = reader.join().unwrap();
    assert!(
        got == want,
        "{} bytes through the FIFO, {} in the file",
        got.len(),
        want.len()
    );
}
