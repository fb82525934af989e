//! Atomic writes: a fresh temporary file beside the destination, synced, then renamed over it.

use std::io::Write;
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

use tempfile::NamedTempFile;

use crate::{os, FileKind, IoError, Result};

/// Checks that `path` may be written, and returns the file that a write will replace: `path`
/// itself, or for a symbolic link the (canonical) file it points to.
///
/// Refused: a path without a file name (empty, ending in `/`, `.` or `..`); an existing
/// directory, device, FIFO or socket (also through a link); a dangling link. A path that does
/// not exist yet is fine (its folder is checked when the file is created).
///
/// Call it on every output before long work, so a bad `-o` fails at once.
///
/// # Errors
/// [`IoError::NotAFilePath`], [`IoError::NotRegularFile`], [`IoError::DanglingLink`], or
/// [`IoError::Os`] when the path cannot be examined.
pub fn check_destination(path: &Path) -> Result<PathBuf> {
    check_destination_as(path, Naming::Given)
}

/// Who named an output; the rule for a symbolic link found there depends on it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Naming {
    /// The user named this path: a symbolic link there is followed and the file it points to
    /// replaced, as a shell's `>` does.
    #[default]
    Given,
    /// The command made the name up (a file inside an output folder, a numbered sibling such as
    /// `out_2.png`): a symbolic link there is replaced by the new file, never followed, so a
    /// link planted beside the outputs cannot redirect a write to a file the user never named.
    Derived,
}

/// [`check_destination`] for an output named as `naming` says: for [`Naming::Derived`] a
/// symbolic link (dangling or not) is accepted and returned as itself, since the write replaces
/// the link rather than its target.
///
/// # Errors
/// As [`check_destination`] (for a derived name, never [`IoError::DanglingLink`]).
pub fn check_destination_as(path: &Path, naming: Naming) -> Result<PathBuf> {
    let not_file = |reason| IoError::NotAFilePath {
        path: path.to_path_buf(),
        reason,
    };
    let text = path.as_os_str().as_encoded_bytes();
    if text.is_empty() {
        return Err(not_file("it is empty"));
    }
    if text.ends_with(b"/") || (cfg!(windows) && text.ends_with(b"\\")) {
        return Err(not_file("it ends with a path separator"));
    }
    if matches!(
        path.components().next_back(),
        Some(Component::CurDir | Component::ParentDir | Component::RootDir)
    ) || path.file_name().is_none()
    {
        return Err(not_file("it names no file"));
    }
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(path.to_path_buf()),
        Err(e) => return Err(os("examine", path)(e)),
    };
    let special = |meta: &std::fs::Metadata| IoError::NotRegularFile {
        path: path.to_path_buf(),
        kind: FileKind::of(meta),
        action: "written",
    };
    if meta.file_type().is_symlink() && naming == Naming::Derived {
        return Ok(path.to_path_buf());
    }
    if meta.file_type().is_symlink() {
        return match std::fs::metadata(path) {
            Ok(target) if target.is_file() => path.canonicalize().map_err(os("resolve", path)),
            Ok(target) => Err(special(&target)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(IoError::DanglingLink {
                path: path.to_path_buf(),
            }),
            Err(e) => Err(os("examine", path)(e)),
        };
    }
    if meta.is_file() {
        Ok(path.to_path_buf())
    } else {
        Err(special(&meta))
    }
}

/// Checks that `path` ends in one of `extensions` (given without the dot, compared
/// case-insensitively), so that `out.jpg` does not silently get PNG bytes: the format follows
/// the extension. `what` names the output in the error (a command-line option, a parameter).
///
/// ```
/// use std::path::Path;
/// assert!(sdfmo_io::check_extension(Path::new("a/out.PNG"), "-o", &["png"]).is_ok());
/// let e = sdfmo_io::check_extension(Path::new("out.jpg"), "-o", &["png"]).unwrap_err();
/// assert_eq!(e.to_string(), "out.jpg: -o must end in .png (the format follows the extension)");
/// ```
///
/// # Errors
/// [`IoError::WrongExtension`].
pub fn check_extension(path: &Path, what: &str, extensions: &'static [&'static str]) -> Result<()> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if ext.as_deref().is_some_and(|e| extensions.contains(&e)) {
        return Ok(());
    }
    Err(IoError::WrongExtension {
        path: path.to_path_buf(),
        what: what.to_owned(),
        expected: extensions,
    })
}

/// Checks an output path before any work, as every front-end does: [`check_destination_as`]
/// (a file that may be replaced), then, when `extensions` is not empty, [`check_extension`]
/// (`what` names the output in that error).
///
/// # Errors
/// As [`check_destination_as`] and [`check_extension`].
pub fn check_output(
    path: &Path,
    what: &str,
    extensions: &'static [&'static str],
    naming: Naming,
) -> Result<()> {
    check_destination_as(path, naming)?;
    if extensions.is_empty() {
        return Ok(());
    }
    check_extension(path, what, extensions)
}

/// Writes `bytes` to `path` atomically: readers see the old file or the whole new one, never a
/// prefix, and a failure leaves the old file and no temporary behind. See the crate docs for
/// the rules on special files and symbolic links.
///
/// # Errors
/// As [`check_destination`], [`IoError::MissingFolder`], plus [`IoError::Os`] when the
/// temporary file cannot be created, written, synced or renamed (a full disk, a read-only
/// folder).
pub fn write_atomic(path: impl AsRef<Path>, bytes: impl AsRef<[u8]>) -> Result<()> {
    write_atomic_as(path, bytes, Naming::Given)
}

/// [`write_atomic`] for an output named as `naming` says (see [`Naming`]).
///
/// # Errors
/// As [`write_atomic`].
pub fn write_atomic_as(
    path: impl AsRef<Path>,
    bytes: impl AsRef<[u8]>,
    naming: Naming,
) -> Result<()> {
    let mut batch = OutputBatch::new();
    batch.stage_as(path.as_ref(), bytes.as_ref(), naming)?;
    batch.commit()
}

/// Creates the folder `base/relative` and the folders between, all of them derived names: a
/// symbolic link found at any of them is removed and a real folder made in its place (the
/// link's target is not touched), so a planted link cannot send the command's files elsewhere.
/// `base` itself, the folder the user named, is created if missing and followed if a link.
///
/// # Errors
/// [`IoError::Os`] when a folder cannot be created (a regular file in the way, permissions).
pub fn create_derived_dir(base: &Path, relative: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(base).map_err(os("create the folder", base))?;
    let mut dir = base.to_path_buf();
    for part in relative.components() {
        dir.push(part);
        match std::fs::symlink_metadata(&dir) {
            Ok(m) if m.is_dir() => continue,
            Ok(m) if m.file_type().is_symlink() => {
                std::fs::remove_file(&dir).map_err(os("replace the link", &dir))?
            }
            _ => {}
        }
        std::fs::create_dir(&dir).map_err(os("create the folder", &dir))?;
    }
    Ok(dir)
}

/// Several outputs written all or none: every file is written to its temporary and synced
/// before the first one is renamed into place, so an encoding error, a full disk or a refused
/// destination in any of them leaves all destinations untouched. (Only a failure of a rename
/// itself, after the others succeeded, can leave some renamed; renames within one folder do
/// not fail for lack of space.) Dropping a batch without committing removes its temporaries.
#[derive(Debug, Default)]
pub struct OutputBatch {
    staged: Vec<Staged>,
}

/// Temporaries created and not yet renamed or removed, for [`remove_pending_temporaries`].
static PENDING: Mutex<Pending> = Mutex::new(Pending {
    paths: Vec::new(),
    closed: false,
});

#[derive(Debug)]
struct Pending {
    paths: Vec<PathBuf>,
    /// Set by [`remove_pending_temporaries`]: no temporary may be created after it.
    closed: bool,
}

fn pending() -> std::sync::MutexGuard<'static, Pending> {
    // A panic while holding the lock leaves the list valid: keep using it.
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every temporary file of this process that is not yet renamed into place or removed,
/// returns how many it removed, and refuses every temporary after it: a later write or commit
/// fails with [`IoError::Os`] and leaves nothing behind. Meant for a SIGINT/SIGTERM handler
/// that then exits (the CLI's does): a write on another thread cannot slip a new temporary in
/// between this call and the exit. (SIGKILL cannot be caught: a process killed by it mid-write
/// can leave one `.NAME.XXXXXX.tmp` beside the destination.)
pub fn remove_pending_temporaries() -> usize {
    let mut list = pending();
    list.closed = true;
    list.paths
        .drain(..)
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

/// A temporary file registered in [`PENDING`] for as long as it exists under its name.
#[derive(Debug)]
struct Tracked(Option<NamedTempFile>);

impl Tracked {
    /// Creates the temporary with `create` and registers it under one lock, so an interrupt
    /// handler either sees it or runs before it exists and stops it from being created.
    fn create(create: impl FnOnce() -> std::io::Result<NamedTempFile>) -> std::io::Result<Tracked> {
        let mut list = pending();
        if list.closed {
            return Err(std::io::Error::new(
                std::io::ErrorKind::Interrupted,
                "the process is being interrupted",
            ));
        }
        let temp = create()?;
        list.paths.push(temp.path().to_path_buf());
        Ok(Tracked(Some(temp)))
    }

    fn file(&mut self) -> &mut NamedTempFile {
        self.0
            .as_mut()
            .expect("a tracked temporary until persisted")
    }

    fn forget(path: &Path) {
        let paths = &mut pending().paths;
        if let Some(i) = paths.iter().position(|p| p == path) {
            paths.swap_remove(i);
        }
    }

    /// Renames the temporary over `target`.
    fn persist(mut self, target: &Path) -> std::io::Result<()> {
        let temp = self.0.take().expect("persisted once");
        let path = temp.path().to_path_buf();
        let result = temp.persist(target).map(drop).map_err(|e| e.error);
        // On error `persist` handed the file back inside `e` and dropped it: removed.
        Tracked::forget(&path);
        result
    }
}

impl Drop for Tracked {
    fn drop(&mut self) {
        if let Some(temp) = self.0.take() {
            let path = temp.path().to_path_buf();
            drop(temp); // removes the file
            Tracked::forget(&path);
        }
    }
}

#[derive(Debug)]
struct Staged {
    temp: Tracked,
    /// The file replaced (the link's target for a symbolic link).
    target: PathBuf,
    /// The path as the caller named it, for errors.
    named: PathBuf,
}

impl OutputBatch {
    /// An empty batch.
    pub fn new() -> OutputBatch {
        OutputBatch::default()
    }

    /// Number of staged outputs.
    pub fn len(&self) -> usize {
        self.staged.len()
    }

    /// True when nothing is staged.
    pub fn is_empty(&self) -> bool {
        self.staged.is_empty()
    }

    /// Checks `path` ([`check_destination`]), writes `bytes` to a new temporary file beside
    /// the file it will replace and syncs it. Nothing at `path` changes until [`commit`].
    ///
    /// [`commit`]: OutputBatch::commit
    ///
    /// # Errors
    /// As [`write_atomic`]; two outputs of one batch naming the same file is an
    /// [`IoError::NotAFilePath`].
    pub fn stage(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        self.stage_as(path, bytes, Naming::Given)
    }

    /// [`stage`](OutputBatch::stage) for an output named as `naming` says (see [`Naming`]).
    ///
    /// # Errors
    /// As [`stage`](OutputBatch::stage).
    pub fn stage_as(&mut self, path: &Path, bytes: &[u8], naming: Naming) -> Result<()> {
        let target = check_destination_as(path, naming)?;
        if self.staged.iter().any(|s| s.target == target) {
            return Err(IoError::NotAFilePath {
                path: path.to_path_buf(),
                reason: "it is already an output of the same command",
            });
        }
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        // NamedTempFile defaults to 0600; a result file should get the usual 0666 & !umask.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o666));
        }
        if std::fs::metadata(&dir).is_err_and(|e| e.kind() == std::io::ErrorKind::NotFound) {
            return Err(IoError::MissingFolder {
                path: path.to_path_buf(),
                folder: dir,
            });
        }
        let mut temp = Tracked::create(|| builder.tempfile_in(&dir))
            .map_err(os("create a temporary file in", &dir))?;
        // On error `temp` is dropped here, which removes it.
        let file = temp.file();
        file.write_all(bytes)
            .and_then(|()| file.as_file().sync_all())
            .map_err(os("write", path))?;
        self.staged.push(Staged {
            temp,
            target,
            named: path.to_path_buf(),
        });
        Ok(())
    }

    /// Renames every staged temporary over its destination, in staging order, then syncs the
    /// folders (best effort: not every platform can sync a folder).
    ///
    /// # Errors
    /// [`IoError::Os`] for a rename that fails; the temporaries not yet renamed are removed.
    pub fn commit(self) -> Result<()> {
        let mut dirs: Vec<PathBuf> = Vec::new();
        for s in self.staged {
            let named = s.named;
            s.temp.persist(&s.target).map_err(os("replace", &named))?;
            if let Some(d) = s.target.parent() {
                if !dirs.iter().any(|x| x == d) {
                    dirs.push(d.to_path_buf());
                }
            }
        }
        for d in dirs {
            let d = if d.as_os_str().is_empty() {
                PathBuf::from(".")
            } else {
                d
            };
            if let Ok(f) = std::fs::File::open(&d) {
                let _ = f.sync_all();
            }
        }
        Ok(())
    }
}
