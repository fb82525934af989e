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
mod clean;
mod closest;
mod point_triangle;
mod pseudo_normals;
mod ray;
mod ray_triangle;
pub mod sample;
mod segments;
mod sign;
mod subset;
#[cfg(test)]
mod test_points;
mod triangle_packet;
mod winding;

use std::sync::OnceLock;

use glam::{Vec3, Vec3A, Vec4};
use obvhs::bvh2::node::Bvh2Node;
use rayon::prelude::*;
use sdfmo_mesh::{EdgeAdjacency, Topology, TriMesh};

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
use winding::{solid_angle, WindingNode, WindingPacket};

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

/// The face-normal shortcut applies to queries closer to the surface than this fraction of the
/// triangle's clean radius.
pub const CLEAN_DISTANCE_FRACTION: f32 = 0.1;

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
    /// The winding tree's leaves' triangles, four per packet, with each triangle's own
    /// far-field data (centroid, (β·r)², area normal), so a triangle of a near leaf that is
    /// itself far enough is taken as one dipole.
    winding_packets: Vec<WindingPacket>,
    /// Winding mode only: the chain boundary and components the clean radii are made from
    /// (`None` in pseudo-normal mode and past [`MAX_CHAIN_BOUNDARY_EDGES`]).
    chain_boundary: Option<clean::ChainBoundary>,
    /// Winding mode only: the radii of the triangles' "clean" neighbourhoods (see
    /// [`clean`](mod@clean)), each BVH leaf's made by the first signed query that needs them.
    clean_radius: OnceLock<clean::CleanRadii>,
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
        let (winding, winding_packets) = winding::build_winding_nodes(&nodes, &leaf_tris, &order);
        // One edge adjacency for the pseudo-normals, the watertightness and the winding
        // sign's chain boundary (each built its own before: three sorts of 3 records per
        // triangle on a closed mesh, the third in the first signed query on an open one).
        let adjacency = EdgeAdjacency::of(mesh);
        let normals = PseudoNormals::with_adjacency(mesh.positions(), mesh.triangles(), &adjacency);
        let sign = match sign {
            SignMode::Auto => {
                if normals.closed_and_oriented
                    && Topology::from_adjacency(mesh.triangle_count(), &adjacency).watertight
                {
                    SignMode::PseudoNormal
                } else {
                    SignMode::Winding
                }
            }
            s => s,
        };
        let chain_boundary = (sign == SignMode::Winding)
            .then(|| clean::ChainBoundary::new(mesh, &adjacency))
            .flatten();
        drop(adjacency);
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
            winding_packets,
            chain_boundary,
            clean_radius: OnceLock::new(),
            depth,
            builder,
        })
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

    #[test]
    fn avx_builds_answer_like_the_generic_code() {
        // The AVX-compiled closest-point search and winding number (taken on CPUs with AVX)
        // give the generic code's bits: closest points near and far from an open sheet and a
        // sphere, and the winding number at both of the sign's accuracies.
        for md in sheet_and_sphere() {
            let mut next = uniform_stream(5, 2.4, 1.2);
            for i in 0..2000 {
                let scale = if i % 2 == 0 { 1.0 } else { 0.05 };
                let p = Vec3::new(next(), next(), next()) * scale;
                let c = md.closest_point(p);
                let g = md.closest_bounded_any(p, f32::INFINITY, ClosestPoint::NONE);
                assert_eq!(
                    (
                        c.distance.to_bits(),
                        c.triangle,
                        c.feature,
                        c.point.to_array()
                    ),
                    (
                        g.distance.to_bits(),
                        g.triangle,
                        g.feature,
                        g.point.to_array()
                    ),
                    "{p:?}"
                );
                for s in [1.0, COARSE_FAR_SCALE] {
                    assert_eq!(
                        md.winding_number_scaled(p, s).to_bits(),
                        md.winding_number_scaled_any(p, s).to_bits(),
                        "{p:?}"
                    );
                }
            }
        }
    }

    /// An open sheet (w ≈ ±½ near its rim) and a closed sphere, with the winding sign.
    fn sheet_and_sphere() -> [MeshDistance; 2] {
        [
            sdfmo_mesh::procedural::open_sheet(1.0, 0.8, 24),
            sdfmo_mesh::procedural::sphere(Vec3::ZERO, 0.5, 3),
        ]
        .map(|mesh| MeshDistance::new(&mesh, SignMode::Winding).unwrap())
    }

    /// A reproducible stream of values `u · scale − offset`, u uniform in [0, 1) (the project's
    /// `SplitMix64`).
    pub(crate) fn uniform_stream(seed: u64, scale: f32, offset: f32) -> impl FnMut() -> f32 {
        let mut rng = sdfmo_io::SplitMix64::new(seed);
        move || rng.next_f32() * scale - offset
    }

    #[test]
    fn two_stage_winding_sign_matches_the_full_winding_number() {
        // An open sheet (w ≈ ±½ near its rim) and a closed sphere: wherever the full hierarchical
        // winding number is not within 0.02 of ½, the two-stage sign agrees with it.
        for md in sheet_and_sphere() {
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
}
