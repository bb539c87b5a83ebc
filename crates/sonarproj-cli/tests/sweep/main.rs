//! `sonarproj sweep` and `merge` from the outside: results do not depend on the chunk size, on
//! interruption and resumption, or on sharding and merging (byte for byte); grids enumerate the
//! poses they describe; bad sweep files and mismatched re-runs are refused naming the key.
//! Parquet output is `parquet`, the `[summary]`'s reductions `summary`.

mod columns;
mod parquet;
mod summary;

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
        (format!("columns = []\n{GRID_2D}"), "columns"),
        (format!("columns = \"span\"\n{GRID_2D}"), "columns"),
        (format!("columns = [\"span\", \"spam\"]\n{GRID_2D}"), "columns[1]"),
        (format!("columns = [\"span\", 3]\n{GRID_2D}"), "columns[1]"),
        (
            format!("columns = [\"span\", \"visible\", \"span\"]\n{GRID_2D}"),
            "columns[2]",
        ),
        (format!("columns = [\"index\"]\n{GRID_2D}"), "columns[0]"),
        (format!("columns = [\"roll\"]\n{GRID_2D}"), "columns[0]"),
        (
            format!("metric = \"visible\"\ncolumns = [\"span\"]\n{GRID_2D}"),
            "metric",
        ),
        (
            format!("columns = [\"span\"]\n{GRID_2D}[summary]\nrows = false\n"),
            "columns",
        ),
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
    let rejects = |extra: &[&str], expected: &[&str]| {
        let mut args = vec![
            "sweep",
            "--config",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--backend",
            "cpu-fast",
        ];
        args.extend(extra);
        common::rejects(&args, None, expected);
    };
    rejects(
        &["--chunk-poses", "1"],
        &[
            "--chunk-poses = 1",
            "1000000000000 chunk files",
            "use chunks of 1000000 poses or more",
        ],
    );
    // Not given, the size is the default's, and the message says so.
    rejects(
        &[],
        &[
            "--chunk-poses (the default) = 131072",
            "7629395 chunk files",
            "use chunks of 1000000 poses or more",
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
