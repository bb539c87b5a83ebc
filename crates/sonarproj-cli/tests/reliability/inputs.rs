//! Inputs from the outside: an output that is an input is refused and the input kept; bad
//! stream lines, batch and recover rows, endless lines and overflowing values each get their
//! error, after the rows before them.

use super::*;

/// Runs `args` in `dir` and checks that it is refused (exit 2) naming `input` as the file it
/// would have replaced, and that `input` still holds `before`.
fn refused_as_input(dir: &Path, args: &[&str], input: &str, before: &[u8]) {
    let out = common::sonarproj()
        .current_dir(dir)
        .args(args)
        .assert()
        .code(2)
        .get_output()
        .clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("is the input file {input}")) && err.contains("give another output path"),
        "{args:?}: {err}"
    );
    assert_eq!(
        std::fs::read(dir.join(input)).unwrap(),
        before,
        "{args:?} changed {input}"
    );
}

#[test]
fn an_output_that_is_the_file_read_on_stdin_is_refused() {
    // `< in.csv` with the output named as the file, as /dev/stdin or as /proc/self/fd/0, for
    // batch and recover: refused, the file kept. From a pipe, stdin is no file: writing the
    // named file is fine.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let poses = std::fs::read(common::repository().join("data/example-poses.csv")).unwrap();
    std::fs::write(d.join("in.csv"), &poses).unwrap();
    let pairs = b"first_range,first_azimuth,second_range,roll,pitch,yaw,tx,ty,tz\n5,0,5.5,0,0,0,-10,0,0\n";
    std::fs::write(d.join("pairs.csv"), pairs).unwrap();
    let batch = [
        "batch",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--backend",
        "cpu-fast",
    ];
    let recover = ["recover", "--from", "paper-fls", "--to", "paper-sss"];
    for (command, input, before) in [
        (&batch[..], "in.csv", &poses[..]),
        (&recover[..], "pairs.csv", &pairs[..]),
    ] {
        for out in [input, "/dev/stdin", "/proc/self/fd/0"] {
            // A real file as stdin (not a pipe fed from it).
            let out_run = std::process::Command::new(assert_cmd::cargo::cargo_bin!("sonarproj"))
                .current_dir(d)
                .env("NODEVICE_SELECT", "1")
                .args(command)
                .args(["--input", "-", "--output", out])
                .stdin(std::fs::File::open(d.join(input)).unwrap())
                .output()
                .unwrap();
            assert_eq!(out_run.status.code(), Some(2), "{command:?} {out}");
            let err = String::from_utf8_lossy(&out_run.stderr);
            assert!(
                err.contains("is the input file read on standard input")
                    && err.contains("give another output path"),
                "{command:?} {out}: {err}"
            );
            assert_eq!(
                std::fs::read(d.join(input)).unwrap(),
                before,
                "{out} changed {input}"
            );
        }
    }
    common::sonarproj()
        .current_dir(d)
        .args(batch)
        .args(["--input", "-", "--output", "out.csv"])
        .write_stdin(poses.clone())
        .assert()
        .success();
    assert!(std::fs::metadata(d.join("out.csv")).unwrap().len() > 0);
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let poses = std::fs::read(common::repository().join("data/example-poses.csv")).unwrap();
    std::fs::write(d.join("in.csv"), &poses).unwrap();
    std::os::unix::fs::symlink("in.csv", d.join("link.csv")).unwrap();
    let absolute = d.join("in.csv").display().to_string();
    let batch = [
        "batch",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--backend",
        "cpu-fast",
    ];
    // The same file by its name, another spelling of the path, a symlink and its absolute path.
    for out in ["in.csv", "./in.csv", "link.csv", absolute.as_str()] {
        let args: Vec<&str> = batch
            .iter()
            .copied()
            .chain(["--input", "in.csv", "--output", out])
            .collect();
        refused_as_input(d, &args, "in.csv", &poses);
    }
    // A sonar file given as sonar 1 or 2 is an input too, whatever its name.
    let sonar = b"kind = \"fls\"\nrange_min = 0.1\nrange_max = 10\nazimuth_aperture = 60\n\
                  elevation_aperture = 12\nrange_bins = 100\nbeams = 10\n";
    std::fs::write(d.join("fls.npy"), sonar).unwrap();
    let pose = ["--range", "5", "--pitch", "90", "--place-range", "15"];
    let project: Vec<&str> = ["project", "--from", "fls.npy", "--to", "paper-sss"]
        .into_iter()
        .chain(pose)
        .chain(["--occupancy", "fls.npy"])
        .collect();
    refused_as_input(d, &project, "fls.npy", sonar);
    let mask = [
        "mask",
        "--from",
        "paper-sss",
        "--to",
        "fls.npy",
        "--place-range",
        "5",
        "--feature",
        "5",
        "--backend",
        "cpu-fast",
        "--npy",
        "fls.npy",
    ];
    refused_as_input(d, &mask, "fls.npy", sonar);
    // recover's batch mode.
    let pairs = b"first_range,first_azimuth,second_range,roll,pitch,yaw,tx,ty,tz\n5,0,5.5,0,0,0,-10,0,0\n";
    std::fs::write(d.join("pairs.csv"), pairs).unwrap();
    let recover = [
        "recover",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--input",
        "pairs.csv",
        "--output",
        "pairs.csv",
    ];
    refused_as_input(d, &recover, "pairs.csv", pairs);
    // A sweep file inside the output directory, named as the sweep's table.
    let sweep = std::fs::read(common::repository().join("data/example-sweep.toml")).unwrap();
    std::fs::create_dir(d.join("out")).unwrap();
    std::fs::write(d.join("out/sweep.csv"), &sweep).unwrap();
    refused_as_input(
        d,
        &[
            "sweep",
            "--config",
            "out/sweep.csv",
            "--out",
            "out",
            "--backend",
            "cpu-fast",
        ],
        "out/sweep.csv",
        &sweep,
    );
    // A different file is written as usual.
    let args: Vec<&str> = batch
        .iter()
        .copied()
        .chain(["--input", "in.csv", "--output", "out.csv"])
        .collect();
    common::sonarproj().current_dir(d).args(&args).assert().success();
}

/// Returns the JSON replies of `mask --stream` to `input`, and its exit status.
fn stream(input: Vec<u8>) -> (Vec<serde_json::Value>, i32) {
    let out = common::sonarproj()
        .args([
            "mask",
            "--from",
            "paper-fls",
            "--to",
            "paper-sss",
            "--backend",
            "cpu",
        ])
        .arg("--stream")
        .write_stdin(input)
        .output()
        .unwrap();
    let replies = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    (replies, out.status.code().unwrap())
}

#[test]
fn a_bad_stream_line_gets_its_error_and_the_stream_goes_on() {
    let good = br#"{"pose": {"pitch": 90, "translation": [15, 0, 0]}, "features": [[5, 10]]}"#;
    let mut input = Vec::new();
    input.extend_from_slice(good);
    input.extend_from_slice(b"\n{\"pitch\": \xff\xfe}\n");
    // A line far past the limit: answered with an error, not read into memory whole.
    input.extend(std::iter::repeat_n(b' ', 5 << 20));
    input.extend_from_slice(b"\n");
    input.extend_from_slice(good);
    input.extend_from_slice(b"\n");
    let (replies, code) = stream(input);
    assert_eq!(replies.len(), 4, "{replies:?}");
    assert!(replies[0].get("features").is_some(), "{}", replies[0]);
    assert!(
        replies[1]["error"].as_str().unwrap().contains("UTF-8"),
        "{}",
        replies[1]
    );
    assert!(
        replies[2]["error"].as_str().unwrap().contains("longer than"),
        "{}",
        replies[2]
    );
    assert_eq!(replies[3]["line"], 4);
    assert!(
        replies[3].get("features").is_some(),
        "the line after the bad ones is answered"
    );
    assert_eq!(code, 2, "bad lines make the exit status 2");
}

#[test]
fn values_that_would_overflow_or_mean_nothing_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let far = dir.path().join("far.toml");
    std::fs::write(
        &far,
        "kind = \"sss\"\nrange_min = 0.1\nrange_max = 1e308\nazimuth_aperture = 1.0\n\
         elevation_aperture = 60.0\nrange_bins = 100\nbeams = 1\n",
    )
    .unwrap();
    common::sonarproj()
        .args(["project", "--from", "paper-fls", "--to"])
        .arg(&far)
        .args(["--range", "5", "--pitch", "90", "--place-range", "15"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("range_max").and(predicates::str::contains("10000")));
    // An imaging sonar's feature needs its azimuth: not read as 0.
    common::sonarproj()
        .args([
            "mask",
            "--from",
            "paper-fls",
            "--to",
            "paper-sss",
            "--pitch",
            "90",
        ])
        .args(["--place-range", "15", "--feature", "5"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("an imaging sonar measures both"));
}

/// A batch input of `rows` rows, every one valid except row `bad` (1-based), whose tz is `x`.
fn batch_rows(rows: usize, bad: usize) -> String {
    let mut text = String::from("range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n");
    for k in 1..=rows {
        let tz = if k == bad {
            "x".to_string()
        } else {
            format!("{}", k % 7)
        };
        text.push_str(&format!("{},0,0,0,90,{},15,0,{tz}\n", 2 + k % 5, k % 11));
    }
    text
}

/// Returns the arguments of `batch` over `input` (cheap sampling: the rows are many).
fn batch_of(input: &Path) -> Vec<String> {
    let args = ["batch", "--from", "paper-fls", "--to", "paper-sss", "--step", "2"];
    let args = args.iter().map(|s| s.to_string());
    args.chain(["--backend".into(), "cpu-fast".into(), "--input".into()])
        .chain([input.display().to_string()])
        .collect()
}

#[test]
fn a_bad_batch_row_stops_the_batch_after_the_rows_before_it() {
    // More rows than one chunk (16 384) before the bad one, so earlier chunks have gone out.
    let (rows, bad) = (40_000, 39_990);
    let dir = tempfile::tempdir().unwrap();
    let (input, good_input) = (dir.path().join("in.csv"), dir.path().join("good.csv"));
    std::fs::write(&input, batch_rows(rows, bad)).unwrap();
    std::fs::write(&good_input, batch_rows(bad - 1, 0)).unwrap();
    let context = format!("input row {bad} (line {})", bad + 1);

    // To stdout: the rows before the bad one are out, exit status 2, the error names the row.
    let out = common::sonarproj().args(batch_of(&input)).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(&context) && stderr.contains("tz"), "{stderr}");
    let good = common::sonarproj().args(batch_of(&good_input)).output().unwrap();
    assert!(good.status.success());
    assert_eq!(out.stdout.len(), good.stdout.len());
    assert!(
        out.stdout == good.stdout,
        "the rows before the bad one differ from a clean run"
    );
    assert_eq!(String::from_utf8_lossy(&good.stdout).lines().count(), bad);

    // To a file: nothing written.
    let output = dir.path().join("out.csv");
    common::sonarproj()
        .args(batch_of(&input))
        .arg("--output")
        .arg(&output)
        .assert()
        .code(2)
        .stderr(predicates::str::contains(context));
    assert!(!output.exists(), "a failed batch left {}", output.display());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(leftovers.len(), 2, "temporaries left: {leftovers:?}");
}

/// Runs `args` with an endless stdin that starts with `head`; returns the exit status, stderr
/// and how many bytes the command took before it stopped reading (it must not read on).
fn endless_stdin(args: &[&str], head: &[u8], filler: &[u8]) -> (Option<i32>, String, usize) {
    use std::io::Write;
    let mut child = Command::new(env!("CARGO_BIN_EXE_sonarproj"))
        .current_dir(common::repository())
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let block = filler.repeat((1 << 16) / filler.len().max(1) + 1);
    let mut sent = head.len();
    let limit = 1usize << 30;
    if stdin.write_all(head).is_ok() {
        while sent < limit && stdin.write_all(&block).is_ok() {
            sent += block.len();
        }
    }
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    (out.status.code(), stderr, sent)
}

/// `recover` of a CSV on stdin between two FLS.
const RECOVER_STDIN: [&str; 7] = [
    "recover",
    "--from",
    "paper-fls",
    "--to",
    "paper-fls",
    "--input",
    "-",
];
/// The header of a recover CSV with azimuths.
const RECOVER_HEADER: &str =
    "first_range,first_azimuth,second_range,second_azimuth,roll,pitch,yaw,tx,ty,tz\n";

#[test]
fn a_bad_first_row_or_an_endless_line_stops_reading_at_once() {
    let batch = [
        "batch",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--backend",
        "cpu",
    ];
    let header = b"range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n";
    // Row 1 is bad and endless good rows follow: the command stops at row 1, not at the end.
    let head = [&header[..], b"5,0,0,0,0,0,1,2,oops\n"].concat();
    let (code, stderr, sent) = endless_stdin(&batch, &head, b"5,0,0,0,0,0,1,2,3\n");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("input row 1 (line 2)"), "{stderr}");
    assert!(sent < 64 << 20, "{sent} bytes were read after a bad first row");
    // One endless line (no newline ever): refused at the line limit, with the row named.
    let (code, stderr, sent) = endless_stdin(&batch, header, b"1");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("input row 1") && stderr.contains("longer than"),
        "{stderr}"
    );
    assert!(sent < 64 << 20, "{sent} bytes were read into one line");
    // The same for recover's CSV.
    let (code, stderr, sent) = endless_stdin(&RECOVER_STDIN, RECOVER_HEADER.as_bytes(), b"\0");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("longer than"), "{stderr}");
    assert!(sent < 64 << 20, "{sent} bytes were read into one line");
}

#[test]
fn a_bad_recover_row_stops_after_the_rows_before_it() {
    let row = "8,5,8.5,-3,0,0,20,1,0.5,0\n";
    let input = format!("{RECOVER_HEADER}{row}{row}-8,5,8.5,-3,0,0,20,1,0.5,0\n{row}");
    let out = common::sonarproj()
        .args(RECOVER_STDIN)
        .write_stdin(input.clone())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("input row 3 (line 4)") && stderr.contains("first range"),
        "{stderr}"
    );
    // Rows 1 and 2 are out (each has two candidates), row 4 is not.
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(stdout.lines().count(), 1 + 2 * 2, "{stdout}");
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.csv");
    common::sonarproj()
        .args(RECOVER_STDIN)
        .arg("--output")
        .arg(&output)
        .write_stdin(input)
        .assert()
        .code(2);
    assert!(!output.exists());
}

#[test]
fn outputs_never_reach_the_runs_inputs_through_links() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // merge: sweep.csv a link to a shard it reads.
    std::fs::write(
        d.join("s.toml"),
        "from = \"paper-fls\"\nto = \"paper-sss\"\nstep = 0.5\n[feature]\nrange = 5\n\
         [place]\nrange = { start = 2, stop = 18, step = 4 }\n",
    )
    .unwrap();
    for k in ["1/2", "2/2"] {
        common::sonarproj()
            .current_dir(d)
            .args([
                "sweep",
                "--config",
                "s.toml",
                "--out",
                "out",
                "--backend",
                "cpu-fast",
                "--shard",
                k,
            ])
            .assert()
            .success();
    }
    let shard = std::fs::read(d.join("out/shard-1-of-2.csv")).unwrap();
    std::os::unix::fs::symlink("shard-1-of-2.csv", d.join("out/sweep.csv")).unwrap();
    let out = common::sonarproj()
        .current_dir(d)
        .args(["merge", "out"])
        .assert()
        .code(2)
        .get_output()
        .clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("is the input file") && err.contains("shard-1-of-2.csv"),
        "{err}"
    );
    assert_eq!(std::fs::read(d.join("out/shard-1-of-2.csv")).unwrap(), shard);

    // A sweep's pose list inside its own output directory, named as its table.
    std::fs::create_dir(d.join("listed")).unwrap();
    let poses = std::fs::read(common::repository().join("data/example-poses.csv")).unwrap();
    std::fs::write(d.join("listed/sweep.csv"), &poses).unwrap();
    std::fs::write(
        d.join("list.toml"),
        "from = \"paper-fls\"\nto = \"paper-sss\"\nposes = \"listed/sweep.csv\"\n",
    )
    .unwrap();
    let out = common::sonarproj()
        .current_dir(d)
        .args([
            "sweep",
            "--config",
            "list.toml",
            "--out",
            "listed",
            "--backend",
            "cpu-fast",
        ])
        .assert()
        .code(2)
        .get_output()
        .clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("is the input file"), "{err}");
    assert_eq!(std::fs::read(d.join("listed/sweep.csv")).unwrap(), poses);

    // An output path that is a loop of links: refused, both links kept.
    std::os::unix::fs::symlink("b.csv", d.join("a.csv")).unwrap();
    std::os::unix::fs::symlink("a.csv", d.join("b.csv")).unwrap();
    let out = common::sonarproj()
        .args(batch_to(&d.join("a.csv")))
        .assert()
        .code(2)
        .get_output()
        .clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("leads to no file"), "{err}");
    assert!(d.join("a.csv").is_symlink() && d.join("b.csv").is_symlink());
}
