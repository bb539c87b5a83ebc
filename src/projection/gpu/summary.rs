//! The summary stage's host side (`shaders/summary.wgsl`): a grid's blocks of poses reduced on the
//! device to one [`Reduction`] each. A chunk reads back only its workgroups' candidates for the
//! smallest and largest poses; a block's last chunk also reads back its accumulators (counts,
//! histogram, cells).

use std::ops::ControlFlow;

use bytemuck::Zeroable;

use crate::error::{Error, Result};
use crate::geometry::SonarKind;
use crate::gpu::GpuContext;
use crate::gpu::pool::BufferPool;
use crate::projection::poses::PreparedGrid;
use crate::projection::reduction::{CellTotals, HistogramCounts, MetricReduction, Reduction};

use super::types::{MarginalGpu, SummaryParams};
use super::unpack::Source;
use super::{GpuBackend, Unpack};

/// Threads a workgroup of the summary stage, one pose each (WGSL `WORKGROUP`).
pub(crate) const SUMMARY_WORKGROUP: usize = 256;

/// Accumulator words before the histogram's bins: poses with a value, NOT the first pose too
/// large, below, above.
const HEAD_WORDS: usize = 4;
/// Accumulator words a cell: count, sum (two words), NOT the least key, the greatest key.
const CELL_WORDS: usize = 5;

/// The features the summary stage needs.
pub(crate) const FEATURES: wgpu::Features = wgpu::Features::SHADER_F64
    .union(wgpu::Features::SHADER_INT64)
    .union(wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX)
    .union(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS);

/// A reduction on the device for one call: its tables and accumulators, and the parameters every
/// chunk shares.
pub(super) struct SummaryRun {
    pub(super) params: SummaryParams,
    pub(super) edges: wgpu::Buffer,
    pub(super) table: wgpu::Buffer,
    pub(super) acc: wgpu::Buffer,
    /// The accumulators' bytes.
    pub(super) acc_bytes: u64,
    /// Candidates a workgroup writes in each order.
    pub(super) keep: usize,
}

impl SummaryRun {
    /// Returns the run of `reduction` over a call on `source`, its tables in buffers of `pool`.
    ///
    /// # Errors
    /// [`Error::Gpu`] when the accumulators do not fit in one binding of `limit` bytes.
    pub(super) fn new(
        ctx: &GpuContext,
        pool: &mut BufferPool,
        source: &Source<'_>,
        reduction: &MetricReduction,
        limit: u64,
    ) -> Result<SummaryRun> {
        let layout = source.layout();
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let bins = reduction.histogram.as_ref().map_or(0, |h| h.edges.len() - 1);
        let mut table = Vec::with_capacity(reduction.cells.len().max(1));
        let mut cells = 0u64;
        for c in &reduction.cells {
            let mut m = MarginalGpu {
                cell_offset: u32::try_from(cells).expect("cells are checked"),
                axes: c.digits.len() as u32,
                ..MarginalGpu::zeroed()
            };
            for (k, d) in c.digits.iter().enumerate() {
                m.digit[k] = [
                    d.stride as u32,
                    (d.stride >> 32) as u32,
                    d.len as u32,
                    d.weight as u32,
                ];
            }
            table.push(m);
            cells += c.cells();
        }
        if table.is_empty() {
            table.push(MarginalGpu::zeroed());
        }
        let acc_words = HEAD_WORDS as u64 + bins as u64 + CELL_WORDS as u64 * cells;
        let acc_bytes = acc_words * 8;
        if acc_bytes > limit {
            return Err(Error::gpu_limit(format!(
                "the summary's histogram and cells ({acc_bytes} bytes) exceed this device's largest \
                 storage binding ({limit} bytes)"
            )));
        }
        let edges: Vec<f64> = match &reduction.histogram {
            Some(h) => h.edges.clone(),
            None => vec![0.0],
        };
        let mut upload = |label: &'static str, contents: &[u8]| {
            let buffer = pool.get(ctx.device(), label, contents.len() as u64, limit, storage);
            ctx.queue().write_buffer(&buffer, 0, contents);
            buffer
        };
        let edges = upload("summary edges", bytemuck::cast_slice(&edges));
        let table = upload("summary cells", bytemuck::cast_slice(&table));
        let acc = pool.get(
            ctx.device(),
            "summary accumulators",
            acc_bytes,
            limit,
            storage | wgpu::BufferUsages::COPY_SRC,
        );
        let keep = reduction.top.max(1);
        let metric = crate::Metric::all()
            .position(|m| m == reduction.metric)
            .expect("a metric of the table");
        let grid = layout.area_grid.filter(|_| source.exact_half().is_none());
        let params = SummaryParams {
            range_bin_width: layout.range_bin_width,
            cell: layout.area_grid.map_or(0.0, |g| g.cell),
            degrees: 1f64.to_degrees(),
            histogram_min: reduction.histogram.as_ref().map_or(0.0, |h| h.min),
            histogram_max: reduction.histogram.as_ref().map_or(0.0, |h| h.max),
            metric: metric as u32,
            exact: u32::from(source.exact_half().is_some()),
            sss: u32::from(layout.kind == SonarKind::Sss),
            has_area: u32::from(grid.is_some()),
            bins: bins as u32,
            marginals: reduction.cells.len() as u32,
            keep: keep as u32,
            cells_at: (HEAD_WORDS + bins) as u32,
            ..SummaryParams::zeroed()
        };
        Ok(SummaryRun {
            params,
            edges,
            table,
            acc,
            acc_bytes,
            keep,
        })
    }

    /// Returns the bytes of the candidates of a chunk of `n` poses: two orders, `keep` each a
    /// workgroup, 16 bytes each.
    pub(super) fn candidate_bytes(&self, n: usize) -> u64 {
        (2 * n.div_ceil(SUMMARY_WORKGROUP) * self.keep * 16) as u64
    }
}

/// What a chunk of a summary run read back: its candidates, and at a block's end the
/// accumulators (u32 words, two a u64, low first).
pub(super) struct ChunkSummary<'a> {
    pub(super) candidates: &'a [u32],
    pub(super) acc: Option<&'a [u32]>,
}

/// Returns the u64 at word pair `k` of `words`.
fn u64_at(words: &[u32], k: usize) -> u64 {
    u64::from(words[2 * k]) | u64::from(words[2 * k + 1]) << 32
}

/// Returns the value whose order key (WGSL `key_of`) is `key`.
fn value_of(key: u64) -> f64 {
    const SIGN: u64 = 1 << 63;
    if key & SIGN != 0 {
        f64::from_bits(key & !SIGN)
    } else {
        f64::from_bits(!key)
    }
}

/// A block's reduction while its chunks come back.
struct Block {
    smallest: Vec<(u64, f64)>,
    largest: Vec<(u64, f64)>,
}

/// Keeps the first `k` of `list` in the order `ascending` (by value, else by descending value),
/// ties to the lower pose.
fn keep_first(list: &mut Vec<(u64, f64)>, k: usize, ascending: bool) {
    let order = |a: &(u64, f64), b: &(u64, f64)| {
        let by_value = if ascending {
            a.1.total_cmp(&b.1)
        } else {
            b.1.total_cmp(&a.1)
        };
        by_value.then(a.0.cmp(&b.0))
    };
    if list.len() > k {
        list.select_nth_unstable_by(k, order);
        list.truncate(k);
    }
    list.sort_by(order);
}

impl GpuBackend {
    /// Returns whether the device has what the summary stage needs (f64, 64-bit integers and
    /// their atomics).
    pub(crate) fn reduces(&self) -> bool {
        self.ctx.device().features().contains(FEATURES)
    }

    /// Reduces poses `blocks` of a prepared grid, block by block, on the device, and hands each
    /// block's [`Reduction`] to `each`. Returns `Break` as soon as `each` does.
    ///
    /// # Errors
    /// As [`MetricReduction::validate`]; [`Error::Gpu`] when the device lacks the features, fails,
    /// or the accumulators do not fit.
    pub(crate) fn reduce_grid_blocks(
        &self,
        prepared: &PreparedGrid<'_>,
        blocks: &[std::ops::Range<u64>],
        reduction: &MetricReduction,
        each: &mut dyn FnMut(std::ops::Range<u64>, &Reduction) -> ControlFlow<()>,
    ) -> Result<ControlFlow<()>> {
        reduction.validate()?;
        if !self.reduces() {
            return Err(Error::gpu_limit(format!(
                "{} has no 64-bit integers or their atomics in shaders: the summary is reduced on \
                 the host",
                self.ctx.info().name
            )));
        }
        let Some((first, runs)) = super::runs_of(blocks) else {
            return Ok(ControlFlow::Continue(()));
        };
        let source = Source::Grid { prepared, first };
        let limit = self
            .ctx
            .limits()
            .max_storage_buffer_binding_size
            .min(self.ctx.limits().max_buffer_size);
        let keep = reduction.top.max(1);
        let mut block = 0;
        let mut kept = Block {
            smallest: Vec::new(),
            largest: Vec::new(),
        };
        self.pool.with(|pool| {
            let run = SummaryRun::new(&self.ctx, pool, &source, reduction, limit)?;
            self.project_with(pool, &source, false, 0, &runs, Some(&run), &mut |u: &Unpack<
                '_,
            >| {
                let chunk = u.summary.as_ref().expect("a summary run's chunk");
                let groups = u.count.div_ceil(SUMMARY_WORKGROUP);
                for (order, list) in [&mut kept.smallest, &mut kept.largest].into_iter().enumerate() {
                    for g in 0..groups {
                        for j in 0..keep {
                            let at = (order * groups + g) * keep + j;
                            let key = u64_at(chunk.candidates, 2 * at);
                            if key == u64::MAX {
                                break;
                            }
                            list.push((u64_at(chunk.candidates, 2 * at + 1), value_of(key)));
                        }
                    }
                    keep_first(list, keep, order == 0);
                }
                let Some(acc) = chunk.acc else {
                    return Ok(ControlFlow::Continue(()));
                };
                let b = blocks[block].clone();
                block += 1;
                let r = reduced(reduction, acc, &b, &mut kept);
                Ok(each(b, &r))
            })
        })
    }
}

/// Returns a block's reduction from its accumulators `acc` and its candidates `kept` (taken).
fn reduced(
    reduction: &MetricReduction,
    acc: &[u32],
    b: &std::ops::Range<u64>,
    kept: &mut Block,
) -> Reduction {
    let word = |k: usize| u64_at(acc, k);
    let bins = reduction.histogram.as_ref().map_or(0, |h| h.edges.len() - 1);
    let histogram = reduction.histogram.as_ref().map(|_| HistogramCounts {
        counts: (0..bins).map(|k| word(HEAD_WORDS + k)).collect(),
        below: word(2),
        above: word(3),
    });
    let too_large = (word(1) != 0).then(|| !word(1));
    let mut at = HEAD_WORDS + bins;
    let cells = if too_large.is_some() {
        Vec::new()
    } else {
        reduction
            .cells
            .iter()
            .map(|c| {
                let n = usize::try_from(c.cells()).expect("cells are checked");
                let mut t = CellTotals {
                    count: Vec::with_capacity(n),
                    sum: Vec::with_capacity(n),
                    min: Vec::with_capacity(n),
                    max: Vec::with_capacity(n),
                };
                for _ in 0..n {
                    let count = word(at);
                    let sum = u128::from(word(at + 1)) | u128::from(word(at + 2)) << 64;
                    t.count.push(count);
                    #[expect(clippy::cast_possible_wrap, reason = "the sum's two's complement")]
                    t.sum.push(sum as i128);
                    t.min.push((count > 0).then(|| value_of(!word(at + 3))));
                    t.max.push((count > 0).then(|| value_of(word(at + 4))));
                    at += CELL_WORDS;
                }
                t
            })
            .collect()
    };
    Reduction {
        poses: b.end - b.start,
        with_value: word(0),
        smallest: std::mem::take(&mut kept.smallest),
        largest: std::mem::take(&mut kept.largest),
        histogram,
        cells,
        too_large,
    }
}
