//! Exact triangle–box overlap by the separating axis theorem (Akenine-Möller 2001).
//!
//! Thirteen candidate axes: the three box normals (done first, as a bounding-box test), the
//! triangle normal, then the nine cross products of the box axes with the triangle edges. The box
//! is an axis-aligned cube given by its centre and half size; the caller inflates the half size
//! to keep every leaf whose interpolant may cross zero (see `crate::subdivide`).

use glam::Vec3;

/// Whether triangle `(a, b, c)` overlaps the axis-aligned box `center ± half`.
///
/// Touching counts as overlapping (all comparisons are non-strict), and a degenerate triangle
/// (zero area) is tested against the box through its edges alone, which is exact for a segment
/// or a point as well.
#[inline]
pub fn tri_box_overlap(center: Vec3, half: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    let v0 = a - center;
    let v1 = b - center;
    let v2 = c - center;

    // Box normals: the bounding box of the triangle against the box.
    let mn = v0.min(v1).min(v2);
    let mx = v0.max(v1).max(v2);
    if mn.x > half.x
        || mx.x < -half.x
        || mn.y > half.y
        || mx.y < -half.y
        || mn.z > half.z
        || mx.z < -half.z
    {
        return false;
    }

    let e0 = v1 - v0;
    let e1 = v2 - v1;
    let e2 = v0 - v2;

    // Triangle normal: the plane against the box. Before the nine edge axes (the answer is
    // their conjunction, so the order changes nothing): one axis instead of nine for the
    // children of a subdivided cell that the triangle's plane misses.
    let n = e0.cross(e1);
    let r = half.x * n.x.abs() + half.y * n.y.abs() + half.z * n.z.abs();
    let d = n.dot(v0);
    let plane_meets_box = d.abs() <= r; // (false for NaN, as before)
    if !plane_meets_box {
        return false;
    }

    // Nine edge cross-product axes. For axis a = (box axis k) × e, the projections of the three
    // vertices take at most two distinct values (two vertices share the edge), so testing the
    // extreme of the three is exact.
    for e in [e0, e1, e2] {
        // X × e = (0, −e.z, e.y)
        let axis = Vec3::new(0.0, -e.z, e.y);
        if separated(axis, half, v0, v1, v2) {
            return false;
        }
        // Y × e = (e.z, 0, −e.x)
        let axis = Vec3::new(e.z, 0.0, -e.x);
        if separated(axis, half, v0, v1, v2) {
            return false;
        }
        // Z × e = (−e.y, e.x, 0)
        let axis = Vec3::new(-e.y, e.x, 0.0);
        if separated(axis, half, v0, v1, v2) {
            return false;
        }
    }

    true
}

#[inline(always)]
fn separated(axis: Vec3, half: Vec3, v0: Vec3, v1: Vec3, v2: Vec3) -> bool {
    let p0 = axis.dot(v0);
    let p1 = axis.dot(v1);
    let p2 = axis.dot(v2);
    let r = half.x * axis.x.abs() + half.y * axis.y.abs() + half.z * axis.z.abs();
    let mn = p0.min(p1).min(p2);
    let mx = p0.max(p1).max(p2);
    mn > r || mx < -r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute-force oracle: the triangle overlaps the box iff the closest point of the triangle
    /// to the box lies in the box; sampled densely on the triangle instead (a conservative
    /// check used only in one direction below).
    fn sampled_overlap(center: Vec3, half: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
        let n = 60;
        for i in 0..=n {
            for j in 0..=(n - i) {
                let u = i as f32 / n as f32;
                let v = j as f32 / n as f32;
                let p = a + (b - a) * u + (c - a) * v;
                let d = (p - center).abs();
                if d.x <= half.x && d.y <= half.y && d.z <= half.z {
                    return true;
                }
            }
        }
        false
    }

    #[test]
    fn inside_outside_and_crossing() {
        let c = Vec3::ZERO;
        let h = Vec3::splat(0.5);
        // Fully inside.
        assert!(tri_box_overlap(
            c,
            h,
            Vec3::splat(0.1),
            Vec3::new(0.2, 0.1, 0.1),
            Vec3::new(0.1, 0.2, 0.1)
        ));
        // Far away.
        assert!(!tri_box_overlap(
            c,
            h,
            Vec3::splat(2.0),
            Vec3::new(3.0, 2.0, 2.0),
            Vec3::new(2.0, 3.0, 2.0)
        ));
        // Big triangle slicing through the box, all vertices outside.
        assert!(tri_box_overlap(
            c,
            h,
            Vec3::new(-10.0, -10.0, 0.0),
            Vec3::new(10.0, -10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0)
        ));
        // Bounding boxes overlap but the triangle passes beside a corner of the box.
        assert!(!tri_box_overlap(
            c,
            h,
            Vec3::new(0.6, 1.5, 0.0),
            Vec3::new(1.5, 0.6, 0.0),
            Vec3::new(1.5, 1.5, 0.0)
        ));
        // Plane misses: triangle parallel to a face just outside it.
        assert!(!tri_box_overlap(
            c,
            h,
            Vec3::new(-1.0, -1.0, 0.51),
            Vec3::new(1.0, -1.0, 0.51),
            Vec3::new(0.0, 1.0, 0.51)
        ));
    }

    #[test]
    fn agrees_with_sampling_on_random_triangles() {
        // Deterministic pseudo-random triangles around a unit box; the SAT must report an
        // overlap whenever dense sampling finds a point inside, and must not when the triangle
        // is farther than the sampling resolution from the box.
        let mut rng = sdfmo_io::SplitMix64::new(0x2545_f491_4f6c_dd1d);
        let mut rnd = || rng.range(-1.5, 1.5);
        let c = Vec3::ZERO;
        let h = Vec3::splat(0.5);
        let mut hits = 0;
        for _ in 0..3000 {
            let a = Vec3::new(rnd(), rnd(), rnd());
            let b = Vec3::new(rnd(), rnd(), rnd());
            let cc = Vec3::new(rnd(), rnd(), rnd());
            let sat = tri_box_overlap(c, h, a, b, cc);
            if sampled_overlap(c, h, a, b, cc) {
                assert!(sat, "missed overlap {a} {b} {cc}");
                hits += 1;
            }
            if sat {
                // A slightly larger box must then contain a sample.
                assert!(
                    sampled_overlap(c, h + Vec3::splat(0.15), a, b, cc),
                    "false overlap {a} {b} {cc}"
                );
            }
        }
        assert!(hits > 100);
    }
}
