//! What the `.smo` targets share: trying an input as given and *resealed* (its last four bytes
//! replaced by the CRC-32 of the rest). Random bytes almost never carry a valid CRC-32; the
//! resealed copy lets the fuzzer reach the structural checks behind the checksum, where a
//! hostile file would attack. The level targets (2.0, 4.0) also put a fuzzed level table behind
//! a valid header ([`forced_levels`]) and check the same properties of what they read
//! ([`check_levels`]).
// Each target uses some of these.
#![allow(dead_code)]

use sdfmo_format::{
    crc32, lod_header_size, LodOctree, LodPrefix, Result, LOD_HEADER_FIXED, LOD_LEVEL_ENTRY, MAGIC,
};

/// Runs `check` on `data`, then (inputs of at least 4 bytes) on `data` resealed.
pub fn with_resealed(data: &[u8], mut check: impl FnMut(&[u8])) {
    check(data);
    if data.len() >= 4 {
        let mut sealed = data.to_vec();
        let n = sealed.len();
        let crc = crc32(&sealed[..n - 4]);
        sealed[n - 4..].copy_from_slice(&crc.to_le_bytes());
        check(&sealed);
    }
}

/// `data` behind the magic and version `major`.0 (2: levels of detail, 4: levels of bricks),
/// with the header's CRC-32 and each level's CRC-32 resealed where the data's own level table
/// puts them, so that random bytes reach the level table's checks and each level's own.
pub fn forced_levels(data: &[u8], major: u8) -> Vec<u8> {
    let mut b = MAGIC.to_vec();
    b.extend_from_slice(&[major, 0]);
    b.extend_from_slice(data);
    if b.len() < LOD_HEADER_FIXED {
        return b;
    }
    let count = b[22] as usize;
    let hs = lod_header_size(count);
    if b.len() < hs {
        return b;
    }
    for i in 0..count {
        let at = LOD_HEADER_FIXED + i * LOD_LEVEL_ENTRY;
        let off = u64::from_le_bytes(b[at..at + 8].try_into().unwrap()) as usize;
        let size = u64::from_le_bytes(b[at + 8..at + 16].try_into().unwrap()) as usize;
        if let Some(end) = off.checked_add(size) {
            if off >= hs && size >= 4 && end <= b.len() {
                let crc = crc32(&b[off..end - 4]);
                b[end - 4..end].copy_from_slice(&crc.to_le_bytes());
            }
        }
    }
    let crc = crc32(&b[..hs - 8]);
    b[hs - 8..hs - 4].copy_from_slice(&crc.to_le_bytes());
    b
}

/// The properties of a file with levels, whatever its format: `whole` reads a whole file,
/// `prefix` a prefix of one and `rewrite` writes levels back in the same format (2.0:
/// `LodOctree::from_bytes`, `from_prefix`, `to_bytes`; 4.0: `decode_levels`,
/// `decode_levels_prefix`, `encode_levels`). The whole-file reader and the prefix reader agree;
/// the levels are consecutive, coarsest first, as the header declares; writing the levels back
/// and reading them again gives the same levels; every level-boundary prefix reads exactly the
/// levels before the boundary; a prefix cut inside a level reads the levels before it.
pub fn check_levels(
    bytes: &[u8],
    whole: impl Fn(&[u8]) -> Result<LodOctree>,
    prefix: impl Fn(&[u8]) -> Result<LodPrefix>,
    rewrite: impl Fn(&LodOctree) -> Vec<u8>,
) {
    let all = whole(bytes);
    let part = prefix(bytes);
    if let Ok(w) = &all {
        let p = part.as_ref().expect("a whole file is also a prefix");
        assert!(p.is_complete());
        assert_eq!(&p.octree, w);
    }
    let Ok(p) = part else { return };
    let o = &p.octree;
    assert!(!o.levels().is_empty() && o.levels().len() <= p.declared.len());
    for (i, l) in o.levels().iter().enumerate() {
        assert_eq!(usize::from(l.depth()), usize::from(o.coarsest()) + i);
        assert_eq!(p.declared[i].level, l.depth());
    }
    let again = whole(&rewrite(o)).expect("re-written levels must read");
    assert_eq!(&again, o);
    for (i, e) in p.declared.iter().enumerate().take(o.levels().len()) {
        let end = e.end() as usize;
        let q = prefix(&bytes[..end]).expect("a level boundary reads");
        assert_eq!(q.octree.levels(), &o.levels()[..=i]);
        if e.size > 1 && i > 0 {
            let q = prefix(&bytes[..end - 1]).expect("a cut reads the levels before");
            assert_eq!(q.octree.levels(), &o.levels()[..i]);
        }
    }
}
