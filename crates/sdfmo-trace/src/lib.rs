//! Ray tracing the packed SDF multi-octree: front-to-back traversal of a
//! [`PackedOctree`](sdfmo_format::PackedOctree) and the ray vs trilinear-voxel kernel.

#![deny(missing_docs)]

pub mod ray_voxel;

pub use ray_voxel::{intersect_voxel, unit_cube_span};
