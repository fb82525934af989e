//! The queries a tracer's walk makes of an octree, over both traced layouts: [`TracedOctree`],
//! implemented by the 1.x octree ([`Octree`]) and the 3.0 brick octree ([`BrickOctree`]), so
//! one tracer (`sdfmo-trace`, monomorphised per layout) reads either in place.
//!
//! Both layouts present the same tree: the same cells at the same levels, children in octant
//! order. A 3.0 brick is a node at `depth − 2` whose two lowest levels are walked from its
//! occupancy ([`BrickNode`]), so a walk sees the cells of the 1.x file of the same octree in the
//! same order, and a leaf's voxels in the same order with the same corner values and flags
//! ([`BrickOctree::encode`] is lossless): its hits are the 1.x file's, bit for bit.

use core::fmt::Debug;
use core::ops::Range;

use crate::{BrickLeaf, BrickNode, BrickOctree, NodeRef, Octree, OctreeMeta};

/// An octree as a tracer walks it (see the module docs): nodes from the root down by child
/// masks, a leaf's voxels, each voxel's corners and flags. Every query reads the validated
/// buffer in place (no allocation); a node, child base or voxel from another octree may panic.
pub trait TracedOctree {
    /// A node (`Copy`, cheap).
    type Node: Copy + Debug;
    /// What [`TracedOctree::child_of`] needs of an inner node to name its children (read once
    /// per node, however many children a walk takes).
    type Children: Copy;
    /// A voxel, as a hit names it (for [`TracedOctree::voxel_corners`]).
    type Voxel: Copy + PartialEq + Debug;
    /// A leaf's voxels, in storage order.
    type Voxels: Iterator<Item = Self::Voxel> + Clone;

    /// Depth, quantisation and normalisation transform.
    fn meta(&self) -> &OctreeMeta;
    /// The root; `None` for an empty octree.
    fn root(&self) -> Option<Self::Node>;
    /// Whether `node` is a leaf.
    fn is_leaf(&self, node: Self::Node) -> bool;
    /// Child mask of an inner node: bit `i` set = a child in octant `i = 4x + 2y + z`.
    fn child_mask(&self, node: Self::Node) -> u8;
    /// What names the children of the inner node `node` (see [`TracedOctree::child_of`]).
    fn children(&self, node: Self::Node) -> Self::Children;
    /// The child in `octant` (present in `mask`, the node's [`TracedOctree::child_mask`]) of
    /// the node whose [`TracedOctree::children`] is `children`.
    fn child_of(&self, children: Self::Children, mask: u32, octant: u32) -> Self::Node;
    /// The child of `node` in `octant` (`4x + 2y + z`, 0..8), if there is one.
    fn child(&self, node: Self::Node, octant: u8) -> Option<Self::Node>;
    /// The voxels of the leaf `node` (none for an inner node).
    fn leaf_voxels(&self, node: Self::Node) -> Self::Voxels;
    /// Whether any voxel of `voxels` (one leaf's) has the clip bit: the test that picks the
    /// clip rule over the plain nearest hit.
    fn any_clip_voxel(&self, voxels: &Self::Voxels) -> bool;
    /// The voxel's eight corner distances (`4x + 2y + z`), dequantised, normalised units.
    fn voxel_corners(&self, voxel: Self::Voxel) -> [f32; 8];
    /// Whether the voxel is a surface (thin) voxel.
    fn voxel_is_surface(&self, voxel: Self::Voxel) -> bool;
    /// Whether the voxel has the clip bit.
    fn voxel_is_clip(&self, voxel: Self::Voxel) -> bool;
    /// Whether `voxel` names a voxel of this octree (a hit from another octree may not).
    fn has_voxel(&self, voxel: Self::Voxel) -> bool;
}

impl<B: AsRef<[u8]>> TracedOctree for Octree<B> {
    type Node = NodeRef;
    /// The index of the first child.
    type Children = u32;
    /// The voxel's index.
    type Voxel = u32;
    type Voxels = Range<u32>;

    #[inline(always)]
    fn meta(&self) -> &OctreeMeta {
        Octree::meta(self)
    }

    #[inline(always)]
    fn root(&self) -> Option<NodeRef> {
        Octree::root(self)
    }

    #[inline(always)]
    fn is_leaf(&self, node: NodeRef) -> bool {
        Octree::is_leaf(self, node)
    }

    #[inline(always)]
    fn child_mask(&self, node: NodeRef) -> u8 {
        Octree::child_mask(self, node)
    }

    #[inline(always)]
    fn children(&self, node: NodeRef) -> u32 {
        self.first_child_index(node)
    }

    /// Children are contiguous in octant order: the first plus those below `octant`.
    #[inline(always)]
    fn child_of(&self, first: u32, mask: u32, octant: u32) -> NodeRef {
        let below = mask & ((1u32 << octant) - 1);
        NodeRef::from_index(first + below.count_ones())
    }

    #[inline(always)]
    fn child(&self, node: NodeRef, octant: u8) -> Option<NodeRef> {
        Octree::child(self, node, octant)
    }

    #[inline(always)]
    fn leaf_voxels(&self, node: NodeRef) -> Range<u32> {
        Octree::leaf_voxels(self, node)
    }

    #[inline(always)]
    fn any_clip_voxel(&self, voxels: &Range<u32>) -> bool {
        Octree::any_clip_voxel(self, voxels.clone())
    }

    #[inline(always)]
    fn voxel_corners(&self, voxel: u32) -> [f32; 8] {
        Octree::voxel_corners(self, voxel)
    }

    #[inline(always)]
    fn voxel_is_surface(&self, voxel: u32) -> bool {
        Octree::voxel_is_surface(self, voxel)
    }

    #[inline(always)]
    fn voxel_is_clip(&self, voxel: u32) -> bool {
        Octree::voxel_is_clip(self, voxel)
    }

    #[inline(always)]
    fn has_voxel(&self, voxel: u32) -> bool {
        (voxel as usize) < self.voxel_count()
    }
}

/// A voxel of a [`BrickOctree`]: voxel `k` of a leaf ([`BrickOctree::voxel_corners`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BrickVoxel {
    /// The leaf.
    pub leaf: BrickLeaf,
    /// The voxel's number in the leaf (0 in a shared leaf).
    pub k: u32,
}

/// The voxels of one [`BrickOctree`] leaf, in storage order.
#[derive(Clone, Debug)]
pub struct BrickVoxels {
    leaf: Option<BrickLeaf>,
    next: u32,
    end: u32,
}

impl Iterator for BrickVoxels {
    type Item = BrickVoxel;

    #[inline(always)]
    fn next(&mut self) -> Option<BrickVoxel> {
        let leaf = self.leaf?;
        if self.next >= self.end {
            return None;
        }
        let k = self.next;
        self.next += 1;
        Some(BrickVoxel { leaf, k })
    }
}

impl<B: AsRef<[u8]>> TracedOctree for BrickOctree<B> {
    type Node = BrickNode;
    /// The inner node, and for a node above the bricks the index of its first child.
    type Children = (BrickNode, u32);
    type Voxel = BrickVoxel;
    type Voxels = BrickVoxels;

    #[inline(always)]
    fn meta(&self) -> &OctreeMeta {
        BrickOctree::meta(self)
    }

    #[inline(always)]
    fn root(&self) -> Option<BrickNode> {
        BrickOctree::root(self)
    }

    #[inline(always)]
    fn is_leaf(&self, node: BrickNode) -> bool {
        BrickOctree::is_leaf(self, node)
    }

    #[inline(always)]
    fn child_mask(&self, node: BrickNode) -> u8 {
        BrickOctree::child_mask(self, node)
    }

    #[inline(always)]
    fn children(&self, node: BrickNode) -> (BrickNode, u32) {
        match node {
            BrickNode::Upper(k) => (node, self.first_child_index(k)),
            _ => (node, 0),
        }
    }

    #[inline(always)]
    fn child_of(&self, (node, first): (BrickNode, u32), mask: u32, octant: u32) -> BrickNode {
        match node {
            BrickNode::Upper(_) => {
                let below = mask & ((1u32 << octant) - 1);
                self.node(first + below.count_ones())
            }
            BrickNode::Brick(brick) => BrickNode::Half {
                brick,
                octant: octant as u8,
            },
            BrickNode::Half { brick, octant: h } => BrickNode::Leaf {
                brick,
                cell: (h << 3) | octant as u8,
            },
            // A leaf has no children (its mask is 0, so no walk asks).
            BrickNode::Leaf { .. } => node,
        }
    }

    #[inline(always)]
    fn child(&self, node: BrickNode, octant: u8) -> Option<BrickNode> {
        BrickOctree::child(self, node, octant)
    }

    #[inline(always)]
    fn leaf_voxels(&self, node: BrickNode) -> BrickVoxels {
        let leaf = self.leaf(node);
        BrickVoxels {
            leaf,
            next: 0,
            end: leaf.map_or(0, |l| l.voxel_count()),
        }
    }

    #[inline(always)]
    fn any_clip_voxel(&self, voxels: &BrickVoxels) -> bool {
        voxels
            .leaf
            .is_some_and(|l| BrickOctree::any_clip_voxel(self, &l))
    }

    #[inline(always)]
    fn voxel_corners(&self, voxel: BrickVoxel) -> [f32; 8] {
        BrickOctree::voxel_corners(self, &voxel.leaf, voxel.k)
    }

    #[inline(always)]
    fn voxel_is_surface(&self, voxel: BrickVoxel) -> bool {
        BrickOctree::voxel_is_surface(self, &voxel.leaf, voxel.k)
    }

    #[inline(always)]
    fn voxel_is_clip(&self, voxel: BrickVoxel) -> bool {
        BrickOctree::voxel_is_clip(self, &voxel.leaf, voxel.k)
    }

    fn has_voxel(&self, voxel: BrickVoxel) -> bool {
        let BrickVoxel { leaf, k } = voxel;
        (leaf.brick() as usize) < self.brick_count()
            && self.leaf(BrickNode::Leaf {
                brick: leaf.brick(),
                cell: leaf.cell(),
            }) == Some(leaf)
            && k < leaf.voxel_count()
    }
}
