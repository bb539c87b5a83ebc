//! Reports: files written whole or not at all (temporary file, then rename), occupancy as PNG and
//! NPY.

pub mod figures;
pub mod mask_image;
pub mod occupancy_image;

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Writes `values` to `w` as an NPY array of `shape` (named `path` in errors).
///
/// # Errors
/// [`Error::WriteOutput`] on I/O failure.
pub fn write_npy<T: npyz::AutoSerialize>(
    w: &mut dyn Write,
    shape: &[u64],
    values: impl IntoIterator<Item = T>,
    path: &Path,
) -> Result<()> {
    use npyz::WriterBuilder;
    let err = |e: std::io::Error| Error::WriteOutput {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut writer = npyz::WriteOptions::<T>::new()
        .default_dtype()
        .shape(shape)
        .writer(w)
        .begin_nd()
        .map_err(err)?;
    writer.extend(values).map_err(err)?;
    writer.finish().map_err(err)
}

/// Where an output path leads, decided before anything is written.
#[derive(Debug, PartialEq, Eq)]
enum Target {
    /// A regular file (or none yet) at this path, replaced atomically: a symlink is followed to
    /// the file it names, which is replaced, and the link kept.
    Replace(PathBuf),
    /// A device, FIFO, socket or terminal, or a magic link such as `/proc/self/fd/1` or
    /// `/dev/stdout`: written straight through, never replaced.
    Through,
}

/// Returns where writing `path` leads.
fn target(path: &Path) -> Result<Target> {
    if path.as_os_str().is_empty() {
        return Err(Error::invalid("output path", "\"\"", "must name a file"));
    }
    // Descriptors reached through /proc or /dev/fd are open files of this process or another:
    // replacing the link's target would detach them from whoever holds them.
    let magic = ["/proc", "/dev/fd", "/dev/stdout", "/dev/stderr", "/dev/stdin"]
        .iter()
        .any(|p| path.starts_with(p));
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(Error::invalid(
            "output path",
            path.display(),
            "is a directory; give a file path",
        )),
        Ok(m) if !m.is_file() || magic => Ok(Target::Through),
        Ok(_) => Ok(Target::Replace(
            std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
        )),
        // A link to nothing yet: the file is created where the link points.
        Err(_) if path.is_symlink() => {
            let dest = std::fs::read_link(path).unwrap_or_else(|_| path.to_path_buf());
            let dest = match path.parent() {
                Some(dir) if dest.is_relative() => dir.join(dest),
                _ => dest,
            };
            Ok(Target::Replace(dest))
        }
        Err(_) => Ok(Target::Replace(path.to_path_buf())),
    }
}

/// Returns `Ok` when `path` (the value of `field`) can be an output directory: a directory, or
/// nothing yet. Commands call it before any work, and [`output_dir`] once there is something to
/// write, so that a refused run leaves nothing behind.
///
/// # Errors
/// An input error naming `field` when `path` is empty or exists and is not a directory.
pub fn check_output_dir(path: &Path, field: &str) -> Result<()> {
    if path.as_os_str().is_empty() {
        return Err(Error::invalid(field, "\"\"", "must name a directory"));
    }
    match std::fs::metadata(path) {
        Ok(m) if !m.is_dir() => Err(Error::invalid(
            field,
            path.display(),
            "is a file, not a directory; give a directory (created when missing)",
        )),
        _ => Ok(()),
    }
}

/// Creates the output directory `path` (the value of `field`) when missing, with its parents.
///
/// # Errors
/// As [`check_output_dir`]; [`Error::WriteOutput`] when it cannot be created.
pub fn output_dir(path: &Path, field: &str) -> Result<()> {
    check_output_dir(path, field)?;
    std::fs::create_dir_all(path).map_err(|e| Error::WriteOutput {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Writes `path` whole or not at all: `fill` writes into a temporary file beside it, which is
/// renamed over `path` only when `fill` succeeded. A symlink is followed and the file it names is
/// replaced (the link stays); a special file — a device, FIFO, socket, terminal, or a magic link
/// such as `/proc/self/fd/1` — is written straight through and never replaced.
///
/// # Errors
/// [`Error::WriteOutput`] on I/O failure; an input error for an empty path or a directory; any
/// error `fill` returns (a regular file is then not created or changed).
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let io_err = |e: &dyn std::fmt::Display| Error::WriteOutput {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
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
    let mut tmp = tempfile::Builder::new()
        .prefix(".sonarproj-")
        .tempfile_in(dir)
        .map_err(|e| io_err(&e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w)?;
        w.flush().map_err(|e| io_err(&e))?;
    }
    // The temporary file is created private (0600); the result is an ordinary output file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let perms = std::fs::Permissions::from_mode(0o644);
        tmp.as_file().set_permissions(perms).map_err(|e| io_err(&e))?;
    }
    tmp.as_file().sync_all().map_err(|e| io_err(&e))?;
    tmp.persist(path).map_err(|e| io_err(&e.error))?;
    Ok(())
}
