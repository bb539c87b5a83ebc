//! Pipelines of the stages, built once per backend. Binding order follows the WGSL files.
#![expect(
    clippy::cast_possible_truncation,
    reason = "buffer sizes and counts bounded by the device limits checked before packing"
)]

use std::borrow::Cow;

use crate::error::{Error, Result};

fn entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// The kind of each binding of a stage, in binding order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Binding {
    /// `var<uniform>`.
    Uniform,
    /// `var<storage, read>`.
    Read,
    /// `var<storage, read_write>`.
    ReadWrite,
}

/// A compute pipeline with its bind-group layout.
#[derive(Debug)]
pub(crate) struct Stage {
    pub(crate) pipeline: wgpu::ComputePipeline,
    /// Layout of its one bind group.
    pub(crate) layout: wgpu::BindGroupLayout,
}

impl Stage {
    /// Returns the pipeline of WGSL `source` (entry point `main`) with `bindings` in group 0.
    ///
    /// # Errors
    /// As [`Stage::with_constants`].
    pub(crate) fn new(device: &wgpu::Device, name: &str, source: &str, bindings: &[Binding]) -> Result<Self> {
        Self::with_constants(device, name, source, bindings, &[])
    }

    /// Returns the pipeline as [`Stage::new`], with the WGSL `override` constants set to
    /// `constants` (name, value). The shader module and the pipeline are made inside error scopes,
    /// so a driver's refusal is an error with wgpu's as its source, not a panic.
    ///
    /// # Errors
    /// [`Error::Gpu`] when the device refuses the shader or the pipeline (validation, an internal
    /// error of the driver, memory).
    pub(crate) fn with_constants(
        device: &wgpu::Device,
        name: &str,
        source: &str,
        bindings: &[Binding],
        constants: &[(&str, f64)],
    ) -> Result<Self> {
        let scopes = [
            wgpu::ErrorFilter::Validation,
            wgpu::ErrorFilter::Internal,
            wgpu::ErrorFilter::OutOfMemory,
        ]
        .map(|f| device.push_error_scope(f));
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(source)),
        });
        let entries: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let ty = match b {
                    Binding::Uniform => wgpu::BufferBindingType::Uniform,
                    Binding::Read => wgpu::BufferBindingType::Storage { read_only: true },
                    Binding::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
                };
                entry(i as u32, ty)
            })
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(name),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(name),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
            cache: None,
        });
        // Popped innermost first, as scopes nest.
        for scope in scopes.into_iter().rev() {
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(Error::gpu(&format!("building the {name} stage"), e));
            }
        }
        Ok(Stage { pipeline, layout })
    }

    /// Returns a bind group of `buffers`, in binding order.
    #[must_use]
    pub(crate) fn bind(&self, device: &wgpu::Device, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        let entries: Vec<_> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &self.layout,
            entries: &entries,
        })
    }
}
