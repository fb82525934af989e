//! Fuzzes the BVH builders (PLOC and the binned SAH that fans get) on generated fans, n-gons
//! and degenerate clusters: every mesh builds within the traversal stacks' depth, and closest
//! points and ray hits equal a brute-force scan of every triangle (issue 19).
//!
//! The bytes choose the shape: a wedge count, a hub, per-wedge radii and heights (zero radius
//! = a degenerate wedge), extra "book" pages through one spine, duplicated triangles, and the
//! query points.
#![no_main]

use glam::Vec3;
use libfuzzer_sys::fuzz_target;
use sdfmo_distance::{
    closest_point_on_triangle, MeshDistance, SignMode, WatertightRay, MAX_BVH_DEPTH,
};
use sdfmo_mesh::TriMesh;

/// Reads bytes cyclically (an empty input reads zeros).
struct Bytes<'a>(&'a [u8], usize);

impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        let b = self.0.get(self.1 % self.0.len().max(1)).copied().unwrap_or(0);
        self.1 += 1;
        b
    }
    fn unit(&mut self) -> f32 {
        f32::from(self.u8()) / 255.0
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes(data, 0);
    let wedges = 3 + (usize::from(b.u8()) << 4 | usize::from(b.u8() >> 4)) % 3000;
    let scale = [1e-3f32, 1.0, 1e3][usize::from(b.u8() % 3)];
    let hub = Vec3::new(b.unit(), b.unit(), b.unit()) * scale;
    let mut positions = vec![hub];
    for k in 0..wedges {
        let a = std::f32::consts::TAU * k as f32 / wedges as f32;
        let r = if b.u8() < 20 { 0.0 } else { 0.2 + b.unit() };
        let z = if b.u8() < 60 { b.unit() - 0.5 } else { 0.0 };
        positions.push(hub + Vec3::new(r * a.cos(), r * a.sin(), z) * scale);
    }
    let n = wedges as u32;
    let mut tris: Vec<[u32; 3]> = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
    let pages = usize::from(b.u8()) * 4;
    let spine = positions.len() as u32;
    positions.push(hub + Vec3::Z * scale);
    positions.push(hub - Vec3::Z * scale);
    for k in 0..pages {
        let a = std::f32::consts::PI * k as f32 / pages.max(1) as f32;
        positions.push(hub + Vec3::new(a.cos(), a.sin(), 0.0) * 0.7 * scale);
        tris.push([spine, spine + 1, spine + 2 + k as u32]);
    }
    for _ in 0..usize::from(b.u8() % 8) {
        let t = tris[usize::from(b.u8()) % tris.len()];
        tris.push(t);
    }
    let parts = vec![0; tris.len()];
    let Ok(mesh) = TriMesh::new(positions, tris, parts) else {
        return;
    };
    let dist = MeshDistance::new(&mesh, SignMode::Auto).expect("every mesh builds");
    assert!(dist.bvh_depth() <= MAX_BVH_DEPTH);
    let corners: Vec<[Vec3; 3]> = (0..mesh.triangle_count()).map(|i| mesh.triangle(i)).collect();
    for _ in 0..8 {
        let p = hub + (Vec3::new(b.unit(), b.unit(), b.unit()) * 3.0 - 1.5) * scale;
        let brute = corners
            .iter()
            .map(|t| (closest_point_on_triangle(p, t[0], t[1], t[2]).0 - p).length())
            .fold(f32::INFINITY, f32::min);
        let got = dist.closest_point(p).distance;
        let tol = 1e-5 * (brute + scale);
        assert!((got - brute).abs() <= tol, "{p}: {got} vs {brute}");
        // A ray from p towards the hub: the BVH's first hit is the brute-force first hit.
        let dir = hub - p;
        let Some(ray) = WatertightRay::new(p, dir) else {
            continue;
        };
        let brute = corners
            .iter()
            .filter_map(|t| ray.intersect(t[0], t[1], t[2], 0.0, f32::INFINITY))
            .min_by(f32::total_cmp);
        let hit = dist.ray_hit(p, dir, 0.0, f32::INFINITY).map(|h| h.t);
        assert_eq!(hit, brute, "ray from {p}");
    }
});
