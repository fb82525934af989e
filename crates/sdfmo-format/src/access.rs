//! One trait over both readers, so a traversal can be written once.

use std::ops::Range;

use crate::{NodeRef, OctreeMeta, PackedOctree, PackedOctreeView};

/// Read access to a packed octree: implemented by [`PackedOctree`] (owned) and
/// [`PackedOctreeView`] (zero copy over the file's bytes, e.g. memory-mapped). A tracer generic
/// over `O: OctreeAccess` runs on either; the methods are the inherent ones, forwarded `#[inline]`.
pub trait OctreeAccess {
    /// Depth, quantisation and normalisation transform.
    fn meta(&self) -> &OctreeMeta;
    /// Leaves in the octree.
    fn leaf_count(&self) -> usize;
    /// Voxels in the octree.
    fn voxel_count(&self) -> usize;
    /// The root node; `None` for an empty octree.
    fn root(&self) -> Option<NodeRef>;
    /// Child mask (bit `4x + 2y + z`); 0 for a leaf.
    fn child_mask(&self, node: NodeRef) -> u8;
    /// The child in `octant`, if any.
    fn child(&self, node: NodeRef, octant: u8) -> Option<NodeRef>;
    /// Index of an inner node's first child (see [`PackedOctree::first_child_index`]).
    fn first_child_index(&self, node: NodeRef) -> u32;
    /// Whether `node` is a leaf (level == depth).
    fn is_leaf(&self, node: NodeRef) -> bool;
    /// The voxel indices of a leaf (empty for an inner node).
    fn leaf_voxels(&self, leaf: NodeRef) -> Range<u32>;
    /// Dequantised corners (`4x + 2y + z`), normalised units.
    fn voxel_corners(&self, voxel: u32) -> [f32; 8];
    /// Whether the voxel is a surface (thin) voxel.
    fn voxel_is_surface(&self, voxel: u32) -> bool;
}

macro_rules! forward {
    ($t:ty) => {
        impl OctreeAccess for $t {
            #[inline]
            fn meta(&self) -> &OctreeMeta {
                <$t>::meta(self)
            }
            #[inline]
            fn leaf_count(&self) -> usize {
                <$t>::leaf_count(self)
            }
            #[inline]
            fn voxel_count(&self) -> usize {
                <$t>::voxel_count(self)
            }
            #[inline]
            fn root(&self) -> Option<NodeRef> {
                <$t>::root(self)
            }
            #[inline]
            fn child_mask(&self, node: NodeRef) -> u8 {
                <$t>::child_mask(self, node)
            }
            #[inline]
            fn child(&self, node: NodeRef, octant: u8) -> Option<NodeRef> {
                <$t>::child(self, node, octant)
            }
            #[inline]
            fn first_child_index(&self, node: NodeRef) -> u32 {
                <$t>::first_child_index(self, node)
            }
            #[inline]
            fn is_leaf(&self, node: NodeRef) -> bool {
                <$t>::is_leaf(self, node)
            }
            #[inline]
            fn leaf_voxels(&self, leaf: NodeRef) -> Range<u32> {
                <$t>::leaf_voxels(self, leaf)
            }
            #[inline]
            fn voxel_corners(&self, voxel: u32) -> [f32; 8] {
                <$t>::voxel_corners(self, voxel)
            }
            #[inline]
            fn voxel_is_surface(&self, voxel: u32) -> bool {
                <$t>::voxel_is_surface(self, voxel)
            }
        }
    };
}

forward!(PackedOctree);
forward!(PackedOctreeView<'_>);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{LeafInput, ValueBits, Voxel};
    use glam::Vec3;

    /// A generic depth-first walk: (leaf coord, Σ corners, surface count) per leaf.
    fn summary<O: OctreeAccess>(o: &O) -> Vec<([u32; 3], f32, usize)> {
        let mut out = Vec::new();
        let mut stack: Vec<(NodeRef, [u32; 3])> =
            o.root().map(|r| (r, [0; 3])).into_iter().collect();
        while let Some((n, c)) = stack.pop() {
            if o.is_leaf(n) {
                let r = o.leaf_voxels(n);
                let sum = r
                    .clone()
                    .map(|v| o.voxel_corners(v).iter().sum::<f32>())
                    .sum();
                let surf = r.filter(|&v| o.voxel_is_surface(v)).count();
                out.push((c, sum, surf));
                continue;
            }
            for oct in 0..8u8 {
                if let Some(ch) = o.child(n, oct) {
                    let k = u32::from(oct);
                    stack.push((
                        ch,
                        [
                            2 * c[0] + (k >> 2),
                            2 * c[1] + (k >> 1 & 1),
                            2 * c[2] + (k & 1),
                        ],
                    ));
                }
            }
        }
        out
    }

    #[test]
    fn owned_and_view_walk_identically() {
        let leaves: Vec<LeafInput> = (0..40u32)
            .map(|i| LeafInput {
                coord: [i % 8, i / 8, (i * 3) % 8],
                voxels: (0..1 + i as usize % 3)
                    .map(|k| Voxel {
                        corners: [0.05 * k as f32 - 0.04; 8],
                        surface: k == 2,
                    })
                    .collect(),
            })
            .collect();
        let meta = OctreeMeta {
            depth: 3,
            bits: ValueBits::Sixteen,
            center: Vec3::ZERO,
            scale: 1.0,
        };
        let o = PackedOctree::from_leaves(meta, leaves).unwrap();
        let bytes = o.to_bytes();
        let v = PackedOctreeView::new(&bytes).unwrap();
        let a = summary(&o);
        assert_eq!(a.len(), o.leaf_count());
        assert!(a.iter().any(|&(_, _, s)| s > 0));
        assert_eq!(a, summary(&v));
        assert_eq!(OctreeAccess::voxel_count(&v), o.voxel_count());
        assert_eq!(OctreeAccess::meta(&v), o.meta());
    }
}
