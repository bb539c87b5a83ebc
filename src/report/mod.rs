//! Reports: files written whole or not at all (temporary file, then rename), occupancy as PNG and
//! NPY.

pub mod figures;
pub mod mask_image;
pub mod occupancy_image;

use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};

/// Writes `path` whole or not at all: `fill` writes into a temporary file beside it, which is
/// renamed over `path` only when `fill` succeeded.
///
/// # Errors
/// [`Error::WriteOutput`] on I/O failure; any error `fill` returns (the file is then not created).
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let io_err = |e: &dyn std::fmt::Display| Error::WriteOutput {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
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
