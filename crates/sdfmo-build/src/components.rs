//! Exact distances to one connected component of the whole mesh.
//!
//! A leaf's component is a piece of one *global* component (connected through shared welded
//! edges, same part). When no other piece of that global component touches the leaf, the
//! voxel's corners are the signed distance to the whole global component — exact, with a sign
//! that does not depend on which triangles happened to be gathered around the leaf. (Distances
//! to the gathered subset alone overestimate far corners and can flip their sign at the
//! subset's cut border; on abc5's panel that made the parts bulge at their silhouettes.)

use glam::Vec3;
use rayon::prelude::*;
use sdfmo_distance::{DistanceError, MeshDistance, SignMode};
use sdfmo_mesh::TriMesh;

use crate::geom::closest_point_triangle;
use crate::local::LocalMesh;

/// One global component: its triangles and a distance structure over them.
pub struct Component {
    /// Global triangle ids, in the component mesh's order.
    pub tris: Vec<u32>,
    /// Distance structure of the component alone.
    pub dist: MeshDistance,
    /// Has boundary edges (open).
    pub open: bool,
}

/// All global components and each triangle's component and index within it.
pub struct Components {
    /// The components.
    pub comps: Vec<Component>,
    /// Component id per global triangle.
    pub of_triangle: Vec<u32>,
    /// Index of each global triangle within its component.
    pub index_in: Vec<u32>,
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let gp = parent[parent[i as usize] as usize];
        parent[i as usize] = gp;
        i = gp;
    }
    i
}

impl Components {
    /// Connected components of `local` through shared welded edges within one part.
    pub fn new(local: &LocalMesh) -> Result<Components, DistanceError> {
        let n = local.len();
        let mut parent: Vec<u32> = (0..n as u32).collect();
        let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * n);
        for (t, v) in local.vids.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                if a != b {
                    edges.push((((a.min(b) as u64) << 32) | a.max(b) as u64, t as u32));
                }
            }
        }
        edges.par_sort_unstable();
        for w in edges.windows(2) {
            if w[0].0 == w[1].0 && local.parts[w[0].1 as usize] == local.parts[w[1].1 as usize] {
                let ra = find(&mut parent, w[0].1);
                let rb = find(&mut parent, w[1].1);
                if ra != rb {
                    let (r, o) = if ra < rb { (ra, rb) } else { (rb, ra) };
                    parent[o as usize] = r;
                }
            }
        }
        let mut of_triangle = vec![u32::MAX; n];
        let mut index_in = vec![0u32; n];
        let mut members: Vec<Vec<u32>> = Vec::new();
        for t in 0..n {
            let r = find(&mut parent, t as u32) as usize;
            if of_triangle[r] == u32::MAX {
                of_triangle[r] = members.len() as u32;
                members.push(Vec::new());
            }
            let c = of_triangle[r];
            of_triangle[t] = c;
            index_in[t] = members[c as usize].len() as u32;
            members[c as usize].push(t as u32);
        }
        let comps = members
            .into_par_iter()
            .map(|tris| {
                let mut positions = Vec::with_capacity(tris.len() * 3);
                let mut triangles = Vec::with_capacity(tris.len());
                for &t in &tris {
                    let b = positions.len() as u32;
                    positions.extend_from_slice(&local.tris[t as usize]);
                    triangles.push([b, b + 1, b + 2]);
                }
                // Bit-identical positions: the distance crate's pseudo-normals weld them again
                // only if its constructor does; the builder signs with its own pseudo-normals
                // (whole-mesh adjacency) wherever the feature is clean, so this is only the
                // fallback winding number.
                let mesh = TriMesh {
                    positions,
                    triangles,
                    parts: vec![0; tris.len()],
                };
                let open = tris.iter().any(|&t| local.boundary[t as usize] != 0);
                MeshDistance::new(&mesh, SignMode::Winding).map(|dist| Component {
                    tris,
                    dist,
                    open,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Components {
            comps,
            of_triangle,
            index_in,
        })
    }

    /// Signed distance from `p` to global component `c`, starting from triangle `hint` (a
    /// global id in that component). Signed by the pseudo-normal of the closest feature when it
    /// is clean or the component is open, else by the component's winding number.
    pub fn signed_distance(&self, local: &LocalMesh, c: u32, p: Vec3, hint: u32) -> f32 {
        let comp = &self.comps[c as usize];
        let cp = comp
            .dist
            .closest_point_with_hint(p, self.index_in[hint as usize]);
        let Some(&t) = comp.tris.get(cp.triangle as usize) else {
            return f32::INFINITY;
        };
        let [a, b, cc] = local.tris[t as usize];
        let (q, f) = closest_point_triangle(p, a, b, cc);
        if comp.open || local.feature_is_clean(t as usize, f) {
            let n = local.pseudo_normal(t as usize, f);
            if (p - q).dot(n) < 0.0 {
                -cp.distance
            } else {
                cp.distance
            }
        } else {
            comp.dist.sign_closest(p, &cp)
        }
    }
}
