//! Meshes that make bottom-up BVH builders degenerate (issue 19): fans, n-gons triangulated
//! from one vertex, clusters of coincident and degenerate triangles. Every closed mesh builds,
//! the tree stays within the traversal stacks, and distances and ray hits equal brute force.

mod common;

use common::*;
use glam::Vec3;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sdfmo_distance::{reshape_fans, BvhBuilder, MeshDistance, SignMode, MAX_BVH_DEPTH};
use sdfmo_mesh::procedural::{fan_cylinder, fan_disc};
use sdfmo_mesh::TriMesh;

/// Distances of `samples` random points in the mesh's padded box against the f64 oracle, and
/// the sign against the closed mesh's inside test when `closed_convex`.
fn check_against_brute_force(mesh: &TriMesh, samples: usize, seed: u64, closed_convex: bool) {
    let md = MeshDistance::new(mesh, SignMode::Auto).expect("every mesh builds");
    assert!(md.bvh_depth() <= MAX_BVH_DEPTH);
    let b = mesh.bounds();
    let pad = b.size().max_element() * 0.3;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for _ in 0..samples {
        let p = Vec3::new(
            rng.random_range(b.min.x - pad..b.max.x + pad),
            rng.random_range(b.min.y - pad..b.max.y + pad),
            rng.random_range(b.min.z - pad..b.max.z + pad),
        );
        let want = oracle_distance(mesh, 0..mesh.triangle_count(), p);
        let got = md.closest_point(p).distance;
        // f32 coordinates: the rounding of a point far from the origin bounds the agreement.
        let tol = 1e-5 * (1.0 + want) + 4.0 * f64::from(f32::EPSILON * p.abs().max_element());
        assert!((f64::from(got) - want).abs() <= tol, "{p}: {got} vs {want}");
        if closed_convex && want > 1e-3 {
            let inside = inside_convex(mesh, p);
            assert_eq!(md.signed_distance(p) < 0.0, inside, "{p}");
        }
    }
}

#[test]
fn fan_cylinders_and_fans_build_shallow_and_answer_exactly() {
    for segments in [600, 5_000] {
        let mesh = fan_cylinder(segments, 1.0, 0.5);
        let md = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
        assert_eq!(md.bvh_builder(), BvhBuilder::BinnedSah, "{segments}");
        assert!(md.bvh_depth() <= 40, "{segments}: {}", md.bvh_depth());
        check_against_brute_force(&mesh, 200, segments as u64, true);
    }
    let disc = fan_disc(50_000);
    let md = MeshDistance::new(&disc, SignMode::Auto).unwrap();
    assert_eq!(md.bvh_builder(), BvhBuilder::BinnedSah);
    check_against_brute_force(&disc, 50, 1, false);
}

#[test]
fn reshaped_fans_answer_the_original_meshs_distances() {
    // The re-triangulated surface is the same surface: its distances equal brute force over
    // the original triangles, its tree is PLOC's again, and the closed cylinder stays closed.
    for (mesh, samples, closed) in [
        (fan_cylinder(5_000, 1.0, 0.5), 300, true),
        (fan_disc(50_000), 100, false),
    ] {
        let reshaped = reshape_fans(&mesh).expect("a fan-shaped mesh is reshaped");
        assert!(reshaped.regions >= 1);
        let md = MeshDistance::new(&reshaped.mesh, SignMode::Auto).unwrap();
        assert_eq!(md.bvh_builder(), BvhBuilder::Ploc);
        assert_eq!(
            md.sign_mode(),
            MeshDistance::new(&mesh, SignMode::Auto)
                .unwrap()
                .sign_mode()
        );
        let b = mesh.bounds();
        let pad = b.size().max_element() * 0.3;
        let mut rng = ChaCha8Rng::seed_from_u64(samples as u64);
        for i in 0..samples {
            let mut p = Vec3::new(
                rng.random_range(b.min.x - pad..b.max.x + pad),
                rng.random_range(b.min.y - pad..b.max.y + pad),
                rng.random_range(b.min.z - pad..b.max.z + pad),
            );
            if i % 2 == 0 {
                // Half of them close to the surface, where the fans' wedges were the trouble.
                let [a, b, c] = mesh.triangle(rng.random_range(0..mesh.triangle_count()));
                p = (a + b + c) / 3.0 + (p - b) * 0.01;
            }
            let want = oracle_distance(&mesh, 0..mesh.triangle_count(), p);
            let got = md.closest_point(p).distance;
            assert!(
                (f64::from(got) - want).abs() <= 1e-5 * (1.0 + want),
                "{p}: {got} vs {want}"
            );
            if closed && want > 1e-3 {
                assert_eq!(md.signed_distance(p) < 0.0, inside_convex(&mesh, p), "{p}");
            }
        }
    }
    // An ordinary closed mesh is left alone.
    assert!(reshape_fans(&l_prism()).is_none());
}

#[test]
fn a_fan_ray_never_slips_between_wedges() {
    // Rays straight down through the hub's neighbourhood of a closed fan cylinder hit a cap.
    let mesh = fan_cylinder(5_000, 1.0, 0.5);
    let md = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..2000 {
        let r = rng.random_range(0.0f32..0.99);
        let a = rng.random_range(0.0f32..std::f32::consts::TAU);
        let o = Vec3::new(r * a.cos(), 2.0, r * a.sin());
        let hit = md
            .ray_hit(o, -Vec3::Y, 0.0, f32::INFINITY)
            .expect("the cap");
        assert!((hit.t - 1.75).abs() < 1e-4, "{o}: {}", hit.t);
    }
}

/// A mesh of `n` wedges around `hub`, some with coincident or degenerate corners.
fn hostile_fan(n: usize, hub: Vec3, seed: u64) -> TriMesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut positions = vec![hub];
    for k in 0..n {
        let a = std::f32::consts::TAU * k as f32 / n as f32;
        let r = if rng.random_bool(0.1) {
            0.0
        } else {
            rng.random_range(0.5f32..1.5)
        };
        let z = if rng.random_bool(0.2) {
            rng.random_range(-0.5f32..0.5)
        } else {
            0.0
        };
        positions.push(hub + Vec3::new(r * a.cos(), r * a.sin(), z));
    }
    let mut tris: Vec<[u32; 3]> = (0..n as u32)
        .map(|k| [0, 1 + k, 1 + (k + 1) % n as u32])
        .collect();
    // A cluster of triangles sharing one edge (a book), every page through the same spine.
    let spine = positions.len() as u32;
    positions.push(hub + Vec3::Z);
    positions.push(hub - Vec3::Z);
    for k in 0..(n / 4) {
        let a = std::f32::consts::PI * k as f32 / (n / 4) as f32;
        positions.push(hub + Vec3::new(a.cos(), a.sin(), 0.0) * 0.7);
        tris.push([spine, spine + 1, spine + 2 + k as u32]);
    }
    let parts = vec![0; tris.len()];
    TriMesh::new(positions, tris, parts).expect("valid indices")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn generated_fans_build_and_match_brute_force(
        n in 3usize..3000,
        seed in any::<u64>(),
        x in -1e3f32..1e3,
    ) {
        let mesh = hostile_fan(n, Vec3::new(x, 0.0, 0.0), seed);
        check_against_brute_force(&mesh, 40, seed, false);
    }
}
