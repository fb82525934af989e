//! The [`Traceable`] trait (what the renderer can ray trace) and an analytic scene of spheres.

use glam::Vec3;
use sdfmo_trace::RayPacket;

/// Rays per packet of [`Traceable::first_hits`] (that of `sdfmo_trace::intersect_packet`).
pub const PACKET: usize = sdfmo_trace::PACKET_SIZE;

/// Default offset of secondary rays, normalised units.
pub const DEFAULT_EPSILON: f32 = 1e-4;

/// What can be ray traced: the packed octree ([`crate::OctreeScene`]), the source mesh
/// ([`crate::MeshScene`]) and analytic scenes ([`Spheres`]). The renderer is generic over it
/// (monomorphised: no dynamic dispatch per ray).
///
/// Directions passed in are unit length; `t` is the distance along the ray.
pub trait Traceable: Sync {
    /// What a hit remembers so that its normal can be evaluated later, only if needed.
    type Hit: Copy;

    /// The closest hit with `t ∈ [t_min, t_max]`.
    fn first_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<Self::Hit>;

    /// The distance `t` of a hit.
    fn hit_t(&self, hit: &Self::Hit) -> f32;

    /// The unit normal at a hit of the ray (`origin`, `dir`). It may face either way: the
    /// renderer flips it toward the viewer (two-sided shading).
    fn normal(&self, origin: Vec3, dir: Vec3, hit: &Self::Hit) -> Vec3;

    /// Whether anything is hit with `t ∈ [t_min, t_max]` (any hit, not the closest).
    fn occluded(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        self.first_hit(origin, dir, t_min, t_max).is_some()
    }

    /// The closest hit in `[0, t_max]` of each traced lane `i` of `rays` into `out[i]` (other
    /// entries are left alone): primary rays of neighbouring pixels, traced together. Must give
    /// exactly what [`Traceable::first_hit`] gives ray by ray (the default does just that; the
    /// octree walks the octree once per packet).
    fn first_hits(&self, rays: &RayPacket, out: &mut [Option<Self::Hit>; PACKET]) {
        for (l, dir) in rays.dirs.iter().enumerate() {
            if rays.lanes >> l & 1 != 0 {
                out[l] = self.first_hit(rays.origin, *dir, 0.0, rays.t_max);
            }
        }
    }

    /// Offset of secondary-ray origins along the normal, normalised units.
    fn epsilon(&self) -> f32 {
        DEFAULT_EPSILON
    }

    /// A box containing the scene, `(min, max)`: the depth-image grey scale is derived from it.
    /// The root cube [-1, 1]³ by default (octrees and normalised meshes).
    fn bounds(&self) -> (Vec3, Vec3) {
        (Vec3::splat(-1.0), Vec3::ONE)
    }

    /// A box every hit lies in, `(min, max)`: the renderer skips rays that miss it (padded by
    /// [`OCCUPIED_PAD`]) without tracing them. Called once per render. `None` (the default):
    /// no such box is known, every ray is traced.
    fn occupied_bounds(&self) -> Option<(Vec3, Vec3)> {
        None
    }

    /// A box every hit of a primary ray from `eye` ([`Traceable::first_hits`] with that
    /// origin) lies in, `(min, max)`, padded and used as [`Traceable::occupied_bounds`] is, for
    /// the primary rays of a render that traces no other rays. By default the occupied box; a
    /// scene whose rays from `eye` see only part of it (a file with levels seen from far: the
    /// levels its distances choose) returns that part's box, found with less work.
    fn primary_bounds(&self, eye: Vec3) -> Option<(Vec3, Vec3)> {
        let _ = eye;
        self.occupied_bounds()
    }
}

/// Padding of [`Traceable::occupied_bounds`] before rays are tested against it, normalised
/// units: far above the rounding of hit points (about 1e-6), so no hit is ever rejected.
pub const OCCUPIED_PAD: f32 = 1e-3;

/// An analytic scene: a union of spheres (a real renderer input for tests and demos).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Spheres {
    /// (centre, radius) of each sphere; radii must be positive.
    pub spheres: Vec<(Vec3, f32)>,
}

/// A hit on [`Spheres`]: distance and the sphere's index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereHit {
    /// Distance along the ray.
    pub t: f32,
    /// Index of the sphere hit.
    pub sphere: u32,
}

impl Spheres {
    /// One sphere.
    pub fn one(center: Vec3, radius: f32) -> Spheres {
        Spheres {
            spheres: vec![(center, radius)],
        }
    }
}

/// First root of |o + t·d − c|² = r² in [t_min, t_max] (entry or, from inside, exit).
fn sphere_t(c: Vec3, r: f32, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
    let oc = o - c;
    let b = oc.dot(d);
    let cc = oc.length_squared() - r * r;
    let disc = b * b - cc;
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    // numerically stable pair of roots
    let q = if b > 0.0 { -b - s } else { -b + s };
    let (mut t0, mut t1) = if q != 0.0 { (q, cc / q) } else { (0.0, 0.0) };
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    [t0, t1].into_iter().find(|t| *t >= t_min && *t <= t_max)
}

impl Traceable for Spheres {
    type Hit = SphereHit;

    fn first_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<SphereHit> {
        let mut best: Option<SphereHit> = None;
        for (i, &(c, r)) in self.spheres.iter().enumerate() {
            let limit = best.map_or(t_max, |h| h.t);
            if let Some(t) = sphere_t(c, r, origin, dir, t_min, limit) {
                if best.is_none_or(|h| t < h.t) {
                    best = Some(SphereHit {
                        t,
                        sphere: i as u32,
                    });
                }
            }
        }
        best
    }

    fn hit_t(&self, hit: &SphereHit) -> f32 {
        hit.t
    }

    fn normal(&self, origin: Vec3, dir: Vec3, hit: &SphereHit) -> Vec3 {
        let (c, _) = self.spheres[hit.sphere as usize];
        (origin + dir * hit.t - c).normalize_or(-dir)
    }

    fn bounds(&self) -> (Vec3, Vec3) {
        let mut min = Vec3::INFINITY;
        let mut max = Vec3::NEG_INFINITY;
        for &(c, r) in &self.spheres {
            min = min.min(c - Vec3::splat(r));
            max = max.max(c + Vec3::splat(r));
        }
        if self.spheres.is_empty() {
            (Vec3::splat(-1.0), Vec3::ONE)
        } else {
            (min, max)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_hits_entry_and_exit() {
        let s = Spheres::one(Vec3::ZERO, 1.0);
        let h = s
            .first_hit(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((h.t - 2.0).abs() < 1e-6);
        let n = s.normal(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, &h);
        assert!((n - Vec3::Z).length() < 1e-6);
        // from inside: the exit
        let h = s
            .first_hit(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY)
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        // t range respected
        assert!(s
            .first_hit(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, 0.0, 1.9)
            .is_none());
        assert!(s
            .first_hit(Vec3::new(0.0, 2.0, 3.0), -Vec3::Z, 0.0, 10.0)
            .is_none());
        assert!(s.occluded(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, 0.0, 10.0));
    }

    #[test]
    fn nearest_of_several_spheres() {
        let s = Spheres {
            spheres: vec![
                (Vec3::new(0.0, 0.0, -2.0), 0.5),
                (Vec3::new(0.0, 0.0, 1.0), 0.5),
            ],
        };
        let h = s
            .first_hit(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert_eq!(h.sphere, 1);
        assert!((h.t - 1.5).abs() < 1e-6);
        let (min, max) = s.bounds();
        assert_eq!(
            (min, max),
            (Vec3::new(-0.5, -0.5, -2.5), Vec3::new(0.5, 0.5, 1.5))
        );
    }
}
