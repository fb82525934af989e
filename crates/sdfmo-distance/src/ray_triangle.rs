//! Watertight ray–triangle intersection (Woop, Benthin & Wald, "Watertight Ray/Triangle
//! Intersection", JCGT 2013).
//!
//! The ray is sheared so that it runs along +z of a permuted frame; the three 2D edge functions
//! of the triangle are then evaluated at the origin. A shared edge of two triangles produces the
//! same edge function (with opposite sign) from both sides, so a ray through an edge or a vertex
//! of a closed mesh hits at least one of its triangles: nothing slips through. When an edge
//! function comes out exactly zero in f32 it is recomputed in f64, as the paper prescribes.
//! Both faces count as hits (no back-face culling).

use glam::Vec3;

/// A ray prepared for the watertight test: permutation and shear constants.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl WatertightRay {
    /// Prepares `origin + t·dir`; `None` when `dir` is zero or not finite (no ray).
    pub fn new(origin: Vec3, dir: Vec3) -> Option<WatertightRay> {
        if !dir.is_finite() || !origin.is_finite() || dir == Vec3::ZERO {
            return None;
        }
        let ad = dir.abs();
        let kz = if ad.x >= ad.y && ad.x >= ad.z {
            0
        } else if ad.y >= ad.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keep the winding of the permuted frame when the dominant direction is negative.
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Some(WatertightRay {
            origin,
            kx,
            ky,
            kz,
            sx: dir[kx] / dir[kz],
            sy: dir[ky] / dir[kz],
            sz: 1.0 / dir[kz],
        })
    }

    /// Ray parameter t of the hit with triangle `(a, b, c)` if it lies in `[t_min, t_max]`.
    #[inline]
    pub fn intersect(&self, a: Vec3, b: Vec3, c: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let a = a - self.origin;
        let b = b - self.origin;
        let c = c - self.origin;
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Exactly on an edge in f32: decide in f64 so both neighbours agree.
            let (ax, ay, bx, by, cx, cy) = (
                ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
            );
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t = (u * az + v * bz + w * cz) / det;
        if t >= t_min && t <= t_max {
            Some(t)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_the_interior_and_misses_outside() {
        let (a, b, c) = (
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        );
        let r = WatertightRay::new(Vec3::new(0.2, 0.2, 0.0), Vec3::Z).unwrap();
        let t = r.intersect(a, b, c, 0.0, 10.0).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        // Back face too.
        let r = WatertightRay::new(Vec3::new(0.2, 0.2, 2.0), -Vec3::Z).unwrap();
        assert!((r.intersect(a, b, c, 0.0, 10.0).unwrap() - 1.0).abs() < 1e-6);
        let r = WatertightRay::new(Vec3::new(0.8, 0.8, 0.0), Vec3::Z).unwrap();
        assert!(r.intersect(a, b, c, 0.0, 10.0).is_none());
        // Outside the t interval.
        let r = WatertightRay::new(Vec3::new(0.2, 0.2, 0.0), Vec3::Z).unwrap();
        assert!(r.intersect(a, b, c, 0.0, 0.5).is_none());
    }

    #[test]
    fn a_ray_through_a_shared_edge_hits_one_side() {
        // Two triangles sharing the diagonal of the unit square at z = 1.
        let p = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]].map(|[x, y]| Vec3::new(x, y, 1.0));
        for i in 0..=100 {
            let s = i as f32 / 100.0;
            let r = WatertightRay::new(Vec3::new(s, s, -1.0), Vec3::new(0.0, 0.0, 1.0)).unwrap();
            let h1 = r.intersect(p[0], p[1], p[2], 0.0, 10.0);
            let h2 = r.intersect(p[0], p[2], p[3], 0.0, 10.0);
            assert!(
                h1.is_some() || h2.is_some(),
                "ray through ({s}, {s}) slipped through"
            );
        }
    }

    #[test]
    fn zero_and_non_finite_directions_are_no_ray() {
        assert!(WatertightRay::new(Vec3::ZERO, Vec3::ZERO).is_none());
        assert!(WatertightRay::new(Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 1.0)).is_none());
        assert!(WatertightRay::new(Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::X).is_none());
    }
}
