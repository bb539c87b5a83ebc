//! `sonarproj sweep` and `merge` from the outside: results do not depend on the chunk size, on
//! interruption and resumption, or on sharding and merging (byte for byte); grids enumerate the
//! poses they describe; bad sweep files and mismatched re-runs are refused naming the key.

use sonarproj_testkit as common;

use std::path::{Path, PathBuf};

/// A 2-D grid (place range × roll, 9 × 61 = 549 poses) of an FLS feature in an SSS.
const GRID_2D: &str = r#"
from = "paper-fls"
to = "paper-sss"
step = 0.5
[feature]
range = 5
azimuth = 3
[place]
range = { start = 2, stop = 18, step = 2 }
[rotation]
roll = { start = 0, stop = 180, step = 3 }
pitch = 10
"#;

/// A 1-D grid (yaw, 46 poses) of an SSS feature in an FLS.
const GRID_1D: &str = r#"
from = "paper-sss"
to = "paper-fls"
step = 1
[feature]
range = 5
[place]
range = 5
[rotation]
yaw = { start = 0, stop = 180, step = 4 }
"#;

/// Writes `text` as `name` in `dir` and returns its path.
fn file(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `sweep` with `args` and returns the bytes of the result file `name` in `out`.
fn sweep(config: &Path, out: &Path, args: &[&str], name: &str) -> Vec<u8> {
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(config)
        .arg("--out")
        .arg(out)
        .args(args)
        .assert()
        .success();
    std::fs::read(out.join(name)).unwrap_or_else(|e| panic!("{name} in {}: {e}", out.display()))
}

#[test]
fn a_grid_lists_every_combination_with_the_last_axis_fastest() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "s.toml", GRID_2D);
    let csv = sweep(&cfg, &dir.path().join("o"), &["--backend", "cpu"], "sweep.csv");
    let mut rdr = csv::Reader::from_reader(csv.as_slice());
    let h = rdr.headers().unwrap().clone();
    let col = |n: &str| h.iter().position(|c| c == n).unwrap();
    let rows: Vec<csv::StringRecord> = rdr.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 9 * 61);
    for (i, r) in rows.iter().enumerate() {
        let num = |n: &str| r[col(n)].parse::<f64>().unwrap();
        assert_eq!(r[col("index")], i.to_string());
        assert_eq!(num("place_range"), 2.0 + 2.0 * (i / 61) as f64);
        assert_eq!(num("roll"), 3.0 * (i % 61) as f64);
        assert_eq!(
            (num("pitch"), num("yaw"), num("range"), num("azimuth")),
            (10.0, 0.0, 5.0, 3.0)
        );
        // paper-fls's 12° elevation aperture at 0.5°: round(24) = 24 is even, so 25 samples.
        assert_eq!(num("total"), 25.0);
    }
}

#[test]
fn results_do_not_depend_on_the_chunk_size() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "s.toml", GRID_2D);
    for backend in common::cli_backends("cpu-fast") {
        let whole = sweep(
            &cfg,
            &dir.path().join(format!("{backend}-all")),
            &["--backend", backend],
            "sweep.csv",
        );
        for chunk in ["1", "7", "100"] {
            let out = dir.path().join(format!("{backend}-{chunk}"));
            let part = sweep(
                &cfg,
                &out,
                &["--backend", backend, "--chunk-poses", chunk],
                "sweep.csv",
            );
            assert!(whole == part, "{backend}: chunk size {chunk} changed sweep.csv");
            assert!(!out.join(".partial-sweep").exists(), "state left behind");
        }
    }
}

#[test]
fn an_interrupted_sweep_resumes_to_the_same_files() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "s.toml", GRID_2D);
    let one = dir.path().join("one");
    let csv = sweep(
        &cfg,
        &one,
        &["--backend", "cpu-fast", "--chunk-poses", "50"],
        "sweep.csv",
    );
    let png = std::fs::read(one.join("sweep-span.png")).unwrap();

    // Stopped after some chunks, then re-run twice with the same command.
    let out = dir.path().join("resumed");
    let args = ["--backend", "cpu-fast", "--chunk-poses", "50"];
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .args(args)
        .args(["--max-chunks", "3"])
        .assert()
        .success()
        .stdout(predicates::str::contains("150 of 549 poses done"));
    assert!(!out.join("sweep.csv").exists());
    let chunks = std::fs::read_dir(out.join(".partial-sweep")).unwrap().count();
    assert_eq!(
        chunks,
        3 * 2 + 2,
        "three chunks, their records, the manifest and the lock"
    );
    // A different chunk size cannot resume this run.
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .args(["--backend", "cpu-fast", "--chunk-poses", "60"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--chunk-poses = 60"));
    let out_text = common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .args(args)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    assert!(
        String::from_utf8_lossy(&out_text).contains("399 computed"),
        "{}",
        String::from_utf8_lossy(&out_text)
    );
    assert!(std::fs::read(out.join("sweep.csv")).unwrap() == csv);
    assert!(std::fs::read(out.join("sweep-span.png")).unwrap() == png);
    assert!(!out.join(".partial-sweep").exists());
}

#[test]
fn a_killed_sweep_resumes_to_the_same_file() {
    let dir = tempfile::tempdir().unwrap();
    // 121 × 121 sss→fls poses at a fine step in 367 chunks: killed part-way, twice.
    let cfg = file(
        dir.path(),
        "s.toml",
        &GRID_1D
            .replace("step = 1", "step = 0.1")
            .replace(
                "[rotation]",
                "[rotation]\nroll = { start = 0, stop = 180, step = 1.5 }",
            )
            .replace("step = 4", "step = 1.5"),
    );
    let whole = sweep(
        &cfg,
        &dir.path().join("whole"),
        &["--backend", "cpu-fast"],
        "sweep.csv",
    );
    let out = dir.path().join("killed");
    let bin = assert_cmd::cargo::cargo_bin("sonarproj");
    let state = out.join(".partial-sweep");
    let chunks = || std::fs::read_dir(&state).map_or(0, |d| d.count());
    for at_least in [3, 10] {
        let mut child = std::process::Command::new(&bin)
            .current_dir(common::repository())
            .env("NODEVICE_SELECT", "1")
            .args([
                "sweep",
                "--backend",
                "cpu-fast",
                "--chunk-poses",
                "40",
                "--config",
            ])
            .arg(&cfg)
            .arg("--out")
            .arg(&out)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        while chunks() < at_least && child.try_wait().unwrap().is_none() {
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        let _ = child.kill();
        child.wait().unwrap();
        assert!(
            !out.join("sweep.csv").exists(),
            "finished before it could be killed"
        );
    }
    let resumed = sweep(
        &cfg,
        &out,
        &["--backend", "cpu-fast", "--chunk-poses", "40"],
        "sweep.csv",
    );
    assert!(whole == resumed, "resumed sweep differs from one run");
}

#[test]
fn shards_merge_into_the_file_one_run_writes() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text, png) in [
        ("2d", GRID_2D, "sweep-span.png"),
        ("1d", GRID_1D, "sweep-projection_area.png"),
    ] {
        let cfg = file(dir.path(), &format!("{name}.toml"), text);
        let one = dir.path().join(format!("{name}-one"));
        let csv = sweep(&cfg, &one, &["--backend", "cpu-fast"], "sweep.csv");
        let fig = std::fs::read(one.join(png)).unwrap();
        let out = dir.path().join(format!("{name}-sharded"));
        for k in [3, 1, 4, 2] {
            let shard = format!("{k}/4");
            sweep(
                &cfg,
                &out,
                &["--backend", "cpu-fast", "--shard", &shard, "--chunk-poses", "9"],
                &format!("shard-{k}-of-4.csv"),
            );
            if k != 2 {
                // Not all parts yet.
                common::sonarproj()
                    .arg("merge")
                    .arg(&out)
                    .assert()
                    .code(2)
                    .stderr(predicates::str::contains("lacks shards"));
            }
        }
        common::sonarproj().arg("merge").arg(&out).assert().success();
        assert!(
            std::fs::read(out.join("sweep.csv")).unwrap() == csv,
            "{name}: merged CSV differs"
        );
        assert!(
            std::fs::read(out.join(png)).unwrap() == fig,
            "{name}: merged figure differs"
        );
    }
}

#[test]
fn a_pose_list_gives_the_same_metrics_as_batch() {
    let dir = tempfile::tempdir().unwrap();
    let poses =
        "range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n5,2,1,10,20,30,1,2,0.5\n4,-3,0,90,0,0,0,0,0\n";
    file(dir.path(), "poses.csv", poses);
    let cfg = file(
        dir.path(),
        "s.toml",
        "from = \"paper-fls\"\nto = \"paper-sss\"\nstep = 0.1\nposes = \"poses.csv\"\n",
    );
    let csv = sweep(&cfg, &dir.path().join("o"), &["--backend", "cpu"], "sweep.csv");
    let batch = common::sonarproj()
        .args([
            "batch",
            "--from",
            "paper-fls",
            "--to",
            "paper-sss",
            "--step",
            "0.1",
            "--backend",
            "cpu",
        ])
        .write_stdin(poses)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    // The sweep's rows are the batch rows with the index in front.
    let sweep_text = String::from_utf8(csv).unwrap();
    let batch_text = String::from_utf8(batch).unwrap();
    for (i, (s, b)) in sweep_text.lines().zip(batch_text.lines()).enumerate() {
        let want = if i == 0 {
            format!("index,{b}")
        } else {
            format!("{},{b}", i - 1)
        };
        assert_eq!(s, want);
    }
    assert_eq!(sweep_text.lines().count(), 3);
    assert!(
        !dir.path().join("o/sweep-span.png").exists(),
        "a list has no figure"
    );
}

#[test]
fn bad_sweep_files_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (GRID_2D.replace("roll =", "rol ="), "rotation.rol"),
        (GRID_2D.replace("pitch = 10", "pitch = \"ten\""), "rotation.pitch"),
        (GRID_2D.replace("step = 3 }", "step = -3 }"), "rotation.roll.step"),
        (GRID_2D.replace("stop = 18", "stop = -18"), "place.range.stop"),
        (GRID_2D.replace("range = 5", "range = 50"), "feature.range"),
        (
            GRID_2D.replace("azimuth = 3", "azimuth = [3, 80]"),
            "feature.azimuth",
        ),
        (
            GRID_2D.replace("[feature]\nrange = 5\n", "[feature]\n"),
            "feature.range",
        ),
        (GRID_2D.replace("paper-sss", "no-such-sonar"), "no-such-sonar"),
        (GRID_2D.replace("step = 0.5", "step = 0"), "step"),
        (format!("metric = \"area\"\n{GRID_2D}"), "metric"),
        (format!("{GRID_2D}[translation]\nx = 1\n"), "translation"),
        (format!("poses = \"p.csv\"\n{GRID_2D}"), "feature"),
        (GRID_2D.replace("[rotation]", "[rotation"), "s.toml"),
    ];
    for (text, key) in cases {
        let cfg = file(dir.path(), "s.toml", &text);
        let out = dir.path().join("never");
        let assert = common::sonarproj()
            .args(["sweep", "--backend", "cpu", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&out)
            .assert()
            .code(2);
        let err = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
        assert!(err.contains(key), "expected {key:?} in: {err}");
        assert!(!out.exists(), "output directory created for a bad file");
    }
    common::sonarproj()
        .args(["sweep", "--shard", "5/4", "--config"])
        .arg(file(dir.path(), "ok.toml", GRID_1D))
        .args(["--out", "x"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--shard"));
}

#[test]
fn more_chunks_than_a_run_keeps_are_refused_up_front() {
    // 10^12 poses a chunk each once asked for 16 TB of bookkeeping (an abort); the run is
    // refused before anything is made, saying which --chunk-poses would do.
    let dir = tempfile::tempdir().unwrap();
    let huge = GRID_2D
        .replace("range = { start = 2, stop = 18, step = 2 }", "range = 15")
        .replace(
            "roll = { start = 0, stop = 180, step = 3 }",
            "roll = { start = 0, stop = 99.9999, step = 0.0001 }",
        )
        .replace(
            "pitch = 10",
            "pitch = { start = 0, stop = 99.9999, step = 0.0001 }",
        );
    let config = file(dir.path(), "huge.toml", &huge);
    let out = dir.path().join("o");
    common::rejects(
        &[
            "sweep",
            "--config",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--backend",
            "cpu-fast",
            "--chunk-poses",
            "1",
        ],
        None,
        &[
            "--chunk-poses = 1",
            "1000000000000 chunk files",
            "--chunk-poses 1000000 or more",
        ],
    );
    assert!(!out.exists(), "a refused run made its directory");
}

#[test]
fn a_directory_of_another_sweep_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    sweep(
        &file(dir.path(), "a.toml", GRID_1D),
        &out,
        &["--backend", "cpu-fast"],
        "sweep.csv",
    );
    common::sonarproj()
        .args(["sweep", "--backend", "cpu-fast", "--config"])
        .arg(file(dir.path(), "b.toml", GRID_2D))
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("different sweep"));
}

/// Returns the stderr of a successful `sweep` run with `args`.
fn sweep_stderr(config: &Path, out: &Path, args: &[&str]) -> String {
    let output = common::sonarproj()
        .args(["sweep", "--config"])
        .arg(config)
        .arg("--out")
        .arg(out)
        .args(args)
        .output()
        .unwrap();
    assert!(output.status.success(), "{output:?}");
    String::from_utf8(output.stderr).unwrap()
}

#[test]
fn damaged_chunks_and_results_are_computed_again() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "2d.toml", GRID_2D);
    let reference = sweep(
        &cfg,
        &dir.path().join("one"),
        &["--backend", "cpu-fast"],
        "sweep.csv",
    );
    let out = dir.path().join("o");
    let args = ["--backend", "cpu-fast", "--chunk-poses", "100"];
    let partial = |args: &[&str]| {
        common::sonarproj()
            .args(["sweep", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&out)
            .args(args)
            .args(["--max-chunks", "4"])
            .assert()
            .success();
    };
    partial(&args);
    let chunk = |c: usize| out.join(format!(".partial-sweep/chunk-{c:08}.csv"));
    // Chunk 0 truncated (a row missing), chunk 1 copied over by chunk 2 (another index range, same
    // length), chunk 3 with its record copied from chunk 2 too (a whole part moved).
    let text = std::fs::read_to_string(chunk(0)).unwrap();
    let cut = text.trim_end().rfind('\n').unwrap() + 1;
    std::fs::write(chunk(0), &text[..cut]).unwrap();
    std::fs::copy(chunk(2), chunk(1)).unwrap();
    std::fs::copy(chunk(2), chunk(3)).unwrap();
    std::fs::copy(
        chunk(2).with_extension("meta.json"),
        chunk(3).with_extension("meta.json"),
    )
    .unwrap();
    let stderr = sweep_stderr(&cfg, &out, &args);
    for c in [0, 1, 3] {
        let name = format!("chunk-{c:08}.csv is damaged");
        assert!(stderr.contains(&name), "chunk {c} not redone: {stderr}");
    }
    assert!(
        !stderr.contains("chunk-00000002.csv"),
        "a good chunk was redone: {stderr}"
    );
    assert!(std::fs::read(out.join("sweep.csv")).unwrap() == reference);

    // A damaged result is computed again, not taken as finished.
    let mut damaged = reference.clone();
    let at = damaged.len() / 2;
    damaged[at] = if damaged[at] == b'1' { b'2' } else { b'1' };
    std::fs::write(out.join("sweep.csv"), &damaged).unwrap();
    let stderr = sweep_stderr(&cfg, &out, &args);
    assert!(stderr.contains("sweep.csv is damaged"), "{stderr}");
    assert!(std::fs::read(out.join("sweep.csv")).unwrap() == reference);
}

#[test]
fn merge_refuses_foreign_or_damaged_shards_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "2d.toml", GRID_2D);
    let other = file(dir.path(), "1d.toml", GRID_1D);
    let (out, foreign) = (dir.path().join("o"), dir.path().join("f"));
    for k in 1..=3 {
        let shard = format!("{k}/3");
        let args = ["--backend", "cpu-fast", "--shard", shard.as_str()];
        sweep(&cfg, &out, &args, &format!("shard-{k}-of-3.csv"));
        sweep(&other, &foreign, &args, &format!("shard-{k}-of-3.csv"));
    }
    let shard = |dir: &Path, k: u64, ext: &str| dir.join(format!("shard-{k}-of-3.{ext}"));
    let keep = dir.path().join("keep");
    std::fs::create_dir(&keep).unwrap();
    for k in 1..=3 {
        for ext in ["csv", "meta.json"] {
            std::fs::copy(shard(&out, k, ext), shard(&keep, k, ext)).unwrap();
        }
    }
    let restore = || {
        for k in 1..=3 {
            for ext in ["csv", "meta.json"] {
                std::fs::copy(shard(&keep, k, ext), shard(&out, k, ext)).unwrap();
            }
        }
    };
    let refused = |what: &str, expect: &str| {
        common::sonarproj()
            .arg("merge")
            .arg(&out)
            .assert()
            .code(2)
            .stderr(predicates::str::contains("shard-2-of-3.csv").and(predicates::str::contains(expect)));
        assert!(!out.join("sweep.csv").exists(), "{what}: merge wrote sweep.csv");
        restore();
    };
    use predicates::prelude::*;
    // Another sweep's shard, with its record.
    std::fs::copy(shard(&foreign, 2, "csv"), shard(&out, 2, "csv")).unwrap();
    std::fs::copy(shard(&foreign, 2, "meta.json"), shard(&out, 2, "meta.json")).unwrap();
    refused("foreign shard", "another sweep");
    // Shard 1 copied over shard 2 (duplicate and missing indices), with and without its record.
    std::fs::copy(shard(&out, 1, "csv"), shard(&out, 2, "csv")).unwrap();
    refused("copied csv", "record says");
    std::fs::copy(shard(&out, 1, "csv"), shard(&out, 2, "csv")).unwrap();
    std::fs::copy(shard(&out, 1, "meta.json"), shard(&out, 2, "meta.json")).unwrap();
    refused("copied shard", "where poses");
    // One byte changed, length kept.
    let mut bytes = std::fs::read(shard(&out, 2, "csv")).unwrap();
    let at = bytes.len() - 3;
    bytes[at] = if bytes[at] == b'1' { b'2' } else { b'1' };
    std::fs::write(shard(&out, 2, "csv"), bytes).unwrap();
    refused("changed byte", "checksum");
    // A shard written before records existed (or whose record was lost).
    std::fs::remove_file(shard(&out, 2, "meta.json")).unwrap();
    refused("no record", "missing");
    // Whole again: merges.
    common::sonarproj().arg("merge").arg(&out).assert().success();
}

#[test]
fn merge_refuses_shards_computed_with_different_settings() {
    use predicates::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "2d.toml", GRID_2D);
    let out = dir.path().join("o");
    sweep(
        &cfg,
        &out,
        &["--backend", "cpu", "--shard", "1/2"],
        "shard-1-of-2.csv",
    );
    sweep(
        &cfg,
        &out,
        &["--backend", "cpu-fast", "--shard", "2/2"],
        "shard-2-of-2.csv",
    );
    common::sonarproj()
        .arg("merge")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(
            predicates::str::contains("backend")
                .and(predicates::str::contains("\"cpu-fast\" in shard 2 of 2"))
                .and(predicates::str::contains("\"cpu\" in shard 1")),
        );
    assert!(!out.join("sweep.csv").exists(), "merge wrote sweep.csv");
    // A finished shard is not passed off as another backend's: re-running it so is refused.
    common::sonarproj()
        .args(["sweep", "--backend", "cpu", "--shard", "2/2", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(
            predicates::str::contains("--backend").and(predicates::str::contains(
                "was finished with backend \"cpu-fast\"",
            )),
        );
    // Shard 2 recomputed on the same backend as shard 1 (its file removed first): merges into
    // the file one run writes.
    std::fs::remove_file(out.join("shard-2-of-2.csv")).unwrap();
    sweep(
        &cfg,
        &out,
        &["--backend", "cpu", "--shard", "2/2"],
        "shard-2-of-2.csv",
    );
    common::sonarproj().arg("merge").arg(&out).assert().success();
    let one = dir.path().join("one");
    let whole = sweep(&cfg, &one, &["--backend", "cpu"], "sweep.csv");
    assert!(std::fs::read(out.join("sweep.csv")).unwrap() == whole);
    // A shard without its record of settings is refused, naming it.
    std::fs::remove_file(out.join("sweep.csv")).unwrap();
    std::fs::remove_file(out.join("shard-2-of-2.run.json")).unwrap();
    common::sonarproj()
        .arg("merge")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("shard-2-of-2.run.json"));
    assert!(!out.join("sweep.csv").exists());
    // Re-running that shard says what to do instead of pretending it is whole.
    common::sonarproj()
        .args(["sweep", "--backend", "cpu", "--shard", "2/2", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(
            predicates::str::contains("no record of how it was computed")
                .and(predicates::str::contains("remove it")),
        );
}

/// Returns the cells of CSV `text` (header, then rows) as numbers, `None` for an empty cell.
fn csv_cells(text: &[u8]) -> (Vec<String>, Vec<Vec<Option<f64>>>) {
    let mut rdr = csv::Reader::from_reader(text);
    let header = rdr.headers().unwrap().iter().map(ToString::to_string).collect();
    let rows = rdr
        .records()
        .map(|r| {
            r.unwrap()
                .iter()
                .map(|c| (!c.is_empty()).then(|| c.parse::<f64>().unwrap()))
                .collect()
        })
        .collect();
    (header, rows)
}

/// Returns the rows of the Parquet file `path` (columns `names`) as numbers, `None` for null.
fn parquet_cells(path: &Path, names: &[String]) -> Vec<Vec<Option<f64>>> {
    use sonarproj_apps::io::parquet::read_groups;
    let kinds = sonarproj_apps::sweep::run::column_kinds(names);
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

#[test]
fn a_parquet_sweep_resumes_redoes_damaged_chunks_and_keeps_its_format() {
    use predicates::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "2d.toml", GRID_2D);
    let reference = sweep(
        &cfg,
        &dir.path().join("one"),
        &["--backend", "cpu-fast", "--format", "parquet"],
        "sweep.parquet",
    );
    let out = dir.path().join("o");
    let args = [
        "--backend",
        "cpu-fast",
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
    // Resuming as CSV is refused naming --format; the unfinished run is kept.
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .args(["--backend", "cpu-fast", "--chunk-poses", "100"])
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
    assert!(stderr.contains("chunk-00000001.parquet is damaged"), "{stderr}");
    assert!(!stderr.contains("chunk-00000000.parquet"), "{stderr}");
    assert!(std::fs::read(out.join("sweep.parquet")).unwrap() == reference);

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

/// GRID_2D with a `[summary]` table (`rows` as given).
fn grid_with_summary(rows: bool) -> String {
    format!(
        "{GRID_2D}[summary]\ntop = 4\nhistogram = {{ min = 0, max = 0.2, bins = 8 }}\nmarginals = [\"roll\", [\"place_range\", \"roll\"]]\nrows = {rows}\n"
    )
}

#[test]
fn summaries_are_the_tables_reduced_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "s.toml", &grid_with_summary(true));
    let out = dir.path().join("o");
    let csv = sweep(&cfg, &out, &["--backend", "cpu-fast"], "sweep.csv");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    // The reductions computed here from the table, by plain loops.
    let (header, rows) = csv_cells(&csv);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (span, roll, place) = (col("span"), col("roll"), col("place_range"));
    let values: Vec<(u64, f64)> = rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r[span].map(|v| (i as u64, v)))
        .collect();
    assert_eq!(summary["poses"], 549);
    assert_eq!(summary["with_value"], values.len());
    let mut sorted = values.clone();
    sorted.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    let ranked = |v: &serde_json::Value| (v["index"].as_u64().unwrap(), v["value"].as_f64().unwrap());
    assert_eq!(ranked(&summary["min"]), sorted[0]);
    let smallest: Vec<_> = summary["smallest"]
        .as_array()
        .unwrap()
        .iter()
        .map(ranked)
        .collect();
    assert_eq!(smallest, sorted[..4]);
    sorted.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    assert_eq!(ranked(&summary["max"]), sorted[0]);
    let largest: Vec<_> = summary["largest"]
        .as_array()
        .unwrap()
        .iter()
        .map(ranked)
        .collect();
    assert_eq!(largest, sorted[..4]);
    // Histogram: bins of 0.025 m from 0, the lower edge in, the last bin closed.
    let mut counts = [0u64; 8];
    let (mut below, mut above) = (0, 0);
    for &(_, v) in &values {
        if v < 0.0 {
            below += 1;
        } else if v > 0.2 {
            above += 1;
        } else {
            let edges: Vec<f64> = (0..=8).map(|k| 0.2 * (f64::from(k) / 8.0)).collect();
            let k = (0..8).rev().find(|&k| v >= edges[k]).unwrap();
            counts[k] += 1;
        }
    }
    let h = &summary["histogram"];
    assert_eq!(
        h["counts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_u64().unwrap())
            .collect::<Vec<_>>(),
        counts
    );
    assert_eq!(
        (h["below"].as_u64().unwrap(), h["above"].as_u64().unwrap()),
        (below, above)
    );
    // Marginal over roll: 9 place ranges per roll; min, mean, max by hand (the mean within the
    // fixed point's 2^-40).
    let m = &summary["marginals"][0];
    let rolls: Vec<f64> = m["values"][0]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(rolls.len(), 61);
    for (c, &r) in rolls.iter().enumerate() {
        let cell: Vec<f64> = rows
            .iter()
            .filter(|row| row[roll] == Some(r))
            .filter_map(|row| row[span])
            .collect();
        assert_eq!(m["count"][c].as_u64().unwrap(), cell.len() as u64);
        let min = cell.iter().copied().fold(f64::INFINITY, f64::min);
        let max = cell.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mean = cell.iter().sum::<f64>() / cell.len() as f64;
        assert_eq!(m["min"][c].as_f64().unwrap(), min, "roll {r}");
        assert_eq!(m["max"][c].as_f64().unwrap(), max, "roll {r}");
        assert!((m["mean"][c].as_f64().unwrap() - mean).abs() < 1e-11, "roll {r}");
    }
    // The 2-D marginal over the grid's two varying axes: each cell is one pose, its row.
    let m2 = &summary["marginals"][1];
    for row in &rows {
        let p = m2["values"][0]
            .as_array()
            .unwrap()
            .iter()
            .position(|v| v.as_f64() == row[place])
            .unwrap();
        let r = rolls.iter().position(|&v| Some(v) == row[roll]).unwrap();
        let c = p * 61 + r;
        assert_eq!(m2["min"][c].as_f64(), row[span]);
        assert!((m2["mean"][c].as_f64().unwrap() - row[span].unwrap()).abs() <= 2f64.powi(-41));
    }
}

#[test]
fn summaries_alone_are_the_same_however_the_run_is_cut() {
    use predicates::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let with_rows = file(dir.path(), "rows.toml", &grid_with_summary(true));
    let alone = file(dir.path(), "alone.toml", &grid_with_summary(false));
    let one = dir.path().join("one");
    sweep(&with_rows, &one, &["--backend", "cpu-fast"], "sweep.csv");
    let summary = std::fs::read(one.join("summary.json")).unwrap();
    let figure = std::fs::read(one.join("sweep-span.png")).unwrap();
    // No rows: no table, the same summaries, the figure from the 2-D marginal.
    let small = dir.path().join("small");
    assert!(
        sweep(
            &alone,
            &small,
            &["--backend", "cpu-fast", "--chunk-poses", "13"],
            "summary.json"
        ) == summary
    );
    assert!(!small.join("sweep.csv").exists() && !small.join("sweep.parquet").exists());
    assert!(std::fs::read(small.join("sweep-span.png")).unwrap() == figure);
    // Interrupted and resumed.
    let resumed = dir.path().join("resumed");
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&alone)
        .arg("--out")
        .arg(&resumed)
        .args([
            "--backend",
            "cpu-fast",
            "--chunk-poses",
            "100",
            "--max-chunks",
            "2",
        ])
        .assert()
        .success();
    assert!(!resumed.join("summary.json").exists());
    assert!(
        sweep(
            &alone,
            &resumed,
            &["--backend", "cpu-fast", "--chunk-poses", "100"],
            "summary.json"
        ) == summary
    );
    // Shards merged.
    let sharded = dir.path().join("sharded");
    for k in [3, 1, 2] {
        let shard = format!("{k}/3");
        sweep(
            &alone,
            &sharded,
            &["--backend", "cpu-fast", "--shard", &shard, "--chunk-poses", "50"],
            &format!("shard-{k}-of-3.summary.json"),
        );
    }
    common::sonarproj().arg("merge").arg(&sharded).assert().success();
    assert!(std::fs::read(sharded.join("summary.json")).unwrap() == summary);
    assert!(std::fs::read(sharded.join("sweep-span.png")).unwrap() == figure);
    // A bad [summary] key is bad input, named.
    let bad = file(
        dir.path(),
        "bad.toml",
        &format!("{GRID_2D}[summary]\nmarginals = [\"heading\"]\n"),
    );
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&bad)
        .arg("--out")
        .arg(dir.path().join("bad"))
        .assert()
        .code(2)
        .stderr(
            predicates::str::contains("summary.marginals").and(predicates::str::contains("not a grid axis")),
        );
}

#[test]
fn summaries_refuse_what_does_not_hold_together() {
    use predicates::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let alone = file(dir.path(), "alone.toml", &grid_with_summary(false));
    // Shards merged under a sweep.json whose [summary] was edited (top 4 -> 6): refused naming
    // the shard, nothing written.
    let out = dir.path().join("edited");
    for k in 1..=2 {
        let shard = format!("{k}/2");
        sweep(
            &alone,
            &out,
            &["--backend", "cpu-fast", "--shard", &shard],
            &format!("shard-{k}-of-2.summary.json"),
        );
    }
    let desc = out.join("sweep.json");
    let text = std::fs::read_to_string(&desc).unwrap();
    assert!(text.contains("\"top\": 4"));
    std::fs::write(&desc, text.replace("\"top\": 4", "\"top\": 6")).unwrap();
    common::sonarproj()
        .arg("merge")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(
            predicates::str::contains("shard-1-of-2.summary.json").and(predicates::str::contains("top = 6")),
        );
    assert!(!out.join("summary.json").exists());
    // A shard's summary missing: named.
    std::fs::write(&desc, text).unwrap();
    std::fs::remove_file(out.join("shard-2-of-2.summary.json")).unwrap();
    common::sonarproj()
        .arg("merge")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("lacks shards [2]"));
    // A histogram whose width overflows is bad input before anything runs.
    let wide = file(
        dir.path(),
        "wide.toml",
        &format!("{GRID_2D}[summary]\nhistogram = {{ min = -1e308, max = 1e308, bins = 2 }}\n"),
    );
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&wide)
        .arg("--out")
        .arg(dir.path().join("wide"))
        .assert()
        .code(2)
        .stderr(
            predicates::str::contains("summary.histogram").and(predicates::str::contains("non-zero width")),
        );
    // summary.json taken by a directory: refused before the table is written.
    let rows = file(dir.path(), "rows.toml", &grid_with_summary(true));
    let taken = dir.path().join("taken");
    std::fs::create_dir_all(taken.join("summary.json")).unwrap();
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&rows)
        .arg("--out")
        .arg(&taken)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("summary.json"));
    assert!(!taken.join("sweep.csv").exists());
}

#[cfg(unix)]
#[test]
fn a_table_written_into_a_device_draws_no_figure_and_does_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "2d.toml", GRID_2D);
    let out = dir.path().join("o");
    std::fs::create_dir(&out).unwrap();
    std::os::unix::fs::symlink("/dev/null", out.join("sweep.csv")).unwrap();
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .args(["--backend", "cpu-fast"])
        .assert()
        .success();
    assert!(!out.join("sweep-span.png").exists());
}

/// A second run into the state of a run still working (here: its lock held by `flock(1)`)
/// stops at once, exit 1, saying so, and leaves the state as it was.
#[cfg(unix)]
#[test]
fn a_second_run_into_a_working_state_stops_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "2d.toml", GRID_2D);
    let out = dir.path().join("o");
    let state = out.join(".partial-shard-1-of-2");
    std::fs::create_dir_all(&state).unwrap();
    let bin = assert_cmd::cargo::cargo_bin("sonarproj");
    let status = std::process::Command::new("flock")
        .arg(state.join("lock"))
        .arg(&bin)
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .args(["--backend", "cpu-fast", "--shard", "1/2"])
        .env("NODEVICE_SELECT", "1")
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("flock(1) from util-linux");
    assert_eq!(status.status.code(), Some(1), "{status:?}");
    let stderr = String::from_utf8_lossy(&status.stderr);
    assert!(stderr.contains("another run of this sweep"), "{stderr}");
    assert!(!out.join("shard-1-of-2.csv").exists());
    // With the lock free, the same command runs.
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .args(["--backend", "cpu-fast", "--shard", "1/2"])
        .assert()
        .success()
        .stdout(predicates::str::contains("shard-1-of-2.csv"));
}
