//! `sonarproj devices`: the adapters wgpu sees and the one `auto` would use.

use sonarproj::BackendChoice;
use sonarproj::gpu::context::{describe, list_adapters};
use sonarproj_apps::Result;

/// Runs `sonarproj devices`.
pub(super) fn run() -> Result<()> {
    let options = super::gpu_env::gpu_options()?;
    let adapters = list_adapters(&options);
    let backends = std::env::var("WGPU_BACKEND").unwrap_or_else(|_| "vulkan,metal,dx12 (default)".into());
    outln!("backends: {backends}")?;
    if adapters.is_empty() {
        outln!("adapters: none")?;
    } else {
        outln!("adapters:")?;
        for (i, info) in adapters.iter().enumerate() {
            outln!("  {i}: {}", describe(info))?;
        }
    }
    let (backend, notice) = super::gpu_env::select(BackendChoice::Auto)?;
    outln!("auto uses: {}", backend.device())?;
    if let Some(n) = notice {
        outln!(
            "  {}",
            n.trim_start_matches("note: ")
                .trim_end_matches(super::gpu_env::SILENCE)
        )?;
    }
    Ok(())
}
