//! Buffers kept between calls, and the bind groups made of them. A stage asks for a buffer by name
//! and size. It gets the one it used last time when that is large enough, or else a new one grown
//! to the next power of two (within the device's limit). So a stream of calls of similar size
//! allocates nothing. Bind groups are kept while they bind the pool's current buffers.

use std::collections::HashMap;
use std::sync::{Mutex, MutexGuard};

use crate::gpu::pipeline::Stage;

/// Named GPU buffers kept between calls and grown on demand, and named bind groups kept with
/// the buffers they bind.
#[derive(Debug, Default)]
pub(crate) struct BufferPool {
    buffers: HashMap<&'static str, wgpu::Buffer>,
    groups: HashMap<&'static str, (Vec<wgpu::Buffer>, wgpu::BindGroup)>,
}

impl BufferPool {
    /// Returns the pool's buffer `label` of at least `size` bytes with `usage`. It is the one kept
    /// from an earlier call when that is large enough. Otherwise it is a new one, kept for later
    /// calls, of `size` rounded up to a power of two but at most `limit` bytes (never less than
    /// `size`). The contents are whatever an earlier call left: callers write or clear what they
    /// read.
    pub(crate) fn get(
        &mut self,
        device: &wgpu::Device,
        label: &'static str,
        size: u64,
        limit: u64,
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        let size = size.max(16);
        if let Some(buffer) = self.buffers.get(label)
            && buffer.size() >= size
            && buffer.usage() == usage
        {
            return buffer.clone();
        }
        let grown = size.next_power_of_two().min(limit).max(size);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: grown,
            usage,
            mapped_at_creation: false,
        });
        // A replaced buffer is freed, and the groups that bound it go with it.
        if let Some(old) = self.buffers.insert(label, buffer.clone()) {
            self.groups.retain(|_, (kept, _)| !kept.contains(&old));
        }
        buffer
    }

    pub(crate) fn bytes(&self) -> u64 {
        self.buffers.values().map(wgpu::Buffer::size).sum()
    }

    /// Returns the pool's bind group `label` of `stage` over `buffers` (in binding order). It is
    /// the one kept from an earlier call when it binds the same buffers, else a new one, kept. A
    /// label names one stage's group: callers never bind one label to two stages.
    pub(crate) fn bind(
        &mut self,
        device: &wgpu::Device,
        label: &'static str,
        stage: &Stage,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        if let Some((kept, group)) = self.groups.get(label)
            && kept.len() == buffers.len()
            && kept.iter().zip(buffers).all(|(k, b)| k == *b)
        {
            return group.clone();
        }
        let group = stage.bind(device, buffers);
        let kept = buffers.iter().map(|&b| b.clone()).collect();
        self.groups.insert(label, (kept, group.clone()));
        group
    }
}

/// A pool behind a lock, shared by the calls of one backend.
#[derive(Debug, Default)]
pub(crate) struct SharedPool(Mutex<BufferPool>);

impl SharedPool {
    /// Runs `f` with the shared pool, or with a fresh pool when another thread holds it. Calls on
    /// one backend from several threads then allocate instead of waiting. When `f` fails, the kept
    /// buffers are dropped, since a failed readback may leave one mapped.
    pub(crate) fn with<T, E>(&self, f: impl FnOnce(&mut BufferPool) -> Result<T, E>) -> Result<T, E> {
        let mut guard: MutexGuard<'_, BufferPool> = match self.0.try_lock() {
            Ok(guard) => guard,
            Err(std::sync::TryLockError::Poisoned(poisoned)) => {
                let mut guard = poisoned.into_inner();
                *guard = BufferPool::default();
                self.0.clear_poison();
                guard
            }
            Err(std::sync::TryLockError::WouldBlock) => return f(&mut BufferPool::default()),
        };
        let result = f(&mut guard);
        if result.is_err() {
            *guard = BufferPool::default();
        }
        result
    }

    /// Returns the bytes of GPU memory the shared pool holds, or 0 while another call uses it.
    pub(crate) fn bytes(&self) -> u64 {
        self.0.try_lock().map_or(0, |pool| pool.bytes())
    }

    /// Drops every kept buffer. They are rebuilt on the next call.
    pub(crate) fn clear(&self) {
        if let Ok(mut pool) = self.0.lock() {
            *pool = BufferPool::default();
        }
    }
}
