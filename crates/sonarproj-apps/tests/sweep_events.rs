//! What a sweep run reports while it works, when its chunks are projected block after block
//! (`Backend::project_blocks`): a resumed run's events in chunk order (a damaged chunk's
//! `Recomputing` just before its own `Progress`, not ahead of the chunks before it), and a
//! `Break` answered to one stops the run there.

use std::ops::ControlFlow;
use std::path::Path;

use sonarproj::Backend;
use sonarproj_apps::sweep::{Event, Format, Options, SweepConfig, run};

const GRID: &str = r#"
from = "paper-fls"
to = "paper-sss"
step = 1
[feature]
range = 5
[place]
range = 10
[rotation]
roll = { start = 0, stop = 99, step = 1 }
"#;

fn options(out: &Path, max_chunks: Option<u64>) -> Options {
    Options {
        out: out.to_path_buf(),
        shard: None,
        chunk_poses: Some(10),
        max_chunks,
        format: Format::Parquet,
    }
}

/// Returns the run's events, answered `Continue` until `stop_at` says otherwise.
fn events_of(
    config: &SweepConfig,
    backend: &Backend,
    opts: &Options,
    stop_at: &dyn Fn(&Event) -> bool,
) -> Vec<Event> {
    let mut seen = Vec::new();
    run(config, backend, opts, sonarproj::stream::Stop::NEVER, &mut |e| {
        let stop = stop_at(&e);
        seen.push(e);
        if stop {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    seen
}

/// Damages chunk `c` of the unfinished run in `out` (one byte flipped).
fn damage(out: &Path, c: u64) {
    let chunk = out.join(format!(".partial-sweep/chunk-{c:08}.parquet"));
    let mut bytes = std::fs::read(&chunk).unwrap();
    let at = bytes.len() / 2;
    bytes[at] ^= 0x55;
    std::fs::write(&chunk, bytes).unwrap();
}

/// A short name of an event: `P<done>` or `R<chunk>`.
fn name(e: &Event) -> String {
    match e {
        Event::Progress { done, .. } => format!("P{done}"),
        Event::Recomputing { file, .. } => {
            let f = file.file_name().unwrap().to_string_lossy();
            format!(
                "R{}",
                f.trim_start_matches("chunk-")
                    .trim_end_matches(".parquet")
                    .trim_start_matches('0')
            )
        }
        _ => "?".into(),
    }
}

#[test]
fn a_resumed_run_reports_its_chunks_in_order_and_stops_where_told() {
    let dir = tempfile::tempdir().unwrap();
    let config = SweepConfig::parse("grid.toml", GRID, dir.path()).unwrap();
    let mut backends = vec![Backend::CpuFast];
    if let Some(gpu) = sonarproj_testkit::gpu() {
        backends.push(Backend::Gpu(Box::new(gpu)));
    }
    for backend in &backends {
        let out = dir.path().join(backend.name());
        // Chunks 0–5 of ten; then 2 and 3 damaged (projected as one run of blocks, with the
        // missing 6–9 as another).
        events_of(&config, backend, &options(&out, Some(6)), &|_| false);
        damage(&out, 2);
        damage(&out, 3);
        let got: Vec<String> = events_of(&config, backend, &options(&out, None), &|_| false)
            .iter()
            .map(name)
            .collect();
        let want = [
            "P10", "P20", "R2", "P30", "R3", "P40", "P50", "P60", "P70", "P80", "P90", "P100",
        ];
        assert_eq!(got, want, "{}", backend.name());
        // Again, with 2 and 3 damaged, told to stop at the news of chunk 3: nothing after it.
        let again = dir.path().join(format!("{}-again", backend.name()));
        events_of(&config, backend, &options(&again, Some(6)), &|_| false);
        damage(&again, 2);
        damage(&again, 3);
        let got: Vec<String> = events_of(
            &config,
            backend,
            &options(&again, None),
            &|e| matches!(e, Event::Recomputing { file, .. } if file.ends_with("chunk-00000003.parquet")),
        )
        .iter()
        .map(name)
        .collect();
        assert_eq!(got, ["P10", "P20", "R2", "P30", "R3"], "{}", backend.name());
        // Chunk 3 was not written again: still damaged, reported by the next run.
        let got: Vec<String> = events_of(&config, backend, &options(&again, None), &|_| false)
            .iter()
            .map(name)
            .collect();
        assert_eq!(got[..5], ["P10", "P20", "P30", "R3", "P40"], "{}", backend.name());
    }
}

/// A run's last chunk goes straight into its results, not into its state: a run told to stop at
/// the news of it has kept every chunk before it and not that one, and the next run computes
/// that chunk alone, to the same table and summaries as a run never stopped.
#[test]
fn a_run_stopped_at_its_last_chunk_loses_that_chunk_alone() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{GRID}[summary]\ntop = 3\nmarginals = [\"roll\"]\n");
    let config = SweepConfig::parse("grid.toml", &text, dir.path()).unwrap();
    let backend = Backend::CpuFast;
    let whole = dir.path().join("whole");
    events_of(&config, &backend, &options(&whole, None), &|_| false);
    let cut = dir.path().join("cut");
    let got: Vec<String> = events_of(&config, &backend, &options(&cut, None), &|e| {
        matches!(e, Event::Progress { done: 100, .. })
    })
    .iter()
    .map(name)
    .collect();
    assert_eq!(got.last().map(String::as_str), Some("P100"));
    let state = cut.join(".partial-sweep");
    for c in 0..10 {
        for ext in ["parquet", "summary.json"] {
            let file = state.join(format!("chunk-{c:08}.{ext}"));
            assert_eq!(file.exists(), c < 9, "{}", file.display());
        }
    }
    assert!(!cut.join("summary.json").exists());
    let outcome = run(
        &config,
        &backend,
        &options(&cut, None),
        sonarproj::stream::Stop::NEVER,
        &mut |_| ControlFlow::Continue(()),
    )
    .unwrap();
    assert_eq!((outcome.resumed, outcome.computed), (90, 10));
    for file in ["sweep.parquet", "summary.json"] {
        let read = |d: &Path| std::fs::read(d.join(file)).unwrap();
        assert!(read(&cut) == read(&whole), "{file} differs");
    }
}

/// A damaged last chunk, recomputed straight into the results, leaves the run's state with it:
/// a run stopped at its news holds no file of that chunk, and the next run has nothing of it to
/// report damaged.
#[test]
fn a_damaged_last_chunk_recomputed_leaves_the_state() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{GRID}[summary]\ntop = 3\n");
    let config = SweepConfig::parse("grid.toml", &text, dir.path()).unwrap();
    let backend = Backend::CpuFast;
    let out = dir.path().join("out");
    let at_the_end = |e: &Event| matches!(e, Event::Progress { done: 100, .. });
    events_of(&config, &backend, &options(&out, None), &at_the_end);
    let state = out.join(".partial-sweep");
    let last: Vec<_> = ["parquet", "summary.json"]
        .iter()
        .map(|ext| state.join(format!("chunk-00000009.{ext}")))
        .collect();
    for file in &last {
        std::fs::write(file, b"not a chunk").unwrap();
    }
    let got: Vec<String> = events_of(&config, &backend, &options(&out, None), &at_the_end)
        .iter()
        .map(name)
        .collect();
    let resumed: Vec<String> = (1..10).map(|k| format!("P{}", 10 * k)).collect();
    assert_eq!(got[..9], resumed[..]);
    assert_eq!(got[9..], ["R9", "P100"]);
    for file in &last {
        assert!(!file.exists(), "{} left behind", file.display());
    }
    let got: Vec<String> = events_of(&config, &backend, &options(&out, None), &|_| false)
        .iter()
        .map(name)
        .collect();
    assert_eq!(got[..9], resumed[..]);
    assert_eq!(got[9..], ["P100"]);
}
