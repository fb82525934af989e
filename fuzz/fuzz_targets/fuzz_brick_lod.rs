//! Fuzzes format 4.0 (levels of bricks, `sdfmo_format::decode_levels`): any bytes, and any
//! prefix of them, must give an error or valid levels, never a panic, an out-of-bounds read or
//! a huge allocation; and any 2.0 file whose coarsest level is at least 2 must encode to 4.0
//! losslessly.
//!
//! Random bytes almost never start with a valid 4.0 header, so each input is also tried
//! *forced*: the magic and version 4.0 put in front, the header's CRC-32 and the CRC-32 of
//! every level block the (fuzzed) level table places inside the data resealed, so that the
//! fuzzer reaches the level table's checks and each block's field checks.
//!
//! Properties checked on every accepted input: the whole-file reader and the prefix reader
//! agree; the levels are consecutive, coarsest first, as the header declares; encoding the
//! levels again and decoding gives the same levels; every level-boundary prefix decodes
//! exactly the levels before the boundary; a prefix cut inside a level decodes the levels
//! before it. On every valid 2.0 input: its 4.0 encoding decodes to the same levels.
//!
//! Seeds: small files from `sdfmo build --lod --format 3`, e.g. `sdfmo build -d 5 --lod
//! --coarsest 2 --format 3 -o fuzz/corpus/fuzz_brick_lod/demo.smo` (`*.smo` is git-ignored).
#![no_main]

mod smo_common;

use libfuzzer_sys::fuzz_target;
use smo_common::forced_levels;
use sdfmo_format::{decode_levels, decode_levels_prefix, encode_levels, LodOctree, BRICK_LEVELS};

fn check(bytes: &[u8]) {
    let whole = decode_levels(bytes);
    let prefix = decode_levels_prefix(bytes);
    if let Ok(w) = &whole {
        let p = prefix.as_ref().expect("a whole file is also a prefix");
        assert!(p.is_complete());
        assert_eq!(&p.octree, w);
    }
    let Ok(p) = prefix else { return };
    let o = &p.octree;
    assert!(!o.levels().is_empty() && o.levels().len() <= p.declared.len());
    for (i, l) in o.levels().iter().enumerate() {
        assert_eq!(usize::from(l.depth()), usize::from(o.coarsest()) + i);
        assert_eq!(p.declared[i].level, l.depth());
    }
    let again = decode_levels(&encode_levels(o).expect("decoded levels encode"))
        .expect("re-encoded levels must decode");
    assert_eq!(&again, o);
    for (i, e) in p.declared.iter().enumerate().take(o.levels().len()) {
        let end = e.end() as usize;
        let q = decode_levels_prefix(&bytes[..end]).expect("a level boundary decodes");
        assert_eq!(q.octree.levels(), &o.levels()[..=i]);
        if i > 0 {
            let q = decode_levels_prefix(&bytes[..end - 1]).expect("a cut decodes the levels before");
            assert_eq!(q.octree.levels(), &o.levels()[..i]);
        }
    }
}

/// A valid 2.0 file with a coarsest level ≥ 2 encodes to 4.0 and decodes to the same levels.
fn check_encode(bytes: &[u8]) {
    let Ok(lod) = LodOctree::from_bytes(bytes) else {
        return;
    };
    if lod.coarsest() < BRICK_LEVELS {
        assert!(encode_levels(&lod).is_err());
        return;
    }
    let v4 = encode_levels(&lod).expect("a valid 2.0 file encodes");
    assert_eq!(decode_levels(&v4).expect("its 4.0 file decodes"), lod);
}

fuzz_target!(|data: &[u8]| {
    check(data);
    check(&forced_levels(data, 4));
    // The 4.0 seeds' bodies behind a 2.0 header rarely make a valid 2.0 file; 2.0 seeds do.
    check_encode(data);
    check_encode(&forced_levels(data, 2));
});
