//! The normal at a hit: the analytic gradient of the voxel's trilinear interpolant.

use glam::Vec3;
use sdfmo_format::OctreeAccess;

use crate::traversal::{Hit, Ray};

/// Unit gradient of the voxel's interpolant at the hit, flipped so `dot(n, ray.dir) ≤ 0`
/// (two-sided, facing the viewer). Where the gradient vanishes (a saddle, or a hit that does not
/// belong to this octree) the normal is `−dir`. Never NaN for a finite ray.
pub fn hit_normal<O: OctreeAccess + ?Sized>(octree: &O, ray: &Ray, hit: &Hit) -> Vec3 {
    let facing = (-ray.dir).try_normalize().unwrap_or(Vec3::Z);
    if (hit.voxel as usize) >= octree.voxel_count()
        || hit.cell_size.is_nan()
        || hit.cell_size <= 0.0
    {
        return facing;
    }
    let corners = octree.voxel_corners(hit.voxel);
    let p = ray.origin + ray.dir * hit.t;
    let local = ((p - hit.cell_min) / hit.cell_size).clamp(Vec3::ZERO, Vec3::ONE);
    // The local gradient is the world gradient times the cell size: same direction.
    match trilinear_gradient(&corners, local).try_normalize() {
        Some(n) if n.dot(ray.dir) > 0.0 => -n,
        Some(n) => n,
        None => facing,
    }
}

/// Gradient of the trilinear interpolant of `corners` at local point `p`, in local units
/// (divide by the cell size for world units).
#[inline]
pub fn trilinear_gradient(corners: &[f32; 8], p: Vec3) -> Vec3 {
    let [c000, c001, c010, c011, c100, c101, c110, c111] = *corners;
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let (x, y, z) = (p.x, p.y, p.z);
    // d/dx: difference of the two x faces, bilinear in (y, z).
    let dx = lerp(
        lerp(c100 - c000, c101 - c001, z),
        lerp(c110 - c010, c111 - c011, z),
        y,
    );
    let dy = lerp(
        lerp(c010 - c000, c011 - c001, z),
        lerp(c110 - c100, c111 - c101, z),
        x,
    );
    let dz = lerp(
        lerp(c001 - c000, c011 - c010, y),
        lerp(c101 - c100, c111 - c110, y),
        x,
    );
    Vec3::new(dx, dy, dz)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_of_a_linear_field_is_exact() {
        // f = 0.3x − 0.5y + 0.2z + 0.1 everywhere in the cube.
        let c: [f32; 8] = core::array::from_fn(|i| {
            let (x, y, z) = ((i >> 2) as f32, ((i >> 1) & 1) as f32, (i & 1) as f32);
            0.3 * x - 0.5 * y + 0.2 * z + 0.1
        });
        for p in [Vec3::ZERO, Vec3::splat(0.5), Vec3::new(0.9, 0.1, 0.7)] {
            let g = trilinear_gradient(&c, p);
            assert!((g - Vec3::new(0.3, -0.5, 0.2)).length() < 1e-6, "{g}");
        }
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let c = [0.3f32, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2, -0.7];
        let p = Vec3::new(0.3, 0.6, 0.2);
        let h = 1e-3;
        let f = |q: Vec3| crate::ray_voxel::trilinear(&c, q);
        let fd = Vec3::new(
            f(p + Vec3::X * h) - f(p - Vec3::X * h),
            f(p + Vec3::Y * h) - f(p - Vec3::Y * h),
            f(p + Vec3::Z * h) - f(p - Vec3::Z * h),
        ) / (2.0 * h);
        assert!((trilinear_gradient(&c, p) - fd).length() < 1e-3);
    }
}
