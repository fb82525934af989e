//! Fuzzes the `.smo` loader: any bytes must give an error or a valid octree, never a panic,
//! an out-of-bounds read or a huge allocation.
//!
//! Random bytes almost never carry a valid CRC-32, so each input is also tried *resealed* (its
//! last four bytes replaced by the CRC of the rest): that lets the fuzzer reach the structural
//! validation behind the checksum, where a hostile file would attack.
//!
//! Properties checked on every accepted input: the borrowed form (`PackedOctreeView`, the bytes
//! read in place) accepts it too, its owned copy is the octree `from_bytes` gives; a full walk through the traversal accessors touches exactly `leaf_count`
//! leaves and every voxel once, and the surface and clip bits read alike in both forms; no leaf
//! holds clip-only voxels alone nor more than `MAX_CLIP_VOXELS_PER_LEAF` clip voxels (the bound
//! on the clip rule's work, issue 19); writing it back and reading again round-trips; decoding the
//! leaves and building them again (`from_leaves`) keeps every voxel's surface and clip bits, the
//! clip count and the version (1.1 iff there are clip voxels).
//!
//! Seeds (small valid files, regenerated deterministically; `*.smo` is git-ignored):
//! `cargo run -p sdfmo-format --example smo_sizes -- --max-depth 4 --write fuzz/corpus/fuzz_smo`.
#![no_main]

mod smo_common;

use libfuzzer_sys::fuzz_target;
use sdfmo_format::{LeafInput, PackedOctree, PackedOctreeView, MAX_CLIP_VOXELS_PER_LEAF};
use smo_common::with_resealed;

fn check(bytes: &[u8]) {
    let owned = PackedOctree::from_bytes(bytes);
    let view = PackedOctreeView::new(bytes);
    assert_eq!(owned.is_ok(), view.is_ok(), "owned and borrowed forms disagree");
    let (Ok(o), Ok(v)) = (owned, view) else { return };
    assert!(v.to_octree() == o);
    assert!(v.as_bytes() == bytes);

    let mut leaves = 0usize;
    let mut next_voxel = 0u32;
    let mut stack: Vec<_> = o.root().into_iter().collect();
    let mut visited = 0usize;
    while let Some(n) = stack.pop() {
        visited += 1;
        assert!(visited <= o.node_count(), "walk visits more nodes than exist");
        if o.is_leaf(n) {
            leaves += 1;
            let r = o.leaf_voxels(n);
            assert!(!r.is_empty() && r.end as usize <= o.voxel_count());
            assert_eq!(r, v.leaf_voxels(n));
            assert_eq!(o.any_clip_voxel(r.clone()), r.clone().any(|x| o.voxel_is_clip(x)));
            assert!(r.clone().any(|x| !(o.voxel_is_surface(x) && o.voxel_is_clip(x))));
            let clips = r.clone().filter(|&x| o.voxel_is_clip(x)).count();
            assert!(clips <= MAX_CLIP_VOXELS_PER_LEAF);
            for vx in r {
                let c = o.voxel_corners(vx);
                assert!(c.iter().all(|x| x.is_finite() && x.abs() <= o.dmax() * 1.0001));
                assert_eq!(o.voxel_is_surface(vx), v.voxel_is_surface(vx));
                assert_eq!(o.voxel_is_clip(vx), v.voxel_is_clip(vx));
                next_voxel += 1;
            }
        } else {
            let mask = o.child_mask(n);
            assert_ne!(mask, 0);
            // Push in reverse so leaves are met in Morton (storage) order.
            for oct in (0..8u8).rev() {
                assert_eq!(o.child(n, oct), v.child(n, oct));
                if let Some(c) = o.child(n, oct) {
                    stack.push(c);
                }
            }
        }
    }
    assert_eq!(leaves, o.leaf_count());
    assert_eq!(next_voxel as usize, o.voxel_count());
    let again = PackedOctree::from_bytes(&o.to_bytes()).expect("re-encoded octree must load");
    assert!(again == o);

    // Decode → encode → decode keeps the voxel kinds (corners may requantise by a code).
    let leaves: Vec<LeafInput> = o
        .leaves()
        .map(|(coord, voxels)| LeafInput { coord, voxels })
        .collect();
    let rebuilt =
        PackedOctree::from_leaves(*o.meta(), leaves.clone()).expect("decoded leaves build");
    assert_eq!(rebuilt.clip_voxel_count(), o.clip_voxel_count());
    assert_eq!(rebuilt.surface_voxel_count(), o.surface_voxel_count());
    assert_eq!(rebuilt.flags(), o.flags());
    assert_eq!(rebuilt.as_bytes()[10], o.as_bytes()[10], "minor version");
    for ((_, got), want) in rebuilt.leaves().zip(&leaves) {
        assert_eq!(got.len(), want.voxels.len());
        for (g, w) in got.iter().zip(&want.voxels) {
            assert_eq!((g.surface, g.clip), (w.surface, w.clip));
        }
    }
}

fuzz_target!(|data: &[u8]| {
    with_resealed(data, check);
});
