//! The source mesh as a scene: the reference image (the source mesh with its face normals), rendered by the same camera and
//! shading through `sdfmo-distance`'s watertight ray hits, with geometric (face) normals,
//! two-sided.

use glam::Vec3;
use sdfmo_distance::{MeshDistance, RayHit};
use sdfmo_format::OctreeMeta;
use sdfmo_mesh::{Normalization, TriMesh};

use crate::scene::Traceable;

/// Offset of secondary rays on the mesh, normalised units (the mesh spans about 2 units; f32
/// hit points are accurate to a few 1e-7 there).
pub const MESH_EPSILON: f32 = 1e-4;

/// The source mesh as a [`Traceable`]. The mesh must already be in the normalised frame of the
/// octree it is compared with: build it with [`mesh_in_octree_frame`] or
/// [`apply_normalization`] (or `TriMesh::normalized` with the builder's margin).
#[derive(Clone, Copy)]
pub struct MeshScene<'a>(pub &'a MeshDistance);

impl Traceable for MeshScene<'_> {
    type Hit = RayHit;

    #[inline]
    fn first_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<RayHit> {
        self.0.ray_hit(origin, dir, t_min, t_max)
    }

    #[inline]
    fn hit_t(&self, hit: &RayHit) -> f32 {
        hit.t
    }

    /// The triangle's geometric normal (the renderer flips it toward the viewer).
    #[inline]
    fn normal(&self, _origin: Vec3, _dir: Vec3, hit: &RayHit) -> Vec3 {
        hit.normal
    }

    #[inline]
    fn occluded(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        self.0.ray_occluded(origin, dir, t_min, t_max)
    }

    fn epsilon(&self) -> f32 {
        MESH_EPSILON
    }
}

/// The transform stored in an octree, as a mesh [`Normalization`].
pub fn octree_normalization(meta: &OctreeMeta) -> Normalization {
    Normalization {
        center: meta.center,
        scale: meta.scale,
    }
}

/// `mesh` (model units) mapped into the normalised frame by `n`, exactly as
/// `TriMesh::normalized` maps it (`(p − center) · scale` in f32).
///
/// # Panics
/// If `n` maps a vertex beyond f32's range (`TriMesh::transformed`); the normalisation of the
/// octree built from `mesh` never does.
pub fn apply_normalization(mesh: &TriMesh, n: Normalization) -> TriMesh {
    mesh.transformed(|p| n.to_normalized(p))
}

/// `mesh` (model units, the mesh the octree was built from) in the octree's normalised frame, so
/// the reference image aligns with the octree's exactly.
pub fn mesh_in_octree_frame(mesh: &TriMesh, meta: &OctreeMeta) -> TriMesh {
    apply_normalization(mesh, octree_normalization(meta))
}
