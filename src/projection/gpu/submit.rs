//! One chunk of a GPU projection call put on the device, in one submission: its direction table,
//! its poses, the passes encoded (poses, splat, reduce) and the copies of what is read back. The
//! host packs the poses of items; the device decodes those of a grid.

use bytemuck::Zeroable;
use rayon::prelude::*;

use crate::geometry::SonarKind;
use crate::gpu::GpuContext;
use crate::gpu::pool::BufferPool;
use crate::sampling::SamplingPlan;

use super::slots::{Directions, SLOT_LABELS, Shape, Slot, SlotLabels};
use super::summary::SUMMARY_WORKGROUP;
use super::tables::{grid_table, pose_gpu};
use super::types::{
    GridParams, PoseGpu, SummaryParams, TargetParams, beam_edges, range_edges_sq, row_weights,
};
use super::unpack::{Source, pair_index};
use super::{GpuBackend, MAX_TILES, POSES_WORKGROUP};

/// What every chunk of one call shares on the device: sonar 2's tables, written once a call (a few
/// KiB), and for a grid its axis table with each axis's offset in it.
pub(super) struct CallTables {
    edges: wgpu::Buffer,
    weights: wgpu::Buffer,
    edges_sq: wgpu::Buffer,
    pub(super) grid: Option<(wgpu::Buffer, [u32; 9])>,
}

impl CallTables {
    /// Returns the tables of a call on `source`, written into buffers of `pool` (at most `limit`
    /// bytes each).
    pub(super) fn upload(
        ctx: &GpuContext,
        pool: &mut BufferPool,
        source: &Source<'_>,
        limit: u64,
    ) -> CallTables {
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let mut upload = |label: &'static str, contents: &[u8]| {
            let buffer = pool.get(ctx.device(), label, contents.len() as u64, limit, storage);
            ctx.queue().write_buffer(&buffer, 0, contents);
            buffer
        };
        let layout = source.layout();
        let edges = upload("beam_edges", bytemuck::cast_slice(&beam_edges(layout)));
        let weights = upload("row_weights", bytemuck::cast_slice(&row_weights(layout)));
        let edges_sq = upload("range_edges_sq", bytemuck::cast_slice(&range_edges_sq(layout)));
        let grid = match source {
            Source::Items(_) | Source::Pairs { .. } => None,
            Source::Grid { prepared, .. } => {
                let (table, offsets) = grid_table(prepared.grid);
                Some((upload("grid_table", bytemuck::cast_slice(&table)), offsets))
            }
        };
        CallTables {
            edges,
            weights,
            edges_sq,
            grid,
        }
    }
}

/// A chunk of a call: the slot it runs in and its poses (indices into the call's source).
pub(super) struct Chunk {
    pub(super) slot: usize,
    pub(super) poses: std::ops::Range<usize>,
    /// Whether the chunk starts its run, and whether it ends it (a summary run's block).
    pub(super) first_in_run: bool,
    pub(super) last_in_run: bool,
}

impl GpuBackend {
    /// Returns the direction table of the plans `chunk` uses. It is `kept` when that holds the same
    /// plans. Otherwise it is a new one, written in queue order after the chunk in flight has read
    /// the old one.
    pub(super) fn directions_for(
        &self,
        pool: &mut BufferPool,
        shape: &Shape<'_>,
        chunk: &Chunk,
        kept: Option<Directions>,
        limit: u64,
    ) -> Directions {
        let used = shape.source.plans_used(chunk.poses.clone());
        match kept {
            Some(d) if d.plans == used => d,
            _ => Directions::upload(&self.ctx, pool, shape.source, used, limit),
        }
    }

    /// Puts `chunk` on the device in its slot and returns its submission. The submission holds its
    /// poses, sonar 2's parameters for its pose count, the passes (poses for a grid, splat or
    /// exact, reduce, and summary in a summary run) with the buffers cleared first, and the copies
    /// of what is read back.
    ///
    /// # Errors
    /// [`crate::Error::Gpu`] when the device refuses the exact or summary stage (built on first
    /// use).
    pub(super) fn submit_chunk(
        &self,
        pool: &mut BufferPool,
        shape: &Shape<'_>,
        tables: &CallTables,
        slots: &[Slot],
        directions: &Directions,
        chunk: &Chunk,
    ) -> crate::Result<wgpu::SubmissionIndex> {
        let (device, queue) = (self.ctx.device(), self.ctx.queue());
        let (slot, labels) = (&slots[chunk.slot], &SLOT_LABELS[chunk.slot]);
        let n = chunk.poses.len();
        let decode = self.chunk_poses_on_device(pool, shape, tables, slot, directions, chunk);
        let params = TargetParams::new(shape.layout, n as u32);
        queue.write_buffer(&slot.params, 0, bytemuck::bytes_of(&params));
        // The groups are kept with the pool's buffers and made again only when one was grown.
        // An exact call runs the exact stage in the splat stage's place, on the same buffers.
        let exact = shape.source.exact_half().is_some();
        let (stage, group_label) = if exact {
            (self.exact_stage()?, labels.exact_group)
        } else {
            (&self.splat, labels.splat_group)
        };
        let splat_group = pool.bind(
            device,
            group_label,
            stage,
            &[
                &slot.params,
                &tables.edges,
                &tables.edges_sq,
                &slot.poses,
                &directions.buffer,
                &slot.bits,
                &slot.metrics,
            ],
        );
        let reduce_group = pool.bind(
            device,
            labels.reduce_group,
            &self.reduce,
            &[
                &slot.params,
                &tables.edges,
                &tables.weights,
                &slot.bits,
                &slot.metrics,
            ],
        );
        let tiles = self.tiles(shape, directions);
        let (used_bits, used_metrics) = shape.bytes(n);
        // The chunk's poses over two dimensions of workgroups.
        let dim = self.ctx.limits().max_compute_workgroups_per_dimension.max(1);
        let across = (n as u32).min(dim);
        let rows = (n as u32).div_ceil(across);

        let mut enc = device.create_command_encoder(&Default::default());
        let summary_group = self.summary_group(pool, &mut enc, shape, slot, labels, chunk)?;
        enc.clear_buffer(&slot.bits, 0, Some(used_bits));
        enc.clear_buffer(&slot.metrics, 0, Some(used_metrics));
        {
            // One pass for the three stages; a timed chunk takes a pass a stage (the poses pass
            // empty for items), each between its own timestamps.
            let timer = slot.timer.as_ref();
            let begin = |enc: &mut wgpu::CommandEncoder, stage: u32| {
                enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: None,
                    timestamp_writes: timer.map(|t| t.writes(stage)),
                })
                .forget_lifetime()
            };
            let mut pass = begin(&mut enc, 0);
            if let Some(group) = &decode {
                pass.set_pipeline(&self.poses.pipeline);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups((n as u64).div_ceil(POSES_WORKGROUP) as u32, 1, 1);
            }
            if timer.is_some() {
                drop(pass);
                pass = begin(&mut enc, 1);
            }
            pass.set_pipeline(&stage.pipeline);
            pass.set_bind_group(0, &splat_group, &[]);
            if exact {
                // One pose a thread, over two dimensions of workgroups.
                let groups = (n as u64).div_ceil(u64::from(self.exact_workgroup())) as u32;
                let across = groups.clamp(1, dim);
                pass.dispatch_workgroups(across, groups.div_ceil(across), 1);
            } else {
                pass.dispatch_workgroups(tiles, across, rows);
            }
            if timer.is_some() {
                drop(pass);
                pass = begin(&mut enc, 2);
            }
            pass.set_pipeline(&self.reduce.pipeline);
            pass.set_bind_group(0, &reduce_group, &[]);
            pass.dispatch_workgroups(across, rows, 1);
            // A summary run reduces the metric in the same pass (timed with the reduce stage).
            if let Some(group) = &summary_group {
                let groups = n.div_ceil(SUMMARY_WORKGROUP) as u32;
                let across = groups.clamp(1, dim);
                pass.set_pipeline(&self.summary_stage()?.pipeline);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(across, groups.div_ceil(across), 1);
            }
        }
        copy_summary(&mut enc, shape, slot, chunk);
        shape.copy_slots(&mut enc, &slot.metrics, &slot.metrics_staging, n);
        if let Some(staging) = &slot.bits_staging {
            enc.copy_buffer_to_buffer(&slot.bits, 0, staging, 0, used_bits);
        }
        if let Some(t) = &slot.timer {
            t.resolve(&mut enc);
        }
        Ok(queue.submit([enc.finish()]))
    }

    /// Returns the workgroups across a pose of the splat stage: enough for the most samples a plan
    /// of the chunk's `directions` draws, at most [`MAX_TILES`].
    fn tiles(&self, shape: &Shape<'_>, directions: &Directions) -> u32 {
        let max_samples = directions
            .plans
            .iter()
            .map(|&p| shape.plans[p].total() as u64)
            .fold(1, u64::max);
        max_samples
            .div_ceil(u64::from(self.options.workgroup))
            .clamp(1, MAX_TILES) as u32
    }

    /// Returns the summary stage's bind group for `chunk` in a summary run (`None` outside one),
    /// its parameters written, and a block's accumulators cleared in `enc` at its first chunk
    /// (queue order: after the block before was copied out).
    ///
    /// # Errors
    /// [`crate::Error::Gpu`] when the device refuses the summary stage (built on first use).
    fn summary_group(
        &self,
        pool: &mut BufferPool,
        enc: &mut wgpu::CommandEncoder,
        shape: &Shape<'_>,
        slot: &Slot,
        labels: &SlotLabels,
        chunk: &Chunk,
    ) -> crate::Result<Option<wgpu::BindGroup>> {
        let (Some(run), Some(s)) = (shape.summary, &slot.summary) else {
            return Ok(None);
        };
        if chunk.first_in_run {
            enc.clear_buffer(&run.acc, 0, None);
        }
        let first = shape.source.first_pose() + chunk.poses.start as u64;
        let params = SummaryParams {
            count: chunk.poses.len() as u32,
            first_lo: first as u32,
            first_hi: (first >> 32) as u32,
            ..run.params
        };
        self.ctx
            .queue()
            .write_buffer(&s.params, 0, bytemuck::bytes_of(&params));
        Ok(Some(pool.bind(
            self.ctx.device(),
            labels.summary_group,
            self.summary_stage()?,
            &[
                &s.params,
                &slot.metrics,
                &slot.poses,
                &run.edges,
                &run.table,
                &run.acc,
                &s.candidates,
            ],
        )))
    }

    /// Writes `chunk`'s poses where the splat stage reads them. Returns the poses stage's bind
    /// group when they are decoded on the device.
    /// - Items are packed on all cores. Serially, this loop and the unpacking took 80–180 ns a pose
    ///   (BENCHMARKS.md).
    /// - A grid writes the digits of the chunk's first pose, and the poses stage decodes the poses.
    fn chunk_poses_on_device(
        &self,
        pool: &mut BufferPool,
        shape: &Shape<'_>,
        tables: &CallTables,
        slot: &Slot,
        directions: &Directions,
        chunk: &Chunk,
    ) -> Option<wgpu::BindGroup> {
        let (device, queue) = (self.ctx.device(), self.ctx.queue());
        let (start, end) = (chunk.poses.start, chunk.poses.end);
        match (
            shape.source,
            &tables.grid,
            &slot.grid_params,
            &directions.range_plans,
        ) {
            (Source::Items(prepared), _, _, _) => {
                let items = &prepared.batch.items;
                let exact = prepared.is_exact();
                let pose_data: Vec<PoseGpu> = (start..end)
                    .into_par_iter()
                    .map(|k| {
                        let plan = (!exact).then(|| prepared.plan_index(k));
                        let plan = plan_reference(directions, &prepared.plans, plan);
                        pose_gpu(
                            &items[k].pose.rotation,
                            items[k].pose.translation.to_array(),
                            items[k].measurement.range,
                            prepared.base_azimuth(k),
                            plan,
                        )
                    })
                    .collect();
                queue.write_buffer(&slot.poses, 0, bytemuck::cast_slice(&pose_data));
                None
            }
            (Source::Pairs { prepared, first }, _, _, _) => {
                let pose_data: Vec<PoseGpu> = (start..end)
                    .into_par_iter()
                    .map(|k| {
                        let (pose, range, base, plan_index) = prepared.pose(pair_index(*first, k));
                        let plan = (!prepared.exact).then_some(plan_index);
                        let plan = plan_reference(directions, &prepared.plans, plan);
                        pose_gpu(&pose.rotation, pose.translation.to_array(), range, base, plan)
                    })
                    .collect();
                queue.write_buffer(&slot.poses, 0, bytemuck::cast_slice(&pose_data));
                None
            }
            (
                Source::Grid { prepared, first, .. },
                Some((table, axis_offsets)),
                Some(grid_params),
                Some(range_plans),
            ) => {
                let grid = prepared.grid;
                let digits = grid.indices(first + start as u64);
                let mut g = GridParams {
                    count: (end - start) as u32,
                    placement: u32::from(grid.placement()),
                    fls: u32::from(prepared.source.kind == SonarKind::Fls),
                    ..GridParams::zeroed()
                };
                for k in 0..9 {
                    g.first[k] = digits[k] as u32;
                    g.lens[k] = grid.axes()[k].len() as u32;
                    g.offsets[k] = axis_offsets[k];
                }
                queue.write_buffer(grid_params, 0, bytemuck::bytes_of(&g));
                Some(pool.bind(
                    device,
                    SLOT_LABELS[chunk.slot].poses_group,
                    &self.poses,
                    &[grid_params, table, range_plans, &slot.poses],
                ))
            }
            _ => unreachable!("a grid has its tables"),
        }
    }
}

/// Returns a pose's reference to its sampling plan `plan` (an index into `plans`) in the
/// direction table: the offsets of its azimuth and elevation entries and their counts. An exact
/// call has no plan (`None`): its stage reads the arc alone, and the reference is zeros.
fn plan_reference(directions: &Directions, plans: &[SamplingPlan], plan: Option<usize>) -> [u32; 4] {
    let Some(index) = plan else {
        return [0; 4];
    };
    let [az_off, el_off] = directions.offsets[&index];
    let plan = &plans[index];
    [
        az_off,
        plan.azimuths.len() as u32,
        el_off,
        plan.elevations.len() as u32,
    ]
}

/// Records into `enc` the copies a summary run reads back of `chunk`: its candidates, and at its
/// block's end the accumulators. Nothing outside a summary run.
fn copy_summary(enc: &mut wgpu::CommandEncoder, shape: &Shape<'_>, slot: &Slot, chunk: &Chunk) {
    if let (Some(run), Some(s)) = (shape.summary, &slot.summary) {
        let bytes = run.candidate_bytes(chunk.poses.len());
        enc.copy_buffer_to_buffer(&s.candidates, 0, &s.candidates_staging, 0, bytes);
        if chunk.last_in_run {
            enc.copy_buffer_to_buffer(&run.acc, 0, &s.acc_staging, 0, run.acc_bytes);
        }
    }
}
