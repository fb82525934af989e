//! Corrupt and hostile `.smo` files are refused: never a panic, an out-of-bounds read or a huge
//! allocation. The file under attack is a real one built from generated leaves.

mod common;

use common::{clipped_shell_leaves, field, meta, reseal, shell_leaves};
use rand::{Rng, SeedableRng};
use sdfmo_format::{
    FormatError, LeafInput, NodeRef, PackedOctree, PackedOctreeView, ValueBits, Voxel,
    FLAG_CLIP_VOXELS, KNOWN_FLAGS, MAX_CLIP_VOXELS_PER_LEAF,
};

fn real_file(bits: ValueBits) -> Vec<u8> {
    let o = PackedOctree::from_leaves(meta(5, bits), shell_leaves(5)).unwrap();
    assert!(
        o.leaf_count() > 300 && o.voxel_count() > o.leaf_count() && o.surface_voxel_count() > 0
    );
    o.to_bytes()
}

/// A real version-1.1 file: `real_file`'s leaves with clip bits (intersect and clip-only).
fn real_clip_file(bits: ValueBits) -> Vec<u8> {
    let o = PackedOctree::from_leaves(meta(5, bits), clipped_shell_leaves(5)).unwrap();
    assert!(o.clip_voxel_count() > 20 && !o.voxel_count().is_multiple_of(64));
    o.to_bytes()
}

/// The 8-bit real file and a seeded random stream to attack it with.
fn real_file_and_rng(seed: u64) -> (Vec<u8>, rand_chacha::ChaCha8Rng) {
    let rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (real_file(ValueBits::Eight), rng)
}

/// Accepting bytes means: the borrowed and owned forms agree, the whole tree can be walked without panicking,
/// and writing it back gives the very same bytes (the encoding is canonical).
fn check_accepted(bytes: &[u8], o: &PackedOctree) {
    let view = PackedOctreeView::new(bytes).expect("view accepts what from_bytes accepts");
    assert_eq!(&view.to_octree(), o);
    // Canonical: writing it back gives the same bytes, up to the minor version (readers accept
    // any 1.x; the writer writes 1.0, or 1.1 with clip voxels).
    let mut expected = bytes.to_vec();
    let minor = u16::from(o.has_clip_voxels());
    expected[field("version_minor")..field("version_minor") + 2]
        .copy_from_slice(&minor.to_le_bytes());
    reseal(&mut expected);
    assert!(o.to_bytes() == expected, "accepted bytes are not canonical");
    let mut leaves = 0;
    let mut stack: Vec<NodeRef> = o.root().into_iter().collect();
    while let Some(n) = stack.pop() {
        if o.is_leaf(n) {
            leaves += 1;
            for v in o.leaf_voxels(n) {
                let _ = (
                    o.voxel_corners(v),
                    o.voxel_is_surface(v),
                    o.voxel_is_clip(v),
                );
            }
        } else {
            stack.extend((0..8).filter_map(|oct| o.child(n, oct)));
        }
    }
    assert_eq!(leaves, o.leaf_count());
}

fn u32_le(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}
fn u64_le(b: &mut [u8], at: usize, v: u64) {
    b[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

#[test]
fn every_truncation_is_refused() {
    for bytes in [
        real_file(ValueBits::Eight),
        real_file(ValueBits::Sixteen),
        real_clip_file(ValueBits::Eight),
    ] {
        for len in 0..bytes.len() {
            let r = PackedOctree::from_bytes(&bytes[..len]);
            assert!(
                r.is_err(),
                "truncation to {len} of {} accepted",
                bytes.len()
            );
            assert!(PackedOctreeView::new(&bytes[..len]).is_err());
        }
        // Trailing garbage is refused too.
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(PackedOctree::from_bytes(&longer).is_err());
    }
}

#[test]
fn thousands_of_random_flips_are_refused_by_the_checksum() {
    let (bytes, mut rng) = real_file_and_rng(0x5eed);
    let mut by_checksum = 0;
    for trial in 0..4000 {
        let mut b = bytes.clone();
        // Single-byte errors are always caught by a CRC; bursts of several random bytes too,
        // with probability 1 − 2^−32 (deterministic here: fixed seed).
        let flips = if trial % 2 == 0 {
            1
        } else {
            rng.random_range(2..8)
        };
        for _ in 0..flips {
            let at = rng.random_range(0..b.len());
            b[at] ^= rng.random_range(1..=255u8);
        }
        match PackedOctree::from_bytes(&b) {
            Err(FormatError::ChecksumMismatch { .. }) => by_checksum += 1,
            Err(_) => {} // e.g. a flipped magic or file_size is caught before the checksum
            Ok(_) => panic!("trial {trial}: a corrupted file was accepted"),
        }
    }
    assert!(by_checksum > 3000, "{by_checksum}");
}

#[test]
fn resealed_random_edits_never_panic_and_accepted_ones_are_canonical() {
    resealed_random_edits(&real_file(ValueBits::Eight), 99);
}

#[test]
fn resealed_random_edits_of_a_clip_file_never_panic() {
    resealed_random_edits(&real_clip_file(ValueBits::Eight), 0xc11b);
}

fn resealed_random_edits(bytes: &[u8], seed: u64) {
    // A hostile writer recomputes the CRC after editing: validation proper must hold the line.
    let bytes = bytes.to_vec();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut refused = 0;
    for _ in 0..3000 {
        let mut b = bytes.clone();
        for _ in 0..rng.random_range(1..4) {
            // Bias edits toward the header and the node/leaf sections, where lies do damage.
            let limit = if rng.random_bool(0.5) {
                128
            } else {
                b.len() - 4
            };
            let at = rng.random_range(0..limit);
            b[at] ^= 1 << rng.random_range(0..8);
        }
        reseal(&mut b);
        match PackedOctree::from_bytes(&b) {
            Ok(o) => check_accepted(&b, &o),
            Err(e) => {
                assert!(!matches!(e, FormatError::ChecksumMismatch { .. }));
                refused += 1;
            }
        }
    }
    // Flipped corner codes and transform bits give other valid octrees; most edits do not.
    assert!(refused > 1000, "{refused}");
}

/// One hostile edit (with a valid checksum) of `base` and a description for the message.
fn expect_corrupt_in(base: &[u8], name: &str, edit: impl Fn(&mut Vec<u8>)) {
    let mut b = base.to_vec();
    edit(&mut b);
    assert_ne!(b, base, "{name}: the edit changed nothing");
    reseal(&mut b);
    let Err(err) = PackedOctree::from_bytes(&b) else {
        panic!("{name}: hostile file accepted");
    };
    assert!(
        !matches!(err, FormatError::ChecksumMismatch { .. }),
        "{name}: refused only by the checksum: {err}"
    );
    assert!(PackedOctreeView::new(&b).is_err());
    println!("{name}: {err}");
}

fn expect_corrupt(name: &str, edit: impl Fn(&mut Vec<u8>)) {
    expect_corrupt_in(&real_file(ValueBits::Eight), name, edit);
}

#[test]
fn lying_header_fields_are_refused() {
    let bytes = real_file(ValueBits::Eight);
    let o = PackedOctree::from_bytes(&bytes).unwrap();
    let inner = o.inner_node_count() as u32;
    let leaves = o.leaf_count() as u32;
    let voxels = o.voxel_count() as u32;
    expect_corrupt("version", |b| b[field("version_major")] = 2);
    expect_corrupt("header_size", |b| u32_le(b, field("header_size"), 4096));
    expect_corrupt("header_size odd", |b| u32_le(b, field("header_size"), 132));
    expect_corrupt("flags unknown", |b| b[field("flags")] |= 0x80);
    expect_corrupt("flags lie", |b| b[field("flags")] &= !1);
    expect_corrupt("depth", |b| b[field("depth")] = 17);
    expect_corrupt("depth lie", |b| b[field("depth")] = 6);
    expect_corrupt("depth shallower", |b| b[field("depth")] = 4);
    expect_corrupt("value_bits", |b| b[field("value_bits")] = 12);
    expect_corrupt("value_bits lie", |b| b[field("value_bits")] = 16);
    expect_corrupt("reserved", |b| b[field("reserved")] = 1);
    expect_corrupt("scale nan", |b| {
        u32_le(b, field("scale"), f32::NAN.to_bits())
    });
    expect_corrupt("scale negative", |b| {
        u32_le(b, field("scale"), (-1.0f32).to_bits())
    });
    expect_corrupt("center inf", |b| {
        u32_le(b, field("center_y"), f32::INFINITY.to_bits())
    });
    for (name, value) in [
        ("inner_node_count", inner + 1),
        ("inner_node_count", inner - 1),
        ("inner_node_count", u32::MAX),
        ("leaf_count", leaves + 1),
        ("leaf_count", leaves - 8),
        ("leaf_count", u32::MAX),
        ("voxel_count", voxels + 1),
        ("voxel_count", u32::MAX),
        ("voxel_count", leaves - 1),
        ("surface_voxel_count", o.surface_voxel_count() as u32 + 1),
        ("surface_voxel_count", voxels + 1),
    ] {
        expect_corrupt(name, |b| u32_le(b, field(name), value));
    }
    expect_corrupt("file_size huge", |b| {
        u64_le(b, field("file_size"), u64::MAX)
    });
    expect_corrupt("file_size short", |b| u64_le(b, field("file_size"), 200));
    for name in [
        "nodes_offset",
        "nodes_size",
        "leaves_offset",
        "leaves_size",
        "surface_offset",
        "surface_size",
        "corners_offset",
        "corners_size",
    ] {
        expect_corrupt(name, |b| {
            let at = field(name);
            let v = u64::from_le_bytes(b[at..at + 8].try_into().unwrap());
            u64_le(b, at, v + 8);
        });
        expect_corrupt(name, |b| u64_le(b, field(name), u64::MAX - 3));
    }
}

#[test]
fn counts_consistent_with_a_longer_file_still_need_a_consistent_tree() {
    // Lie about the voxel count *and* make the file as long as that count implies (appending
    // zero voxels and resizing every section): the layout checks pass, the tree checks must not.
    let bytes = real_file(ValueBits::Eight);
    let o = PackedOctree::from_bytes(&bytes).unwrap();
    let extra = 64u32;
    let voxels = o.voxel_count() as u32 + extra;
    let mut b = bytes[..bytes.len() - 4].to_vec();
    b.extend(std::iter::repeat_n(0u8, extra as usize * 8));
    // Surface bitmap grows by one word: shift the corners section by 8 bytes.
    let s_at = field("surface_offset");
    let surface_off = u64::from_le_bytes(b[s_at..s_at + 8].try_into().unwrap()) as usize;
    let surface_size = (voxels as usize).div_ceil(64) * 8;
    let old_surface_size = o.voxel_count().div_ceil(64) * 8;
    for _ in old_surface_size..surface_size {
        b.insert(surface_off + old_surface_size, 0);
    }
    u32_le(&mut b, field("voxel_count"), voxels);
    u64_le(&mut b, field("surface_size"), surface_size as u64);
    u64_le(
        &mut b,
        field("corners_offset"),
        (surface_off + surface_size) as u64,
    );
    u64_le(&mut b, field("corners_size"), voxels as u64 * 8);
    b.extend([0u8; 4]);
    let len = b.len() as u64;
    u64_le(&mut b, field("file_size"), len);
    reseal(&mut b);
    let err = PackedOctree::from_bytes(&b).unwrap_err();
    assert!(
        matches!(
            err,
            FormatError::Corrupt {
                field: "leaves",
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn lying_sections_are_refused() {
    let bytes = real_file(ValueBits::Eight);
    let at = |name: &str| {
        let f = field(name);
        u64::from_le_bytes(bytes[f..f + 8].try_into().unwrap()) as usize
    };
    let nodes = at("nodes_offset");
    let leaves = at("leaves_offset");
    let surface = at("surface_offset");
    let corners = at("corners_offset");
    let o = PackedOctree::from_bytes(&bytes).unwrap();
    // Node groups: a wrong first-child base, a removed child, an added child, an empty node.
    expect_corrupt("node base", |b| b[nodes + 12] ^= 1);
    expect_corrupt("node base huge", |b| u32_le(b, nodes + 12, u32::MAX));
    expect_corrupt("root mask lost a child", |b| {
        let m = b[nodes + 4];
        b[nodes + 4] = m & (m - 1);
    });
    // The first node with a free octant: add a child there.
    let partial = (0..o.inner_node_count())
        .find(|&k| o.child_mask(NodeRef::from_index(k as u32)) != 0xff)
        .unwrap();
    expect_corrupt("mask gained a child", |b| {
        let at = nodes + (partial / 8) * 12 + 4 + partial % 8;
        let m = b[at];
        b[at] = m | !m & (!m).wrapping_neg();
    });
    expect_corrupt("inner node emptied", |b| b[nodes + 5] = 0);
    // Swapping bits between two masks keeps every popcount and base but breaks levels or order;
    // moving a child from a last-level node's mask to another keeps the tree shape valid, so
    // instead swap the root's mask with a deeper node's: the level sizes no longer match.
    expect_corrupt("root mask swapped", |b| {
        b.swap(nodes + 4, nodes + 4 + o.inner_node_count() - 1)
    });
    // Leaf groups: a zero count, a wrong base, a count that breaks the total.
    expect_corrupt("leaf count zero", |b| b[leaves + 4] = 0);
    expect_corrupt("leaf count raised", |b| b[leaves + 4] += 1);
    expect_corrupt("leaf base", |b| u32_le(b, leaves + 12, 1));
    // Surface bitmap: an extra bit (popcount), a padding bit.
    expect_corrupt("surface bit", |b| {
        let word = (0..).find(|&w| b[surface + w] != 0xff).unwrap();
        let byte = b[surface + word];
        b[surface + word] = byte | !byte & (!byte).wrapping_neg();
    });
    // Corner code −128 is outside the symmetric range.
    expect_corrupt("corner -128", |b| b[corners + 17] = 0x80);
    // Padding between sections must be zero.
    expect_corrupt("padding", |b| {
        let end = nodes + o.inner_node_count().div_ceil(8) * 12;
        assert!(end < leaves, "the node section needs padding in this file");
        b[end] = 1;
    });
}

#[test]
fn non_zero_padding_slots_are_refused() {
    // A file whose last node group, leaf group and bitmap word are partly padding.
    let mut leaves = shell_leaves(5);
    leaves.truncate(8 * 37 + 3);
    let o = PackedOctree::from_leaves(meta(5, ValueBits::Eight), leaves).unwrap();
    let (inner, n, v) = (o.inner_node_count(), o.leaf_count(), o.voxel_count());
    assert!(
        inner & 7 != 0 && n & 7 != 0 && v & 63 != 0,
        "{inner} {n} {v}"
    );
    let base = o.to_bytes();
    let offset = |name: &str| {
        let f = field(name);
        u64::from_le_bytes(base[f..f + 8].try_into().unwrap()) as usize
    };
    let (nodes, leaf_groups, surface) = (
        offset("nodes_offset"),
        offset("leaves_offset"),
        offset("surface_offset"),
    );
    expect_corrupt_in(&base, "node mask padding", |b| {
        b[nodes + (inner / 8) * 12 + 4 + inner % 8] = 1
    });
    expect_corrupt_in(&base, "leaf count padding", |b| {
        b[leaf_groups + (n / 8) * 12 + 4 + n % 8] = 1
    });
    expect_corrupt_in(&base, "surface padding bit", |b| {
        b[surface + (v / 64) * 8 + 7] |= 0x80
    });
}

#[test]
fn lying_clip_flags_and_bitmaps_are_refused() {
    let plain = real_file(ValueBits::Eight);
    let clip = real_clip_file(ValueBits::Eight);
    let o = PackedOctree::from_bytes(&clip).unwrap();
    let v = o.voxel_count();
    let words = v.div_ceil(64) * 8;
    // The bitmap is the last section: right before the checksum.
    let bitmap = clip.len() - 4 - words;
    let minor = field("version_minor");
    let flags = field("flags");
    // The flag without the section (and the section without the flag): the sizes disagree.
    expect_corrupt_in(&plain, "clip flag on a 1.0 file", |b| {
        b[flags] |= FLAG_CLIP_VOXELS as u8;
        b[minor] = 1;
    });
    expect_corrupt_in(&clip, "clip flag cleared", |b| {
        b[flags] &= !(FLAG_CLIP_VOXELS as u8)
    });
    // The flag and the section, but version 1.0.
    expect_corrupt_in(&clip, "clip voxels in a 1.0 file", |b| b[minor] = 0);
    // The section with no bit set.
    expect_corrupt_in(&clip, "empty clip bitmap", |b| {
        b[bitmap..bitmap + words].fill(0)
    });
    // A padding bit after the last voxel.
    expect_corrupt_in(&clip, "clip padding bit", |b| b[bitmap + words - 1] |= 0x80);
    // A leaf of clip-only voxels alone: the clip bit on a plate-only leaf's surface voxel.
    let lone_surface = (0..o.node_count() as u32)
        .map(NodeRef::from_index)
        .filter(|&n| o.is_leaf(n))
        .map(|n| o.leaf_voxels(n))
        .find(|r| r.len() == 1 && o.voxel_is_surface(r.start) && !o.voxel_is_clip(r.start))
        .expect("a leaf with one surface voxel")
        .start as usize;
    expect_corrupt_in(&clip, "leaf of clip-only voxels", |b| {
        b[bitmap + lone_surface / 8] |= 1 << (lone_surface % 8)
    });
    // The section placed where a 1.0 reader puts the checksum: a 1.0 header of a 1.1 file is
    // refused by the file size even when the flags are forged.
    expect_corrupt_in(&clip, "clip file claiming 1.0 without the flag", |b| {
        b[minor] = 0;
        b[flags] &= !(FLAG_CLIP_VOXELS as u8);
    });
}

/// Issue 19: the clip rule's work per leaf is (voxels × clip voxels); a valid 1.1 file of
/// leaves with 255 intersect voxels took 51 s to render 128² before validation bounded the clip
/// voxels of a leaf. A leaf at the bound is accepted, one clip voxel more is refused, by the
/// reader and by the writer.
#[test]
fn leaves_with_more_clip_voxels_than_the_bound_are_refused() {
    let max = MAX_CLIP_VOXELS_PER_LEAF;
    // One leaf of `n` voxels: planes x = 0.5 + 0.01·k, every voxel an intersect voxel.
    let leaf = |n: usize, clips: usize| LeafInput {
        coord: [1, 2, 3],
        voxels: (0..n)
            .map(|k| Voxel {
                corners: core::array::from_fn(|i| (i >> 2) as f32 - 0.5 - 0.01 * k as f32),
                surface: false,
                clip: k < clips,
            })
            .collect(),
    };
    let file = |clips: usize| {
        PackedOctree::from_leaves(meta(3, ValueBits::Eight), vec![leaf(20, clips)])
            .unwrap()
            .to_bytes()
    };
    let at_bound = file(max);
    PackedOctree::from_bytes(&at_bound).expect("a leaf at the bound is valid");
    // The writer refuses one more.
    let e =
        PackedOctree::from_leaves(meta(3, ValueBits::Eight), vec![leaf(20, max + 1)]).unwrap_err();
    assert!(
        matches!(e, FormatError::ClipCount { coord: [1, 2, 3], count, max: m } if count == max + 1 && m == max),
        "{e}"
    );
    // The reader refuses a resealed file with one more clip bit, and one with all 20.
    let bitmap = at_bound.len() - 4 - 8;
    for (name, bits) in [
        ("one clip voxel too many", (1u64 << (max + 1)) - 1),
        ("all 20", (1 << 20) - 1),
    ] {
        let mut b = at_bound.clone();
        b[bitmap..bitmap + 8].copy_from_slice(&bits.to_le_bytes());
        reseal(&mut b);
        let e = PackedOctree::from_bytes(&b).unwrap_err();
        let msg = e.to_string();
        assert!(
            matches!(e, FormatError::Corrupt { field: "clip", .. })
                && msg.contains("clip voxels, more than the 8"),
            "{name}: {msg}"
        );
    }
}

/// A reader of version 1.0 knows flag bits 0 and 1 only and refuses unknown ones: a file with
/// clip voxels is refused by it, never misread as a plain multi-octree.
#[test]
fn a_1_0_reader_refuses_clip_files_by_their_flag() {
    const KNOWN_FLAGS_1_0: u32 = 0b11;
    assert_ne!(FLAG_CLIP_VOXELS & !KNOWN_FLAGS_1_0, 0);
    assert_eq!(KNOWN_FLAGS, KNOWN_FLAGS_1_0 | FLAG_CLIP_VOXELS);
    let clip = real_clip_file(ValueBits::Sixteen);
    let f = field("flags");
    let flags = u32::from_le_bytes(clip[f..f + 4].try_into().unwrap());
    assert_ne!(flags & !KNOWN_FLAGS_1_0, 0);
    // And this reader refuses the next unknown bit the same way.
    expect_corrupt_in(&clip, "flag bit 3", |b| b[f] |= 0x08);
}

#[test]
fn not_smo_at_all() {
    assert!(matches!(
        PackedOctree::from_bytes(b""),
        Err(FormatError::Truncated { .. })
    ));
    assert!(matches!(
        PackedOctree::from_bytes(b"solid cube\nfacet"),
        Err(FormatError::BadMagic { .. })
    ));
    let mut b = real_file(ValueBits::Eight);
    b[field("version_major")] = 9;
    assert!(matches!(
        PackedOctree::from_bytes(&b),
        Err(FormatError::UnsupportedVersion { major: 9, .. })
    ));
}
