//! Bad input and failures from the outside: bad input exits with status 2 and a message naming
//! the field (or flag, or variable) and the value, leaving no output file behind; a failure of the
//! machine (no GPU, a closed pipe, a full disk) exits with 1 and says so; never a panic.

use sonarproj_testkit as common;

use common::json;

const PROJECT: [&str; 5] = ["project", "--from", "paper-fls", "--to", "paper-sss"];

/// Returns `sonarproj project --from paper-fls --to paper-sss` followed by `extra`.
fn p<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    [&PROJECT[..], extra].concat()
}

#[test]
fn bad_project_input_exits_2_naming_field_and_value() {
    // (arguments after `project --from paper-fls --to paper-sss`, what stderr must say)
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--range", "11", "--place-range", "5"],
            &["feature range = 11", "[0.1, 10]"],
        ),
        (&["--range", "-1", "--place-range", "5"], &["feature range = -1"]),
        (
            &["--range", "5", "--azimuth", "31", "--place-range", "5"],
            &["feature azimuth = 31", "[-30, 30]"],
        ),
        (
            &["--range", "5", "--elevation", "7", "--place-range", "5"],
            &["feature elevation = 7"],
        ),
        (
            &["--range", "NaN", "--place-range", "5"],
            &["feature range = NaN", "finite"],
        ),
        (
            &["--range", "5", "--place-range", "5", "--step", "0"],
            &["step = 0"],
        ),
        (
            &["--range", "5", "--place-range", "5", "--step", "-1"],
            &["step = -1"],
        ),
        (
            &["--range", "5", "--place-range", "5", "--area-grid", "0"],
            &["area_grid = 0", "> 0 m"],
        ),
        (
            &["--range", "5", "--place-range", "5", "--sigma-range", "-0.1"],
            &["sigma_range = -0.1", "> 0 m"],
        ),
        (&["--range", "5", "--place-range", "-2"], &["place range = -2"]),
        (
            &["--range", "5", "--place-range", "5", "--roll", "inf"],
            &["roll = inf"],
        ),
        (
            &[
                "--range",
                "5",
                "--place-range",
                "5",
                "--matrix",
                "1,0,0,0,1,0,0,0.5,1",
            ],
            &["orthonormal"],
        ),
        (
            &[
                "--range",
                "5",
                "--place-range",
                "5",
                "--matrix",
                "1,0,0,0,1,0,0,0,-1",
            ],
            &["determinant"],
        ),
        (
            &["--range", "5", "--place-range", "5", "--matrix", "1,0,0"],
            &["--matrix", "9 comma-separated"],
        ),
        (
            &["--range", "5", "--place-range", "5", "--quaternion", "1,1,0,0"],
            &["unit quaternion"],
        ),
        (
            &["--range", "5", "--translation", "1,x,3"],
            &["--translation", "\"x\""],
        ),
        (&["--range", "5"], &["--place-range"]),
        (
            &["--range", "5", "--place-range", "5", "--translation", "1,2,3"],
            &["cannot be used with"],
        ),
        (
            &["--range", "5", "--place-range", "5", "--occupancy", "x.bmp"],
            &["--occupancy", ".png or .npy"],
        ),
    ];
    for (args, needles) in cases {
        common::rejects(&p(args), None, needles);
    }
    let unknown = [
        "project",
        "--from",
        "paper-fls",
        "--to",
        "sonar-x",
        "--range",
        "5",
        "--place-range",
        "5",
    ];
    common::rejects(&unknown, None, &["unknown sonar \"sonar-x\"", "paper-sss"]);
}

#[test]
fn bad_sonar_files_exit_2_naming_file_key_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "range_min = -1\nrange_max = 5\nazimuth_aperture = 30\nelevation_aperture = 10",
            "range_min = -1",
        ),
        (
            "range_min = 6\nrange_max = 5\nazimuth_aperture = 30\nelevation_aperture = 10",
            "range_max = 5",
        ),
        (
            "range_min = 1\nrange_max = 5\nazimuth_aperture = 400\nelevation_aperture = 10",
            "azimuth_aperture = 400",
        ),
        (
            "range_min = 1\nrange_max = 5\nazimuth_aperture = 30\nelevation_aperture = 0",
            "elevation_aperture = 0",
        ),
        (
            "range_min = 1\nrange_max = 5\nazimuth_aperture = 30\nelevation_aperture = 190",
            "elevation_aperture = 190",
        ),
        (
            "range_min = 1\nrange_max = 5\nazimuth_aperture = 30\nelevation_aperture = 10\ncolour = 'red'",
            "colour",
        ),
        (
            "range_min = 1\nrange_max = 5\nazimuth_aperture = 30",
            "elevation_aperture",
        ),
    ];
    for (k, (body, needle)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("s{k}.toml"));
        std::fs::write(
            &path,
            format!("kind = 'fls'\nrange_bins = 10\nbeams = 16\n{body}\n"),
        )
        .unwrap();
        let path = path.to_str().unwrap();
        common::rejects(
            &[
                "project",
                "--from",
                path,
                "--to",
                "paper-sss",
                "--range",
                "2",
                "--place-range",
                "5",
            ],
            None,
            &[needle, path],
        );
    }
}

#[test]
fn flips_of_a_two_sided_sidescan_row_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let npy = dir.path().join("o.npy");
    let npy = npy.to_str().unwrap();
    for flag in ["--flip-range", "--flip-beams"] {
        common::rejects(
            &[
                "project",
                "--from",
                "paper-fls",
                "--to",
                "holoocean-sidescan",
                "--range",
                "5",
                "--azimuth",
                "0",
                "--pitch",
                "90",
                "--place-range",
                "12",
                "--occupancy",
                npy,
                flag,
            ],
            None,
            &[flag, "two-sided", "one row"],
        );
    }
    assert!(!std::path::Path::new(npy).exists(), "nothing written");
}

#[test]
fn an_area_grid_too_fine_for_the_image_names_the_smallest_cell() {
    let args = [
        "project",
        "--from",
        "paper-sss",
        "--to",
        "oculus-m750d",
        "--range",
        "5",
        "--place-range",
        "5",
        "--area-grid",
        "0.01",
        "--backend",
        "cpu",
    ];
    common::rejects(
        &args,
        None,
        &[
            "area_grid = 0.01",
            "cells over sonar 2's image",
            "use at least 0.020 m",
        ],
    );
}

#[test]
fn a_long_unknown_sonar_name_is_cut_in_the_error() {
    let long = "x".repeat(5000);
    let out = common::sonarproj()
        .args([
            "project",
            "--from",
            "paper-fls",
            "--to",
            &long,
            "--range",
            "5",
            "--place-range",
            "5",
        ])
        .assert()
        .code(2)
        .get_output()
        .clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("unknown sonar") && err.contains("(5000 bytes)"),
        "{err}"
    );
    assert!(err.len() < 600, "{} bytes of error", err.len());
}

#[test]
fn parameters_whose_results_would_overflow_are_refused_naming_the_largest() {
    // A range sigma or a grid cell large enough to make a sigma or an area infinite: refused,
    // naming the parameter and the largest value that works, before any output.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.csv");
    let out = out.to_str().unwrap();
    let batch = |extra: &[&'static str]| -> Vec<String> {
        [
            "batch",
            "--from",
            "paper-sss",
            "--to",
            "paper-fls",
            "--input",
            "data/example-poses.csv",
            "--output",
            out,
        ]
        .iter()
        .chain(extra)
        .map(ToString::to_string)
        .collect()
    };
    for (args, said) in [
        (
            batch(&["--sigma-range", "1e308"]),
            ["sigma_range = 1e308", "at most 1000000 m"],
        ),
        (
            batch(&["--area-grid", "1e300"]),
            ["area_grid = 1e300", "at most 20000 m"],
        ),
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        common::rejects(&args, None, &said);
        assert!(!std::path::Path::new(out).exists());
    }
    common::rejects(
        &[
            "recover",
            "--from",
            "paper-fls",
            "--to",
            "paper-sss",
            "--pitch",
            "90",
            "--place-range",
            "15",
            "--feature-elevation",
            "3",
            "--first",
            "5,0",
            "--second",
            "15",
            "--sigma-range",
            "1e308",
            "--sigma-azimuth",
            "0.1",
        ],
        None,
        &["--sigma-range = 1e308", "[0, 1000000] m"],
    );
    // An advise file's mix scales: a denormal one would make the score infinite.
    let config = dir.path().join("mix.toml");
    std::fs::write(
        &config,
        "from = \"paper-fls\"\nto = \"paper-fls\"\nobjective = \"mix\"\n[mix]\nweight = 0.5\n\
         metric_scale = 1e-310\nsigma_scale = 1\n[features]\ncount = 10\n[rig]\norigin = [0, 0, -0.5]\n",
    )
    .unwrap();
    let advise_out = dir.path().join("advise");
    common::rejects(
        &[
            "advise",
            "--config",
            config.to_str().unwrap(),
            "--out",
            advise_out.to_str().unwrap(),
        ],
        None,
        &["mix.metric_scale = 1e-310", "[1e-6, 1e6]"],
    );
    assert!(!advise_out.exists());
}

#[test]
fn bad_batch_input_exits_2_naming_the_row_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.csv");
    let out = output.to_str().unwrap();
    let args = [
        "batch",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--step",
        "0.5",
        "--output",
        out,
        "--backend",
        "cpu",
    ];
    let header = "range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n";
    let good = "5,0,0,0,0,0,1,0,0\n";
    let cases: [(String, &[&str]); 13] = [
        (String::new(), &["empty input"]),
        (header.to_string(), &["no rows"]),
        (
            format!("{header}{good}{good}5,0,0,0,0,0,1,0,abc\n"),
            &["row 3", "line 4", "column tz", "\"abc\""],
        ),
        (
            format!("{header}{good}50,0,0,0,0,0,1,0,0\n"),
            &["row 2", "feature range = 50"],
        ),
        (
            format!("{header}{good}5,40,0,0,0,0,1,0,0\n"),
            &["row 2", "feature azimuth = 40"],
        ),
        (format!("{header}5,0,0,nan,0,0,1,0,0\n"), &["row 1", "roll = NaN"]),
        (format!("{header}5,0,0,0,0\n"), &["row 1"]),
        (
            "range,azimuth,elevation,roll,pitch,yaw\n5,0,0,0,0,0\n".to_string(),
            &["missing translation"],
        ),
        (
            "range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz,bogus\n".to_string(),
            &["unknown column \"bogus\""],
        ),
        // With tx,ty,tz the true point's elevation is optional; a placement needs it.
        (
            "range,azimuth,roll,pitch,yaw,place_range,place_azimuth,place_elevation\n".to_string(),
            &[
                "missing column(s) elevation",
                "a placement needs the feature's true point",
            ],
        ),
        (
            "range,azimuth,qw,qx,qy,qz,tx,ty,tz\n5,0,1,0,0,0,1,0,0\n5,0,1,0,0.01,0,1,0,0\n".to_string(),
            &["row 2", "quaternion", "norm within 0.000001 of 1"],
        ),
        (
            "range,azimuth,r11,r12,r13,r21,r22,r23,r31,r32,r33,tx,ty,tz\n5,0,1,0,0,0,1,0,0,0,-1,1,0,0\n"
                .to_string(),
            &["row 1", "matrix", "determinant +1"],
        ),
        (
            "range,azimuth,roll,pitch,yaw,qw,qx,qy,qz,tx,ty,tz\n".to_string(),
            &["give one rotation, not roll,pitch,yaw and qw,qx,qy,qz"],
        ),
    ];
    for (input, needles) in cases {
        common::rejects(&args, Some(&input), needles);
        assert!(!output.exists(), "a failed batch left {out} behind");
    }
    let both = "range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz,place_range,place_azimuth,place_elevation\n";
    common::rejects(&args, Some(both), &["not both"]);
    // Nothing half-written either: no temporary files remain in the directory.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn gpu_backend_without_adapter_is_a_failure_not_bad_input() {
    // An empty backend list leaves wgpu with no adapter: --backend gpu exits 1, auto falls back.
    let args = [
        "project",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--range",
        "5",
        "--place-range",
        "15",
        "--step",
        "1",
    ];
    let out = common::sonarproj()
        .env("WGPU_BACKEND", "none")
        .args(args)
        .args(["--backend", "gpu"])
        .assert()
        .code(1)
        .get_output()
        .clone();
    assert!(String::from_utf8_lossy(&out.stderr).contains("no GPU adapter"));
    let out = common::sonarproj()
        .env("WGPU_BACKEND", "none")
        .args(args)
        .assert()
        .success()
        .get_output()
        .clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "one-line notice: {err}");
    assert!(err.contains("CPU"), "{err}");
    assert_eq!(json(&out.stdout)["backend"], "cpu-fast");
}

#[test]
fn bad_recover_input_exits_2() {
    let base = [
        "recover",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--translation",
        "1,0,0",
    ];
    let cases: &[(&[&str], &[&str])] = &[
        (&["--first", "5", "--second", "5"], &["first azimuth", "FLS"]),
        (
            &["--first", "5,0", "--second", "5,3"],
            &["second azimuth = 3", "SSS"],
        ),
        (&["--first", "50,0", "--second", "5"], &["first range = 50"]),
        (&["--first", "5,x", "--second", "5"], &["--first", "\"x\""]),
        (
            &["--first", "5,0", "--second", "5", "--sigma-range", "-1"],
            &["--sigma-range = -1"],
        ),
        (
            &["--first", "5,0", "--second", "5", "--curve-step", "0"],
            &["curve step = 0"],
        ),
    ];
    for (args, needles) in cases {
        common::rejects(&[&base[..], args].concat(), None, needles);
    }
    // A NaN range is named as the option it came in, even when the placement is built from it.
    let placed = [
        "recover",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--pitch",
        "90",
        "--place-range",
        "15",
        "--feature-elevation",
        "3",
        "--first",
        "nan,0",
        "--second",
        "15",
    ];
    common::rejects(&placed, None, &["--first = nan,0", "finite"]);
    let batch = [
        "recover",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--input",
        "-",
    ];
    common::rejects(
        &batch,
        Some("first_range,second_range\n"),
        &["missing column \"roll\""],
    );
    common::rejects(
        &batch,
        Some(
            "first_range,first_azimuth,second_range,roll,pitch,yaw,tx,ty,tz\n5,0,5,0,0,0,1,0,0\n5,0,99,0,0,0,1,0,0\n",
        ),
        &["row 2", "second range = 99"],
    );
}

#[test]
fn bad_paper_input_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    common::rejects(
        &["paper", "--out", out, "--angle-step", "0"],
        None,
        &["--angle-step = 0"],
    );
    common::rejects(&["paper", "--out", out, "--step", "-1"], None, &["step = -1"]);
    common::rejects(
        &["paper", "--out", out, "--step", "smooth"],
        None,
        &["--step", "in degrees (> 0), `auto` or `exact`", "\"smooth\""],
    );
    let batch = [
        "batch",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--step",
        "-0.5",
    ];
    common::rejects(
        &batch,
        Some("range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n5,0,0,0,0,0,1,0,0\n"),
        &["step = -0.5"],
    );
}

/// Runs the binary with `args` and stdout on `out`; returns the exit code and stderr.
fn run_with_stdout(args: &[&str], out: std::process::Stdio) -> (Option<i32>, String) {
    let output = std::process::Command::new(assert_cmd::cargo::cargo_bin("sonarproj"))
        .current_dir(common::repository())
        .args(args)
        .env("NODEVICE_SELECT", "1")
        .stdout(out)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// Returns the arguments of one small projection.
fn one_projection() -> Vec<&'static str> {
    p(&["--range", "5", "--place-range", "15"])
}

/// A closed pipe or a full disk on stdout is a failure with a message (exit status 1), never a
/// panic (exit status 101).
#[test]
fn output_errors_are_reported_not_panics() {
    let commands = [
        vec!["devices"],
        one_projection(),
        vec!["bench", "masks", "--runs", "1"],
    ];
    for args in &commands {
        // A pipe whose reading end is already closed: every write fails with EPIPE.
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let (code, stderr) = run_with_stdout(args, writer.into());
        assert_eq!(code, Some(1), "{args:?} into a closed pipe: {stderr}");
        assert!(stderr.contains("cannot write stdout"), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        if std::path::Path::new("/dev/full").exists() {
            let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
            let (code, stderr) = run_with_stdout(args, full.into());
            assert_eq!(code, Some(1), "{args:?} into /dev/full: {stderr}");
            assert!(stderr.contains("No space left"), "{args:?}: {stderr}");
        }
    }
}

/// `WGPU_ADAPTER_NAME` naming no adapter is bad input (exit status 2, the variable and value
/// named), not wgpu's panic; `auto` falls back to the CPU with a notice, `devices` says so.
#[test]
fn an_adapter_name_that_matches_nothing_is_bad_input() {
    let wanted = "no-such-adapter-xyz";
    let mut gpu = one_projection();
    gpu.extend(["--backend", "gpu"]);
    let out = common::sonarproj()
        .args(&gpu)
        .env("WGPU_ADAPTER_NAME", wanted)
        .assert()
        .code(2)
        .get_output()
        .clone();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("WGPU_ADAPTER_NAME") && stderr.contains(wanted),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    let out = common::sonarproj()
        .args(one_projection())
        .env("WGPU_ADAPTER_NAME", wanted)
        .assert()
        .success()
        .get_output()
        .clone();
    assert!(String::from_utf8_lossy(&out.stderr).contains("WGPU_ADAPTER_NAME"));
    let out = common::sonarproj()
        .arg("devices")
        .env("WGPU_ADAPTER_NAME", wanted)
        .assert()
        .success()
        .get_output()
        .clone();
    assert!(String::from_utf8_lossy(&out.stdout).contains(wanted));
}

/// Sizes taken from the input are bounded before anything is allocated: each of these used to
/// abort allocating terabytes; now each is bad input (exit 2) naming the key and the limit.
#[test]
fn sizes_from_the_input_are_bounded_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("fine.toml");
    std::fs::write(
        &sweep,
        "from = \"paper-fls\"\nto = \"paper-sss\"\n[feature]\nrange = 5\n\
         [place]\nrange = { start = 0, stop = 180, step = 1e-9 }\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let (sweep, out) = (sweep.to_str().unwrap(), out.to_str().unwrap());
    let cases: [(Vec<&str>, &[&str]); 6] = [
        (
            vec!["paper", "--out", out, "--angle-step", "1e-9"],
            &["--angle-step = 0.000000001", "[0.01, 180]"],
        ),
        (
            vec!["sweep", "--config", sweep, "--out", out],
            &["place.range.step", "at most 1000000 per axis"],
        ),
        (
            vec![
                "sweep",
                "--config",
                "data/example-sweep.toml",
                "--out",
                out,
                "--shard",
                "1/1099511627776",
            ],
            &["--shard", "at most 100000"],
        ),
        (vec!["bench", "--runs", "1000000000"], &["--runs", "1..=10000"]),
        (
            vec!["bench", "--backends", "quantum"],
            &["--backends", "quantum", "cpu-fast"],
        ),
        (
            vec!["bench", "--backends", "cpu", "--no-reference"],
            &["--backends", "--no-reference"],
        ),
    ];
    for (args, words) in cases {
        let output = common::sonarproj()
            .args(&args)
            .env("WGPU_BACKEND", "metal")
            .assert()
            .code(2)
            .get_output()
            .clone();
        let stderr = String::from_utf8_lossy(&output.stderr);
        for w in words {
            assert!(stderr.contains(w), "{args:?}: {w:?} not in {stderr}");
        }
        assert!(!std::path::Path::new(out).join("sweep.csv").exists());
    }
}

/// The GPU's environment variables are read by the command line and checked there: a value
/// outside the allowed ones is bad input (exit status 2) naming the variable and the value, for
/// `--backend gpu` and `auto`; the CPU backends never open a GPU and do not read them.
#[test]
fn bad_gpu_variables_are_bad_input() {
    for (var, value) in [
        ("SONARPROJ_GPU_CULL", "yes"),
        ("SONARPROJ_GPU_FILTER", "2"),
        ("SONARPROJ_GPU_WORKGROUP", "48"),
        ("SONARPROJ_GPU_PRECISION", "f16"),
        ("WGPU_BACKEND", "vulkun"),
        ("WGPU_ADAPTER_NAME", " "),
    ] {
        for backend in ["gpu", "auto"] {
            let out = common::sonarproj()
                .args(one_projection())
                .args(["--backend", backend])
                .env(var, value)
                .assert()
                .code(2)
                .get_output()
                .clone();
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(
                stderr.contains(var) && stderr.contains(&format!("{:?}", value.trim())),
                "{var}={value} --backend {backend}: {stderr}"
            );
        }
        common::sonarproj()
            .args(one_projection())
            .args(["--backend", "cpu-fast"])
            .env(var, value)
            .assert()
            .success();
    }
    // `bench` measures the GPU only where one is usable, but a bad variable is still bad input.
    for bench in [
        &["bench", "--runs", "1"][..],
        &["bench", "masks", "--runs", "1"][..],
    ] {
        let out = common::sonarproj()
            .args(bench)
            .env("SONARPROJ_GPU_WORKGROUP", "48")
            .assert()
            .code(2)
            .get_output()
            .clone();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("SONARPROJ_GPU_WORKGROUP") && stderr.contains("48"),
            "{bench:?}: {stderr}"
        );
    }
}

/// Exact sampling solves an imaging sonar's arc: a sidescan sonar 1 is refused, naming the step.
#[test]
fn exact_sampling_of_a_sidescan_exits_2() {
    let args = "project --from paper-sss --to paper-fls --range 5 --roll 0 --pitch 0 --yaw 0 \
                --place-range 5 --step exact --backend cpu";
    let args: Vec<&str> = args.split_whitespace().collect();
    common::rejects(&args, None, &["step = exact", "sidescan"]);
}
