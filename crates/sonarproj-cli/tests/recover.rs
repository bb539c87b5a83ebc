//! `sonarproj recover` from the outside: the placed point found for every pair, and one row per
//! candidate in batch mode (bad input is `bad_input.rs`).

use sonarproj_testkit as common;

use common::json;
use serde_json::Value;

/// Returns the candidates' `point_first` of `sonarproj recover` run with `args`.
fn recover_points(args: &[&str]) -> (Value, Vec<[f64; 3]>) {
    let out = common::sonarproj()
        .arg("recover")
        .args(args)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v = json(&out);
    let points = v["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            for key in ["point_second", "first", "second", "in_view", "rank"] {
                assert!(!c[key].is_null(), "candidate lacks {key}: {c}");
            }
            let p = c["point_first"].as_array().unwrap();
            [0, 1, 2].map(|i| p[i].as_f64().unwrap())
        })
        .collect();
    (v, points)
}

#[test]
fn recover_finds_the_placed_point_for_every_pair() {
    // The feature at (5 m, 2°, el) in sonar 1 (el = 3° in an FLS, 0.1° in the SSS's thin beam)
    // is placed at (R2, 4°, 0.1°) in sonar 2; its measurements in both are recovered back to it.
    let truth = |el: f64| {
        let (r, az, el) = (5.0f64, 2f64.to_radians(), el.to_radians());
        [r * el.cos() * az.cos(), r * el.cos() * az.sin(), r * el.sin()]
    };
    let pose = [
        "--roll",
        "10",
        "--pitch",
        "30",
        "--yaw",
        "5",
        "--place-azimuth",
        "4",
        "--place-elevation",
        "0.1",
    ];
    let cases: [(&str, &str, &str, &str, &str, &str); 4] = [
        ("paper-fls", "paper-sss", "5,2", "15", "15", "3"),
        ("paper-sss", "paper-fls", "5", "6,4", "6", "0.1"),
        ("paper-fls", "holoocean-imaging", "5,2", "6,4", "6", "3"),
        ("paper-sss", "holoocean-sidescan", "5", "15", "15", "0.1"),
    ];
    for (from, to, first, second, place, el) in cases {
        let truth = truth(el.parse().unwrap());
        let mut args = vec!["--from", from, "--to", to, "--first", first, "--second", second];
        args.extend(pose);
        args.extend([
            "--place-range",
            place,
            "--feature-elevation",
            el,
            "--feature-azimuth",
            "2",
        ]);
        args.extend([
            "--sigma-range",
            "0.01",
            "--sigma-azimuth",
            "0.1",
            "--curve-step",
            "0.001",
        ]);
        let (v, points) = recover_points(&args);
        let nearest = points
            .iter()
            .map(|p| (0..3).map(|i| (p[i] - truth[i]).powi(2)).sum::<f64>().sqrt())
            .fold(f64::INFINITY, f64::min);
        let tol = if v["curve"].is_null() { 1e-9 } else { 0.001 };
        assert!(
            nearest <= tol,
            "{from}->{to}: nearest candidate {nearest} m from the truth: {v}"
        );
        if v["curve"].is_null() {
            assert!(
                v["candidates"][0]["sigma_elevation"].as_f64().unwrap() > 0.0,
                "{from}->{to}"
            );
        } else {
            assert!(v["curve"]["length"].as_f64().unwrap() > 0.0);
        }
    }
}

#[test]
fn recover_batch_writes_one_row_per_candidate() {
    let input = "first_range,first_azimuth,second_range,roll,pitch,yaw,tx,ty,tz,sigma_range\n\
                 5,0,5.5,0,0,0,-10,0,0,0.01\n\
                 5,0,2,0,0,0,-10,0,0,\n";
    let out = common::sonarproj()
        .args([
            "recover",
            "--from",
            "paper-fls",
            "--to",
            "paper-sss",
            "--input",
            "-",
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
    assert_eq!(&header[..3], ["first_range", "first_azimuth", "second_range"]);
    assert!(header.contains(&"sigma_elevation".to_string()) && header.contains(&"flags".to_string()));
    let rows: Vec<csv::StringRecord> = rdr.records().map(Result::unwrap).collect();
    // Row 1: the arc at 5 m meets the 5.5 m sphere around a sonar 10 m ahead twice (±el);
    // row 2: a 2 m range is out of reach.
    assert_eq!(rows.len(), 3, "{text}");
    let flags = header.iter().position(|h| h == "flags").unwrap();
    assert_eq!((&rows[0][10], &rows[1][10]), ("2", "2"));
    assert_eq!((&rows[2][10], &rows[2][flags]), ("0", "no_solution"));
}
