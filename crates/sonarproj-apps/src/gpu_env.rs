//! The GPU options as environment variables: their names, the values each allows, and one
//! checked reading. The command line takes them so, as do the tests and benches run under
//! `scripts/test.sh` and `scripts/gpu-remote.sh`. The engine reads no environment: a front
//! passes its lookup (`std::env::var`) in.
//!
//! | variable | values | option |
//! |---|---|---|
//! | `WGPU_BACKEND` | `vulkan`, `metal`, `dx12`, `gl` (comma-separated), or `none` | [`GpuOptions::backends`] |
//! | `WGPU_ADAPTER_NAME` | part of an adapter's name | [`GpuOptions::adapter`] |
//! | `SONARPROJ_GPU_PRECISION` | `f64`, `double-f32` (or `df`) | [`GpuOptions::precision`] |
//! | `SONARPROJ_GPU_CULL` | `0`, `1` | [`GpuOptions::cull`] |
//! | `SONARPROJ_GPU_FILTER` | `0`, `1` | [`GpuOptions::filter`] |
//! | `SONARPROJ_GPU_WORKGROUP` | `32`, `64`, `128`, `256` | [`GpuOptions::workgroup`] |

use sonarproj::error::excerpt;
use sonarproj::gpu::options::{SPLAT_WORKGROUPS, workgroups_text};
use sonarproj::gpu::{GpuOptions, Precision};

use crate::error::Result;

/// The variables, in the order of the table above.
pub const VARIABLES: [&str; 6] = [
    "WGPU_BACKEND",
    "WGPU_ADAPTER_NAME",
    "SONARPROJ_GPU_PRECISION",
    "SONARPROJ_GPU_CULL",
    "SONARPROJ_GPU_FILTER",
    "SONARPROJ_GPU_WORKGROUP",
];

/// The backend names `WGPU_BACKEND` takes (wgpu's own spellings).
const BACKENDS: [&str; 9] = [
    "vulkan", "vk", "metal", "mtl", "dx12", "d3d12", "gl", "gles", "opengl",
];

/// Returns the GPU options the variables give. `lookup` returns a variable's value, or `None`
/// when unset. A variable set to an empty value counts as unset.
///
/// # Errors
/// [`sonarproj::Error::InvalidValue`] naming the variable whose value is not allowed.
pub fn gpu_options(lookup: impl Fn(&str) -> Option<String>) -> Result<GpuOptions> {
    let var = |name: &str| {
        lookup(name)
            .map(|v| v.trim().to_string())
            .filter(|v| !v.is_empty())
    };
    let bad = |name: &str, value: &str, allowed: String| -> crate::Error {
        sonarproj::Error::invalid(name, excerpt(value), allowed).into()
    };
    let flag = |name: &str| -> Result<Option<bool>> {
        match var(name).as_deref() {
            None => Ok(None),
            Some("0") => Ok(Some(false)),
            Some("1") => Ok(Some(true)),
            Some(v) => Err(bad(name, v, "0 (off) or 1 (on)".into())),
        }
    };
    let backends = match var("WGPU_BACKEND") {
        None => None,
        Some(v) if v.eq_ignore_ascii_case("none") => Some(wgpu::Backends::empty()),
        Some(v) => {
            if v.split(',')
                .any(|b| !BACKENDS.contains(&b.trim().to_lowercase().as_str()))
            {
                return Err(bad(
                    "WGPU_BACKEND",
                    &v,
                    "vulkan, metal, dx12 or gl, comma-separated, or none".into(),
                ));
            }
            Some(wgpu::Backends::from_comma_list(&v))
        }
    };
    let precision = match var("SONARPROJ_GPU_PRECISION") {
        None => None,
        Some(v) => Some(
            Precision::parse(&v)
                .ok_or_else(|| bad("SONARPROJ_GPU_PRECISION", &v, "f64, or double-f32 (df)".into()))?,
        ),
    };
    let workgroup = match var("SONARPROJ_GPU_WORKGROUP") {
        None => None,
        Some(v) => match v.parse::<u32>() {
            Ok(w) if SPLAT_WORKGROUPS.contains(&w) => Some(w),
            _ => return Err(bad("SONARPROJ_GPU_WORKGROUP", &v, workgroups_text())),
        },
    };
    // Set but blank is refused, not read as unset: a name was meant.
    let adapter = match lookup("WGPU_ADAPTER_NAME") {
        Some(v) if v.trim().is_empty() => {
            return Err(bad(
                "WGPU_ADAPTER_NAME",
                "",
                "part of an adapter's name (`sonarproj devices` lists them)".into(),
            ));
        }
        other => other.map(|v| v.trim().to_string()),
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

#[cfg(test)]
mod tests {
    use super::*;

    fn read(pairs: &[(&str, &str)]) -> Result<GpuOptions> {
        let pairs: Vec<(String, String)> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        gpu_options(move |k| pairs.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone()))
    }

    #[test]
    fn every_variable_is_read_and_checked() {
        let o = read(&[
            ("WGPU_BACKEND", "vulkan,gl"),
            ("WGPU_ADAPTER_NAME", " H100 "),
            ("SONARPROJ_GPU_PRECISION", "df"),
            ("SONARPROJ_GPU_CULL", "0"),
            ("SONARPROJ_GPU_FILTER", "1"),
            ("SONARPROJ_GPU_WORKGROUP", "128"),
        ])
        .unwrap();
        assert_eq!(o.backends, Some(wgpu::Backends::VULKAN | wgpu::Backends::GL));
        assert_eq!(o.adapter.as_deref(), Some("H100"));
        assert_eq!(o.precision, Some(Precision::DoubleF32));
        assert_eq!(
            (o.cull, o.filter, o.workgroup),
            (Some(false), Some(true), Some(128))
        );
        assert_eq!(read(&[]).unwrap(), GpuOptions::default());
        assert_eq!(
            read(&[("WGPU_BACKEND", "none")]).unwrap().backends,
            Some(wgpu::Backends::empty())
        );
        for (var, value) in [
            ("WGPU_BACKEND", "vulkun"),
            ("WGPU_ADAPTER_NAME", " "),
            ("SONARPROJ_GPU_PRECISION", "f16"),
            ("SONARPROJ_GPU_CULL", "yes"),
            ("SONARPROJ_GPU_FILTER", "2"),
            ("SONARPROJ_GPU_WORKGROUP", "48"),
        ] {
            let e = read(&[(var, value)]).unwrap_err();
            assert!(e.is_input() && e.to_string().starts_with(var), "{var}: {e}");
        }
        assert_eq!(VARIABLES.len(), 6);
    }
}
