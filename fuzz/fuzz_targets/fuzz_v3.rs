//! Fuzzes format 3.0 (bricks, `sdfmo_format::BrickOctree`): any bytes must give an error or a
//! valid brick octree, never a panic, an out-of-bounds read or a huge allocation; and every
//! valid 1.x octree of depth ≥ 2 must encode to 3.1 (and 3.0) losslessly.
//!
//! Each input is also tried resealed (`smo_common::with_resealed`), to reach the checks behind
//! the CRC-32.
//!
//! Properties checked on every accepted 3.0 input: the owned and borrowed forms agree; a full
//! walk through the traversal queries (`root`, `child_mask`, `child`, `leaf`) visits at most
//! the nodes the counts allow, meets exactly `leaf_count` leaves and `voxel_count` voxels, and
//! every child mask agrees with `child`; every voxel's codes are within ±Q; shared leaves hold
//! one volume voxel; `find_leaf` finds every leaf the walk met; the 1.x octree it decodes to
//! (`to_octree`) answers every voxel alike, and encoding that octree again decodes to it. On
//! every valid 1.x input of depth ≥ 2: the encoding validates and answers every voxel as the
//! 1.x octree does, and decodes to its canonical bytes.
//!
//! Seeds (small valid 1.x files and their 3.0 encodings, regenerated deterministically; `*.smo`
//! is git-ignored): `cargo run -p sdfmo-format --example smo_sizes -- --max-depth 4 --write
//! fuzz/corpus/fuzz_v3`.
#![no_main]

mod smo_common;

use libfuzzer_sys::fuzz_target;
use sdfmo_format::{BrickNode, BrickOctree, BrickOctreeView, PackedOctreeView, BRICK_LEVELS};
use smo_common::with_resealed;

fn check_v3(bytes: &[u8]) {
    let owned = BrickOctree::new(bytes.to_vec());
    let view = BrickOctreeView::new(bytes);
    assert_eq!(owned.is_ok(), view.is_ok(), "owned and borrowed forms disagree");
    let (Ok(o), Ok(v)) = (owned, view) else {
        return;
    };
    assert!(o == v);

    let q = i16::MAX >> (16 - o.meta().bits.bits());
    // Upper nodes, bricks, half-bricks (≤ 8 per brick) and leaves.
    let max_nodes = v.upper_node_count() + 9 * v.brick_count() + v.leaf_count();
    let (mut visited, mut leaves, mut voxels) = (0usize, 0usize, 0usize);
    let mut stack: Vec<(BrickNode, [u32; 3])> = v.root().map(|r| (r, [0; 3])).into_iter().collect();
    while let Some((n, c)) = stack.pop() {
        visited += 1;
        assert!(visited <= max_nodes, "walk visits more nodes than exist");
        if let Some(leaf) = v.leaf(n) {
            leaves += 1;
            assert_eq!(v.find_leaf(c), Some(leaf));
            assert_eq!(v.child_mask(n), 0);
            let count = leaf.voxel_count();
            if leaf.is_shared() {
                assert!(count == 1 && !v.voxel_is_surface(&leaf, 0) && !v.voxel_is_clip(&leaf, 0));
            }
            for k in 0..count {
                assert!(v.voxel_codes(&leaf, k).iter().all(|c| c.abs() <= q));
            }
            voxels += count as usize;
            continue;
        }
        assert!(!v.is_leaf(n));
        let mask = v.child_mask(n);
        assert_ne!(mask, 0);
        for oct in (0..8u8).rev() {
            assert_eq!(v.child(n, oct).is_some(), mask >> oct & 1 != 0);
            if let Some(ch) = v.child(n, oct) {
                stack.push((ch, sdfmo_format::child_coord(c, oct)));
            }
        }
    }
    assert_eq!(leaves, v.leaf_count());
    assert_eq!(voxels, v.voxel_count());

    let decoded = v.to_octree();
    assert_eq!(v.first_difference(&decoded), None);
    let again = BrickOctree::encode(&decoded).expect("a decoded octree encodes");
    assert!(again.to_octree() == decoded, "encode(decode) decodes to another octree");
}

fn check_1x(bytes: &[u8]) {
    let Ok(o) = PackedOctreeView::new(bytes) else {
        return;
    };
    if o.depth() < BRICK_LEVELS {
        assert!(BrickOctree::encode(&o).is_err());
        return;
    }
    let b = BrickOctree::encode(&o).expect("a valid 1.x octree of depth >= 2 encodes");
    let v = BrickOctreeView::new(b.as_bytes()).expect("the encoding validates");
    let canonical = o.to_octree();
    assert_eq!(v.first_difference(&canonical), None);
    assert!(v.to_octree() == canonical, "3.x does not decode to the 1.x octree");
    // The 3.0 layout of the same octree (every private voxel wide) reads back alike.
    let b = BrickOctree::encode_minor(&o, 0).expect("a valid 1.x octree encodes as 3.0");
    let v = BrickOctreeView::new(b.as_bytes()).expect("the 3.0 encoding validates");
    assert_eq!(v.first_difference(&canonical), None);
}

fuzz_target!(|data: &[u8]| {
    with_resealed(data, |d| {
        check_v3(d);
        check_1x(d);
    });
});
