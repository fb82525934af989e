//! A `.smo` file whose header declares another size than the file has is refused after reading
//! its header, whatever the file's length: every loader checks the header against the file's
//! length before reading the body (issue 32).
//!
//! This file holds one test so that the process's peak resident memory is this test's alone.

mod common;

use std::time::{Duration, Instant};

use common::{meta, shell_leaves};
use sdfmo_format::{read_smo, FormatError, LodOctree, PackedOctree, SmoFile, SmoRead, ValueBits};
use sdfmo_testdata::sparse::{peak_rss, reset_peak_rss, sparse_file, SPARSE_LEN};

/// Runs `load` and checks it failed within a second and 100 MB of peak memory.
fn refused_quickly(what: &str, load: impl FnOnce() -> Result<(), FormatError>) -> FormatError {
    reset_peak_rss();
    let before = peak_rss();
    let t = Instant::now();
    let e = load().expect_err(what);
    let took = t.elapsed();
    assert!(took < Duration::from_secs(1), "{what}: {took:?}");
    if let (Some(before), Some(after)) = (before, peak_rss()) {
        // Before the fix each load read the whole 3 GiB (12 s, 3 GB in the audit).
        assert!(
            after < 100 << 20,
            "{what}: peak RSS {after} bytes (was {before})"
        );
    }
    e
}

#[test]
fn a_3_gib_sparse_file_whose_header_says_kilobytes_is_refused_before_reading_it() {
    let dir = tempfile::tempdir().unwrap();
    let one = PackedOctree::from_leaves(meta(6, ValueBits::Eight), shell_leaves(6)).unwrap();
    let declared = one.byte_size() as u64;
    assert!(declared > 10_000, "{declared}");
    let p1 = sparse_file(dir.path(), "one.smo", one.as_bytes());
    let lod = LodOctree::from_levels(
        (3..=5)
            .map(|d| PackedOctree::from_leaves(meta(d, ValueBits::Eight), shell_leaves(d)).unwrap())
            .collect(),
    )
    .unwrap();
    let p2 = sparse_file(dir.path(), "levels.smo", &lod.to_bytes());

    let trailing = |e: &FormatError| {
        matches!(
            e,
            FormatError::Corrupt {
                field: "file_size",
                ..
            }
        ) && e.to_string().contains(&SPARSE_LEN.to_string())
    };
    for (what, e) in [
        (
            "PackedOctree::load",
            refused_quickly("1.x", || PackedOctree::load(&p1).map(drop)),
        ),
        (
            "SmoFile::load 1.x",
            refused_quickly("1.x", || SmoFile::load(&p1).map(drop)),
        ),
        (
            "SmoFile::load 2.0",
            refused_quickly("2.0", || SmoFile::load(&p2).map(drop)),
        ),
        (
            "LodOctree::load",
            refused_quickly("2.0", || LodOctree::load(&p2).map(drop)),
        ),
        (
            "read_smo prefix 2.0",
            refused_quickly("prefix", || {
                read_smo(&p2, u64::MAX, SmoRead::Prefix).map(drop)
            }),
        ),
    ] {
        assert!(trailing(&e), "{what}: {e}");
    }

    // The same files at their declared size load as before.
    for p in [&p1, &p2] {
        std::fs::OpenOptions::new()
            .write(true)
            .open(p)
            .unwrap()
            .set_len(0)
            .unwrap();
    }
    std::fs::write(&p1, one.as_bytes()).unwrap();
    std::fs::write(&p2, lod.to_bytes()).unwrap();
    assert_eq!(PackedOctree::load(&p1).unwrap(), one);
    assert_eq!(LodOctree::load(&p2).unwrap(), lod);
    // A file cut short: `Truncated` from the header, as from the bytes; a prefix of a 2.0 file
    // is read when asked for.
    let cut = lod.to_bytes().len() - 100;
    std::fs::write(&p2, &lod.to_bytes()[..cut]).unwrap();
    assert!(matches!(
        LodOctree::load(&p2),
        Err(FormatError::Truncated { .. })
    ));
    assert_eq!(read_smo(&p2, u64::MAX, SmoRead::Prefix).unwrap().len(), cut);
    std::fs::write(&p1, &one.as_bytes()[..1000]).unwrap();
    assert!(matches!(
        PackedOctree::load(&p1),
        Err(FormatError::Truncated { len: 1000, .. })
    ));
}
