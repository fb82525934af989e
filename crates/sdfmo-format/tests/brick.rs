//! Format 3.0 (bricks): the encoder is lossless against the 1.x octree it reads, the view
//! answers every traversal query as the 1.x octree does, and hostile bytes are typed errors.

mod common;

use common::{clipped_shell_leaves, meta, shape_leaves, shell_leaves};
use sdfmo_format::{
    crc32, BrickLeaf, BrickNode, BrickOctree, BrickOctreeView, FormatError, LeafInput, NodeRef,
    OctreeMeta, PackedOctree, ValueBits, Voxel, BRICK_RECORD_SIZE, CHECKSUM_SIZE, V3_HEADER_FIELDS,
    V3_HEADER_SIZE,
};

fn octree(depth: u8, bits: ValueBits, leaves: Vec<LeafInput>) -> PackedOctree {
    PackedOctree::from_leaves(meta(depth, bits), leaves).unwrap()
}

/// The test octrees: multi-voxel shells with surface voxels, with clip voxels, and an SVO.
fn cases() -> Vec<PackedOctree> {
    let mut out = Vec::new();
    for bits in [ValueBits::Eight, ValueBits::Sixteen] {
        for depth in [2, 3, 5, 6] {
            out.push(octree(depth, bits, shell_leaves(depth)));
            out.push(octree(depth, bits, clipped_shell_leaves(depth)));
            out.push(octree(depth, bits, shape_leaves(depth, false)));
        }
    }
    out
}

/// Every voxel of `o` read through the 3.0 view's random access equals the 1.x voxel, and the
/// corners and the clip test of a leaf read alike too.
fn assert_lossless<B: AsRef<[u8]>>(o: &PackedOctree, v: &BrickOctree<B>) {
    assert_eq!(v.first_difference(o), None);
    let inner = o.inner_node_count() as u32;
    for (j, coord) in o.leaf_coords().into_iter().enumerate() {
        let voxels = o.leaf_voxels(NodeRef::from_index(inner + j as u32));
        let leaf = v.find_leaf(coord).expect("the leaf is in the 3.0 file");
        assert_eq!(v.any_clip_voxel(&leaf), o.any_clip_voxel(voxels.clone()));
        for (k, x) in voxels.enumerate() {
            assert_eq!(v.voxel_corners(&leaf, k as u32), o.voxel_corners(x));
        }
    }
}

#[test]
fn encoding_is_lossless_and_decodes_to_the_same_file() {
    for o in cases() {
        // 3.0 still reads back alike (the reader takes both minors).
        let b = BrickOctree::encode_minor(&o, 0).unwrap();
        assert_eq!(b.version_minor(), 0);
        assert_eq!(b.wide_voxel_count(), b.private_voxel_count());
        let view = BrickOctreeView::new(b.as_bytes()).unwrap();
        assert_lossless(&o, &view);
        assert_eq!(b.to_octree(), o, "{o:?}");
        let b = BrickOctree::encode(&o).unwrap();
        assert_eq!(b.version_minor(), 1);
        let view = BrickOctreeView::new(b.as_bytes()).unwrap();
        assert_eq!(view, b);
        assert_lossless(&o, &view);
        assert_eq!(b.to_octree(), o, "{o:?}");
        // Deterministic.
        assert_eq!(BrickOctree::encode(&o.as_view()).unwrap(), b);
    }
}

#[test]
fn shells_share_most_leaves_and_keep_multi_and_surface_leaves_private() {
    let o = octree(6, ValueBits::Eight, clipped_shell_leaves(6));
    let b = BrickOctree::encode(&o).unwrap();
    let multi = o.voxel_count() - o.leaf_count();
    assert!(multi > 0 && o.surface_voxel_count() > 0 && o.clip_voxel_count() > 0);
    assert_eq!(b.surface_voxel_count(), o.surface_voxel_count());
    assert_eq!(b.clip_voxel_count(), o.clip_voxel_count());
    // Every leaf with several voxels, a surface or a clip voxel is private; most are shared.
    assert!(b.private_leaf_count() < o.leaf_count() / 2);
    for (_, leaf) in b.leaves() {
        if leaf.is_shared() {
            assert_eq!(leaf.voxel_count(), 1);
            assert!(!b.voxel_is_surface(&leaf, 0) && !b.voxel_is_clip(&leaf, 0));
        }
    }
    assert!(b.as_bytes().len() < o.as_bytes().len());
    // An SVO (every leaf one volume voxel) shares every leaf: under half the 1.x bytes.
    let o = octree(6, ValueBits::Eight, shape_leaves(6, false));
    let b = BrickOctree::encode(&o).unwrap();
    assert_eq!(b.private_leaf_count(), 0);
    assert!(
        b.as_bytes().len() * 2 < o.as_bytes().len(),
        "{}",
        b.as_bytes().len()
    );
}

/// A depth-first walk: (coord, voxel count, Σ codes) per leaf, in the order visited.
fn walk_1x(o: &PackedOctree) -> Vec<([u32; 3], usize, i64)> {
    let mut out = Vec::new();
    let mut stack: Vec<(NodeRef, [u32; 3])> = o.root().map(|r| (r, [0; 3])).into_iter().collect();
    while let Some((n, c)) = stack.pop() {
        if o.is_leaf(n) {
            let r = o.leaf_voxels(n);
            let sum = r
                .clone()
                .flat_map(|x| o.voxel_codes(x))
                .map(i64::from)
                .sum();
            out.push((c, r.len(), sum));
            continue;
        }
        for oct in 0..8u8 {
            assert_eq!(o.child(n, oct).is_some(), o.child_mask(n) >> oct & 1 != 0);
            if let Some(ch) = o.child(n, oct) {
                stack.push((ch, sdfmo_format::child_coord(c, oct)));
            }
        }
    }
    out
}

fn walk_3<B: AsRef<[u8]>>(b: &BrickOctree<B>) -> Vec<([u32; 3], usize, i64)> {
    let mut out = Vec::new();
    let mut stack: Vec<(BrickNode, [u32; 3])> = b.root().map(|r| (r, [0; 3])).into_iter().collect();
    while let Some((n, c)) = stack.pop() {
        if b.is_leaf(n) {
            let leaf: BrickLeaf = b.leaf(n).expect("a leaf node");
            assert_eq!(b.child_mask(n), 0);
            let sum = (0..leaf.voxel_count())
                .flat_map(|k| b.voxel_codes(&leaf, k))
                .map(i64::from)
                .sum();
            out.push((c, leaf.voxel_count() as usize, sum));
            continue;
        }
        assert!(b.leaf(n).is_none());
        for oct in 0..8u8 {
            assert_eq!(b.child(n, oct).is_some(), b.child_mask(n) >> oct & 1 != 0);
            if let Some(ch) = b.child(n, oct) {
                stack.push((ch, sdfmo_format::child_coord(c, oct)));
            }
        }
        assert_eq!(b.child(n, 8), None);
    }
    out
}

#[test]
fn traversal_visits_the_same_tree_as_1x() {
    for o in cases() {
        let b = BrickOctree::encode(&o).unwrap();
        assert_eq!(walk_3(&b), walk_1x(&o));
        // Cells that are not leaves are not found.
        let side = 1u32 << o.depth();
        let leaves: std::collections::HashSet<[u32; 3]> = o.leaf_coords().into_iter().collect();
        for c in [
            [0, 0, 0],
            [side - 1, 1, 2],
            [side / 2, side / 2, side / 2],
            [side, 0, 0],
        ] {
            assert_eq!(b.find_leaf(c).is_some(), leaves.contains(&c), "{c:?}");
        }
    }
}

#[test]
fn empty_and_shallow_octrees() {
    let empty = octree(4, ValueBits::Eight, vec![]);
    let b = BrickOctree::encode(&empty).unwrap();
    assert_eq!(b.root(), None);
    assert_eq!(b.leaves().count(), 0);
    assert_eq!(b.to_octree(), empty);
    assert_eq!(BrickOctreeView::new(b.as_bytes()).unwrap(), b);
    for depth in [0, 1] {
        let leaves = vec![LeafInput {
            coord: [0, 0, 0],
            voxels: vec![Voxel {
                corners: [0.1; 8],
                surface: false,
                clip: false,
            }],
        }];
        let o = octree(depth, ValueBits::Eight, leaves);
        assert!(matches!(
            BrickOctree::encode(&o),
            Err(FormatError::Unrepresentable { major: 3, .. })
        ));
    }
    // Depth 2: the root is the one brick.
    let o = octree(2, ValueBits::Eight, shape_leaves(2, false));
    let b = BrickOctree::encode(&o).unwrap();
    assert_eq!(b.root(), Some(BrickNode::Brick(0)));
    assert_eq!(b.upper_node_count(), 0);
}

/// A plane's worth of codes that no residual narrower than the code can store: a brick
/// whose codes jump between ±Q every other point (the widest width, wrapped residuals).
#[test]
fn extreme_codes_round_trip() {
    for bits in [ValueBits::Eight, ValueBits::Sixteen] {
        let depth = 3;
        let m = OctreeMeta::unit(depth, bits);
        let big = m.dmax() * 2.0;
        let mut leaves = Vec::new();
        for x in 0..8u32 {
            for y in 0..8u32 {
                for z in 0..8u32 {
                    let corners = std::array::from_fn(|k| {
                        let p = [
                            x + (k as u32 >> 2),
                            y + (k as u32 >> 1 & 1),
                            z + (k as u32 & 1),
                        ];
                        if (p[0] + p[1] + p[2]).is_multiple_of(2) {
                            big
                        } else {
                            -big
                        }
                    });
                    leaves.push(LeafInput {
                        coord: [x, y, z],
                        voxels: vec![Voxel {
                            corners,
                            surface: false,
                            clip: false,
                        }],
                    });
                }
            }
        }
        let o = PackedOctree::from_leaves(m, leaves).unwrap();
        let b = BrickOctree::encode(&o).unwrap();
        assert_eq!(b.private_leaf_count(), 0);
        assert_lossless(&o, &BrickOctreeView::new(b.as_bytes()).unwrap());
    }
}

// ---- Hostile input ------------------------------------------------------------------------

fn reseal(mut bytes: Vec<u8>) -> Vec<u8> {
    let at = bytes.len() - CHECKSUM_SIZE;
    let crc = crc32(&bytes[..at]);
    bytes[at..].copy_from_slice(&crc.to_le_bytes());
    bytes
}

fn field(name: &str) -> std::ops::Range<usize> {
    let f = V3_HEADER_FIELDS.iter().find(|f| f.name == name).unwrap();
    f.offset..f.offset + f.size
}

fn read_u64(b: &[u8], name: &str) -> u64 {
    let mut x = [0u8; 8];
    let r = field(name);
    x[..r.len()].copy_from_slice(&b[r]);
    u64::from_le_bytes(x)
}

fn put(b: &mut [u8], name: &str, value: u64) {
    let r = field(name);
    let n = r.len();
    b[r].copy_from_slice(&value.to_le_bytes()[..n]);
}

fn corrupt_field(e: FormatError) -> &'static str {
    match e {
        FormatError::Corrupt { field, .. } => field,
        other => panic!("expected Corrupt, got {other:?}"),
    }
}

fn sample() -> Vec<u8> {
    let o = octree(4, ValueBits::Eight, clipped_shell_leaves(4));
    BrickOctree::encode(&o).unwrap().into_bytes()
}

#[test]
fn every_truncation_is_a_typed_error() {
    let bytes = sample();
    for cut in 0..bytes.len() {
        let e = BrickOctreeView::new(&bytes[..cut]).unwrap_err();
        assert!(
            matches!(
                e,
                FormatError::Truncated { .. }
                    | FormatError::Corrupt { .. }
                    | FormatError::ChecksumMismatch { .. }
            ),
            "{cut}: {e:?}"
        );
    }
}

/// A 3.1 file whose private leaves are narrow and wide, of 8 and 16 bits: narrow voxels
/// are smaller, and a 3.0 file of the same octree reads back alike.
#[test]
fn narrow_private_voxels_save_bytes_and_read_back() {
    for bits in [ValueBits::Eight, ValueBits::Sixteen] {
        let o = octree(6, bits, clipped_shell_leaves(6));
        let v31 = BrickOctree::encode(&o).unwrap();
        let v30 = BrickOctree::encode_minor(&o, 0).unwrap();
        let (w, x) = (v31.private_voxel_count(), v31.wide_voxel_count());
        assert!(x < w, "{bits:?}: {x} wide of {w}");
        let b = bits.bytes();
        assert_eq!(
            v31.section_sizes().private_corners,
            2 * b * (3 * w + x),
            "{bits:?}"
        );
        assert_eq!(v30.section_sizes().private_corners, 8 * b * w);
        assert!(v31.as_bytes().len() < v30.as_bytes().len());
        assert_eq!(v31.to_octree(), v30.to_octree());
    }
}

/// A private leaf of 128 voxels does not fit a 3.1 count byte: `encode` writes 3.0,
/// `encode_minor(1)` says why not, and a minor above 1 is refused both ways.
#[test]
fn a_leaf_of_128_voxels_is_written_as_3_0() {
    let mut leaves = shell_leaves(3);
    let extra = leaves[0].voxels[0];
    leaves[0].voxels.resize(128, extra);
    let o = octree(3, ValueBits::Eight, leaves);
    let b = BrickOctree::encode(&o).unwrap();
    assert_eq!(b.version_minor(), 0);
    assert_lossless(&o, &b);
    assert!(matches!(
        BrickOctree::encode_minor(&o, 1),
        Err(FormatError::Unrepresentable { .. })
    ));
    assert!(matches!(
        BrickOctree::encode_minor(&o, 2),
        Err(FormatError::Unrepresentable { .. })
    ));
    let mut bytes = sample();
    put(&mut bytes, "version_minor", 2);
    assert!(matches!(
        BrickOctreeView::new(&reseal(bytes)),
        Err(FormatError::UnsupportedVersion { minor: 2, .. })
    ));
}

#[test]
fn every_resealed_byte_flip_is_refused_or_reads_without_panic() {
    byte_flips_are_refused_or_read(sample());
    // And of the 3.0 layout.
    let o = octree(4, ValueBits::Eight, clipped_shell_leaves(4));
    byte_flips_are_refused_or_read(BrickOctree::encode_minor(&o, 0).unwrap().into_bytes());
    // A 3.1 file of 16 bits.
    let o = octree(4, ValueBits::Sixteen, clipped_shell_leaves(4));
    byte_flips_are_refused_or_read(BrickOctree::encode(&o).unwrap().into_bytes());
}

fn byte_flips_are_refused_or_read(bytes: Vec<u8>) {
    let mut refused = 0;
    for i in 0..bytes.len() - CHECKSUM_SIZE {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut b = bytes.clone();
            b[i] ^= flip;
            let b = reseal(b);
            match BrickOctreeView::new(&b) {
                Err(_) => refused += 1,
                // Counts, sizes and offsets (bytes 40..176) are all cross-checked.
                Ok(_) if (40..V3_HEADER_SIZE).contains(&i) => panic!("flip {flip:#x} at {i}"),
                // A flip the format cannot see (a plane term, a residual, a corner code):
                // every query still answers, in bounds.
                Ok(v) => {
                    let _ = walk_3(&v);
                    let _ = v.to_octree();
                }
            }
        }
    }
    assert!(refused > 3 * (V3_HEADER_SIZE - 40), "{refused}");
    // Unsealed: the checksum.
    let mut b = bytes.clone();
    b[200] ^= 1;
    assert!(matches!(
        BrickOctreeView::new(&b),
        Err(FormatError::ChecksumMismatch { .. })
    ));
}

#[test]
fn bad_header_fields_are_named() {
    let bytes = sample();
    let edit = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = bytes.clone();
        f(&mut b);
        BrickOctreeView::new(&reseal(b)).unwrap_err()
    };
    let e = edit(&|b| b[0] = b'X');
    assert!(matches!(e, FormatError::BadMagic { .. }));
    let e = edit(&|b| put(b, "version_major", 1));
    assert!(matches!(
        e,
        FormatError::UnsupportedVersion {
            major: 1,
            supported: 3,
            ..
        }
    ));
    let read = |name| read_u64(&bytes, name);
    // (field, the value written there, the field the error names)
    for (name, value, named) in [
        ("depth", 1, "depth"),
        ("value_bits", 12, "value_bits"),
        ("flags", 1 << 9, "flags"),
        ("header_size", 100, "header_size"),
        ("leaf_count", read("leaf_count") + 1, "voxel_count"),
        ("brick_count", read("brick_count") + 1, "file_size"),
        (
            "private_voxel_count",
            read("private_voxel_count") + 1,
            "voxel_count",
        ),
        ("residuals_size", read("residuals_size") + 8, "file_size"),
        ("residuals_size", u64::MAX, "residuals_size"),
        ("bricks_offset", read("bricks_offset") + 8, "bricks_offset"),
    ] {
        let e = edit(&|b| put(b, name, value));
        assert_eq!(corrupt_field(e), named, "{name} = {value}");
    }
}

#[test]
fn bad_brick_records_are_named() {
    let bytes = sample();
    let bricks = read_u64(&bytes, "bricks_offset") as usize;
    let n = read_u64(&bytes, "brick_count") as usize;
    // A brick with private leaves, and one after it (so its offsets are checked).
    let b0 = (0..n - 1)
        .find(|&b| {
            let at = bricks + b * BRICK_RECORD_SIZE;
            u64::from_le_bytes(bytes[at + 8..at + 16].try_into().unwrap()) != 0
        })
        .unwrap();
    let rec = bricks + b0 * BRICK_RECORD_SIZE;
    let edit = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = bytes.clone();
        f(&mut b);
        let e = BrickOctreeView::new(&reseal(b)).unwrap_err();
        match e {
            FormatError::Corrupt { field, reason } => (field, reason),
            other => panic!("{other:?}"),
        }
    };
    // Zero occupancy.
    let (f, r) = edit(&|b| b[rec..rec + 8].fill(0));
    assert_eq!(f, "bricks", "{r}");
    // A private cell that is not a leaf.
    let (f, _) = edit(&|b| {
        let occ = u64::from_le_bytes(b[rec..rec + 8].try_into().unwrap());
        let hole = (!occ).trailing_zeros().min(63) as u64;
        let private = u64::from_le_bytes(b[rec + 8..rec + 16].try_into().unwrap());
        b[rec + 8..rec + 16].copy_from_slice(&(private | 1 << hole).to_le_bytes());
    });
    assert_eq!(f, "bricks");
    // A residual offset or first private leaf that is not the running sum.
    let next = rec + BRICK_RECORD_SIZE;
    let (f, r) = edit(&|b| b[next + 24] ^= 1);
    assert!(f == "bricks" && r.contains("residual offset"), "{r}");
    let (f, r) = edit(&|b| b[next + 28] ^= 1);
    assert!(f == "bricks" && r.contains("first_private_leaf"), "{r}");
    // A leaf made private without a private leaf record: the totals disagree.
    let (f, _) = edit(&|b| {
        let occ = u64::from_le_bytes(b[rec..rec + 8].try_into().unwrap());
        let private = u64::from_le_bytes(b[rec + 8..rec + 16].try_into().unwrap());
        let shared = occ & !private;
        b[rec + 8..rec + 16]
            .copy_from_slice(&(private | shared & shared.wrapping_neg()).to_le_bytes());
    });
    assert!(["bricks", "residuals"].contains(&f), "{f}");
}

#[test]
fn codes_outside_the_range_are_refused() {
    // A private corner of −128.
    let bytes = sample();
    let at = read_u64(&bytes, "private_corners_offset") as usize;
    let mut b = bytes.clone();
    b[at + 3] = 0x80;
    assert_eq!(
        corrupt_field(BrickOctreeView::new(&reseal(b)).unwrap_err()),
        "private_corners"
    );
    // A plane that predicts +127 with a residual of +1 wraps to −128 at full width: find a
    // brick with 8-bit residuals and push its first point's residual to what decodes to −128.
    let o = octree(5, ValueBits::Eight, shape_leaves(5, false));
    let bytes = BrickOctree::encode(&o).unwrap().into_bytes();
    let bricks = read_u64(&bytes, "bricks_offset") as usize;
    let res = read_u64(&bytes, "residuals_offset") as usize;
    let n = read_u64(&bytes, "brick_count") as usize;
    let mut refused = 0;
    for b in 0..n {
        let rec = bricks + b * BRICK_RECORD_SIZE;
        let word = u32::from_le_bytes(bytes[rec + 24..rec + 28].try_into().unwrap());
        if word >> 30 != 3 {
            continue;
        }
        let mut x = bytes.clone();
        let first = res + (word & ((1 << 30) - 1)) as usize;
        for v in 0..=255u8 {
            x[first] = v;
            if let Err(e) = BrickOctreeView::new(&reseal(x.clone())) {
                assert_eq!(corrupt_field(e), "residuals");
                refused += 1;
            }
        }
        break;
    }
    assert_eq!(refused, 1, "exactly one byte value decodes to −128");
}

#[test]
fn first_difference_names_the_leaf_that_differs() {
    let o = octree(4, ValueBits::Eight, clipped_shell_leaves(4));
    let b = BrickOctree::encode(&o).unwrap();
    assert_eq!(b.first_difference(&o), None);
    // One code of one voxel changed, a surface bit flipped, a leaf removed.
    let leaves: Vec<LeafInput> = o
        .leaves()
        .map(|(coord, voxels)| LeafInput { coord, voxels })
        .collect();
    let mut code = leaves.clone();
    code[7].voxels[0].corners[5] += 3.0 * o.dequant_scale();
    let mut flag = leaves.clone();
    flag[9].voxels[0].surface = !flag[9].voxels[0].surface;
    let mut fewer = leaves.clone();
    fewer.remove(3);
    for (changed, what) in [
        (code, format!("{:?} voxel 0", leaves[7].coord)),
        (flag, format!("{:?} voxel 0", leaves[9].coord)),
        (fewer, "leaves".to_string()),
    ] {
        let other = PackedOctree::from_leaves(*o.meta(), changed).unwrap();
        let diff = b.first_difference(&other).expect("a difference");
        assert!(diff.contains(&what), "{diff} ({what})");
    }
}
