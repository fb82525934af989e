//! Small geometric helpers of the builder: triangle clipping against a box and the distance of
//! an interpolant's zero set. What a voxel is (corner order, interpolant) is the format's.

use glam::Vec3;

pub use sdfmo_format::{corner_offset, trilinear, trilinear_gradient};

/// Most vertices a triangle clipped by the six planes of a box can have.
pub const MAX_CLIP: usize = 9;

/// Clips triangle `tri` to the box `[lo, hi]` (Sutherland–Hodgman over the six planes); writes
/// the polygon into `out` and returns its vertex count (0 when the triangle misses the box).
pub fn clip_triangle(tri: [Vec3; 3], lo: Vec3, hi: Vec3, out: &mut [Vec3; MAX_CLIP + 1]) -> usize {
    let mut buf_a = [Vec3::ZERO; MAX_CLIP + 1];
    let mut n = 3;
    buf_a[..3].copy_from_slice(&tri);
    let mut buf_b = [Vec3::ZERO; MAX_CLIP + 1];
    let mut src = &mut buf_a;
    let mut dst = &mut buf_b;
    for axis in 0..3 {
        for side in 0..2 {
            // Keep the half-space s·(p[axis] − bound) ≤ 0.
            let (bound, s) = if side == 0 {
                (lo[axis], -1.0f32)
            } else {
                (hi[axis], 1.0f32)
            };
            let mut m = 0;
            for i in 0..n {
                let p = src[i];
                let q = src[(i + 1) % n];
                let dp = s * (p[axis] - bound);
                let dq = s * (q[axis] - bound);
                if dp <= 0.0 && m < MAX_CLIP + 1 {
                    dst[m] = p;
                    m += 1;
                }
                if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                    let t = dp / (dp - dq);
                    let mut x = p + (q - p) * t;
                    x[axis] = bound;
                    if m < MAX_CLIP + 1 {
                        dst[m] = x;
                        m += 1;
                    }
                }
            }
            n = m;
            std::mem::swap(&mut src, &mut dst);
            if n == 0 {
                return 0;
            }
        }
    }
    out[..n].copy_from_slice(&src[..n]);
    n
}

/// How far (in cell edges, capped at 1) the zero set of the trilinear interpolant `c` of a
/// signed distance with cell edge `h` is from the point `l` (local coordinates) that should lie
/// on it: `|f| / |∇f|` to first order, the gradient counted at most at its signed-distance
/// value (1 per unit length), so the estimate is never below `|f| / h`.
///
/// `|f|` alone is blind to a collapsed gradient: a plate thinner than the cell lying on the
/// cell's diagonal gives corners `+a, −b, −b, +a` whose interpolant is a saddle, `|f|` about
/// `0.18 h` on the plate's faces while the zero set only hugs two cell edges, so a ray through
/// the middle of the cell misses the plate (vertical stripes). The gradient there is a third of
/// a distance's, which the estimate turns into the real gap.
#[inline]
pub fn zero_set_gap(c: &[f32; 8], l: Vec3, h: f32) -> f32 {
    let f = trilinear(c, l).abs();
    let g = trilinear_gradient(c, l).length().min(h);
    if f < g {
        f / g
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_keeps_the_inside() {
        let mut out = [Vec3::ZERO; MAX_CLIP + 1];
        // Inside: unchanged.
        let t = [
            Vec3::splat(0.1),
            Vec3::new(0.5, 0.1, 0.1),
            Vec3::new(0.1, 0.5, 0.1),
        ];
        assert_eq!(clip_triangle(t, Vec3::ZERO, Vec3::ONE, &mut out), 3);
        // Outside: empty.
        let t = [
            Vec3::splat(2.0),
            Vec3::new(3.0, 2.0, 2.0),
            Vec3::new(2.0, 3.0, 2.0),
        ];
        assert_eq!(clip_triangle(t, Vec3::ZERO, Vec3::ONE, &mut out), 0);
        // A big triangle in the plane z = 0.5 clipped to the unit square: four corners.
        let t = [
            Vec3::new(-10.0, -10.0, 0.5),
            Vec3::new(10.0, -10.0, 0.5),
            Vec3::new(-10.0, 30.0, 0.5),
        ];
        let n = clip_triangle(t, Vec3::ZERO, Vec3::ONE, &mut out);
        assert_eq!(n, 4);
        for p in &out[..n] {
            assert!(p.cmpge(Vec3::splat(-1e-6)).all() && p.cmple(Vec3::splat(1.0 + 1e-6)).all());
        }
    }

    /// The demo part's thin plate (0.4 voxel thick at depth 7, its mid-plane on the cells'
    /// diagonal x + z = const): leaf (96, 19, 31) gets these global corners (cell units).
    /// Its interpolant is a saddle: on the plate's face (u + w = 1.283, centroid of the clipped
    /// face at u = w = 0.6415) `|f|` is only 0.18 of a cell, below the thin-split threshold 0.2,
    /// yet the zero set only hugs the two cell edges where the plate's mid-plane meets them, and a
    /// ray through the middle of the cell misses the plate (the vertical stripes).
    #[test]
    fn saddle_of_a_diagonal_thin_plate_is_far_from_its_zero_set() {
        let c = [0.505, -0.205, 0.505, -0.205, -0.205, 0.505, -0.205, 0.505];
        let face = Vec3::new(0.6415, 0.5, 0.6415);
        let f = trilinear(&c, face);
        assert!(f > 0.17 && f < 0.19, "{f}");
        let gap = zero_set_gap(&c, face, 1.0);
        assert!(gap > 0.5, "{gap}");
        // Along the plate's normal through the face point, the interpolant stays positive:
        // there really is no zero within the cell's middle.
        for k in 0..=10 {
            let s = -0.3 + 0.06 * k as f32;
            assert!(trilinear(&c, face + Vec3::new(s, 0.0, s)) > 0.1);
        }
        // An exact distance (a plane) keeps the estimate at |f|.
        let plane: [f32; 8] =
            std::array::from_fn(|i| corner_offset(i).dot(Vec3::new(0.6, 0.0, 0.8)) - 0.5);
        let l = Vec3::new(0.3, 0.7, 0.2);
        assert!((zero_set_gap(&plane, l, 1.0) - trilinear(&plane, l).abs()).abs() < 1e-6);
        // A value beyond the gradient caps at one cell.
        assert_eq!(zero_set_gap(&[1.0; 8], l, 1.0), 1.0);
    }
}
