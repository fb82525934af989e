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
/// bytes, so a file that grows while it is read cannot exhaust memory either. The buffer is
/// allocated fallibly: a file larger than the memory the process may map is
/// [`IoError::OutOfMemory`], not an abort.
///
/// # Errors
/// As [`open_regular`], plus [`IoError::TooLarge`] and [`IoError::OutOfMemory`].
pub fn read_regular(path: &Path, limit: u64) -> Result<Vec<u8>> {
    read_regular_checked(path, limit, 0, |_, len| Ok(len))
}

/// [`read_regular`] for a format whose header declares its size: the first `head_len` bytes
/// (the whole file when it is shorter) are read and handed to `check` with the file's length
/// in bytes, and the rest is read only when `check` accepts them. `check` returns how many
/// bytes of the file to read in all: its length, or less for a format that ignores what
/// follows its declared size (never less than the head already read). A header that lies about
/// the size is refused after reading `head_len` bytes, whatever the file's length (a sparse
/// file of gigabytes behind a header of a few hundred kilobytes costs one small read).
///
/// # Errors
/// As [`read_regular`] (converted into `E`), and whatever `check` returns.
pub fn read_regular_checked<E: From<IoError>>(
    path: &Path,
    limit: u64,
    head_len: usize,
    check: impl FnOnce(&[u8], u64) -> std::result::Result<u64, E>,
) -> std::result::Result<Vec<u8>, E> {
    let (mut file, len) = open_regular(path)?;
    let too_large = |size| IoError::TooLarge {
        path: path.to_path_buf(),
        size,
        limit,
    };
    if len > limit {
        return Err(too_large(len).into());
    }
    let head_len = (head_len as u64).min(len);
    let mut bytes = Vec::new();
    reserve(&mut bytes, head_len, path)?;
    (&mut file)
        .take(head_len)
        .read_to_end(&mut bytes)
        .map_err(os("read", path))?;
    let wanted = check(&bytes, len)?.clamp(bytes.len() as u64, len);
    let more = wanted - bytes.len() as u64;
    reserve(&mut bytes, more, path)?;
    // Up to `limit + 1` bytes when the whole file is wanted (a file growing past the limit is
    // refused), else the bytes wanted.
    let rest = if wanted < len {
        wanted
    } else {
        limit.saturating_add(1)
    } - bytes.len() as u64;
    file.take(rest)
        .read_to_end(&mut bytes)
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::OutOfMemory => IoError::OutOfMemory {
                path: path.to_path_buf(),
                bytes: len,
            },
            _ => os("read", path)(e),
        })?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64).into());
    }
    Ok(bytes)
}

/// Reserves room for `more` bytes in `bytes`, or [`IoError::OutOfMemory`].
pub(crate) fn reserve(bytes: &mut Vec<u8>, more: u64, path: &Path) -> Result<()> {
    let total = more.saturating_add(bytes.len() as u64);
    let out_of_memory = || IoError::OutOfMemory {
        path: path.to_path_buf(),
        bytes: total,
    };
    let more = usize::try_from(more).map_err(|_| out_of_memory())?;
    bytes.try_reserve_exact(more).map_err(|_| out_of_memory())
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
