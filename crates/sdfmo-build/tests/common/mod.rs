//! Fixtures shared by the builder's integration tests.

use glam::Vec3;
use sdfmo_build::{build, BuildSettings};
use sdfmo_mesh::{procedural, TriMesh};

/// A rotated thin plate beside a sphere, and the same part with one vertex coordinate moved by
/// one ulp: the pair the one-ulp stability tests build and compare.
pub fn plate_and_sphere_moved_one_ulp() -> (TriMesh, TriMesh) {
    let rot = glam::Mat3::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, 0.2);
    let part = TriMesh::merge(&[
        procedural::thin_plate(Vec3::new(1.0, 0.01, 0.8)).transformed(|p| rot * p),
        procedural::sphere(Vec3::new(0.2, 0.3, -0.1), 0.3, 2),
    ]);
    let (mut positions, triangles, parts) = part.clone().into_arrays();
    positions[0].x = f32::from_bits(positions[0].x.to_bits() + 1);
    let moved = TriMesh::new(positions, triangles, parts).unwrap();
    (part, moved)
}

/// The file bytes of `mesh` built with `settings` on a pool of each size in `threads`, in
/// order (the builder runs on the caller's pool): what the thread-count determinism tests
/// compare.
pub fn bytes_on_threads(
    mesh: &TriMesh,
    settings: &BuildSettings,
    threads: &[usize],
) -> Vec<Vec<u8>> {
    threads
        .iter()
        .map(|&t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .expect("a pool")
                .install(|| build(mesh, settings))
                .expect("build")
                .0
                .to_bytes()
        })
        .collect()
}
