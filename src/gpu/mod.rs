//! The GPU plumbing shared by the projection and the mask pipelines: the device ([`GpuContext`],
//! opened once per process for the [`GpuOptions`] the fronts give), its arithmetic ([`Precision`]),
//! compute stages and their binding tables (`pipeline`), buffers kept between calls (`pool`), the
//! device's own time of a pass (`timing`), and reading buffers back. It is a leaf: it imports
//! nothing of the engine but its errors. Each pipeline assembles its own WGSL
//! (`projection/gpu/source.rs`, `masks/gpu/source.rs`).

pub mod context;
pub mod options;
pub(crate) mod pipeline;
pub(crate) mod pool;
pub mod precision;
pub(crate) mod timing;
#[cfg(test)]
pub(crate) mod wgsl_checks;

use std::sync::mpsc;

use crate::error::{Error, Result};
pub use context::GpuContext;
pub use options::GpuOptions;
pub use precision::Precision;

/// Returns what `f` makes of the first `size` bytes of the mappable `buffer` as u32s. It waits for
/// submission `index` and those before it, or for every submission when `None`; later submissions
/// can go on running. The bytes are read in place while the buffer is mapped, without a copy.
pub(crate) fn read_after<T>(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    size: u64,
    index: Option<wgpu::SubmissionIndex>,
    f: impl FnOnce(&[u32]) -> T,
) -> Result<T> {
    let slice = buffer.slice(..size);
    let (tx, rx) = mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.device()
        .poll(wgpu::PollType::Wait {
            submission_index: index,
            timeout: Some(context::WAIT_TIMEOUT),
        })
        .map_err(|e| Error::gpu("waiting for the GPU", e))?;
    rx.recv()
        .map_err(|e| Error::gpu("readback never answered", e))?
        .map_err(|e| Error::gpu("cannot map the readback buffer", e))?;
    let out = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| Error::gpu("cannot read the readback buffer", e))?;
        f(bytemuck::cast_slice::<u8, u32>(&view))
    };
    buffer.unmap();
    Ok(out)
}
