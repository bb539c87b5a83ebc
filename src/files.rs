//! Opening the files a run reads: regular files only, bounded, and never a wait on a FIFO
//! (opened without blocking, then refused for what it is). A FIFO, a device or a socket where a
//! file is expected is an error naming it, never a hang or an endless read.

use std::fs::File;
use std::io::Read;
use std::path::Path;

/// The words of the error for a path that is not a regular file.
pub const NOT_REGULAR: &str = "not a regular file (a FIFO, a device, a socket or a directory)";

/// Returns the regular file at `path` opened for reading, following links; an error for
/// anything else (a FIFO is opened without waiting for a writer, then refused).
///
/// # Errors
/// The I/O error of opening it, or [`NOT_REGULAR`] as an `io::Error` when it is not a regular file.
pub fn open_regular(path: &Path) -> std::io::Result<File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(rustix::fs::OFlags::NONBLOCK.bits().cast_signed());
    }
    let file = options.open(path)?;
    if file.metadata()?.is_file() {
        Ok(file)
    } else {
        Err(std::io::Error::other(NOT_REGULAR))
    }
}

/// Returns the bytes of the regular file at `path` ([`open_regular`]), at most `limit` of them.
///
/// # Errors
/// As [`open_regular`], read errors, and an error saying so when the file is longer than `limit`.
pub fn read_regular(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    open_regular(path)?.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(std::io::Error::other(format!("longer than {limit} bytes")));
    }
    Ok(bytes)
}

#[cfg(all(test, unix))]
mod tests {
    use super::{open_regular, read_regular};

    #[test]
    fn fifos_and_devices_are_refused_at_once_files_read_within_their_limit() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        rustix::fs::mkfifoat(rustix::fs::CWD, &fifo, rustix::fs::Mode::from_raw_mode(0o600)).unwrap();
        for path in [fifo.as_path(), std::path::Path::new("/dev/zero"), dir.path()] {
            let e = open_regular(path).map(|_| ()).unwrap_err();
            assert!(
                e.to_string().contains("not a regular file") || path.is_dir(),
                "{path:?}: {e}"
            );
        }
        // A link to a device is the device.
        let link = dir.path().join("zero");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        assert!(read_regular(&link, 10).is_err());
        let file = dir.path().join("f");
        std::fs::write(&file, b"0123456789").unwrap();
        assert_eq!(read_regular(&file, 10).unwrap(), b"0123456789");
        assert!(
            read_regular(&file, 9)
                .unwrap_err()
                .to_string()
                .contains("longer than 9")
        );
    }
}
