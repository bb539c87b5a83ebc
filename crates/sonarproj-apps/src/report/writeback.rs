//! A file that hands its bytes to the disk while it is still being written, so that the flush
//! before its rename waits for the last few megabytes only, not the whole file.
//!
//! Without it, a large result (a 1 M-pose Parquet sweep is over 40 MB) sits in the page cache
//! until the final `fsync`, which then writes all of it while the run waits. Every [`STEP`] bytes
//! the file asks Linux to start writing the bytes so far (`sync_file_range` with
//! `SYNC_FILE_RANGE_WRITE`: it starts the writes and returns, waiting only when the disk's queue
//! is full). That is only a hint: the final flush still checks every byte, and an error from the
//! hint is left to it. Elsewhere it writes through and does nothing more.

use std::fs::File;
use std::io::Write;

/// Bytes written between two hints.
const STEP: u64 = 4 << 20;

/// A file written from its start, handing each [`STEP`] of bytes to the disk as they come.
pub(super) struct WritingBack<'f> {
    file: &'f mut File,
    /// Bytes written.
    written: u64,
    /// Bytes whose writing has been started.
    started: u64,
    /// Bytes written between hints.
    step: u64,
}

impl<'f> WritingBack<'f> {
    /// Returns `file`, empty, written through this: handed to the disk as it comes when
    /// `hand_on` (it will be flushed), else only written.
    pub(super) fn new(file: &'f mut File, hand_on: bool) -> Self {
        WritingBack {
            file,
            written: 0,
            started: 0,
            step: if hand_on { STEP } else { u64::MAX },
        }
    }
}

impl Write for WritingBack<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.written += n as u64;
        if self.written - self.started >= self.step {
            start_writing(self.file, self.started, self.written - self.started);
            self.started = self.written;
        }
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// Asks the system to start writing `len` bytes of `file` from `offset` to the disk, without
/// waiting for them. Errors are left to the final flush, which sees every byte.
#[cfg(target_os = "linux")]
fn start_writing(file: &File, offset: u64, len: u64) {
    use std::os::fd::AsRawFd;
    let (Ok(offset), Ok(len)) = (i64::try_from(offset), i64::try_from(len)) else {
        return;
    };
    // SAFETY: the descriptor is `file`'s, open for the whole call, and no memory is passed.
    let _ = unsafe { libc::sync_file_range(file.as_raw_fd(), offset, len, libc::SYNC_FILE_RANGE_WRITE) };
}

#[cfg(not(target_os = "linux"))]
fn start_writing(_: &File, _: u64, _: u64) {}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Seek};

    /// Bytes written in pieces of every size, across many hints, come back as written, and a
    /// hint is started at each step.
    #[test]
    fn writes_every_byte_and_starts_each_step() {
        let mut file = tempfile::tempfile().unwrap();
        let bytes: Vec<u8> = (0..200_000u32)
            .map(|i| u8::try_from(i * 7 % 251).unwrap())
            .collect();
        {
            let mut w = WritingBack::new(&mut file, true);
            w.step = 1000;
            let mut rest = &bytes[..];
            let mut piece = 1;
            while !rest.is_empty() {
                let (a, b) = rest.split_at(piece.min(rest.len()));
                w.write_all(a).unwrap();
                rest = b;
                piece = piece * 3 % 4093 + 1;
            }
            w.flush().unwrap();
            assert_eq!(w.written, bytes.len() as u64);
            assert!(
                w.written - w.started < 1000 + 4093,
                "{} of {}",
                w.started,
                w.written
            );
            assert!(w.started > 0);
        }
        file.sync_all().unwrap();
        file.rewind().unwrap();
        let mut back = Vec::new();
        file.read_to_end(&mut back).unwrap();
        assert!(back == bytes);
    }

    /// A file that will not be flushed is only written: no hint.
    #[test]
    fn a_file_not_flushed_gets_no_hint() {
        let mut file = tempfile::tempfile().unwrap();
        let mut w = WritingBack::new(&mut file, false);
        w.write_all(&vec![1u8; usize::try_from(STEP).unwrap() + 10])
            .unwrap();
        assert_eq!((w.written, w.started), (STEP + 10, 0));
    }
}
