//! The write and read rules on real files, FIFOs, devices and links.

use std::path::Path;

use sdfmo_io::{check_destination, read_regular, write_atomic, FileKind, IoError, OutputBatch};

/// A fresh temporary folder with the file `name` holding `bytes` in it.
fn dir_with_file(name: &str, bytes: &[u8]) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    (dir, path)
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let ok = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "mkfifo {}", path.display());
}

#[test]
fn atomic_write_replaces_and_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.txt");
    write_atomic(&p, b"one").unwrap();
    write_atomic(&p, b"two").unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), b"two");
    assert_eq!(names(dir.path()), ["x.txt"]);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Not the 0600 of a temporary: group/other read follows the umask as for File::create.
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        let plain = dir.path().join("plain");
        std::fs::write(&plain, b"").unwrap();
        let expect = std::fs::metadata(&plain).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, expect);
    }
}

#[test]
fn paths_that_name_no_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for p in ["", "adir/", ".", ".."] {
        let e = check_destination(Path::new(p)).unwrap_err();
        assert!(matches!(e, IoError::NotAFilePath { .. }), "{p:?}: {e}");
    }
    let e = write_atomic(dir.path(), b"x").unwrap_err();
    assert!(
        matches!(
            e,
            IoError::NotRegularFile {
                kind: FileKind::Directory,
                ..
            }
        ),
        "{e}"
    );
    let e = write_atomic(dir.path().join("missing/x.txt"), b"x").unwrap_err();
    assert_eq!(e.os_kind(), Some(std::io::ErrorKind::NotFound), "{e}");
    assert!(e.to_string().contains("the folder"), "{e}");
    assert!(e.to_string().contains("does not exist"), "{e}");
    assert!(names(dir.path()).is_empty());
}

#[cfg(unix)]
#[test]
fn special_destinations_are_refused_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    mkfifo(&fifo);
    let e = write_atomic(&fifo, b"x").unwrap_err();
    assert!(
        matches!(
            e,
            IoError::NotRegularFile {
                kind: FileKind::Fifo,
                ..
            }
        ),
        "{e}"
    );
    let e = check_destination(Path::new("/dev/null")).unwrap_err();
    assert!(
        matches!(
            e,
            IoError::NotRegularFile {
                kind: FileKind::CharDevice,
                ..
            }
        ),
        "{e}"
    );
    // A link to a FIFO is refused too, and the FIFO stays a FIFO.
    std::os::unix::fs::symlink(&fifo, dir.path().join("to-pipe")).unwrap();
    assert!(write_atomic(dir.path().join("to-pipe"), b"x").is_err());
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    assert_eq!(names(dir.path()), ["pipe", "to-pipe"]);
}

#[cfg(unix)]
#[test]
fn links_are_followed_and_dangling_links_refused() {
    let (dir, real) = dir_with_file("real.png", b"old");
    let link = dir.path().join("link.png");
    std::os::unix::fs::symlink("real.png", &link).unwrap();
    write_atomic(&link, b"new").unwrap();
    assert_eq!(std::fs::read(&real).unwrap(), b"new");
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let dangling = dir.path().join("dangling.png");
    std::os::unix::fs::symlink("nowhere.png", &dangling).unwrap();
    let e = write_atomic(&dangling, b"x").unwrap_err();
    assert!(matches!(e, IoError::DanglingLink { .. }), "{e}");
    assert!(!dir.path().join("nowhere.png").exists());
    assert_eq!(names(dir.path()), ["dangling.png", "link.png", "real.png"]);
}

#[cfg(unix)]
#[test]
fn a_planted_link_at_a_temporary_name_is_never_followed() {
    // Temporary names are random and created with O_EXCL; plant links at the names the old
    // writers used (pid-based) and check that the victim is untouched.
    let (dir, victim) = dir_with_file("victim", b"precious");
    let pid = std::process::id();
    for name in [format!(".out.png.tmp-{pid}"), format!(".out.png.tmp{pid}")] {
        std::os::unix::fs::symlink(&victim, dir.path().join(name)).unwrap();
    }
    write_atomic(dir.path().join("out.png"), b"image").unwrap();
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    assert_eq!(std::fs::read(dir.path().join("out.png")).unwrap(), b"image");
}

#[test]
fn a_batch_writes_all_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.png");
    let b = dir.path().join("b.exr");
    std::fs::write(&a, b"old a").unwrap();
    let mut batch = OutputBatch::new();
    batch.stage(&a, b"new a").unwrap();
    // The second output is refused: the first stays as it was and no temporary is left.
    assert!(batch.stage(dir.path(), b"x").is_err());
    drop(batch);
    assert_eq!(std::fs::read(&a).unwrap(), b"old a");
    assert_eq!(names(dir.path()), ["a.png"]);
    let mut batch = OutputBatch::new();
    batch.stage(&a, b"new a").unwrap();
    batch.stage(&b, b"new b").unwrap();
    assert!(batch.stage(&a, b"again").is_err(), "the same file twice");
    assert_eq!(batch.len(), 2);
    batch.commit().unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), b"new a");
    assert_eq!(std::fs::read(&b).unwrap(), b"new b");
    assert_eq!(names(dir.path()), ["a.png", "b.exr"]);
}

#[test]
fn reads_are_bounded_and_regular_only() {
    let (dir, p) = dir_with_file("f.bin", &[7u8; 100]);
    assert_eq!(read_regular(&p, 100).unwrap().len(), 100);
    let e = read_regular(&p, 99).unwrap_err();
    assert!(
        matches!(
            e,
            IoError::TooLarge {
                size: 100,
                limit: 99,
                ..
            }
        ),
        "{e}"
    );
    let e = read_regular(dir.path(), 1 << 20).unwrap_err();
    assert!(
        matches!(
            e,
            IoError::NotRegularFile {
                kind: FileKind::Directory,
                ..
            }
        ),
        "{e}"
    );
    let e = read_regular(&dir.path().join("missing"), 10).unwrap_err();
    assert_eq!(e.os_kind(), Some(std::io::ErrorKind::NotFound));
}

#[cfg(unix)]
#[test]
fn endless_and_blocking_inputs_are_refused_at_once() {
    let t = std::time::Instant::now();
    let e = read_regular(Path::new("/dev/zero"), u64::MAX).unwrap_err();
    assert!(
        matches!(
            e,
            IoError::NotRegularFile {
                kind: FileKind::CharDevice,
                ..
            }
        ),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    mkfifo(&fifo);
    let e = read_regular(&fifo, u64::MAX).unwrap_err();
    assert!(
        matches!(
            e,
            IoError::NotRegularFile {
                kind: FileKind::Fifo,
                ..
            }
        ),
        "{e}"
    );
    assert!(t.elapsed().as_secs() < 2, "{:?}", t.elapsed());
}

#[test]
fn errors_say_each_thing_once() {
    let e = read_regular(Path::new("/nonexistent/x.stl"), 10).unwrap_err();
    let top = e.to_string();
    let cause = std::error::Error::source(&e).unwrap().to_string();
    assert_eq!(top, "cannot read /nonexistent/x.stl");
    assert!(
        !top.contains(&cause) && !cause.contains("x.stl"),
        "{top} / {cause}"
    );
}

#[test]
fn a_checked_read_shows_the_header_before_reading_the_body() {
    let (dir, p) = dir_with_file("f.bin", b"HEAD and the body");
    let mut seen = None;
    let bytes = sdfmo_io::read_regular_checked::<IoError>(&p, 100, 4, |head, len| {
        seen = Some((head.to_vec(), len));
        Ok(len)
    })
    .unwrap();
    assert_eq!(bytes, b"HEAD and the body");
    assert_eq!(seen, Some((b"HEAD".to_vec(), 17)));
    // A head longer than the file is the whole file.
    let bytes = sdfmo_io::read_regular_checked::<IoError>(&p, 100, 4096, |head, len| {
        assert_eq!((head.len(), len), (17, 17));
        Ok(len)
    })
    .unwrap();
    assert_eq!(bytes.len(), 17);
    // A format that ignores what follows its declared size reads only that much.
    let bytes = sdfmo_io::read_regular_checked::<IoError>(&p, 100, 4, |_, _| Ok(8)).unwrap();
    assert_eq!(bytes, b"HEAD and");
    // A refusal stops the read: a sparse 3 GiB file costs one small read.
    let big = dir.path().join("sparse.bin");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    let t = std::time::Instant::now();
    let e = sdfmo_io::read_regular_checked(&big, u64::MAX, 128, |head, len| {
        assert_eq!((head.len(), len), (128, 3 << 30));
        Err(IoError::TooLarge {
            path: big.clone(),
            size: len,
            limit: 1,
        })
    })
    .unwrap_err();
    assert!(
        matches!(e, IoError::TooLarge { size, .. } if size == 3 << 30),
        "{e}"
    );
    assert!(t.elapsed().as_secs_f64() < 1.0, "{:?}", t.elapsed());
}
