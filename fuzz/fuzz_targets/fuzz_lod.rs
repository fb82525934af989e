//! Fuzzes the reader of files with levels of detail (`.smo` 2.0, `LodOctree`): any bytes, and
//! any prefix of them, must give an error or valid levels, never a panic, an out-of-bounds read
//! or a huge allocation.
//!
//! Random bytes almost never start with a 2.0 header with a valid CRC-32, so each input is also
//! tried *forced*: the magic and version 2.0 put in front, the header's CRC-32 and the CRC-32 of
//! every level the (fuzzed) level table places inside the data resealed, so that the fuzzer
//! reaches the level table's checks and each level's 1.x validation.
//!
//! Properties checked on every accepted input: the whole-file reader and the prefix reader
//! agree; the levels are consecutive, coarsest first, as the header declares; writing the levels
//! back and reading them again gives the same levels; every level-boundary prefix loads exactly
//! the levels before the boundary; a prefix cut inside a level loads the levels before it.
//!
//! Seeds: small files from `sdfmo build --lod`, e.g. `sdfmo build -d 4 --lod --coarsest 1 -o
//! fuzz/corpus/fuzz_lod/demo.smo` (`*.smo` is git-ignored).
#![no_main]

mod smo_common;

use libfuzzer_sys::fuzz_target;
use sdfmo_format::LodOctree;
use smo_common::{check_levels, forced_levels};

fn check(bytes: &[u8]) {
    check_levels(bytes, LodOctree::from_bytes, LodOctree::from_prefix, |o| {
        o.to_bytes()
    });
}

fuzz_target!(|data: &[u8]| {
    check(data);
    check(&forced_levels(data, 2));
});
