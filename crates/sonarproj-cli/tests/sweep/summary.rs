//! A sweep file's `[summary]`: the table's reductions, the same bytes however the run is cut,
//! and what does not hold together refused.

use super::*;

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

/// A sweep of summaries alone fills only the metric it reduces (`MetricColumns::only`: the GPU
/// unpacks that one alone); its summaries are those of the same backend's Parquet sweep, whose
/// blocks fill every column, for a real, a count and an extreme.
#[test]
fn summaries_alone_are_those_of_the_rows_on_every_backend() {
    let dir = tempfile::tempdir().unwrap();
    for backend in common::cli_backends("cpu-fast") {
        for by in ["span", "occupied", "azimuth_max"] {
            let config = |rows: bool| {
                grid_with_summary(rows).replace("[summary]\n", &format!("[summary]\nby = \"{by}\"\n"))
            };
            let with_rows = file(dir.path(), &format!("{backend}-{by}-rows.toml"), &config(true));
            let alone = file(dir.path(), &format!("{backend}-{by}-alone.toml"), &config(false));
            let (a, b) = (
                dir.path().join(format!("{backend}-{by}-a")),
                dir.path().join(format!("{backend}-{by}-b")),
            );
            let args = ["--backend", backend, "--format", "parquet"];
            sweep(&with_rows, &a, &args, "sweep.parquet");
            let want = std::fs::read(a.join("summary.json")).unwrap();
            assert!(String::from_utf8_lossy(&want).contains(&format!("\"metric\": \"{by}\"")));
            let got = sweep(&alone, &b, &args[..2], "summary.json");
            assert!(
                got == want,
                "{backend}, by {by}: summaries alone differ from the rows'"
            );
        }
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
    // Resumed without --chunk-poses: the unfinished run's size is kept (the default for
    // summaries only, DEFAULT_SUMMARY_CHUNK_POSES, would be refused as another setting).
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(resumed.join(".partial-sweep/manifest.json")).unwrap())
            .unwrap();
    assert_eq!(manifest["chunk_poses"], 100);
    let out = common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&alone)
        .arg("--out")
        .arg(&resumed)
        .args(["--backend", "cpu-fast"])
        .assert()
        .success();
    let stdout = String::from_utf8_lossy(&out.get_output().stdout).into_owned();
    assert!(stdout.contains("200 from earlier runs"), "{stdout}");
    assert!(std::fs::read(resumed.join("summary.json")).unwrap() == summary);
    // A fresh summaries-only run takes chunks of DEFAULT_SUMMARY_CHUNK_POSES.
    let fresh = dir.path().join("fresh");
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&alone)
        .arg("--out")
        .arg(&fresh)
        .args(["--backend", "cpu-fast", "--max-chunks", "0"])
        .assert()
        .success();
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(fresh.join(".partial-sweep/manifest.json")).unwrap()).unwrap();
    assert_eq!(
        manifest["chunk_poses"],
        sonarproj_apps::sweep::DEFAULT_SUMMARY_CHUNK_POSES
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

/// A table written into a FIFO is not read back when the sweep runs again (opening it to check
/// its bytes would wait for a writer forever): each run writes it through anew.
#[test]
fn a_table_written_into_a_fifo_is_written_again_not_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(dir.path(), "1d.toml", GRID_1D);
    let out = dir.path().join("o");
    std::fs::create_dir(&out).unwrap();
    let fifo = out.join("sweep.csv");
    common::mkfifo(&fifo);
    for run in 1..=2 {
        let reader = common::read_fifo(&fifo);
        common::sonarproj()
            .args(["sweep", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&out)
            .args(["--backend", "cpu-fast"])
            .timeout(std::time::Duration::from_secs(60))
            .assert()
            .success();
        let text = reader.join().unwrap();
        assert_eq!(
            text.lines().count(),
            47,
            "run {run}: the header and 46 rows came through"
        );
    }
}
