//! Writes a run's chunks while the next are computed, up to two writes in flight (one for chunks
//! of large tables), each on its own thread. Parquet encoding and summaries thus overlap the
//! next projections, and a chunk's file being written does not hold the next projection up; a
//! join that falls a chunk behind still does. A write's error stops the run. As chunks finish,
//! summaries join the total and a Parquet result is joined on its thread.

use std::collections::VecDeque;
use std::thread::{Scope, ScopedJoinHandle};

use crate::error::{Error, Result};
use crate::sweep::plan::Computed;
use crate::sweep::records::read_part;
use crate::sweep::state::{Files, ToJoin, Written};
use crate::sweep::summary::{PartSummary, Summary};

/// The most chunks being written at once. Each holds its table and encoded bytes in memory.
const IN_FLIGHT: usize = 2;

/// The largest chunk of rows written two at a time: two row groups (about 60 MB of tables and
/// bytes). Larger chunks (`--chunk-poses` up to 2^21) are written one at a time, so that one more
/// in memory is at most that much.
const TWO_IN_FLIGHT_ROWS: u64 = 2 * crate::io::parquet::GROUP_ROWS;

/// The writing side of a run: the chunks being written, oldest first, the Parquet join thread (if any), and
/// the summary of the chunks finished so far, this run's and earlier runs'.
pub(crate) struct Writer<'s, 'e> {
    scope: &'s Scope<'s, 'e>,
    files: &'e Files<'e>,
    writing: VecDeque<(u64, ScopedJoinHandle<'s, Result<Written>>)>,
    /// The most chunks written at once: [`IN_FLIGHT`], or 1 for large chunks of rows.
    in_flight: usize,
    joiner: Option<Joiner<'s>>,
    /// The total so far. Its means are derived once at the end.
    pub(crate) total: Option<Summary>,
    /// An empty summary of this run, which parts read back are made into.
    template: Option<Summary>,
}

impl<'s, 'e> Writer<'s, 'e> {
    /// Returns the writer of `files`' chunks in `scope`.
    /// With `join`, a Parquet result is joined as chunks finish; else from the files at the end.
    pub(crate) fn new(scope: &'s Scope<'s, 'e>, files: &'e Files<'e>, join: bool) -> Self {
        let joiner = join.then(|| {
            let (tx, rx) = std::sync::mpsc::sync_channel(1);
            Joiner {
                tx,
                handle: scope.spawn(move || files.join_chunks(rx)),
            }
        });
        let plan = files.plan;
        let template = plan.spec.map(|s| s.empty(plan.grid));
        let large = plan.rows && plan.chunk_poses > TWO_IN_FLIGHT_ROWS;
        Writer {
            scope,
            files,
            writing: VecDeque::new(),
            in_flight: if large { 1 } else { IN_FLIGHT },
            joiner,
            total: template.clone(),
            template,
        }
    }

    /// Returns whether the result is joined as chunks finish.
    pub(crate) fn joins(&self) -> bool {
        self.joiner.is_some()
    }

    /// Waits for every chunk being written, in order, adding each one's summary to the total and
    /// its table to the result's join.
    pub(crate) fn settle(&mut self) -> Result<()> {
        while !self.writing.is_empty() {
            self.settle_oldest()?;
        }
        Ok(())
    }

    /// Waits for the oldest chunk being written, if any, then adds its summary to the total and
    /// its table to the result's join. On an error, the writes after it are waited for too (their
    /// results, even a panic, set aside), and the first error is returned.
    fn settle_oldest(&mut self) -> Result<()> {
        let settled = self.settle_one();
        if settled.is_err() {
            for (_, h) in self.writing.drain(..) {
                let _ = h.join();
            }
        }
        settled
    }

    fn settle_one(&mut self) -> Result<()> {
        let Some((c, h)) = self.writing.pop_front() else {
            return Ok(());
        };
        let written = h
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        if let (Some(spec), Some(t), Some(s)) = (self.files.plan.spec, &mut self.total, written.summary) {
            spec.merge_into(t, &s, "summary")?;
        }
        match written.table {
            Some(bytes) => Joiner::send(&mut self.joiner, ToJoin::Bytes(c, bytes)),
            None => Ok(()),
        }
    }

    /// Settles the oldest chunk while the most are being written, then starts writing `computed`
    /// on a thread of its own.
    ///
    /// The run's `last` chunk keeps out of the run's state what the results take from memory:
    /// its summary part (the summary goes straight into the total) and, when the result is
    /// joined as chunks finish, its Parquet table (straight into the result). A CSV chunk, or a
    /// Parquet one joined from the files at the end, is still written. The results are written
    /// next, so an interruption loses at most this chunk, as it may any other.
    pub(crate) fn write(&mut self, computed: Computed, last: bool) -> Result<()> {
        while self.writing.len() >= self.in_flight {
            self.settle_oldest()?;
        }
        let files = self.files;
        let Computed {
            chunk,
            poses,
            table,
            values,
        } = computed;
        let keep = !(last && (table.is_none() || self.joins()));
        let handle = self
            .scope
            .spawn(move || files.write_chunk(chunk, poses, table, values, keep));
        self.writing.push_back((chunk, handle));
        Ok(())
    }

    /// Takes chunk `c`, finished by an earlier run: its table into the result's join, and its
    /// summary, read back, into the total.
    pub(crate) fn resumed(&mut self, c: u64) -> Result<()> {
        if self.joiner.is_some() {
            self.settle()?;
            Joiner::send(&mut self.joiner, ToJoin::File(c))?;
        }
        let plan = self.files.plan;
        if let (Some(spec), Some(t), Some(template)) = (plan.spec, &mut self.total, &self.template) {
            let r = plan.chunk(c);
            let path = self.files.chunk_summary(c);
            let context = path.display().to_string();
            let part: PartSummary = read_part(&path, self.files.expected(&r))?;
            let part = part.into_summary(template, &context)?;
            spec.check(&part, r.start, r.end - r.start, &context)?;
            spec.merge_into(t, &part, &context)?;
        }
        Ok(())
    }

    /// Tells the joiner every chunk is in and waits for the result, if it is joined this way.
    pub(crate) fn finish_join(&mut self) -> Result<()> {
        match self.joiner.take() {
            Some(joiner) => joiner.finish(),
            None => Ok(()),
        }
    }
}

/// The thread joining a run's Parquet chunks ([`Files::join_chunks`]), and its channel.
struct Joiner<'s> {
    tx: std::sync::mpsc::SyncSender<ToJoin>,
    handle: ScopedJoinHandle<'s, Result<()>>,
}

impl Joiner<'_> {
    /// Sends `message` to the joiner, if any. If it has stopped on an error, returns that error.
    fn send(joiner: &mut Option<Joiner<'_>>, message: ToJoin) -> Result<()> {
        let Some(j) = joiner else {
            return Ok(());
        };
        if j.tx.send(message).is_ok() {
            return Ok(());
        }
        let j = joiner.take().expect("a joiner");
        drop(j.tx);
        match j
            .handle
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        {
            Err(e) => Err(e),
            Ok(()) => Err(Error::write_output(
                std::path::Path::new("sweep"),
                "the join of its chunks ended early",
            )),
        }
    }

    fn finish(self) -> Result<()> {
        // A joiner that has stopped on an error has dropped its receiver: its error is returned.
        let _ = self.tx.send(ToJoin::Finish);
        drop(self.tx);
        self.handle
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    }
}
