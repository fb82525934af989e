//! Levels of detail (`.smo` 2.0, [`LodOctree`]): tracing a file at one level, or at the level
//! each ray needs by screen-space error.
//!
//! Level `k` of a file with levels is a complete octree of depth `k` ([`LodOctree::level`]):
//! every query of this crate takes it as it is — [`intersect`], [`intersect_packet`],
//! [`distance_at`](crate::distance_at), [`hit_normal`](crate::hit_normal) — so a traversal
//! "stopped at level `k`" is the traversal of that octree. What is new here is the per-ray
//! choice: [`intersect_lod`] with [`LevelChoice::PixelError`] lets each ray stop at the
//! coarsest level whose voxels project below a number of pixels at the hit distance.

use glam::Vec3;
use sdfmo_format::{cell_size, LodOctree, PackedOctree};

use crate::packet::{intersect_packet, RayPacket, PACKET_SIZE};
use crate::ray_voxel::unit_cube_span;
use crate::traversal::{intersect, Hit, Ray};

/// Which level a ray is traced at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LevelChoice {
    /// This level (clamped to the file's levels).
    Level(u8),
    /// The coarsest level whose voxel edge `2 / 2^k` projects to at most `pixels` pixels at the
    /// hit distance `t`: `2 / 2^k ≤ pixels · t · pixel_angle`, with `pixel_angle` the angle one
    /// pixel subtends (a pinhole camera of vertical field of view `fov` and `height` pixels:
    /// `2 · tan(fov / 2) / height`, [`pixel_angle`]). The ray's direction must be unit length,
    /// so that `t` is a distance.
    PixelError {
        /// The largest projected voxel edge allowed, in pixels (> 0).
        pixels: f32,
        /// Radians per pixel (> 0).
        pixel_angle: f32,
    },
}

/// Radians one pixel subtends at the centre of a pinhole camera of vertical field of view
/// `fov_degrees` and `height` pixels: `2 · tan(fov / 2) / height`.
pub fn pixel_angle(fov_degrees: f32, height: u32) -> f32 {
    2.0 * (0.5 * fov_degrees.to_radians()).tan() / height as f32
}

/// The coarsest level in `coarsest..=finest` whose voxel edge `2 / 2^k` projects to at most
/// `pixels` pixels at distance `t` (`finest` when none does; `coarsest` at `t = ∞`).
pub fn level_for_distance(t: f32, pixels: f32, pixel_angle: f32, coarsest: u8, finest: u8) -> u8 {
    let budget = pixels * t * pixel_angle;
    (coarsest..=finest)
        .find(|&k| cell_size(k) <= budget)
        .unwrap_or(finest)
}

/// The levels a hit of `ray` in `[t_min, t_max]` can need by [`LevelChoice::PixelError`]:
/// `(near, far)`, those of the ends of its span in the root cube `[-1, 1]³` (distances are
/// `t · |dir|`); `None` when the span is empty.
fn span_levels(
    lod: &LodOctree,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    pixels: f32,
    pixel_angle: f32,
) -> Option<(u8, u8)> {
    // The root cube [-1, 1]³ is the unit cube at (p + 1) / 2, with the same t.
    let (t_in, t_out) = unit_cube_span((ray.origin + Vec3::ONE) * 0.5, ray.dir * 0.5)?;
    let (t_in, t_out) = (t_in.max(t_min), t_out.min(t_max));
    if t_in > t_out {
        return None;
    }
    let scale = ray.dir.length();
    let at =
        |t: f32| level_for_distance(t * scale, pixels, pixel_angle, lod.coarsest(), lod.depth());
    Some((at(t_in), at(t_out)))
}

/// The levels the nearest and the farthest point of the root cube `[-1, 1]³` from `origin` need
/// by [`LevelChoice::PixelError`], `(near, far)`: every ray from `origin` needs levels between
/// them inside the cube ([`span_levels`] lies within), so where they are equal every ray from
/// `origin` needs that one level. The distances are widened (relative 1e-5, absolute 1e-5 ×
/// the larger) so that a ray's rounded span cannot step outside them.
fn cube_levels(lod: &LodOctree, origin: Vec3, pixels: f32, pixel_angle: f32) -> (u8, u8) {
    let nearest = origin.clamp(Vec3::NEG_ONE, Vec3::ONE);
    let farthest = Vec3::select(origin.cmpge(Vec3::ZERO), Vec3::NEG_ONE, Vec3::ONE);
    let d_max = (origin - farthest).length();
    let slack = 1e-5 * (1.0 + d_max);
    let d_min = (origin - nearest).length() * (1.0 - 1e-5) - slack;
    let d_max = d_max * (1.0 + 1e-5) + slack;
    let at = |d: f32| level_for_distance(d, pixels, pixel_angle, lod.coarsest(), lod.depth());
    (at(d_min.max(0.0)), at(d_max))
}

/// The levels [`LevelChoice::PixelError`] can choose for rays from `eye`: `(coarsest,
/// finest)`, those the farthest and the nearest point of the root cube `[-1, 1]³` need (the
/// same widened distances as the packet shortcut). Every hit [`intersect_lod`] returns for a
/// ray from `eye` is at a level between them; where they are equal, every ray is traced at
/// that one level. What a front-end reports as the levels a view draws.
pub fn eye_levels(lod: &LodOctree, eye: Vec3, pixels: f32, pixel_angle: f32) -> (u8, u8) {
    let (near, far) = cube_levels(lod, eye, pixels, pixel_angle);
    (far, near)
}

/// [`intersect_lod`] for a packet of rays (lanes not traced: `None`; each traced lane exactly
/// what [`intersect_lod`]`(lod, ray, 0.0, t_max, choice)` returns). A fixed level, and a
/// pixel-error choice under which every traced lane's span needs one and the same level (a
/// far object: its whole depth range needs one level), walk that level's octree once for the
/// packet ([`intersect_packet`]); otherwise lane by lane. Where the whole root cube needs one
/// level from the packet's origin (a far camera), the lanes are not looked at.
pub fn intersect_lod_packet(
    lod: &LodOctree,
    rays: &RayPacket,
    choice: LevelChoice,
) -> [Option<LodHit>; PACKET_SIZE] {
    let packet_at = |level: u8| -> [Option<LodHit>; PACKET_SIZE] {
        match lod.level(level) {
            Some(octree) => {
                intersect_packet(octree, rays).map(|h| h.map(|hit| LodHit { hit, level }))
            }
            None => [None; PACKET_SIZE],
        }
    };
    let lanes = || (0..PACKET_SIZE).filter(|l| rays.lanes >> l & 1 != 0);
    match choice {
        LevelChoice::Level(k) => packet_at(k.clamp(lod.coarsest(), lod.depth())),
        LevelChoice::PixelError {
            pixels,
            pixel_angle,
        } => {
            let ray = |l: usize| Ray {
                origin: rays.origin,
                dir: rays.dirs[l],
            };
            // A far packet: every point of the root cube needs one level, so every lane does.
            let (near, far) = cube_levels(lod, rays.origin, pixels, pixel_angle);
            if near == far {
                return packet_at(near);
            }
            let mut common: Option<u8> = None;
            let mut uniform = true;
            for l in lanes() {
                match span_levels(lod, &ray(l), 0.0, rays.t_max, pixels, pixel_angle) {
                    // A lane that misses the root cube misses at every level.
                    None => {}
                    Some((near, far)) if near == far && common.is_none_or(|c| c == near) => {
                        common = Some(near)
                    }
                    Some(_) => uniform = false,
                }
            }
            match (uniform, common) {
                (true, Some(level)) => packet_at(level),
                (true, None) => [None; PACKET_SIZE],
                (false, _) => {
                    let mut out = [None; PACKET_SIZE];
                    for l in lanes() {
                        out[l] = intersect_lod(lod, &ray(l), 0.0, rays.t_max, choice);
                    }
                    out
                }
            }
        }
    }
}

/// A hit of [`intersect_lod`]: the hit in the level's octree, and the level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodHit {
    /// The hit, in the octree of `level` ([`LodOctree::level`]): its voxel indices refer to it.
    pub hit: Hit,
    /// The level it was found at.
    pub level: u8,
}

impl LodHit {
    /// The octree the hit belongs to (for [`hit_normal`](crate::hit_normal)).
    pub fn octree<'a>(&self, lod: &'a LodOctree) -> &'a PackedOctree {
        lod.level(self.level).unwrap_or(lod.finest())
    }
}

/// The first hit of `ray` in `[t_min, t_max]` at the level `choice` selects.
///
/// With [`LevelChoice::PixelError`], let `[t_in, t_out]` be the ray's span in the root cube
/// (within `[t_min, t_max]`): every hit lies there, so the levels a hit can need lie between
/// `k_far = level_for_distance(t_out)` and `k_near = level_for_distance(t_in)`. The ray is
/// traced at `k_far`; where it hits at a distance that needs a finer level it is traced again
/// at that level, and so on (the level only grows: at most one trace per level, in practice one
/// or two). Where it misses at a level below `k_near` it is traced once more at `k_near` (a thin
/// part a coarse level lost may be there; any hit at `k_near` is fine enough). So the hit
/// returned is at a level at least as fine as its own distance needs, and a ray misses only
/// where a level fine enough for every point of its span misses.
pub fn intersect_lod(
    lod: &LodOctree,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    choice: LevelChoice,
) -> Option<LodHit> {
    let (coarsest, finest) = (lod.coarsest(), lod.depth());
    match choice {
        LevelChoice::Level(k) => {
            let level = k.clamp(coarsest, finest);
            let octree = lod.level(level)?;
            intersect(octree, ray, t_min, t_max).map(|hit| LodHit { hit, level })
        }
        LevelChoice::PixelError {
            pixels,
            pixel_angle,
        } => {
            let (near, far) = span_levels(lod, ray, t_min, t_max, pixels, pixel_angle)?;
            let scale = ray.dir.length();
            let level_at =
                |t: f32| level_for_distance(t * scale, pixels, pixel_angle, coarsest, finest);
            let mut level = far;
            loop {
                let Some(hit) = intersect(lod.level(level)?, ray, t_min, t_max) else {
                    if level >= near {
                        return None;
                    }
                    level = near;
                    continue;
                };
                let need = level_at(hit.t);
                if need <= level {
                    return Some(LodHit { hit, level });
                }
                level = need;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sdfmo_format::testing::sphere_leaves;
    use sdfmo_format::{OctreeMeta, ValueBits};

    fn sphere(depth: u8) -> PackedOctree {
        let leaves = sphere_leaves(depth, 0.6);
        PackedOctree::from_leaves(OctreeMeta::unit(depth, ValueBits::Eight), leaves).unwrap()
    }

    #[test]
    fn level_for_distance_is_the_coarsest_below_the_budget() {
        let pa = pixel_angle(60.0, 1024);
        // At t = 3, one pixel is 3·pa ≈ 0.00338: level 10's edge 0.00195 fits, level 9's
        // 0.0039 does not.
        assert_eq!(level_for_distance(3.0, 1.0, pa, 2, 12), 10);
        // Four times farther: two levels coarser.
        assert_eq!(level_for_distance(12.0, 1.0, pa, 2, 12), 8);
        assert_eq!(level_for_distance(3.0, 1.0, pa, 2, 9), 9);
        assert_eq!(level_for_distance(f32::INFINITY, 1.0, pa, 2, 9), 2);
        assert_eq!(level_for_distance(1e6, 1.0, pa, 4, 9), 4);
        for bad in [0.0, -1.0, f32::NAN, 1e-40] {
            assert_eq!(level_for_distance(bad, 1.0, 1.0, 2, 9), 9, "{bad}");
        }
    }

    /// A fixed level is that level's octree; the pixel-error choice ends at the level its hit
    /// distance needs and agrees with a trace of that level.
    #[test]
    fn choices_trace_the_right_level() {
        let lod = LodOctree::from_levels((2..=6).map(sphere).collect()).unwrap();
        for &dist in &[1.2f32, 3.0, 20.0, 200.0] {
            // Aimed at a point inside the sphere, off its centre.
            let origin = Vec3::new(0.0, 0.0, dist);
            let ray = Ray {
                origin,
                dir: (Vec3::new(0.1, 0.05, 0.3) - origin).normalize(),
            };
            for k in 2..=6 {
                let h = intersect_lod(&lod, &ray, 0.0, f32::INFINITY, LevelChoice::Level(k));
                let direct = intersect(lod.level(k).unwrap(), &ray, 0.0, f32::INFINITY);
                assert_eq!(h.map(|h| h.hit), direct);
                assert_eq!(h.map(|h| h.level), direct.map(|_| k));
            }
            let (pixels, pa) = (1.0, pixel_angle(60.0, 256));
            let choice = LevelChoice::PixelError {
                pixels,
                pixel_angle: pa,
            };
            let h = intersect_lod(&lod, &ray, 0.0, f32::INFINITY, choice).expect("hits the sphere");
            assert!(level_for_distance(h.hit.t, pixels, pa, 2, 6) <= h.level);
            let (coarse, fine) = eye_levels(&lod, origin, pixels, pa);
            assert!(
                (coarse..=fine).contains(&h.level),
                "{dist}: {coarse}..={fine}"
            );
            let direct = intersect(lod.level(h.level).unwrap(), &ray, 0.0, f32::INFINITY);
            assert_eq!(Some(h.hit), direct);
            // Far away the coarsest level does; near, the finest is needed.
            if dist >= 200.0 {
                assert_eq!(h.level, 2);
            }
            if dist <= 1.2 {
                assert_eq!(h.level, 6);
            }
        }
    }

    /// Where the whole cube needs one level from an origin, every ray from there that enters
    /// the cube needs exactly it (the packet shortcut's premise), at distances placed on and
    /// around the levels' boundaries.
    #[test]
    fn a_cube_needing_one_level_means_every_ray_does() {
        let lod = LodOctree::from_levels((2..=6).map(sphere).collect()).unwrap();
        let (pixels, pa) = (1.0, pixel_angle(60.0, 128));
        let mut x = 0x2545_f491u32;
        let mut rnd = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as f32 / u32::MAX as f32 * 2.0 - 1.0
        };
        let mut shortcuts = 0;
        for i in 0..400i32 {
            // Distances where the level changes: edge 2^(1-k) = pixels · d · pa.
            let k: i32 = 2 + i % 5;
            let d = 2f32.powi(1 - k) / (pixels * pa) * (1.0 + 0.02 * rnd());
            let origin = Vec3::new(rnd(), rnd(), rnd()).normalize() * d;
            let (near, far) = cube_levels(&lod, origin, pixels, pa);
            if near != far {
                continue;
            }
            shortcuts += 1;
            for _ in 0..64 {
                let target = Vec3::new(rnd(), rnd(), rnd()) * 1.2;
                let ray = Ray {
                    origin,
                    dir: (target - origin) * (0.3 + rnd().abs()),
                };
                if let Some(levels) = span_levels(&lod, &ray, 0.0, f32::INFINITY, pixels, pa) {
                    assert_eq!(levels, (near, near), "origin {origin}, target {target}");
                }
            }
        }
        assert!(shortcuts > 50, "{shortcuts} origins with one level");
    }

    /// The packet form gives every lane what the ray-by-ray form gives, near (mixed levels,
    /// lane by lane) and far (one level for the packet), with directions of any length.
    #[test]
    fn packets_match_rays() {
        let lod = LodOctree::from_levels((2..=6).map(sphere).collect()).unwrap();
        let choice = LevelChoice::PixelError {
            pixels: 1.0,
            pixel_angle: pixel_angle(60.0, 128),
        };
        for &dist in &[1.5f32, 3.0, 40.0] {
            let origin = Vec3::new(0.2, 0.1, dist);
            let dirs: [Vec3; PACKET_SIZE] = core::array::from_fn(|l| {
                let target = Vec3::new(-0.7 + 0.1 * l as f32, 0.05 * (l % 3) as f32, 0.0);
                (target - origin) * (0.5 + l as f32 * 0.1)
            });
            let rays = RayPacket {
                origin,
                dirs,
                lanes: (u32::MAX >> (32 - PACKET_SIZE as u32)) & !2,
                t_max: f32::INFINITY,
            };
            let got = intersect_lod_packet(&lod, &rays, choice);
            let mut hits = 0;
            for (l, dir) in dirs.iter().enumerate() {
                let want = if l == 1 {
                    None
                } else {
                    intersect_lod(&lod, &Ray { origin, dir: *dir }, 0.0, f32::INFINITY, choice)
                };
                assert_eq!(got[l], want, "distance {dist}, lane {l}");
                hits += usize::from(want.is_some());
            }
            assert!(hits > 2, "distance {dist}: {hits} hits");
        }
    }
}
