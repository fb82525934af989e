//! The builder's own view of the normalised mesh: triangles with vertices welded by position,
//! face and angle-weighted pseudo-normals (Bærentzen & Aanæs 2005) over the whole mesh (the
//! distance layer's `PseudoNormals`, in f64), boundary and clean-edge flags, and brute-force
//! signed distance to a small triangle subset (a leaf's component) through the distance layer's
//! box-pruned subset loop ([`TriangleSlices`]: flat arrays, no BVH, no allocation).

use glam::Vec3;
use sdfmo_mesh::{EdgeAdjacency, TriMesh};

use sdfmo_distance::{
    sign_by_pseudo_normal, triangle_boxes, ClosestPoint, Feature, TriangleSlices,
};

/// Per-triangle data for the leaf-level work.
#[derive(Clone, Debug)]
pub struct LocalMesh {
    /// Triangle vertex positions (normalised frame).
    pub tris: Vec<[Vec3; 3]>,
    /// Welded vertex ids per triangle (vertices welded by exact position across parts).
    pub vids: Vec<[u32; 3]>,
    /// Part id per triangle.
    pub parts: Vec<u32>,
    /// Unit face normal (zero for a degenerate triangle).
    pub face_normal: Vec<Vec3>,
    /// Pseudo-normal of edge `i` (v_i → v_{i+1}): sum of the incident faces' unit normals.
    pub edge_normal: Vec<[Vec3; 3]>,
    /// Bit `i` set: edge `i` is a boundary edge of the whole mesh (one incident triangle).
    pub boundary: Vec<u8>,
    /// Bit `i` set: edge `i` is a *clean* manifold edge (exactly two incident triangles that
    /// traverse it in opposite directions), so its pseudo-normal signs reliably.
    pub edge_clean: Vec<u8>,
    /// Per welded vertex: every incident edge is clean.
    pub vertex_clean: Vec<bool>,
    /// Angle-weighted pseudo-normal per welded vertex.
    pub vertex_normal: Vec<Vec3>,
    /// Triangle bounding boxes (min, max).
    pub bbox: Vec<(Vec3, Vec3)>,
    /// Twice the area per triangle.
    pub area2: Vec<f32>,
}

impl LocalMesh {
    /// Builds the per-triangle tables of `mesh` (already normalised).
    pub fn new(mesh: &TriMesh) -> LocalMesh {
        // Weld by exact position (the loaders weld bit-identical vertices per part; OBJ objects
        // and glTF primitives may still repeat a position across parts).
        let (welded_pos, vids) = mesh.welded_by_position();
        let mut tris = Vec::with_capacity(vids.len());
        let mut area2 = Vec::with_capacity(vids.len());
        for v in &vids {
            let p = v.map(|i| welded_pos[i as usize]);
            tris.push(p);
            area2.push((p[1] - p[0]).cross(p[2] - p[0]).length());
        }
        let bbox = triangle_boxes(&tris);
        // Face, edge and vertex pseudo-normals of the welded mesh: the distance layer's (f64);
        // boundary and clean flags: the mesh layer's.
        let adjacency = EdgeAdjacency::of_triangles(&vids);
        let normals = sdfmo_distance::PseudoNormals::with_adjacency(&welded_pos, &vids, &adjacency);
        let flags = adjacency.edge_flags(&vids, welded_pos.len());
        LocalMesh {
            tris,
            vids,
            parts: mesh.parts().to_vec(),
            face_normal: normals.face,
            edge_normal: normals.edge,
            boundary: flags.boundary,
            edge_clean: flags.clean,
            vertex_clean: flags.vertex_clean,
            vertex_normal: normals.vertex,
            bbox,
            area2,
        }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// No triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// The triangles as the distance layer's subset queries read them.
    #[inline]
    fn slices(&self) -> TriangleSlices<'_> {
        TriangleSlices {
            corners: &self.tris,
            boxes: &self.bbox,
        }
    }

    /// Signed distance from `p` to the triangles `subset` (indices into this mesh), signed by the
    /// pseudo-normal of the closest feature (computed over the whole mesh). `f32::INFINITY` for an
    /// empty subset.
    #[inline]
    pub fn signed_distance_subset(&self, subset: &[u32], p: Vec3) -> f32 {
        self.closest_in_subset(subset, p, |c| {
            sign_by_pseudo_normal(p, c, self.pseudo_normal(c.triangle as usize, c.feature))
        })
    }

    /// Distance from `p` to the open sheet `subset` continued past its rims: the offset from the
    /// closest point along the normal of the face it lies on. Inside a face's Voronoi region
    /// that is the signed distance; beyond a rim it is the distance to the plane of the rim's
    /// face (the sheet's tangent continuation) where the true distance bends around the
    /// boundary edge. Signed by the face's own orientation. `f32::INFINITY` for an empty subset.
    #[inline]
    pub fn sheet_continuation_distance(&self, subset: &[u32], p: Vec3) -> f32 {
        self.closest_in_subset(subset, p, |c| {
            (p - c.point).dot(self.face_normal[c.triangle as usize])
        })
    }

    /// `distance` of the closest point to `p` on `subset`; `f32::INFINITY` for an empty subset.
    #[inline]
    fn closest_in_subset(
        &self,
        subset: &[u32],
        p: Vec3,
        distance: impl FnOnce(&ClosestPoint) -> f32,
    ) -> f32 {
        let c = self
            .slices()
            .closest_point_in_subset(subset, p, f32::INFINITY);
        if c.is_found() {
            distance(&c)
        } else {
            f32::INFINITY
        }
    }

    /// The closest point to `p` on the triangles `subset` nearer than `cap`, if any.
    #[inline]
    pub fn closest_point_subset(&self, subset: &[u32], p: Vec3, cap: f32) -> Option<Vec3> {
        let c = self.slices().closest_point_in_subset(subset, p, cap);
        c.is_found().then_some(c.point)
    }

    /// Signed distance from `p` to `subset` when its closest point lies nearer than `reach`
    /// and on a clean feature (whose pseudo-normal signs reliably); `None` otherwise. With
    /// `subset` a leaf's gathered triangles of one component and `reach` the gather margin,
    /// the answer is the distance to the whole component: every triangle not gathered is
    /// farther from the cell than that.
    #[inline]
    pub fn signed_distance_near(&self, subset: &[u32], p: Vec3, reach: f32) -> Option<f32> {
        let c = self.slices().closest_point_in_subset(subset, p, reach);
        (c.is_found() && self.feature_is_clean(c.triangle as usize, c.feature)).then(|| {
            sign_by_pseudo_normal(p, &c, self.pseudo_normal(c.triangle as usize, c.feature))
        })
    }

    /// Unsigned distance from `p` to `subset`, at most `cap`.
    #[inline]
    pub fn unsigned_distance_subset(&self, subset: &[u32], p: Vec3, cap: f32) -> f32 {
        self.slices().unsigned_distance_in_subset(subset, p, cap)
    }

    /// Whether feature `f` of triangle `t` has a reliable pseudo-normal: the face interior, a
    /// clean manifold edge, or a vertex all of whose edges are clean.
    #[inline]
    pub fn feature_is_clean(&self, t: usize, f: Feature) -> bool {
        match f {
            Feature::Face => self.face_normal[t] != Vec3::ZERO,
            Feature::Edge(k) => self.edge_clean[t] & (1 << k) != 0,
            Feature::Vertex(k) => self.vertex_clean[self.vids[t][k as usize] as usize],
        }
    }

    /// The pseudo-normal of feature `f` of triangle `t`.
    #[inline]
    pub fn pseudo_normal(&self, t: usize, f: Feature) -> Vec3 {
        match f {
            Feature::Face => self.face_normal[t],
            Feature::Edge(k) => self.edge_normal[t][k as usize],
            Feature::Vertex(k) => self.vertex_normal[self.vids[t][k as usize] as usize],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> TriMesh {
        // Unit cube [-0.5, 0.5]³, outward normals.
        let p = (0..8)
            .map(|i| {
                Vec3::new(
                    ((i >> 2) & 1) as f32 - 0.5,
                    ((i >> 1) & 1) as f32 - 0.5,
                    (i & 1) as f32 - 0.5,
                )
            })
            .collect::<Vec<_>>();
        let quads = [
            [0, 1, 3, 2], // x = -0.5
            [4, 6, 7, 5], // x = +0.5
            [0, 4, 5, 1], // y = -0.5
            [2, 3, 7, 6], // y = +0.5
            [0, 2, 6, 4], // z = -0.5
            [1, 5, 7, 3], // z = +0.5
        ];
        let mut t = Vec::new();
        for q in quads {
            t.push([q[0], q[1], q[2]]);
            t.push([q[0], q[2], q[3]]);
        }
        let n = t.len();
        TriMesh::new(p, t, vec![0; n]).unwrap()
    }

    #[test]
    fn cube_signs_and_boundary() {
        let m = cube();
        let l = LocalMesh::new(&m);
        assert!(l.boundary.iter().all(|&b| b == 0));
        assert!(l.edge_clean.iter().all(|&b| b == 7));
        assert!(l.vertex_clean.iter().all(|&b| b));
        let all: Vec<u32> = (0..l.len() as u32).collect();
        // Inside, outside near faces, edges and corners.
        assert!((l.signed_distance_subset(&all, Vec3::ZERO) + 0.5).abs() < 1e-6);
        assert!((l.signed_distance_subset(&all, Vec3::new(0.7, 0.0, 0.0)) - 0.2).abs() < 1e-6);
        let d = l.signed_distance_subset(&all, Vec3::new(0.6, 0.6, 0.0));
        assert!((d - 0.1 * 2f32.sqrt()).abs() < 1e-6, "{d}");
        let d = l.signed_distance_subset(&all, Vec3::splat(0.6));
        assert!((d - 0.1 * 3f32.sqrt()).abs() < 1e-6, "{d}");
        let d = l.signed_distance_subset(&all, Vec3::splat(0.45));
        assert!((d + 0.05).abs() < 1e-6, "{d}");
        // Subset: the +y face alone still signs by the whole mesh's pseudo-normals.
        let top: Vec<u32> = vec![6, 7];
        assert!(l.signed_distance_subset(&top, Vec3::new(0.0, 0.4, 0.0)) < 0.0);
        assert!(l.signed_distance_subset(&top, Vec3::new(0.0, 0.6, 0.0)) > 0.0);
        assert_eq!(l.signed_distance_subset(&[], Vec3::ZERO), f32::INFINITY);
        assert!(
            (l.unsigned_distance_subset(&top, Vec3::new(0.0, 0.2, 0.0), 1.0) - 0.3).abs() < 1e-6
        );
    }

    #[test]
    fn open_sheet_has_boundary_edges() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z];
        let m = TriMesh::new(p, vec![[0, 2, 1], [0, 3, 2]], vec![0, 0]).unwrap();
        let l = LocalMesh::new(&m);
        assert_eq!(l.boundary[0].count_ones() + l.boundary[1].count_ones(), 4);
        // The diagonal is the only clean edge; every vertex touches a boundary edge.
        assert_eq!(
            l.edge_clean[0].count_ones() + l.edge_clean[1].count_ones(),
            2
        );
        assert!(l.vertex_clean.iter().all(|&b| !b));
        assert!(l.feature_is_clean(0, Feature::Face));
        assert!(!l.feature_is_clean(0, Feature::Vertex(0)));
    }
}
