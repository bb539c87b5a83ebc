//! The GPU options of the command line, read from its environment variables (the engine reads
//! none; the variables and their values are [`sonarproj_apps::gpu_env`]'s): the backend or mask
//! engine a command asks for, opened with them. A value outside the allowed ones is bad input
//! (exit status 2) naming the variable.

use sonarproj::gpu::GpuOptions;
use sonarproj::{Backend, BackendChoice, MaskEngine, Sonar};
use sonarproj_apps::{Error, Result};

/// Returns the GPU options the environment gives ([`sonarproj_apps::gpu_env`]).
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming the variable whose value is not allowed.
pub(crate) fn gpu_options() -> Result<GpuOptions> {
    sonarproj_apps::gpu_env::gpu_options(|name| std::env::var(name).ok())
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
