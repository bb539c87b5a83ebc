//! The command line from the outside: `project`, `batch`, `devices`, `paper` print and write what
//! they say (`recover` is `recover.rs`, `bench` is `bench.rs`, bad input is `bad_input.rs`).

use sonarproj_testkit as common;

use common::json;
use serde_json::Value;
use sonarproj::metrics::METRIC_NAMES;
use sonarproj_apps::io::METRIC_COLUMNS;

#[test]
fn project_prints_metrics_as_json() {
    for backend in common::cli_backends("cpu") {
        let out = common::sonarproj()
            .args([
                "project",
                "--from",
                "paper-fls",
                "--to",
                "paper-sss",
                "--range",
                "5",
            ])
            .args([
                "--pitch",
                "90",
                "--place-range",
                "15",
                "--step",
                "0.1",
                "--backend",
                backend,
            ])
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        let v = json(&out);
        assert_eq!(v["backend"], backend);
        assert_eq!(v["metrics"]["visible"], 121);
        assert_eq!(v["metrics"]["total"], 121);
        assert_eq!(v["sampling"]["elevation_samples"], 121);
        let span = v["metrics"]["span"].as_f64().unwrap();
        assert!((span - 1.0452).abs() < 1e-3, "{span}");
    }
}

#[test]
fn project_accepts_every_rotation_form_alike() {
    // The same rotation three ways: yaw 90° (paper convention), its quaternion and its matrix.
    let base = [
        "project",
        "--from",
        "paper-sss",
        "--to",
        "paper-fls",
        "--range",
        "12",
        "--step",
        "0.1",
    ];
    let tail = [
        "--place-range",
        "5",
        "--place-azimuth",
        "10",
        "--place-elevation",
        "2",
        "--backend",
        "cpu",
    ];
    let forms: [&[&str]; 3] = [
        &["--yaw", "90"],
        &["--quaternion", "0.7071067811865476,0,0,-0.7071067811865476"],
        &["--matrix", "0,1,0,-1,0,0,0,0,1"],
    ];
    let metrics: Vec<Value> = forms
        .iter()
        .map(|f| {
            let out = common::sonarproj()
                .args(base)
                .args(*f)
                .args(tail)
                .assert()
                .success()
                .get_output()
                .stdout
                .clone();
            json(&out)["metrics"].clone()
        })
        .collect();
    assert!(metrics[0]["visible"].as_u64().unwrap() > 0);
    for m in &metrics[1..] {
        assert_eq!(m["visible"], metrics[0]["visible"]);
        assert_eq!(m["occupied"], metrics[0]["occupied"]);
    }
}

#[test]
fn project_writes_occupancy_as_npy_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let npy = dir.path().join("occ.npy");
    let png = dir.path().join("occ.png");
    for (file, backend) in [(&npy, "cpu"), (&png, "auto")] {
        let out = common::sonarproj()
            .args([
                "project",
                "--from",
                "paper-sss",
                "--to",
                "paper-fls",
                "--range",
                "15",
            ])
            .args([
                "--roll",
                "-30",
                "--place-range",
                "5",
                "--step",
                "0.1",
                "--backend",
                backend,
            ])
            .arg("--occupancy")
            .arg(file)
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        assert!(json(&out)["metrics"]["occupied"].as_u64().unwrap() > 0);
    }
    let bytes = std::fs::read(&npy).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let header = String::from_utf8_lossy(&bytes[..128]);
    assert!(header.replace(' ', "").contains("'shape':(990,512,)"), "{header}");
    assert!(header.contains("|u1"), "{header}");
    // The PNG is a labelled picture (RGB), its one panel the raw layout holding the arc.
    let pic = common::Picture::read(&png);
    let panels = pic.panels();
    assert_eq!(panels.len(), 1, "{panels:?}");
    assert!(!pic.coloured(panels[0]).is_empty());
}

/// Runs `project` from paper-fls to itself with no motion, a feature at `range` (m) and
/// `azimuth` (deg), writing the occupancy to `file` with `extra` options.
fn project_in_place(range: &str, azimuth: &str, file: &std::path::Path, extra: &[&str]) {
    common::sonarproj()
        .args([
            "project",
            "--from",
            "paper-fls",
            "--to",
            "paper-fls",
            "--range",
            range,
        ])
        .args(["--azimuth", azimuth, "--translation", "0,0,0", "--backend", "cpu"])
        .arg("--occupancy")
        .arg(file)
        .args(extra)
        .assert()
        .success();
}

#[test]
fn occupancy_png_shows_port_on_the_left_and_near_range_at_the_bottom() {
    // Sonar 2 is sonar 1: the feature stays where it is. +azimuth is +y, port; the paper FLS
    // reaches 10 m, so 2 m is near and 8 m far.
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("occ.png");
    for (range, azimuth, port, near) in [
        ("2", "20", true, true),
        ("8", "-20", false, false),
        ("8", "25", true, false),
    ] {
        project_in_place(range, azimuth, &png, &[]);
        let pic = common::Picture::read(&png);
        let panels = pic.panels();
        assert_eq!(panels.len(), 1, "{panels:?}");
        pic.assert_side(
            panels[0],
            Some(port),
            near,
            &format!("feature at {range} m, {azimuth}°"),
        );
    }
    // A sidescan target: a vertical strip (the first panel: the whole range), near range low.
    for (range, near) in [("4", true), ("26", false)] {
        common::sonarproj()
            .args([
                "project",
                "--from",
                "paper-sss",
                "--to",
                "paper-sss",
                "--range",
                range,
            ])
            .args(["--translation", "0,0,0", "--backend", "cpu", "--occupancy"])
            .arg(&png)
            .assert()
            .success();
        let pic = common::Picture::read(&png);
        let strip = pic.panels()[0];
        assert!(
            strip.y1 - strip.y0 > 3 * (strip.x1 - strip.x0),
            "vertical: {strip:?}"
        );
        pic.assert_side(strip, None, near, &format!("sidescan feature at {range} m"));
    }
}

#[test]
fn occupancy_npy_keeps_its_layout_and_flips_apply_to_it_only() {
    let dir = tempfile::tempdir().unwrap();
    let read = |path: &std::path::Path| -> Vec<u8> {
        let bytes = std::fs::read(path).unwrap();
        let npy = npyz::NpyFile::new(bytes.as_slice()).unwrap();
        assert_eq!(npy.shape(), &[990, 512]);
        npy.into_vec().unwrap()
    };
    let plain = dir.path().join("plain.npy");
    project_in_place("2", "20", &plain, &[]);
    let plain = read(&plain);
    let set: Vec<(usize, usize)> = (0..plain.len())
        .filter(|&k| plain[k] == 1)
        .map(|k| (k / 512, k % 512))
        .collect();
    assert!(!set.is_empty());
    // Row 0 is range_min (0.1 m, 1 cm bins: 2 m is row 190); column 0 is the starboard-most
    // beam, so a port feature (+20° of ±30°) is in the upper columns.
    for &(i, j) in &set {
        assert!((189..=191).contains(&i) && j > 256, "pixel ({i}, {j})");
    }
    for (flags, mirror_rows, mirror_cols) in [
        (&["--flip-range"][..], true, false),
        (&["--flip-beams"][..], false, true),
        (&["--flip-range", "--flip-beams"][..], true, true),
    ] {
        let path = dir.path().join("flipped.npy");
        project_in_place("2", "20", &path, flags);
        let flipped = read(&path);
        for i in 0..990 {
            for j in 0..512 {
                let (fi, fj) = (
                    if mirror_rows { 989 - i } else { i },
                    if mirror_cols { 511 - j } else { j },
                );
                assert_eq!(flipped[fi * 512 + fj], plain[i * 512 + j], "{flags:?} ({i}, {j})");
            }
        }
    }
    // A picture always follows the convention: a flip asked for one is refused.
    for flag in ["--flip-range", "--flip-beams"] {
        let png = dir.path().join("o.png");
        let png = png.to_str().unwrap();
        common::rejects(
            &[
                "project",
                "--from",
                "paper-fls",
                "--to",
                "paper-fls",
                "--range",
                "2",
                "--translation",
                "0,0,0",
                "--occupancy",
                png,
                flag,
            ],
            None,
            &[flag, ".npy"],
        );
        assert!(
            !std::path::Path::new(png).exists(),
            "nothing written when refused"
        );
    }
}

#[test]
fn batch_reads_poses_and_writes_metrics() {
    let input = "range,azimuth,elevation,roll,pitch,yaw,place_range,place_azimuth,place_elevation\n\
                 5,0,0,0,90,0,15,0,0\n\
                 5,10,-3,20,30,40,15,5,0\n\
                 5,0,0,0,0,0,15,0,0\n";
    for backend in common::cli_backends("cpu") {
        let out = common::sonarproj()
            .args([
                "batch",
                "--from",
                "paper-fls",
                "--to",
                "paper-sss",
                "--step",
                "0.1",
                "--backend",
                backend,
            ])
            .write_stdin(input)
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        let text = String::from_utf8(out).unwrap();
        let mut rdr = csv::Reader::from_reader(text.as_bytes());
        let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header.len(), 9 + METRIC_COLUMNS.len());
        assert_eq!(
            header[9..],
            METRIC_COLUMNS,
            "metric columns: the metric table's names, in order, then the local precision"
        );
        assert_eq!(header[9..9 + METRIC_NAMES.len()], METRIC_NAMES);
        let rows: Vec<csv::StringRecord> = rdr.records().map(Result::unwrap).collect();
        assert_eq!(rows.len(), 3);
        assert_eq!(&rows[0][9], "121", "{backend}: pitch 90 keeps the whole arc");
        assert_eq!(&rows[1][1], "10", "input columns echoed as given");
        for row in &rows {
            assert_eq!(&row[10], "121");
        }
    }
}

#[test]
fn batch_takes_translations_and_files() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.csv");
    let output = dir.path().join("out.csv");
    std::fs::write(
        &input,
        "tx,ty,tz,yaw,pitch,roll,range,azimuth,elevation\n10,0,0,0,0,0,5,0,0\n",
    )
    .unwrap();
    common::sonarproj()
        .args([
            "batch",
            "--from",
            "paper-sss",
            "--to",
            "paper-fls",
            "--backend",
            "cpu",
            "--step",
            "0.1",
        ])
        .arg("--input")
        .arg(&input)
        .arg("--output")
        .arg(&output)
        .assert()
        .success();
    let text = std::fs::read_to_string(&output).unwrap();
    assert!(
        text.starts_with("tx,ty,tz,yaw,pitch,roll,range,azimuth,elevation,visible,"),
        "{text}"
    );
    assert_eq!(text.lines().count(), 2);
}

#[test]
fn devices_lists_adapters_and_the_choice() {
    let out = common::sonarproj()
        .arg("devices")
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("adapters"), "{text}");
    assert!(text.contains("auto uses:"), "{text}");
    if common::gpu().is_some() {
        assert!(!text.contains("adapters: none"), "{text}");
    }
}

#[test]
fn the_cpu_notice_is_one_short_line_saying_how_to_silence_it() {
    // No wgpu backend to look on: `auto` runs on the CPU whatever the machine, and says so.
    let project = [
        "project",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--range",
        "5",
        "--pitch",
        "90",
        "--place-range",
        "15",
    ];
    let out = common::sonarproj()
        .args(project)
        .env("WGPU_BACKEND", "none")
        .assert()
        .success()
        .get_output()
        .clone();
    let err = String::from_utf8(out.stderr).unwrap();
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].starts_with("note: running on the CPU"), "{err}");
    assert!(
        lines[0].ends_with("; --backend cpu-fast skips this note"),
        "{err}"
    );
    assert!(
        lines[0].chars().count() <= 100,
        "{} characters: {err}",
        lines[0].len()
    );
    // As it says: choosing the CPU prints nothing.
    let out = common::sonarproj()
        .args(project)
        .args(["--backend", "cpu-fast"])
        .env("WGPU_BACKEND", "none")
        .assert()
        .success()
        .get_output()
        .clone();
    assert!(out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
    // `devices` gives the reason alone, without the hint meant for a command's stderr.
    let out = common::sonarproj()
        .arg("devices")
        .env("WGPU_BACKEND", "none")
        .assert()
        .success()
        .get_output()
        .clone();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("running on the CPU") && !text.contains("skips this note"),
        "{text}"
    );
}

#[test]
fn mask_help_says_one_thing_of_the_cpu_backends() {
    // Masks have one CPU engine, f64 on every core: the help never calls `cpu` the one-core
    // reference there, as the projecting commands rightly do.
    let help = |command: &str| {
        let out = common::sonarproj()
            .args([command, "--help"])
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        String::from_utf8(out).unwrap()
    };
    let mask = help("mask");
    assert!(!mask.contains("one core"), "{mask}");
    assert!(mask.contains("one CPU engine"), "{mask}");
    let cpu_line = mask
        .lines()
        .find(|l| l.trim_start().starts_with("- cpu:"))
        .expect("the cpu value");
    assert!(cpu_line.contains("every core"), "{cpu_line}");
    assert!(help("project").contains("one core"));
}

#[test]
fn paper_writes_csv_figures_and_findings() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("paper");
    common::sonarproj()
        .args(["paper", "--angle-step", "30", "--backend", "cpu-fast", "--out"])
        .arg(&out)
        .assert()
        .success();
    // 30° steps: 7 angles; scenarios 1–6: 9 × 7 poses, 7–9: 7 × 7.
    let rows = 6 * 9 * 7 + 3 * 7 * 7;
    for d in ["fls-to-sss", "sss-to-fls"] {
        let text = std::fs::read_to_string(out.join(format!("{d}.csv"))).unwrap();
        assert!(
            text.starts_with("scenario,fraction,roll,pitch,yaw,visible,total,visible_fraction,range_min,")
        );
        assert_eq!(text.lines().count(), rows + 1, "{d}");
        for fig in ["lines", "heatmaps"] {
            let file = std::fs::File::open(out.join(format!("{d}-{fig}.png"))).unwrap();
            let info = png::Decoder::new(std::io::BufReader::new(file))
                .read_info()
                .unwrap();
            assert!(info.info().width >= 1000, "{d}-{fig}");
        }
    }
    let md = std::fs::read_to_string(out.join("findings.md")).unwrap();
    assert_eq!(md.matches("\n## ").count(), 4, "{md}");
}

#[test]
fn project_json_keys_are_the_metric_table() {
    let out = common::sonarproj()
        .args([
            "project",
            "--from",
            "paper-fls",
            "--to",
            "paper-sss",
            "--backend",
            "cpu",
        ])
        .args(["--range", "5", "--pitch", "90", "--place-range", "15"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let json: Value = serde_json::from_slice(&out).unwrap();
    let keys: Vec<&str> = json["metrics"]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(
        keys, METRIC_COLUMNS,
        "JSON keys: the metric table's names, in order, then the local precision"
    );
    // Values are read through the table as the struct holds them: pitch 90° keeps the whole arc.
    assert!(json["metrics"]["visible"].as_u64().unwrap() > 100);
    assert_eq!(json["metrics"]["visible"], json["metrics"]["total"]);
    assert!(json["metrics"]["range_min"].as_f64().unwrap() < 15.0);
}

#[test]
fn a_holoocean_sensor_file_is_a_sonar_with_its_frames_shape() {
    // A sonar file holding a HoloOcean sensor, as its scenario configures it: the occupancy is
    // HoloOcean's frame, (RangeBins, AzimuthBins) = ((40 − 1) / 0.05, 130 / 0.25).
    let dir = tempfile::tempdir().unwrap();
    let sonar = dir.path().join("imaging.toml");
    std::fs::write(
        &sonar,
        "[holoocean]\nsensor_type = \"ImagingSonar\"\nAzimuth = 130\nElevation = 20\nRangeMin = 1\n\
         RangeMax = 40\nRangeRes = 0.05\nAzimuthRes = 0.25\nAddSigma = 0.15\nMultiPath = true\n",
    )
    .unwrap();
    let npy = dir.path().join("occ.npy");
    common::sonarproj()
        .args(["project", "--from", "paper-sss", "--to"])
        .arg(&sonar)
        .args([
            "--range",
            "15",
            "--roll",
            "-30",
            "--place-range",
            "5",
            "--backend",
            "cpu",
            "--occupancy",
        ])
        .arg(&npy)
        .assert()
        .success();
    let bytes = std::fs::read(&npy).unwrap();
    let arr = npyz::NpyFile::new(bytes.as_slice()).unwrap();
    assert_eq!(arr.shape(), &[780, 520]);
    // A misspelt key is refused naming it, not read as the default.
    std::fs::write(
        &sonar,
        "[holoocean]\nsensor_type = \"ImagingSonar\"\nRangeMAx = 40\n",
    )
    .unwrap();
    common::rejects(
        &[
            "project",
            "--from",
            "paper-sss",
            "--to",
            sonar.to_str().unwrap(),
            "--range",
            "15",
            "--place-range",
            "5",
        ],
        None,
        &["HoloOcean ImagingSonar: \"RangeMAx\"", "not a key"],
    );
}
