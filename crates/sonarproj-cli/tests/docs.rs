//! The README's and the guide's (`docs/*.md`) code blocks, run, and their links followed.
//!
//! - Every fence names its language (rustdoc would compile an untagged one as Rust), one of
//!   `LANGUAGES`, with only the attributes listed there.
//! - Shell blocks run in order (README first, then the guide's pages by name) in one temporary
//!   directory holding the repository's `data/` and a saved Oculus ping `ping.raw`, with the
//!   built `sonarproj` first on `PATH` and no GPU (`WGPU_BACKEND=none`: what a machine without
//!   one prints). `cargo run --release --` runs as `sonarproj`, the binary it builds. A block
//!   already run (the same text in the README and a page) is not run again. Blocks marked
//!   `skip-test` are the few in `SKIPPED`, each with its reason beside it in the docs.
//! - A block marked `output` is the stdout of the last shell block run before it in its file,
//!   exactly.
//! - A `toml sonar` block is read as a sonar file and a `toml sweep` block runs as a sweep file,
//!   through the command line's own parsers; a `toml cargo` block names the root package.
//! - Rust blocks are the engine's doctests: their file must be included in `src/lib.rs`.
//!   Python blocks are run by `python/tests/test_docs.py`.
//! - Every relative link resolves to a file and, with a `#fragment`, to a heading of it (GitHub's
//!   anchors) or an `<a id>`.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use sonarproj_testkit as common;

/// The fence languages, and the attributes each may carry after it.
const LANGUAGES: &[(&str, &[&str])] = &[
    ("sh", &["skip-test"]),
    ("toml", &["sonar", "sweep", "cargo"]),
    ("csv", &["output"]),
    ("json", &["output"]),
    ("text", &["output"]),
    ("python", &[]),
    ("rust", &[]),
];

/// The shell blocks not run, by the start of their first line. Each says why beside it.
const SKIPPED: &[&str] = &[
    // The whole test suite, this test included.
    "scripts/test.sh",
    // Serves until stopped; web/tests drive it in a browser.
    "sonarproj view --open",
    // Builds the extension module (minutes); the test command builds and installs the wheel.
    "pip install .",
    // Builds documentation (minutes); CI builds it with warnings denied.
    "cargo doc --release --no-deps -p sonarproj --open",
    // Needs a Slurm cluster; scripts/test_slurm.sh runs this recipe on one it starts.
    "jobid=$(sbatch",
];

/// A shell block may run this long.
const BLOCK_TIMEOUT: Duration = Duration::from_secs(300);

struct Block {
    /// The file, relative to the repository.
    file: String,
    /// The line of the opening fence (1-based).
    line: usize,
    lang: String,
    attrs: Vec<String>,
    code: String,
}

impl Block {
    fn at(&self) -> String {
        format!("{}:{}", self.file, self.line)
    }
}

/// Returns the README and the guide's pages, README first, then the pages by name.
fn documents(root: &Path) -> Vec<PathBuf> {
    let mut pages: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    pages.sort();
    let mut all = vec![root.join("README.md")];
    all.extend(pages);
    all
}

fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root).unwrap().display().to_string()
}

/// Returns the fenced code blocks of `text`; an indented fence (in a list) has its indent
/// removed from its lines.
fn blocks(file: &str, text: &str) -> Vec<Block> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let trimmed = lines[i].trim_start();
        let Some(info) = trimmed.strip_prefix("```") else {
            i += 1;
            continue;
        };
        let indent = &lines[i][..lines[i].len() - trimmed.len()];
        let mut words = info.split_whitespace().map(str::to_string);
        let lang = words.next().unwrap_or_default();
        let attrs = words.collect();
        let line = i + 1;
        let mut code = String::new();
        i += 1;
        while i < lines.len() && lines[i].trim() != "```" {
            code.push_str(lines[i].strip_prefix(indent).unwrap_or(lines[i]));
            code.push('\n');
            i += 1;
        }
        assert!(i < lines.len(), "{file}:{line}: the code block is never closed");
        i += 1;
        out.push(Block {
            file: file.to_string(),
            line,
            lang,
            attrs,
            code,
        });
    }
    out
}

/// Returns a saved Oculus ping: one simple ping result (layout version 2, 8-bit, no gains) as
/// the vendor SDK lays it out — 256 beams over ±30°, denser at the centre, 700 range lines of
/// 2.8 mm (the layout of `examples/python/oculus_masks.py`'s synthetic ping).
#[allow(clippy::cast_possible_truncation)] // bearings in 0.01° fit an i16 by construction
fn oculus_ping() -> Vec<u8> {
    let (beams, rows, resolution) = (256_usize, 700_usize, 0.0028_f64);
    let fixed = 202;
    let image_offset = fixed + 2 * beams;
    let total = image_offset + rows * beams;
    let u32_of = |n: usize| u32::try_from(n).unwrap().to_le_bytes();
    let mut m = Vec::with_capacity(total);
    for v in [0x4F53_u16, 1, 0, 0x23, 2] {
        m.extend(v.to_le_bytes());
    }
    m.extend(u32_of(total - 16));
    m.extend(0_u16.to_le_bytes());
    m.extend([2_u8, 0, 255, 127, 0x09]);
    for v in [2.0_f64, 50.0, 1500.0, 0.0] {
        m.extend(v.to_le_bytes());
    }
    m.extend([0_u8; 36]);
    m.extend(1_u32.to_le_bytes());
    m.extend(0_u32.to_le_bytes());
    for v in [2.1e6_f64, 12.0, 1.0, 0.0, 0.0, 0.0, 1500.0, 0.0] {
        m.extend(v.to_le_bytes());
    }
    m.push(0);
    m.extend(resolution.to_le_bytes());
    m.extend(u16::try_from(rows).unwrap().to_le_bytes());
    m.extend(u16::try_from(beams).unwrap().to_le_bytes());
    for _ in 0..4 {
        m.extend(0_u32.to_le_bytes());
    }
    m.extend(u32_of(image_offset));
    m.extend(u32_of(rows * beams));
    m.extend(u32_of(total));
    assert_eq!(m.len(), fixed);
    for k in 0..beams {
        let u = -1.0 + 2.0 * k as f64 / (beams - 1) as f64;
        let bearing = (3000.0 * (0.6 * u + 0.4 * u * u * u)).round() as i16;
        m.extend(bearing.to_le_bytes());
    }
    for row in 0..rows {
        let range = (row as f64 + 0.5) * resolution;
        let value = if (range - 1.1).abs() < 0.1 { 200 } else { 20 };
        m.extend(std::iter::repeat_n(value, beams));
    }
    assert_eq!(m.len(), total);
    m
}

/// Runs `script` with bash in `dir`, the built binary first on `PATH` and no GPU adapter.
/// Returns stdout; panics, with the block's place and stderr, unless it succeeds in time.
fn run_shell(dir: &Path, script: &str, at: &str) -> String {
    let binary = Path::new(env!("CARGO_BIN_EXE_sonarproj"));
    let path = format!(
        "{}:{}",
        binary.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut command = Command::new("bash");
    command
        .arg("-c")
        .arg(format!("set -euo pipefail\n{script}"))
        .current_dir(dir)
        .env("PATH", path)
        .env("WGPU_BACKEND", "none")
        .env("NODEVICE_SELECT", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for variable in [
        "WGPU_ADAPTER_NAME",
        "SONARPROJ_GPU_PRECISION",
        "SONARPROJ_GPU_CULL",
        "SONARPROJ_GPU_FILTER",
        "SONARPROJ_GPU_WORKGROUP",
    ] {
        command.env_remove(variable);
    }
    let child = command.spawn().unwrap();
    let id = child.id();
    let started = Instant::now();
    let waiter = std::thread::spawn(move || child.wait_with_output().unwrap());
    while !waiter.is_finished() {
        if started.elapsed() > BLOCK_TIMEOUT {
            let _ = Command::new("kill").arg(id.to_string()).status();
            panic!("{at}: the block ran past {BLOCK_TIMEOUT:?}:\n{script}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = waiter.join().unwrap();
    assert!(
        out.status.success(),
        "{at}: the block failed ({}):\n{script}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn every_code_block_of_the_readme_and_the_guide_runs() {
    let root = common::repository();
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(root.join("data"), dir.path().join("data")).unwrap();
    std::fs::write(dir.path().join("ping.raw"), oculus_ping()).unwrap();
    let lib = std::fs::read_to_string(root.join("src/lib.rs")).unwrap();

    let mut problems = Vec::new();
    let mut skipped = HashSet::new();
    let mut run: HashMap<String, String> = HashMap::new();
    let (mut shell, mut files) = (0, 0);
    let started = Instant::now();
    for path in documents(&root) {
        let file = relative(&root, &path);
        let text = std::fs::read_to_string(&path).unwrap();
        let mut last_stdout: Option<String> = None;
        for b in blocks(&file, &text) {
            let Some((_, allowed)) = LANGUAGES.iter().find(|(l, _)| *l == b.lang) else {
                problems.push(format!(
                    "{}: fence language {:?}: tag every block with one of {:?}",
                    b.at(),
                    b.lang,
                    LANGUAGES.iter().map(|(l, _)| *l).collect::<Vec<_>>()
                ));
                continue;
            };
            if let Some(a) = b.attrs.iter().find(|a| !allowed.contains(&a.as_str())) {
                problems.push(format!(
                    "{}: {} block with unknown attribute {a:?}",
                    b.at(),
                    b.lang
                ));
                continue;
            }
            let has = |a: &str| b.attrs.iter().any(|x| x == a);
            match b.lang.as_str() {
                "sh" if has("skip-test") => {
                    let first = b.code.lines().next().unwrap_or_default();
                    match SKIPPED.iter().find(|s| first.starts_with(*s)) {
                        Some(s) => {
                            skipped.insert(*s);
                        }
                        None => problems.push(format!(
                            "{}: `{first}` is marked skip-test but is not one of SKIPPED",
                            b.at()
                        )),
                    }
                }
                "sh" => {
                    let script = b.code.replace("cargo run --release -- ", "sonarproj ");
                    let stdout = match run.get(&script) {
                        Some(s) => s.clone(),
                        None => {
                            shell += 1;
                            let s = run_shell(dir.path(), &script, &b.at());
                            run.insert(script, s.clone());
                            s
                        }
                    };
                    last_stdout = Some(stdout);
                }
                "toml" if has("sonar") => {
                    files += 1;
                    let name = format!("doc-sonar-{files}.toml");
                    std::fs::write(dir.path().join(&name), &b.code).unwrap();
                    run_shell(
                        dir.path(),
                        &format!(
                            "sonarproj project --from paper-fls --to {name} --range 5 --translation 0,0,0 --backend cpu-fast >/dev/null"
                        ),
                        &b.at(),
                    );
                }
                "toml" if has("sweep") => {
                    files += 1;
                    let name = format!("doc-sweep-{files}");
                    std::fs::write(dir.path().join(format!("{name}.toml")), &b.code).unwrap();
                    run_shell(
                        dir.path(),
                        &format!("sonarproj sweep --config {name}.toml --out out/{name} --backend cpu-fast"),
                        &b.at(),
                    );
                }
                "toml" if has("cargo") => {
                    let by_path =
                        b.code.contains("[dependencies]") && b.code.contains("sonarproj = { path = ");
                    problems.extend((!by_path).then(|| {
                        format!(
                            "{}: the Cargo fragment does not depend on sonarproj by path",
                            b.at()
                        )
                    }));
                }
                "toml" => problems.push(format!(
                    "{}: say what the TOML is (sonar, sweep or cargo) so that it is checked",
                    b.at()
                )),
                "rust" => {
                    let included = lib.contains(&format!("include_str!(\"../{file}\")"));
                    problems.extend((!included).then(|| {
                        format!(
                            "{}: a Rust block, but src/lib.rs does not include {file} as doctests",
                            b.at()
                        )
                    }));
                }
                _ if has("output") => match &last_stdout {
                    Some(stdout) if *stdout == b.code => {}
                    Some(stdout) => problems.push(format!(
                        "{}: the block is not what the last shell block run before it prints:\n{stdout}",
                        b.at()
                    )),
                    None => problems.push(format!("{}: an output block after no run shell block", b.at())),
                },
                _ => {}
            }
        }
    }
    for s in SKIPPED {
        if !skipped.contains(s) {
            problems.push(format!(
                "SKIPPED names `{s}`, which no skip-test block starts with"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(
        shell >= 15 && files >= 3,
        "{shell} shell blocks and {files} files run: too few found"
    );
    eprintln!(
        "{shell} shell blocks and {files} sonar and sweep files run in {:.1} s",
        started.elapsed().as_secs_f64()
    );
}

/// Returns the lines of `text` outside its fenced code blocks (the fences' own lines too left out).
fn outside_fences(text: &str) -> impl Iterator<Item = &str> {
    let mut fenced = false;
    text.lines().filter(move |line| {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            return false;
        }
        !fenced
    })
}

/// Returns `text` without its fenced blocks and inline code spans, where `](` is not a link.
fn prose(text: &str) -> String {
    let mut out = String::new();
    for line in outside_fences(text) {
        let mut rest = line;
        while let Some(start) = rest.find('`') {
            out.push_str(&rest[..start]);
            let ticks = rest[start..].len() - rest[start..].trim_start_matches('`').len();
            let after = &rest[start + ticks..];
            match after.find(&"`".repeat(ticks)) {
                Some(end) => rest = &after[end + ticks..],
                None => {
                    rest = after;
                }
            }
        }
        out.push_str(rest);
        out.push('\n');
    }
    out
}

/// Returns GitHub's anchor for a heading's text: markup dropped, lower case, letters, digits,
/// spaces, `-` and `_` kept, spaces made `-`.
fn slug(heading: &str) -> String {
    let mut text = String::new();
    let mut rest = heading;
    // A link keeps its text.
    while let Some(open) = rest.find("](") {
        text.push_str(&rest[..open]);
        rest = rest[open..].split_once(')').map_or("", |(_, r)| r);
    }
    text.push_str(rest);
    text.to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// Returns the anchors of a Markdown file: its headings' (a repeated one numbered `-1`, `-2`…
/// as GitHub does) and its `<a id>`s.
fn anchors(text: &str) -> HashSet<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = HashSet::new();
    for line in outside_fences(text) {
        if let Some(heading) = line.strip_prefix('#') {
            let base = slug(heading.trim_start_matches('#').trim());
            let n = seen.entry(base.clone()).or_insert(0);
            out.insert(if *n == 0 {
                base.clone()
            } else {
                format!("{base}-{n}")
            });
            *n += 1;
        }
        for part in line.split("<a id=\"").skip(1) {
            if let Some((id, _)) = part.split_once('"') {
                out.insert(id.to_string());
            }
        }
    }
    out
}

#[test]
fn links_between_the_docs_resolve() {
    let root = common::repository();
    let mut problems = Vec::new();
    let mut checked = 0;
    for path in documents(&root) {
        let file = relative(&root, &path);
        let text = std::fs::read_to_string(&path).unwrap();
        let prose = prose(&text);
        for part in prose.split("](").skip(1) {
            let Some((target, _)) = part.split_once(')') else {
                continue;
            };
            let target = target.split_whitespace().next().unwrap_or_default();
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            checked += 1;
            let (to, fragment) = target
                .split_once('#')
                .map_or((target, None), |(p, f)| (p, Some(f)));
            let resolved = if to.is_empty() {
                path.clone()
            } else {
                path.parent().unwrap().join(to)
            };
            if !resolved.exists() {
                problems.push(format!("{file}: link to {target}: no such file"));
                continue;
            }
            if let Some(fragment) = fragment {
                let body = std::fs::read_to_string(&resolved).unwrap_or_default();
                if !anchors(&body).contains(fragment) {
                    problems.push(format!("{file}: link to {target}: no such heading"));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(checked > 50, "only {checked} links found");
}

#[test]
fn anchors_are_githubs() {
    // The rule the link check relies on, on headings of these docs' kinds.
    let a = anchors(
        "# A\n## Summaries only (`[summary]` with `rows = false`)\n## A\n```sh\n# not a heading\n```\n<a id=\"x\"></a>\n### The paper's simulations: 1–9\n",
    );
    for want in [
        "a",
        "summaries-only-summary-with-rows--false",
        "a-1",
        "x",
        "the-papers-simulations-19",
    ] {
        assert!(a.contains(want), "{want} not in {a:?}");
    }
    assert!(!a.contains("not-a-heading"));
    assert_eq!(slug("See [Sweeps](sweeps.md) here"), "see-sweeps-here");
}
