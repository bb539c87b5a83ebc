//! Reports: files written whole or not at all (temporary file, then rename), occupancy as PNG and
//! NPY.

pub mod figures;
pub mod mask_image;
pub mod occupancy_image;

use std::io::Write;
use std::path::Path;

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
