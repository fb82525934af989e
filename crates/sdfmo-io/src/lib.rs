//! Safe file I/O for sdf-multioctree, shared by every crate that reads or writes files.
//!
//! Four rules, each in its own module:
//! - **Writes are atomic and never clobber special files** ([`write_atomic`], [`OutputBatch`]):
//!   the bytes go to a fresh temporary file created with `O_EXCL` in the destination's
//!   directory, are synced, then renamed over the destination. A destination that exists and is
//!   not a regular file (a directory, a device such as `/dev/null`, a FIFO, a socket) is refused
//!   before anything is written. A symbolic link is *followed*: the file it points to is
//!   replaced and the link itself stays (as a shell's `>` would do); a dangling link is refused.
//!   That holds for paths the user named; a name the command derives ([`Naming::Derived`]: the
//!   files inside an output folder, numbered siblings) replaces a link found there instead of
//!   following it, and [`create_derived_dir`] does the same for derived folders.
//!   The temporary file is removed on every error path.
//!   An output's name carries its format's extension ([`check_extension`]: `out.jpg` never
//!   gets PNG bytes), checked by every front-end before any work.
//! - **Reads take regular files only, with a size limit known before reading**
//!   ([`read_regular`]): devices and FIFOs are refused at once (no endless `/dev/zero`, no
//!   blocking FIFO), and a file larger than the caller's limit is refused before allocating.
//!   A format whose header declares its size reads the header first and checks it against the
//!   file's length before reading the body ([`read_regular_checked`]); buffers are allocated
//!   fallibly ([`IoError::OutOfMemory`]).
//! - **Logs are appended one whole record at a time** ([`AppendLog`]): one write and a sync
//!   per record, a torn last line dropped on reopening.
//! - **Relative resources stay in their folder** ([`resolve_in_folder`]): absolute paths, `..`
//!   components and symbolic links that lead outside the folder are refused. Files inside a
//!   folder someone else wrote (a shard's output) are read with [`read_beneath`], which follows
//!   no link below the folder at all.
//!
//! ```
//! let dir = tempfile::tempdir()?;
//! let out = dir.path().join("result.txt");
//! sdfmo_io::write_atomic(&out, b"all or nothing")?;
//! assert_eq!(sdfmo_io::read_regular(&out, 1 << 20)?, b"all or nothing");
//! # #[cfg(unix)]
//! assert!(sdfmo_io::read_regular(std::path::Path::new("/dev/zero"), 1 << 20).is_err());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

mod append;
mod beneath;
mod confine;
mod random;
mod read;
mod write;

use std::fmt;
use std::path::PathBuf;

pub use append::AppendLog;
pub use beneath::read_beneath;
pub use confine::resolve_in_folder;
pub use random::SplitMix64;
pub use read::{open_regular, read_regular, read_regular_checked, read_regular_to_string};
pub use write::{
    check_destination, check_destination_as, check_extension, check_output, create_derived_dir,
    remove_pending_temporaries, write_atomic, write_atomic_as, Naming, OutputBatch,
};

/// What kind of file system object a path names, for errors about the wrong kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// A directory.
    Directory,
    /// A character device (`/dev/null`, `/dev/zero`, a terminal).
    CharDevice,
    /// A block device (a disk).
    BlockDevice,
    /// A named pipe.
    Fifo,
    /// A Unix domain socket.
    Socket,
    /// Anything else that is not a regular file.
    Other,
}

impl FileKind {
    /// The kind of a non-regular file from its metadata.
    pub fn of(meta: &std::fs::Metadata) -> FileKind {
        let t = meta.file_type();
        if t.is_dir() {
            return FileKind::Directory;
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            if t.is_char_device() {
                return FileKind::CharDevice;
            }
            if t.is_block_device() {
                return FileKind::BlockDevice;
            }
            if t.is_fifo() {
                return FileKind::Fifo;
            }
            if t.is_socket() {
                return FileKind::Socket;
            }
        }
        FileKind::Other
    }
}

impl fmt::Display for FileKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileKind::Directory => "a directory",
            FileKind::CharDevice => "a character device",
            FileKind::BlockDevice => "a block device",
            FileKind::Fifo => "a FIFO (named pipe)",
            FileKind::Socket => "a socket",
            FileKind::Other => "not a regular file",
        })
    }
}

/// Everything that can go wrong reading or writing a file. The `Display` of each variant names
/// the path and the reason once; the operating system's error, where there is one, is the
/// [`source`](std::error::Error::source) (print the chain, e.g. anyhow's `{:#}`, to see it).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IoError {
    /// The operating system refused an operation on `path`.
    #[error("cannot {action} {}", path.display())]
    Os {
        /// What was being done: "read", "open", "create a temporary file in", …
        action: &'static str,
        /// The path it was done on.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The folder an output goes into does not exist (outputs never create folders the user
    /// named).
    #[error("cannot write {}: the folder {} does not exist", path.display(), folder.display())]
    MissingFolder {
        /// The output as named.
        path: PathBuf,
        /// Its folder.
        folder: PathBuf,
    },
    /// The path exists but is not a regular file.
    #[error("{} is {kind}; only regular files can be {action}", path.display())]
    NotRegularFile {
        /// The path as given.
        path: PathBuf,
        /// What it is.
        kind: FileKind,
        /// "read" or "written".
        action: &'static str,
    },
    /// The file is larger than the reader allows.
    #[error("{} holds {size} bytes, more than the limit of {limit} bytes", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size (at least; a growing file is cut off after `limit + 1` bytes).
        size: u64,
        /// The most bytes the caller accepts.
        limit: u64,
    },
    /// The memory to read the file into could not be allocated (a file larger than the
    /// process may map, e.g. under an address-space limit): refused, never an abort.
    #[error("cannot allocate {bytes} bytes to read {}", path.display())]
    OutOfMemory {
        /// The file.
        path: PathBuf,
        /// The bytes asked for.
        bytes: u64,
    },
    /// An output path that is a symbolic link whose target does not exist.
    #[error("{} is a symbolic link to a file that does not exist", path.display())]
    DanglingLink {
        /// The link.
        path: PathBuf,
    },
    /// A path that cannot name a file (empty, or ending in a separator, `.` or `..`).
    #[error("{} is not a file path: {reason}", path.display())]
    NotAFilePath {
        /// The path as given.
        path: PathBuf,
        /// Why not.
        reason: &'static str,
    },
    /// A relative reference (e.g. a glTF buffer URI) that would leave its folder.
    #[error("{reference:?} is outside the folder {}: {reason}", folder.display())]
    OutsideFolder {
        /// The reference as decoded (shortened to 120 characters).
        reference: String,
        /// The folder it must stay in.
        folder: PathBuf,
        /// Why it leaves: absolute, `..`, or a symbolic link.
        reason: &'static str,
    },
    /// A symbolic link where a file inside a folder is read ([`read_beneath`]) or a log
    /// appended to ([`AppendLog`]): links there are refused, never followed.
    #[error("{} is a symbolic link; links inside this folder are not followed", path.display())]
    SymbolicLink {
        /// The link.
        path: PathBuf,
    },
    /// A file with other names (hard links) that would be modified in place: changing it
    /// would change the file at its other names too.
    #[error("{} has {links} hard links; a file modified in place must have one name", path.display())]
    HardLinked {
        /// The file.
        path: PathBuf,
        /// Its link count.
        links: u64,
    },
    /// An output path whose extension is not the one its format needs
    /// ([`check_extension`]).
    #[error(
        "{}: {what} must end in {} (the format follows the extension)",
        path.display(),
        dotted(expected)
    )]
    WrongExtension {
        /// The path as given.
        path: PathBuf,
        /// What the path is for (a command-line option, a parameter name).
        what: String,
        /// The extensions accepted, without the dot.
        expected: &'static [&'static str],
    },
}

impl IoError {
    /// The path the error is about (for [`IoError::OutsideFolder`], the folder).
    pub fn path(&self) -> &std::path::Path {
        match self {
            IoError::Os { path, .. }
            | IoError::NotRegularFile { path, .. }
            | IoError::TooLarge { path, .. }
            | IoError::OutOfMemory { path, .. }
            | IoError::DanglingLink { path }
            | IoError::SymbolicLink { path }
            | IoError::HardLinked { path, .. }
            | IoError::NotAFilePath { path, .. }
            | IoError::WrongExtension { path, .. }
            | IoError::MissingFolder { path, .. } => path,
            IoError::OutsideFolder { folder, .. } => folder,
        }
    }

    /// The operating system's error kind, when the error comes from one.
    pub fn os_kind(&self) -> Option<std::io::ErrorKind> {
        match self {
            IoError::Os { source, .. } => Some(source.kind()),
            IoError::MissingFolder { .. } => Some(std::io::ErrorKind::NotFound),
            _ => None,
        }
    }
}

/// `["png", "exr"]` as `.png or .exr`.
fn dotted(extensions: &[&str]) -> String {
    let dotted: Vec<String> = extensions.iter().map(|e| format!(".{e}")).collect();
    dotted.join(" or ")
}

/// The result type of this crate.
pub type Result<T> = std::result::Result<T, IoError>;

pub(crate) fn os(
    action: &'static str,
    path: &std::path::Path,
) -> impl FnOnce(std::io::Error) -> IoError {
    let path = path.to_path_buf();
    move |source| IoError::Os {
        action,
        path,
        source,
    }
}
