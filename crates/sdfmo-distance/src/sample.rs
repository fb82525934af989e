//! Deterministic query points for benchmarks, examples and comparisons with other tools.
//!
//! A SplitMix64 generator (Steele, Lea & Flood 2014) keeps the points identical on every platform
//! and independent of the `rand` crate's versions, so a benchmark and a peer script fed from a
//! file see exactly the same points.

use glam::Vec3;
use sdfmo_mesh::TriMesh;

/// The generator of the points (the project's one, from `sdfmo-io`).
pub use sdfmo_io::SplitMix64;

/// `n` points uniformly distributed in the root cube [-1, 1]³.
pub fn uniform_points(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        })
        .collect()
}

/// `n` points near the surface of `mesh`: a triangle chosen with probability proportional to its
/// area, a uniform point on it, then an offset in a uniformly random direction with a length
/// uniform in [0, `max_offset`). Empty if the mesh has no area.
pub fn near_surface_points(mesh: &TriMesh, n: usize, max_offset: f32, seed: u64) -> Vec<Vec3> {
    let mut cumulative = Vec::with_capacity(mesh.triangles().len());
    let mut total = 0.0f64;
    for i in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(i);
        total += 0.5 * (b - a).cross(c - a).length() as f64;
        cumulative.push(total);
    }
    if total <= 0.0 || !total.is_finite() {
        return Vec::new();
    }
    let mut rng = SplitMix64::new(seed);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let x = (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64) * total;
        let t = cumulative
            .partition_point(|&c| c <= x)
            .min(cumulative.len() - 1);
        let [a, b, c] = mesh.triangle(t);
        let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let dir = loop {
            let d = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let l2 = d.length_squared();
            if l2 > 1e-6 && l2 <= 1.0 {
                break d / l2.sqrt();
            }
        };
        out.push(a + (b - a) * u + (c - a) * v + dir * rng.range(0.0, max_offset));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use sdfmo_mesh::procedural::box_mesh;

    #[test]
    fn points_are_deterministic_and_in_range() {
        let a = uniform_points(1000, 5);
        assert_eq!(a, uniform_points(1000, 5));
        assert_ne!(a, uniform_points(1000, 6));
        assert!(a.iter().all(|p| p.abs().max_element() <= 1.0));
        let mean = a.iter().copied().sum::<Vec3>() / a.len() as f32;
        assert!(mean.abs().max_element() < 0.1, "{mean:?}");
    }

    #[test]
    fn near_surface_points_are_near_the_surface() {
        let mesh = box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5));
        let pts = near_surface_points(&mesh, 500, 0.01, 1);
        assert_eq!(pts.len(), 500);
        for p in &pts {
            // Exact distance to the surface of the box.
            let q = p.abs() - Vec3::splat(0.5);
            let d = if q.max_element() > 0.0 {
                q.max(Vec3::ZERO).length()
            } else {
                -q.max_element()
            };
            assert!(d <= 0.01 + 1e-6, "{p:?} is {d} from the surface");
        }
    }
}
