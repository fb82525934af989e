//! `remove_pending_temporaries` in a process of its own (it removes every pending temporary
//! of the process and refuses new ones, which would disturb tests running beside it).

use std::io::ErrorKind;

use sdfmo_io::{remove_pending_temporaries, write_atomic, IoError, OutputBatch};

#[test]
fn an_interrupt_handler_can_remove_pending_temporaries() {
    let dir = tempfile::tempdir().unwrap();
    let count = || std::fs::read_dir(dir.path()).unwrap().count();
    // A committed write leaves nothing pending.
    let done = dir.path().join("done.png");
    write_atomic(&done, b"x").unwrap();
    assert_eq!(std::fs::read(&done).unwrap(), b"x");

    let p = dir.path().join("late.png");
    let mut batch = OutputBatch::new();
    batch.stage(&p, b"bytes").unwrap();
    batch.stage(&dir.path().join("late.exr"), b"more").unwrap();
    assert_eq!(count(), 3, "done.png and the two staged temporaries");
    assert_eq!(remove_pending_temporaries(), 2);
    assert_eq!(count(), 1);
    assert_eq!(remove_pending_temporaries(), 0);
    assert!(batch.commit().is_err(), "its temporaries are gone");
    assert!(!p.exists());

    // After it no temporary can be created: a write on another thread between the handler
    // and the process's exit would otherwise leave one behind.
    let err = write_atomic(&p, b"x").unwrap_err();
    assert!(
        matches!(&err, IoError::Os { source, .. } if source.kind() == ErrorKind::Interrupted),
        "{err:?}"
    );
    assert_eq!(count(), 1);
    assert_eq!(remove_pending_temporaries(), 0);
}
