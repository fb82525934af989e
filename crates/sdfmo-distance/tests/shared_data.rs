//! Tests on the shared meshes (`SDFMO_TEST_DATA`, default `../shared/data` beside the workspace):
//! reported as ignored when the directory is missing, unless `SDFMO_REQUIRE_TEST_DATA=1`.

mod common;

use std::path::PathBuf;

use common::*;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sdfmo_distance::{reshape_fans, MeshDistance, SignMode};
use sdfmo_mesh::{load_mesh, TriMesh};

/// A mesh of the shared test data (resolved by `build.rs` through `sdfmo-testdata`), normalised;
/// the tests that call this are ignored when the directory is absent and
/// `SDFMO_REQUIRE_TEST_DATA` is not `1`.
/// The normalised mesh `name` and its distance structure, whose automatic sign must be `sign`.
fn distance_with_sign(name: &str, sign: SignMode) -> (TriMesh, MeshDistance) {
    let mesh = load_normalized(name);
    let md = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
    assert_eq!(md.sign_mode(), sign, "{name}");
    (mesh, md)
}

fn load_normalized(name: &str) -> TriMesh {
    let path = PathBuf::from(env!("SDFMO_TEST_DATA_DIR")).join(name);
    let loaded = load_mesh(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    loaded.mesh.normalized(0.05).0
}

/// Points uniformly in the root cube and close to random triangles.
fn sample_points(mesh: &TriMesh, n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut pts = Vec::with_capacity(n);
    for i in 0..n {
        if i % 2 == 0 {
            pts.push(Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ));
        } else {
            let [a, b, c] = mesh.triangle(rng.random_range(0..mesh.triangle_count()));
            let (mut u, mut v): (f32, f32) =
                (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let off = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            pts.push(a + (b - a) * u + (c - a) * v + off * 0.02);
        }
    }
    pts
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn teapot_distances_match_the_oracle_and_winding_signs_match_the_exact_winding_number() {
    let (mesh, md) = distance_with_sign("teapot.obj", SignMode::Winding); // open
    let pts = sample_points(&mesh, 600, 1);
    let mut max_err = 0.0f64;
    let mut compared = 0;
    let sd = md.signed_distances(&pts);
    for (&p, &d) in pts.iter().zip(&sd) {
        let od = oracle_distance(&mesh, 0..mesh.triangle_count(), p);
        assert!(
            (d.abs() as f64 - od).abs() <= 2e-6 + 2e-6 * od,
            "p {p:?}: {d} vs oracle {od}"
        );
        let fast = md.winding_number(p) as f64;
        let exact = md.winding_number_exact(p);
        max_err = max_err.max((fast - exact).abs());
        if (exact - 0.5).abs() > 0.05 {
            compared += 1;
            assert_eq!(
                d < 0.0,
                exact > 0.5,
                "p {p:?}: signed distance {d}, exact winding {exact}"
            );
        }
    }
    eprintln!("teapot: max |fast − exact| winding number {max_err:.5} over {} points, {compared} signs compared", pts.len());
    assert!(max_err < 0.05, "winding error {max_err}");
    assert!(compared > pts.len() / 2);
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn closed_cad_part_has_no_sign_errors_near_edges_and_vertices() {
    let (mesh, md) = distance_with_sign("abc8.stl", SignMode::PseudoNormal); // watertight
                                                                             // Every 8th point near a vertex or an edge, offsets 1e-5 .. 1e-2 (normalised units).
    let pts: Vec<Vec3> = points_near_features(&mesh, 0.1, 8)
        .into_iter()
        .step_by(8)
        .collect();
    let sd = md.signed_distances(&pts);
    let mut errors = 0;
    let mut compared = 0;
    let mut off_surface = 0;
    for (&p, &d) in pts.iter().zip(&sd) {
        if d.abs() < 1e-6 {
            continue; // on the surface within f32 rounding: either sign is right
        }
        off_surface += 1;
        let exact = md.winding_number_exact(p);
        if (exact - 0.5).abs() < 0.25 {
            continue; // the f32 solid-angle sum is not conclusive this close to the surface
        }
        compared += 1;
        if (d < 0.0) != (exact > 0.5) {
            errors += 1;
        }
    }
    eprintln!("abc8: {errors} sign errors in {compared} points near features");
    assert_eq!(errors, 0);
    assert!(
        compared > off_surface * 9 / 10,
        "{compared} of {off_surface}"
    );
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn no_shared_mesh_is_reshaped_as_a_fan() {
    // `reshape_fans` must leave every ordinary mesh alone: their octrees, images and distances
    // stay byte-identical to what they were before it existed.
    for name in [
        "abc1.stl",
        "abc3.stl",
        "abc5.stl",
        "abc8.stl",
        "abc5_parts.obj",
        "stanford-bunny.obj",
        "teapot.obj",
    ] {
        assert!(reshape_fans(&load_normalized(name)).is_none(), "{name}");
    }
}
