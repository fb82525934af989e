//! Building the triangle BVH: obvhs' PLOC for ordinary meshes, a top-down binned-SAH builder
//! with a depth bound where PLOC degenerates.
//!
//! PLOC merges mutually nearest clusters bottom-up. When the triangles' boxes nest inside each
//! other — a fan (a cylinder's cap, an n-gon triangulated from one vertex), where every
//! triangle's box spans from the hub to the rim — one growing cluster is everyone's best
//! partner and absorbs one neighbour per pass: the passes become O(n) (a 50 000-triangle fan took
//! 13 s, 100 000 took 40 s) and the tree a chain (depth 154 for a 600-segment cylinder with fan
//! caps). Such meshes are recognised before PLOC runs by how much their triangles' boxes
//! overlap ([`box_overlap`]) and go to [`build_binned_sah`], which is O(n log n) and never
//! deeper than [`SAH_DEPTH_BOUND`]; a PLOC tree that still comes out deeper than the traversal
//! stacks allow is rebuilt the same way.

use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use sdfmo_mesh::{retriangulate_flat_regions, FlatRegionSettings, Retriangulated, TriMesh};
use std::time::Duration;

/// Which builder made a [`crate::MeshDistance`]'s BVH.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum BvhBuilder {
    /// obvhs' PLOC with reinsertion (`BvhBuildParams::medium_build`): the default.
    Ploc,
    /// Top-down binned SAH with a median-split fallback, for meshes whose triangles' boxes
    /// overlap more than [`MAX_PLOC_BOX_OVERLAP`] (fans), or whose PLOC tree was too deep.
    BinnedSah,
}

/// Meshes whose summed triangle box areas exceed this multiple of the root box's area are built
/// with the binned SAH instead of PLOC (see [`box_overlap`]).
///
/// Measured (`examples/bvh_overlap.rs`, docs/hardening.md): the shared meshes 3.5–15.8 (the
/// bunny 3.5, the CAD parts 8.5–15.8: their caps are small fans), cylinders whose caps are fans
/// from a rim vertex 66.6 at 400 segments and 98.4 at 600 (where PLOC's depth reaches 158), a
/// 50 000-triangle fan about 4 000. 32 keeps every shared mesh on PLOC (their trees and every
/// result stay byte-identical) with a 2× margin.
pub const MAX_PLOC_BOX_OVERLAP: f64 = 32.0;

/// Meshes with a vertex shared by more triangles than this are built with the binned SAH: a
/// large fan inside a much larger mesh barely moves [`box_overlap`] but still stalls PLOC.
/// Measured: the shared meshes' largest valence is 161 (abc1); a 600-segment fan cap's is 601.
pub const MAX_PLOC_VALENCE: u32 = 256;

/// The binned-SAH builder switches to median splits below this depth, so its trees are at most
/// `SAH_DEPTH_BOUND + ⌈log₂ n⌉` deep (≤ 80 for 2³² triangles), within
/// [`crate::MAX_BVH_DEPTH`].
pub const SAH_DEPTH_BOUND: usize = 48;

/// Most triangles a leaf of the binned-SAH tree holds (PLOC's collapse uses the same).
const MAX_LEAF_TRIANGLES: usize = 8;

/// Bins per axis of the SAH sweep.
const SAH_BINS: usize = 16;

/// Cost of visiting an inner node relative to testing one triangle (obvhs' collapse uses 3).
const TRAVERSAL_COST: f32 = 3.0;

/// Σ over triangles of their bounding box's half area, over the root box's half area.
///
/// A surface mesh of n small triangles scores about its own area over its box's (1–4 on the
/// shared meshes); n wedges sharing a hub score about n/10, since each wedge's box spans from
/// the hub to the rim.
pub fn box_overlap(tris: &[[Vec3; 3]]) -> f64 {
    let mut root = Aabb::empty();
    let mut sum = 0.0f64;
    for t in tris {
        let b = triangle_box(t);
        sum += f64::from(b.half_area());
        root = root.union(&b);
    }
    let root_area = f64::from(root.half_area());
    if root_area > 0.0 {
        sum / root_area
    } else {
        0.0
    }
}

fn triangle_box(t: &[Vec3; 3]) -> Aabb {
    let a = Vec3A::from(t[0]);
    let b = Vec3A::from(t[1]);
    let c = Vec3A::from(t[2]);
    Aabb::new(a.min(b).min(c), a.max(b).max(c))
}

/// Whether the mesh's triangles are shaped like fans: their boxes overlap more than
/// [`MAX_PLOC_BOX_OVERLAP`] or a vertex has more than [`MAX_PLOC_VALENCE`] triangles. Such a
/// mesh gets the binned-SAH tree, and queries near its fans visit O(n) triangles.
fn fan_shaped(mesh: &TriMesh, tris: &[[Vec3; 3]]) -> bool {
    box_overlap(tris) > MAX_PLOC_BOX_OVERLAP
        || max_valence(mesh.triangles(), mesh.vertex_count()) > MAX_PLOC_VALENCE
}

/// The same surface with its flat fans re-triangulated into well-shaped triangles
/// ([`sdfmo_mesh::retriangulate_flat_regions`] with the default settings), for a mesh whose
/// triangles are shaped like fans (the meshes that get the binned SAH); `None` for any other
/// mesh (every shared mesh: their results stay byte-identical) or when no flat region could be
/// replaced.
///
/// For callers that need only the surface (the octree builder, distances without faces, ray
/// hits): no axis-aligned box or winding-number dipole separates a fan's wedges, so near a fan
/// every query visits O(n) of them; after this they visit O(log n). Measured on a 50 000-wedge
/// disc and 50 000-segment fan-capped cylinders in docs/hardening.md. Triangle indices change.
pub fn reshape_fans(mesh: &TriMesh) -> Option<Retriangulated> {
    let tris: Vec<[Vec3; 3]> = (0..mesh.triangle_count())
        .map(|t| mesh.triangle(t))
        .collect();
    if !fan_shaped(mesh, &tris) {
        return None;
    }
    retriangulate_flat_regions(mesh, &FlatRegionSettings::default())
}

/// A built tree: obvhs' layout (node 0 the root, an inner node's children at `first_index` and
/// `first_index + 1`, a leaf's triangles at `primitive_indices[first_index..][..prim_count]`).
pub(crate) struct BuiltBvh {
    pub nodes: Vec<Bvh2Node>,
    pub primitive_indices: Vec<u32>,
    pub builder: BvhBuilder,
    /// The nodes in pre-order (parents before children).
    pub preorder: Vec<u32>,
    /// The tree's depth (a single leaf has depth 1).
    pub depth: usize,
}

impl BuiltBvh {
    fn new(nodes: Vec<Bvh2Node>, primitive_indices: Vec<u32>, builder: BvhBuilder) -> Self {
        let (preorder, depth) = preorder_and_depth(&nodes);
        BuiltBvh {
            nodes,
            primitive_indices,
            builder,
            preorder,
            depth,
        }
    }
}

/// Depth of a tree in obvhs' layout (a single leaf has depth 1), and its nodes in pre-order
/// (parents before children).
pub(crate) fn preorder_and_depth(nodes: &[Bvh2Node]) -> (Vec<u32>, usize) {
    let mut order = Vec::with_capacity(nodes.len());
    let mut depth = 0;
    let mut stack = vec![(0u32, 1usize)];
    while let Some((n, d)) = stack.pop() {
        order.push(n);
        depth = depth.max(d);
        let node = &nodes[n as usize];
        if node.prim_count == 0 {
            stack.push((node.first_index, d + 1));
            stack.push((node.first_index + 1, d + 1));
        }
    }
    (order, depth)
}

/// Most triangles sharing one vertex.
fn max_valence(triangles: &[[u32; 3]], vertex_count: usize) -> u32 {
    let mut valence = vec![0u32; vertex_count];
    for t in triangles {
        for &v in t {
            valence[v as usize] += 1;
        }
    }
    valence.into_iter().max().unwrap_or(0)
}

/// Builds the BVH of the mesh's triangles (`tris`, their corners in the mesh's order) with the
/// builder their shape calls for (module docs).
///
/// PLOC's input (obvhs' triangles, 48 bytes each) goes into the caller's `ploc_input`, so that
/// it is freed with the caller's other temporaries, after the long-lived arrays are allocated.
/// Freed here instead, before them, it changed glibc's heap layout so that each build's drop
/// trimmed the heap and the next build faulted it back in (220 `brk` calls instead of 35 over
/// 30 abc1 builds, as many as before this builder existed). The instructions are the same
/// either way; docs/hardening.md has the measurements and the cases this does not cover.
pub(crate) fn build(
    mesh: &TriMesh,
    tris: &[[Vec3; 3]],
    ploc_input: &mut Vec<Triangle>,
) -> BuiltBvh {
    if fan_shaped(mesh, tris) {
        return build_binned_sah(tris);
    }
    ploc_input.clear();
    ploc_input.extend(tris.iter().map(|t| Triangle {
        v0: t[0].into(),
        v1: t[1].into(),
        v2: t[2].into(),
    }));
    let mut build_time = Duration::ZERO;
    let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(
        ploc_input,
        BvhBuildParams::medium_build(),
        &mut build_time,
    );
    let built = BuiltBvh::new(bvh.nodes, bvh.primitive_indices, BvhBuilder::Ploc);
    if built.depth > crate::MAX_BVH_DEPTH {
        return build_binned_sah(tris);
    }
    built
}

/// One pending node of the top-down build.
struct Task {
    node: usize,
    start: usize,
    end: usize,
    depth: usize,
}

/// Top-down binned-SAH build (16 bins on each axis), median splits on the longest centroid axis
/// from depth [`SAH_DEPTH_BOUND`] on or wherever the SAH finds no split: O(n log n), depth at
/// most `SAH_DEPTH_BOUND + ⌈log₂ n⌉`.
pub(crate) fn build_binned_sah(tris: &[[Vec3; 3]]) -> BuiltBvh {
    let boxes: Vec<Aabb> = tris.iter().map(triangle_box).collect();
    let centroids: Vec<Vec3A> = boxes.iter().map(Aabb::center).collect();
    let mut indices: Vec<u32> = (0..tris.len() as u32).collect();
    let mut nodes = vec![Bvh2Node::new(Aabb::empty(), 0, 0)];
    let mut tasks = vec![Task {
        node: 0,
        start: 0,
        end: tris.len(),
        depth: 1,
    }];
    while let Some(task) = tasks.pop() {
        let range = &mut indices[task.start..task.end];
        let mut bounds = Aabb::empty();
        let mut centroid_bounds = Aabb::empty();
        for &i in range.iter() {
            bounds = bounds.union(&boxes[i as usize]);
            centroid_bounds.extend(centroids[i as usize]);
        }
        let n = range.len();
        let split = if n <= 1 || (task.depth >= SAH_DEPTH_BOUND && n <= MAX_LEAF_TRIANGLES) {
            None
        } else if task.depth >= SAH_DEPTH_BOUND {
            Some(median_split(range, &centroids, &centroid_bounds))
        } else {
            match sah_split(range, &boxes, &centroids, &centroid_bounds, &bounds) {
                SahChoice::Leaf if n <= MAX_LEAF_TRIANGLES => None,
                SahChoice::Split(mid) => Some(mid),
                _ => Some(median_split(range, &centroids, &centroid_bounds)),
            }
        };
        match split {
            None => nodes[task.node] = Bvh2Node::new(bounds, n as u32, task.start as u32),
            Some(mid) => {
                let first = nodes.len();
                nodes[task.node] = Bvh2Node::new(bounds, 0, first as u32);
                nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
                nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
                tasks.push(Task {
                    node: first + 1,
                    start: task.start + mid,
                    end: task.end,
                    depth: task.depth + 1,
                });
                tasks.push(Task {
                    node: first,
                    start: task.start,
                    end: task.start + mid,
                    depth: task.depth + 1,
                });
            }
        }
    }
    BuiltBvh::new(nodes, indices, BvhBuilder::BinnedSah)
}

enum SahChoice {
    /// Keeping the triangles in one leaf costs less than any split.
    Leaf,
    /// Split after this many triangles (the range has been partitioned).
    Split(usize),
    /// No plane separates the centroids (they coincide).
    None,
}

/// The cheapest of the 3 × 15 bin planes, or a leaf when that is cheaper (only considered for
/// ranges a leaf can hold). Partitions `range` when it splits.
fn sah_split(
    range: &mut [u32],
    boxes: &[Aabb],
    centroids: &[Vec3A],
    centroid_bounds: &Aabb,
    bounds: &Aabb,
) -> SahChoice {
    let extent = centroid_bounds.diagonal();
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, plane)
    for axis in 0..3 {
        if extent[axis].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let scale = SAH_BINS as f32 / extent[axis];
        let bin_of = |i: u32| {
            let b = ((centroids[i as usize][axis] - centroid_bounds.min[axis]) * scale) as usize;
            b.min(SAH_BINS - 1)
        };
        let mut bin_boxes = [Aabb::empty(); SAH_BINS];
        let mut bin_counts = [0usize; SAH_BINS];
        for &i in range.iter() {
            let b = bin_of(i);
            bin_boxes[b] = bin_boxes[b].union(&boxes[i as usize]);
            bin_counts[b] += 1;
        }
        // Right-to-left sweep: area × count of bins plane.. for each plane.
        let mut right_cost = [0.0f32; SAH_BINS];
        let mut acc = Aabb::empty();
        let mut count = 0;
        for plane in (1..SAH_BINS).rev() {
            acc = acc.union(&bin_boxes[plane]);
            count += bin_counts[plane];
            right_cost[plane] = if count > 0 {
                acc.half_area() * count as f32
            } else {
                f32::INFINITY
            };
        }
        let mut acc = Aabb::empty();
        let mut count = 0;
        for plane in 1..SAH_BINS {
            acc = acc.union(&bin_boxes[plane - 1]);
            count += bin_counts[plane - 1];
            if count == 0 {
                continue;
            }
            let cost = acc.half_area() * count as f32 + right_cost[plane];
            if cost.is_finite() && best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, plane));
            }
        }
    }
    let Some((cost, axis, plane)) = best else {
        return SahChoice::None;
    };
    let area = bounds.half_area();
    let split_cost = TRAVERSAL_COST + if area > 0.0 { cost / area } else { 0.0 };
    if range.len() <= MAX_LEAF_TRIANGLES && range.len() as f32 <= split_cost {
        return SahChoice::Leaf;
    }
    let scale = SAH_BINS as f32 / extent[axis];
    let left = partition(range, |i| {
        let b = ((centroids[i as usize][axis] - centroid_bounds.min[axis]) * scale) as usize;
        b.min(SAH_BINS - 1) < plane
    });
    if left == 0 || left == range.len() {
        return SahChoice::None;
    }
    SahChoice::Split(left)
}

/// Splits `range` at its middle by centroid on the longest centroid axis (by position when the
/// centroids coincide); returns the left half's length.
fn median_split(range: &mut [u32], centroids: &[Vec3A], centroid_bounds: &Aabb) -> usize {
    let mid = range.len() / 2;
    let extent = centroid_bounds.diagonal();
    if extent.max_element() > 0.0 {
        let axis = centroid_bounds.largest_axis();
        range.select_nth_unstable_by(mid, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
    }
    mid
}

/// Moves the elements satisfying `left` to the front; returns how many there are.
fn partition(range: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut first_right = 0;
    for k in 0..range.len() {
        if left(range[k]) {
            range.swap(first_right, k);
            first_right += 1;
        }
    }
    first_right
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A disc of `n` triangles sharing the hub at the origin.
    fn fan(n: usize) -> Vec<[Vec3; 3]> {
        (0..n)
            .map(|k| {
                let a0 = std::f32::consts::TAU * k as f32 / n as f32;
                let a1 = std::f32::consts::TAU * (k + 1) as f32 / n as f32;
                [
                    Vec3::ZERO,
                    Vec3::new(a0.cos(), a0.sin(), 0.0),
                    Vec3::new(a1.cos(), a1.sin(), 0.0),
                ]
            })
            .collect()
    }

    fn check_tree(bvh: &BuiltBvh, tris: &[[Vec3; 3]]) -> usize {
        let (order, depth) = preorder_and_depth(&bvh.nodes);
        assert_eq!(order.len(), bvh.nodes.len(), "every node reachable once");
        let mut seen = vec![false; tris.len()];
        for &n in &order {
            let node = &bvh.nodes[n as usize];
            if node.prim_count > 0 {
                for &p in
                    &bvh.primitive_indices[node.first_index as usize..][..node.prim_count as usize]
                {
                    assert!(!seen[p as usize]);
                    seen[p as usize] = true;
                    let b = triangle_box(&tris[p as usize]);
                    assert!(
                        node.aabb().union(&b) == *node.aabb(),
                        "leaf box holds its triangle"
                    );
                }
            } else {
                for c in [node.first_index, node.first_index + 1] {
                    let child = bvh.nodes[c as usize].aabb();
                    assert!(
                        node.aabb().union(child) == *node.aabb(),
                        "parent holds child"
                    );
                }
            }
        }
        assert!(seen.iter().all(|&s| s), "every triangle in one leaf");
        depth
    }

    #[test]
    fn fans_take_the_binned_sah_and_stay_shallow() {
        for n in [600, 5_000, 50_000] {
            let tris = fan(n);
            assert!(box_overlap(&tris) > MAX_PLOC_BOX_OVERLAP, "{n}");
            let bvh = build_binned_sah(&tris);
            let depth = check_tree(&bvh, &tris);
            assert!(depth <= SAH_DEPTH_BOUND + 20, "{n}: depth {depth}");
        }
    }

    #[test]
    fn coincident_triangles_split_by_position() {
        let tris = vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 1000];
        let bvh = build_binned_sah(&tris);
        let depth = check_tree(&bvh, &tris);
        assert!(depth <= 12, "depth {depth}");
    }

    #[test]
    fn a_grid_of_small_triangles_overlaps_little() {
        let mut tris = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                let p = Vec3::new(i as f32, j as f32, 0.0);
                tris.push([p, p + Vec3::X, p + Vec3::Y]);
            }
        }
        assert!(box_overlap(&tris) < 2.0);
    }
}
