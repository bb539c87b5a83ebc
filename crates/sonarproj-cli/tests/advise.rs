//! `sonarproj advise` from the outside: the documented example runs and writes its four files
//! (best.json naming the best pose, candidates.parquet with every candidate, features.csv that
//! `batch` reads back to the best pose's score, to the bit); bad advise files exit 2 naming the key
//! and the value, and leave no output directory behind.

use sonarproj_testkit as common;

const EXAMPLE: &str = "data/example-advise.toml";

#[test]
fn the_example_writes_its_files_and_batch_recomputes_the_best_score() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("advise");
    let run = common::sonarproj()
        .args(["advise", "--config", EXAMPLE, "--backend", "cpu-fast", "--out"])
        .arg(&out)
        .assert()
        .success()
        .get_output()
        .clone();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("advise: ") && err.contains("best roll"), "{err}");
    let best: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("best.json")).unwrap()).unwrap();
    let top = &best["ranked"][0];
    assert!(top["score"].as_f64().unwrap() > 0.0, "{best}");
    assert_eq!(best["metric"], "occupied_measure");
    assert!(best["next_move"]["now"]["rotation"].is_array());
    assert!(std::fs::metadata(out.join("candidates.parquet")).unwrap().len() > 1000);
    let picture = common::Picture::read(&out.join("landscape.png"));
    assert!(
        picture.w >= 800 && picture.h >= 600,
        "landscape {}x{}",
        picture.w,
        picture.h
    );
    // features.csv through `batch`: the features both sonars see, their exact arcs' pixel areas'
    // mean is the best pose's metric, to the bit.
    let metrics = dir.path().join("metrics.csv");
    common::sonarproj()
        .args([
            "batch",
            "--from",
            "paper-fls",
            "--to",
            "paper-fls",
            "--step",
            "exact",
            "--backend",
            "cpu-fast",
            "--input",
        ])
        .arg(out.join("features.csv"))
        .arg("--output")
        .arg(&metrics)
        .assert()
        .success();
    let mut rdr = csv::Reader::from_path(&metrics).unwrap();
    let headers = rdr.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = rdr.records().map(Result::unwrap).collect();
    // The best pose's features, each seen by both sonars (sonar 2's field of view checked here).
    assert_eq!(rows.len() as u64, top["features"].as_u64().unwrap());
    assert_eq!(
        shared_rows(&rows, col("range"), col("azimuth"), col("elevation"), top).len(),
        rows.len()
    );
    let area = col("occupied_measure");
    let sum: f64 = rows.iter().map(|row| row[area].parse::<f64>().unwrap()).sum();
    #[expect(clippy::cast_precision_loss, reason = "a thousand features")]
    let mean = sum / rows.len() as f64;
    assert_eq!(top["metric"]["mean"].as_f64().unwrap(), mean, "the areas by hand");
    // The score: each pool point examined costs its area when both sonars see it, else a blind
    // search of sonar 2's whole sector (paper-fls: 60 deg, 0.1-10 m).
    let blind = 60f64.to_radians() / 2.0 * (10f64.powi(2) - 0.1f64.powi(2));
    assert_eq!(best["objective"]["blind_cost"].as_f64().unwrap(), blind);
    let examined = top["examined"].as_u64().unwrap() as f64;
    let unseen = examined - rows.len() as f64;
    let cost = (rows
        .iter()
        .map(|row| row[area].parse::<f64>().unwrap().min(blind))
        .sum::<f64>()
        + unseen * blind)
        / examined;
    let score = top["score"].as_f64().unwrap();
    assert!(
        (score - cost).abs() <= 1e-12 * cost,
        "{score} against {cost} by hand"
    );
    assert_eq!(best["score_unit"], "m²");
    // The ties, the recommended pose and the Pareto front are reported.
    let tied = best["tied"].as_u64().unwrap();
    assert!(tied >= 1 && best["recommended"]["tied"] == true, "{best}");
    assert!(
        err.contains(&format!("{tied} candidate(s) tied with the best")),
        "{err}"
    );
    // The README's worked example quotes these numbers.
    let readme = std::fs::read_to_string(common::repository().join("README.md")).unwrap();
    let readme = readme.split_whitespace().collect::<Vec<_>>().join(" ");
    let quoted = [
        format!(
            "shares {:.0} % of the features",
            100.0 * top["shared"].as_f64().unwrap()
        ),
        format!("at {:.4} m² each", top["metric"]["mean"].as_f64().unwrap()),
        format!("the blind search is {blind:.2} m²"),
        format!("≈ {score:.2} m²"),
    ];
    for q in &quoted {
        assert!(readme.contains(q.as_str()), "the README should say {q:?}");
    }
    let pareto = std::fs::read_to_string(out.join("pareto.csv")).unwrap();
    assert_eq!(
        pareto.lines().count() as u64,
        1 + best["pareto"].as_u64().unwrap()
    );
    assert!(pareto.starts_with("index,roll,pitch,yaw,x,y,z,shared,shared_se,ambiguity_m²"));
}

/// Returns the rows whose true points sonar 2 (paper-fls) sees under `top`'s pose.
fn shared_rows(
    rows: &[csv::StringRecord],
    r: usize,
    az: usize,
    el: usize,
    top: &serde_json::Value,
) -> Vec<usize> {
    use sonarproj::geometry::pose::{RelativePose, Rotation, cart_to_sph, sph_to_cart};
    let rot: Vec<f64> = top["rotation"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let t: Vec<f64> = top["translation"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let pose = RelativePose::new(
        Rotation::RollPitchYaw {
            roll: rot[0],
            pitch: rot[1],
            yaw: rot[2],
        },
        [t[0], t[1], t[2]],
    )
    .unwrap();
    let layout = sonarproj::occupancy::Layout::of(&common::preset("paper-fls"));
    (0..rows.len())
        .filter(|&k| {
            let f = |i: usize| rows[k][i].parse::<f64>().unwrap();
            let (r2, a2, e2) =
                cart_to_sph(pose.apply(sph_to_cart(f(r), f(az).to_radians(), f(el).to_radians())));
            layout.inside(r2, a2, e2)
        })
        .collect()
}

#[test]
fn bad_advise_files_exit_2_naming_the_key() {
    let base = "from = \"paper-fls\"\nto = \"paper-fls\"\nstep = 0.1\n[features]\ncount = 10\n[rig]\norigin = [0, 0, 0]\n";
    let cases: &[(String, &[&str])] = &[
        (format!("{base}colour = 1\n"), &["colour", "unknown key"]),
        (
            base.replace("count = 10", "count = 0"),
            &["features.count", "[1, 1000000]"],
        ),
        (
            base.replace("count = 10", "points = [[50, 0, 0]]"),
            &["features.points[0]", "feature range = 50"],
        ),
        (
            format!("objective = \"fast\"\n{base}"),
            &["objective", "\"fast\""],
        ),
        (format!("min_shared = 2\n{base}"), &["min_shared = 2", "[0, 1]"]),
        (
            format!("objective = \"mix\"\n{base}"),
            &["mix", "[mix] with weight"],
        ),
        (
            base.replace("origin = [0, 0, 0]", "origin = [0, 0]"),
            &["rig.origin", "three finite numbers"],
        ),
        (
            base.replace(
                "origin = [0, 0, 0]",
                "origin = [0, 0, 0]\ntranslation = [1, 0, 0]",
            ),
            &["rig", "one of origin, translation, place"],
        ),
        (
            format!("{base}[search]\nroll = [0, 10]\nlandscape = [\"roll\", \"yaw\"]\n"),
            &["search.landscape", "two different axes"],
        ),
        (
            format!("{base}[search]\nrefine = 1.5\n"),
            &["search.refine = 1.5"],
        ),
        (
            format!("{base}[search]\nuniform = 100\nroll = [0, 1]\n"),
            &["search.roll", "not both"],
        ),
        (
            format!("{base}[search]\nuniform = 1\n"),
            &["search.uniform = 1", "[2, 1000000]"],
        ),
        (
            format!("{base}[search]\nuniform = 50\nlandscape = [\"x\", \"y\"]\n"),
            &["search.landscape", "grid"],
        ),
        (
            format!("{base}[search]\nz = [0, 2000]\n"),
            &["search.z = 2000", "1000 m"],
        ),
        (
            base.replace("origin = [0, 0, 0]", "origin = [0, \"x\", 0.5]"),
            &["rig.origin", "three finite numbers"],
        ),
        (
            base.replace("origin = [0, 0, 0]", "origin = [900000, 900000, 0]"),
            &["rig", "within 1000000 m"],
        ),
        (format!("{base}[from_pose]\nstep = 0\n"), &["from_pose.step = 0"]),
        // The value as written, and the choices step really has.
        (
            base.replace("step = 0.1", "step = -0.1"),
            &["step = -0.1 is invalid", "\"auto\" or \"exact\""],
        ),
        (
            base.replace("step = 0.1", "step = \"fine\""),
            &["step = \"fine\"", "must be > 0 (deg), \"auto\" or \"exact\""],
        ),
        (
            base.replace("step = 0.1", "step = 1e-300"),
            &["advise file", "step = 1e-300", "samples per pose"],
        ),
        (
            base.replace("count = 10", "points = [[5, 0, 0]]\nseed = 3"),
            &["features.seed = 3", "not both"],
        ),
        (
            base.replace("count = 10", "count = \"10\""),
            &["features.count = \"10\"", "must be one number"],
        ),
        (
            base.replace("origin = [0, 0, 0]", "origin = [2000000, 0, 0]"),
            &["rig.origin", "within ±1000000"],
        ),
        (
            base.replace("[rig]\norigin = [0, 0, 0]\n", ""),
            &["rig", "missing"],
        ),
        (
            "from = \"paper-fls\"\nto = [".to_string(),
            &["advise file", "expected"],
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (k, (text, needles)) in cases.iter().enumerate() {
        let file = dir.path().join(format!("bad-{k}.toml"));
        std::fs::write(&file, text).unwrap();
        let out = dir.path().join(format!("out-{k}"));
        let (f, o) = (file.to_str().unwrap(), out.to_str().unwrap());
        common::rejects(
            &["advise", "--config", f, "--out", o, "--backend", "cpu"],
            None,
            needles,
        );
        assert!(!out.exists(), "case {k}: the output directory was created");
    }
}

/// A search where sonar 2 sees no feature says so, not just "see min_shared".
#[test]
fn nothing_shared_is_said_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("far.toml");
    std::fs::write(
        &file,
        "from = \"paper-fls\"\nto = \"paper-fls\"\n[features]\ncount = 10\n\
         [rig]\norigin = [0, 0, 5000]\n[search]\nroll = [0, 10]\nrefine = 0\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let run = common::sonarproj()
        .args([
            "advise",
            "--config",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--backend", "cpu-fast"])
        .assert()
        .success();
    let err = String::from_utf8_lossy(&run.get_output().stderr).to_string();
    assert!(
        err.contains("no candidate pose lets sonar 2 see any of the features"),
        "{err}"
    );
}
