//! Every parser of text a user writes — sonar TOML, sweep TOML, batch and recover CSV, mask
//! stream JSON lines, pose strings and features — on arbitrary bytes and on arbitrary structured
//! values (the right keys and columns holding NaN, infinities, huge, negative or non-numbers):
//! each returns `Ok` or a typed error and never panics. Inputs stay small (a few KiB), so every
//! case takes milliseconds and a few MiB; a case slower than 100 ms is reported on stderr
//! (`cargo test --release --test parsers -- --nocapture`), never failed on time.

use sonarproj_testkit as common;

use std::path::Path;
use std::time::{Duration, Instant};

use proptest::prelude::*;
use sonarproj::Sonar;
use sonarproj::recovery::recover;
use sonarproj_apps::io::recover::recover_csv;
use sonarproj_apps::io::text::{feature, numbers, one_or_three, parse_mask_line};
use sonarproj_apps::io::{project_csv, read_batch_csv, read_batch_csv_at_most};
use sonarproj_apps::sweep::SweepConfig;

/// Returns a strategy over number-like text: specials, extremes, signs and garbage.
fn number_text() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("1e308".to_string()),
        Just("-1e308".to_string()),
        Just("1e-320".to_string()),
        Just("0".to_string()),
        Just("-0".to_string()),
        Just(String::new()),
        Just("x".to_string()),
        Just("\"5\"".to_string()),
        (-1e4..1e4f64).prop_map(|v| v.to_string()),
        (0.0..20.0f64).prop_map(|v| format!("{v:.3}")),
        "[0-9eE+.,-]{0,12}",
    ]
}

/// Returns a strategy over arbitrary text: any characters, and the characters that matter to
/// CSV, TOML and JSON.
fn any_text() -> impl Strategy<Value = String> {
    prop_oneof![
        ".{0,400}",
        "[\\[\\]{}\",=:\n\r\t #'a-z0-9.-]{0,400}",
        prop::collection::vec(any::<u8>(), 0..400).prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ]
}

/// Times the parser calls of one case and reports the slow ones.
struct Slowest(&'static str, Duration);

impl Slowest {
    fn time<T>(&mut self, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.1 = self.1.max(start.elapsed());
        out
    }
}

impl Drop for Slowest {
    fn drop(&mut self) {
        if self.1 > Duration::from_millis(100) {
            eprintln!("{}: a slow case, {:.1} ms", self.0, self.1.as_secs_f64() * 1e3);
        }
    }
}

/// The sonar TOML keys, for structured files.
const SONAR_KEYS: [&str; 9] = [
    "kind",
    "range_min",
    "range_max",
    "azimuth_aperture",
    "elevation_aperture",
    "range_bins",
    "beams",
    "beam_edges",
    "beam_centres",
];

/// The sweep TOML keys (top level and tables), for structured files.
const SWEEP_KEYS: [&str; 14] = [
    "from = \"paper-fls\"",
    "to = \"paper-sss\"",
    "from = \"holoocean-sidescan\"",
    "step",
    "metric",
    "poses",
    "[feature]",
    "[place]",
    "[translation]",
    "[rotation]",
    "range",
    "roll",
    "x",
    "yaw",
];

/// Returns a TOML value: a number-like text, a string, a list or a range table.
fn toml_value() -> impl Strategy<Value = String> {
    prop_oneof![
        number_text(),
        Just("\"fls\"".to_string()),
        Just("\"sss\"".to_string()),
        Just("\"span\"".to_string()),
        prop::collection::vec(number_text(), 0..5).prop_map(|v| format!("[{}]", v.join(", "))),
        (number_text(), number_text(), number_text())
            .prop_map(|(a, b, c)| format!("{{ start = {a}, stop = {b}, step = {c} }}")),
    ]
}

proptest! {
    #![proptest_config(common::proptest_config())]

    #[test]
    fn sonar_files_parse_or_refuse(text in any_text(),
                                   pairs in prop::collection::vec((0..SONAR_KEYS.len(), toml_value()), 0..10)) {
        let mut slowest = Slowest("sonar TOML", Duration::ZERO);
        slowest.time(|| { let _ = Sonar::from_toml_str("arbitrary.toml", &text); });
        let structured: String = pairs
            .iter()
            .map(|(k, v)| format!("{} = {v}\n", SONAR_KEYS[*k]))
            .collect();
        slowest.time(|| { let _ = Sonar::from_toml_str("structured.toml", &structured); });
    }

    #[test]
    fn sweep_files_parse_or_refuse(text in any_text(),
                                   lines in prop::collection::vec((0..SWEEP_KEYS.len(), toml_value()), 0..14)) {
        let mut slowest = Slowest("sweep TOML", Duration::ZERO);
        let base = Path::new("data");
        slowest.time(|| { let _ = SweepConfig::parse("arbitrary.toml", &text, base); });
        let structured: String = lines
            .iter()
            .map(|(k, v)| {
                let key = SWEEP_KEYS[*k];
                if key.contains('=') || key.starts_with('[') { format!("{key}\n") } else { format!("{key} = {v}\n") }
            })
            .collect();
        slowest.time(|| { let _ = SweepConfig::parse("structured.toml", &structured, base); });
    }

    #[test]
    fn batch_csv_parses_or_refuses(bytes in prop::collection::vec(any::<u8>(), 0..600),
                                   header in prop::sample::subsequence(
                                       vec!["range", "azimuth", "elevation", "roll", "pitch", "yaw",
                                            "tx", "ty", "tz", "place_range", "place_azimuth", "place_elevation"], 0..12),
                                   rows in prop::collection::vec(prop::collection::vec(number_text(), 0..13), 0..6)) {
        let mut slowest = Slowest("batch CSV", Duration::ZERO);
        let (fls, sss) = (Sonar::preset("paper-fls").unwrap(), Sonar::preset("paper-sss").unwrap());
        slowest.time(|| { let _ = read_batch_csv(bytes.as_slice(), &fls); });
        let mut text = header.join(",");
        for row in &rows {
            text.push('\n');
            text.push_str(&row.join(","));
        }
        // Read whole, and streamed through a projection (small sampling: only parsing is tested).
        slowest.time(|| { let _ = read_batch_csv(text.as_bytes(), &fls); });
        let pair = sonarproj::Batch { sigma_range: None,
            source: fls,
            target: sss,
            sampling: sonarproj::Sampling::Step(3.0),
            area_grid: sonarproj::PAPER_AREA_GRID,
            items: Vec::new(),
        };
        slowest.time(|| {
            let _ = project_csv(text.as_bytes(), std::io::sink(), &pair, |b| {
                Ok(sonarproj::Backend::CpuFast.project(b, sonarproj::Output::MetricsOnly)?)
            });
        });
    }

    #[test]
    fn recover_csv_parses_or_refuses(bytes in prop::collection::vec(any::<u8>(), 0..600),
                                     header in prop::sample::subsequence(
                                         vec!["first_range", "first_azimuth", "second_range", "second_azimuth",
                                              "roll", "pitch", "yaw", "tx", "ty", "tz", "sigma_range", "sigma_azimuth"], 0..12),
                                     rows in prop::collection::vec(prop::collection::vec(number_text(), 0..13), 0..6)) {
        let mut slowest = Slowest("recover CSV", Duration::ZERO);
        let fls = Sonar::preset("paper-fls").unwrap();
        let run = |input: &[u8]| {
            let _ = recover_csv(input, std::io::sink(), |item| {
                Ok(recover(&fls, &fls, &item.pose, item.first, item.second, item.sigmas, 0.01)?)
            });
        };
        slowest.time(|| run(&bytes));
        let mut text = header.join(",");
        for row in &rows {
            text.push('\n');
            text.push_str(&row.join(","));
        }
        slowest.time(|| run(text.as_bytes()));
    }

    #[test]
    fn stream_lines_parse_or_refuse(text in any_text(),
                                    rotation in prop_oneof![
                                        Just(String::new()),
                                        (number_text(), number_text()).prop_map(|(a, b)| format!("\"roll\": {a}, \"yaw\": {b}, ")),
                                        prop::collection::vec(number_text(), 0..6).prop_map(|v| format!("\"quaternion\": [{}], ", v.join(","))),
                                        prop::collection::vec(number_text(), 0..10).prop_map(|v| format!("\"matrix\": [[{}]], ", v.join(","))),
                                    ],
                                    translation in prop::collection::vec(number_text(), 0..5),
                                    features in prop::collection::vec(prop::collection::vec(number_text(), 0..4), 0..4),
                                    sigma in prop::option::of(prop::collection::vec((0..5usize, number_text()), 0..5))) {
        let mut slowest = Slowest("stream JSON", Duration::ZERO);
        let (fls, sss) = (Sonar::preset("paper-fls").unwrap(), Sonar::preset("paper-sss").unwrap());
        slowest.time(|| { let _ = parse_mask_line(&fls, &text); });
        let features: Vec<String> = features.iter().map(|f| format!("[{}]", f.join(","))).collect();
        let sigma = sigma.map(|s| {
            let keys = ["rotation", "translation", "range", "azimuth", "coverage"];
            let body: Vec<String> = s.iter().map(|(k, v)| format!("\"{}\": {v}", keys[*k])).collect();
            format!(", \"sigma\": {{{}}}", body.join(", "))
        }).unwrap_or_default();
        let line = format!(
            "{{\"pose\": {{{rotation}\"translation\": [{}]}}, \"features\": [{}]{sigma}}}",
            translation.join(","),
            features.join(",")
        );
        for source in [&fls, &sss] {
            slowest.time(|| { let _ = parse_mask_line(source, &line); });
        }
    }

    #[test]
    fn pose_strings_and_features_parse_or_refuse(text in prop_oneof![
                                                     any_text(),
                                                     prop::collection::vec(number_text(), 0..11).prop_map(|v| v.join(",")),
                                                 ]) {
        let mut slowest = Slowest("pose strings", Duration::ZERO);
        let (fls, sss) = (Sonar::preset("paper-fls").unwrap(), Sonar::preset("paper-sss").unwrap());
        slowest.time(|| {
            let _ = numbers::<1>("--x", &text);
            let _ = numbers::<3>("--translation", &text);
            let _ = numbers::<4>("--quaternion", &text);
            let _ = numbers::<9>("--matrix", &text);
            let _ = one_or_three("--sigma-rotation", &text);
            let _ = feature(&fls, 0, &text);
            let _ = feature(&sss, 0, &text);
        });
    }
}

#[test]
fn parsers_accept_what_the_readme_shows() {
    // The properties above would pass if every parser refused everything: these must parse.
    let fls = Sonar::preset("paper-fls").unwrap();
    assert_eq!(
        numbers::<3>("--translation", "1, 2,0.5").unwrap(),
        [1.0, 2.0, 0.5]
    );
    assert_eq!(one_or_three("--s", "0.5").unwrap(), [0.5; 3]);
    assert!(feature(&fls, 0, "5,10").is_ok());
    let line = r#"{"pose": {"pitch": 90, "translation": [15, 0, 0]}, "features": [[5, 10]]}"#;
    assert_eq!(parse_mask_line(&fls, line).unwrap().features.len(), 1);
    let csv = std::fs::read(common::repository().join("data/example-poses.csv")).unwrap();
    assert!(!read_batch_csv(csv.as_slice(), &fls).unwrap().items.is_empty());
    assert!(SweepConfig::load(&common::repository().join("data/example-sweep.toml")).is_ok());
    assert!(
        Sonar::from_toml_str(
            "ok.toml",
            "kind = \"sss\"\nrange_min = 0.5\nrange_max = 30\n\
        azimuth_aperture = 1\nelevation_aperture = 60\nrange_bins = 500\n"
        )
        .is_ok()
    );
}

/// A pose list is held in memory, so one longer than the limit is refused as soon as its next
/// row is read, naming what was read; and a sweep file is read at most `MAX_CONFIG_BYTES` deep,
/// whatever it is (a device that never ends included).
#[test]
fn pose_lists_and_sweep_files_past_their_limits_are_refused_while_read() {
    let fls = Sonar::preset("paper-fls").unwrap();
    let csv = std::fs::read(common::repository().join("data/example-poses.csv")).unwrap();
    let rows = read_batch_csv(csv.as_slice(), &fls).unwrap().items.len();
    assert!(rows > 2);
    assert_eq!(
        read_batch_csv_at_most(csv.as_slice(), &fls, rows, "poses")
            .unwrap()
            .items
            .len(),
        rows
    );
    let e = read_batch_csv_at_most(csv.as_slice(), &fls, rows - 1, "list \"p.csv\"")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains(&format!("list \"p.csv\" = more than {} rows", rows - 1))
            && e.contains(&format!("at most {} rows", rows - 1)),
        "{e}"
    );
    // An endless device is no sweep file: refused before a byte is read.
    let e = SweepConfig::load(Path::new("/dev/zero"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("/dev/zero") && e.contains("not a regular file"), "{e}");
    // A file past the limit (sparse: no disk) is read no deeper than the limit.
    let dir = tempfile::tempdir().unwrap();
    let long = dir.path().join("long.toml");
    std::fs::File::create(&long)
        .unwrap()
        .set_len(sonarproj_apps::limits::MAX_CONFIG_BYTES + 1)
        .unwrap();
    let e = SweepConfig::load(&long).err().unwrap().to_string();
    assert!(
        e.contains(&format!(
            "longer than {} bytes",
            sonarproj_apps::limits::MAX_CONFIG_BYTES
        )),
        "{e}"
    );
}

/// Exact mode leaves the projection area empty: an exact sweep into an imaging sonar draws the
/// span by default, and one that names `metric = "projection_area"` is refused.
#[test]
fn exact_sweeps_draw_the_span_of_an_imaging_sonar_2() {
    let text = "from = \"paper-fls\"\nto = \"paper-fls\"\nstep = \"exact\"\n[feature]\nrange = 5\n[place]\n\
                range = 6\n[rotation]\nyaw = { start = 0, stop = 10, step = 5 }\n";
    let config = SweepConfig::parse("exact.toml", text, Path::new(".")).unwrap();
    assert_eq!(config.sampling, sonarproj::Sampling::Exact);
    assert_eq!(config.metric, sonarproj::Metric::Span);
    let named = format!("metric = \"projection_area\"\n{text}");
    let e = SweepConfig::parse("exact.toml", &named, Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(e.contains("projection_area") && e.contains("exact"), "{e}");
}
