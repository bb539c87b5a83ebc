//! The command line's GPU options, read from its environment variables, and the backend or
//! mask engine a command asks for, opened with them. The engine reads no environment.
//! [`sonarproj_apps::gpu_env`] defines the variables and their values. A value outside the
//! allowed ones is bad input (exit status 2) naming the variable.

use sonarproj::gpu::GpuOptions;
use sonarproj::{Backend, BackendChoice, MaskEngine, Sonar};
use sonarproj_apps::Result;

/// Returns the GPU options the environment gives ([`sonarproj_apps::gpu_env`]).
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming the variable whose value is not allowed.
pub(crate) fn gpu_options() -> Result<GpuOptions> {
    sonarproj_apps::gpu_env::gpu_options(|name| std::env::var(name).ok())
}

/// Returns the options for `choice`: the environment's for a GPU or `auto`, none for a CPU
/// backend. A CPU backend never opens a GPU, so a bad variable does not stop it.
///
/// # Errors
/// As [`gpu_options`].
pub(crate) fn options_for(choice: BackendChoice) -> Result<GpuOptions> {
    match choice {
        BackendChoice::Cpu | BackendChoice::CpuFast => Ok(GpuOptions::default()),
        BackendChoice::Auto | BackendChoice::Gpu => gpu_options(),
    }
}

/// What every notice of `auto` running on the CPU ends with: how to choose the CPU and be told
/// nothing.
pub(crate) const SILENCE: &str = "; --backend cpu-fast skips this note";

/// Returns `notice`'s line in the command line's words, ending in [`SILENCE`].
fn line(notice: &sonarproj::projection::backend::Notice) -> String {
    format!("{}{SILENCE}", notice.render(&super::names::name))
}

/// Returns the backend for `choice` with the environment's GPU options. When `auto` fell back
/// to the CPU, also returns its one-line notice in the command line's words.
///
/// # Errors
/// As [`gpu_options`] and [`Backend::select`].
pub(crate) fn select(choice: BackendChoice) -> Result<(Backend, Option<String>)> {
    let gpu = options_for(choice)?;
    let (backend, notice) = Backend::select(choice, &gpu)?;
    Ok((backend, notice.as_ref().map(line)))
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
    let (engine, notice) = MaskEngine::select(source, target, choice, counts, &gpu)?;
    Ok((engine, notice.as_ref().map(line)))
}
