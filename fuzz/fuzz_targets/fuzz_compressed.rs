//! Fuzzes the compressed container (`sdfmo_format::compressed`): any bytes must decode to an
//! error or to exactly a valid `.smo`, never a panic, an out-of-bounds read, a huge allocation
//! or a hang; and every valid `.smo` must survive compress → decompress byte for byte.
//!
//! Random bytes almost never carry the container's trailing CRC-32, so each input is also tried
//! *resealed* (its last four bytes replaced by the CRC-32 of the rest): the fuzzer then reaches
//! the stream table, zstd and the neighbour walk that rebuilds the file (the decoded file's own
//! CRC-32, stored in the container, is checked only after the walk).
//!
//! Properties checked: when a container decodes to a valid `.smo`, loading the container
//! (`SmoFile::from_bytes`) gives the same file as loading the decoded bytes, and compressing them
//! again and decoding gives them back; an input that is itself a valid `.smo` (1.x, 2.0 or 3.0)
//! round-trips through the container. (`SmoFile::from_bytes` reads a 3.0 file as its 1.x
//! octree, so a container of a 3.0 file is compared through that.)
//!
//! Seeds: small compressed files from `sdfmo build --compress`, e.g. `sdfmo build -d 4 --compress
//! -o fuzz/corpus/fuzz_compressed/d4.smo` (`*.smo` is git-ignored), the same with `--format 3`
//! (plain and compressed 3.0 files), and the `fuzz_smo` seeds.
#![no_main]

mod smo_common;

use libfuzzer_sys::fuzz_target;
use sdfmo_format::compressed::{compress_with_level, decompress, is_compressed};
use sdfmo_format::SmoFile;
use smo_common::with_resealed;

/// A bound on what one input may decode to (the container also caps it at 1024× its size).
const MAX_DECODED: u64 = 64 << 20;

fn check_container(bytes: &[u8]) {
    let Ok(smo) = decompress(bytes, MAX_DECODED) else {
        return;
    };
    // The container checked the decoded file's CRC-32: it is what the encoder was given, which
    // was a valid `.smo` only if the encoder made it; a hand-made container may wrap anything,
    // and the readers must then refuse the decoded bytes with an error, not accept garbage.
    let Ok(file) = SmoFile::from_bytes(&smo) else {
        return;
    };
    let direct = SmoFile::from_bytes(bytes).expect("the container of a valid file loads");
    assert!(
        direct == file,
        "loading the container differs from loading its decoded bytes"
    );
    check_round_trip(&smo);
}

/// A valid `.smo` compresses and decodes to itself.
fn check_round_trip(smo: &[u8]) {
    let packed = compress_with_level(smo, 1).expect("a valid .smo compresses");
    let back = decompress(&packed, MAX_DECODED.max(smo.len() as u64)).expect("and decodes");
    assert!(back == smo, "compress -> decompress changed the file");
}

fuzz_target!(|data: &[u8]| {
    with_resealed(data, check_container);
    // (`SmoFile::from_bytes` also reads containers: only a plain `.smo` is compressed here.)
    if !is_compressed(data) && data.len() as u64 <= MAX_DECODED && SmoFile::from_bytes(data).is_ok()
    {
        check_round_trip(data);
    }
});
