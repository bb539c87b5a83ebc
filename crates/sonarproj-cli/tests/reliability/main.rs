//! Reliability from the outside: what the binary does with special output files, symlinks, bad
//! output paths, bad lines in a stream and bad rows in long CSV inputs (docs/reliability.md).
//! Inputs — bad, endless, or the same file as an output — are `inputs`.

mod inputs;
mod state;

use sonarproj_testkit as common;

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
    common::mkfifo(&fifo);
    let reader = common::read_fifo(&fifo);
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

#[test]
fn a_single_file_output_creates_its_folder_as_a_directory_output_does() {
    let dir = tempfile::tempdir().unwrap();
    // Missing folders are created, as `--out DIR` creates its directory.
    let nested = dir.path().join("new/deeper/metrics.csv");
    common::sonarproj().args(batch_to(&nested)).assert().success();
    assert!(std::fs::read_to_string(&nested).unwrap().starts_with("range,"));
    // A run that fails while writing leaves no folder behind: its file is written whole or not
    // at all, and so are the folders made for it.
    let input = dir.path().join("poses.csv");
    std::fs::write(
        &input,
        "range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n5,0,0,0,0,0,1,0,0\n5,0,0,0,0,0,1,0,abc\n",
    )
    .unwrap();
    let refused = dir.path().join("other/sub/metrics.csv");
    common::sonarproj()
        .args([
            "batch",
            "--from",
            "paper-fls",
            "--to",
            "paper-sss",
            "--backend",
            "cpu-fast",
            "--input",
        ])
        .arg(&input)
        .arg("--output")
        .arg(&refused)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("row 2"));
    assert!(!dir.path().join("other").exists(), "a failed run left its folder");
    // A file in the way of the folder is bad input, named, and stays as it was.
    let file = dir.path().join("results");
    std::fs::write(&file, "keep me").unwrap();
    common::sonarproj()
        .args(batch_to(&file.join("metrics.csv")))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("is a file, not a directory"));
    let mask = file.join("sub/m.png");
    common::sonarproj()
        .args([
            "mask",
            "--from",
            "paper-sss",
            "--to",
            "paper-fls",
            "--translation",
            "1,0,0",
            "--feature",
            "5",
            "--out",
        ])
        .arg(&mask)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("is a file, not a directory"));
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
