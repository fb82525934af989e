//! The normal at a hit: the analytic gradient of the voxel's trilinear interpolant.

use glam::Vec3;
use sdfmo_format::trilinear_gradient;

use crate::traversal::{Hit, Ray};

/// Unit gradient of the voxel's interpolant at the hit, flipped so `dot(n, ray.dir) ≤ 0`
/// (two-sided, facing the viewer), from the corners the hit carries ([`Hit::corners`]: no read
/// of the octree). Where the gradient vanishes (a saddle) the normal is `−dir`. Never NaN for a
/// finite ray.
pub fn hit_normal<V>(ray: &Ray, hit: &Hit<V>) -> Vec3 {
    // Only needed where the gradient fails: computed there (a square root and a division less
    // per hit).
    let facing = || (-ray.dir).try_normalize().unwrap_or(Vec3::Z);
    if hit.cell_size.is_nan() || hit.cell_size <= 0.0 {
        return facing();
    }
    let p = ray.origin + ray.dir * hit.t;
    let local = ((p - hit.cell_min) / hit.cell_size).clamp(Vec3::ZERO, Vec3::ONE);
    // The local gradient is the world gradient times the cell size: same direction.
    match trilinear_gradient(&hit.corners, local).try_normalize() {
        Some(n) if n.dot(ray.dir) > 0.0 => -n,
        Some(n) => n,
        None => facing(),
    }
}
