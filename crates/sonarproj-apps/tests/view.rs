//! The viewer's computation (`sonarproj_apps::view`), without a browser: scenes parsed and
//! refused with the field named, the 3-D samples' visibility against the engine's count, the
//! occupancy runs against the engine's occupancy, and the "copy as" sweep file read back by the
//! sweep parser to the same pose. The page itself is tested in a browser (`web/tests`).

use std::path::Path;

use serde_json::Value;
use sonarproj::{Backend, BackendChoice, Batch, BatchItem, GpuOptions, Measurement, Output, Sampling, Sonar};
use sonarproj_apps::sweep::config::SweepConfig;
use sonarproj_apps::view::{Choice, MAX_REQUEST_BYTES, Scene, Viewer};

fn viewer() -> Viewer {
    Viewer::new(
        Vec::new(),
        Backend::Cpu,
        BackendChoice::Cpu,
        GpuOptions::default(),
    )
}

fn scene(json: &str) -> Scene {
    Scene::parse(json.as_bytes()).expect("a valid scene")
}

/// Scenes of all four pairs, placements and translations, where sonar 2 sees part of the set.
const SCENES: [&str; 5] = [
    r#"{"from":"paper-fls","to":"paper-sss","feature":{"range":5,"azimuth":10},"rotation":{"pitch":90},"place":{"range":15}}"#,
    r#"{"from":"paper-sss","to":"paper-fls","feature":{"range":5},"rotation":{"roll":20,"pitch":30,"yaw":40},"place":{"range":5,"azimuth":5},"step":0.2}"#,
    r#"{"from":"paper-fls","to":"paper-fls","feature":{"range":4,"azimuth":-12,"elevation":3},"rotation":{"roll":5,"yaw":-15},"translation":[-1,0.5,0.2]}"#,
    r#"{"from":"holoocean-sidescan","to":"holoocean-sidescan","feature":{"range":12},"rotation":{"yaw":30},"place":{"range":14,"azimuth":-10},"step":0.2}"#,
    r#"{"from":"paper-fls","to":"paper-fls","feature":{"range":5},"rotation":{"roll":90},"place":{"range":3,"azimuth":20},"step":0.05}"#,
];

#[test]
fn a_scene_shows_the_engines_metrics_occupancy_and_visible_samples() {
    let v = viewer();
    for text in SCENES {
        let s = scene(text);
        let out = v.scene(&s).expect(text);
        // the engine's own answer for the same inputs, through the library's batch API
        let (from, to) = (Sonar::preset(&s.from).unwrap(), Sonar::preset(&s.to).unwrap());
        let measurement = Measurement::of(&from, s.feature.range, s.feature.azimuth).unwrap();
        let batch = Batch {
            sigma_range: None,
            source: from,
            target: to,
            sampling: s.step.map_or(Sampling::Auto, Sampling::Step),
            area_grid: sonarproj::PAPER_AREA_GRID,
            items: vec![BatchItem {
                true_point: None,
                measurement,
                pose: s.pose().unwrap(),
            }],
        };
        let p = Backend::Cpu
            .project(&batch, Output::WithOccupancy)
            .unwrap()
            .pop()
            .unwrap();
        // The metric table's values, then the local precision at the true point.
        let mut expected = serde_json::to_value(p.metrics).unwrap();
        let f = s.feature;
        let local = sonarproj::local_precision::local_precision(
            &batch.source,
            &batch.target,
            [f.range, f.azimuth, f.elevation],
            &batch.items[0].pose,
            sonarproj::local_precision::default_sigma_range(&batch.source, &batch.target),
        );
        expected["range_per_elevation"] = serde_json::json!(local.range_per_elevation);
        expected["sigma_elevation"] = serde_json::json!(local.sigma_elevation);
        assert_eq!(out["metrics"], expected, "{text}");
        assert!(
            p.metrics.visible > 0,
            "{text}: a scene where sonar 2 sees something"
        );
        // runs → pixels, compared with the occupancy's own pixel list
        let occ = p.occupancy.unwrap();
        let mut pixels = Vec::new();
        for run in out["occupancy"]["runs"].as_array().unwrap() {
            let (start, len) = (run[0].as_u64().unwrap(), run[1].as_u64().unwrap());
            for k in start..start + len {
                let k = usize::try_from(k).unwrap();
                pixels.push((k / occ.beams, k % occ.beams));
            }
        }
        assert_eq!(pixels, occ.pixels().collect::<Vec<_>>(), "{text}");
        // the 3-D view's highlight: every sample is shown here (none of these is thinned), and
        // the seen ones are as many as the reference counts visible
        let samples = &out["samples"];
        assert_eq!(samples["shown"], samples["total"], "{text}");
        let seen: u64 = samples["visible"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .sum();
        assert_eq!(seen, p.metrics.visible, "{text}");
        assert_eq!(
            samples["first"].as_array().unwrap().len(),
            3 * usize::try_from(p.metrics.total).unwrap()
        );
    }
}

#[test]
fn a_large_surface_is_thinned_for_the_3d_view_but_counted_whole() {
    let v = viewer();
    let s = scene(
        r#"{"from":"paper-sss","to":"paper-fls","feature":{"range":20},"place":{"range":5},"step":0.01}"#,
    );
    let out = v.scene(&s).unwrap();
    let (shown, total) = (
        out["samples"]["shown"].as_u64().unwrap(),
        out["samples"]["total"].as_u64().unwrap(),
    );
    assert_eq!(out["metrics"]["total"].as_u64().unwrap(), total);
    assert!(
        total > 100_000 && shown <= 8192 && shown > 2000,
        "{shown} of {total}"
    );
}

#[test]
fn bad_scenes_are_refused_naming_the_field() {
    let v = viewer();
    let refused = |v: &Viewer, text: &str, words: &[&str]| {
        let e = Scene::parse(text.as_bytes())
            .and_then(|s| v.scene(&s))
            .expect_err(text);
        assert!(e.is_input(), "{text}: {e}");
        let m = e.to_string();
        for w in words {
            assert!(m.contains(w), "{text}: {m:?} lacks {w:?}");
        }
    };
    let base = r#""from":"paper-fls","to":"paper-sss","feature":{"range":5}"#;
    let cases: [(String, &[&str]); 15] = [
        (format!("{{{base}}}"), &["pose", "no translation"]),
        (
            format!(r#"{{{base},"place":{{"range":15}},"translation":[0,0,0]}}"#),
            &["pose", "both"],
        ),
        (
            format!(r#"{{{base},"place":{{"range":15}},"colour":1}}"#),
            &["request", "unknown field `colour`"],
        ),
        (
            r#"{"from":"/etc/passwd","to":"paper-sss","feature":{"range":5},"place":{"range":15}}"#.into(),
            &["from", "/etc/passwd", "one of paper-fls"],
        ),
        (
            r#"{"from":"paper-fls","to":"paper-sss","feature":{"range":50},"place":{"range":15}}"#.into(),
            &["feature range", "50", "[0.1, 10]"],
        ),
        (
            r#"{"from":"paper-fls","to":"paper-sss","feature":{"range":5,"elevation":40},"place":{"range":15}}"#.into(),
            &["feature elevation", "40"],
        ),
        (
            format!(r#"{{{base},"place":{{"range":15}},"step":0}}"#),
            &["step", "> 0"],
        ),
        (
            format!(r#"{{{base},"place":{{"range":15}},"step":1e-7}}"#),
            &["samples per pose"],
        ),
        (
            format!(r#"{{{base},"place":{{"range":15}},"sigma":{{"roll":-1}}}}"#),
            &["sigma roll", "-1"],
        ),
        // Numbers whose derived quantities would overflow (a mask radius, the true point in
        // sonar 2) are bad input, not a null in the answer.
        (
            format!(r#"{{{base},"place":{{"range":15}},"sigma":{{"roll":1e308}}}}"#),
            &["sigma roll", "1e308", "[0, 180] deg"],
        ),
        (
            format!(r#"{{{base},"place":{{"range":15}},"sigma":{{"tx":1e308}}}}"#),
            &["sigma tx", "1e308", "[0, 10000] m"],
        ),
        (
            format!(r#"{{{base},"place":{{"range":1e308}}}}"#),
            &["place range", "1e308", "at most 1000000 m"],
        ),
        (
            format!(r#"{{{base},"translation":[1e300,0,0]}}"#),
            &["tx", "1e300", "within ±1000000 m"],
        ),
        (
            format!(r#"{{{base},"place":{{"range":15}},"second":{{"range":99}}}}"#),
            &["second range", "99"],
        ),
        (
            format!(r#"{{{base},"rotation":{{"pitch":"ninety"}},"place":{{"range":15}}}}"#),
            &["request", "invalid type"],
        ),
    ];
    for (text, words) in &cases {
        refused(&v, text, words);
    }
    let huge = format!(
        r#"{{{base},"place":{{"range":15}}}}{}"#,
        " ".repeat(MAX_REQUEST_BYTES)
    );
    refused(&v, &huge, &["request", "at most 65536 bytes"]);
}

#[test]
fn the_sweep_file_it_offers_gives_back_the_same_pose() {
    let dir = tempfile::tempdir().unwrap();
    // a sonar file with a name that needs quoting, named on the command line
    let file = dir.path().join("my \"odd\" sonar's.toml");
    std::fs::write(
        &file,
        "kind = \"fls\"\nrange_min = 0.1\nrange_max = 10\nazimuth_aperture = 60\n\
         elevation_aperture = 12\nrange_bins = 990\nbeams = 512\n",
    )
    .unwrap();
    let own = Choice::resolve(file.to_str().unwrap()).unwrap();
    let label = own.label.clone();
    let v = Viewer::new(vec![own], Backend::Cpu, BackendChoice::Cpu, GpuOptions::default());
    for text in SCENES {
        let mut s = scene(text);
        if s.from == "paper-fls" {
            s.from.clone_from(&label);
        }
        let out = v.scene(&s).expect(text);
        let toml = out["copy"]["toml"].as_str().unwrap();
        let config =
            SweepConfig::parse("view.toml", toml, Path::new("/")).unwrap_or_else(|e| panic!("{toml}\n{e}"));
        assert_eq!(config.count().unwrap(), 1);
        let (items, _) = config.items(0..1).unwrap();
        let pose = s.pose().unwrap();
        assert_eq!(items[0].pose.rotation, pose.rotation, "{toml}");
        assert_eq!(items[0].pose.translation, pose.translation, "{toml}");
        assert_eq!(items[0].measurement.range, s.feature.range);
        assert_eq!(config.sampling, s.step.map_or(Sampling::Auto, Sampling::Step));
        let command = out["copy"]["command"].as_str().unwrap();
        assert!(command.starts_with("sonarproj project --from "), "{command}");
        let python = out["copy"]["python"].as_str().unwrap();
        assert!(
            python.contains("sonarproj.project(first, second, pose"),
            "{python}"
        );
        if s.from == label {
            assert!(command.contains("'\\''"), "the path is quoted: {command}");
            assert!(python.contains("Sonar.from_toml("), "{python}");
        }
    }
}

#[test]
fn init_lists_every_preset_and_the_devices() {
    let v = viewer();
    let init: Value = v.init();
    let labels: Vec<&str> = init["sonars"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["label"].as_str().unwrap())
        .collect();
    assert_eq!(labels, Sonar::preset_names());
    assert_eq!(init["backend"], "cpu");
    let fls = &init["sonars"][0];
    assert_eq!(
        fls["beam_edges"].as_array().unwrap().len() as u64,
        fls["beams"].as_u64().unwrap() + 1
    );
}

#[test]
fn the_advise_panel_refuses_what_would_take_long_and_stops_when_asked() {
    use sonarproj_apps::view::advise::AdviseRequest;
    let v = viewer();
    let ask = |features: usize, steps: usize| {
        AdviseRequest::parse(
            format!(
                r#"{{"scene":{{"from":"paper-sss","to":"paper-fls","feature":{{"range":5}},"rotation":{{"pitch":30}},"place":{{"range":5}}}},"features":{features},"steps":{steps}}}"#
            )
            .as_bytes(),
        )
        .unwrap()
    };
    // 441 cells × 2000 sidescan features of thousands of samples each: refused, naming the knob.
    let e = v.advise(&ask(2000, 21)).unwrap_err();
    assert!(e.is_input(), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("features = 2000") && text.contains("lower features or steps"),
        "{text}"
    );
    // A small one, its client gone before it starts: given up, not computed.
    let gone = || true;
    let e = v
        .advise_until(&ask(20, 3), sonarproj::stream::Stop::when(&gone))
        .unwrap_err();
    assert!(
        matches!(e, sonarproj_apps::Error::Engine(sonarproj::Error::Stopped)),
        "{e}"
    );
    assert!(v.advise(&ask(20, 3)).is_ok());
}
