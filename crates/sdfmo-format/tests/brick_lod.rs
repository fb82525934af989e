//! Format 4.0 (levels of bricks): every level decodes to the 1.x octree of the 2.0 file, every
//! level-boundary prefix holds exactly its levels, and hostile bytes are typed errors.

mod common;

use common::{clipped_shell_leaves, meta, shape_leaves, shell_leaves};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sdfmo_format::{
    crc32, decode_levels, decode_levels_prefix, encode_levels, is_brick_levels, FormatError,
    LeafInput, LodOctree, PackedOctree, SmoFile, ValueBits, CHECKSUM_SIZE, LOD_HEADER_FIXED,
    LOD_HEADER_TRAILER, LOD_LEVEL_ENTRY,
};

type Shape = fn(u8) -> Vec<LeafInput>;

fn lod(bits: ValueBits, coarsest: u8, depth: u8, shape: Shape) -> LodOctree {
    let levels = (coarsest..=depth)
        .map(|d| PackedOctree::from_leaves(meta(d, bits), shape(d)).unwrap())
        .collect();
    LodOctree::from_levels(levels).unwrap()
}

fn sphere(depth: u8) -> Vec<LeafInput> {
    shape_leaves(depth, false)
}

/// Sphere shells (shared leaves), shells with a plate (surface voxels, two-voxel leaves) and
/// with clip voxels, at 8 and 16 bits.
fn cases() -> Vec<LodOctree> {
    let mut out = Vec::new();
    for bits in [ValueBits::Eight, ValueBits::Sixteen] {
        for shape in [sphere as Shape, shell_leaves, clipped_shell_leaves] {
            out.push(lod(bits, 2, 6, shape));
            out.push(lod(bits, 4, 5, shape));
        }
    }
    out
}

#[test]
fn every_level_decodes_to_its_octree() {
    for l in cases() {
        let bytes = encode_levels(&l).unwrap();
        assert!(is_brick_levels(&bytes));
        assert_eq!(decode_levels(&bytes).unwrap(), l);
        // Deterministic, and SmoFile reads it as the levels.
        assert_eq!(encode_levels(&l).unwrap(), bytes);
        assert_eq!(SmoFile::from_bytes(&bytes).unwrap(), SmoFile::Levels(l));
    }
}

#[test]
fn finer_levels_cost_less_than_their_own_bricks() {
    // The sphere at depth 6 from depth 5: the coded level is smaller than its 3.0 file.
    let l = lod(ValueBits::Eight, 5, 6, sphere);
    let bytes = encode_levels(&l).unwrap();
    let p = decode_levels_prefix(&bytes).unwrap();
    let v3 = sdfmo_format::BrickOctree::encode(l.finest()).unwrap();
    let fine = p.declared[1].size;
    assert!(
        fine * 10 < v3.as_bytes().len() as u64 * 9,
        "level 6: {fine} bytes, its 3.0 file {}",
        v3.as_bytes().len()
    );
}

#[test]
fn every_level_boundary_prefix_holds_its_levels() {
    let l = lod(ValueBits::Eight, 2, 6, shell_leaves);
    let bytes = encode_levels(&l).unwrap();
    let whole = decode_levels_prefix(&bytes).unwrap();
    assert!(whole.is_complete());
    for (i, e) in whole.declared.iter().enumerate() {
        let p = decode_levels_prefix(&bytes[..e.end() as usize]).unwrap();
        assert_eq!(
            p.octree.levels(),
            &l.levels()[..=i],
            "prefix to level {}",
            e.level
        );
        // One byte short of the level's end: the levels before it.
        if i > 0 {
            let p = decode_levels_prefix(&bytes[..e.end() as usize - 1]).unwrap();
            assert_eq!(p.octree.levels(), &l.levels()[..i]);
            // SmoFile refuses a cut inside a level.
            assert!(matches!(
                SmoFile::from_prefix(&bytes[..e.end() as usize - 1]),
                Err(FormatError::CutInsideLevel { .. })
            ));
        }
        let s = SmoFile::from_prefix(&bytes[..e.end() as usize]).unwrap();
        assert_eq!(s.held(), (2, e.level));
        assert_eq!(s.declared, (2, 6));
    }
    assert!(matches!(
        decode_levels(&bytes[..bytes.len() - 1]),
        Err(FormatError::Truncated { .. })
    ));
    assert!(matches!(
        decode_levels_prefix(&bytes[..whole.declared[0].end() as usize - 1]),
        Err(FormatError::Truncated { .. })
    ));
}

#[test]
fn levels_below_depth_2_are_refused() {
    let l = lod(ValueBits::Eight, 1, 3, sphere);
    assert!(matches!(
        encode_levels(&l),
        Err(FormatError::Unrepresentable { major: 4, .. })
    ));
}

/// Recomputes the header CRC and every level block's CRC, so that a change reaches the
/// checks behind them.
fn reseal(bytes: &mut [u8], entries: &[(usize, usize)]) {
    let hs = LOD_HEADER_FIXED + LOD_LEVEL_ENTRY * entries.len() + LOD_HEADER_TRAILER;
    let crc_at = hs - LOD_HEADER_TRAILER;
    let crc = crc32(&bytes[..crc_at]);
    bytes[crc_at..crc_at + 4].copy_from_slice(&crc.to_le_bytes());
    for &(from, to) in entries {
        if to <= bytes.len() && to - from >= CHECKSUM_SIZE {
            let c = crc32(&bytes[from..to - CHECKSUM_SIZE]);
            bytes[to - CHECKSUM_SIZE..to].copy_from_slice(&c.to_le_bytes());
        }
    }
}

#[test]
fn hostile_bytes_are_typed_errors() {
    let mut rng = ChaCha8Rng::seed_from_u64(34);
    for l in cases() {
        let bytes = encode_levels(&l).unwrap();
        let entries: Vec<(usize, usize)> = decode_levels_prefix(&bytes)
            .unwrap()
            .declared
            .iter()
            .map(|e| (e.offset as usize, e.end() as usize))
            .collect();
        for _ in 0..100 {
            let mut b = bytes.clone();
            for _ in 0..rng.random_range(1..4) {
                let i = rng.random_range(0..b.len());
                b[i] ^= 1 << rng.random_range(0..8);
            }
            // Unsealed: a CRC-32 refuses it (or the header check); resealed: the field checks.
            assert!(decode_levels(&b).is_err());
            reseal(&mut b, &entries);
            if let Ok(d) = decode_levels(&b) {
                // A change that decodes is a valid file of its own, re-encoded alike.
                assert_eq!(decode_levels(&encode_levels(&d).unwrap()).unwrap(), d);
            }
        }
        for n in [0, 9, 63, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode_levels(&bytes[..n]).is_err());
        }
    }
}

#[test]
fn a_compressed_file_decodes_to_its_bytes() {
    let l = lod(ValueBits::Eight, 2, 6, shell_leaves);
    let bytes = encode_levels(&l).unwrap();
    let z = sdfmo_format::compressed::compress(&bytes).unwrap();
    assert!(z.len() < bytes.len());
    assert_eq!(
        sdfmo_format::compressed::decompress(&z, bytes.len() as u64).unwrap(),
        bytes
    );
    assert_eq!(SmoFile::from_bytes(&z).unwrap(), SmoFile::Levels(l));
    // A damaged 4.0 file is refused before it is compressed.
    let mut bad = bytes.clone();
    let last = bad.len() - 1;
    bad[last] ^= 1;
    assert!(sdfmo_format::compressed::compress(&bad).is_err());
}
