//! Files written whole or not at all: a temporary beside the output is renamed over it once
//! everything is written.
//!
//! A temporary's name says whose it is: `.sonarproj-HOST-PID-RANDOM.tmp`. A signal handler
//! removes the process's own ([`remove_live_temporaries`]). A later run removes those this
//! host's dead processes left ([`remove_stale_temporaries`]), but never a live process's or
//! another host's: shards of one sweep may write to one directory from several machines.

use sonarproj::error::Field;
use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use super::writeback::WritingBack;
use crate::error::{Error, Result};

/// Bytes a file written through a temporary is written in. Copies into it (a Parquet join's row
/// groups) come in pieces of 8 KiB, each a `write` of its own with a smaller buffer: a 1 M-pose
/// Parquet sweep made 5 865 writes, now 65 (every file of the run, `strace -c -e write`).
const BUFFER: usize = 1 << 20;

/// The temporaries this process has open.
static LIVE: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());
/// The directories whose stale temporaries this process has already looked for.
static SWEPT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());
/// The files this process reads as inputs, keyed by device, inode, change time and size, with
/// the path they were given as. The change time and size keep a new file on a freed inode
/// (the input deleted meanwhile) from passing for the input.
static INPUTS: Mutex<BTreeMap<InputKey, PathBuf>> = Mutex::new(BTreeMap::new());

/// Device, inode, change time (s, ns) and size of a file.
type InputKey = (u64, u64, i64, i64, u64);

/// Returns the key of the file `m` describes in [`INPUTS`].
#[cfg(unix)]
fn input_key(m: &std::fs::Metadata) -> InputKey {
    use std::os::unix::fs::MetadataExt;
    (m.dev(), m.ino(), m.ctime(), m.ctime_nsec(), m.size())
}

/// Notes that this process reads the regular file at `path`, such as an input CSV, a sonar file
/// or a sweep file. [`write_atomic`] then refuses to replace it, whatever path or link leads
/// there.
pub fn note_input(path: &Path) {
    #[cfg(unix)]
    if let Ok(m) = std::fs::metadata(path)
        && m.is_file()
        && let Ok(mut inputs) = INPUTS.lock()
    {
        inputs.insert(input_key(&m), path.to_path_buf());
    }
    #[cfg(not(unix))]
    let _ = path;
}

/// Notes that this process reads standard input, when it is a regular file (`< file`): no
/// output may then replace that file, whatever path or link leads there (`/dev/stdin`,
/// `/proc/self/fd/0`, the file's own name).
pub fn note_stdin() {
    #[cfg(unix)]
    {
        use std::os::fd::AsFd;
        let file = std::io::stdin()
            .as_fd()
            .try_clone_to_owned()
            .map(std::fs::File::from);
        if let Ok(m) = file.and_then(|f| f.metadata())
            && m.is_file()
            && let Ok(mut inputs) = INPUTS.lock()
        {
            inputs.insert(input_key(&m), PathBuf::from("read on standard input"));
        }
    }
}

/// Returns the text of the configuration file at `path`, noted as an input ([`note_input`]),
/// and the folder its relative paths are taken from.
///
/// # Errors
/// [`Error::ReadInput`] when it cannot be read, is not UTF-8 or is longer than
/// [`MAX_CONFIG_BYTES`](crate::limits::MAX_CONFIG_BYTES).
pub fn read_config(path: &Path) -> Result<(String, std::path::PathBuf)> {
    use crate::limits::MAX_CONFIG_BYTES;
    use std::io::Read;
    note_input(path);
    let fail = |source: std::io::Error| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    };
    let mut bytes = Vec::new();
    sonarproj::files::open_regular(path)
        .and_then(|f| f.take(MAX_CONFIG_BYTES + 1).read_to_end(&mut bytes))
        .map_err(fail)?;
    if bytes.len() as u64 > MAX_CONFIG_BYTES {
        return Err(fail(std::io::Error::other(format!(
            "longer than {MAX_CONFIG_BYTES} bytes: not a sweep or advise file"
        ))));
    }
    let text = String::from_utf8(bytes)
        .map_err(|e| fail(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))?;
    Ok((text, path.parent().map(Path::to_path_buf).unwrap_or_default()))
}

/// Returns an error when the regular file at `path` is one that [`note_input`] noted.
fn refuse_input(path: &Path, m: &std::fs::Metadata) -> Result<()> {
    #[cfg(unix)]
    {
        let inputs = INPUTS.lock().map_err(|_| Error::WriteOutput {
            path: path.to_path_buf(),
            message: "the list of input files is poisoned".into(),
        })?;
        if let Some(input) = inputs.get(&input_key(m)) {
            return Err(Error::invalid(
                "output path",
                path.display(),
                format!(
                    "is the input file {} (the same file): writing it would destroy what is \
                     being read; give another output path",
                    input.display()
                ),
            ));
        }
    }
    #[cfg(not(unix))]
    let _ = (path, m);
    Ok(())
}

/// Returns this machine's host name, made safe for a file name (`unknown` when it has none).
fn host() -> String {
    #[cfg(unix)]
    let name = rustix::system::uname().nodename().to_string_lossy().into_owned();
    #[cfg(not(unix))]
    let name = std::env::var("COMPUTERNAME").unwrap_or_default();
    let safe: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if safe.is_empty() { "unknown".into() } else { safe }
}

fn host_prefix() -> String {
    format!(".sonarproj-{}-", host())
}

/// Returns whether process `pid` of this host is alive, or true when that cannot be told.
fn alive(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Some(pid) = i32::try_from(pid).ok().and_then(rustix::process::Pid::from_raw) else {
            return true;
        };
        // ESRCH means no such process. Any other answer (EPERM: another user's) means it exists.
        !matches!(
            rustix::process::test_kill_process(pid),
            Err(e) if e == rustix::io::Errno::SRCH
        )
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

/// Removes the temporaries this process has open and returns how many. The caller is about to
/// exit, so they are never renamed. Safe to call from a signal-handling thread.
pub fn remove_live_temporaries() -> usize {
    let live = match LIVE.lock() {
        Ok(live) => live,
        Err(poisoned) => poisoned.into_inner(),
    };
    live.iter().filter(|p| std::fs::remove_file(p).is_ok()).count()
}

/// Removes from `dir` the temporaries of this host's processes that no longer run, and returns
/// how many (callers may ignore it). Never touches temporaries of live processes or of other
/// hosts, nor files of other names.
#[expect(
    clippy::must_use_candidate,
    reason = "the count is for tests and logs; a caller has nothing to act on"
)]
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let prefix = host_prefix();
    let me = std::process::id();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(&prefix))
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        let regular = entry.file_type().is_ok_and(|t| t.is_file());
        if regular && pid != me && !alive(pid) && std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Removes `dir`'s stale temporaries the first time this process writes there.
fn sweep_once(dir: &Path) {
    let key = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    let first = SWEPT.lock().map(|mut s| s.insert(key)).unwrap_or(false);
    if first {
        remove_stale_temporaries(dir);
    }
}

/// A temporary file on the list of live ones, taken off the list when dropped.
struct Listed(PathBuf);

impl Drop for Listed {
    fn drop(&mut self) {
        if let Ok(mut live) = LIVE.lock() {
            live.remove(&self.0);
        }
    }
}

/// Where an output path leads, decided before anything is written.
#[derive(Debug, PartialEq, Eq)]
enum Target {
    /// A regular file, or none yet, at this path, replaced atomically. A symlink is followed to
    /// the file it names, which is replaced while the link stays.
    Replace(PathBuf),
    /// A device, FIFO, socket or terminal, or a magic link such as `/proc/self/fd/1` or
    /// `/dev/stdout`. Written straight through, never replaced.
    Through,
}

fn target(path: &Path) -> Result<Target> {
    if path.as_os_str().is_empty() {
        return Err(Error::invalid("output path", "\"\"", "must name a file"));
    }
    // Paths under /proc or /dev/fd are open files of this process or another. Replacing the link's
    // target would detach them from whoever holds them.
    let magic = ["/proc", "/dev/fd", "/dev/stdout", "/dev/stderr", "/dev/stdin"]
        .iter()
        .any(|p| path.starts_with(p));
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(Error::invalid(
            "output path",
            path.display(),
            "is a directory; give a file path",
        )),
        // A magic link to a regular file (`/dev/stdin` read from a file) leads to that file:
        // never to an input.
        Ok(m) if !m.is_file() || magic => {
            if m.is_file() {
                refuse_input(path, &m)?;
            }
            Ok(Target::Through)
        }
        Ok(m) => {
            refuse_input(path, &m)?;
            Ok(Target::Replace(
                std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
            ))
        }
        // A link to nothing yet: the file is created where the link points. A loop of links, or
        // a link to another link that leads nowhere, is refused: writing would replace a link.
        Err(e) if path.is_symlink() => {
            let dest = std::fs::read_link(path).unwrap_or_else(|_| path.to_path_buf());
            let dest = match path.parent() {
                Some(dir) if dest.is_relative() => dir.join(dest),
                _ => dest,
            };
            if e.kind() != std::io::ErrorKind::NotFound || dest.is_symlink() {
                return Err(Error::invalid(
                    "output path",
                    path.display(),
                    "is a link that leads to no file (a loop or a chain of links); give a file path",
                ));
            }
            creatable_parent(path, &dest)?;
            Ok(Target::Replace(dest))
        }
        Err(_) => {
            creatable_parent(path, path)?;
            Ok(Target::Replace(path.to_path_buf()))
        }
    }
}

/// Returns `Ok` when the folder of `file` (where output `path` leads) exists or can be created:
/// no part of it is a file.
fn creatable_parent(path: &Path, file: &Path) -> Result<()> {
    let nearest = file
        .ancestors()
        .skip(1)
        .find(|a| !a.as_os_str().is_empty() && std::fs::metadata(a).is_ok());
    match nearest {
        Some(a) if !a.is_dir() => Err(Error::invalid(
            "output path",
            path.display(),
            format!("cannot be created: {} is a file, not a directory", a.display()),
        )),
        _ => Ok(()),
    }
}

/// Creates the missing folders above `file` and returns them, the deepest first, for
/// [`remove_created`] to take away should nothing be written.
fn create_parents(file: &Path) -> std::io::Result<Vec<PathBuf>> {
    let missing: Vec<PathBuf> = file
        .ancestors()
        .skip(1)
        .take_while(|a| !a.as_os_str().is_empty() && std::fs::symlink_metadata(a).is_err())
        .map(Path::to_path_buf)
        .collect();
    if let Some(deepest) = missing.first() {
        std::fs::create_dir_all(deepest)?;
    }
    Ok(missing)
}

/// Removes the folders [`create_parents`] made, the deepest first, each only while empty.
fn remove_created(created: &[PathBuf]) {
    for dir in created {
        if std::fs::remove_dir(dir).is_err() {
            break;
        }
    }
}

/// Returns `Ok` when [`write_atomic`] could write `path`: not a directory, nor an input of this
/// process, nor under a file. For commands that check all their output files before writing
/// any.
///
/// # Errors
/// As [`write_atomic`]'s checks, with `field` naming the path.
pub fn check_output_file(path: &Path, field: impl Into<Field>) -> Result<()> {
    target(path).map(|_| ()).map_err(|e| match e {
        Error::Engine(e) => Error::Engine(e.in_context(field)),
        other => other,
    })
}

/// Writes `path` whole or not at all, creating its folder when missing.
///
/// 1. `fill` writes into a temporary `.sonarproj-HOST-PID-RANDOM.tmp` beside `path`, listed
///    for [`remove_live_temporaries`].
/// 2. Only when `fill` succeeds is the temporary renamed over `path`.
///
/// A symlink is followed and the file it names replaced. A special file (device, FIFO, socket,
/// terminal, or a magic link such as `/proc/self/fd/1`) is written straight through. An input
/// of this process ([`note_input`]) is never replaced. Missing folders above the file are
/// created, and removed again when `fill` fails.
///
/// # Errors
/// [`Error::WriteOutput`] on I/O failure. An input error for an empty path, a directory, an
/// input file or a folder that cannot be created (a file is in the way). Any error of `fill`,
/// which leaves a regular file untouched.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut (dyn Write + Send)) -> Result<()>) -> Result<()> {
    write_atomic_with(path, true, fill)
}

/// Writes `path` as [`write_atomic`] does, but without flushing it to disk before the rename.
/// Only for files whose reader checks them against a record (a sweep's chunk, with its size
/// and CRC-32): a crash can damage such a file but never pass it off as whole. The flush saved
/// can cost as much as a chunk's whole computation on a GPU.
///
/// # Errors
/// As [`write_atomic`].
pub fn write_atomic_unsynced(
    path: &Path,
    fill: impl FnOnce(&mut (dyn Write + Send)) -> Result<()>,
) -> Result<()> {
    write_atomic_with(path, false, fill)
}

/// Writes as [`write_atomic`], flushing the temporary to disk before the rename when `sync`.
fn write_atomic_with(
    path: &Path,
    sync: bool,
    fill: impl FnOnce(&mut (dyn Write + Send)) -> Result<()>,
) -> Result<()> {
    let io_err = |e: &dyn std::fmt::Display| Error::WriteOutput {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let shown = path;
    let path = match target(path)? {
        Target::Replace(p) => p,
        Target::Through => {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| io_err(&e))?;
            let mut w = std::io::BufWriter::new(file);
            fill(&mut w)?;
            return w.flush().map_err(|e| io_err(&e));
        }
    };
    let path = path.as_path();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    // The folder is created when missing, as output directories are, and taken away again
    // when nothing is written there.
    let created = create_parents(path).map_err(|e| io_err(&e))?;
    let written = write_in((shown, path, dir), sync, fill);
    if written.is_err() {
        remove_created(&created);
    }
    written
}

/// Writes `path` in its existing folder `dir` through a temporary, as [`write_atomic_with`];
/// errors name the output as it was `shown`.
fn write_in(
    (shown, path, dir): (&Path, &Path, &Path),
    sync: bool,
    fill: impl FnOnce(&mut (dyn Write + Send)) -> Result<()>,
) -> Result<()> {
    let io_err = |e: &dyn std::fmt::Display| Error::WriteOutput {
        path: shown.to_path_buf(),
        message: e.to_string(),
    };
    sweep_once(dir);
    // Listed before it exists and until it is gone (`listed` is dropped after `tmp`), so a signal
    // handler finds it. No other live process makes names with this process's id.
    let mut listed: Option<Listed> = None;
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!("{}{}-", host_prefix(), std::process::id()))
        .suffix(".tmp")
        .make_in(dir, |p| {
            if let Ok(mut live) = LIVE.lock() {
                live.insert(p.to_path_buf());
            }
            listed = Some(Listed(p.to_path_buf()));
            let mut options = std::fs::OpenOptions::new();
            options.read(true).write(true).create_new(true);
            #[cfg(unix)]
            std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
            options.open(p)
        })
        .map_err(|e| io_err(&e))?;
    {
        // When it is flushed below, handed to the disk as it is written: the flush then waits
        // for the end only.
        let mut w = std::io::BufWriter::with_capacity(BUFFER, WritingBack::new(tmp.as_file_mut(), sync));
        fill(&mut w)?;
        w.flush().map_err(|e| io_err(&e))?;
    }
    // The temporary is created private (0600). The result is an ordinary output file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let perms = std::fs::Permissions::from_mode(0o644);
        tmp.as_file().set_permissions(perms).map_err(|e| io_err(&e))?;
    }
    if sync {
        tmp.as_file().sync_all().map_err(|e| io_err(&e))?;
    }
    tmp.persist(path).map_err(|e| io_err(&e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::write_atomic;

    #[test]
    fn a_file_creates_its_folders_and_a_failed_fill_takes_them_away() {
        let dir = tempfile::tempdir().unwrap();
        let kept = dir.path().join("kept");
        std::fs::create_dir(&kept).unwrap();
        // A fill that fails: no file, and none of the folders made for it.
        let failed = kept.join("a/b/c.txt");
        let e = write_atomic(&failed, |_| Err(crate::Error::invalid("x", 1, "fails")));
        assert!(e.is_err());
        assert!(!kept.join("a").exists(), "a failed write left its folders");
        assert!(kept.is_dir(), "a folder that was there is kept");
        // A fill that succeeds: the folders and the whole file.
        let written = kept.join("a/b/c.txt");
        write_atomic(&written, |w| {
            w.write_all(b"whole")
                .map_err(|e| crate::Error::write_output(&written, e))
        })
        .unwrap();
        assert_eq!(std::fs::read_to_string(&written).unwrap(), "whole");
        // A file in the way of a folder is bad input, and stays.
        let blocker = dir.path().join("blocker");
        std::fs::write(&blocker, "keep").unwrap();
        let e = write_atomic(&blocker.join("x/y.txt"), |_| Ok(())).unwrap_err();
        assert!(
            e.is_input() && e.to_string().contains("is a file, not a directory"),
            "{e}"
        );
        assert_eq!(std::fs::read_to_string(&blocker).unwrap(), "keep");
    }
}
