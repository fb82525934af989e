//! The compressed container (`sdfmo_format::compressed`): every kind of file decodes to its own
//! bytes, loads through every reader, and hostile containers are refused without a panic.

mod common;

use common::{clipped_shell_leaves, meta, shell_leaves};
use rand::{Rng, SeedableRng};
use sdfmo_format::compressed::{
    compress, compress_with_level, decompress, is_compressed, COMPRESSED_HEADER_SIZE,
    COMPRESSED_VERSION_MINOR,
};
use sdfmo_format::{
    BrickOctree, FormatError, LeafInput, LodOctree, OctreeMeta, PackedOctree, SmoFile, ValueBits,
    Voxel, MAX_FILE_SIZE,
};

fn files() -> Vec<(&'static str, Vec<u8>)> {
    let mut out = Vec::new();
    for (name, bits) in [("8", ValueBits::Eight), ("16", ValueBits::Sixteen)] {
        let shell = PackedOctree::from_leaves(meta(5, bits), shell_leaves(5)).unwrap();
        assert!(shell.voxel_count() > shell.leaf_count() && shell.surface_voxel_count() > 0);
        out.push((
            if name == "8" { "shell 8" } else { "shell 16" },
            shell.to_bytes(),
        ));
        let clip = PackedOctree::from_leaves(meta(5, bits), clipped_shell_leaves(5)).unwrap();
        assert!(clip.has_clip_voxels());
        out.push((
            if name == "8" { "clip 8" } else { "clip 16" },
            clip.to_bytes(),
        ));
    }
    out.push((
        "empty",
        PackedOctree::from_leaves(meta(4, ValueBits::Eight), Vec::new())
            .unwrap()
            .to_bytes(),
    ));
    let root = LeafInput {
        coord: [0, 0, 0],
        voxels: vec![Voxel {
            corners: [-0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5],
            surface: false,
            clip: false,
        }],
    };
    out.push((
        "depth 0",
        PackedOctree::from_leaves(meta(0, ValueBits::Eight), vec![root])
            .unwrap()
            .to_bytes(),
    ));
    let levels: Vec<PackedOctree> = (2..=5)
        .map(|d| PackedOctree::from_leaves(meta(d, ValueBits::Eight), shell_leaves(d)).unwrap())
        .collect();
    out.push((
        "levels 2-5",
        LodOctree::from_levels(levels).unwrap().to_bytes(),
    ));
    out
}

#[test]
fn every_kind_of_file_decodes_to_its_own_bytes() {
    for (name, smo) in files() {
        let packed = compress(&smo).unwrap();
        assert!(is_compressed(&packed) && !is_compressed(&smo), "{name}");
        assert_eq!(decompress(&packed, MAX_FILE_SIZE).unwrap(), smo, "{name}");
        // The level only changes the size.
        assert_eq!(
            decompress(&compress_with_level(&smo, 1).unwrap(), MAX_FILE_SIZE).unwrap(),
            smo,
            "{name}"
        );
        if smo.len() > 4096 {
            assert!(
                packed.len() * 3 < smo.len(),
                "{name}: {} of {}",
                packed.len(),
                smo.len()
            );
        }
    }
}

#[test]
fn shared_corners_cost_almost_nothing() {
    // A volume-only sphere shell: the corners each voxel shares with the voxel before it along
    // an axis are predicted exactly, so the corner residuals are mostly zero.
    // Against zstd on the file as it is, at the same level, the container is far smaller.
    let leaves: Vec<LeafInput> = common::shape_leaves(7, false);
    let o = PackedOctree::from_leaves(meta(7, ValueBits::Eight), leaves).unwrap();
    let smo = o.to_bytes();
    let packed = compress(&smo).unwrap();
    let plain =
        zstd::bulk::compress(&smo, sdfmo_format::compressed::DEFAULT_COMPRESSION_LEVEL).unwrap();
    let per_voxel = |n: usize| n as f64 / o.voxel_count() as f64;
    eprintln!(
        "{} voxels: {:.3} B/voxel traced, {:.3} zstd alone, {:.3} container",
        o.voxel_count(),
        per_voxel(smo.len()),
        per_voxel(plain.len()),
        per_voxel(packed.len())
    );
    assert!(
        (packed.len() as f64) < 0.6 * plain.len() as f64,
        "{} vs {}",
        packed.len(),
        plain.len()
    );
}

#[test]
fn every_reader_loads_a_compressed_file() {
    let dir = tempfile::tempdir().unwrap();
    for (name, smo) in files() {
        let path = dir.path().join("x.smo");
        std::fs::write(&path, compress(&smo).unwrap()).unwrap();
        let whole = SmoFile::load(&path).unwrap();
        assert_eq!(whole, SmoFile::from_bytes(&smo).unwrap(), "{name}");
        if SmoFile::has_levels(&smo) {
            assert_eq!(
                LodOctree::load(&path).unwrap(),
                LodOctree::from_bytes(&smo).unwrap()
            );
        } else {
            assert_eq!(
                PackedOctree::load(&path).unwrap().as_bytes(),
                &smo[..],
                "{name}"
            );
        }
        // The size limit applies to the decoded bytes.
        let limit = smo.len() as u64 - 1;
        assert!(
            PackedOctree::load_with_limit(&path, limit).is_err(),
            "{name}"
        );
        assert!(SmoFile::load_with_limit(&path, limit).is_err(), "{name}");
    }
}

#[test]
fn bad_levels_and_non_files_are_refused() {
    let o = PackedOctree::from_leaves(meta(3, ValueBits::Eight), shell_leaves(3)).unwrap();
    let err = compress_with_level(&o.to_bytes(), 0).unwrap_err();
    assert!(err.to_string().contains("level"), "{err}");
    assert!(matches!(
        compress(b"not a file"),
        Err(FormatError::BadMagic { .. })
    ));
}

/// Rewrites the container's trailing CRC-32 over the rest, so that a change gets past it.
fn reseal(packed: &mut [u8]) {
    let n = packed.len();
    let crc = sdfmo_format::crc32(&packed[..n - 4]);
    packed[n - 4..].copy_from_slice(&crc.to_le_bytes());
}

/// Every proper prefix of a container is an error.
fn assert_every_prefix_refused(packed: &[u8]) {
    for n in 0..packed.len() {
        assert!(
            decompress(&packed[..n], MAX_FILE_SIZE).is_err(),
            "prefix {n}"
        );
    }
}

/// 3000 copies of `packed` with one to three random bytes changed (never the CRC), each
/// resealed (see [`reseal`]); `seed` makes them reproducible.
fn resealed_changes(packed: &[u8], seed: u64) -> impl Iterator<Item = Vec<u8>> + '_ {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..3000).map(move |_| {
        let mut bad = packed.to_vec();
        for _ in 0..rng.random_range(1..4) {
            let i = rng.random_range(0..bad.len() - 4);
            bad[i] = rng.random();
        }
        reseal(&mut bad);
        bad
    })
}

#[test]
fn hostile_containers_are_refused_without_panic() {
    let smo = PackedOctree::from_leaves(meta(4, ValueBits::Eight), shell_leaves(4))
        .unwrap()
        .to_bytes();
    let packed = compress(&smo).unwrap();
    // Every truncation.
    assert_every_prefix_refused(&packed);
    // Random byte changes, resealed so that they get past the container's CRC-32.
    let mut accepted = 0;
    for bad in resealed_changes(&packed, 34) {
        if let Ok(out) = decompress(&bad, MAX_FILE_SIZE) {
            // Only a change that decodes to the same file (e.g. a zstd frame's unused bits) may
            // pass: the decoded file's CRC-32 is checked.
            assert_eq!(out, smo);
            accepted += 1;
        }
    }
    eprintln!("{accepted} of 3000 resealed changes decoded to the same file");
}

#[test]
fn a_small_file_cannot_ask_for_a_huge_buffer() {
    let smo = PackedOctree::from_leaves(meta(3, ValueBits::Eight), shell_leaves(3))
        .unwrap()
        .to_bytes();
    let mut packed = compress(&smo).unwrap();
    packed[16..24].copy_from_slice(&(1u64 << 40).to_le_bytes());
    reseal(&mut packed);
    let err = decompress(&packed, MAX_FILE_SIZE).unwrap_err();
    assert!(err.to_string().contains("decoded_size"), "{err}");
    let _: OctreeMeta = meta(3, ValueBits::Eight);
}

/// 3.1 files of the shapes [`files`] uses (8 and 16 bits; with surface, multi and clip voxels),
/// then the same octrees as 3.0 files (the container keeps both).
fn v3_files() -> Vec<(&'static str, Vec<u8>)> {
    let mut out = v31_files();
    for (name, v31) in out.clone() {
        let o = BrickOctree::new(v31).unwrap().to_octree();
        let v30 = BrickOctree::encode_minor(&o, 0).unwrap();
        out.push((name, v30.into_bytes()));
    }
    out
}

/// The 3.1 files of [`v3_files`].
fn v31_files() -> Vec<(&'static str, Vec<u8>)> {
    let mut out = Vec::new();
    for (name, bits, clip) in [
        ("v3 shell 8", ValueBits::Eight, false),
        ("v3 shell 16", ValueBits::Sixteen, false),
        ("v3 clip 8", ValueBits::Eight, true),
        ("v3 clip 16", ValueBits::Sixteen, true),
    ] {
        let leaves = if clip {
            clipped_shell_leaves(5)
        } else {
            shell_leaves(5)
        };
        let o = PackedOctree::from_leaves(meta(5, bits), leaves).unwrap();
        let v3 = BrickOctree::encode(&o).unwrap();
        assert!(v3.private_voxel_count() > 0 && v3.private_voxel_count() < v3.voxel_count());
        out.push((name, v3.into_bytes()));
    }
    out
}

#[test]
fn a_v3_file_decodes_to_its_own_bytes() {
    let v3s = v3_files();
    let v30_len = |name: &str| v3s.iter().rev().find(|f| f.0 == name).unwrap().1.len();
    for (name, v3) in &v3s {
        let (name, v3) = (*name, v3.clone());
        let packed = compress(&v3).unwrap();
        assert!(is_compressed(&packed), "{name}");
        // Minor 1: a container a 1.0 reader cannot decode; 1.x files stay 1.0.
        assert_eq!(
            packed[10..12],
            COMPRESSED_VERSION_MINOR.to_le_bytes(),
            "{name}"
        );
        assert_eq!(decompress(&packed, MAX_FILE_SIZE).unwrap(), v3, "{name}");
        // Less than half the 3.0 file (a 3.1 file is smaller to begin with).
        assert!(
            packed.len() * 2 < v30_len(name),
            "{name}: {} of {} ({} as 3.0)",
            packed.len(),
            v3.len(),
            v30_len(name)
        );
    }
    let (_, smo) = &files()[0];
    assert_eq!(compress(smo).unwrap()[10..12], [0, 0]);
}

#[test]
fn hostile_v3_containers_are_refused_without_panic() {
    let (_, v3) = v3_files().swap_remove(2);
    let packed = compress(&v3).unwrap();
    assert_every_prefix_refused(&packed);
    // Random byte changes, resealed: an error, or (a change zstd ignores) the same file.
    let mut refused = 0;
    for bad in resealed_changes(&packed, 340) {
        match decompress(&bad, MAX_FILE_SIZE) {
            Ok(out) => assert_eq!(out, v3),
            Err(_) => refused += 1,
        }
    }
    assert!(refused > 2000, "{refused}");
}

#[test]
fn a_v3_header_with_sections_elsewhere_is_refused() {
    // The container rebuilds a 3.0 file from its counts: a header whose section table does not
    // match them (here the residuals declared one byte longer) is named, not decoded.
    let (_, v3) = v3_files().swap_remove(0);
    let packed = compress(&v3).unwrap();
    let table = COMPRESSED_HEADER_SIZE;
    let (packed_len, size) = (
        u64::from_le_bytes(packed[table..table + 8].try_into().unwrap()) as usize,
        u64::from_le_bytes(packed[table + 8..table + 16].try_into().unwrap()) as usize,
    );
    let mut prelude =
        zstd::bulk::decompress(&packed[table + 7 * 16..][..packed_len], size).unwrap();
    let at = 120; // residuals_size (FORMAT.md, 3.0 header)
    let declared = u64::from_le_bytes(prelude[at..at + 8].try_into().unwrap());
    prelude[at..at + 8].copy_from_slice(&(declared + 1).to_le_bytes());
    let frame = zstd::bulk::compress(&prelude, 1).unwrap();
    let mut bad = packed[..table + 7 * 16].to_vec();
    bad[table..table + 8].copy_from_slice(&(frame.len() as u64).to_le_bytes());
    bad.extend_from_slice(&frame);
    bad.extend_from_slice(&packed[table + 7 * 16 + packed_len..packed.len() - 4]);
    let crc = sdfmo_format::crc32(&bad);
    bad.extend_from_slice(&crc.to_le_bytes());
    let err = decompress(&bad, MAX_FILE_SIZE).unwrap_err();
    assert!(err.to_string().contains("file_size"), "{err}");
}

#[test]
fn every_reader_loads_a_v3_file() {
    // A 3.0 file (plain or compressed) loads as its bricks through the file readers (which the
    // tracers read in place), and as the 1.x octree it encodes through the 1.x reader.
    let dir = tempfile::tempdir().unwrap();
    for (name, v3) in v3_files() {
        let octree = BrickOctree::new(&v3[..]).unwrap().to_octree();
        for (kind, bytes) in [
            ("plain", v3.clone()),
            ("compressed", compress(&v3).unwrap()),
        ] {
            let path = dir.path().join("x.smo");
            std::fs::write(&path, &bytes).unwrap();
            assert_eq!(PackedOctree::load(&path).unwrap(), octree, "{name} {kind}");
            let want = SmoFile::Bricks(BrickOctree::new(v3.clone()).unwrap());
            assert_eq!(SmoFile::load(&path).unwrap(), want, "{name} {kind}");
            assert_eq!(SmoFile::from_bytes(&bytes).unwrap(), want, "{name} {kind}");
            assert_eq!(
                SmoFile::from_prefix(&bytes).unwrap().file,
                want,
                "{name} {kind}"
            );
        }
        // A cut 3.0 file is refused from its header, before its body is read.
        let path = dir.path().join("cut.smo");
        std::fs::write(&path, &v3[..v3.len() - 1]).unwrap();
        assert!(matches!(
            SmoFile::load(&path),
            Err(FormatError::Truncated { .. })
        ));
        assert!(PackedOctree::load(&path).is_err());
    }
}
