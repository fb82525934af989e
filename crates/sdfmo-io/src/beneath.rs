//! Reading a file inside a folder that someone else wrote (a shard's output folder copied from
//! another machine), without following any symbolic link below that folder.
//!
//! [`read_regular`](crate::read_regular) follows links, which is right for a path the user
//! named but not for a name the command derives inside a folder it did not write: a link
//! planted at `images/part/svo_d7_0.png` (or at `images` itself) would make the reader copy any
//! file the user can read. Here every component below the folder is opened relative to the one
//! before it (`openat` with `O_NOFOLLOW`), so a link anywhere below the folder is refused, and
//! no rename between a check and the open can swap one in.

use std::fs::File;
use std::io::Read;
use std::path::{Component, Path};

use crate::{os, FileKind, IoError, Result};

/// Reads the regular file `folder/relative` if it holds at most `limit` bytes, following no
/// symbolic link below `folder` (`folder` itself, named by the user, may be one).
///
/// `relative` must be made of plain names: an absolute path or a `..` component is refused
/// before anything is opened.
///
/// # Errors
/// [`IoError::OutsideFolder`] for an absolute `relative` or one with `..`;
/// [`IoError::SymbolicLink`] when any component below `folder` is a link;
/// [`IoError::NotRegularFile`] when the file (or a folder on the way) is of the wrong kind;
/// [`IoError::TooLarge`]; [`IoError::OutOfMemory`] when the buffer cannot be allocated;
/// [`IoError::Os`] (of kind `NotFound` for a missing file).
pub fn read_beneath(folder: &Path, relative: &Path, limit: u64) -> Result<Vec<u8>> {
    let path = folder.join(relative);
    let outside = |reason| IoError::OutsideFolder {
        reference: relative.display().to_string().chars().take(120).collect(),
        folder: folder.to_path_buf(),
        reason,
    };
    let mut names = Vec::new();
    for c in relative.components() {
        match c {
            Component::Normal(n) => names.push(n),
            Component::CurDir => {}
            Component::ParentDir => return Err(outside("it climbs out with `..`")),
            Component::RootDir | Component::Prefix(_) => {
                return Err(outside("it is an absolute path"))
            }
        }
    }
    if names.is_empty() {
        return Err(IoError::NotAFilePath {
            path,
            reason: "it names no file",
        });
    }
    let file = open_beneath(folder, &names, &path)?;
    let meta = file.metadata().map_err(os("read", &path))?;
    if !meta.is_file() {
        return Err(IoError::NotRegularFile {
            path,
            kind: FileKind::of(&meta),
            action: "read",
        });
    }
    let too_large = |size| IoError::TooLarge {
        path: path.clone(),
        size,
        limit,
    };
    if meta.len() > limit {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::new();
    crate::read::reserve(&mut bytes, meta.len(), &path)?;
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(os("read", &path))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// Opens `folder/names…` one component at a time with `openat(…, O_NOFOLLOW)`.
#[cfg(unix)]
fn open_beneath(folder: &Path, names: &[&std::ffi::OsStr], path: &Path) -> Result<File> {
    use std::ffi::CString;
    use std::os::fd::{FromRawFd, OwnedFd};
    use std::os::unix::ffi::OsStrExt;

    let dir = std::fs::OpenOptions::new()
        .read(true)
        .open(folder)
        .map_err(os("open", folder))?;
    let mut dir: OwnedFd = dir.into();
    let mut sofar = folder.to_path_buf();
    for (i, name) in names.iter().enumerate() {
        sofar.push(name);
        let last = i + 1 == names.len();
        let c = CString::new(name.as_bytes()).map_err(|_| IoError::NotAFilePath {
            path: path.to_path_buf(),
            reason: "it holds a NUL byte",
        })?;
        let flags = libc::O_RDONLY
            | libc::O_NOFOLLOW
            | libc::O_CLOEXEC
            | if last {
                // A FIFO swapped in must not block the open.
                libc::O_NONBLOCK
            } else {
                libc::O_DIRECTORY
            };
        use std::os::fd::AsRawFd;
        // SAFETY: `dir` is an open descriptor we own and `c` a NUL-terminated string; openat
        // reads both and returns a new descriptor or -1.
        let fd = unsafe { libc::openat(dir.as_raw_fd(), c.as_ptr(), flags) };
        if fd < 0 {
            let e = std::io::Error::last_os_error();
            return Err(refusal(&sofar, e));
        }
        // SAFETY: `fd` was just returned by openat and is owned by nobody else.
        dir = unsafe { OwnedFd::from_raw_fd(fd) };
    }
    Ok(File::from(dir))
}

/// What a failed `openat` of `at` means: a link (`ELOOP`, or `ENOTDIR` on a link to a folder
/// opened with `O_DIRECTORY|O_NOFOLLOW`) or the operating system's error.
#[cfg(unix)]
fn refusal(at: &Path, e: std::io::Error) -> IoError {
    let is_link = std::fs::symlink_metadata(at).is_ok_and(|m| m.file_type().is_symlink());
    if is_link || e.raw_os_error() == Some(libc::ELOOP) {
        return IoError::SymbolicLink {
            path: at.to_path_buf(),
        };
    }
    if e.raw_os_error() == Some(libc::ENOTDIR) {
        if let Ok(meta) = std::fs::symlink_metadata(at) {
            return IoError::NotRegularFile {
                path: at.to_path_buf(),
                kind: FileKind::of(&meta),
                action: "read",
            };
        }
    }
    os("open", at)(e)
}

/// Elsewhere: each component is checked with `symlink_metadata` before the file is opened (a
/// link swapped in between is not caught).
#[cfg(not(unix))]
fn open_beneath(folder: &Path, names: &[&std::ffi::OsStr], path: &Path) -> Result<File> {
    let mut sofar = folder.to_path_buf();
    for name in names {
        sofar.push(name);
        let meta = std::fs::symlink_metadata(&sofar).map_err(os("open", &sofar))?;
        if meta.file_type().is_symlink() {
            return Err(IoError::SymbolicLink { path: sofar });
        }
    }
    File::open(path).map_err(os("open", path))
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn links_below_the_folder_are_refused_and_plain_files_read() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let secret = d.join("secret");
        std::fs::write(&secret, b"secret").unwrap();
        let shard = d.join("shard");
        std::fs::create_dir_all(shard.join("images/a")).unwrap();
        std::fs::write(shard.join("images/a/v.png"), b"png").unwrap();
        assert_eq!(
            read_beneath(&shard, Path::new("images/a/v.png"), 16).unwrap(),
            b"png"
        );
        // A link as the file, as a folder on the way, and as the first folder.
        std::os::unix::fs::symlink(&secret, shard.join("images/a/w.png")).unwrap();
        std::os::unix::fs::symlink(d, shard.join("images/b")).unwrap();
        std::fs::create_dir(d.join("other")).unwrap();
        std::fs::create_dir(d.join("other/a")).unwrap();
        std::fs::write(d.join("other/a/v.png"), b"other").unwrap();
        let s2 = d.join("s2");
        std::fs::create_dir(&s2).unwrap();
        std::os::unix::fs::symlink(d.join("other"), s2.join("images")).unwrap();
        for (base, rel) in [
            (&shard, "images/a/w.png"),
            (&shard, "images/b/secret"),
            (&s2, "images/a/v.png"),
        ] {
            let e = read_beneath(base, Path::new(rel), 16).unwrap_err();
            assert!(matches!(e, IoError::SymbolicLink { .. }), "{rel}: {e}");
        }
        // The folder itself may be a link (the user named it).
        std::os::unix::fs::symlink(&shard, d.join("via")).unwrap();
        assert!(read_beneath(&d.join("via"), Path::new("images/a/v.png"), 16).is_ok());
        for bad in ["../secret", "/etc/hostname"] {
            let e = read_beneath(&shard, Path::new(bad), 16).unwrap_err();
            assert!(matches!(e, IoError::OutsideFolder { .. }), "{bad}: {e}");
        }
        let e = read_beneath(&shard, Path::new("images/a/v.png"), 2).unwrap_err();
        assert!(matches!(e, IoError::TooLarge { .. }), "{e}");
        let e = read_beneath(&shard, Path::new("images/a"), 16).unwrap_err();
        assert!(matches!(e, IoError::NotRegularFile { .. }), "{e}");
        let e = read_beneath(&shard, Path::new("missing.png"), 16).unwrap_err();
        assert_eq!(e.os_kind(), Some(std::io::ErrorKind::NotFound));
    }
}
