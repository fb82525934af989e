//! A 4-wide BVH collapsed from obvhs' BVH2, for the closest-point search.
//!
//! Far from the surface (uniform query points) a closest-point search visits ≈ 100 inner nodes
//! of a binary tree, each a dependent load and an unpredictable branch. Collapsing every two
//! levels into one node of four children with their boxes stored as structure of arrays
//! (one `Vec4` per box coordinate) halves the visits and tests the four boxes in one SIMD
//! pass. Each leaf's triangles are stored with it as [`TrianglePacket`]s (four triangles in
//! SIMD lanes), a leaf of two packets as one [`TrianglePair`] (eight lanes, for the AVX pass),
//! so a leaf is one or two contiguous loads.

use glam::{Vec3, Vec3A, Vec4};
use obvhs::bvh2::node::Bvh2Node;

use crate::triangle_packet::{TrianglePacket, TrianglePair};

/// Up to four triangles of one leaf and their leaf slots (a leaf of n triangles fills
/// ⌈n/4⌉ packets; unused lanes repeat the leaf's last triangle and slot, which can never beat
/// the lane that holds it).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct LeafPacket {
    /// The triangles (rotated corners, as in the leaf records).
    pub(crate) triangles: TrianglePacket,
    /// The leaf slot of each lane.
    pub(crate) slots: [u32; 4],
}

/// A leaf of five to eight triangles: its two packets as one [`TrianglePair`], and the leaf
/// slot of each lane (`slots[0]` lanes 0–3, `slots[1]` lanes 4–7; unused lanes as in
/// [`LeafPacket`]).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct LeafPair {
    /// The triangles (rotated corners, as in the leaf records).
    pub(crate) triangles: TrianglePair,
    /// The leaf slot of each lane, per half.
    pub(crate) slots: [[u32; 4]; 2],
}

/// One node of four children. Unused lanes have an empty box (min +∞, max −∞), whose distance
/// is +∞ for every point, so no search ever enters them.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Node4 {
    /// x, y and z of the four children's box minima.
    min: [Vec4; 3],
    /// x, y and z of the four children's box maxima.
    max: [Vec4; 3],
    /// Per lane: the index of an inner child in the node array, or a leaf's first packet (its
    /// pair, for a leaf of two packets).
    pub(crate) child: [u32; 4],
    /// Per lane: 0 for an inner child, else the number of packets of the leaf (2: the leaf is
    /// in `Bvh4::pairs`).
    pub(crate) count: [u32; 4],
}

// Two cache lines, aligned, so one node is never split over three lines.
const _: () = assert!(std::mem::size_of::<Node4>() == 128);

impl Node4 {
    const EMPTY: Node4 = Node4 {
        min: [Vec4::INFINITY; 3],
        max: [Vec4::NEG_INFINITY; 3],
        child: [0; 4],
        count: [0; 4],
    };

    /// Squared distances from `p` to the four children's boxes (0 inside, +∞ for unused lanes).
    #[inline(always)]
    pub(crate) fn box_dist2(&self, p: Vec3A) -> Vec4 {
        let axis = |k: usize, v: f32| {
            let v = Vec4::splat(v);
            let d = (self.min[k] - v).max(v - self.max[k]).max(Vec4::ZERO);
            d * d
        };
        axis(0, p.x) + axis(1, p.y) + axis(2, p.z)
    }
}

/// The collapsed tree; node 0 is the root.
#[derive(Clone, Debug, Default)]
pub(crate) struct Bvh4 {
    pub(crate) nodes: Vec<Node4>,
    /// The triangles of the leaves of one packet or of more than two, each leaf's packets
    /// contiguous.
    pub(crate) packets: Vec<LeafPacket>,
    /// The triangles of the leaves of two packets.
    pub(crate) pairs: Vec<LeafPair>,
    /// Levels of nodes (a root alone is 1): bounds the search's stack.
    pub(crate) depth: usize,
    /// Largest absolute coordinate of any triangle corner (the closest-point search's rounding
    /// margin scales with it).
    pub(crate) extent: f32,
}

impl Bvh4 {
    /// Collapses the BVH2 `nodes` (node 0 the root; inner nodes' children at `first_index` and
    /// `first_index + 1`): each 4-wide node takes the BVH2 node's children and opens the
    /// largest (by surface area) inner ones until it has four. `corners` are the triangles per
    /// leaf slot.
    pub(crate) fn from_bvh2(nodes: &[Bvh2Node], corners: &[[Vec3; 3]]) -> Bvh4 {
        let mut out = Bvh4 {
            nodes: Vec::with_capacity(nodes.len() / 3 + 1),
            packets: Vec::new(),
            pairs: Vec::new(),
            depth: 1,
            extent: corners
                .iter()
                .flatten()
                .fold(0.0f32, |m, v| m.max(v.abs().max_element())),
        };
        if nodes.is_empty() {
            out.nodes.push(Node4::EMPTY);
            return out;
        }
        out.nodes.push(Node4::EMPTY);
        // (BVH2 node to collapse, Node4 slot it fills, its level)
        let mut work = vec![(0usize, 0usize, 1usize)];
        while let Some((n2, slot, level)) = work.pop() {
            out.depth = out.depth.max(level);
            let root = &nodes[n2];
            let mut kids: Vec<usize> = if root.prim_count > 0 {
                // A tree that is one leaf: the root node holds it as its only child.
                vec![n2]
            } else {
                let l = root.first_index as usize;
                vec![l, l + 1]
            };
            while kids.len() < 4 {
                let widest = kids
                    .iter()
                    .enumerate()
                    .filter(|(_, &k)| nodes[k].prim_count == 0)
                    .max_by(|a, b| {
                        let sa = nodes[*a.1].aabb().half_area();
                        let sb = nodes[*b.1].aabb().half_area();
                        sa.total_cmp(&sb)
                    })
                    .map(|(i, _)| i);
                let Some(i) = widest else { break };
                let l = nodes[kids[i]].first_index as usize;
                kids[i] = l;
                kids.push(l + 1);
            }
            let mut node = Node4::EMPTY;
            for (lane, &k) in kids.iter().enumerate() {
                let b = nodes[k].aabb();
                for axis in 0..3 {
                    node.min[axis][lane] = b.min[axis];
                    node.max[axis][lane] = b.max[axis];
                }
                if nodes[k].prim_count > 0 {
                    let first = nodes[k].first_index as usize;
                    let slots = first..first + nodes[k].prim_count as usize;
                    let packets: Vec<LeafPacket> = slots
                        .clone()
                        .step_by(4)
                        .map(|start| {
                            let chunk = start..(start + 4).min(slots.end);
                            let last = chunk.end - 1;
                            LeafPacket {
                                triangles: TrianglePacket::new(&corners[chunk]),
                                slots: std::array::from_fn(|l| (start + l).min(last) as u32),
                            }
                        })
                        .collect();
                    node.count[lane] = packets.len() as u32;
                    if let [lo, hi] = packets[..] {
                        node.child[lane] = out.pairs.len() as u32;
                        out.pairs.push(LeafPair {
                            triangles: TrianglePair::new(&lo.triangles, &hi.triangles),
                            slots: [lo.slots, hi.slots],
                        });
                    } else {
                        node.child[lane] = out.packets.len() as u32;
                        out.packets.extend(packets);
                    }
                } else {
                    let index = out.nodes.len();
                    out.nodes.push(Node4::EMPTY);
                    node.child[lane] = index as u32;
                    work.push((k, index, level + 1));
                }
            }
            out.nodes[slot] = node;
        }
        out
    }
}
