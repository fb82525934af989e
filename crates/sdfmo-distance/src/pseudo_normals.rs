//! Angle-weighted pseudo-normals (Bærentzen & Aanæs, "Signed distance computation using the
//! angle weighted pseudonormal", IEEE TVCG 2005).
//!
//! For a closed, consistently oriented 2-manifold, the sign of (p − q) · n, with q the closest
//! point on the surface and n the pseudo-normal of the feature q lies on, is the sign of the
//! distance: the face normal for a face interior, the sum of the two incident face normals for an
//! edge, and the sum of the incident face normals weighted by their angle at the vertex for a
//! vertex. The face normal of the closest triangle alone (what the reference code uses) gives
//! wrong signs near edges and vertices.
//!
//! Edges are identified by the (welded) vertex indices of the mesh (grouped by the mesh layer's
//! `EdgeAdjacency`), so adjacency is that of the
//! whole mesh even when a query is restricted to a subset of triangles.

use glam::{DVec3, Vec3};
use sdfmo_mesh::EdgeAdjacency;

use crate::point_triangle::Feature;

/// Pseudo-normals of every face, edge and vertex, plus what the edge pass learnt about the
/// topology. Computed in f64 (face normals from the f64 cross product, vertex angles from
/// `atan2`, robust for needles and obtuse corners) and stored in f32. The builder's per-leaf
/// signs use these too, so a fix here is a fix everywhere.
#[derive(Clone, Debug)]
pub struct PseudoNormals {
    /// Unit face normal per triangle (zero for zero-area triangles).
    pub face: Vec<Vec3>,
    /// Edge pseudo-normal per triangle and local edge k (v_k → v_{k+1}).
    pub edge: Vec<[Vec3; 3]>,
    /// Angle-weighted vertex pseudo-normal per vertex.
    pub vertex: Vec<Vec3>,
    /// Every edge has exactly two incident triangles that traverse it in opposite directions.
    pub closed_and_oriented: bool,
}

impl PseudoNormals {
    /// Computes the pseudo-normals of the triangles over `positions`; edges are shared through
    /// equal vertex indices (weld first).
    ///
    /// # Panics
    /// When an index is out of range (a `TriMesh`'s arrays are always in range).
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> PseudoNormals {
        PseudoNormals::with_adjacency(
            positions,
            triangles,
            &EdgeAdjacency::of_triangles(triangles),
        )
    }

    /// As [`PseudoNormals::new`], with the edge adjacency of `triangles` already built (the
    /// mesh layer's [`EdgeAdjacency::of_triangles`] of the same triangles), so a caller that
    /// needs it for other flags too builds it once.
    ///
    /// # Panics
    /// When an index is out of range, or `adjacency` is of other triangles.
    pub fn with_adjacency(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        adjacency: &EdgeAdjacency,
    ) -> PseudoNormals {
        let mut face = Vec::with_capacity(triangles.len());
        let mut vertex = vec![DVec3::ZERO; positions.len()];
        for t in triangles {
            let p = t.map(|i| positions[i as usize].as_dvec3());
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            face.push(n.as_vec3());
            for k in 0..3 {
                let e1 = p[(k + 1) % 3] - p[k];
                let e2 = p[(k + 2) % 3] - p[k];
                // atan2 of |e1 × e2| and e1 · e2: robust for needles and obtuse corners.
                let angle = e1.cross(e2).length().atan2(e1.dot(e2));
                vertex[t[k] as usize] += angle * n;
            }
        }
        // Edges: the sum of the incident faces' normals, in ascending triangle order. An edge
        // with a repeated vertex is no edge (the adjacency skips it): it belongs to a zero-area
        // triangle, whose face normal is zero, so its pseudo-normal stays zero, and the mesh
        // is not a closed 2-manifold.
        let mut edge = vec![[Vec3::ZERO; 3]; triangles.len()];
        let mut closed_and_oriented = triangles
            .iter()
            .all(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0]);
        for e in 0..adjacency.edge_count() {
            let (tris, slots) = (adjacency.triangles_of(e), adjacency.slots_of(e));
            let mut sum = Vec3::ZERO;
            for &t in tris {
                sum += face[t as usize];
            }
            for (&t, &k) in tris.iter().zip(slots) {
                edge[t as usize][k as usize] = sum;
            }
            // Two incident triangles traversing the edge in opposite directions start it at
            // different vertices.
            let start = |i: usize| triangles[tris[i] as usize][slots[i] as usize];
            if tris.len() != 2 || start(0) == start(1) {
                closed_and_oriented = false;
            }
        }
        PseudoNormals {
            face,
            edge,
            vertex: vertex.into_iter().map(|v| v.as_vec3()).collect(),
            closed_and_oriented,
        }
    }

    /// The pseudo-normal of `feature` of triangle `tri` (with vertex indices `idx`).
    #[inline]
    pub fn normal(&self, tri: usize, idx: [u32; 3], feature: Feature) -> Vec3 {
        match feature {
            Feature::Face => self.face[tri],
            Feature::Edge(k) => self.edge[tri][k as usize],
            Feature::Vertex(k) => self.vertex[idx[k as usize] as usize],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sdfmo_mesh::procedural::{box_mesh, open_sheet};

    #[test]
    fn closed_box_edges_sum_their_two_faces() {
        let m = box_mesh(Vec3::ZERO, Vec3::ONE);
        let n = PseudoNormals::new(m.positions(), m.triangles());
        assert!(n.closed_and_oriented);
        let adj = EdgeAdjacency::of(&m);
        for e in 0..adj.edge_count() {
            let (tris, slots) = (adj.triangles_of(e), adj.slots_of(e));
            let sum = n.face[tris[0] as usize] + n.face[tris[1] as usize];
            for (&t, &k) in tris.iter().zip(slots) {
                assert_eq!(n.edge[t as usize][k as usize], sum);
            }
        }
        let again = PseudoNormals::with_adjacency(m.positions(), m.triangles(), &adj);
        assert_eq!((again.edge, again.vertex), (n.edge, n.vertex));
    }

    #[test]
    fn open_flipped_or_repeated_vertex_meshes_are_not_closed() {
        let sheet = open_sheet(1.0, 1.0, 2);
        assert!(!PseudoNormals::new(sheet.positions(), sheet.triangles()).closed_and_oriented);
        // One face of a box turned over: its edges are traversed twice in the same direction.
        let b = box_mesh(Vec3::ZERO, Vec3::ONE);
        let mut tris = b.triangles().to_vec();
        tris[0] = [tris[0][0], tris[0][2], tris[0][1]];
        assert!(!PseudoNormals::new(b.positions(), &tris).closed_and_oriented);
        // A triangle with a repeated vertex: a zero face normal, no edge where the vertex
        // repeats (zero pseudo-normal), its real edge 0–1 shared with the first triangle.
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let n = PseudoNormals::new(&p, &[[0, 1, 2], [0, 0, 1]]);
        assert!(!n.closed_and_oriented);
        assert_eq!(n.face[1], Vec3::ZERO);
        assert_eq!(n.edge[1][0], Vec3::ZERO);
        assert_eq!(n.edge[1][1], n.face[0]);
        assert_eq!(n.edge[0][0], n.face[0]);
    }
}
