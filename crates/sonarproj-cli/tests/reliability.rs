//! Reliability from the outside: what the binary does with special output files, symlinks, bad
//! output paths, bad lines in a stream and bad rows in long CSV inputs (README: Reliability).

use sonarproj_testkit as common;

use std::io::Read;

use predicates::prelude::*;
use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::Command;

/// Returns the arguments of a small `batch` run writing to `out`.
fn batch_to(out: &Path) -> Vec<String> {
    [
        "batch",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--backend",
        "cpu-fast",
        "--input",
        "data/example-poses.csv",
        "--output",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain([out.display().to_string()])
    .collect()
}

/// Returns whether this process runs as root (device nodes can be created).
fn is_root() -> bool {
    let out = Command::new("id").arg("-u").output().unwrap();
    String::from_utf8_lossy(&out.stdout).trim() == "0"
}

#[test]
fn a_fifo_is_written_through_and_stays_a_fifo() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("out.fifo");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let mut text = String::new();
            std::fs::File::open(fifo)
                .unwrap()
                .read_to_string(&mut text)
                .unwrap();
            text
        })
    };
    common::sonarproj().args(batch_to(&fifo)).assert().success();
    // Checked before joining: a replaced FIFO would leave the reader waiting for a writer.
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(kind.is_fifo(), "the FIFO was replaced by {kind:?}");
    let text = reader.join().unwrap();
    assert!(text.starts_with("range,"), "{text}");
    assert!(text.lines().count() > 2, "every row came through the FIFO");
    let stray: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(stray.len(), 1, "no temporary file left beside it");
}

#[test]
fn device_nodes_are_written_through_and_never_replaced() {
    if !is_root() {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI must run this test as root (it creates device nodes)"
        );
        eprintln!("SKIPPED: creating device nodes needs root");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // The test's own device nodes, never the system's /dev: 1,3 is null, 1,7 is full.
    let null = dir.path().join("null");
    let full = dir.path().join("full");
    for (node, minor) in [(&null, "3"), (&full, "7")] {
        let ok = Command::new("mknod")
            .arg(node)
            .args(["c", "1", minor])
            .status()
            .unwrap();
        assert!(ok.success(), "mknod {}", node.display());
    }
    common::sonarproj().args(batch_to(&null)).assert().success();
    common::sonarproj()
        .args(batch_to(&full))
        .assert()
        .code(1)
        .stderr(predicates::str::contains("No space left on device"));
    for node in [&null, &full] {
        let kind = std::fs::symlink_metadata(node).unwrap().file_type();
        assert!(kind.is_char_device(), "{} became {kind:?}", node.display());
    }
    let stray: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(stray.len(), 2, "no temporary file left beside them");
}

#[test]
fn a_symlink_is_followed_and_its_file_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let real = dir.path().join("real.csv");
    let link = dir.path().join("link.csv");
    std::fs::write(&real, "old contents\n").unwrap();
    std::os::unix::fs::symlink("real.csv", &link).unwrap();
    common::sonarproj().args(batch_to(&link)).assert().success();
    assert!(
        std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(),
        "the link stays"
    );
    let text = std::fs::read_to_string(&real).unwrap();
    assert!(
        text.starts_with("range,"),
        "the file it names holds the output: {text}"
    );
    // A dangling link: the file is created where it points.
    let new_link = dir.path().join("new-link.csv");
    std::os::unix::fs::symlink("created.csv", &new_link).unwrap();
    common::sonarproj().args(batch_to(&new_link)).assert().success();
    assert!(
        std::fs::read_to_string(dir.path().join("created.csv"))
            .unwrap()
            .starts_with("range,")
    );
}

#[test]
fn an_empty_or_directory_output_path_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    common::sonarproj()
        .args(batch_to(Path::new("")))
        .assert()
        .code(2)
        .stderr(predicates::str::contains("output path"));
    common::sonarproj()
        .args(batch_to(dir.path()))
        .assert()
        .code(2)
        .stderr(predicates::str::contains("is a directory"));
}

#[test]
fn one_pose_of_the_finest_sampling_runs_in_bounded_memory() {
    // 66.5 million samples in one pose (the limit is 2^26): tables of the whole plan took 5 GB
    // and a 2 GB address-space limit aborted the process. Tiles keep it near 100 MB; here it
    // runs under a 768 MiB limit (two threads, so the limit measures the engine and not the
    // machine's core count; the arena variable matters only under glibc's allocator).
    let binary = assert_cmd::cargo::cargo_bin!("sonarproj");
    let out = Command::new("sh")
        .args(["-c", "ulimit -v 786432 && exec \"$0\" \"$@\""])
        .arg(binary)
        .args([
            "project",
            "--from",
            "holoocean-sidescan",
            "--to",
            "oculus-m750d",
            "--range",
            "20",
            "--place-range",
            "20",
            "--step",
            "0.0008",
            "--backend",
            "cpu-fast",
        ])
        .env("RAYON_NUM_THREADS", "2")
        .env("MALLOC_ARENA_MAX", "2")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let metrics = &json["metrics"];
    assert!(metrics["total"].as_u64().unwrap() > 60_000_000, "{metrics}");
    assert!(metrics["visible"].as_u64().unwrap() > 0, "{metrics}");
}

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
fn a_refused_run_leaves_nothing_that_blocks_the_corrected_one() {
    let dir = tempfile::tempdir().unwrap();
    let example = std::fs::read_to_string(common::repository().join("data/example-sweep.toml")).unwrap();
    assert!(
        example.contains("step = 0.1 "),
        "the example sweep's step line changed"
    );
    let good = dir.path().join("good.toml");
    std::fs::write(&good, &example).unwrap();
    // 120 000 001 samples per pose: more than a pose may draw.
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, example.replacen("step = 0.1 ", "step = 0.0000001 ", 1)).unwrap();
    let out = dir.path().join("out");
    common::sonarproj()
        .args(["sweep", "--backend", "cpu-fast", "--config"])
        .arg(&bad)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("samples per pose"));
    assert!(!out.exists(), "a refused sweep created {}", out.display());
    common::sonarproj()
        .args(["sweep", "--backend", "cpu-fast", "--config"])
        .arg(&good)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    assert!(out.join("sweep.csv").is_file());

    let paper = dir.path().join("paper");
    common::sonarproj()
        .args(["paper", "--backend", "cpu-fast", "--step", "0.0000001", "--out"])
        .arg(&paper)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("samples per pose"));
    assert!(!paper.exists(), "a refused paper run created {}", paper.display());
}

#[test]
fn a_file_given_as_an_output_directory_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("results");
    std::fs::write(&file, "keep me").unwrap();
    let not_a_dir = predicates::str::contains("is a file, not a directory");
    common::sonarproj()
        .args(["sweep", "--config", "data/example-sweep.toml", "--out"])
        .arg(&file)
        .assert()
        .code(2)
        .stderr(not_a_dir.clone());
    common::sonarproj()
        .args(["paper", "--angle-step", "30", "--out"])
        .arg(&file)
        .assert()
        .code(2)
        .stderr(not_a_dir.clone());
    // A directory to create under that file is bad input too.
    common::sonarproj()
        .args(["paper", "--angle-step", "30", "--out"])
        .arg(file.join("figures/new"))
        .assert()
        .code(2)
        .stderr(not_a_dir);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");
}

/// Returns this host's name as temporary file names carry it.
fn host() -> String {
    let out = Command::new("uname").arg("-n").output().unwrap();
    String::from_utf8(out.stdout)
        .unwrap()
        .trim()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Returns the names of the files in `dir` that start with `.sonarproj-`.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".sonarproj-"))
        .collect()
}

#[test]
fn a_signal_during_a_write_removes_the_temporary() {
    use std::io::Write;
    use std::os::unix::process::ExitStatusExt;
    for (signal, number) in [("TERM", 15), ("INT", 2), ("HUP", 1)] {
        let dir = tempfile::tempdir().unwrap();
        let output = dir.path().join("out.csv");
        let mut child = Command::new(env!("CARGO_BIN_EXE_sonarproj"))
            .current_dir(common::repository())
            .args(["batch", "--from", "paper-fls", "--to", "paper-sss", "--step", "2"])
            .args(["--backend", "cpu-fast", "--input", "-", "--output"])
            .arg(&output)
            .stdin(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // More than one chunk of rows, and stdin left open: the command is mid-write.
        let mut stdin = child.stdin.take().unwrap();
        stdin
            .write_all(b"range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n")
            .unwrap();
        stdin.write_all(&b"5,0,0,0,90,0,15,0,0\n".repeat(20_000)).unwrap();
        stdin.flush().unwrap();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
        while temporaries(dir.path()).is_empty() {
            assert!(std::time::Instant::now() < deadline, "no temporary appeared");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let temp = temporaries(dir.path()).remove(0);
        let pid = child.id().to_string();
        assert!(
            temp.starts_with(&format!(".sonarproj-{}-{pid}-", host())),
            "{temp}"
        );
        Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(&pid)
            .status()
            .unwrap();
        let status = child.wait().unwrap();
        drop(stdin);
        assert_eq!(status.signal(), Some(number), "SIG{signal}: {status:?}");
        assert!(temporaries(dir.path()).is_empty(), "SIG{signal} left {temp}");
        assert!(!output.exists(), "SIG{signal} left a partial output");
    }
}

#[test]
fn stale_temporaries_of_dead_processes_here_are_removed_and_no_others() {
    let dir = tempfile::tempdir().unwrap();
    let mut done = Command::new("true").spawn().unwrap();
    let dead = done.id();
    done.wait().unwrap();
    let mut sleeper = Command::new("sleep").arg("60").spawn().unwrap();
    let live = sleeper.id();
    let host = host();
    let stale = format!(".sonarproj-{host}-{dead}-aaaaaa.tmp");
    let kept = [
        format!(".sonarproj-{host}-{live}-bbbbbb.tmp"),
        format!(".sonarproj-other.host-{dead}-cccccc.tmp"),
        ".sonarproj-XyZ123".to_string(),
        "notes.txt".to_string(),
    ];
    for name in kept.iter().chain([&stale]) {
        std::fs::write(dir.path().join(name), "x").unwrap();
    }
    common::sonarproj()
        .args(batch_to(&dir.path().join("out.csv")))
        .assert()
        .success();
    let _ = sleeper.kill();
    let _ = sleeper.wait();
    assert!(
        !dir.path().join(&stale).exists(),
        "the dead process's temporary stayed"
    );
    for name in &kept {
        assert!(dir.path().join(name).exists(), "{name} was removed");
    }
}

#[test]
fn messages_are_plain_short_and_keep_their_lines() {
    let dir = tempfile::tempdir().unwrap();
    let stderr_of = |cmd: &mut assert_cmd::Command| {
        let out = cmd.output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{out:?}");
        String::from_utf8(out.stderr).unwrap()
    };
    // A directory given as a sonar file is called one.
    let e = stderr_of(
        common::sonarproj()
            .args(["project", "--to", "paper-sss", "--range", "5", "--from"])
            .arg(dir.path()),
    );
    assert!(e.contains("is a directory") && !e.contains("no such file"), "{e}");
    // A 100 000-byte column name is quoted as a short excerpt.
    let long = "a".repeat(100_000);
    let e = stderr_of(
        common::sonarproj()
            .args(["batch", "--from", "paper-fls", "--to", "paper-sss"])
            .write_stdin(format!("range,{long}\n")),
    );
    assert!(
        e.len() < 1_000 && e.contains("100000 bytes"),
        "{} bytes: {}",
        e.len(),
        &e[..e.len().min(300)]
    );
    // A TOML error keeps its lines (where, the line, the caret), each cut short.
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        format!("kind = \"fls\"\nrange_min = {}\n", "x".repeat(100_000)),
    )
    .unwrap();
    let e = stderr_of(
        common::sonarproj()
            .args(["project", "--to", "paper-sss", "--range", "5", "--from"])
            .arg(&bad),
    );
    assert!(e.lines().count() >= 4, "{e}");
    assert!(e.contains("line 2") && e.contains('^'), "{e}");
    assert!(e.len() < 2_000, "{} bytes", e.len());
    // Something missing is said in words, not as "X = missing is invalid".
    let e = stderr_of(common::sonarproj().args([
        "project",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--range",
        "5",
    ]));
    assert!(
        e.contains("pose: no translation given; give --place-range or --translation"),
        "{e}"
    );
    assert!(!e.contains("is invalid"), "{e}");
    let e = stderr_of(common::sonarproj().args([
        "recover",
        "--from",
        "paper-fls",
        "--to",
        "paper-sss",
        "--pitch",
        "90",
        "--place-range",
        "15",
        "--first",
        "5",
        "--second",
        "15",
    ]));
    assert!(
        e.contains("first azimuth: missing") && !e.contains("is invalid"),
        "{e}"
    );
}
