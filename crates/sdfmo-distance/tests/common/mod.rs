//! Shared helpers of the integration tests: an f64 brute-force oracle and test meshes.
#![allow(dead_code)]

use glam::{DVec3, Vec3};
use sdfmo_mesh::TriMesh;

/// Closest point on a triangle in f64 by projection and barycentric signs, else the nearest of
/// the three clamped edge segments (a different method from Ericson's regions).
pub fn oracle_closest(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (DVec3, f64) {
    let n = (b - a).cross(c - a);
    let nn = n.length_squared();
    if nn > 0.0 {
        let q = p - n * ((p - a).dot(n) / nn);
        let wa = (b - q).cross(c - q).dot(n);
        let wb = (c - q).cross(a - q).dot(n);
        let wc = (a - q).cross(b - q).dot(n);
        if wa >= 0.0 && wb >= 0.0 && wc >= 0.0 {
            return (q, (p - q).length());
        }
    }
    let mut best = (a, f64::INFINITY);
    for (s, e) in [(a, b), (b, c), (c, a)] {
        let se = e - s;
        let l2 = se.length_squared();
        let t = if l2 > 0.0 {
            ((p - s).dot(se) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = s + se * t;
        let d = (p - q).length();
        if d < best.1 {
            best = (q, d);
        }
    }
    best
}

/// Unsigned distance to a set of triangles of `mesh`, brute force in f64.
pub fn oracle_distance(mesh: &TriMesh, subset: impl IntoIterator<Item = usize>, p: Vec3) -> f64 {
    let p = p.as_dvec3();
    subset
        .into_iter()
        .map(|i| {
            let t = mesh.triangle(i).map(|v| v.as_dvec3());
            oracle_closest(p, t[0], t[1], t[2]).1
        })
        .fold(f64::INFINITY, f64::min)
}

/// An L-shaped prism: the polygon (0,0) (2,0) (2,1) (1,1) (1,2) (0,2) extruded over z in [0, 1],
/// fanned from (0.5, 0.5). Closed, outward oriented, with a concave edge and saddle vertices.
pub fn l_prism() -> TriMesh {
    let poly = [
        (0.0, 0.0),
        (2.0, 0.0),
        (2.0, 1.0),
        (1.0, 1.0),
        (1.0, 2.0),
        (0.0, 2.0),
    ];
    let n = poly.len() as u32;
    let mut positions = Vec::new();
    for z in [0.0f32, 1.0] {
        for &(x, y) in &poly {
            positions.push(Vec3::new(x, y, z));
        }
    }
    positions.push(Vec3::new(0.5, 0.5, 0.0)); // 2n: bottom centre
    positions.push(Vec3::new(0.5, 0.5, 1.0)); // 2n + 1: top centre
    let mut triangles = Vec::new();
    for i in 0..n {
        let j = (i + 1) % n;
        // Bottom faces −z: clockwise seen from above.
        triangles.push([2 * n, j, i]);
        // Top faces +z.
        triangles.push([2 * n + 1, n + i, n + j]);
        // Side quad (i, j) outward: the polygon is counter-clockwise.
        triangles.push([i, j, n + j]);
        triangles.push([i, n + j, n + i]);
    }
    let parts = vec![0; triangles.len()];
    TriMesh::new(positions, triangles, parts).expect("valid L prism")
}

/// Whether `p` is strictly inside the L prism (analytic).
pub fn inside_l_prism(p: Vec3) -> bool {
    let in_l = (p.x > 0.0 && p.x < 2.0 && p.y > 0.0 && p.y < 1.0)
        || (p.x > 0.0 && p.x < 1.0 && p.y > 0.0 && p.y < 2.0);
    in_l && p.z > 0.0 && p.z < 1.0
}

/// Whether `p` is strictly inside a closed convex mesh (behind every face plane).
pub fn inside_convex(mesh: &TriMesh, p: Vec3) -> bool {
    (0..mesh.triangle_count()).all(|i| {
        let [a, b, c] = mesh.triangle(i).map(|v| v.as_dvec3());
        let n = (b - a).cross(c - a);
        (p.as_dvec3() - a).dot(n) < 0.0
    })
}

/// Points near every vertex and along every edge of `mesh`, offset in random directions by
/// distances from 1e-4 to 1e-1 of `scale`.
pub fn points_near_features(mesh: &TriMesh, scale: f32, seed: u64) -> Vec<Vec3> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    let offsets = [1e-4f32, 1e-3, 1e-2, 1e-1];
    let dir = |rng: &mut rand_chacha::ChaCha8Rng| loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    };
    for &v in mesh.positions() {
        for &o in &offsets {
            for _ in 0..4 {
                out.push(v + dir(&mut rng) * o * scale);
            }
        }
    }
    for t in mesh.triangles() {
        for k in 0..3 {
            let a = mesh.positions()[t[k] as usize];
            let b = mesh.positions()[t[(k + 1) % 3] as usize];
            for &o in &offsets {
                let s: f32 = rng.random_range(0.0..1.0);
                out.push(a + (b - a) * s + dir(&mut rng) * o * scale);
            }
            // Exactly at the edge midpoint, nudged along the bisector-free random direction.
            out.push((a + b) * 0.5 + dir(&mut rng) * 1e-5 * scale);
        }
    }
    out
}
