//! `sonarproj mask --stream`: a JSON line out for every line in.
//!
//! A thread of its own reads and parses the lines. When a ping is taken, the pings already
//! waiting (those that arrived while the one before was drawn) are drawn with it, two in
//! flight on a GPU. Each is answered as soon as it is read back. A ping that arrives alone is
//! drawn at once: none is held back to wait for another.

use sonarproj::stream::{Flow, Stop};
use std::io::Write;
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError, sync_channel};
use std::time::Instant;

use serde_json::{Value, json};
use sonarproj::masks::{Counts, MaskEngine, Noise, run_lengths};
use sonarproj::occupancy::Occupancy;
use sonarproj::{Measurement, RelativePose, Sonar};
use sonarproj_apps::io::text::parse_mask_line;
use sonarproj_apps::io::{BoundedLine, MAX_LINE_BYTES, read_line_bounded};
use sonarproj_apps::{Error, Result};

use super::mask_json::{features_json, summary_json};

/// The most waiting pings drawn together, and the most lines read ahead of the one drawn.
const MAX_BATCH: usize = 64;

/// A ping of the stream: its line number and what the line asks for.
struct Ping {
    line: usize,
    pose: RelativePose,
    features: Vec<Measurement>,
    noise: Option<Noise>,
}

/// What the reading thread sends.
enum Msg {
    /// A ping to draw.
    Ping(Ping),
    /// A line that is not a ping: its number and why.
    Bad(usize, String),
    /// The input ended after this many lines.
    End(usize),
    /// The input could not be read.
    Failed(std::io::Error),
}

/// Reads stdin line by line into `tx`, parsing each against sonar 1 `source` and skipping
/// blank lines. Stops at the end of the input, at a read error, or when the receiver is gone.
fn read_lines(source: &Sonar, tx: &SyncSender<Msg>) {
    let mut input = std::io::stdin().lock();
    let mut buf = Vec::new();
    let mut lines = 0usize;
    loop {
        let msg = match read_line_bounded(&mut input, MAX_LINE_BYTES, &mut buf) {
            Err(e) => Msg::Failed(e),
            Ok(None) => Msg::End(lines),
            Ok(Some(read)) => {
                lines += 1;
                let text = match read {
                    BoundedLine::TooLong(len) => Err(Error::input(
                        "line",
                        format!("{len} bytes, longer than the {MAX_LINE_BYTES} a line may hold"),
                    )),
                    BoundedLine::Line => std::str::from_utf8(&buf)
                        .map_err(|e| Error::input("line", format!("not valid UTF-8 ({e})"))),
                };
                if matches!(&text, Ok(t) if t.trim().is_empty()) {
                    continue;
                }
                match text.and_then(|t| parse_mask_line(source, t)) {
                    Ok(r) => Msg::Ping(Ping {
                        line: lines,
                        pose: r.pose,
                        features: r.features,
                        noise: r.noise,
                    }),
                    Err(e) => Msg::Bad(lines, e.to_string()),
                }
            }
        };
        let last = matches!(msg, Msg::End(_) | Msg::Failed(_));
        if tx.send(msg).is_err() || last {
            return;
        }
    }
}

/// Runs the stream mode: a JSON line out for every line in. A bad line gets
/// `{"line", "error"}` and the stream goes on, with exit status 2 at the end.
pub(super) fn stream(engine: &MaskEngine, runs: bool) -> Result<()> {
    let (tx, rx) = sync_channel(MAX_BATCH);
    let source = engine.source().clone();
    // Not a scoped thread: a run that stops early (stdout closed) must not wait for stdin.
    std::thread::spawn(move || read_lines(&source, &tx));
    let mut out = Replies {
        out: std::io::stdout().lock(),
        bad: 0,
    };
    let mut held: Option<Msg> = None;
    let lines = loop {
        let Some(msg) = held.take().or_else(|| rx.recv().ok()) else {
            // The reader always sends a last message. Should it not, end as at the input's end.
            break 0;
        };
        match msg {
            Msg::End(lines) => break lines,
            Msg::Failed(source) => {
                return Err(Error::ReadInput {
                    path: "stdin".into(),
                    source,
                });
            }
            Msg::Bad(line, error) => out.error(line, &error)?,
            Msg::Ping(first) => {
                let (batch, next) = waiting(first, &rx);
                held = next;
                draw(engine, runs, &batch, &mut out)?;
            }
        }
    };
    if out.bad > 0 {
        return Err(Error::BadLines { bad: out.bad, lines });
    }
    Ok(())
}

/// Returns `first` plus the pings already waiting in `rx` with the same noise, at most
/// [`MAX_BATCH`] in all. Also returns the first message taken that cannot join them.
fn waiting(first: Ping, rx: &Receiver<Msg>) -> (Vec<Ping>, Option<Msg>) {
    let mut batch = vec![first];
    while batch.len() < MAX_BATCH {
        match rx.try_recv() {
            Ok(Msg::Ping(p)) if p.noise == batch[0].noise => batch.push(p),
            Ok(other) => return (batch, Some(other)),
            Err(TryRecvError::Empty | TryRecvError::Disconnected) => break,
        }
    }
    (batch, None)
}

/// The replies written so far, and how many were errors.
struct Replies<'a> {
    out: std::io::StdoutLock<'a>,
    bad: usize,
}

impl Replies<'_> {
    /// Writes `reply` as one line, flushed.
    fn write(&mut self, reply: &Value) -> Result<()> {
        let write_error = |e: std::io::Error| Error::WriteOutput {
            path: "stdout".into(),
            message: e.to_string(),
        };
        serde_json::to_writer(&mut self.out, reply).map_err(|e| write_error(e.into()))?;
        self.out.write_all(b"\n").map_err(write_error)?;
        self.out.flush().map_err(write_error)
    }

    /// Writes the error reply of line `line`.
    fn error(&mut self, line: usize, error: &str) -> Result<()> {
        self.bad += 1;
        self.write(&json!({ "line": line, "error": error }))
    }

    /// Writes the answer of line `line`: its features' JSON and the union, drawn in `elapsed`.
    fn answer(
        &mut self,
        line: usize,
        per_feature: Vec<Value>,
        union: &Occupancy,
        elapsed: std::time::Duration,
    ) -> Result<()> {
        self.write(&json!({
            "line": line,
            "features": per_feature,
            "union_occupied": union.count(),
            "union_runs": run_lengths(union),
            "elapsed_ms": elapsed.as_secs_f64() * 1e3,
        }))
    }
}

/// Draws `batch` and writes each ping's reply in order, alone or together (two in flight on a
/// GPU). Together, each ping's `elapsed_ms` is the time since the reply before. When drawing
/// them together fails, the pings not yet answered are drawn one by one, so each bad one gets
/// its own error.
fn draw(engine: &MaskEngine, runs: bool, batch: &[Ping], out: &mut Replies<'_>) -> Result<()> {
    let mut done = 0;
    if batch.len() > 1 {
        let pings: Vec<(RelativePose, Vec<Measurement>)> =
            batch.iter().map(|p| (p.pose, p.features.clone())).collect();
        let noise = batch[0].noise.as_ref();
        let mut last = Instant::now();
        let mut written: Result<()> = Ok(());
        let mut reply =
            |per_feature: &dyn Fn(&Ping) -> Vec<Value>, union: &Occupancy| -> sonarproj::Result<Flow> {
                let p = &batch[done];
                written = out.answer(p.line, per_feature(p), union, last.elapsed());
                last = Instant::now();
                done += 1;
                // A reply that cannot be written stops the drawing. Its error is returned below.
                Ok(if written.is_ok() {
                    Flow::Continue(())
                } else {
                    Flow::Break(())
                })
            };
        let drawn = if runs {
            engine.masks_of_pings_each(&pings, noise, Stop::NEVER, &mut |set| {
                reply(
                    &|p: &Ping| features_json(engine, &p.features, &set, true),
                    &set.union,
                )
            })
        } else {
            engine.summaries_of_pings_each(&pings, noise, Stop::NEVER, &mut |s| {
                reply(&|p: &Ping| summary_json(engine, &p.features, &s), &s.union)
            })
        };
        written?;
        if drawn.is_ok() {
            return Ok(());
        }
    }
    for p in &batch[done..] {
        let start = Instant::now();
        let answer = if runs {
            engine
                .masks(&p.pose, &p.features, p.noise.as_ref(), Counts::Skip)
                .map(|set| (features_json(engine, &p.features, &set, true), set.union))
        } else {
            engine
                .summary(&p.pose, &p.features, p.noise.as_ref())
                .map(|s| (summary_json(engine, &p.features, &s), s.union))
        };
        match answer {
            Ok((per_feature, union)) => out.answer(p.line, per_feature, &union, start.elapsed())?,
            Err(e) => out.error(p.line, &e.to_string())?,
        }
    }
    Ok(())
}
