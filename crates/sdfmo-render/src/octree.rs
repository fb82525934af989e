//! The packed octree as a scene, through `sdfmo-trace`'s kernel.

use glam::Vec3;
use sdfmo_format::{cell_size, PackedOctree};
use sdfmo_trace::{
    hit_normal, intersect, intersect_packet, occluded, occupied_bounds, Hit, Ray, RayPacket,
};

use crate::scene::{Traceable, PACKET};

/// Offset of secondary rays on the octree, as a fraction of the leaf edge `2 / 2^depth`. Large
/// enough that a shadow ray leaving a surface voxel does not re-find the zero crossing it
/// starts on (the kernel's roots are accurate to about 1e-4 of a voxel), small enough not to
/// skip thin geometry (at depth 9 it is 2e-4 normalised units).
pub const OCTREE_EPSILON_LEAVES: f32 = 0.05;

/// Levels below the root whose occupied cells make [`Traceable::occupied_bounds`] (cells of
/// 1/16 of the root's edge: a tight box for a few thousand node visits per render).
pub const OCCUPIED_LEVELS: u8 = 5;

/// A packed octree as a [`Traceable`] (`sdfmo_trace::{intersect, occluded, hit_normal}`).
#[derive(Clone, Copy)]
pub struct OctreeScene<'a>(pub &'a PackedOctree);

impl Traceable for OctreeScene<'_> {
    type Hit = Hit;

    #[inline]
    fn first_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<Hit> {
        intersect(self.0, &Ray { origin, dir }, t_min, t_max)
    }

    /// One walk of the octree for the whole packet (`sdfmo_trace::intersect_packet`: the same
    /// hits as ray by ray, bit for bit).
    #[inline]
    fn first_hits(&self, rays: &RayPacket, out: &mut [Option<Hit>; PACKET]) {
        let hits = intersect_packet(self.0, rays);
        for (l, hit) in hits.into_iter().enumerate() {
            if rays.lanes >> l & 1 != 0 {
                out[l] = hit;
            }
        }
    }

    #[inline]
    fn hit_t(&self, hit: &Hit) -> f32 {
        hit.t
    }

    /// The analytic gradient of the hit voxel's trilinear interpolant.
    #[inline]
    fn normal(&self, origin: Vec3, dir: Vec3, hit: &Hit) -> Vec3 {
        hit_normal(self.0, &Ray { origin, dir }, hit)
    }

    #[inline]
    fn occluded(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        occluded(self.0, &Ray { origin, dir }, t_min, t_max)
    }

    /// The union of the occupied cells [`OCCUPIED_LEVELS`] below the root (`None`, trace
    /// everything, for an empty octree, which the traversal rejects at once anyway).
    fn occupied_bounds(&self) -> Option<(Vec3, Vec3)> {
        occupied_bounds(self.0, OCCUPIED_LEVELS)
    }

    fn epsilon(&self) -> f32 {
        let leaf = cell_size(self.0.depth());
        OCTREE_EPSILON_LEAVES * leaf
    }
}
