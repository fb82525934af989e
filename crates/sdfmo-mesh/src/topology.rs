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
    /// Per entry of `triangles`: which edge `k` of that triangle it is (`v_k → v_{k+1}`).
    pub slots: Vec<u8>,
}

/// Per-triangle flags of the edges and vertices of a mesh (see [`EdgeAdjacency::edge_flags`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EdgeFlags {
    /// Bit `k` of triangle `t`: its edge `k` is a boundary edge (one incident triangle).
    pub boundary: Vec<u8>,
    /// Bit `k` of triangle `t`: its edge `k` is a *clean* manifold edge, exactly two incident
    /// triangles traversing it in opposite directions (its pseudo-normal signs reliably).
    pub clean: Vec<u8>,
    /// Per vertex: every incident edge is clean.
    pub vertex_clean: Vec<bool>,
}

impl EdgeAdjacency {
    /// Builds the adjacency of `mesh`. Edges of triangles with a repeated vertex are skipped
    /// (a cleaned mesh has none).
    pub fn of(mesh: &TriMesh) -> EdgeAdjacency {
        EdgeAdjacency::of_triangles(mesh.triangles())
    }

    /// Builds the adjacency of triangles given by vertex indices (for instance after welding
    /// by position); edges with a repeated vertex are skipped.
    pub fn of_triangles(triangles: &[[u32; 3]]) -> EdgeAdjacency {
        let mut recs: Vec<(u64, u32, u8)> = Vec::with_capacity(triangles.len() * 3);
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if a == b {
                    continue;
                }
                let (lo, hi) = if a < b { (a, b) } else { (b, a) };
                recs.push((((lo as u64) << 32) | hi as u64, t as u32, k as u8));
            }
        }
        recs.sort_unstable();
        let mut edges = Vec::new();
        let mut offsets = Vec::new();
        let mut tris = Vec::with_capacity(recs.len());
        let mut slots = Vec::with_capacity(recs.len());
        let mut prev = None;
        for &(key, t, k) in &recs {
            if prev != Some(key) {
                edges.push([(key >> 32) as u32, key as u32]);
                offsets.push(tris.len() as u32);
                prev = Some(key);
            }
            tris.push(t);
            slots.push(k);
        }
        offsets.push(tris.len() as u32);
        EdgeAdjacency {
            edges,
            offsets,
            triangles: tris,
            slots,
        }
    }

    /// The *chain boundary* of `triangles` (the triangles this adjacency was built from): the
    /// edges whose orientations do not cancel, as `[lo, hi]` in edge order. These are the
    /// boundary edges of an open mesh and the non-manifold or inconsistently oriented edges
    /// whose triangles do not pair up in opposite directions; the smooth part of a generalised
    /// winding number depends on them alone.
    pub fn chain_boundary<'a>(
        &'a self,
        triangles: &'a [[u32; 3]],
    ) -> impl Iterator<Item = [u32; 2]> + 'a {
        (0..self.edges.len()).filter_map(move |e| {
            let orientation: i32 = self
                .triangles_of(e)
                .iter()
                .zip(self.slots_of(e))
                .map(|(&t, &k)| {
                    let tri = triangles[t as usize];
                    let k = usize::from(k);
                    if tri[k] < tri[(k + 1) % 3] {
                        1
                    } else {
                        -1
                    }
                })
                .sum();
            (orientation != 0).then_some(self.edges[e])
        })
    }

    /// Boundary and clean-edge flags per triangle edge, and clean vertices, of `triangles` (the
    /// triangles this adjacency was built from) over `vertex_count` vertices.
    pub fn edge_flags(&self, triangles: &[[u32; 3]], vertex_count: usize) -> EdgeFlags {
        let mut boundary = vec![0u8; triangles.len()];
        let mut clean = vec![0u8; triangles.len()];
        let mut vertex_clean = vec![true; vertex_count];
        for e in 0..self.edge_count() {
            let (tris, slots) = (self.triangles_of(e), self.slots_of(e));
            // The start vertex of each traversal: opposite directions start at different ends.
            let start = |i: usize| triangles[tris[i] as usize][slots[i] as usize];
            let is_clean = tris.len() == 2 && start(0) != start(1);
            for (&t, &k) in tris.iter().zip(slots) {
                if tris.len() == 1 {
                    boundary[t as usize] |= 1 << k;
                }
                if is_clean {
                    clean[t as usize] |= 1 << k;
                }
            }
            if !is_clean {
                for v in self.edges[e] {
                    vertex_clean[v as usize] = false;
                }
            }
        }
        EdgeFlags {
            boundary,
            clean,
            vertex_clean,
        }
    }

    /// Connected components within parts: triangles of the same part (`parts[t]`) sharing an
    /// edge are joined. Component id per triangle (numbered in order of first triangle) and the
    /// count.
    pub fn components_within_parts(&self, parts: &[u32]) -> (Vec<u32>, usize) {
        let mut uf = UnionFind::new(parts.len());
        for e in 0..self.edge_count() {
            let tris = self.triangles_of(e);
            for (i, &a) in tris.iter().enumerate() {
                // The first earlier triangle of the same part: joining to it joins the part's
                // whole row.
                if let Some(&b) = tris[..i]
                    .iter()
                    .find(|&&b| parts[b as usize] == parts[a as usize])
                {
                    uf.union(b, a);
                }
            }
        }
        let mut ids = Vec::new();
        let count = uf.labels_into(&mut ids);
        (ids, count)
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

    /// Which edge `k` of each triangle of [`EdgeAdjacency::triangles_of`] edge `e` is.
    pub fn slots_of(&self, e: usize) -> &[u8] {
        &self.slots[self.offsets[e] as usize..self.offsets[e + 1] as usize]
    }
}

// The topology of a mesh is this module's concept, so the method lives here: `mesh` itself
// knows nothing of edges (no module cycle).
impl TriMesh {
    /// Connectivity through shared (welded) edges: components, boundary and non-manifold edge
    /// counts, watertightness.
    pub fn topology(&self) -> Topology {
        Topology::of(self)
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
    fn chain_boundary_is_where_orientations_do_not_cancel() {
        let chain = |tris: Vec<[u32; 3]>, n: usize| {
            let m = mesh(tris, n);
            let a = EdgeAdjacency::of(&m);
            a.chain_boundary(m.triangles()).collect::<Vec<_>>()
        };
        // Closed: nothing.
        assert!(chain(vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]], 4).is_empty());
        // Two consistently oriented triangles: the four outer edges, not the shared 1-2.
        assert_eq!(
            chain(vec![[0, 1, 2], [2, 1, 3]], 4),
            vec![[0, 1], [0, 2], [1, 3], [2, 3]]
        );
        // The second one flipped: the shared edge is traversed twice the same way.
        assert_eq!(
            chain(vec![[0, 1, 2], [1, 2, 3]], 4),
            vec![[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]
        );
        // Three fins on 0-1 (two one way, one the other): it stays unbalanced.
        assert!(chain(vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]], 5).contains(&[0, 1]));
        // Four fins paired in opposite directions: balanced, as a closed surface's edge.
        assert!(!chain(vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [1, 0, 5]], 6).contains(&[0, 1]));
    }

    #[test]
    fn adjacency_rows() {
        let m = mesh(vec![[0, 1, 2], [2, 1, 3]], 4);
        let a = EdgeAdjacency::of(&m);
        assert_eq!(a.edges, vec![[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]);
        assert_eq!(a.triangles_of(2), &[0, 1]);
        assert_eq!(a.triangles_of(0), &[0]);
        // Edge 1–2 is edge 1 of triangle 0 (1 → 2) and edge 0 of triangle 1 (2 → 1).
        assert_eq!(
            &a.slots[a.offsets[2] as usize..a.offsets[3] as usize],
            &[1, 0]
        );
    }

    #[test]
    fn edge_flags_of_an_open_pair_and_a_flipped_pair() {
        let tris = vec![[0, 1, 2], [2, 1, 3]];
        let a = EdgeAdjacency::of_triangles(&tris);
        let f = a.edge_flags(&tris, 4);
        // The shared edge is clean (traversed both ways); the other four are boundary edges.
        assert_eq!(f.clean, vec![0b010, 0b001]);
        assert_eq!(f.boundary, vec![0b101, 0b110]);
        assert_eq!(f.vertex_clean, vec![false; 4]);
        // The second triangle flipped: the shared edge is traversed twice the same way.
        let tris = vec![[0, 1, 2], [1, 2, 3]];
        let f = EdgeAdjacency::of_triangles(&tris).edge_flags(&tris, 4);
        assert_eq!(f.clean, vec![0, 0]);
        // A closed tetrahedron: every edge clean, every vertex clean.
        let tet = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let f = EdgeAdjacency::of_triangles(&tet).edge_flags(&tet, 4);
        assert_eq!(f.clean, vec![0b111; 4]);
        assert_eq!(f.boundary, vec![0; 4]);
        assert_eq!(f.vertex_clean, vec![true; 4]);
    }

    #[test]
    fn components_within_parts_split_at_part_borders() {
        // Three fins on edge 0–1, parts 0, 1, 0: the two part-0 fins are one component even
        // though a part-1 fin lies between them in the edge's row.
        let m = mesh(vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]], 5);
        let a = EdgeAdjacency::of(&m);
        assert_eq!(a.components_within_parts(&[0, 1, 0]), (vec![0, 1, 0], 2));
        assert_eq!(a.components_within_parts(&[0, 0, 0]), (vec![0, 0, 0], 1));
        assert_eq!(a.components_within_parts(&[0, 1, 2]), (vec![0, 1, 2], 3));
    }
}
