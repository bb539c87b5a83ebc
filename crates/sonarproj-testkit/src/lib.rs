//! Helpers shared by the workspace's integration tests: presets, the one GPU context of a test
//! binary, the envelope check of a GPU result, the built `sonarproj` binary, and PNG pictures.
//! Test code only: no shipped crate depends on it.

use sonarproj::Sonar;
use sonarproj::gpu::{GpuContext, GpuOptions};
use sonarproj::projection::gpu::GpuBackend;

/// Returns the preset `name`. Tests name only presets that exist.
#[must_use]
pub fn preset(name: &str) -> Sonar {
    Sonar::preset(name).unwrap_or_else(|| panic!("no preset {name:?}"))
}

/// Returns the repository's root, where the README's commands run: the nearest folder at or
/// above the current one holding `crates/sonarproj-cli`, else the root this crate was built in.
/// Cargo runs a test in its package's folder, and `scripts/gpu-remote.sh` from a copy's root.
#[must_use]
pub fn repository() -> std::path::PathBuf {
    let here = std::env::current_dir().unwrap_or_default();
    here.ancestors()
        .find(|d| d.join("crates/sonarproj-cli").is_dir() && d.join("Cargo.toml").is_file())
        .map_or_else(
            || std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."),
            std::path::Path::to_path_buf,
        )
}

/// Returns a command running the built `sonarproj` binary in the repository's root, as a user
/// runs it. It silences Mesa's device-select layer on headless machines.
///
/// # Panics
/// When the binary is not built.
#[must_use]
pub fn sonarproj() -> assert_cmd::Command {
    let mut c = assert_cmd::Command::cargo_bin("sonarproj").expect("the sonarproj binary");
    c.env("NODEVICE_SELECT", "1").current_dir(repository());
    c
}

/// Makes a FIFO at `path` with `mkfifo`.
///
/// # Panics
/// When it cannot be made.
pub fn mkfifo(path: &std::path::Path) {
    let made = std::process::Command::new("mkfifo").arg(path).status().unwrap();
    assert!(made.success(), "mkfifo {}", path.display());
}

/// Returns a thread that opens the FIFO at `path` and reads what a writer put through it, as
/// text.
///
/// # Panics
/// The thread panics when the FIFO cannot be read, or what came through is not UTF-8.
#[must_use]
pub fn read_fifo(path: &std::path::Path) -> std::thread::JoinHandle<String> {
    let path = path.to_path_buf();
    std::thread::spawn(move || std::fs::read_to_string(path).unwrap())
}

/// Returns a thread that opens the FIFO at `path` and reads the bytes a writer put through it.
///
/// # Panics
/// The thread panics when the FIFO cannot be read.
#[must_use]
pub fn read_fifo_bytes(path: &std::path::Path) -> std::thread::JoinHandle<Vec<u8>> {
    let path = path.to_path_buf();
    std::thread::spawn(move || std::fs::read(path).unwrap())
}

/// Runs the binary with `args` and `stdin`. Expects exit status 2 (bad input), no panic, and a
/// stderr containing each of `needles`.
///
/// # Panics
/// When any of that does not hold.
pub fn rejects(args: &[&str], stdin: Option<&str>, needles: &[&str]) {
    let mut cmd = sonarproj();
    cmd.args(args);
    if let Some(s) = stdin {
        cmd.write_stdin(s);
    }
    let out = cmd.assert().code(2).get_output().clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "stderr lacks {n:?}: {err}");
    }
}

/// Returns the `--backend` values to try: always `cpu`, the CPU backend a test wants, and `gpu`
/// where an adapter exists. In CI one always does, since [`gpu`] fails loudly without one.
#[must_use]
pub fn cli_backends(cpu: &'static str) -> Vec<&'static str> {
    let mut b = vec![cpu];
    if gpu().is_some() {
        b.push("gpu");
    }
    b
}

/// Returns the test run's GPU options, read from the environment as the command line does
/// ([`sonarproj_apps::gpu_env`]). `SONARPROJ_GPU_PRECISION=df`, say, runs in double-f32.
///
/// # Panics
/// When a variable holds a value it does not allow: a test run must not quietly ignore it.
#[must_use]
pub fn gpu_options() -> GpuOptions {
    sonarproj_apps::gpu_env::gpu_options(|name| std::env::var(name).ok())
        .unwrap_or_else(|e| panic!("the test run's GPU variables: {e}"))
}

/// Returns `out`, a command's stdout, parsed as JSON.
///
/// # Panics
/// When it is not JSON, showing it.
#[must_use]
pub fn json(out: &[u8]) -> serde_json::Value {
    serde_json::from_slice(out).unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(out)))
}

/// Returns the test binary's one GPU context, on the adapter `auto` would use.
/// All tests share it, as an application shares its device. On an H100 with NVIDIA's Vulkan
/// driver, tests that each made their own instance crashed the process or found no driver.
/// Without an adapter it panics when `CI=true` (GPU tests must run in CI, on lavapipe), and
/// otherwise says the test is skipped and returns `None`.
#[must_use]
pub fn gpu_context() -> Option<GpuContext> {
    static CONTEXT: std::sync::OnceLock<Result<GpuContext, String>> = std::sync::OnceLock::new();
    match CONTEXT.get_or_init(|| GpuContext::open(&gpu_options()).map_err(|e| e.to_string())) {
        Ok(ctx) => Some(ctx.clone()),
        Err(e) => {
            if std::env::var("CI").is_ok_and(|v| v == "true" || v == "1") {
                panic!("CI=true but no GPU adapter: {e}. Install lavapipe (mesa-vulkan-drivers).");
            }
            say_skipped(e);
            None
        }
    }
}

/// Writes `skipped: no adapter` and the test's name to stderr, once per test, and the reason once
/// per test binary. It bypasses the harness's capture so a passing GPU test says it was skipped.
fn say_skipped(why: &str) {
    use std::io::Write;
    static SAID: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let test = std::thread::current().name().unwrap_or("a GPU test").to_string();
    let mut said = SAID.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if said.contains(&test) {
        return;
    }
    let reason = if said.is_empty() {
        format!(": {why}")
    } else {
        String::new()
    };
    said.push(test.clone());
    let _ = writeln!(std::io::stderr(), "skipped: no adapter ({test}){reason}");
}

/// Returns a GPU backend on the shared [`gpu_context`], with the splat stage the GPU variables
/// ask for.
#[must_use]
pub fn gpu() -> Option<GpuBackend> {
    gpu_context().map(gpu_backend_on)
}

/// Returns a GPU backend on `ctx`, with the splat stage the GPU variables ask for.
///
/// # Panics
/// When the device refuses a stage.
#[must_use]
pub fn gpu_backend_on(ctx: GpuContext) -> GpuBackend {
    let variant = sonarproj::projection::gpu::SplatOptions::for_adapter(&ctx, &gpu_options());
    GpuBackend::with_options(ctx, variant).expect("the GPU builds the projection stages")
}

use sonarproj::Projection;
use sonarproj::geometry::sonar::SonarKind;
use sonarproj::occupancy::Layout;
use sonarproj::projection::envelope::Bounds;

/// The relative error allowed on the GPU's FLS occupied measure. It sums pixel areas in f32:
/// at most about (rows per thread + log2 64) roundings of 2^-24, well under 1e-5 for every
/// layout here. The SSS measure is computed in f64 from the exact count and gets no allowance.
pub const F32_AREA_SUM_RELATIVE: f64 = 1e-5;

/// Returns `Ok` when `p`, a GPU result with its occupancy, lies inside the CPU reference's
/// envelope `b` for the same pose. Else returns a message naming the failed check.
pub fn check_within_bounds(layout: &Layout, b: &Bounds, p: &Projection) -> Result<(), String> {
    let m = &p.metrics;
    let occ = p.occupancy.as_ref().ok_or("no occupancy read back")?;
    if !(b.visible_min..=b.visible_max).contains(&m.visible) {
        return Err(format!(
            "visible {} outside [{}, {}]",
            m.visible, b.visible_min, b.visible_max
        ));
    }
    if !b.certain.is_subset_of(occ) {
        let missing: Vec<_> = b
            .certain
            .pixels()
            .filter(|&(i, j)| !occ.get(i, j))
            .take(5)
            .collect();
        return Err(format!("certain pixels not set: {missing:?}"));
    }
    if !occ.is_subset_of(&b.possible) {
        let extra: Vec<_> = occ
            .pixels()
            .filter(|&(i, j)| !b.possible.get(i, j))
            .take(5)
            .collect();
        return Err(format!("pixels set that no sample can reach: {extra:?}"));
    }
    if m.occupied != occ.count() {
        return Err(format!("occupied {} but {} bits set", m.occupied, occ.count()));
    }
    let (lo, hi) = b.measure(layout);
    let slack = match layout.kind {
        SonarKind::Fls => F32_AREA_SUM_RELATIVE,
        SonarKind::Sss => 1e-12,
    };
    if m.occupied_measure < lo * (1.0 - slack) || m.occupied_measure > hi * (1.0 + slack) {
        return Err(format!("measure {} outside [{lo}, {hi}]", m.occupied_measure));
    }
    // Both areas are a cell count times the same cell², so they compare exactly. The cells lie
    // between the certain and the possible ones.
    match (b.projection_area(layout), m.projection_area) {
        (None, None) => {}
        (Some((lo, hi)), Some(a)) if (lo..=hi).contains(&a) => {}
        (interval, area) => {
            return Err(format!("projection_area {area:?} outside {interval:?}"));
        }
    }
    if let Some(grid) = layout.area_grid {
        let cells = p.cells.as_ref().ok_or("no cells read back")?;
        if !b.cells_certain.is_subset_of(cells) {
            return Err("certain projection-area cells not set".into());
        }
        if !cells.is_subset_of(&b.cells_possible) {
            return Err("projection-area cells set that no sample can reach".into());
        }
        if m.projection_area != Some(grid.area(cells.count())) {
            return Err(format!(
                "projection_area {:?} but {} cells set",
                m.projection_area,
                cells.count()
            ));
        }
    }
    if m.visible > 0 {
        let inside = |name: &str, v: Option<f64>, (lo, hi): (f64, f64)| -> Result<(), String> {
            let v = v.ok_or(format!("{name} missing"))?;
            if v < lo || v > hi {
                return Err(format!("{name} {v} outside [{lo}, {hi}]"));
            }
            Ok(())
        };
        inside("range_min", m.range_min, b.range_min)?;
        inside("range_max", m.range_max, b.range_max)?;
        inside("azimuth_min", m.azimuth_min, b.azimuth_min)?;
        inside("azimuth_max", m.azimuth_max, b.azimuth_max)?;
    } else if m.range_min.is_some() || m.span != 0.0 {
        return Err("nothing visible but extremes or span reported".into());
    }
    Ok(())
}

/// Returns the number of pixels set in exactly one of `a` and `b`.
#[must_use]
pub fn differing_pixels(a: &sonarproj::Occupancy, b: &sonarproj::Occupancy) -> u64 {
    a.words
        .iter()
        .zip(&b.words)
        .map(|(x, y)| u64::from((x ^ y).count_ones()))
        .sum()
}

/// Returns the property tests' configuration: 256 cases from a fixed seed, so runs repeat and
/// CI sees the same cases. `PROPTEST_RNG_SEED=N` explores others. Failures found so far are
/// replayed first from the test's `.proptest-regressions` file.
#[must_use]
pub fn proptest_config() -> proptest::test_runner::Config {
    use proptest::test_runner::{Config, RngSeed};
    let default = Config::default();
    let rng_seed = match default.rng_seed {
        RngSeed::Random => RngSeed::Fixed(20_261_122),
        chosen => chosen,
    };
    Config {
        cases: 256,
        rng_seed,
        ..default
    }
}

/// A decoded picture the CLI wrote, read by the picture convention of docs/conventions.md and the
/// `report` module: panels of sonar data are the light grey (235, 235, 235) areas, the empty
/// field of view. Masks and occupied pixels are coloured.
pub struct Picture {
    /// Width (px).
    pub w: usize,
    /// Height (px).
    pub h: usize,
    rgb: Vec<u8>,
}

/// A panel's bounding box in a [`Picture`], inclusive.
#[derive(Clone, Copy, Debug)]
pub struct Panel {
    /// Leftmost column.
    pub x0: usize,
    /// Rightmost column.
    pub x1: usize,
    /// Top row.
    pub y0: usize,
    /// Bottom row.
    pub y1: usize,
}

/// The light grey of the empty field of view.
const EMPTY: [u8; 3] = [235, 235, 235];

impl Picture {
    /// Decodes the PNG at `path`, which must be 8-bit RGB.
    #[must_use]
    pub fn read(path: &std::path::Path) -> Self {
        let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut rgb = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut rgb).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb, "{}", path.display());
        assert_eq!(info.bit_depth, png::BitDepth::Eight, "{}", path.display());
        rgb.truncate(info.buffer_size());
        Picture {
            w: info.width as usize,
            h: info.height as usize,
            rgb,
        }
    }

    fn px(&self, x: usize, y: usize) -> [u8; 3] {
        let k = (y * self.w + x) * 3;
        [self.rgb[k], self.rgb[k + 1], self.rgb[k + 2]]
    }

    /// Returns the panels, left to right. A panel is a run of columns holding 20 light grey pixels
    /// in a row; runs a few columns apart (split by a bearing line) join. Its rows are those with
    /// 8 light grey pixels side by side, so anti-aliased text is not a panel.
    #[must_use]
    pub fn panels(&self) -> Vec<Panel> {
        let longest = |cells: &mut dyn Iterator<Item = [u8; 3]>| {
            let (mut best, mut run) = (0, 0);
            for c in cells {
                run = if c == EMPTY { run + 1 } else { 0 };
                best = best.max(run);
            }
            best
        };
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for x in 0..self.w {
            if longest(&mut (0..self.h).map(|y| self.px(x, y))) < 20 {
                continue;
            }
            match runs.last_mut() {
                Some(r) if x <= r.1 + 4 => r.1 = x,
                _ => runs.push((x, x)),
            }
        }
        runs.into_iter()
            .map(|(x0, x1)| {
                let rows: Vec<usize> = (0..self.h)
                    .filter(|&y| longest(&mut (x0..=x1).map(|x| self.px(x, y))) >= 8)
                    .collect();
                Panel {
                    x0,
                    x1,
                    y0: rows[0],
                    y1: rows[rows.len() - 1],
                }
            })
            .collect()
    }

    /// Returns the coloured pixels inside `p`: channels at least 60 apart, so not white, grey or
    /// black text.
    #[must_use]
    pub fn coloured(&self, p: Panel) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for y in p.y0..=p.y1 {
            for x in p.x0..=p.x1 {
                let c = self.px(x, y);
                if c.iter().max().unwrap() - c.iter().min().unwrap() >= 60 {
                    out.push((x, y));
                }
            }
        }
        out
    }

    /// Asserts that panel `p` holds coloured pixels, all in its lower half when `near`, else all in
    /// its upper half. `port` also checks the side: `Some(true)` the left half, `Some(false)` the
    /// right half, `None` no check.
    pub fn assert_side(&self, p: Panel, port: Option<bool>, near: bool, what: &str) {
        let px = self.coloured(p);
        assert!(!px.is_empty(), "{what}: nothing coloured in panel {p:?}");
        let (cx, cy) = ((p.x0 + p.x1) / 2, (p.y0 + p.y1) / 2);
        for &(x, y) in &px {
            if let Some(port) = port {
                assert_eq!(
                    x < cx,
                    port,
                    "{what}: pixel ({x}, {y}) in panel {p:?}: port must be on the left"
                );
            }
            assert_eq!(
                y > cy,
                near,
                "{what}: pixel ({x}, {y}) in panel {p:?}: near range must be at the bottom"
            );
        }
    }
}
