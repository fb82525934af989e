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
use sdfmo_format::{decode_levels, decode_levels_prefix, encode_levels, LodOctree, BRICK_LEVELS};
use smo_common::{check_levels, forced_levels};

fn check(bytes: &[u8]) {
    check_levels(bytes, decode_levels, decode_levels_prefix, |o| {
        encode_levels(o).expect("decoded levels encode")
    });
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
