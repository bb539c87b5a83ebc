//! The wgpu instance, adapter, device and queue. Kept apart from the work so tests and callers
//! can bring their own device.

use crate::error::{Error, Result};
use crate::gpu::shaders::Precision;

/// Timeout for one wait on the GPU; lavapipe can be slow on big batches.
pub const WAIT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(600);

/// A device ready for compute work, with the adapter it came from.
#[derive(Clone, Debug)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// What the adapter says of itself.
    pub info: wgpu::AdapterInfo,
    /// The limits the device was created with.
    pub limits: wgpu::Limits,
    /// The arithmetic of the splat stage: f64 where the adapter has it.
    pub precision: Precision,
}

/// Returns a wgpu instance over the backends named in `WGPU_BACKEND` (default: the primary ones,
/// Vulkan, Metal, DX12).
#[must_use]
pub fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle().with_env();
    if wgpu::Backends::from_env().is_none() {
        desc.backends = wgpu::Backends::PRIMARY;
    }
    wgpu::Instance::new(desc)
}

/// Returns what every adapter wgpu sees says of itself.
#[must_use]
pub fn list_adapters() -> Vec<wgpu::AdapterInfo> {
    let inst = instance();
    let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
    pollster::block_on(inst.enumerate_adapters(backends))
        .iter()
        .map(|a| a.get_info())
        .collect()
}

/// Returns a short description of an adapter: name, backend, type, driver.
#[must_use]
pub fn describe(info: &wgpu::AdapterInfo) -> String {
    format!(
        "{} ({:?}, {:?}, driver {} {})",
        info.name, info.backend, info.device_type, info.driver, info.driver_info
    )
    .replace(" )", ")")
}

impl GpuContext {
    /// Returns whether the adapter is a software one (lavapipe, llvmpipe, WARP): it runs on the
    /// CPU's cores.
    #[must_use]
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Returns a context on the adapter `auto` picks: `WGPU_ADAPTER_NAME` when set, else the
    /// high-performance adapter of the enabled backends (a software one such as lavapipe counts).
    ///
    /// # Errors
    /// [`Error::NoAdapter`] when no adapter exists; [`Error::Gpu`] when the device cannot be made;
    /// [`Error::InvalidValue`] when `WGPU_ADAPTER_NAME` names no adapter.
    pub fn new() -> Result<Self> {
        let inst = instance();
        let adapter = match std::env::var("WGPU_ADAPTER_NAME") {
            // wgpu's own helper for this variable panics when nothing matches.
            Ok(wanted) => {
                let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
                let adapters = pollster::block_on(inst.enumerate_adapters(backends));
                let lower = wanted.to_lowercase();
                let found = adapters
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&lower));
                match found {
                    Some(k) => adapters.into_iter().nth(k).expect("found above"),
                    None => {
                        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
                        let excerpt: String = wanted.chars().take(80).collect();
                        return Err(Error::invalid(
                            "WGPU_ADAPTER_NAME",
                            format!("{excerpt:?}"),
                            if names.is_empty() {
                                "the name of an adapter, but wgpu sees none".to_string()
                            } else {
                                format!("part of an adapter's name: {}", names.join(", "))
                            },
                        ));
                    }
                }
            }
            Err(_) => pollster::block_on(inst.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::from_env().unwrap_or_default(),
                ..Default::default()
            }))
            .map_err(|e| Error::NoAdapter {
                hint: format!(": {e}"),
            })?,
        };
        Self::from_adapter(&adapter)
    }

    /// Returns a context on `adapter`, asking for the larger buffer limits it offers; the splat
    /// stage computes in f64 where the adapter has it, unless the environment variable
    /// `SONARPROJ_GPU_PRECISION` is `df` (double-f32, for measuring that path).
    ///
    /// # Errors
    /// [`Error::Gpu`] when the device cannot be made.
    pub fn from_adapter(adapter: &wgpu::Adapter) -> Result<Self> {
        let offered = adapter.limits();
        let mut limits = wgpu::Limits::default();
        // Ask for up to 1 GiB bindings where the adapter has them; chunks are sized from these.
        limits.max_storage_buffer_binding_size = offered.max_storage_buffer_binding_size.min(1 << 30);
        limits.max_buffer_size = offered.max_buffer_size.min(1 << 30);
        limits.max_storage_buffers_per_shader_stage = limits
            .max_storage_buffers_per_shader_stage
            .min(offered.max_storage_buffers_per_shader_stage);
        // SONARPROJ_GPU_PRECISION=df measures the double-f32 path (what GPUs without f64 run)
        // on a GPU that has f64.
        let force_df = std::env::var("SONARPROJ_GPU_PRECISION").is_ok_and(|v| v.trim() == "df");
        let f64_ok = adapter.features().contains(wgpu::Features::SHADER_F64) && !force_df;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("sonarproj"),
            required_limits: limits.clone(),
            required_features: if f64_ok {
                wgpu::Features::SHADER_F64
            } else {
                wgpu::Features::empty()
            },
            ..Default::default()
        }))
        .map_err(|e| Error::Gpu(format!("cannot create a device: {e}")))?;
        Ok(GpuContext {
            device,
            queue,
            info: adapter.get_info(),
            limits,
            precision: if f64_ok {
                Precision::F64
            } else {
                Precision::DoubleF32
            },
        })
    }
}
