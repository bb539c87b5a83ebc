//! The programs in `examples/` run and print what they promise. `scripts/test.sh` builds them
//! (`cargo build --release --examples`: `cargo test` builds examples only as test harnesses)
//! before the tests; this test runs the built programs.

use std::path::PathBuf;
use std::process::Command;

use sonarproj_testkit as common;

/// Returns the path of the built example `name`, next to this test binary's `deps/` folder.
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    let dir = exe
        .parent()
        .and_then(|d| d.parent())
        .expect("target/<profile>/deps");
    let path = dir
        .join("examples")
        .join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    assert!(
        path.is_file(),
        "{} not built: run scripts/test.sh, or `cargo build --release --examples` before the tests",
        path.display()
    );
    path
}

/// Returns the stdout of the example `name` run with `args`, which must succeed, run as on a
/// headless machine: without `XDG_RUNTIME_DIR`, whose absence makes Mesa's device-select layer
/// print an error unless the program quiets it (with `NODEVICE_SELECT`, which the examples set
/// themselves, as the CLI does). Its stderr must carry no such noise.
fn run(name: &str, args: &[&str]) -> String {
    let out = Command::new(example(name))
        .args(args)
        .env_remove("NODEVICE_SELECT")
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .expect("the example starts");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{name} failed ({}):\n{stdout}\n{stderr}",
        out.status,
    );
    assert!(
        !stderr.contains("XDG_RUNTIME_DIR"),
        "{name} printed Mesa's noise:\n{stderr}"
    );
    stdout
}

#[test]
fn one_pose_on_every_backend_agrees() {
    let out = run("project_every_backend", &[]);
    let rows: Vec<&str> = out.lines().filter(|l| l.contains(" visible ")).collect();
    // The reference and the fast CPU path always; the GPU where an adapter exists (always in
    // CI, where the helper fails loudly without one).
    let expected = if common::gpu().is_some() { 3 } else { 2 };
    assert_eq!(rows.len(), expected, "{out}");
    // The FLS arc at 5 m seen from 15 m: every one of its 121 samples lands in the sidescan's
    // view, as the paper's placement puts the true point at its boresight.
    for row in &rows {
        assert!(row.contains("visible   121 of   121"), "{row}");
    }
    // The two f64 CPU paths print the same figures (the GPU's f32 may differ in the last digit
    // or by a bin at an edge; tests/agreement.rs bounds that).
    let tail = |r: &str| r.split_once(' ').map(|(_, t)| t.trim().to_string()).unwrap();
    assert_eq!(tail(rows[0]), tail(rows[1]), "{out}");
}

#[test]
fn a_ping_of_masks_is_written_as_npy() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ping.npy");
    let out = run("mask_ping", &[path.to_str().unwrap()]);
    assert!(out.contains("feature 3 at   12 m:     0 of"), "{out}");
    let bytes = std::fs::read(&path).expect("the NPY file");
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    // Three features, 512 range bins, 512 beams (holoocean-imaging).
    assert_eq!(npy.shape(), &[3, 512, 512]);
    let data: Vec<u8> = npy.into_vec().unwrap();
    let per_feature = 512 * 512;
    let counts: Vec<usize> = data
        .chunks(per_feature)
        .map(|m| m.iter().filter(|&&v| v == 1).count())
        .collect();
    assert!(counts[0] > 0 && counts[1] > 0 && counts[2] == 0, "{counts:?}");
    // The counts printed are the NPY's.
    for (k, c) in counts.iter().enumerate() {
        assert!(
            out.lines()
                .any(|l| l.starts_with(&format!("feature {}", k + 1)) && l.contains(&format!(" {c} of"))),
            "{out}"
        );
    }
}

#[test]
fn the_lost_elevation_is_recovered() {
    let out = run("recover_elevation", &[]);
    assert!(out.contains("candidate 1: elevation 3.000°"), "{out}");
    assert!(out.contains("recovered the planted elevation"), "{out}");
}
