//! What a voxel *is*: eight corner values in the order `i = 4x + 2y + z` and their trilinear
//! interpolant over the cell. The builder samples it, the tracer intersects it, collision
//! queries evaluate it; each uses these functions, so the three can never disagree.

use glam::Vec3;

/// Offset of corner `i` (`4x + 2y + z`) in units of the cell size.
#[inline]
pub fn corner_offset(i: usize) -> Vec3 {
    Vec3::new(((i >> 2) & 1) as f32, ((i >> 1) & 1) as f32, (i & 1) as f32)
}

/// Edge of a cell at `depth` levels below the root cube `[-1, 1]³`: `2 / 2^depth`, exact in f32
/// (a depth above 63 counts as 63). The leaf size of an octree of that depth.
#[inline]
pub fn cell_size(depth: u8) -> f32 {
    2.0 / (1u64 << depth.min(63)) as f32
}

/// The values of `f` at the eight corners (order `4x + 2y + z`) of the leaf cell `coord` of an
/// octree of `depth` over the root cube `[-1, 1]³`: a voxel sampling `f` exactly there.
pub fn cell_corners(depth: u8, coord: [u32; 3], f: impl Fn(Vec3) -> f32) -> [f32; 8] {
    let h = cell_size(depth);
    let lo = Vec3::new(coord[0] as f32, coord[1] as f32, coord[2] as f32) * h - 1.0;
    core::array::from_fn(|i| f(lo + corner_offset(i) * h))
}

/// Integer coordinate of child `octant` (`4x + 2y + z`, the corner order) of the cell at
/// `parent`, one level down.
#[inline]
pub fn child_coord(parent: [u32; 3], octant: u8) -> [u32; 3] {
    let o = u32::from(octant);
    [
        2 * parent[0] + (o >> 2),
        2 * parent[1] + (o >> 1 & 1),
        2 * parent[2] + (o & 1),
    ]
}

/// The trilinear interpolant of `corners` (index `4x + 2y + z`) at local coordinates `l ∈ [0,1]³`.
#[inline]
pub fn trilinear(c: &[f32; 8], l: Vec3) -> f32 {
    let (x, y, z) = (l.x, l.y, l.z);
    let c00 = c[0] + (c[1] - c[0]) * z;
    let c01 = c[2] + (c[3] - c[2]) * z;
    let c10 = c[4] + (c[5] - c[4]) * z;
    let c11 = c[6] + (c[7] - c[6]) * z;
    let c0 = c00 + (c01 - c00) * y;
    let c1 = c10 + (c11 - c10) * y;
    c0 + (c1 - c0) * x
}

/// The gradient of the trilinear interpolant of `c` with respect to the local coordinates
/// `l ∈ [0,1]³` (value units per cell edge).
#[inline]
pub fn trilinear_gradient(c: &[f32; 8], l: Vec3) -> Vec3 {
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let (x, y, z) = (l.x, l.y, l.z);
    // Differences along each axis, interpolated over the other two.
    let dx = lerp(
        lerp(c[4] - c[0], c[5] - c[1], z),
        lerp(c[6] - c[2], c[7] - c[3], z),
        y,
    );
    let dy = lerp(
        lerp(c[2] - c[0], c[3] - c[1], z),
        lerp(c[6] - c[4], c[7] - c[5], z),
        x,
    );
    let dz = lerp(
        lerp(c[1] - c[0], c[3] - c[2], y),
        lerp(c[5] - c[4], c[7] - c[6], y),
        x,
    );
    Vec3::new(dx, dy, dz)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trilinear_reproduces_linear_functions() {
        let f = |p: Vec3| 0.3 * p.x - 0.7 * p.y + 0.2 * p.z + 0.1;
        let mut c = [0.0; 8];
        for (i, ci) in c.iter_mut().enumerate() {
            *ci = f(corner_offset(i));
        }
        for p in [
            Vec3::ZERO,
            Vec3::ONE,
            Vec3::new(0.25, 0.5, 0.75),
            Vec3::new(0.9, 0.1, 0.4),
        ] {
            assert!((trilinear(&c, p) - f(p)).abs() < 1e-6);
        }
    }

    #[test]
    fn trilinear_gradient_matches_finite_differences() {
        let c = [0.3, -0.7, 1.1, 0.2, -0.4, 0.9, -1.3, 0.5];
        for l in [
            Vec3::splat(0.5),
            Vec3::new(0.1, 0.8, 0.3),
            Vec3::new(0.9, 0.2, 0.6),
        ] {
            let g = trilinear_gradient(&c, l);
            let e = 1e-3;
            for (axis, d) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
                let fd = (trilinear(&c, l + d * e) - trilinear(&c, l - d * e)) / (2.0 * e);
                assert!((g[axis] - fd).abs() < 1e-3, "{axis}: {} vs {fd}", g[axis]);
            }
        }
    }

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
        let f = |q: Vec3| trilinear(&c, q);
        let fd = Vec3::new(
            f(p + Vec3::X * h) - f(p - Vec3::X * h),
            f(p + Vec3::Y * h) - f(p - Vec3::Y * h),
            f(p + Vec3::Z * h) - f(p - Vec3::Z * h),
        ) / (2.0 * h);
        assert!((trilinear_gradient(&c, p) - fd).length() < 1e-3);
    }
}
