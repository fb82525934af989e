//! The packed octree as a scene, through `sdfmo-trace`'s kernel.

use glam::Vec3;
use sdfmo_format::{cell_size, LodOctree, PackedOctree, TracedOctree};
use sdfmo_trace::{
    eye_levels, hit_normal, intersect, intersect_lod, intersect_lod_packet, intersect_packet,
    occluded, occupied_bounds, Hit, LevelChoice, LodHit, Ray, RayPacket,
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

/// A packed octree as a [`Traceable`] (`sdfmo_trace::{intersect, occluded, hit_normal}`): a
/// 1.x [`PackedOctree`] (the default) or any other [`TracedOctree`], such as a 3.0
/// [`BrickOctree`](sdfmo_format::BrickOctree) traced in place (the same images as its 1.x
/// octree, byte for byte).
pub struct OctreeScene<'a, O = PackedOctree>(pub &'a O);

// Not derived: a derive would ask `O: Clone` (the scene only copies the reference).
impl<O> Clone for OctreeScene<'_, O> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<O> Copy for OctreeScene<'_, O> {}

impl<O: TracedOctree + Sync> Traceable for OctreeScene<'_, O> {
    type Hit = Hit<O::Voxel>;

    #[inline]
    fn first_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<Self::Hit> {
        intersect(self.0, &Ray { origin, dir }, t_min, t_max)
    }

    /// One walk of the octree for the whole packet (`sdfmo_trace::intersect_packet`: the same
    /// hits as ray by ray, bit for bit).
    #[inline]
    fn first_hits(&self, rays: &RayPacket, out: &mut [Option<Self::Hit>; PACKET]) {
        let hits = intersect_packet(self.0, rays);
        for (l, hit) in hits.into_iter().enumerate() {
            if rays.lanes >> l & 1 != 0 {
                out[l] = hit;
            }
        }
    }

    #[inline]
    fn hit_t(&self, hit: &Self::Hit) -> f32 {
        hit.t
    }

    /// The analytic gradient of the hit voxel's trilinear interpolant.
    #[inline]
    fn normal(&self, origin: Vec3, dir: Vec3, hit: &Self::Hit) -> Vec3 {
        hit_normal(&Ray { origin, dir }, hit)
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
        let leaf = cell_size(self.0.meta().depth);
        OCTREE_EPSILON_LEAVES * leaf
    }
}

/// A file with levels of detail as a [`Traceable`], each ray at the level `choice` selects
/// (`sdfmo_trace::intersect_lod`): with [`LevelChoice::PixelError`], the coarsest level whose
/// voxels project below the given pixels at the ray's hit distance. (A fixed level is better
/// also drawn as `OctreeScene(lod.level(k))`.)
#[derive(Clone, Copy)]
pub struct LodScene<'a> {
    /// The levels.
    pub lod: &'a LodOctree,
    /// How each ray picks its level.
    pub choice: LevelChoice,
}

impl LodScene<'_> {
    /// The levels the rays from `eye` (normalised frame) are traced at, `(coarsest, finest)`:
    /// by pixel error those [`eye_levels`] gives (every hit's level lies between them), or the
    /// one level chosen (clamped to the file's levels).
    pub fn levels(&self, eye: Vec3) -> (u8, u8) {
        match self.choice {
            LevelChoice::PixelError {
                pixels,
                pixel_angle,
            } => eye_levels(self.lod, eye, pixels, pixel_angle),
            LevelChoice::Level(k) => {
                let k = k.clamp(self.lod.coarsest(), self.lod.depth());
                (k, k)
            }
        }
    }

    /// The union of the occupied boxes ([`OCCUPIED_LEVELS`] below the root) of the levels
    /// `coarsest..=finest`.
    fn occupied_bounds_of(&self, coarsest: u8, finest: u8) -> Option<(Vec3, Vec3)> {
        (coarsest..=finest)
            .filter_map(|k| self.lod.level(k))
            .filter_map(|l| occupied_bounds(l, OCCUPIED_LEVELS))
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    }
}

impl Traceable for LodScene<'_> {
    type Hit = LodHit;

    #[inline]
    fn first_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<LodHit> {
        intersect_lod(self.lod, &Ray { origin, dir }, t_min, t_max, self.choice)
    }

    /// [`intersect_lod_packet`]: one walk of one level for the packet where every lane needs
    /// the same level (the same hits as ray by ray).
    #[inline]
    fn first_hits(&self, rays: &RayPacket, out: &mut [Option<LodHit>; PACKET]) {
        let hits = intersect_lod_packet(self.lod, rays, self.choice);
        for (l, hit) in hits.into_iter().enumerate() {
            if rays.lanes >> l & 1 != 0 {
                out[l] = hit;
            }
        }
    }

    #[inline]
    fn hit_t(&self, hit: &LodHit) -> f32 {
        hit.hit.t
    }

    /// The analytic gradient of the hit voxel's trilinear interpolant, in the hit's level.
    #[inline]
    fn normal(&self, origin: Vec3, dir: Vec3, hit: &LodHit) -> Vec3 {
        hit_normal(&Ray { origin, dir }, &hit.hit)
    }

    /// Shadow rays test the finest level (a shadow's level of detail is not chosen per ray).
    #[inline]
    fn occluded(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        occluded(self.lod.finest(), &Ray { origin, dir }, t_min, t_max)
    }

    /// The union of every level's occupied cells [`OCCUPIED_LEVELS`] below the root (a
    /// level's leaves need not lie within a coarser level's: each build keeps its own cells).
    fn occupied_bounds(&self) -> Option<(Vec3, Vec3)> {
        self.occupied_bounds_of(self.lod.coarsest(), self.lod.depth())
    }

    /// The union of the occupied cells of the levels rays from `eye` are traced at
    /// ([`LodScene::levels`]): from far, one level's walk instead of every level's (abc5 with
    /// levels 6–10 from radius 12: 0.10 M instructions a frame instead of 0.49 M).
    fn primary_bounds(&self, eye: Vec3) -> Option<(Vec3, Vec3)> {
        let (coarsest, finest) = self.levels(eye);
        self.occupied_bounds_of(coarsest, finest)
    }

    /// The finest level's epsilon (the smallest).
    fn epsilon(&self) -> f32 {
        OCTREE_EPSILON_LEAVES * cell_size(self.lod.depth())
    }
}
