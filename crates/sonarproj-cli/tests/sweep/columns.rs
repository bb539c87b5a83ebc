//! A sweep file's `columns`: the table keeps the result columns named, each the same cells as
//! in the table of every column, in CSV and Parquet, on every backend, merged and resumed as
//! any other sweep.

use super::parquet::parquet_cells;
use super::*;

/// Returns the cells of `names` in a table of `header` and `rows`.
fn pick(header: &[String], rows: &[Vec<Option<f64>>], names: &[String]) -> Vec<Vec<Option<f64>>> {
    let at: Vec<usize> = names
        .iter()
        .map(|n| {
            header
                .iter()
                .position(|h| h == n)
                .unwrap_or_else(|| panic!("{n} in {header:?}"))
        })
        .collect();
    rows.iter().map(|r| at.iter().map(|&k| r[k]).collect()).collect()
}

/// The table's columns: the index, the pose columns, then the kept ones in the metric table's
/// order (not the file's), each cell the backend's full table's (which the agreement tests
/// hold to the reference), CSV and Parquet alike; a figure of the default metric when it is
/// kept, of the first kept metric with a label when it is not.
#[test]
fn kept_columns_are_those_of_the_full_table_on_every_backend() {
    let dir = tempfile::tempdir().unwrap();
    let full_cfg = file(dir.path(), "full.toml", GRID_2D);
    let poses = [
        "index",
        "range",
        "azimuth",
        "elevation",
        "place_range",
        "place_azimuth",
        "place_elevation",
        "roll",
        "pitch",
        "yaw",
    ];
    // Listed out of table order; the span's figure, as the full table's.
    let listed = r#"columns = ["sigma_elevation", "projection_area", "span", "azimuth_max", "visible"]"#;
    let kept = [
        "visible",
        "span",
        "azimuth_max",
        "projection_area",
        "sigma_elevation",
    ];
    let names: Vec<String> = poses.iter().chain(&kept).map(ToString::to_string).collect();
    let cfg = file(dir.path(), "kept.toml", &format!("{listed}\n{GRID_2D}"));
    // The span alone: on the fast path, drawn without the azimuths' extremes.
    let span = file(
        dir.path(),
        "span.toml",
        &format!("columns = [\"span\"]\n{GRID_2D}"),
    );
    let span_names: Vec<String> = poses.iter().chain(&["span"]).map(ToString::to_string).collect();
    for backend in common::cli_backends("cpu-fast").into_iter().chain(["cpu"]) {
        let full_dir = dir.path().join(format!("{backend}-full"));
        let (header, rows) = csv_cells(&sweep(&full_cfg, &full_dir, &["--backend", backend], "sweep.csv"));
        let want = pick(&header, &rows, &names);
        assert!(want.iter().any(|r| r.contains(&None)), "nulls to compare");
        let csv_dir = dir.path().join(format!("{backend}-csv"));
        let csv = sweep(&cfg, &csv_dir, &["--backend", backend], "sweep.csv");
        let (got_header, got) = csv_cells(&csv);
        assert_eq!(got_header, names, "{backend}: the CSV's header");
        assert_eq!(got, want, "{backend}: the CSV's cells");
        let pq_dir = dir.path().join(format!("{backend}-pq"));
        sweep(
            &cfg,
            &pq_dir,
            &["--backend", backend, "--format", "parquet"],
            "sweep.parquet",
        );
        // The full table as Parquet: a GPU's f32 results are written as CSV in their shortest
        // f32 form, as Parquet in the f64 of the f32.
        let full_pq = dir.path().join(format!("{backend}-full-pq"));
        sweep(
            &full_cfg,
            &full_pq,
            &["--backend", backend, "--format", "parquet"],
            "sweep.parquet",
        );
        let (all, want_pq) = (
            header.clone(),
            parquet_cells(&full_pq.join("sweep.parquet"), &header),
        );
        assert_eq!(
            parquet_cells(&pq_dir.join("sweep.parquet"), &names),
            pick(&all, &want_pq, &names),
            "{backend}: Parquet"
        );
        let png = std::fs::read(csv_dir.join("sweep-span.png")).unwrap();
        assert!(png == std::fs::read(full_dir.join("sweep-span.png")).unwrap());
        let out = dir.path().join(format!("{backend}-span"));
        let (got_header, got) = csv_cells(&sweep(&span, &out, &["--backend", backend], "sweep.csv"));
        assert_eq!(got_header, span_names);
        assert_eq!(
            got,
            pick(&header, &rows, &span_names),
            "{backend}: the span alone"
        );
    }
    let (header, rows) = csv_cells(&std::fs::read(dir.path().join("cpu-fast-full/sweep.csv")).unwrap());
    // No span kept: the figure draws the first kept metric with a label; a summary reduces
    // the sonar's default metric still (it needs no column).
    let visible = file(
        dir.path(),
        "visible.toml",
        &format!("columns = [\"total\", \"visible\"]\n{GRID_2D}[summary]\ntop = 2\n"),
    );
    let out = dir.path().join("visible");
    sweep(&visible, &out, &["--backend", "cpu-fast"], "sweep.csv");
    assert!(out.join("sweep-visible.png").exists());
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["metric"], "span", "{summary}");
    let spans = pick(&header, &rows, &["span".to_string()]);
    let least = spans.iter().filter_map(|r| r[0]).fold(f64::INFINITY, f64::min);
    assert_eq!(summary["min"]["value"].as_f64(), Some(least), "{summary}");
    assert!(!out.join("sweep-span.png").exists());
    // Only the local precision: no metric kept, none drawn.
    let local = file(
        dir.path(),
        "local.toml",
        &format!("columns = [\"range_per_elevation\"]\n{GRID_2D}"),
    );
    let out = dir.path().join("local");
    let (got_header, got) = csv_cells(&sweep(&local, &out, &["--backend", "cpu-fast"], "sweep.csv"));
    let names: Vec<String> = poses
        .iter()
        .chain(&["range_per_elevation"])
        .map(ToString::to_string)
        .collect();
    assert_eq!((got_header, got), (names.clone(), pick(&header, &rows, &names)));
    assert!(
        !std::fs::read_dir(&out)
            .unwrap()
            .any(|e| e.unwrap().path().extension().is_some_and(|x| x == "png"))
    );
}

/// A pose list keeps the columns named too: the batch's cells.
#[test]
fn a_pose_list_keeps_the_columns_named() {
    let dir = tempfile::tempdir().unwrap();
    let poses =
        "range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n5,2,1,10,20,30,1,2,0.5\n4,-3,0,90,0,0,0,0,0\n";
    file(dir.path(), "poses.csv", poses);
    let head = "from = \"paper-fls\"\nto = \"paper-sss\"\nstep = 0.1\nposes = \"poses.csv\"\n";
    let full = file(dir.path(), "full.toml", head);
    let kept = file(
        dir.path(),
        "kept.toml",
        &format!("columns = [\"sigma_elevation\", \"range_min\"]\n{head}"),
    );
    for format in ["csv", "parquet"] {
        let name = format!("sweep.{format}");
        let args = ["--backend", "cpu-fast", "--format", format];
        sweep(&full, &dir.path().join(format!("full-{format}")), &args, &name);
        sweep(&kept, &dir.path().join(format!("kept-{format}")), &args, &name);
    }
    let (header, rows) = csv_cells(&std::fs::read(dir.path().join("full-csv/sweep.csv")).unwrap());
    let names: Vec<String> = [
        "index",
        "range",
        "azimuth",
        "elevation",
        "roll",
        "pitch",
        "yaw",
        "tx",
        "ty",
        "tz",
        "range_min",
        "sigma_elevation",
    ]
    .map(String::from)
    .to_vec();
    let (got_header, got) = csv_cells(&std::fs::read(dir.path().join("kept-csv/sweep.csv")).unwrap());
    assert_eq!(got_header, names);
    let want = pick(&header, &rows, &names);
    assert_eq!(got, want);
    assert_eq!(
        parquet_cells(&dir.path().join("kept-parquet/sweep.parquet"), &names),
        want
    );
}

/// Shards of a sweep keeping some columns merge into the file one run writes; a resumed run
/// gives it too; the columns are part of what the sweep is (a directory of the full sweep
/// refuses it).
#[test]
fn kept_columns_merge_resume_and_make_another_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = file(
        dir.path(),
        "kept.toml",
        &format!("columns = [\"span\", \"occupied\"]\n{GRID_1D}"),
    );
    let args = [
        "--backend",
        "cpu-fast",
        "--format",
        "parquet",
        "--chunk-poses",
        "5",
    ];
    let one = sweep(&cfg, &dir.path().join("one"), &args, "sweep.parquet");
    let sharded = dir.path().join("sharded");
    for k in ["2/2", "1/2"] {
        common::sonarproj()
            .args(["sweep", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&sharded)
            .args(args)
            .args(["--shard", k])
            .assert()
            .success();
    }
    common::sonarproj().arg("merge").arg(&sharded).assert().success();
    assert!(
        std::fs::read(sharded.join("sweep.parquet")).unwrap() == one,
        "merged"
    );
    let resumed = dir.path().join("resumed");
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&resumed)
        .args(args)
        .args(["--max-chunks", "3"])
        .assert()
        .success()
        .stdout(predicates::str::contains("15 of 46 poses done"));
    assert!(sweep(&cfg, &resumed, &args, "sweep.parquet") == one, "resumed");
    let full = file(dir.path(), "full.toml", GRID_1D);
    common::sonarproj()
        .args(["sweep", "--config"])
        .arg(&full)
        .arg("--out")
        .arg(dir.path().join("one"))
        .args(args)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("different sweep"));
}
