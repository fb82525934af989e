//! Reading regular files only, with a size limit known before reading.

use std::fs::{File, OpenOptions};
use std::io::Read;
use std::path::Path;

use crate::{os, FileKind, IoError, Result};

/// Opens `path` for reading if it is a regular file (symbolic links followed), and returns it
/// with its size. Devices, FIFOs, sockets and directories are refused without blocking: the
/// kind is checked before opening, and again on the opened file (opened non-blocking, so a
/// FIFO swapped in between cannot hang the caller).
///
/// # Errors
/// [`IoError::NotRegularFile`] for anything but a regular file, [`IoError::Os`] when the file
/// cannot be examined or opened.
pub fn open_regular(path: &Path) -> Result<(File, u64)> {
    let meta = std::fs::metadata(path).map_err(os("read", path))?;
    refuse_special(path, &meta)?;
    let mut opts = OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        opts.custom_flags(libc_nonblock());
    }
    let file = opts.open(path).map_err(os("open", path))?;
    let meta = file.metadata().map_err(os("read", path))?;
    refuse_special(path, &meta)?;
    Ok((file, meta.len()))
}

/// `O_NONBLOCK`: opening a FIFO for reading would otherwise wait for a writer. It has no effect
/// on regular files.
#[cfg(unix)]
fn libc_nonblock() -> i32 {
    libc::O_NONBLOCK
}

fn refuse_special(path: &Path, meta: &std::fs::Metadata) -> Result<()> {
    if meta.is_file() {
        Ok(())
    } else {
        Err(IoError::NotRegularFile {
            path: path.to_path_buf(),
            kind: FileKind::of(meta),
            action: "read",
        })
    }
}

/// Reads the whole regular file at `path` if it holds at most `limit` bytes.
///
/// The size is checked before any buffer is allocated, and the read stops after `limit + 1`
/// bytes, so a file that grows while it is read cannot exhaust memory either.
///
/// # Errors
/// As [`open_regular`], plus [`IoError::TooLarge`].
pub fn read_regular(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let (file, len) = open_regular(path)?;
    let too_large = |size| IoError::TooLarge {
        path: path.to_path_buf(),
        size,
        limit,
    };
    if len > limit {
        return Err(too_large(len));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(os("read", path))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// [`read_regular`] for UTF-8 text.
///
/// # Errors
/// As [`read_regular`]; invalid UTF-8 is an [`IoError::Os`] of kind `InvalidData`.
pub fn read_regular_to_string(path: &Path, limit: u64) -> Result<String> {
    let bytes = read_regular(path, limit)?;
    String::from_utf8(bytes).map_err(|e| IoError::Os {
        action: "read",
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e.utf8_error()),
    })
}
