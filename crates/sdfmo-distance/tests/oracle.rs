//! MeshDistance against f64 brute-force oracles on procedural meshes.

mod common;

use common::*;
use glam::Vec3;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sdfmo_distance::{Feature, MeshDistance, SignMode, WatertightRay};
use sdfmo_mesh::procedural::{box_mesh, gap_pair, open_sheet, sphere, thin_plate};
use sdfmo_mesh::TriMesh;

fn random_points(rng: &mut ChaCha8Rng, n: usize, lo: f32, hi: f32) -> Vec<Vec3> {
    (0..n)
        .map(|_| {
            Vec3::new(
                rng.random_range(lo..hi),
                rng.random_range(lo..hi),
                rng.random_range(lo..hi),
            )
        })
        .collect()
}

fn tol(d: f64) -> f64 {
    2e-6 + 2e-6 * d
}

fn check_closest_against_oracle(mesh: &TriMesh, points: &[Vec3]) {
    let md = MeshDistance::new(mesh, SignMode::Auto).unwrap();
    for &p in points {
        let c = md.closest_point(p);
        let od = oracle_distance(mesh, 0..mesh.triangle_count(), p);
        assert!(
            (c.distance as f64 - od).abs() <= tol(od),
            "p {p:?}: distance {} vs oracle {od}",
            c.distance
        );
        // The reported point lies on the reported triangle at the reported distance.
        let on_tri = oracle_distance(mesh, [c.triangle as usize], c.point);
        assert!(
            on_tri <= 1e-5,
            "point {:?} is {on_tri} off triangle {}",
            c.point,
            c.triangle
        );
        assert!(((p - c.point).length() - c.distance).abs() <= 1e-6 * (1.0 + c.distance));
        assert_eq!(md.unsigned_distance(p), c.distance);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Random triangle soups (some degenerate) against the brute-force oracle.
    #[test]
    fn random_soups_match_the_oracle(seed in any::<u64>(), n in 1usize..300) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..n {
            let a = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let s: f32 = rng.random_range(0.001..0.4);
            let mut b = a + Vec3::new(rng.random_range(-s..s), rng.random_range(-s..s), rng.random_range(-s..s));
            let mut c = a + Vec3::new(rng.random_range(-s..s), rng.random_range(-s..s), rng.random_range(-s..s));
            match i % 7 {
                0 => c = a + (b - a) * 0.37, // exactly collinear (zero area)
                1 => b = a,                  // coincident vertices
                2 => c = a + (b - a) * 0.5 + Vec3::splat(1e-6), // sliver
                _ => {}
            }
            let base = positions.len() as u32;
            positions.extend([a, b, c]);
            triangles.push([base, base + 1, base + 2]);
        }
        let parts = vec![0; triangles.len()];
        let mesh = TriMesh::new(positions, triangles, parts).unwrap();
        let pts = random_points(&mut rng, 40, -1.5, 1.5);
        check_closest_against_oracle(&mesh, &pts);
    }
}

#[test]
fn closest_points_on_procedural_meshes_match_the_oracle() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let meshes = [
        box_mesh(Vec3::splat(-0.5), Vec3::new(0.3, 0.6, 0.5)),
        sphere(Vec3::new(0.1, 0.0, -0.2), 0.7, 3),
        thin_plate(Vec3::new(1.0, 0.01, 0.8)),
        open_sheet(1.5, 1.0, 8),
        gap_pair(1.0, 0.02),
        l_prism(),
    ];
    for mesh in &meshes {
        let mut pts = random_points(&mut rng, 300, -1.5, 1.5);
        pts.extend(points_near_features(mesh, 1.0, 3).into_iter().step_by(7));
        check_closest_against_oracle(mesh, &pts);
    }
}

/// Sign errors on closed meshes near edges and vertices, checked against analytic inside tests.
fn count_sign_errors(mesh: &TriMesh, inside: impl Fn(Vec3) -> bool, scale: f32) -> (usize, usize) {
    let md = MeshDistance::new(mesh, SignMode::Auto).unwrap();
    assert_eq!(
        md.sign_mode(),
        SignMode::PseudoNormal,
        "a closed mesh resolves to pseudo-normals"
    );
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut pts = points_near_features(mesh, scale, 5);
    pts.extend(random_points(&mut rng, 2000, -2.0, 2.0));
    let mut errors = 0;
    let all: Vec<u32> = (0..mesh.triangle_count() as u32).collect();
    let batch = md.signed_distances(&pts);
    for (i, &p) in pts.iter().enumerate() {
        let d = md.signed_distance(p);
        assert_eq!(
            d.to_bits(),
            batch[i].to_bits(),
            "batch and single queries agree"
        );
        // The subset query over all triangles gives the same sign (pseudo-normals of the mesh).
        let ds = md.signed_distance_in_subset(&all, p);
        assert!(
            (d - ds).abs() <= 1e-6 + 1e-6 * d.abs(),
            "subset over all: {ds} vs {d}"
        );
        if d.abs() < 1e-6 {
            continue; // on the surface: either sign is right
        }
        if (d < 0.0) != inside(p) {
            errors += 1;
        }
    }
    (errors, pts.len())
}

#[test]
fn no_sign_errors_on_a_box_near_edges_and_vertices() {
    let (lo, hi) = (Vec3::new(-0.5, -0.3, -0.4), Vec3::new(0.6, 0.3, 0.45));
    let mesh = box_mesh(lo, hi);
    let (e, n) = count_sign_errors(&mesh, |p| p.cmpgt(lo).all() && p.cmplt(hi).all(), 1.0);
    assert_eq!(e, 0, "{e} sign errors in {n} points");
}

#[test]
fn no_sign_errors_on_a_sphere_near_edges_and_vertices() {
    let mesh = sphere(Vec3::new(0.05, -0.1, 0.0), 0.8, 3);
    let (e, n) = count_sign_errors(&mesh, |p| inside_convex(&mesh, p), 0.2);
    assert_eq!(e, 0, "{e} sign errors in {n} points");
}

#[test]
fn no_sign_errors_on_a_concave_prism_near_edges_and_vertices() {
    let mesh = l_prism();
    let (e, n) = count_sign_errors(&mesh, inside_l_prism, 1.0);
    assert_eq!(e, 0, "{e} sign errors in {n} points");
}

#[test]
fn closed_sign_modes_agree() {
    // On a closed mesh the winding number and the pseudo-normals must give the same sign.
    let mesh = l_prism();
    let pn = MeshDistance::new(&mesh, SignMode::PseudoNormal).unwrap();
    let wn = MeshDistance::new(&mesh, SignMode::Winding).unwrap();
    assert_eq!(wn.sign_mode(), SignMode::Winding);
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for p in random_points(&mut rng, 3000, -0.5, 2.5) {
        let (a, b) = (pn.signed_distance(p), wn.signed_distance(p));
        assert_eq!(a.abs(), b.abs());
        if a.abs() > 1e-4 {
            assert_eq!(a < 0.0, b < 0.0, "p {p:?}: pseudo-normal {a}, winding {b}");
            assert_eq!(a < 0.0, inside_l_prism(p));
        }
    }
}

#[test]
fn hierarchical_winding_numbers_match_the_exact_sum() {
    let meshes = [
        open_sheet(1.5, 1.0, 12),
        sphere(Vec3::ZERO, 0.7, 3),
        l_prism(),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for mesh in &meshes {
        let md = MeshDistance::new(mesh, SignMode::Winding).unwrap();
        let mut max_err = 0.0f64;
        for p in random_points(&mut rng, 1500, -1.5, 2.5) {
            let fast = md.winding_number(p) as f64;
            let exact = md.winding_number_exact(p);
            max_err = max_err.max((fast - exact).abs());
            if (exact - 0.5).abs() > 0.05 {
                assert_eq!(
                    fast > 0.5,
                    exact > 0.5,
                    "p {p:?}: fast {fast}, exact {exact}"
                );
            }
        }
        // Second order, β = 2: 0.009 on the sheet, 0.054 inside the sphere (measured; every
        // node's error has the same sign there).
        assert!(max_err < 0.06, "max winding error {max_err}");
    }
}

#[test]
fn open_sheet_resolves_to_winding_and_signs_by_side() {
    let mesh = open_sheet(1.0, 1.0, 6);
    let md = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
    assert_eq!(md.sign_mode(), SignMode::Winding);
    // Points right above and below the middle of the sheet are on opposite sides (winding
    // number ≈ ±½ there), and far away it is 0.
    let above = md.winding_number(Vec3::new(0.0, 0.01, 0.0));
    let below = md.winding_number(Vec3::new(0.0, -0.01, 0.0));
    assert!(
        (above.abs() - 0.5).abs() < 0.02 && (below.abs() - 0.5).abs() < 0.02,
        "{above} {below}"
    );
    assert!((above + below).abs() < 0.02, "{above} {below}");
    assert!(md.winding_number(Vec3::new(5.0, 3.0, 1.0)).abs() < 0.01);
}

/// Ray hits vs brute force over all triangles.
#[test]
fn ray_hits_match_brute_force() {
    let meshes = [
        sphere(Vec3::ZERO, 0.8, 3),
        l_prism(),
        open_sheet(1.5, 1.0, 8),
        gap_pair(1.0, 0.05),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for mesh in &meshes {
        let md = MeshDistance::new(mesh, SignMode::Auto).unwrap();
        for _ in 0..2000 {
            let o = random_points(&mut rng, 1, -2.5, 2.5)[0];
            let target = random_points(&mut rng, 1, -1.0, 1.5)[0];
            let dir = target - o;
            let hit = md.ray_hit(o, dir, 0.0, f32::INFINITY);
            let ray = WatertightRay::new(o, dir).unwrap();
            let brute = (0..mesh.triangle_count())
                .filter_map(|i| {
                    let [a, b, c] = mesh.triangle(i);
                    ray.intersect(a, b, c, 0.0, f32::INFINITY).map(|t| (t, i))
                })
                .min_by(|x, y| x.0.total_cmp(&y.0));
            match (hit, brute) {
                (None, None) => {}
                (Some(h), Some((t, _))) => {
                    assert_eq!(h.t, t, "closest t");
                    assert!((h.normal.length() - 1.0).abs() < 1e-5);
                    assert!(md.ray_occluded(o, dir, 0.0, f32::INFINITY));
                    assert!(!md.ray_occluded(o, dir, 0.0, t * 0.999));
                }
                (h, b) => panic!("ray {o:?} {dir:?}: bvh {h:?} vs brute {b:?}"),
            }
        }
    }
}

/// Rays through vertices and edges of closed meshes, from interior points outwards and from
/// outside through the feature towards interior points, must never slip through: each of them
/// crosses the surface.
#[test]
fn rays_through_edges_and_vertices_never_slip_through() {
    let sph = sphere(Vec3::ZERO, 0.8, 2);
    let bx = box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5));
    let inside_sphere = |p: Vec3| inside_convex(&sph, p);
    let inside_box = |p: Vec3| p.abs().max_element() < 0.5;
    let meshes: [(&TriMesh, &dyn Fn(Vec3) -> bool); 3] = [
        (&sph, &inside_sphere),
        (&l_prism(), &inside_l_prism),
        (&bx, &inside_box),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for (mesh, inside) in meshes {
        let md = MeshDistance::new(mesh, SignMode::Auto).unwrap();
        let interior: Vec<Vec3> =
            std::iter::repeat_with(|| random_points(&mut rng, 1, -1.0, 2.0)[0])
                .filter(|&p| inside(p))
                .take(4)
                .collect();
        let mut targets: Vec<Vec3> = mesh.positions().to_vec();
        for t in mesh.triangles() {
            for k in 0..3 {
                let a = mesh.positions()[t[k] as usize];
                let b = mesh.positions()[t[(k + 1) % 3] as usize];
                targets.push((a + b) * 0.5);
                targets.push(a + (b - a) * rng.random_range(0.0f32..1.0));
            }
        }
        let mut slips = 0;
        let mut rays = 0;
        for &target in &targets {
            for &q in &interior {
                rays += 2;
                if md.ray_hit(q, target - q, 0.0, f32::INFINITY).is_none() {
                    slips += 1;
                }
                let o = target + (target - q).normalize() * 3.0;
                if md.ray_hit(o, q - o, 0.0, f32::INFINITY).is_none() {
                    slips += 1;
                }
            }
        }
        assert_eq!(slips, 0, "{slips} of {rays} rays slipped through");
    }
}

#[test]
fn subset_queries_measure_only_the_subset() {
    // Two boxes; the subset of the first box's triangles must ignore the second box.
    let mesh = gap_pair(1.0, 0.1);
    let md = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
    let part0: Vec<u32> = (0..mesh.triangle_count() as u32)
        .filter(|&i| mesh.parts()[i as usize] == 0)
        .collect();
    assert!(!part0.is_empty() && part0.len() < mesh.triangle_count());
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for p in random_points(&mut rng, 500, -1.5, 1.5) {
        let c = md.closest_point_in_subset(&part0, p);
        let od = oracle_distance(&mesh, part0.iter().map(|&i| i as usize), p);
        assert!(
            (c.distance as f64 - od).abs() <= tol(od),
            "{} vs {od}",
            c.distance
        );
        assert!(part0.contains(&c.triangle));
        let sd = md.signed_distance_in_subset(&part0, p);
        assert_eq!(sd.abs(), c.distance);
        let inside0 = inside_convex(
            &TriMesh::new(
                mesh.positions().to_vec(),
                part0
                    .iter()
                    .map(|&i| mesh.triangles()[i as usize])
                    .collect(),
                vec![0; part0.len()],
            )
            .unwrap(),
            p,
        );
        if sd.abs() > 1e-5 {
            assert_eq!(sd < 0.0, inside0, "p {p:?} sd {sd}");
        }
        let mut out = [0.0f32; 2];
        md.signed_distances_in_subset(&part0, &[p, p], &mut out);
        assert_eq!(out, [sd, sd]);
    }
    // Empty and out-of-range subsets are not errors.
    assert!(!md.closest_point_in_subset(&[], Vec3::ZERO).is_found());
    assert_eq!(
        md.signed_distance_in_subset(&[u32::MAX], Vec3::ZERO),
        f32::INFINITY
    );
}

#[test]
fn bounded_and_hinted_queries_agree_with_the_full_query() {
    let mesh = sphere(Vec3::ZERO, 0.8, 3);
    let md = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for p in random_points(&mut rng, 1000, -1.2, 1.2) {
        let full = md.closest_point(p);
        let within = md.closest_point_within(p, 0.2);
        if full.distance < 0.2 * 0.9999 {
            assert_eq!(within.distance, full.distance);
        } else if full.distance > 0.2 {
            assert!(!within.is_found());
        }
        let hint = rng.random_range(0..mesh.triangle_count() as u32);
        let hinted = md.closest_point_with_hint(p, hint);
        assert_eq!(hinted.distance, full.distance);
        assert_eq!(md.sign_closest(p, &hinted).abs(), full.distance);
        if let Feature::Vertex(k) = hinted.feature {
            assert!(k < 3);
        }
    }
}

#[test]
fn bad_meshes_are_errors_not_panics() {
    // A `TriMesh` cannot hold these (its fields are private and `TriMesh::new` checks them), so
    // `MeshDistance::new` never sees one: the error comes where the mesh is made.
    let (positions, triangles, parts) = box_mesh(Vec3::ZERO, Vec3::ONE).into_arrays();
    let mut bad = triangles.clone();
    bad[3][1] = 1000;
    assert!(matches!(
        TriMesh::new(positions.clone(), bad, parts.clone()),
        Err(sdfmo_mesh::MeshError::IndexOutOfRange { index: 1000, .. })
    ));
    let mut nan = positions.clone();
    nan[2].y = f32::NAN;
    assert!(matches!(
        TriMesh::new(nan, triangles.clone(), parts),
        Err(sdfmo_mesh::MeshError::NonFinite { ref element, .. }) if element == "vertex 2"
    ));
    assert!(matches!(
        TriMesh::new(positions, Vec::new(), Vec::new()),
        Err(sdfmo_mesh::MeshError::NoTriangles { .. })
    ));
    // Non-finite queries do not panic.
    let md = MeshDistance::new(&box_mesh(Vec3::ZERO, Vec3::ONE), SignMode::Auto).unwrap();
    let _ = md.signed_distance(Vec3::splat(f32::NAN));
    let _ = md.winding_number(Vec3::splat(f32::INFINITY));
    assert!(md.ray_hit(Vec3::ZERO, Vec3::ZERO, 0.0, 1.0).is_none());
    assert!(md.ray_hit(Vec3::splat(0.5), Vec3::X, 1.0, 0.0).is_none());
}
