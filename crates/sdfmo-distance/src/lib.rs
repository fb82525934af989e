//! Exact distances from points to a triangle mesh: closest points, signed distance with a robust
//! sign, distance to a subset of the triangles, and watertight ray hits.
//!
//! [`MeshDistance`] builds a BVH over the triangles once (obvhs' PLOC builder, `Bvh2`; a binned
//! SAH with a depth bound for fans and other meshes whose triangles' boxes nest, where PLOC
//! degenerates: [`BvhBuilder`]) and answers queries without allocating:
//!
//! - **Closest point**: obvhs' BVH2 collapsed into a 4-wide tree (four child boxes tested in one
//!   SIMD pass), best-first (nearest child first, subtrees pruned by their box distance, a
//!   stack sized to the tree's depth); each leaf's triangles go four at a time through a SIMD
//!   test of their boxes, then a branch-free SIMD copy of Ericson's Voronoi-region method, whose
//!   vertex and edge distances are the exact ones; the exact scalar test in f32, safe on
//!   degenerate triangles ([`closest_point_on_triangle`]), runs only on face-interior lanes that
//!   can win, and once for the winner.
//! - **Sign**: angle-weighted pseudo-normals (Bærentzen & Aanæs 2005) for closed, consistently
//!   oriented manifolds; the generalised winding number (Jacobson et al. 2013) with the
//!   hierarchical dipole approximation of Barill et al. 2018 for open or non-manifold meshes.
//!   [`SignMode::Auto`] picks pseudo-normals when the mesh is watertight and consistently
//!   oriented, the winding number otherwise. Signed distances are negative inside. In winding
//!   mode a query whose closest point lies in the face interior of a triangle far (relative to
//!   the query's distance) from every chain-boundary edge, in a BVH leaf probed to have winding
//!   number ≈ 0 in front and ≈ 1 behind and crossed by no other triangle, takes its sign from
//!   the face normal; the others run a coarse winding number (β = [`COARSE_WINDING_BETA`]) and the full one only when the coarse
//!   value is within [`COARSE_WINDING_MARGIN`] of ½. On the benchmark's 200 000 points (abc1
//!   and the bunny, near and uniform) the signs equal those of the full winding number.
//! - **Subsets**: [`MeshDistance::closest_point_in_subset`] and
//!   [`MeshDistance::signed_distance_in_subset`] scan a list of triangle indices (the builder's
//!   per-leaf components, typically 1–50 triangles) by brute force; the sign comes from the
//!   pseudo-normal of the closest feature computed with the adjacency of the whole mesh.
//! - **Rays**: [`MeshDistance::ray_hit`] and [`MeshDistance::ray_occluded`] use the watertight
//!   ray–triangle test of Woop, Benthin & Wald 2013: a ray through an edge or a vertex of a
//!   closed mesh never slips through.
//!
//! For callers with many queries close to the surface there are bounded and hinted variants
//! ([`MeshDistance::closest_point_within`], [`MeshDistance::closest_point_with_hint`]), which
//! prune the traversal from the start.
//!
//! ```
//! use glam::Vec3;
//! use sdfmo_distance::{MeshDistance, SignMode};
//! use sdfmo_mesh::procedural::box_mesh;
//!
//! let mesh = box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5));
//! let dist = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
//! assert_eq!(dist.sign_mode(), SignMode::PseudoNormal); // closed box
//! assert!((dist.signed_distance(Vec3::ZERO) + 0.5).abs() < 1e-6); // inside: negative
//! assert!((dist.signed_distance(Vec3::new(1.5, 0.0, 0.0)) - 1.0).abs() < 1e-6);
//! ```
#![deny(missing_docs)]

mod bvh4;
mod bvh_build;
mod closest;
mod point_triangle;
mod pseudo_normals;
mod ray;
mod ray_triangle;
pub mod sample;
mod segments;
mod sign;
mod subset;
mod triangle_packet;
mod winding;

use std::sync::OnceLock;

use glam::{Vec3, Vec3A, Vec4};
use obvhs::bvh2::node::Bvh2Node;
use rayon::prelude::*;
use sdfmo_mesh::{EdgeAdjacency, TriMesh};

pub use bvh_build::{
    box_overlap, reshape_fans, BvhBuilder, MAX_PLOC_BOX_OVERLAP, MAX_PLOC_VALENCE, SAH_DEPTH_BOUND,
};
pub use point_triangle::{closest_point_on_triangle, Feature};
pub use ray_triangle::WatertightRay;
pub use subset::{sign_by_pseudo_normal, triangle_boxes, TriangleSlices};
pub use winding::WINDING_BETA;

use bvh4::Bvh4;
use closest::LeafRecord;
pub use pseudo_normals::PseudoNormals;
use segments::SegmentTree;
use winding::{solid_angle, TriangleDipole, WindingNode};

/// Deepest BVH the fixed traversal stacks support. obvhs' PLOC trees over real meshes are far
/// shallower (≈ 2 log₂ n; 30–40 for 10⁵ triangles); a deeper PLOC tree is rebuilt with the
/// binned SAH, whose depth is at most [`SAH_DEPTH_BOUND`] + ⌈log₂ n⌉.
pub const MAX_BVH_DEPTH: usize = 128;

/// Largest coordinate of a query point in the normalised frame that the queries answer: they
/// work with squared distances in f32, which overflow (to an infinite distance and a NaN
/// winding number) beyond about 1.8e19. The CLI's `distance` and the Python package refuse
/// points farther out.
pub const MAX_QUERY_COORDINATE: f32 = 1e18;

/// β of the coarse first pass of the winding-number sign (see [`SignMode::Winding`]).
pub const COARSE_WINDING_BETA: f32 = 1.25;

/// A coarse winding number farther than this from ½ decides the sign without the full pass.
pub const COARSE_WINDING_MARGIN: f32 = 0.3;

/// Meshes with more chain-boundary edges (edges whose triangle orientations do not cancel) than
/// this take every winding sign from the winding number (no face-normal shortcut). It bounds
/// the memory of the edges' search tree (≈ 40 MB here); the time is O(n log n) in the edges.
/// Was 1024 while each triangle scanned every edge (O(triangles × edges)).
pub const MAX_CHAIN_BOUNDARY_EDGES: usize = 1 << 20;

/// A clean leaf's probes must give a winding number within this of 0 in front and 1 behind.
const CLEAN_PROBE_TOLERANCE: f32 = 0.2;

/// The face-normal shortcut applies to queries closer to the surface than this fraction of the
/// triangle's clean radius.
pub const CLEAN_DISTANCE_FRACTION: f32 = 0.1;

/// What the other triangles do around a BVH leaf, for the winding sign's face-normal shortcut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Surroundings {
    /// A triangle sharing no vertex with one of the leaf's crosses it (an edge of one through
    /// the other, watertight segment test): the winding levels change inside the leaf, so its
    /// probe does not speak for its triangles.
    Crossed,
    /// Nothing crosses the leaf, and its box holds triangles of its own component only.
    Clear,
    /// Nothing crosses the leaf, but its box holds a triangle of another connected component
    /// (or its own triangles belong to several): that shell may leave some of the leaf's
    /// triangles inside it without crossing them.
    OtherShellNear,
}

const COARSE_FAR_SCALE: f32 =
    (COARSE_WINDING_BETA / WINDING_BETA) * (COARSE_WINDING_BETA / WINDING_BETA);

/// Errors of [`MeshDistance::new`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DistanceError {
    /// The BVH is deeper than the traversal stacks allow.
    #[error("the BVH has depth {depth}, more than the supported {max}")]
    BvhTooDeep {
        /// Depth of the tree that was built.
        depth: usize,
        /// [`MAX_BVH_DEPTH`].
        max: usize,
    },
}

/// How the sign of a signed distance is decided.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SignMode {
    /// Pseudo-normals when the mesh is watertight and consistently oriented, winding number
    /// otherwise.
    #[default]
    Auto,
    /// Angle-weighted pseudo-normal of the closest feature (exact for closed manifolds).
    PseudoNormal,
    /// Generalised winding number > ½ means inside (robust for open and non-manifold meshes).
    Winding,
}

/// The closest point on the mesh (or on a subset of it) to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    /// The closest point on the surface.
    pub point: Vec3,
    /// Euclidean distance from the query to `point` (`f32::INFINITY` when nothing was found:
    /// an empty subset, or nothing within the bound of a bounded query).
    pub distance: f32,
    /// Index of the triangle `point` lies on (`u32::MAX` when nothing was found).
    pub triangle: u32,
    /// The feature of that triangle `point` lies on (vertex, edge or face interior).
    pub feature: Feature,
}

impl ClosestPoint {
    const NONE: ClosestPoint = ClosestPoint {
        point: Vec3::splat(f32::INFINITY),
        distance: f32::INFINITY,
        triangle: u32::MAX,
        feature: Feature::Face,
    };

    /// Whether a closest point was found.
    pub fn is_found(&self) -> bool {
        self.triangle != u32::MAX
    }
}

/// A ray–mesh hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Ray parameter of the hit: `origin + t·dir`.
    pub t: f32,
    /// Index of the triangle hit.
    pub triangle: u32,
    /// Unit geometric normal of that triangle, `(b − a) × (c − a)` normalised (not flipped
    /// towards the ray).
    pub normal: Vec3,
}

/// Distance queries against one triangle mesh. Immutable after construction, `Sync`: share it
/// across threads by reference.
pub struct MeshDistance {
    mesh: TriMesh,
    sign: SignMode,
    /// obvhs BVH2 nodes; node 0 is the root, inner nodes' children at `first_index` and
    /// `first_index + 1`, leaves cover `leaf_tris[first_index .. first_index + prim_count]`.
    nodes: Vec<Bvh2Node>,
    /// The same tree collapsed to four children per node (closest-point search).
    bvh4: Bvh4,
    /// Triangle corners in BVH leaf order.
    leaf_tris: Vec<[Vec3; 3]>,
    /// Per leaf slot, one cache line holding everything the closest-point search reads.
    leaf_records: Vec<LeafRecord>,
    /// Original triangle index per leaf slot.
    leaf_ids: Vec<u32>,
    /// Triangle corners in the mesh's order (subset queries).
    tris: Vec<[Vec3; 3]>,
    /// Their bounding boxes (subset queries).
    tri_boxes: Vec<(Vec3, Vec3)>,
    normals: PseudoNormals,
    winding: Vec<WindingNode>,
    /// Per leaf slot: the triangle's own far-field data (centroid, (β·r)², area normal), so a
    /// triangle of a near leaf that is itself far enough is taken as one dipole.
    leaf_dipoles: Vec<TriangleDipole>,
    /// Per triangle (mesh order), winding mode only: the radius of its "clean" neighbourhood
    /// (see [`MeshDistance::clean_winding_radii`]), 0 where the shortcut does not apply;
    /// computed on the first signed query that needs it.
    clean_radius: OnceLock<Vec<f32>>,
    depth: usize,
    builder: BvhBuilder,
}

/// Spreads the low 10 bits of `v` to every third bit.
fn spread_bits(v: u32) -> u32 {
    let mut x = v & 0x3ff;
    x = (x | (x << 16)) & 0x0300_00ff;
    x = (x | (x << 8)) & 0x0300_f00f;
    x = (x | (x << 4)) & 0x030c_30c3;
    x = (x | (x << 2)) & 0x0924_9249;
    x
}

/// Indices of `points` sorted by their 30-bit Morton code in the points' bounding box
/// (non-finite points last, in their original order).
fn morton_order(points: &[Vec3]) -> Vec<usize> {
    let (lo, hi) = points
        .iter()
        .filter(|p| p.is_finite())
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let ext = (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
    let scale = Vec3::splat(1023.0) / ext;
    let mut keyed: Vec<(u32, usize)> = points
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            if !p.is_finite() {
                return (u32::MAX, i);
            }
            let q = ((p - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(1023.0));
            let code = spread_bits(q.x as u32)
                | (spread_bits(q.y as u32) << 1)
                | (spread_bits(q.z as u32) << 2);
            (code, i)
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

impl MeshDistance {
    /// Builds the BVH, the pseudo-normals and the winding-number tree of `mesh` (which is
    /// copied). `SignMode::Auto` is resolved here from the mesh's topology.
    pub fn new(mesh: &TriMesh, sign: SignMode) -> Result<MeshDistance, DistanceError> {
        let tris: Vec<[Vec3; 3]> = mesh
            .triangles()
            .iter()
            .map(|t| t.map(|i| mesh.positions()[i as usize]))
            .collect();
        let mut ploc_input = Vec::new();
        let built = bvh_build::build(mesh, &tris, &mut ploc_input);
        let nodes = built.nodes;
        let leaf_ids = built.primitive_indices;
        let builder = built.builder;
        let leaf_tris: Vec<[Vec3; 3]> = leaf_ids.iter().map(|&i| tris[i as usize]).collect();
        let leaf_records: Vec<LeafRecord> = leaf_tris
            .iter()
            .zip(&leaf_ids)
            .map(|(t, &id)| {
                let c = (t[0].min(t[1]).min(t[2]) + t[0].max(t[1]).max(t[2])) * 0.5;
                let r = t.iter().map(|v| (*v - c).length()).fold(0.0f32, f32::max);
                let rotation = point_triangle::apex_rotation(t[0], t[1], t[2]);
                let k = rotation as usize;
                LeafRecord {
                    // Inflated a little so rounding never skips the triangle that attains the
                    // minimum.
                    sphere: c.extend(r * (1.0 + 1e-5) + 1e-7),
                    corners: [t[k], t[(k + 1) % 3], t[(k + 2) % 3]],
                    id,
                    rotation,
                }
            })
            .collect();

        let (order, depth) = (built.preorder, built.depth);
        if depth > MAX_BVH_DEPTH {
            return Err(DistanceError::BvhTooDeep {
                depth,
                max: MAX_BVH_DEPTH,
            });
        }
        let winding = winding::build_winding_nodes(&nodes, &leaf_tris, &order);
        let leaf_dipoles = leaf_tris.iter().map(TriangleDipole::new).collect();
        let normals = PseudoNormals::new(mesh.positions(), mesh.triangles());
        let sign = match sign {
            SignMode::Auto => {
                if normals.closed_and_oriented && mesh.topology().watertight {
                    SignMode::PseudoNormal
                } else {
                    SignMode::Winding
                }
            }
            s => s,
        };
        let corners: Vec<[Vec3; 3]> = leaf_records.iter().map(|r| r.corners).collect();
        let bvh4 = Bvh4::from_bvh2(&nodes, &corners);

        Ok(MeshDistance {
            mesh: mesh.clone(),
            sign,
            nodes,
            bvh4,
            leaf_tris,
            leaf_records,
            leaf_ids,
            tri_boxes: subset::triangle_boxes(&tris),
            tris,
            normals,
            winding,
            leaf_dipoles,
            clean_radius: OnceLock::new(),
            depth,
            builder,
        })
    }

    /// For the winding-number sign near the surface: per triangle, the radius within which a
    /// query whose closest point lies in the triangle's face interior may take its sign from
    /// the face normal instead of the winding number (0: never).
    ///
    /// The winding number is piecewise constant, jumping by exactly 1 across a sheet, except for
    /// a smooth part that depends only on the mesh's *chain boundary*: the edges whose
    /// orientations do not cancel (boundary edges of open meshes, unbalanced non-manifold
    /// edges). Per BVH leaf, its largest triangle is probed just in front of and just behind
    /// its centroid with the coarse winding number; the leaf is clean when that gives ≈ 0 in
    /// front and ≈ 1 behind (a locally closed, outward surface with the usual levels), no
    /// triangle sharing no vertex with it crosses it (self-intersections change the levels).
    /// Each triangle of a clean leaf not facing against the probed one (unit normals' dot
    /// product > −0.25) gets as radius the distance from its centroid to the nearest
    /// chain-boundary edge minus its own circumradius about the centroid; where another shell
    /// comes near the leaf ([`Surroundings::OtherShellNear`]) only if its own probe shows the
    /// usual levels too. Meshes with more than [`MAX_CHAIN_BOUNDARY_EDGES`] such edges get no shortcut.
    fn clean_winding_radii(&self) -> Vec<f32> {
        let tris = self.mesh.triangles();
        let positions = self.mesh.positions();
        let adjacency = EdgeAdjacency::of(&self.mesh);
        let (component, _) = adjacency.components(tris.len(), false);
        let mut chain = Vec::new();
        for [a, b] in adjacency.chain_boundary(tris) {
            chain.push((positions[a as usize], positions[b as usize]));
            if chain.len() > MAX_CHAIN_BOUNDARY_EDGES {
                return vec![0.0; tris.len()];
            }
        }
        let chain = SegmentTree::new(chain);
        let leaves: Vec<&Bvh2Node> = self.nodes.iter().filter(|n| n.prim_count > 0).collect();
        let per_leaf: Vec<Vec<(u32, f32)>> = leaves
            .par_iter()
            .map(|node| {
                let range =
                    node.first_index as usize..(node.first_index + node.prim_count) as usize;
                let Some(n) = self.leaf_is_clean(&self.leaf_tris[range.clone()]) else {
                    return Vec::new();
                };
                let other_shell_near = match self.leaf_surroundings(node, range.clone(), &component)
                {
                    Surroundings::Crossed => return Vec::new(),
                    Surroundings::Clear => false,
                    Surroundings::OtherShellNear => true,
                };
                range
                    .filter_map(|slot| {
                        let t = &self.leaf_tris[slot];
                        // Only triangles facing roughly the probed way share its two levels.
                        // Near another shell each is probed itself: that shell can cross the
                        // surface between two triangles of the leaf without crossing either
                        // (through other leaves' triangles), leaving one of them inside it.
                        if (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero().dot(n) <= -0.25
                            || other_shell_near && self.has_usual_levels(t).is_none()
                        {
                            return None;
                        }
                        let c = (t[0] + t[1] + t[2]) / 3.0;
                        let rad = t.iter().map(|v| (*v - c).length()).fold(0.0f32, f32::max);
                        let to_chain = chain.nearest_distance(c);
                        Some((self.leaf_ids[slot], (to_chain - rad).max(0.0)))
                    })
                    .collect()
            })
            .collect();
        let mut out = vec![0.0f32; tris.len()];
        for (id, r) in per_leaf.into_iter().flatten() {
            out[id as usize] = r;
        }
        out
    }

    /// What the other triangles do around a leaf (slots `range`, box of `leaf`; `component`:
    /// connected component per triangle), see [`Surroundings`].
    fn leaf_surroundings(
        &self,
        leaf: &Bvh2Node,
        range: std::ops::Range<usize>,
        component: &[u32],
    ) -> Surroundings {
        let lb = leaf.aabb();
        let own = component[self.leaf_ids[range.start] as usize];
        let mut other_shell_near = range
            .clone()
            .any(|slot| component[self.leaf_ids[slot] as usize] != own);
        let overlaps = |n: &Bvh2Node| {
            let b = n.aabb();
            b.min.cmple(lb.max).all() && lb.min.cmple(b.max).all()
        };
        let crosses = |s: &[Vec3; 3], t: &[Vec3; 3]| {
            (0..3).any(|k| {
                let (e0, e1) = (s[k], s[(k + 1) % 3]);
                WatertightRay::new(e0, e1 - e0)
                    .and_then(|r| r.intersect(t[0], t[1], t[2], 0.0, 1.0))
                    .is_some()
            })
        };
        let apart = |t: &[Vec3; 3], o: &[Vec3; 3]| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            let d = o.map(|v| n.dot(v - t[0]));
            d.iter().all(|&x| x > 0.0) || d.iter().all(|&x| x < 0.0)
        };
        let mut stack = vec![0usize];
        while let Some(ni) = stack.pop() {
            let node = &self.nodes[ni];
            if !overlaps(node) {
                continue;
            }
            if node.prim_count == 0 {
                stack.push(node.first_index as usize);
                stack.push(node.first_index as usize + 1);
                continue;
            }
            let start = node.first_index as usize;
            for other in start..start + node.prim_count as usize {
                let oi = self.mesh.triangles()[self.leaf_ids[other] as usize];
                let ot = &self.leaf_tris[other];
                if !other_shell_near && component[self.leaf_ids[other] as usize] != own {
                    let (lo, hi) = (ot[0].min(ot[1]).min(ot[2]), ot[0].max(ot[1]).max(ot[2]));
                    other_shell_near =
                        lo.cmple(lb.max.into()).all() && Vec3::from(lb.min).cmple(hi).all();
                }
                for slot in range.clone() {
                    if slot == other {
                        continue;
                    }
                    let li = self.mesh.triangles()[self.leaf_ids[slot] as usize];
                    if li.iter().any(|v| oi.contains(v)) {
                        continue;
                    }
                    let lt = &self.leaf_tris[slot];
                    // Early out (Möller 1997): one triangle strictly on one side of the
                    // other's plane cannot cross it.
                    if apart(lt, ot) || apart(ot, lt) {
                        continue;
                    }
                    if crosses(ot, lt) || crosses(lt, ot) {
                        return Surroundings::Crossed;
                    }
                }
            }
        }
        if other_shell_near {
            Surroundings::OtherShellNear
        } else {
            Surroundings::Clear
        }
    }

    /// Computes the one-time data of the sign now (in winding mode, the per-triangle radii of
    /// the face-normal shortcut, in parallel) instead of in the first signed query that needs
    /// it; for timing a build, or before handing the structure to many threads. Idempotent.
    pub fn prepare_sign(&self) {
        if self.sign == SignMode::Winding {
            self.clean_radii();
        }
    }

    /// The per-triangle radii of the winding mode's face-normal shortcut, computed on first use.
    fn clean_radii(&self) -> &[f32] {
        self.clean_radius.get_or_init(|| self.clean_winding_radii())
    }

    /// The unit normal of the largest triangle of a leaf if that triangle has the usual levels
    /// ([`has_usual_levels`](Self::has_usual_levels); the leaf is clean, see
    /// [`clean_winding_radii`](Self::clean_winding_radii)), else `None`.
    fn leaf_is_clean(&self, tris: &[[Vec3; 3]]) -> Option<Vec3> {
        let area = |t: &&[Vec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).length();
        let big = tris.iter().max_by(|a, b| area(a).total_cmp(&area(b)))?;
        self.has_usual_levels(big)
    }

    /// The unit normal of triangle `t` if the coarse winding number is ≈ 0 just in front of its
    /// centroid and ≈ 1 just behind (a locally closed, outward surface), else `None`.
    fn has_usual_levels(&self, t: &[Vec3; 3]) -> Option<Vec3> {
        let area_normal = (t[1] - t[0]).cross(t[2] - t[0]);
        let n = area_normal.normalize_or_zero();
        if n == Vec3::ZERO {
            return None;
        }
        let c = (t[0] + t[1] + t[2]) / 3.0;
        // 5 % of the triangle's smallest height, at least 1e-5 (far above f32 rounding in the
        // normalised frame), so the probes lie on either side of the plane.
        let longest = (t[1] - t[0])
            .length()
            .max((t[2] - t[1]).length())
            .max((t[0] - t[2]).length());
        let eps = (0.05 * area_normal.length() / longest).max(1e-5);
        // The back probe only where the front one passes (the same answer, one winding number
        // fewer on a rejected triangle).
        let front = self.winding_number_scaled(c + n * eps, COARSE_FAR_SCALE);
        let front_passes = front.abs() <= CLEAN_PROBE_TOLERANCE; // (false for NaN)
        if !front_passes {
            return None;
        }
        let back = self.winding_number_scaled(c - n * eps, COARSE_FAR_SCALE);
        ((back - 1.0).abs() <= CLEAN_PROBE_TOLERANCE).then_some(n)
    }

    /// The mesh the queries run against.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// The sign mode in use (resolved: never `Auto`).
    pub fn sign_mode(&self) -> SignMode {
        self.sign
    }

    /// Depth of the BVH (a single leaf has depth 1).
    pub fn bvh_depth(&self) -> usize {
        self.depth
    }

    /// Number of BVH nodes.
    pub fn bvh_node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Which builder made the BVH (PLOC, or the binned SAH for fans and the like).
    pub fn bvh_builder(&self) -> BvhBuilder {
        self.builder
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sdfmo_mesh::TriMesh;

    #[test]
    fn morton_order_is_a_permutation_that_groups_nearby_points() {
        // Two clusters interleaved in the input; non-finite points go last.
        let mut pts = Vec::new();
        for i in 0..300 {
            let f = i as f32 * 1e-3;
            pts.push(Vec3::new(f, f, f));
            pts.push(Vec3::new(10.0 + f, 10.0, 10.0 - f));
        }
        pts.push(Vec3::NAN);
        let order = morton_order(&pts);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..pts.len()).collect::<Vec<_>>());
        assert_eq!(*order.last().unwrap(), pts.len() - 1);
        // The first half of the order is one cluster, the second half the other.
        let first_cluster = order[..300].iter().all(|&i| i % 2 == order[0] % 2);
        assert!(first_cluster, "{:?}", &order[..20]);
        assert_eq!(spread_bits(0x3ff), 0x0924_9249);
    }

    #[test]
    fn map_points_answers_in_the_callers_order() {
        // 1,001 shuffled points (one NaN) around a sphere: each answer is the one-point query's,
        // bit for bit, at the caller's index, whatever order the batch visited them in.
        let sphere = sdfmo_mesh::procedural::sphere(Vec3::ZERO, 0.5, 3);
        let md = MeshDistance::new(&sphere, SignMode::Winding).unwrap();
        let mut next = uniform_stream(11, 2.0, 1.0);
        let mut pts: Vec<Vec3> = (0..1000)
            .map(|_| Vec3::new(next(), next(), next()))
            .collect();
        pts.insert(500, Vec3::NAN);
        let got = md.map_points(&pts, |md, p| {
            let c = md.closest_point(p);
            (
                c.distance.to_bits(),
                c.triangle,
                md.winding_number(p).to_bits(),
            )
        });
        assert_eq!(got.len(), pts.len());
        for (&p, g) in pts.iter().zip(&got) {
            let c = md.closest_point(p);
            assert_eq!(
                *g,
                (
                    c.distance.to_bits(),
                    c.triangle,
                    md.winding_number(p).to_bits()
                ),
                "{p:?}"
            );
        }
        let signed = md.signed_distances(&pts);
        for (&p, &d) in pts.iter().zip(&signed) {
            assert_eq!(d.to_bits(), md.signed_distance(p).to_bits(), "{p:?}");
        }
    }

    /// A reproducible stream of values `u · scale − offset`, u uniform in [0, 1) (the project's
    /// `SplitMix64`).
    fn uniform_stream(seed: u64, scale: f32, offset: f32) -> impl FnMut() -> f32 {
        let mut rng = sdfmo_io::SplitMix64::new(seed);
        move || rng.next_f32() * scale - offset
    }

    #[test]
    fn two_stage_winding_sign_matches_the_full_winding_number() {
        // An open sheet (w ≈ ±½ near its rim) and a closed sphere: wherever the full hierarchical
        // winding number is not within 0.02 of ½, the two-stage sign agrees with it.
        for mesh in [
            sdfmo_mesh::procedural::open_sheet(1.0, 0.8, 24),
            sdfmo_mesh::procedural::sphere(Vec3::ZERO, 0.5, 3),
        ] {
            let md = MeshDistance::new(&mesh, SignMode::Winding).unwrap();
            let mut next = uniform_stream(7, 1.6, 0.8);
            let mut near_half = 0;
            for _ in 0..3000 {
                let p = Vec3::new(next(), next() * 0.2, next());
                let full = md.winding_number(p);
                if (full - 0.5).abs() < 0.02 {
                    near_half += 1;
                    continue;
                }
                assert_eq!(md.winding_inside(p), full > 0.5, "p {p:?}, w {full}");
                // The whole signed query (face-normal shortcut included) agrees too.
                assert_eq!(md.signed_distance(p) < 0.0, full > 0.5, "p {p:?}, w {full}");
            }
            assert!(near_half < 300);
        }
    }

    /// The cube [-h, h]³ without its face at `+h` along `axis`.
    fn open_box(h: f32, axis: usize) -> TriMesh {
        let (p, mut tris, mut parts) =
            sdfmo_mesh::procedural::box_mesh(Vec3::splat(-h), Vec3::splat(h)).into_arrays();
        tris.retain(|t| !t.iter().all(|&i| p[i as usize][axis] > h - 0.01));
        parts.truncate(tris.len());
        TriMesh::new(p, tris, parts).unwrap()
    }

    #[test]
    fn clean_radii_follow_the_chain_boundary() {
        // Closed sphere: no chain boundary, every triangle clean with an unbounded radius.
        let sphere = sdfmo_mesh::procedural::sphere(Vec3::ZERO, 0.5, 3);
        let md = MeshDistance::new(&sphere, SignMode::Winding).unwrap();
        assert!(md.clean_winding_radii().iter().all(|r| r.is_infinite()));
        // Open sheet: w is ±½ on either side, so no leaf is clean.
        let sheet = sdfmo_mesh::procedural::open_sheet(1.0, 0.8, 24);
        let md = MeshDistance::new(&sheet, SignMode::Winding).unwrap();
        assert!(md.clean_winding_radii().iter().all(|&r| r == 0.0));
        // A box without its top face: triangles far from the rim are clean, with radii no
        // larger than their distance to the rim (the top edges at y = 0.5).
        let open_box = open_box(0.5, 1);
        let p = open_box.positions();
        assert!(open_box.triangles().len() < 12);
        let md = MeshDistance::new(&open_box, SignMode::Winding).unwrap();
        let radii = md.clean_winding_radii();
        for (t, &r) in open_box.triangles().iter().zip(&radii) {
            let lowest = t
                .iter()
                .map(|&i| p[i as usize].y)
                .fold(f32::INFINITY, f32::min);
            assert!(
                r <= 0.5 - lowest + 1e-5,
                "radius {r} for a triangle reaching y = {lowest}"
            );
        }
    }

    /// Found in session 7 when the points of the test below came from another generator: a
    /// leaf passed the probe and the crossing test while one of its triangles lay inside the
    /// other sphere (the curve where the spheres cross runs through triangles of *other*
    /// leaves), so a point 0.031 in front of that triangle, inside the other sphere (winding
    /// number 0.976), took the outside sign from the face normal. Now, near another shell, each
    /// triangle of a clean leaf is probed itself.
    #[test]
    fn shortcut_sign_inside_an_overlapping_shell() {
        let a = sdfmo_mesh::procedural::sphere(Vec3::new(-0.2, 0.0, 0.0), 0.4, 3);
        let b = sdfmo_mesh::procedural::sphere(Vec3::new(0.2, 0.05, 0.0), 0.35, 3);
        let md = MeshDistance::new(&TriMesh::merge(&[a, b]), SignMode::Winding).unwrap();
        let q = Vec3::new(0.016013017, -0.28269655, -0.0080042);
        let w = md.winding_number(q);
        assert!(w > 0.9, "w {w}");
        assert!(md.signed_distance(q) < 0.0, "w {w}, but signed outside");
    }

    #[test]
    fn shortcut_signs_match_the_winding_number_on_overlapping_and_open_shells() {
        // Self-intersections leave no chain boundary, so only the probes guard the shortcut:
        // two overlapping spheres (w = 2 in the overlap), a sphere overlapping an open box, and
        // points within 0.03 of the surface.
        let a = sdfmo_mesh::procedural::sphere(Vec3::new(-0.2, 0.0, 0.0), 0.4, 3);
        let b = sdfmo_mesh::procedural::sphere(Vec3::new(0.2, 0.05, 0.0), 0.35, 3);
        let open_box = open_box(0.3, 0);
        for mesh in [
            TriMesh::merge(&[a, b.clone()]),
            TriMesh::merge(&[b, open_box]),
        ] {
            let md = MeshDistance::new(&mesh, SignMode::Winding).unwrap();
            let mut next = uniform_stream(11, 2.0, 1.0);
            let radii = md.clean_winding_radii();
            let (mut compared, mut shortcut) = (0, 0);
            for t in mesh.triangles().iter().step_by(3) {
                let c = t
                    .iter()
                    .map(|&i| mesh.positions()[i as usize])
                    .sum::<Vec3>()
                    / 3.0;
                let q = c + Vec3::new(next(), next(), next()) * 0.03;
                let full = md.winding_number(q);
                if (full - 0.5).abs() < 0.05 {
                    continue;
                }
                compared += 1;
                let cp = md.closest_point(q);
                if cp.feature == Feature::Face
                    && cp.distance < radii[cp.triangle as usize] * CLEAN_DISTANCE_FRACTION
                {
                    shortcut += 1;
                }
                assert_eq!(md.signed_distance(q) < 0.0, full > 0.5, "q {q:?}, w {full}");
            }
            // The shortcut is exercised (not every leaf is crossed or near the rim).
            assert!(
                compared > 100 && shortcut > compared / 10,
                "{compared} {shortcut}"
            );
        }
    }
}
