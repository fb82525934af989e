//! The in-memory packed octree: construction from leaves and the traversal accessors.

use std::ops::Range;

use crate::error::{FormatError, Result};
use crate::quant::{self, dequant_scale, quantize};
use crate::{morton, LeafInput, OctreeMeta, ValueBits, Voxel, MAX_VOXELS_PER_LEAF};

/// Eight consecutive inner nodes (breadth-first order): 12 bytes, the record of the node section.
///
/// `masks[s]` is the child mask of node `8g + s` (bit `i` = a child in octant `i = 4x + 2y + z`);
/// `first_child` is the node index of the first child of node `8g` (or, if it has none, of the
/// first node after it that has children). Node `8g + s`'s child in octant `o` is
/// `first_child + popcount(masks_as_u64_le & ((1 << (8s + o)) − 1))`. Example: masks
/// `[0b1001_0000, 0b0000_0110, …]`, `first_child = 9`: node `8g + 1`'s child in octant 2 is
/// `9 + popcount(0b1001_0000) + popcount(0b0000_0110 & 0b11) = 9 + 2 + 1 = 12`.
/// Masks of the slots past the last inner node are 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct NodeGroup {
    /// Node index of the first child of the group's nodes.
    pub(crate) first_child: u32,
    /// Child masks of the group's eight nodes.
    pub(crate) masks: [u8; 8],
}
const _: () = assert!(std::mem::size_of::<NodeGroup>() == 12);

/// Eight consecutive leaves (Morton order): 12 bytes, the record of the leaf section.
///
/// `counts[s]` is the voxel count (1..=255) of leaf `8g + s`; `first_voxel` the index of the
/// first voxel of leaf `8g`. Leaf `8g + s`'s voxels are `first_voxel + Σ counts[..s]` onwards.
/// Counts past the last leaf are 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct LeafGroup {
    /// Index of the first voxel of the group's first leaf.
    pub(crate) first_voxel: u32,
    /// Voxel counts of the group's eight leaves.
    pub(crate) counts: [u8; 8],
}
const _: () = assert!(std::mem::size_of::<LeafGroup>() == 12);

/// Quantised corner codes, 8 per voxel.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Corners {
    /// 8-bit codes in −127..=127.
    Eight(Vec<[i8; 8]>),
    /// 16-bit codes in −32767..=32767.
    Sixteen(Vec<[i16; 8]>),
}

/// A node of a [`PackedOctree`]: its breadth-first index (root = 0). Cheap to copy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeRef(pub(crate) u32);

impl NodeRef {
    /// The node's breadth-first index (inner nodes first, then the leaves in Morton order).
    #[inline]
    pub fn index(self) -> u32 {
        self.0
    }

    /// The node with breadth-first index `index` (for tools that store node indices; the
    /// accessors panic on an index outside the octree they are given).
    #[inline]
    pub fn from_index(index: u32) -> NodeRef {
        NodeRef(index)
    }
}

/// The packed sparse multi-octree (see the crate docs for the layout).
#[derive(Clone, Debug, PartialEq)]
pub struct PackedOctree {
    pub(crate) meta: OctreeMeta,
    pub(crate) inner_count: u32,
    pub(crate) leaf_count: u32,
    pub(crate) voxel_count: u32,
    pub(crate) surface_count: u32,
    pub(crate) nodes: Vec<NodeGroup>,
    pub(crate) leaves: Vec<LeafGroup>,
    pub(crate) surface: Vec<u64>,
    pub(crate) corners: Corners,
    /// `dmax / Q`: code → distance.
    pub(crate) dequant: f32,
}

/// Sum of the eight bytes of `x` (each ≤ 255; the sum fits easily).
#[inline]
pub(crate) fn byte_sum(x: u64) -> u32 {
    let pairs = (x & 0x00ff_00ff_00ff_00ff) + ((x >> 8) & 0x00ff_00ff_00ff_00ff);
    // Four 16-bit lanes ≤ 510 each: the top lane of the product is their sum (≤ 2040).
    (pairs.wrapping_mul(0x0001_0001_0001_0001) >> 48) as u32
}

/// Bits of `x` below bit `n` (`n` ≤ 63).
#[inline]
pub(crate) fn low_bits(x: u64, n: u32) -> u64 {
    x & ((1u64 << n) - 1)
}

/// `u32::try_from` with a typed error.
pub(crate) fn to_u32(count: u64, what: &'static str) -> Result<u32> {
    u32::try_from(count).map_err(|_| FormatError::TooLarge { what, count })
}

impl PackedOctree {
    /// Builds the inner nodes; deterministic whatever the order of `leaves` (sorted by Morton
    /// code; the voxels of a leaf keep their order). Corners are quantised over ± the voxel
    /// diagonal (clamped), rounding to nearest.
    ///
    /// Errors: depth above [`MAX_DEPTH`](crate::MAX_DEPTH), a bad transform, a coordinate
    /// outside `[0, 2^depth)`, two leaves with the same coordinate, a leaf with 0 or more than 255
    /// voxels, a non-finite corner, or more than 2³² − 1 nodes or voxels.
    pub fn from_leaves(meta: OctreeMeta, leaves: Vec<LeafInput>) -> Result<PackedOctree> {
        meta.validate()?;
        let depth = meta.depth;
        let side = 1u64 << depth;
        let mut total_voxels = 0u64;
        let mut keyed = Vec::with_capacity(leaves.len());
        for (index, leaf) in leaves.iter().enumerate() {
            if leaf.coord.iter().any(|&c| u64::from(c) >= side) {
                return Err(FormatError::CoordOutOfRange {
                    index,
                    coord: leaf.coord,
                    depth,
                    side,
                });
            }
            let count = leaf.voxels.len();
            if count == 0 || count > MAX_VOXELS_PER_LEAF {
                return Err(FormatError::VoxelCount {
                    coord: leaf.coord,
                    count,
                    max: MAX_VOXELS_PER_LEAF,
                });
            }
            for (v, voxel) in leaf.voxels.iter().enumerate() {
                if let Some(corner) = voxel.corners.iter().position(|c| !c.is_finite()) {
                    return Err(FormatError::NonFiniteCorner {
                        coord: leaf.coord,
                        voxel: v,
                        corner,
                        value: voxel.corners[corner],
                    });
                }
            }
            total_voxels += count as u64;
            keyed.push((morton::encode(leaf.coord), index));
        }
        let leaf_count = to_u32(leaves.len() as u64, "leaves")?;
        let voxel_count = to_u32(total_voxels, "voxels")?;
        // Codes are unique once duplicates are refused, so the order is total: deterministic.
        keyed.sort_unstable();
        if let Some(w) = keyed.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(FormatError::DuplicateLeaf {
                coord: leaves[w[1].1].coord,
            });
        }

        // Inner levels bottom-up: the parents of a sorted level are its codes >> 3, deduplicated.
        let mut levels: Vec<Vec<u8>> = Vec::with_capacity(depth as usize);
        let mut codes: Vec<u64> = keyed.iter().map(|&(c, _)| c).collect();
        if !codes.is_empty() {
            for _ in 0..depth {
                let mut parents: Vec<u64> = Vec::with_capacity(codes.len() / 2 + 1);
                let mut masks: Vec<u8> = Vec::with_capacity(codes.len() / 2 + 1);
                for &c in &codes {
                    let p = c >> 3;
                    if parents.last() != Some(&p) {
                        parents.push(p);
                        masks.push(0);
                    }
                    if let Some(m) = masks.last_mut() {
                        *m |= 1 << (c & 7);
                    }
                }
                levels.push(masks);
                codes = parents;
            }
        }
        levels.reverse(); // level 0 (the root) first: breadth-first order.
        let inner_total: u64 = levels.iter().map(|l| l.len() as u64).sum();
        let inner_count = to_u32(inner_total, "inner nodes")?;
        to_u32(inner_total + u64::from(leaf_count), "nodes")?;

        let mut nodes = Vec::with_capacity(levels.iter().map(Vec::len).sum::<usize>().div_ceil(8));
        let mut next_child = 1u32;
        let mut group = NodeGroup::default();
        let mut slot = 0;
        for &mask in levels.iter().flatten() {
            if slot == 0 {
                group.first_child = next_child;
            }
            group.masks[slot] = mask;
            next_child += mask.count_ones();
            slot += 1;
            if slot == 8 {
                nodes.push(group);
                group = NodeGroup::default();
                slot = 0;
            }
        }
        if slot != 0 {
            nodes.push(group);
        }

        let dmax = meta.dmax();
        let bits = meta.bits;
        let mut leaf_groups = Vec::with_capacity(leaves.len().div_ceil(8));
        let mut surface = vec![0u64; (voxel_count as usize).div_ceil(64)];
        let mut corners = match bits {
            ValueBits::Eight => Corners::Eight(Vec::with_capacity(voxel_count as usize)),
            ValueBits::Sixteen => Corners::Sixteen(Vec::with_capacity(voxel_count as usize)),
        };
        let mut surface_count = 0u32;
        let mut voxel = 0u32;
        let mut group = LeafGroup::default();
        for (j, &(_, index)) in keyed.iter().enumerate() {
            let slot = j % 8;
            if slot == 0 {
                group.first_voxel = voxel;
            }
            let leaf = &leaves[index];
            group.counts[slot] = leaf.voxels.len() as u8; // 1..=255, checked above
            for vx in &leaf.voxels {
                if vx.surface {
                    surface[voxel as usize / 64] |= 1 << (voxel % 64);
                    surface_count += 1;
                }
                match &mut corners {
                    Corners::Eight(c) => c.push(vx.corners.map(|v| quantize(v, dmax, bits) as i8)),
                    Corners::Sixteen(c) => {
                        c.push(vx.corners.map(|v| quantize(v, dmax, bits) as i16))
                    }
                }
                voxel += 1;
            }
            if slot == 7 {
                leaf_groups.push(group);
                group = LeafGroup::default();
            }
        }
        if leaves.len() & 7 != 0 {
            leaf_groups.push(group);
        }

        Ok(PackedOctree {
            meta,
            inner_count,
            leaf_count,
            voxel_count,
            surface_count,
            nodes,
            leaves: leaf_groups,
            surface,
            corners,
            dequant: dequant_scale(depth, bits),
        })
    }

    /// Depth, quantisation and normalisation transform.
    #[inline]
    pub fn meta(&self) -> &OctreeMeta {
        &self.meta
    }

    /// Leaves sit at this level.
    #[inline]
    pub fn depth(&self) -> u8 {
        self.meta.depth
    }

    /// Inner nodes plus leaves.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.inner_count as usize + self.leaf_count as usize
    }

    /// Inner nodes only (levels `0..depth`).
    #[inline]
    pub fn inner_node_count(&self) -> usize {
        self.inner_count as usize
    }

    /// Leaves (level `depth`).
    #[inline]
    pub fn leaf_count(&self) -> usize {
        self.leaf_count as usize
    }

    /// Voxels in all leaves.
    #[inline]
    pub fn voxel_count(&self) -> usize {
        self.voxel_count as usize
    }

    /// Voxels flagged surface (thin).
    #[inline]
    pub fn surface_voxel_count(&self) -> usize {
        self.surface_count as usize
    }

    /// `dmax / Q`: multiply a stored code by this to get a distance in normalised units.
    #[inline]
    pub fn dequant_scale(&self) -> f32 {
        self.dequant
    }

    // ---- Traversal access (sdfmo-trace) -------------------------------------------------

    /// The root node; `None` for an empty octree (no leaves).
    #[inline]
    pub fn root(&self) -> Option<NodeRef> {
        (self.leaf_count > 0).then_some(NodeRef(0))
    }

    /// Child mask of `node`: bit `i` set = a child in octant `i = 4x + 2y + z`; 0 for a leaf.
    ///
    /// Panics if `node` does not belong to this octree (index out of range).
    #[inline]
    pub fn child_mask(&self, node: NodeRef) -> u8 {
        if node.0 >= self.inner_count {
            return 0;
        }
        self.nodes[(node.0 >> 3) as usize].masks[(node.0 & 7) as usize]
    }

    /// The child of `node` in `octant` (`4x + 2y + z`, 0..8), if there is one.
    ///
    /// Panics if `node` does not belong to this octree (index out of range).
    #[inline]
    pub fn child(&self, node: NodeRef, octant: u8) -> Option<NodeRef> {
        if node.0 >= self.inner_count || octant > 7 {
            return None;
        }
        let group = &self.nodes[(node.0 >> 3) as usize];
        let masks = u64::from_le_bytes(group.masks);
        let bit = (node.0 & 7) * 8 + u32::from(octant);
        if masks >> bit & 1 == 0 {
            return None;
        }
        Some(NodeRef(
            group.first_child + low_bits(masks, bit).count_ones(),
        ))
    }

    /// Index of the first child of an inner node: its children (in octant order) are
    /// `first_child_index + 0 .. popcount(mask)`, and the one in octant `o` is
    /// `first_child_index + popcount(mask & ((1 << o) − 1))` — so a traversal that visits several
    /// children of one node can read the group once.
    ///
    /// Panics if `node` is not an inner node of this octree.
    #[inline]
    pub fn first_child_index(&self, node: NodeRef) -> u32 {
        assert!(node.0 < self.inner_count, "not an inner node");
        let group = &self.nodes[(node.0 >> 3) as usize];
        let masks = u64::from_le_bytes(group.masks);
        group.first_child + low_bits(masks, (node.0 & 7) * 8).count_ones()
    }

    /// Whether `node` is a leaf (leaves sit at level == depth).
    #[inline]
    pub fn is_leaf(&self, node: NodeRef) -> bool {
        node.0 >= self.inner_count
    }

    /// Leaf number of `node` in Morton order (`node − inner_node_count`), `None` for an inner node.
    #[inline]
    pub fn leaf_index(&self, node: NodeRef) -> Option<u32> {
        node.0.checked_sub(self.inner_count)
    }

    /// The voxel indices of a leaf (empty for an inner node).
    ///
    /// Panics if `leaf` does not belong to this octree (index out of range).
    #[inline]
    pub fn leaf_voxels(&self, leaf: NodeRef) -> Range<u32> {
        let Some(j) = self.leaf_index(leaf) else {
            return 0..0;
        };
        let group = &self.leaves[(j >> 3) as usize];
        let slot = j & 7;
        let start =
            group.first_voxel + byte_sum(low_bits(u64::from_le_bytes(group.counts), slot * 8));
        start..start + u32::from(group.counts[slot as usize])
    }

    /// The voxel's 8 corner distances (`4x + 2y + z`), dequantised, in normalised units.
    ///
    /// Panics if `voxel` is out of range.
    #[inline]
    pub fn voxel_corners(&self, voxel: u32) -> [f32; 8] {
        let s = self.dequant;
        match &self.corners {
            Corners::Eight(c) => c[voxel as usize].map(|q| f32::from(q) * s),
            Corners::Sixteen(c) => c[voxel as usize].map(|q| f32::from(q) * s),
        }
    }

    /// The voxel's stored integer codes (−Q..=Q); `value = code · dequant_scale()`.
    ///
    /// Panics if `voxel` is out of range.
    #[inline]
    pub fn voxel_codes(&self, voxel: u32) -> [i16; 8] {
        match &self.corners {
            Corners::Eight(c) => c[voxel as usize].map(i16::from),
            Corners::Sixteen(c) => c[voxel as usize],
        }
    }

    /// Whether the voxel is a surface (thin) voxel.
    ///
    /// Panics if `voxel` is out of range.
    #[inline]
    pub fn voxel_is_surface(&self, voxel: u32) -> bool {
        self.surface[(voxel >> 6) as usize] >> (voxel & 63) & 1 != 0
    }

    // ---- Whole-octree helpers -----------------------------------------------------------

    /// Cell coordinates of every leaf, in Morton (storage) order. Allocates; for tools.
    pub fn leaf_coords(&self) -> Vec<[u32; 3]> {
        let mut coords: Vec<[u32; 3]> = Vec::with_capacity(self.node_count());
        if self.leaf_count == 0 {
            return coords;
        }
        coords.push([0, 0, 0]);
        // Breadth first: appending each node's children in order reproduces the node numbering.
        for k in 0..self.inner_count {
            let [x, y, z] = coords[k as usize];
            let mask = self.child_mask(NodeRef(k));
            for o in 0..8u32 {
                if mask >> o & 1 != 0 {
                    coords.push([2 * x + (o >> 2), 2 * y + (o >> 1 & 1), 2 * z + (o & 1)]);
                }
            }
        }
        coords.drain(..self.inner_count as usize);
        coords
    }

    /// Iterates the leaves in Morton order: (coord, decoded voxels). For tests and tools.
    pub fn leaves(&self) -> impl Iterator<Item = ([u32; 3], Vec<Voxel>)> + '_ {
        let coords = self.leaf_coords();
        coords.into_iter().enumerate().map(move |(j, coord)| {
            let range = self.leaf_voxels(NodeRef(self.inner_count + j as u32));
            let voxels = range
                .map(|v| Voxel {
                    corners: self.voxel_corners(v),
                    surface: self.voxel_is_surface(v),
                })
                .collect();
            (coord, voxels)
        })
    }

    /// The leaf diagonal `dmax` over which corners are quantised.
    #[inline]
    pub fn dmax(&self) -> f32 {
        quant::voxel_diagonal(self.meta.depth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn meta(depth: u8) -> OctreeMeta {
        OctreeMeta {
            depth,
            bits: ValueBits::Eight,
            center: Vec3::ZERO,
            scale: 1.0,
        }
    }

    fn leaf(coord: [u32; 3], n: usize) -> LeafInput {
        LeafInput {
            coord,
            voxels: (0..n)
                .map(|i| Voxel {
                    corners: [0.01 * i as f32; 8],
                    surface: i % 2 == 1,
                })
                .collect(),
        }
    }

    #[test]
    fn byte_sum_is_exact() {
        assert_eq!(byte_sum(0), 0);
        assert_eq!(byte_sum(u64::MAX), 8 * 255);
        assert_eq!(byte_sum(u64::from_le_bytes([1, 2, 3, 4, 5, 6, 7, 8])), 36);
        assert_eq!(
            byte_sum(u64::from_le_bytes([255, 255, 255, 255, 255, 255, 255, 0])),
            7 * 255
        );
    }

    #[test]
    fn empty_octree_has_no_root() {
        let o = PackedOctree::from_leaves(meta(4), vec![]).unwrap();
        assert_eq!(o.root(), None);
        assert_eq!(o.node_count(), 0);
        assert_eq!(o.voxel_count(), 0);
        assert_eq!(o.leaves().count(), 0);
    }

    #[test]
    fn depth_zero_root_is_the_leaf() {
        let o = PackedOctree::from_leaves(meta(0), vec![leaf([0, 0, 0], 3)]).unwrap();
        let root = o.root().unwrap();
        assert!(o.is_leaf(root));
        assert_eq!(o.child_mask(root), 0);
        assert_eq!(o.leaf_voxels(root), 0..3);
        assert_eq!(o.node_count(), 1);
    }

    #[test]
    fn single_leaf_path_down_the_tree() {
        // Depth 3, leaf at (5, 2, 7) = binary x 101, y 010, z 111: octants 5, 3, 5 from the top.
        let o = PackedOctree::from_leaves(meta(3), vec![leaf([5, 2, 7], 2)]).unwrap();
        assert_eq!(o.inner_node_count(), 3);
        let mut n = o.root().unwrap();
        for expected in [5u8, 3, 5] {
            assert!(!o.is_leaf(n));
            assert_eq!(o.child_mask(n), 1 << expected);
            for oct in 0..8 {
                assert_eq!(o.child(n, oct).is_some(), oct == expected);
            }
            n = o.child(n, expected).unwrap();
        }
        assert!(o.is_leaf(n));
        assert_eq!(o.leaf_voxels(n), 0..2);
        assert!(!o.voxel_is_surface(0));
        assert!(o.voxel_is_surface(1));
        assert_eq!(o.leaf_coords(), vec![[5, 2, 7]]);
    }

    #[test]
    fn descending_every_coordinate_finds_its_leaf() {
        // A dense-ish random set at depth 4 with varying counts, > 8 per group everywhere.
        let depth = 4;
        let mut leaves = Vec::new();
        let mut state = 12345u64;
        for x in 0..16u32 {
            for y in 0..16u32 {
                for z in 0..16u32 {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    if state >> 61 == 0 {
                        leaves.push(leaf([x, y, z], 1 + (state >> 40) as usize % 5));
                    }
                }
            }
        }
        let o = PackedOctree::from_leaves(meta(depth), leaves.clone()).unwrap();
        assert_eq!(o.leaf_count(), leaves.len());
        let mut expected_voxels = 0;
        for l in &leaves {
            let mut n = o.root().unwrap();
            for level in (0..depth).rev() {
                let [x, y, z] = l.coord.map(|c| (c >> level) & 1);
                let oct = (4 * x + 2 * y + z) as u8;
                n = o.child(n, oct).expect("child on the leaf's path");
            }
            assert!(o.is_leaf(n));
            let r = o.leaf_voxels(n);
            assert_eq!(r.len(), l.voxels.len());
            for (k, v) in r.clone().enumerate() {
                assert_eq!(o.voxel_is_surface(v), l.voxels[k].surface);
                let c = o.voxel_corners(v);
                for (a, b) in c.iter().zip(l.voxels[k].corners) {
                    assert!((a - b).abs() <= o.dmax() / 254.0 + 1e-6);
                }
            }
            expected_voxels += l.voxels.len();
        }
        assert_eq!(o.voxel_count(), expected_voxels);
        // Leaves come out in Morton order and match the input set.
        let mut sorted = leaves.clone();
        sorted.sort_by_key(|l| morton::encode(l.coord));
        let coords: Vec<_> = o.leaves().map(|(c, _)| c).collect();
        assert_eq!(coords, sorted.iter().map(|l| l.coord).collect::<Vec<_>>());
    }

    #[test]
    fn first_child_index_agrees_with_child() {
        let leaves: Vec<_> = (0..64u32)
            .filter(|i| i % 3 != 1)
            .map(|i| leaf([i % 4, i / 16, (i / 4) % 4], 1))
            .collect();
        let o = PackedOctree::from_leaves(meta(2), leaves).unwrap();
        for k in 0..o.inner_node_count() as u32 {
            let n = NodeRef(k);
            let mask = o.child_mask(n);
            let first = o.first_child_index(n);
            for oct in 0..8u8 {
                let expected = (mask >> oct & 1 == 1)
                    .then(|| NodeRef(first + (u32::from(mask) & ((1 << oct) - 1)).count_ones()));
                assert_eq!(o.child(n, oct), expected);
            }
        }
    }

    #[test]
    fn input_errors_are_typed() {
        let e = PackedOctree::from_leaves(meta(17), vec![]).unwrap_err();
        assert!(matches!(e, FormatError::InvalidDepth { depth: 17, .. }));
        let e = PackedOctree::from_leaves(meta(2), vec![leaf([4, 0, 0], 1)]).unwrap_err();
        assert!(matches!(
            e,
            FormatError::CoordOutOfRange {
                coord: [4, 0, 0],
                ..
            }
        ));
        let e = PackedOctree::from_leaves(meta(2), vec![leaf([1, 0, 0], 1), leaf([1, 0, 0], 2)])
            .unwrap_err();
        assert!(matches!(e, FormatError::DuplicateLeaf { coord: [1, 0, 0] }));
        let e = PackedOctree::from_leaves(meta(2), vec![leaf([1, 0, 0], 0)]).unwrap_err();
        assert!(matches!(e, FormatError::VoxelCount { count: 0, .. }));
        let e = PackedOctree::from_leaves(meta(2), vec![leaf([1, 0, 0], 256)]).unwrap_err();
        assert!(matches!(e, FormatError::VoxelCount { count: 256, .. }));
        let mut bad = leaf([1, 0, 0], 1);
        bad.voxels[0].corners[3] = f32::NAN;
        let e = PackedOctree::from_leaves(meta(2), vec![bad]).unwrap_err();
        assert!(matches!(e, FormatError::NonFiniteCorner { corner: 3, .. }));
        let mut m = meta(2);
        m.scale = 0.0;
        assert!(matches!(
            PackedOctree::from_leaves(m, vec![]).unwrap_err(),
            FormatError::InvalidTransform { .. }
        ));
    }

    #[test]
    fn max_depth_coordinates_work() {
        let depth = crate::MAX_DEPTH;
        let top = (1u32 << depth) - 1;
        let o = PackedOctree::from_leaves(
            meta(depth),
            vec![
                leaf([top, 0, top], 1),
                leaf([0, top, 0], 1),
                leaf([top, top, top], 255),
            ],
        )
        .unwrap();
        assert_eq!(
            o.leaf_coords(),
            vec![[0, top, 0], [top, 0, top], [top, top, top]]
        );
        let last = NodeRef(o.node_count() as u32 - 1);
        assert_eq!(o.leaf_voxels(last), 2..257);
    }
}
