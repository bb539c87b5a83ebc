//! The GPU options of the command line, read from its environment variables (the engine reads
//! none): `WGPU_BACKEND` (which wgpu backends: `vulkan`, `metal`, `dx12`, `gl`, comma-separated,
//! or `none`), `WGPU_ADAPTER_NAME` (part of an adapter's name), `SONARPROJ_GPU_PRECISION=df`
//! (double-f32 even on a GPU with f64), `SONARPROJ_GPU_CULL=0|1` and `SONARPROJ_GPU_FILTER=0|1`
//! (the splat stage's block culling and f32 filter), `SONARPROJ_GPU_WORKGROUP=32|64|128|256`. A
//! value outside these is bad input (exit status 2) naming the variable.

use sonarproj::gpu::{GpuOptions, Precision};
use sonarproj::{Backend, BackendChoice, MaskEngine, Sonar};
use sonarproj_apps::{Error, Result};

/// Returns the GPU options the environment gives.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming the variable whose value is not allowed.
pub(crate) fn gpu_options() -> Result<GpuOptions> {
    let var = |name: &str| std::env::var(name).ok().map(|v| v.trim().to_string());
    let bad = |name: &str, value: &str, allowed: &str| -> Error {
        sonarproj::Error::invalid(name, format!("{:?}", excerpt(value)), allowed).into()
    };
    let flag = |name: &str| -> Result<Option<bool>> {
        match var(name).as_deref() {
            None => Ok(None),
            Some("0") => Ok(Some(false)),
            Some("1") => Ok(Some(true)),
            Some(v) => Err(bad(name, v, "0 (off) or 1 (on)")),
        }
    };
    let backends = match var("WGPU_BACKEND") {
        None => None,
        Some(v) if v.eq_ignore_ascii_case("none") => Some(wgpu::Backends::empty()),
        Some(v) => {
            let known = [
                "vulkan", "vk", "metal", "mtl", "dx12", "d3d12", "gl", "gles", "opengl",
            ];
            if v.split(',')
                .any(|b| !known.contains(&b.trim().to_lowercase().as_str()))
            {
                return Err(bad(
                    "WGPU_BACKEND",
                    &v,
                    "vulkan, metal, dx12 or gl, comma-separated, or none",
                ));
            }
            Some(wgpu::Backends::from_comma_list(&v))
        }
    };
    let precision = match var("SONARPROJ_GPU_PRECISION").as_deref() {
        None => None,
        Some("df") => Some(Precision::DoubleF32),
        Some("f64") => Some(Precision::F64),
        Some(v) => return Err(bad("SONARPROJ_GPU_PRECISION", v, "df (double-f32) or f64")),
    };
    let workgroup = match var("SONARPROJ_GPU_WORKGROUP") {
        None => None,
        Some(v) => match v.parse::<u32>() {
            Ok(w) if sonarproj::gpu::options::SPLAT_WORKGROUPS.contains(&w) => Some(w),
            _ => return Err(bad("SONARPROJ_GPU_WORKGROUP", &v, "32, 64, 128 or 256")),
        },
    };
    let adapter = match var("WGPU_ADAPTER_NAME") {
        Some(v) if v.is_empty() => {
            return Err(bad(
                "WGPU_ADAPTER_NAME",
                &v,
                "part of an adapter's name (`sonarproj devices`)",
            ));
        }
        other => other,
    };
    Ok(GpuOptions {
        backends,
        adapter,
        precision,
        cull: flag("SONARPROJ_GPU_CULL")?,
        filter: flag("SONARPROJ_GPU_FILTER")?,
        workgroup,
    })
}

/// Returns the first 80 characters of `v` (an error never echoes a long value whole).
fn excerpt(v: &str) -> String {
    v.chars().take(80).collect()
}

/// Returns the options for `choice`: the environment's for a GPU or `auto`, none for a CPU
/// backend (which never opens a GPU, so a bad variable does not stop it).
///
/// # Errors
/// As [`gpu_options`].
pub(crate) fn options_for(choice: BackendChoice) -> Result<GpuOptions> {
    match choice {
        BackendChoice::Cpu | BackendChoice::CpuFast => Ok(GpuOptions::default()),
        BackendChoice::Auto | BackendChoice::Gpu => gpu_options(),
    }
}

/// Names the environment variable in an engine error about a GPU option (the engine names the
/// option, the command line knows where it came from).
pub(crate) fn name_variable(e: sonarproj::Error) -> Error {
    let e = match &e {
        sonarproj::Error::InvalidValue { field, .. } if field == "GPU adapter" => {
            e.in_context("WGPU_ADAPTER_NAME")
        }
        sonarproj::Error::InvalidValue { field, .. } if field == "GPU precision" => {
            e.in_context("SONARPROJ_GPU_PRECISION")
        }
        _ => e,
    };
    e.into()
}

/// Returns `auto`'s notice with the environment variable named where the engine named the
/// option it came from (an adapter name that matches nothing).
fn name_in_notice(notice: String) -> String {
    notice.replacen(
        "note: GPU adapter = ",
        "note: WGPU_ADAPTER_NAME: GPU adapter = ",
        1,
    )
}

/// Returns the backend for `choice` with the environment's GPU options and, when `auto` fell back
/// to the CPU, its one-line notice.
///
/// # Errors
/// As [`gpu_options`] and [`Backend::select`].
pub(crate) fn select(choice: BackendChoice) -> Result<(Backend, Option<String>)> {
    let gpu = options_for(choice)?;
    let (backend, notice) = Backend::select(choice, &gpu).map_err(name_variable)?;
    Ok((backend, notice.map(name_in_notice)))
}

/// Returns the mask engine for `choice` with the environment's GPU options, as [`select`].
///
/// # Errors
/// As [`gpu_options`] and [`MaskEngine::select`].
pub(crate) fn select_masks(
    source: Sonar,
    target: Sonar,
    choice: BackendChoice,
    counts: sonarproj::Counts,
) -> Result<(MaskEngine, Option<String>)> {
    let gpu = options_for(choice)?;
    let (engine, notice) = MaskEngine::select(source, target, choice, counts, &gpu).map_err(name_variable)?;
    Ok((engine, notice.map(name_in_notice)))
}
