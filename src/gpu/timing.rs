//! GPU time of compute passes, from the device's own clock (timestamp queries, where the adapter
//! has them). `bench sweep` reports it as device time beside the host's.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use crate::error::Result;
use crate::gpu::{GpuContext, read_after};

/// The compute passes a projection chunk is timed in: pose decoding, the splat (or exact) stage,
/// the reduce stage.
pub(crate) const STAGES: usize = 3;
/// The timestamps of a chunk: two a stage.
const QUERIES: u32 = 6;
const _: () = assert!(QUERIES as usize == 2 * STAGES);

/// Two timestamps around each of a chunk's [`STAGES`] compute passes: the query set, where they
/// are resolved, and where they are read back.
pub(crate) struct PassTimer {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    staging: wgpu::Buffer,
}

impl PassTimer {
    /// Returns a timer on `ctx`, or `None` when its device has no timestamp queries.
    pub(crate) fn new(ctx: &GpuContext) -> Option<PassTimer> {
        if !ctx.device().features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let buffer = |label, usage| {
            ctx.device().create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16 * STAGES as u64,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(PassTimer {
            queries: ctx.device().create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timer"),
                ty: wgpu::QueryType::Timestamp,
                count: QUERIES,
            }),
            resolved: buffer(
                "pass timer resolved",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            staging: buffer(
                "pass timer staging",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
        })
    }

    /// Returns the timestamp writes of stage `stage`'s pass: one at its beginning, one at its end.
    pub(crate) fn writes(&self, stage: u32) -> wgpu::ComputePassTimestampWrites<'_> {
        let first = 2 * stage;
        wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(first),
            end_of_pass_write_index: Some(first + 1),
        }
    }

    /// Records, after the pass, the copy of its timestamps to where [`PassTimer::elapsed`] reads
    /// them.
    pub(crate) fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&self.queries, 0..QUERIES, &self.resolved, 0);
        enc.copy_buffer_to_buffer(&self.resolved, 0, &self.staging, 0, 16 * STAGES as u64);
    }

    /// Returns the time between each stage's two timestamps, once submission `index` has
    /// finished. That is the submission that resolved them; `None` waits for every submission.
    ///
    /// # Errors
    /// [`crate::Error::Gpu`] when the readback fails.
    pub(crate) fn elapsed(
        &self,
        ctx: &GpuContext,
        index: Option<wgpu::SubmissionIndex>,
    ) -> Result<[Duration; STAGES]> {
        let words = read_after(ctx, &self.staging, 16 * STAGES as u64, index, <[u32]>::to_vec)?;
        let period = f64::from(ctx.queue().get_timestamp_period());
        Ok(std::array::from_fn(|s| {
            let at = |k: usize| u64::from(words[k]) | (u64::from(words[k + 1]) << 32);
            let ns = at(4 * s + 2).saturating_sub(at(4 * s)) as f64 * period;
            Duration::from_secs_f64(ns / 1e9)
        }))
    }
}

/// The summed device time of a backend's passes while timing was on, and the host's time beside
/// them: waiting for chunks to finish, and unpacking what they read back.
#[derive(Debug, Default)]
pub(crate) struct DeviceClock {
    on: AtomicBool,
    /// Nanoseconds of the device's passes, of the host's waits, of the host's unpacking, then of
    /// each of the device's [`STAGES`].
    ns: [AtomicU64; 3 + STAGES],
}

/// What a [`DeviceClock`] sums.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Timed {
    /// The device's compute passes, on its own clock.
    Device = 0,
    /// The host waiting for a chunk's submission to finish.
    Wait = 1,
    /// The host unpacking a chunk's results.
    Unpack = 2,
    /// The device's pose decoding pass (a grid's poses), on its own clock.
    Poses = 3,
    /// The device's splat (or exact) stage pass.
    Splat = 4,
    /// The device's reduce stage pass.
    Reduce = 5,
}

impl Timed {
    /// The device's passes in the order a chunk runs them (stage `s` of [`PassTimer::writes`]).
    pub(crate) const STAGES: [Timed; STAGES] = [Timed::Poses, Timed::Splat, Timed::Reduce];
}

impl DeviceClock {
    /// Starts or stops timing. Starting clears the sums.
    pub(crate) fn set(&self, on: bool) {
        if on {
            for n in &self.ns {
                n.store(0, Ordering::Relaxed);
            }
        }
        self.on.store(on, Ordering::Relaxed);
    }

    pub(crate) fn on(&self) -> bool {
        self.on.load(Ordering::Relaxed)
    }

    #[expect(
        clippy::cast_possible_truncation,
        reason = "nanoseconds of a run fit in u64 (584 years)"
    )]
    pub(crate) fn add(&self, what: Timed, t: Duration) {
        self.ns[what as usize].fetch_add(t.as_nanos() as u64, Ordering::Relaxed);
    }

    /// Returns the sum of `what` since timing started.
    pub(crate) fn total(&self, what: Timed) -> Duration {
        Duration::from_nanos(self.ns[what as usize].load(Ordering::Relaxed))
    }
}
