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
//! Edges are identified by the (welded) vertex indices of the mesh, so adjacency is that of the
//! whole mesh even when a query is restricted to a subset of triangles.

use glam::{DVec3, Vec3};

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
    /// When an index is out of range (validate the mesh first, as `TriMesh::new` does).
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> PseudoNormals {
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
        // Edges: sort the directed half-edges by their undirected key and group them.
        let mut half: Vec<(u64, u32)> = Vec::with_capacity(triangles.len() * 3);
        for (ti, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let key = ((a.min(b) as u64) << 32) | a.max(b) as u64;
                half.push((key, (ti as u32) * 3 + k as u32));
            }
        }
        half.sort_unstable();
        let mut edge = vec![[Vec3::ZERO; 3]; triangles.len()];
        let mut closed_and_oriented = true;
        let mut i = 0;
        while i < half.len() {
            let mut j = i + 1;
            while j < half.len() && half[j].0 == half[i].0 {
                j += 1;
            }
            let group = &half[i..j];
            let mut sum = Vec3::ZERO;
            for &(_, h) in group {
                sum += face[(h / 3) as usize];
            }
            for &(_, h) in group {
                edge[(h / 3) as usize][(h % 3) as usize] = sum;
            }
            if group.len() != 2 {
                closed_and_oriented = false;
            } else {
                let dir = |h: u32| {
                    let t = triangles[(h / 3) as usize];
                    let k = (h % 3) as usize;
                    t[k] < t[(k + 1) % 3]
                };
                if dir(group[0].1) == dir(group[1].1) {
                    closed_and_oriented = false;
                }
            }
            i = j;
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
