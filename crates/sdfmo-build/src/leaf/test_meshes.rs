//! Test fixtures of the leaf phases: a mesh taken as already normalised, its builder tables, and
//! leaves cut out of it as the subdivision would gather them.

use glam::Vec3;
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_mesh::{procedural, TriMesh};

use super::samples::Samples;
use super::split::candidate_voxels;
use super::{Cand, Cell, LeafCtx, Params, Scratch};
use crate::components::Components;
use crate::local::LocalMesh;

/// A mesh in the normalised frame with the builder's tables.
pub(crate) struct Fixture {
    pub mesh: LocalMesh,
    pub global: Components,
    dist: MeshDistance,
}

/// One leaf of a fixture: its cell, gathered triangles and global corners.
pub(crate) struct Leaf {
    pub coord: [u32; 3],
    pub cell: Cell,
    pub tris: Vec<u32>,
    pub g: [f32; 8],
}

impl Fixture {
    pub fn new(mesh: TriMesh) -> Fixture {
        let local = LocalMesh::new(&mesh);
        Fixture {
            global: Components::new(&local),
            dist: MeshDistance::new(&mesh, SignMode::Auto).expect("a valid test mesh"),
            mesh: local,
        }
    }

    pub fn all_triangles(&self) -> Vec<u32> {
        (0..self.mesh.len() as u32).collect()
    }

    /// The leaf containing `point`, its triangles those whose bounding box meets the cell
    /// inflated by the builder's gather margin (0.3 of the cell edge).
    pub fn leaf(&self, p: &Params, point: Vec3) -> Leaf {
        let coord = ((point + Vec3::ONE) / p.h).floor().as_uvec3().to_array();
        let cell = Cell::new(coord, p.h);
        let m = Vec3::splat(0.3 * p.h);
        let tris = (0..self.mesh.len() as u32)
            .filter(|&t| {
                let (lo, hi) = self.mesh.bbox[t as usize];
                lo.cmple(cell.hi + m).all() && hi.cmpge(cell.lo - m).all()
            })
            .collect();
        let g = cell.corners().map(|x| self.dist.signed_distance(x));
        Leaf {
            coord,
            cell,
            tris,
            g,
        }
    }
}

/// Two boxes whose faces x = 0.05 and x = 0.15 bound a gap of 0.1 (0.4 of a depth-3 cell), as
/// two mesh parts, or as one part (`parts == false`).
pub fn two_boxes(parts: bool) -> Fixture {
    let a = procedural::box_mesh(Vec3::new(-0.5, -0.5, -0.5), Vec3::new(0.05, 0.5, 0.5));
    let b = procedural::box_mesh(Vec3::new(0.15, -0.5, -0.5), Vec3::new(0.6, 0.5, 0.5));
    let mut m = TriMesh::merge(&[a, b]);
    if !parts {
        let (p, t, q) = m.into_arrays();
        m = TriMesh::new(p, t, vec![0; q.len()]).unwrap();
    }
    Fixture::new(m)
}

impl Leaf {
    /// What the phases of this leaf read.
    pub fn ctx<'a>(&'a self, f: &'a Fixture, p: &'a Params) -> LeafCtx<'a> {
        LeafCtx::new(p, &f.mesh, &f.global, self.coord, &self.tris, &self.g)
    }

    pub fn samples(&self, f: &Fixture, p: &Params) -> Samples {
        let mut s = Samples::default();
        s.collect(p, &f.mesh, &self.cell, &self.tris);
        s
    }

    /// Phases 1–3: the candidate voxels of the leaf's components.
    pub fn candidates(&self, f: &Fixture, p: &Params) -> Vec<Cand> {
        let ctx = self.ctx(f, p);
        let mut s = Scratch::default();
        super::samples::collect(&ctx, &mut s);
        s.components.find(&f.global, &self.tris);
        candidate_voxels(&ctx, &mut s);
        s.cands
    }
}
