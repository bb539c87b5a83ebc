//! The `mask` command: its JSON, PNG and NPY describe the library's masks, its pictures follow the
//! picture convention, its stream answers every line, and bad input names the option.

use serde_json::Value;
use sonarproj::masks::{Counts, MaskEngine, run_lengths};
use sonarproj::{Measurement, RelativePose, Rotation, Sonar};
use sonarproj_testkit::{Picture, sonarproj};

const PAIR: [&str; 4] = ["--from", "holoocean-sidescan", "--to", "holoocean-imaging"];
/// The CPU engine, which [`library`] uses too: on a hardware GPU `auto` draws on the GPU,
/// whose masks hold the CPU's but may be a pixel wider (its f32 slack), so comparing the
/// two bit for bit needs the same engine on both sides.
const CPU: [&str; 2] = ["--backend", "cpu"];
const POSE: [&str; 6] = ["--pitch", "5", "--yaw", "10", "--translation", "0.3,0.2,-0.1"];

/// Returns the pose of pitch 5°, yaw `yaw` and translation (0.3, 0.2, -0.1) m, and the
/// sidescan features of ranges `features`: the tests' pings.
fn ping(yaw: f64, features: &[f64]) -> (RelativePose, Vec<Measurement>) {
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: 0.0,
            pitch: 5.0,
            yaw,
        },
        [0.3, 0.2, -0.1],
    )
    .unwrap();
    let ms = features
        .iter()
        .map(|&r| Measurement {
            range: r,
            azimuth: 0.0,
        })
        .collect();
    (pose, ms)
}

/// Returns the library's masks for the same pose and features as the CLI calls below.
fn library(features: &[f64]) -> Vec<sonarproj::Occupancy> {
    let engine = MaskEngine::new(
        Sonar::preset("holoocean-sidescan").unwrap(),
        Sonar::preset("holoocean-imaging").unwrap(),
    )
    .unwrap();
    let (pose, ms) = ping(10.0, features);
    engine
        .masks(&pose, &ms, None, Counts::Skip)
        .unwrap()
        .masks
        .into_iter()
        .map(|m| m.occupancy)
        .collect()
}

#[test]
fn json_png_and_npy_describe_the_same_masks() {
    let dir = tempfile::tempdir().unwrap();
    let (png, npy) = (dir.path().join("m.png"), dir.path().join("m.npy"));
    let out = sonarproj()
        .arg("mask")
        .args(PAIR)
        .args(CPU)
        .args(POSE)
        .args(["--feature", "4", "--feature", "7.5", "--json", "--out"])
        .arg(&png)
        .arg("--npy")
        .arg(&npy)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: Value = serde_json::from_slice(&out).unwrap();
    let want = library(&[4.0, 7.5]);
    let f = v["features"].as_array().unwrap();
    assert_eq!(f.len(), 2);
    for (k, occ) in want.iter().enumerate() {
        assert_eq!(f[k]["occupied"].as_u64().unwrap(), occ.count());
        assert!(occ.count() > 0, "feature {k} should be seen in this pose");
        let b = &f[k]["bounding_box"];
        // The sidescan feature at range R lies near range R in the imaging sonar here.
        let r = [4.0, 7.5][k];
        assert!(
            b["range_min"].as_f64().unwrap() < r && b["range_max"].as_f64().unwrap() > r - 0.5,
            "{b}"
        );
    }
    let bytes = std::fs::read(&npy).unwrap();
    let arr = npyz::NpyFile::new(bytes.as_slice()).unwrap();
    assert_eq!(arr.shape(), &[2, 512, 512]);
    let data: Vec<u8> = arr.into_vec().unwrap();
    for (k, occ) in want.iter().enumerate() {
        assert_eq!(
            &data[k * 512 * 512..(k + 1) * 512 * 512],
            occ.to_bytes(false, false).as_slice()
        );
    }
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
}

/// Runs `mask` from `sonar` to itself with no motion for `features`, writing the PNG to
/// `png`, and reads it back.
fn picture_in_place(sonar: &str, features: &[&str], png: &std::path::Path) -> Picture {
    let mut cmd = sonarproj();
    cmd.args(["mask", "--from", sonar, "--to", sonar, "--translation", "0,0,0"])
        .args(CPU);
    for f in features {
        cmd.args(["--feature", f]);
    }
    cmd.arg("--out").arg(png).assert().success();
    Picture::read(png)
}

#[test]
fn png_shows_port_on_the_left_and_near_range_at_the_bottom() {
    // Sonar 2 is sonar 1: each feature's mask lies where the feature is. +azimuth is +y,
    // port; holoocean-imaging reaches 10 m (±60°), so 2 m is near and 8 m far.
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("m.png");
    for (feature, port, near) in [
        ("2,30", true, true),
        ("8,-30", false, false),
        ("8,40", true, false),
        ("3,-45", false, true),
    ] {
        let pic = picture_in_place("holoocean-imaging", &[feature], &png);
        let panels = pic.panels();
        assert_eq!(panels.len(), 2, "the fan and the raw layout: {panels:?}");
        for (p, name) in panels.iter().zip(["fan", "raw layout"]) {
            pic.assert_side(*p, Some(port), near, &format!("{name}, feature {feature}"));
        }
    }
    // A sidescan target: vertical strips (the feature's, then the union), near range low.
    for (feature, near) in [("5", true), ("30", false)] {
        let pic = picture_in_place("holoocean-sidescan", &[feature], &png);
        let panels = pic.panels();
        assert!(panels.len() >= 2, "{panels:?}");
        for p in &panels[..2] {
            assert!(p.y1 - p.y0 > 3 * (p.x1 - p.x0), "vertical: {p:?}");
            pic.assert_side(*p, None, near, &format!("strip, feature {feature}"));
        }
    }
}

#[test]
fn the_stream_answers_every_line_and_names_bad_ones() {
    let input = [
        r#"{"pose": {"pitch": 5, "yaw": 10, "translation": [0.3, 0.2, -0.1]}, "features": [[4], [7.5]]}"#,
        r#"{"pose": {"pitch": 5, "yaw": 10, "translation": [0.3, 0.2, -0.1]}, "features": [[400]]}"#,
        r#"{"pose": {"pitch": 5, "yaw": 10, "translation": [0.3, 0.2, -0.1]}, "features": [[4]], "sigma": {"rotation": 0.5, "range": 0.05, "coverage": 0.95}}"#,
        r#"{"pose": {"pitch": 5}, "features": [[4]]}"#,
        r#"{"pose": {"pitch": "five", "translation": [0.3, 0.2, -0.1]}, "features": [[4]]}"#,
    ]
    .join("\n");
    let assert = sonarproj()
        .arg("mask")
        .args(PAIR)
        .args(CPU)
        .arg("--stream")
        .write_stdin(input)
        .assert()
        .code(2);
    let out = String::from_utf8(assert.get_output().stdout.clone()).unwrap();
    let lines: Vec<Value> = out.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 5);
    let want = library(&[4.0, 7.5]);
    for (k, occ) in want.iter().enumerate() {
        let runs: Vec<[u64; 2]> = serde_json::from_value(lines[0]["features"][k]["runs"].clone()).unwrap();
        assert_eq!(runs, run_lengths(occ));
    }
    assert!(lines[0]["elapsed_ms"].as_f64().unwrap() >= 0.0);
    assert!(
        lines[1]["error"].as_str().unwrap().contains("features[0]"),
        "{}",
        lines[1]
    );
    // Widened: a superset of the plain mask.
    let widened = lines[2]["features"][0]["occupied"].as_u64().unwrap();
    assert!(widened > want[0].count(), "{widened} vs {}", want[0].count());
    assert!(
        lines[3]["error"].as_str().unwrap().contains("translation"),
        "{}",
        lines[3]
    );
    assert_eq!(lines[3]["line"], 4);
    // The parser's whole message (what it expected, and where), and the line's form for a
    // sidescan's features (a range each).
    let bad = lines[4]["error"].as_str().unwrap();
    assert!(
        bad.contains(r#"invalid type: string "five", expected f64 at line 1 column"#),
        "{bad}"
    );
    assert!(bad.contains(r#""features": [[R], …]"#), "{bad}");
}

/// `--stream --no-runs` answers with the masks' summaries (reduced by `MaskEngine::summary`):
/// the same counts, boxes and union as the full answer, without the per-feature runs.
#[test]
fn the_stream_without_runs_says_the_same_of_each_feature() {
    let input = [
        r#"{"pose": {"pitch": 5, "yaw": 10, "translation": [0.3, 0.2, -0.1]}, "features": [[4], [7.5], [35]]}"#,
        r#"{"pose": {"pitch": 5, "yaw": 10, "translation": [0.3, 0.2, -0.1]}, "features": [[4]], "sigma": {"rotation": 0.5, "range": 0.05, "coverage": 0.95}}"#,
    ]
    .join("\n");
    let answers = |extra: &[&str]| -> Vec<Value> {
        let assert = sonarproj()
            .arg("mask")
            .args(PAIR)
            .args(CPU)
            .arg("--stream")
            .args(extra)
            .write_stdin(input.clone())
            .assert()
            .success();
        let out = String::from_utf8(assert.get_output().stdout.clone()).unwrap();
        out.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
    };
    let (full, reduced) = (answers(&[]), answers(&["--no-runs"]));
    assert_eq!(full.len(), 2);
    for (f, r) in full.iter().zip(&reduced) {
        assert_eq!(f["union_runs"], r["union_runs"]);
        assert_eq!(f["union_occupied"], r["union_occupied"]);
        for (ff, rf) in f["features"]
            .as_array()
            .unwrap()
            .iter()
            .zip(r["features"].as_array().unwrap())
        {
            for key in [
                "occupied",
                "bounding_box",
                "radius",
                "noise_radius",
                "cells",
                "range",
            ] {
                assert_eq!(ff[key], rf[key], "{key}");
            }
            assert!(ff.get("runs").is_some() && rf.get("runs").is_none());
        }
    }
    // The third feature (35 m) is beyond the imaging sonar: an empty mask, no box.
    assert_eq!(reduced[0]["features"][2]["occupied"], 0);
    assert!(reduced[0]["features"][2]["bounding_box"].is_null());
    assert!(reduced[0]["features"][0]["occupied"].as_u64().unwrap() > 100);
}

/// A stream whose lines arrive faster than they are drawn (all of stdin at once): the pings
/// waiting are drawn together (two in flight on a GPU), and every line still gets its own
/// answer, in line order, the one the library gives that ping alone — with runs and without,
/// on the CPU and on the GPU, a bad line and a line with another noise among them.
#[test]
fn a_stream_of_waiting_pings_answers_each_in_order() {
    let (s1, s2) = (
        Sonar::preset("holoocean-sidescan").unwrap(),
        Sonar::preset("holoocean-imaging").unwrap(),
    );
    let line_ping = |k: usize| {
        let yaw = 5.0 + (k % 17) as f64;
        let features = vec![4.0 + 0.1 * (k % 5) as f64, 7.5];
        (yaw, features)
    };
    let mut input = Vec::new();
    for k in 0..150 {
        let (yaw, features) = line_ping(k);
        let fs: Vec<String> = features.iter().map(|r| format!("[{r}]")).collect();
        let sigma = if k == 80 {
            r#", "sigma": {"rotation": 0.5, "range": 0.05, "coverage": 0.95}"#
        } else {
            ""
        };
        input.push(if k == 50 {
            "{not json".to_string()
        } else {
            format!(
                r#"{{"pose": {{"pitch": 5, "yaw": {yaw}, "translation": [0.3, 0.2, -0.1]}}, "features": [{}]{sigma}}}"#,
                fs.join(", ")
            )
        });
    }
    let input = input.join("\n");
    let gpu = sonarproj_testkit::gpu_context();
    let mut engines = vec![("cpu", MaskEngine::new(s1.clone(), s2.clone()).unwrap())];
    if let Some(ctx) = gpu {
        engines.push(("gpu", MaskEngine::on_gpu(s1.clone(), s2.clone(), ctx).unwrap()));
    }
    for (backend, engine) in &engines {
        for extra in [&[][..], &["--no-runs"][..]] {
            let assert = sonarproj()
                .arg("mask")
                .args(PAIR)
                .args(["--backend", backend, "--stream"])
                .args(extra)
                .write_stdin(input.clone())
                .assert()
                .code(2);
            let out = String::from_utf8(assert.get_output().stdout.clone()).unwrap();
            let lines: Vec<Value> = out.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
            assert_eq!(lines.len(), 150, "{backend} {extra:?}");
            for (k, reply) in lines.iter().enumerate() {
                assert_eq!(reply["line"], k + 1, "{backend} {extra:?}");
                if k == 50 {
                    assert!(reply["error"].is_string(), "{reply}");
                    continue;
                }
                if k == 80 {
                    assert!(reply["features"][0]["noise_radius"].as_f64().unwrap() > 0.0);
                    continue;
                }
                let (yaw, features) = line_ping(k);
                let (pose, ms) = ping(yaw, &features);
                let want = engine.masks(&pose, &ms, None, Counts::Skip).unwrap();
                assert_eq!(
                    reply["union_occupied"],
                    want.union.count(),
                    "{backend} line {}",
                    k + 1
                );
                assert_eq!(
                    reply["union_runs"],
                    serde_json::to_value(run_lengths(&want.union)).unwrap()
                );
                for (f, m) in want.masks.iter().enumerate() {
                    assert_eq!(reply["features"][f]["occupied"], m.occupancy.count());
                    if extra.is_empty() {
                        assert_eq!(
                            reply["features"][f]["runs"],
                            serde_json::to_value(run_lengths(&m.occupancy)).unwrap()
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn bad_mask_input_names_the_option() {
    for (args, needle) in [
        (vec!["--feature", "50"], "--feature 1"),
        (vec!["--feature", "5", "--feature", "5,1,2"], "--feature 2"),
        (vec!["--feature", "5", "--sigma-rotation", "-1"], "sigma roll"),
        // Noise so wide that its radius overflows is bad input, not a null radius.
        (
            vec!["--feature", "5", "--sigma-rotation", "1e308"],
            "sigma roll = 1e308",
        ),
        (
            vec!["--feature", "5", "--sigma-translation", "1e308"],
            "sigma tx = 1e308",
        ),
        (
            vec!["--feature", "5", "--sigma-range", "1e308"],
            "sigma range = 1e308",
        ),
        (
            vec!["--feature", "5", "--sigma-range", "0.1", "--coverage", "1"],
            "coverage",
        ),
        (vec!["--feature", "5", "--out", "x.jpg"], "--out"),
        // Without any sigma the coverage means nothing, but a bad one is still refused.
        (vec!["--feature", "5", "--coverage", "NaN"], "--coverage"),
        (vec!["--feature", "5", "--coverage", "inf"], "--coverage"),
        (vec!["--feature", "5", "--coverage", "0"], "--coverage"),
        (vec!["--feature", "5", "--coverage", "1.5"], "--coverage"),
        // A sidescan measures no azimuth: one given is refused, not dropped.
        (vec!["--feature", "4,5"], "a sidescan measures no azimuth"),
    ] {
        let assert = sonarproj()
            .arg("mask")
            .args(PAIR)
            .args(POSE)
            .args(&args)
            .assert()
            .code(2);
        let err = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
        assert!(err.contains(needle), "{args:?}: expected {needle:?} in {err}");
    }
}

/// Returns an NPY file's bytes: a 2-D array of `descr` ("|u1", "<f4") in C or Fortran order.
fn npy(descr: &str, fortran: bool, shape: (usize, usize), data: &[u8]) -> Vec<u8> {
    let mut header = format!(
        "{{'descr': '{descr}', 'fortran_order': {}, 'shape': ({}, {}), }}",
        if fortran { "True" } else { "False" },
        shape.0,
        shape.1
    );
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend(u16::try_from(header.len()).unwrap().to_le_bytes());
    out.extend(header.as_bytes());
    out.extend(data);
    out
}

/// Returns the RGB pixel at `(x, y)` of the PNG at `path`.
fn pixels(path: &std::path::Path) -> impl Fn(usize, usize) -> [u8; 3] {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    let mut rgb = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut rgb).unwrap();
    let w = info.width as usize;
    move |x, y| {
        let k = (y * w + x) * 3;
        [rgb[k], rgb[k + 1], rgb[k + 2]]
    }
}

#[test]
fn the_picture_is_drawn_over_the_ping_image_beside_the_sonar_file() {
    // An imaging sonar 2 as `sonar from-oculus` leaves it: DIR/sonar.toml and DIR/image.npy, the
    // image bright on the port half (beams 16–31, +azimuth) and black on the starboard half.
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("sonar.toml");
    std::fs::write(
        &toml,
        "kind = \"fls\"\nrange_min = 0.5\nrange_max = 5.0\nazimuth_aperture = 60.0\n\
         elevation_aperture = 12.0\nrange_bins = 40\nbeams = 32\n",
    )
    .unwrap();
    let (rows, beams) = (40, 32);
    let bright = |j: usize| if j >= beams / 2 { 255u8 } else { 0 };
    let c_order: Vec<u8> = (0..rows * beams).map(|k| bright(k % beams)).collect();
    std::fs::write(
        dir.path().join("image.npy"),
        npy("|u1", false, (rows, beams), &c_order),
    )
    .unwrap();
    // The same image as float32 in Fortran order (columns one after the other), elsewhere.
    let f_order: Vec<u8> = (0..rows * beams)
        .flat_map(|k| f32::from(bright(k / rows)).to_le_bytes())
        .collect();
    let other = dir.path().join("frame.npy");
    std::fs::write(&other, npy("<f4", true, (rows, beams), &f_order)).unwrap();
    let run = |png: &std::path::Path, extra: &[&std::ffi::OsStr]| {
        sonarproj()
            .args(["mask", "--from", "paper-sss", "--to"])
            .arg(&toml)
            .args([
                "--translation",
                "0,0,0",
                "--feature",
                "20",
                "--backend",
                "cpu",
                "--out",
            ])
            .arg(png)
            .args(extra)
            .assert()
            .success();
    };
    let plain = dir.path().join("plain.png");
    run(&plain, &["--no-image".as_ref()]);
    // The raw panel, the light grey of the empty field of view without an image.
    let panels = Picture::read(&plain).panels();
    assert_eq!(panels.len(), 2, "{panels:?}");
    let raw = panels[1];
    let (left, right, mid) = (
        raw.x0 + (raw.x1 - raw.x0) / 4,
        raw.x1 - (raw.x1 - raw.x0) / 4,
        (raw.y0 + raw.y1) / 2,
    );
    let over = dir.path().join("over.png");
    run(&over, &[]);
    let explicit = dir.path().join("explicit.png");
    run(&explicit, &["--image".as_ref(), other.as_os_str()]);
    for png in [&over, &explicit] {
        let px = pixels(png);
        // Port, the bright half, on the left of the raw panel; starboard, black, on the right.
        assert_eq!(px(left, mid), [255, 255, 255], "{}", png.display());
        assert_eq!(px(right, mid), [0, 0, 0], "{}", png.display());
    }
    // An image of another shape, or under a sidescan's masks, is refused naming --image.
    let wrong = dir.path().join("wrong.npy");
    std::fs::write(
        &wrong,
        npy("|u1", false, (rows, beams + 1), &vec![0; rows * (beams + 1)]),
    )
    .unwrap();
    for (to, needle) in [
        (toml.as_os_str(), "shape (40, 33)"),
        ("paper-sss".as_ref(), "sidescan"),
    ] {
        let assert = sonarproj()
            .args(["mask", "--from", "paper-sss", "--to"])
            .arg(to)
            .args([
                "--translation",
                "0,0,0",
                "--feature",
                "20",
                "--backend",
                "cpu",
                "--image",
            ])
            .arg(&wrong)
            .arg("--out")
            .arg(dir.path().join("no.png"))
            .assert()
            .code(2);
        let err = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
        assert!(err.contains("--image") && err.contains(needle), "{err}");
    }
    // A FIFO given as --image is refused unread (no writer ever comes: it must not wait).
    let fifo = dir.path().join("fifo.npy");
    sonarproj_testkit::mkfifo(&fifo);
    let assert = sonarproj()
        .args(["mask", "--from", "paper-sss", "--to"])
        .arg(&toml)
        .args([
            "--translation",
            "0,0,0",
            "--feature",
            "20",
            "--backend",
            "cpu",
            "--image",
        ])
        .arg(&fifo)
        .arg("--out")
        .arg(dir.path().join("no.png"))
        .timeout(std::time::Duration::from_secs(60))
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
    assert!(
        err.contains("fifo.npy") && err.contains("not a regular file"),
        "{err}"
    );
    assert!(!dir.path().join("no.png").exists());
}
