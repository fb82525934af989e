//! Relative resources (a glTF buffer file) confined to the folder of the file that names them.

use std::path::{Component, Path, PathBuf};

use crate::{os, IoError, Result};

/// Resolves `reference`, a relative path already decoded from its URI form, inside `folder`,
/// and returns the canonical path of the file it names.
///
/// Refused: an empty reference; an absolute path or one with a drive or root; any `..`
/// component; a backslash (a Windows separator that would mean `..\` elsewhere); and any
/// reference that, once symbolic links are resolved, lies outside the canonical `folder`.
/// Symbolic links that stay inside the folder are allowed. The file must exist (it is
/// canonicalised); whether it is a regular file is for the reader to check
/// ([`read_regular`](crate::read_regular)).
///
/// # Errors
/// [`IoError::OutsideFolder`] naming the rule that was broken, [`IoError::Os`] when the folder
/// or the file cannot be resolved.
pub fn resolve_in_folder(folder: &Path, reference: &str) -> Result<PathBuf> {
    let outside = |reason| IoError::OutsideFolder {
        reference: reference.chars().take(120).collect(),
        folder: folder.to_path_buf(),
        reason,
    };
    if reference.is_empty() {
        return Err(outside("the reference is empty"));
    }
    if reference.contains('\\') {
        return Err(outside("backslashes are not path separators in a URI"));
    }
    if reference.contains('\0') {
        return Err(outside("the reference holds a NUL byte"));
    }
    let rel = Path::new(reference);
    for c in rel.components() {
        match c {
            Component::Normal(_) | Component::CurDir => {}
            Component::ParentDir => return Err(outside("it climbs out with `..`")),
            Component::RootDir | Component::Prefix(_) => {
                return Err(outside("it is an absolute path"))
            }
        }
    }
    let folder_abs = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let root = folder_abs
        .canonicalize()
        .map_err(os("resolve the folder", folder_abs))?;
    let joined = folder_abs.join(rel);
    let resolved = joined.canonicalize().map_err(os("open", &joined))?;
    if !resolved.starts_with(&root) {
        return Err(outside("a symbolic link leads out of the folder"));
    }
    Ok(resolved)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_stay_inside() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("sub")).unwrap();
        std::fs::write(d.join("sub/a.bin"), b"a").unwrap();
        std::fs::write(dir.path().join("b.bin"), b"b").unwrap();
        assert!(resolve_in_folder(d, "sub/a.bin")
            .unwrap()
            .ends_with("sub/a.bin"));
        assert!(resolve_in_folder(d, "./b.bin").is_ok());
        for bad in [
            "",
            "../b.bin",
            "sub/../b.bin",
            "/etc/passwd",
            "sub\\a.bin",
            "a\0b",
        ] {
            let e = resolve_in_folder(&d.join("sub"), bad).unwrap_err();
            assert!(matches!(e, IoError::OutsideFolder { .. }), "{bad:?}: {e}");
        }
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink("/etc/hostname", d.join("link.bin")).unwrap();
            std::os::unix::fs::symlink("sub/a.bin", d.join("inside.bin")).unwrap();
            let e = resolve_in_folder(d, "link.bin").unwrap_err();
            assert!(matches!(e, IoError::OutsideFolder { .. }), "{e}");
            assert!(resolve_in_folder(d, "inside.bin").is_ok());
        }
        let e = resolve_in_folder(d, "missing.bin").unwrap_err();
        assert_eq!(e.os_kind(), Some(std::io::ErrorKind::NotFound));
    }
}
