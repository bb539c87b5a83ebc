//! `sonarproj devices`: the adapters wgpu sees and the one `auto` would use.

use sonarproj::gpu::context::{describe, list_adapters};
use sonarproj::{Backend, BackendChoice};
use sonarproj_apps::Result;

/// Runs `sonarproj devices`.
pub(super) fn run() -> Result<()> {
    let adapters = list_adapters();
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
    let (backend, notice) = Backend::select(BackendChoice::Auto)?;
    outln!("auto uses: {}", backend.device())?;
    if let Some(n) = notice {
        outln!("  {}", n.trim_start_matches("note: "))?;
    }
    Ok(())
}
