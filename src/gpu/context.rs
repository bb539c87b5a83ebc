//! The wgpu instance, adapter, device and queue. They are kept apart from the work, so tests and
//! callers can bring their own device. A process opens one context per device its [`GpuOptions`]
//! ask for, and shares it ([`GpuContext::open`]). Instances created and dropped by many threads at
//! once crashed NVIDIA's Vulkan driver.

use std::sync::{Mutex, PoisonError};

use crate::error::{Error, Result, excerpt};
use crate::gpu::options::GpuOptions;
use crate::gpu::precision::Precision;

/// Timeout for one wait on the GPU. Lavapipe can be slow on big batches.
pub const WAIT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(600);

/// A device ready for compute work, with the adapter it came from. Cloning it shares the device.
/// What runs on it (the splat stage's variant) belongs to the backend, not the device.
#[derive(Clone, Debug)]
pub struct GpuContext {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    precision: Precision,
}

/// What tells two devices apart: the backends, the adapter asked for and the precision asked for.
/// That is [`GpuOptions`] without the splat stage's variant.
type DeviceKey = (Option<wgpu::Backends>, Option<String>, Option<Precision>);

fn device_key(options: &GpuOptions) -> DeviceKey {
    (options.backends, options.adapter.clone(), options.precision)
}

fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    wgpu::Instance::new(desc)
}

/// Returns what every adapter wgpu sees on the backends of `options` says of itself.
#[must_use]
pub fn list_adapters(options: &GpuOptions) -> Vec<wgpu::AdapterInfo> {
    let backends = options.backends();
    pollster::block_on(instance(backends).enumerate_adapters(backends))
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

/// The contexts this process has opened, with the options they were opened for.
static OPENED: Mutex<Vec<(DeviceKey, GpuContext)>> = Mutex::new(Vec::new());

impl GpuContext {
    /// Returns what the adapter says of itself (name, backend, type, driver).
    #[must_use]
    pub fn info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// Returns the limits the device was created with.
    #[must_use]
    pub fn limits(&self) -> &wgpu::Limits {
        &self.limits
    }

    /// Returns the arithmetic of the projection's `Real` numbers: f64 where the adapter has it.
    #[must_use]
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// Returns the features the device was created with (f64 in shaders, timestamp queries).
    #[must_use]
    pub fn features(&self) -> wgpu::Features {
        self.device.features()
    }

    pub(crate) fn device(&self) -> &wgpu::Device {
        &self.device
    }

    pub(crate) fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Returns whether the adapter is a software one (lavapipe, llvmpipe, WARP), which runs on the
    /// CPU's cores.
    #[must_use]
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Returns the process's context for `options`, shared as an application shares its device.
    ///
    /// The first call opens it, on the adapter `options.adapter` names, else on the
    /// high-performance adapter of the backends (a software one such as lavapipe included). Every
    /// later call that asks for the same device (the same backends, adapter and precision) shares
    /// it. The splat stage's variant in `options` is not the device's: a backend takes it
    /// ([`crate::projection::gpu::SplatOptions::for_adapter`]).
    ///
    /// # Errors
    /// As [`GpuOptions::validate`]; [`Error::NoAdapter`] when no adapter exists;
    /// [`Error::InvalidValue`] when `options.adapter` names none (the message lists those there
    /// are); [`Error::Gpu`] when the device cannot be made.
    pub fn open(options: &GpuOptions) -> Result<Self> {
        options.validate()?;
        let mut opened = OPENED.lock().unwrap_or_else(PoisonError::into_inner);
        let key = device_key(options);
        if let Some((_, ctx)) = opened.iter().find(|(k, _)| *k == key) {
            return Ok(ctx.clone());
        }
        let ctx = Self::open_new(options)?;
        opened.push((key, ctx.clone()));
        Ok(ctx)
    }

    /// Returns how many contexts this process has opened with [`GpuContext::open`]. There is one
    /// per device asked for (backends, adapter, precision), however often, from however many
    /// threads and with whichever variant of the splat stage.
    #[must_use]
    pub fn opened() -> usize {
        OPENED.lock().unwrap_or_else(PoisonError::into_inner).len()
    }

    /// Returns a new context for `options` (validated).
    fn open_new(options: &GpuOptions) -> Result<Self> {
        let backends = options.backends();
        let inst = instance(backends);
        let adapter = match &options.adapter {
            // wgpu's own helper for choosing by name panics when nothing matches.
            Some(wanted) => {
                let adapters = pollster::block_on(inst.enumerate_adapters(backends));
                let lower = wanted.to_lowercase();
                let found = adapters
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&lower));
                match found {
                    Some(k) => adapters.into_iter().nth(k).expect("found above"),
                    None => {
                        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
                        return Err(Error::invalid(
                            crate::gpu::options::ADAPTER,
                            excerpt(wanted),
                            if names.is_empty() {
                                "the name of an adapter, but wgpu sees none".to_string()
                            } else {
                                format!("part of an adapter's name: {}", names.join(", "))
                            },
                        ));
                    }
                }
            }
            None => pollster::block_on(inst.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            }))
            .map_err(|e| Error::NoAdapter {
                hint: format!(": {e}"),
            })?,
        };
        Self::from_adapter(&adapter, options.precision)
    }

    /// Returns a new context on `adapter`, not shared, asking for the larger buffer limits it
    /// offers. The projection computes in f64 where the adapter has it, unless `precision` asks for
    /// double-f32.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] when `precision` asks for f64 on an adapter without it;
    /// [`Error::Gpu`] when the device cannot be made.
    pub fn from_adapter(adapter: &wgpu::Adapter, precision: Option<Precision>) -> Result<Self> {
        let offered = adapter.limits();
        let mut limits = wgpu::Limits::default();
        // Ask for up to 1 GiB bindings where the adapter has them. Chunks are sized from these.
        limits.max_storage_buffer_binding_size = offered.max_storage_buffer_binding_size.min(1 << 30);
        limits.max_buffer_size = offered.max_buffer_size.min(1 << 30);
        limits.max_storage_buffers_per_shader_stage = limits
            .max_storage_buffers_per_shader_stage
            .min(offered.max_storage_buffers_per_shader_stage);
        let has_f64 = adapter.features().contains(wgpu::Features::SHADER_F64);
        let precision = match precision {
            None if has_f64 => Precision::F64,
            None | Some(Precision::DoubleF32) => Precision::DoubleF32,
            Some(Precision::F64) if has_f64 => Precision::F64,
            Some(Precision::F64) => {
                return Err(Error::invalid(
                    crate::gpu::options::PRECISION,
                    "f64",
                    format!("double-f32: {} has no f64 in shaders", adapter.get_info().name),
                ));
            }
        };
        let f64_ok = precision == Precision::F64;
        let (device, queue) = pollster::block_on(
            adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("sonarproj"),
                required_limits: limits.clone(),
                // Timestamp queries where the adapter has them, so `bench` reports the device's time.
                // The summary stage's features where the adapter has them all (it reduces on the
                // device only then).
                required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY
                    | if adapter
                        .features()
                        .contains(crate::projection::gpu::SUMMARY_FEATURES)
                    {
                        crate::projection::gpu::SUMMARY_FEATURES
                    } else {
                        wgpu::Features::empty()
                    }
                    | if f64_ok {
                        wgpu::Features::SHADER_F64
                    } else {
                        wgpu::Features::empty()
                    },
                ..Default::default()
            }),
        )
        .map_err(|e| Error::gpu("cannot create a device", e))?;
        Ok(GpuContext {
            device,
            queue,
            info: adapter.get_info(),
            limits,
            precision,
        })
    }
}
