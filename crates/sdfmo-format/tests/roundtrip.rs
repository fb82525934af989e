//! Round trips, determinism, the zero-copy view and quantisation bounds through the public API.

mod common;

use common::{clipped_shell_leaves, meta, shell_leaves};
use proptest::prelude::*;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use sdfmo_format::{LeafInput, NodeRef, PackedOctree, PackedOctreeView, ValueBits, Voxel};

/// Walks the whole tree from the root through `child`, collecting (coord, voxel range) per leaf.
fn walk(o: &PackedOctree) -> Vec<([u32; 3], std::ops::Range<u32>)> {
    let mut out = Vec::new();
    let Some(root) = o.root() else { return out };
    let mut stack = vec![(root, [0u32; 3])];
    while let Some((n, c)) = stack.pop() {
        if o.is_leaf(n) {
            out.push((c, o.leaf_voxels(n)));
            continue;
        }
        let mask = o.child_mask(n);
        assert_ne!(mask, 0);
        for oct in 0..8u8 {
            let child = o.child(n, oct);
            assert_eq!(child.is_some(), mask >> oct & 1 == 1);
            if let Some(ch) = child {
                stack.push((ch, sdfmo_format::child_coord(c, oct)));
            }
        }
    }
    out.sort_by_key(|(_, r)| r.start);
    out
}

#[test]
fn shuffled_inputs_give_identical_bytes() {
    let leaves = shell_leaves(6);
    assert!(leaves.len() > 1000);
    let reference = PackedOctree::from_leaves(meta(6, ValueBits::Eight), leaves.clone())
        .unwrap()
        .to_bytes();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for _ in 0..5 {
        let mut shuffled = leaves.clone();
        shuffled.shuffle(&mut rng);
        let bytes = PackedOctree::from_leaves(meta(6, ValueBits::Eight), shuffled)
            .unwrap()
            .to_bytes();
        assert_eq!(bytes, reference);
    }
}

#[test]
fn traversal_reaches_every_input_leaf_with_its_voxels() {
    for bits in [ValueBits::Eight, ValueBits::Sixteen] {
        let depth = 6;
        let leaves = shell_leaves(depth);
        let o = PackedOctree::from_leaves(meta(depth, bits), leaves.clone()).unwrap();
        let bound = o.dmax()
            / if bits == ValueBits::Eight {
                254.0
            } else {
                65534.0
            }
            + 1e-6;
        let mut by_coord: std::collections::HashMap<[u32; 3], &LeafInput> =
            leaves.iter().map(|l| (l.coord, l)).collect();
        let walked = walk(&o);
        assert_eq!(walked.len(), leaves.len());
        let mut surface = 0;
        for (coord, range) in walked {
            let input = by_coord
                .remove(&coord)
                .expect("walked leaf is an input leaf");
            assert_eq!(range.len(), input.voxels.len());
            for (v, want) in range.zip(&input.voxels) {
                assert_eq!(o.voxel_is_surface(v), want.surface);
                surface += usize::from(want.surface);
                for (got, want) in o.voxel_corners(v).iter().zip(want.corners) {
                    let clamped = want.clamp(-o.dmax(), o.dmax());
                    assert!((got - clamped).abs() <= bound, "{got} vs {clamped}");
                }
            }
        }
        assert!(by_coord.is_empty());
        assert_eq!(o.surface_voxel_count(), surface);
        assert!(
            surface > 0 && o.voxel_count() > o.leaf_count(),
            "the test shape has both kinds"
        );
    }
}

#[test]
fn leaves_iterator_matches_sorted_input() {
    let leaves = shell_leaves(5);
    let o = PackedOctree::from_leaves(meta(5, ValueBits::Sixteen), leaves.clone()).unwrap();
    let mut sorted = leaves;
    // Morton order: compare the interleaved bits level by level from the top.
    sorted.sort_by_key(|l| {
        (0..5)
            .rev()
            .map(|b| l.coord.map(|c| c >> b & 1))
            .map(|[x, y, z]| 4 * x + 2 * y + z)
            .collect::<Vec<_>>()
    });
    let got: Vec<_> = o.leaves().collect();
    assert_eq!(got.len(), sorted.len());
    for ((coord, voxels), want) in got.iter().zip(&sorted) {
        assert_eq!(*coord, want.coord);
        assert_eq!(voxels.len(), want.voxels.len());
    }
}

/// The borrowed form (over the file's bytes) and the owned form of the one octree type answer
/// every accessor alike, and copying the borrowed one gives the owned one.
#[test]
fn borrowed_and_owned_forms_agree() {
    for leaves in [shell_leaves(6), clipped_shell_leaves(6)] {
        let o = PackedOctree::from_leaves(meta(6, ValueBits::Eight), leaves).unwrap();
        forms_agree(&o);
    }
}

fn forms_agree(o: &PackedOctree) {
    let bytes = o.to_bytes();
    let v = PackedOctreeView::new(&bytes).unwrap();
    assert_eq!(v.meta(), o.meta());
    assert_eq!(
        (
            v.node_count(),
            v.leaf_count(),
            v.voxel_count(),
            v.surface_voxel_count()
        ),
        (
            o.node_count(),
            o.leaf_count(),
            o.voxel_count(),
            o.surface_voxel_count()
        )
    );
    for k in 0..o.node_count() as u32 {
        let n = NodeRef::from_index(k);
        assert_eq!(v.is_leaf(n), o.is_leaf(n));
        assert_eq!(v.child_mask(n), o.child_mask(n));
        for oct in 0..8 {
            assert_eq!(v.child(n, oct), o.child(n, oct));
        }
        if !o.is_leaf(n) {
            assert_eq!(v.first_child_index(n), o.first_child_index(n));
        }
        assert_eq!(v.leaf_voxels(n), o.leaf_voxels(n));
    }
    for voxel in 0..o.voxel_count() as u32 {
        assert_eq!(v.voxel_corners(voxel), o.voxel_corners(voxel));
        assert_eq!(v.voxel_is_surface(voxel), o.voxel_is_surface(voxel));
        assert_eq!(v.voxel_is_clip(voxel), o.voxel_is_clip(voxel));
    }
    assert_eq!(&v.to_octree(), o);
    assert_eq!(v.as_bytes(), o.as_bytes());
    assert_eq!(v.section_sizes(), o.section_sizes());
}

fn arb_leaves() -> impl Strategy<Value = (u8, Vec<LeafInput>)> {
    (1u8..=7).prop_flat_map(|depth| {
        let side = 1u32 << depth;
        // Clip bits in about one voxel in four (so most octrees have none, and stay 1.0).
        let voxel = (
            prop::array::uniform8(-1.0f32..1.0),
            any::<bool>(),
            prop::bool::weighted(0.25),
        )
            .prop_map(|(corners, surface, clip)| Voxel {
                corners,
                surface,
                clip,
            });
        let leaf = (
            prop::array::uniform3(0..side),
            prop::collection::vec(voxel, 1..4),
        )
            .prop_map(|(coord, mut voxels)| {
                // A leaf of clip-only voxels alone is invalid input: make one hittable.
                if voxels.iter().all(Voxel::is_clip_only) {
                    voxels[0].clip = false;
                }
                LeafInput { coord, voxels }
            });
        (Just(depth), prop::collection::vec(leaf, 0..60))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn from_leaves_to_bytes_from_bytes_round_trip((depth, leaves) in arb_leaves(), sixteen in any::<bool>()) {
        let mut leaves = leaves;
        leaves.sort_by_key(|l| l.coord);
        leaves.dedup_by_key(|l| l.coord);
        let bits = if sixteen { ValueBits::Sixteen } else { ValueBits::Eight };
        let o = PackedOctree::from_leaves(meta(depth, bits), leaves.clone()).unwrap();
        let bytes = o.to_bytes();
        prop_assert_eq!(bytes.len(), o.byte_size());
        // Any input order gives the same bytes (here: reversed, and rotated by one).
        let mut reversed = leaves.clone();
        reversed.reverse();
        prop_assert_eq!(&PackedOctree::from_leaves(meta(depth, bits), reversed).unwrap().to_bytes(), &bytes);
        let mut rotated = leaves.clone();
        if !rotated.is_empty() {
            rotated.rotate_left(1);
        }
        prop_assert_eq!(&PackedOctree::from_leaves(meta(depth, bits), rotated).unwrap().to_bytes(), &bytes);
        let back = PackedOctree::from_bytes(&bytes).unwrap();
        prop_assert_eq!(&back, &o);
        // Version 1.1 with the clip bitmap iff some voxel has the clip bit, else 1.0.
        let clip = leaves.iter().flat_map(|l| &l.voxels).filter(|v| v.clip).count();
        prop_assert_eq!(o.clip_voxel_count(), clip);
        prop_assert_eq!(u16::from_le_bytes([bytes[10], bytes[11]]), u16::from(clip > 0));
        prop_assert_eq!(o.section_sizes().clip, if clip > 0 { o.voxel_count().div_ceil(64) * 8 } else { 0 });
        prop_assert_eq!(back.to_bytes(), bytes);
        // Decoded leaves equal the input up to quantisation (values scaled by the leaf diagonal).
        let q = if sixteen { 32767.0 } else { 127.0 };
        let bound = o.dmax() / q / 2.0 + o.dmax() * 1e-6;
        let decoded: Vec<_> = back.leaves().collect();
        prop_assert_eq!(decoded.len(), leaves.len());
        for (coord, voxels) in decoded {
            let want = leaves.iter().find(|l| l.coord == coord).unwrap();
            prop_assert_eq!(voxels.len(), want.voxels.len());
            for (g, w) in voxels.iter().zip(&want.voxels) {
                prop_assert_eq!(g.surface, w.surface);
                prop_assert_eq!(g.clip, w.clip);
                for (a, b) in g.corners.iter().zip(w.corners) {
                    let b = b.clamp(-o.dmax(), o.dmax());
                    prop_assert!((a - b).abs() <= bound, "{} vs {} (bound {})", a, b, bound);
                }
            }
        }
    }
}
