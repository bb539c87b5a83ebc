//! How the GPU is opened and the splat stage built, as a value the fronts build and pass in. The
//! command line builds it from its environment variables, Python from keyword arguments, and a Rust
//! caller by hand. The engine itself reads no environment variable.

use crate::error::{Error, Param, Result};
use crate::gpu::precision::Precision;

/// The GPU adapter option ([`GpuOptions::adapter`]) as errors name it.
pub const ADAPTER: Param = Param::new("GPU adapter");
/// The GPU precision option ([`GpuOptions::precision`]) as errors name it.
pub const PRECISION: Param = Param::new("GPU precision");
/// The splat stage's workgroup option ([`GpuOptions::workgroup`]) as errors name it.
pub const WORKGROUP: Param = Param::new("GPU workgroup");

/// The splat stage's workgroup sizes [`GpuOptions::workgroup`] may take. They are multiples of the
/// culling block (16 samples) that every adapter runs (at least 256 threads a workgroup).
pub const SPLAT_WORKGROUPS: [u32; 4] = [32, 64, 128, 256];

/// Threads per workgroup of the splat stage by default: the WGSL `override WORKGROUP` in
/// splat.wgsl, checked in the shader tests.
pub const SPLAT_WORKGROUP: u32 = 64;

/// The options of the GPU: which adapter, which arithmetic, which variant of the splat stage. Each
/// field left `None` takes the engine's choice, and [`GpuOptions::default`] leaves them all.
/// Results do not depend on `cull`, `filter` or `workgroup` (tested). `precision` changes only the
/// last bits of the GPU's f32 output, within the envelope of "How the GPU is checked".
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GpuOptions {
    /// The wgpu backends adapters are looked for on. `None`: the primary ones (Vulkan, Metal,
    /// DX12). Empty: none, so every GPU request finds no adapter.
    pub backends: Option<wgpu::Backends>,
    /// Part of the adapter's name, case-insensitive. `None`: the high-performance adapter of the
    /// backends (a software one such as lavapipe counts).
    pub adapter: Option<String>,
    /// The splat stage's arithmetic. `None`: f64 where the adapter has it, else double-f32.
    /// `Some(DoubleF32)` measures the path of GPUs without f64 on one that has it.
    pub precision: Option<Precision>,
    /// Block culling in the splat stage. `None`: on for a hardware adapter, off for a software one
    /// (measured slower there).
    pub cull: Option<bool>,
    /// The splat stage's f32 filter: each sample is decided in f32 first, and in f64 or double-f32
    /// only near a bound or an edge. `None`: on for a hardware adapter, off for a software one.
    pub filter: Option<bool>,
    /// Threads a workgroup of the splat stage, one of [`SPLAT_WORKGROUPS`]. `None`:
    /// [`SPLAT_WORKGROUP`].
    pub workgroup: Option<u32>,
}

/// Returns the allowed workgroup sizes in words: `32, 64, 128 or 256`.
#[must_use]
pub fn workgroups_text() -> String {
    let names: Vec<String> = SPLAT_WORKGROUPS.iter().map(u32::to_string).collect();
    let (last, rest) = names.split_last().expect("sizes");
    format!("{} or {last}", rest.join(", "))
}

/// Returns `Ok(())` when `workgroup` is one of [`SPLAT_WORKGROUPS`].
///
/// # Errors
/// [`Error::InvalidValue`] naming the GPU workgroup otherwise.
pub fn check_workgroup(workgroup: u32) -> Result<()> {
    if SPLAT_WORKGROUPS.contains(&workgroup) {
        Ok(())
    } else {
        Err(Error::invalid(
            WORKGROUP,
            workgroup,
            format!("{} threads", workgroups_text()),
        ))
    }
}

impl GpuOptions {
    /// Returns `Ok(())` when every option given is allowed.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming `workgroup` when it is not one of [`SPLAT_WORKGROUPS`], or
    /// `adapter` when it is empty.
    pub fn validate(&self) -> Result<()> {
        if let Some(w) = self.workgroup {
            check_workgroup(w)?;
        }
        if self.adapter.as_deref().is_some_and(|a| a.trim().is_empty()) {
            return Err(Error::invalid(
                ADAPTER,
                "\"\"",
                "part of an adapter's name (`sonarproj devices` lists them)",
            ));
        }
        Ok(())
    }

    /// Returns the backends adapters are looked for on.
    #[must_use]
    pub fn backends(&self) -> wgpu::Backends {
        self.backends.unwrap_or(wgpu::Backends::PRIMARY)
    }

    /// Returns a short description of the options given, such as `adapter "H100", double-f32`,
    /// or `defaults`.
    #[must_use]
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if let Some(b) = self.backends {
            parts.push(format!("backends {b:?}"));
        }
        if let Some(a) = &self.adapter {
            parts.push(format!("adapter {a:?}"));
        }
        if let Some(p) = self.precision {
            parts.push(p.name().to_string());
        }
        for (name, v) in [("culling", self.cull), ("f32 filter", self.filter)] {
            if let Some(on) = v {
                parts.push(format!("{name} {}", if on { "on" } else { "off" }));
            }
        }
        if let Some(w) = self.workgroup {
            parts.push(format!("{w} threads a workgroup"));
        }
        if parts.is_empty() {
            "defaults".to_string()
        } else {
            parts.join(", ")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_options_are_named() {
        let bad = GpuOptions {
            workgroup: Some(48),
            ..GpuOptions::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("workgroup") && e.contains("48"), "{e}");
        let bad = GpuOptions {
            adapter: Some(" ".into()),
            ..GpuOptions::default()
        };
        assert!(bad.validate().unwrap_err().to_string().contains("adapter"));
        for w in SPLAT_WORKGROUPS {
            let ok = GpuOptions {
                workgroup: Some(w),
                ..GpuOptions::default()
            };
            assert!(ok.validate().is_ok());
        }
        assert_eq!(GpuOptions::default().describe(), "defaults");
    }
}
