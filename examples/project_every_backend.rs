//! One pose projected on every backend and compared: the f64 reference, the fast CPU path and,
//! where a GPU adapter exists, the WGSL shaders.
//!
//! Run: `cargo run --release --example project_every_backend`

use sonarproj::{
    Backend, Batch, BatchItem, GpuOptions, Measurement, Output, RelativePose, Rotation, Sampling, Sonar,
};

fn main() -> Result<(), sonarproj::Error> {
    quiet_headless_vulkan();
    // The paper's pair: a feature seen by the FLS, looked for in the sidescan.
    let fls = Sonar::preset("paper-fls").expect("a preset");
    let sss = Sonar::preset("paper-sss").expect("a preset");
    // A feature at 5 m, azimuth 10°, measured by the FLS (its elevation is lost).
    let feature = Measurement::of(&fls, 5.0, 10.0)?;
    // The sidescan pitched 90° and placed so the feature's true point (elevation 0) lies 15 m
    // from it, straight ahead: the paper's placement, `[range (m), azimuth (deg), elevation (deg)]`.
    let rotation = Rotation::RollPitchYaw {
        roll: 0.0,
        pitch: 90.0,
        yaw: 0.0,
    };
    let pose = RelativePose::placement(rotation, [5.0, 10.0, 0.0], [15.0, 0.0, 0.0])?;
    let batch = Batch {
        sigma_range: None,
        source: fls,
        target: sss,
        sampling: Sampling::Step(0.1),
        area_grid: sonarproj::PAPER_AREA_GRID,
        items: vec![BatchItem {
            true_point: None,
            measurement: feature,
            pose,
        }],
    };

    let mut backends = vec![Backend::Cpu, Backend::CpuFast];
    // The GPU the engine picks (GpuOptions names an adapter, a precision, a variant).
    match Backend::gpu(&GpuOptions::default()) {
        Ok(gpu) => backends.push(gpu),
        Err(e) => println!("no GPU backend here ({e})"),
    }
    let mut reference = None;
    for backend in &backends {
        let m = backend.project(&batch, Output::MetricsOnly)?.remove(0).metrics;
        println!(
            "{:8} visible {:5} of {:5}  range {:.4}..{:.4} m  span {:.4} m  occupied {} bins",
            backend.label(),
            m.visible,
            m.total,
            m.range_min.unwrap_or(f64::NAN),
            m.range_max.unwrap_or(f64::NAN),
            m.span,
            m.occupied,
        );
        let r = reference.get_or_insert(m);
        // The CPU paths are f64 and agree exactly; the GPU rounds to f32, so a sample on a bin
        // edge may land in the neighbouring bin (the test suite bounds that difference).
        if !matches!(backend, Backend::Gpu(_)) {
            assert_eq!(
                (m.visible, m.occupied),
                (r.visible, r.occupied),
                "{}",
                backend.name()
            );
        }
    }
    Ok(())
}

/// On a headless machine (no `XDG_RUNTIME_DIR`), Mesa's Vulkan device-select layer tries to reach
/// a Wayland display and prints `error: XDG_RUNTIME_DIR is invalid or not set` for every GPU
/// instance. It only reorders adapters, so a program switches it off there (`NODEVICE_SELECT=1`)
/// before opening a GPU, unless its user set that variable, as the command line and the Python
/// package do. The engine reads no environment: this is the program's choice.
fn quiet_headless_vulkan() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() && std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: called first thing in main, before any other thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}
