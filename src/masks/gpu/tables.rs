//! The direction tables of the masks' cell grids, kept on the device between pings, and the
//! shape of a GPU block of cells (`shaders/mask.wgsl` reads both).
#![expect(
    clippy::cast_possible_truncation,
    reason = "directions are rounded to f32 on purpose (the masks' slack covers it); offsets are bounded by the table's cap"
)]

use std::collections::HashMap;

use crate::gpu::GpuContext;
use crate::masks::plan::BLOCK;

/// A table's first and last angle's bits, count and block size.
type TableKey = (u64, u64, usize, usize);

/// The direction tables of cell grids, kept on the device between pings. A grid depends on its
/// count (and an arc's azimuth on the feature), not on the pose, so pings after the first mostly
/// find theirs here. Each table holds its cells' directions, then its blocks' middles
/// (`ceil(count / block)`, for the block's size along that axis).
#[derive(Default)]
pub(super) struct Tables {
    /// Each table's offset and angles, by its first and last angle's bits, count and block size.
    index: HashMap<TableKey, (u32, Vec<f64>)>,
    /// Every entry, as on the device.
    pub(super) host: Vec<[f32; 2]>,
    /// Entries already on the device.
    uploaded: usize,
    /// The device's copy.
    pub(super) buffer: Option<wgpu::Buffer>,
}

/// Returns the cells of a GPU block along the azimuth and the elevation, for `na × ne` cells.
/// A block has 64 cells, one per workgroup thread, in `BLOCK × BLOCK`. A grid thinner than
/// `BLOCK` along one axis (an arc is one azimuth; a sidescan's surface a few elevations) gets
/// blocks as wide as the grid, rounded up to a power of two, and longer along the other axis.
/// So no thread is idle. Any shape is as safe, since a block's ball covers its cells'.
pub(super) fn block_shape(na: usize, ne: usize) -> (usize, usize) {
    let cells = BLOCK * BLOCK;
    if na < BLOCK {
        let a = na.max(1).next_power_of_two();
        (a, cells / a)
    } else if ne < BLOCK {
        let e = ne.max(1).next_power_of_two();
        (cells / e, e)
    } else {
        (BLOCK, BLOCK)
    }
}

/// Returns the entries a table of `n` cells in blocks of `block` takes.
pub(super) fn table_entries(n: usize, block: usize) -> usize {
    n + n.div_ceil(block)
}

impl Tables {
    /// Returns where the table of `angles` in blocks of `block` starts, adding it when new.
    pub(super) fn offset(&mut self, angles: &[f64], block: usize) -> u32 {
        let key = (
            angles.first().map_or(0, |a| a.to_bits()),
            angles.last().map_or(0, |a| a.to_bits()),
            angles.len(),
            block,
        );
        if let Some((at, kept)) = self.index.get(&key)
            && kept == angles
        {
            return *at;
        }
        let at = self.host.len() as u32;
        let dir = |a: f64| [a.cos() as f32, a.sin() as f32];
        self.host.extend(angles.iter().map(|&a| dir(a)));
        // A block's middle is halfway between its first and last cell's centres, as
        // `View::blocks` takes it.
        self.host
            .extend(angles.chunks(block).map(|b| dir((b[0] + b[b.len() - 1]) / 2.0)));
        self.index.insert(key, (at, angles.to_vec()));
        at
    }

    /// Starts afresh (the device's copy is rewritten as it fills again).
    pub(super) fn clear(&mut self) {
        self.index.clear();
        self.host.clear();
        self.uploaded = 0;
    }

    /// Puts the entries added since the last call on the device. A buffer that must grow is
    /// replaced, so bind groups made of the old one are made again.
    pub(super) fn upload(&mut self, ctx: &GpuContext) {
        let bytes = (self.host.len().max(2) * 8) as u64;
        let fits = self.buffer.as_ref().is_some_and(|b| b.size() >= bytes);
        if !fits {
            let size = bytes.next_power_of_two().max(4096);
            self.buffer = Some(ctx.device().create_buffer(&wgpu::BufferDescriptor {
                label: Some("mask dirs"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
            self.uploaded = 0;
        }
        if let Some(buffer) = &self.buffer
            && self.uploaded < self.host.len()
        {
            ctx.queue().write_buffer(
                buffer,
                (self.uploaded * 8) as u64,
                bytemuck::cast_slice(&self.host[self.uploaded..]),
            );
            self.uploaded = self.host.len();
        }
    }
}
