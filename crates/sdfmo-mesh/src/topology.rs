//! Edge adjacency, connected components (union–find over shared edges), boundary and
//! non-manifold edge counts.
//!
//! Edges are keyed by their two (welded) vertex indices, unordered; two triangles are connected
//! when they share such an edge. Everything is built from one sort of the 3·T edge records, so
//! an 80k-triangle mesh takes a few milliseconds.

use crate::mesh::TriMesh;
use crate::union_find::UnionFind;

/// Connectivity of a mesh through shared edges of its (welded) vertices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Topology {
    /// Component id per triangle, `0..component_count`, numbered in order of each component's
    /// first triangle; triangles are connected through shared (welded) edges.
    pub component_of_triangle: Vec<u32>,
    /// Number of connected components.
    pub component_count: usize,
    /// Edges with exactly one incident triangle.
    pub boundary_edges: usize,
    /// Edges with more than two incident triangles.
    pub non_manifold_edges: usize,
    /// No boundary and no non-manifold edges.
    pub watertight: bool,
}

/// Every distinct edge with the triangles incident to it (compressed rows).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EdgeAdjacency {
    /// Distinct edges as `[lo, hi]` vertex indices (`lo < hi`), sorted.
    pub edges: Vec<[u32; 2]>,
    /// `offsets[e]..offsets[e + 1]` indexes `triangles` for edge `e`; length `edges.len() + 1`.
    pub offsets: Vec<u32>,
    /// Incident triangle indices, grouped by edge, ascending within a group.
    pub triangles: Vec<u32>,
}

impl EdgeAdjacency {
    /// Builds the adjacency of `mesh`. Edges of triangles with a repeated vertex are skipped
    /// (a cleaned mesh has none).
    pub fn of(mesh: &TriMesh) -> EdgeAdjacency {
        let mut recs: Vec<(u64, u32)> = Vec::with_capacity(mesh.triangles.len() * 3);
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if a == b {
                    continue;
                }
                let (lo, hi) = if a < b { (a, b) } else { (b, a) };
                recs.push((((lo as u64) << 32) | hi as u64, t as u32));
            }
        }
        recs.sort_unstable();
        let mut edges = Vec::new();
        let mut offsets = Vec::new();
        let mut triangles = Vec::with_capacity(recs.len());
        let mut prev = None;
        for &(key, t) in &recs {
            if prev != Some(key) {
                edges.push([(key >> 32) as u32, key as u32]);
                offsets.push(triangles.len() as u32);
                prev = Some(key);
            }
            triangles.push(t);
        }
        offsets.push(triangles.len() as u32);
        EdgeAdjacency {
            edges,
            offsets,
            triangles,
        }
    }

    /// Number of distinct edges.
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    /// Connected components of the `triangle_count` triangles: component id per triangle
    /// (numbered in order of first triangle) and the count. Triangles are joined through every
    /// shared edge, or with `manifold_only` only through edges shared by exactly two triangles
    /// (trimesh's `face_adjacency` definition).
    pub fn components(&self, triangle_count: usize, manifold_only: bool) -> (Vec<u32>, usize) {
        let mut uf = UnionFind::new(triangle_count);
        for e in 0..self.edge_count() {
            let tris = self.triangles_of(e);
            if manifold_only && tris.len() != 2 {
                continue;
            }
            for &t in &tris[1..] {
                uf.union(tris[0], t);
            }
        }
        let mut ids = Vec::new();
        let count = uf.labels_into(&mut ids);
        (ids, count)
    }

    /// Triangles incident to edge `e`.
    pub fn triangles_of(&self, e: usize) -> &[u32] {
        &self.triangles[self.offsets[e] as usize..self.offsets[e + 1] as usize]
    }
}

impl Topology {
    /// Computes the topology of `mesh` (see [`TriMesh::topology`]).
    pub fn of(mesh: &TriMesh) -> Topology {
        Topology::from_adjacency(mesh.triangle_count(), &EdgeAdjacency::of(mesh))
    }

    /// Computes the topology from a prebuilt adjacency of a mesh with `triangle_count` triangles.
    pub fn from_adjacency(triangle_count: usize, adj: &EdgeAdjacency) -> Topology {
        let (mut boundary, mut non_manifold) = (0, 0);
        for e in 0..adj.edge_count() {
            match adj.triangles_of(e).len() {
                1 => boundary += 1,
                2 => {}
                _ => non_manifold += 1,
            }
        }
        let (component_of_triangle, component_count) = adj.components(triangle_count, false);
        Topology {
            component_of_triangle,
            component_count,
            boundary_edges: boundary,
            non_manifold_edges: non_manifold,
            watertight: boundary == 0 && non_manifold == 0,
        }
    }

    /// Triangle indices of each component, in component order.
    pub fn components(&self) -> Vec<Vec<u32>> {
        let mut out = vec![Vec::new(); self.component_count];
        for (t, &c) in self.component_of_triangle.iter().enumerate() {
            out[c as usize].push(t as u32);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn mesh(tris: Vec<[u32; 3]>, n: usize) -> TriMesh {
        let positions = (0..n)
            .map(|i| Vec3::new(i as f32, (i * i) as f32, 1.0))
            .collect();
        let parts = vec![0; tris.len()];
        TriMesh::new(positions, tris, parts).unwrap()
    }

    #[test]
    fn tetrahedron_is_watertight() {
        let t = mesh(vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]], 4).topology();
        assert_eq!(t.component_count, 1);
        assert_eq!((t.boundary_edges, t.non_manifold_edges), (0, 0));
        assert!(t.watertight);
    }

    #[test]
    fn open_and_non_manifold_counts() {
        // Two triangles sharing edge 1-2: 4 boundary edges, one component.
        let t = mesh(vec![[0, 1, 2], [2, 1, 3]], 4).topology();
        assert_eq!(
            (t.component_count, t.boundary_edges, t.non_manifold_edges),
            (1, 4, 0)
        );
        assert!(!t.watertight);
        // Three fins on edge 0-1: that edge is non-manifold, 6 boundary edges.
        let t = mesh(vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]], 5).topology();
        assert_eq!(
            (t.component_count, t.boundary_edges, t.non_manifold_edges),
            (1, 6, 1)
        );
        // Sharing only a vertex does not connect.
        let t = mesh(vec![[0, 1, 2], [0, 3, 4], [5, 6, 7]], 8).topology();
        assert_eq!(t.component_count, 3);
        assert_eq!(t.component_of_triangle, vec![0, 1, 2]);
        assert_eq!(t.components(), vec![vec![0], vec![1], vec![2]]);
    }

    #[test]
    fn adjacency_rows() {
        let m = mesh(vec![[0, 1, 2], [2, 1, 3]], 4);
        let a = EdgeAdjacency::of(&m);
        assert_eq!(a.edges, vec![[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]);
        assert_eq!(a.triangles_of(2), &[0, 1]);
        assert_eq!(a.triangles_of(0), &[0]);
    }
}
