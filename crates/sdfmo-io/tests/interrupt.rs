//! `remove_pending_temporaries` in a process of its own (it removes every pending temporary
//! of the process, which would disturb tests running beside it).

use sdfmo_io::{remove_pending_temporaries, OutputBatch};

#[test]
fn an_interrupt_handler_can_remove_pending_temporaries() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("late.png");
    let mut batch = OutputBatch::new();
    batch.stage(&p, b"bytes").unwrap();
    batch.stage(&dir.path().join("late.exr"), b"more").unwrap();
    let count = || std::fs::read_dir(dir.path()).unwrap().count();
    assert_eq!(count(), 2, "the staged temporaries");
    assert_eq!(remove_pending_temporaries(), 2);
    assert_eq!(count(), 0);
    assert_eq!(remove_pending_temporaries(), 0);
    assert!(batch.commit().is_err(), "its temporaries are gone");
    assert!(!p.exists());
    // A committed write leaves nothing pending.
    sdfmo_io::write_atomic(&p, b"x").unwrap();
    assert_eq!(remove_pending_temporaries(), 0);
    assert_eq!(std::fs::read(&p).unwrap(), b"x");
}
