//! Ray tracing the packed SDF multi-octree: front-to-back traversal of a
//! [`PackedOctree`](sdfmo_format::PackedOctree) ([`intersect`], [`occluded`]; for primary rays
//! sharing the eye, [`intersect_packet`] walks the octree once per packet of [`PACKET_SIZE`]
//! rays with each ray's hit bit for bit that of [`intersect`]), the ray vs
//! trilinear-voxel kernel ([`intersect_voxel`]), analytic normals ([`hit_normal`]), and the
//! stored signed distance and its gradient at a point ([`distance_at`], for collision queries).
//! Leaves with clip voxels (format 1.1: intersect and clip-only voxels) follow the clip rule
//! (`FORMAT.md` in sdfmo-format, section `clip`): a hit counts only inside the leaf's other
//! clip voxels, and the distance there is the intersection of their fields.
//!
//! Depends on `sdfmo-format` and glam only, so an engine that loads and renders octrees embeds
//! these two crates and nothing else. Nothing here allocates: the traversal keeps a fixed-size
//! stack on the machine stack (sized by [`sdfmo_format::MAX_DEPTH`]) and there is no dynamic
//! dispatch per ray.
//!
//! ```
//! use glam::Vec3;
//! use sdfmo_format::{LeafInput, OctreeMeta, PackedOctree, ValueBits, Voxel};
//! use sdfmo_trace::{hit_normal, intersect, Ray};
//!
//! // One leaf at depth 1 (cell [0,1]³) holding the plane x = 0.5 (inside x > 0.5).
//! let corners = core::array::from_fn(|i| 0.5 - (i >> 2) as f32);
//! let voxel = Voxel { corners, surface: false, clip: false };
//! let leaf = LeafInput { coord: [1, 1, 1], voxels: vec![voxel] };
//! let octree = PackedOctree::from_leaves(OctreeMeta::unit(1, ValueBits::Sixteen), vec![leaf]).unwrap();
//! let ray = Ray { origin: Vec3::new(-3.0, 0.5, 0.5), dir: Vec3::X };
//! let hit = intersect(&octree, &ray, 0.0, f32::INFINITY).unwrap();
//! assert!((hit.t - 3.5).abs() < 1e-4);
//! assert!((hit_normal(&ray, &hit) - -Vec3::X).length() < 1e-4);
//! ```

#![deny(missing_docs)]

// Private modules: every public item has one path, the crate root's.
mod clip;
mod distance;
mod lod;
mod normal;
mod packet;
mod ray_voxel;
mod traversal;

pub use clip::inside_clip;
pub use distance::{distance_at, DistanceSample};
pub use lod::{
    eye_levels, intersect_lod, intersect_lod_packet, level_for_distance, pixel_angle, LevelChoice,
    LodHit,
};
pub use normal::hit_normal;
pub use packet::{intersect_packet, RayPacket, PACKET_SIZE};
pub use ray_voxel::{intersect_voxel, intersect_voxel_where, unit_cube_span};
pub use traversal::{intersect, occluded, occupied_bounds, ray_meets_box, Hit, Ray};
