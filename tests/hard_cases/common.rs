//! Helpers shared by the hard-case tests: building, rendering in the normalised frame, masks.

use std::collections::BTreeMap;
use std::path::PathBuf;

use glam::Vec3;
use sdf_multioctree::build::{BuildSettings, Method};
use sdf_multioctree::distance::{MeshDistance, SignMode};
use sdf_multioctree::format::{PackedOctree, Voxel};
use sdf_multioctree::mesh::TriMesh;
use sdf_multioctree::render::{
    self, Camera, MeshScene, Mode, OctreeScene, RenderSettings, Rendered,
};
use sdf_multioctree::DEFAULT_MARGIN;

/// The multi-octree with the default cap.
pub const MULTI: Method = Method::Multi { max_voxels: 8 };

/// Both methods, with a name for messages.
pub const METHODS: [(&str, Method); 2] = [("svo", Method::Svo), ("multi", MULTI)];

/// Builds with the facade's defaults.
pub fn build(mesh: &TriMesh, depth: u8, method: Method) -> PackedOctree {
    sdf_multioctree::build_octree(mesh, depth, method)
        .unwrap_or_else(|e| panic!("build depth {depth} {method:?}: {e}"))
        .0
}

/// Builds with an explicit normalisation margin.
pub fn build_with_margin(mesh: &TriMesh, depth: u8, method: Method, margin: f32) -> PackedOctree {
    let settings = BuildSettings::new(depth, method).with_margin(margin);
    sdf_multioctree::build::build(mesh, &settings)
        .unwrap_or_else(|e| panic!("build depth {depth} {method:?}: {e}"))
        .0
}

/// Renders an octree (normalised frame).
pub fn render_octree(octree: &PackedOctree, camera: &Camera, mode: Mode) -> Rendered {
    render::render(&OctreeScene(octree), camera, &RenderSettings::new(mode)).expect("render octree")
}

/// Renders the reference: the mesh normalised exactly as the builder does with `margin`.
pub fn render_mesh_margin(mesh: &TriMesh, camera: &Camera, mode: Mode, margin: f32) -> Rendered {
    let (normalized, _) = mesh.normalized(margin);
    let dist = MeshDistance::new(&normalized, SignMode::Auto).expect("mesh distance");
    render::render(&MeshScene(&dist), camera, &RenderSettings::new(mode)).expect("render mesh")
}

/// Renders the reference with the default margin.
pub fn render_mesh(mesh: &TriMesh, camera: &Camera, mode: Mode) -> Rendered {
    render_mesh_margin(mesh, camera, mode, DEFAULT_MARGIN)
}

/// Hit mask of an image (any non-black pixel; in mask mode hits are white).
pub fn mask(r: &Rendered) -> Vec<bool> {
    r.rgb
        .chunks_exact(3)
        .map(|p| p.iter().any(|&c| c > 0))
        .collect()
}

/// Number of set pixels.
pub fn count(m: &[bool]) -> usize {
    m.iter().filter(|&&b| b).count()
}

/// Pixels set in `reference` and missing from `test`.
pub fn missing(reference: &[bool], test: &[bool]) -> usize {
    reference
        .iter()
        .zip(test)
        .filter(|(&r, &t)| r && !t)
        .count()
}

/// Pixels set in `test` and not in `reference`.
pub fn extra(reference: &[bool], test: &[bool]) -> usize {
    missing(test, reference)
}

/// The mask eroded by `k` pixels (8-neighbourhood; pixels near the border are cleared).
pub fn erode(m: &[bool], w: u32, h: u32, k: i32) -> Vec<bool> {
    let (w, h) = (w as i32, h as i32);
    let at = |x: i32, y: i32| x >= 0 && y >= 0 && x < w && y < h && m[(y * w + x) as usize];
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| (-k..=k).all(|dy| (-k..=k).all(|dx| at(x + dx, y + dy))))
        .collect()
}

/// Asserts the depth buffer of a depth-mode render holds no NaN and only positive finite
/// distances or +∞ (background); returns the number of hits.
pub fn assert_depth_sane(r: &Rendered, what: &str) -> usize {
    let depth = r.depth.as_ref().expect("depth mode keeps depth");
    let mut hits = 0;
    for (i, &t) in depth.iter().enumerate() {
        assert!(!t.is_nan(), "{what}: NaN depth at pixel {i}");
        assert!(t > 0.0, "{what}: depth {t} at pixel {i}");
        if t.is_finite() {
            hits += 1;
        } else {
            assert_eq!(t, f32::INFINITY, "{what}: depth {t} at pixel {i}");
        }
    }
    hits
}

/// Asserts the normals of a normal-mode render are unit (hits) or zero (background), never NaN.
pub fn assert_normals_sane(r: &Rendered, what: &str) {
    let normals = r.normals.as_ref().expect("normal mode keeps normals");
    for (i, n) in normals.iter().enumerate() {
        assert!(n.is_finite(), "{what}: normal {n} at pixel {i}");
        let l = n.length();
        assert!(
            l == 0.0 || (l - 1.0).abs() < 1e-3,
            "{what}: normal {n} (|n| {l}) at pixel {i}"
        );
    }
}

/// Renders depth and normal images of the octree and checks both are free of NaN; returns the
/// depth render's hit count.
pub fn assert_renders_sane(octree: &PackedOctree, camera: &Camera, what: &str) -> usize {
    let hits = assert_depth_sane(&render_octree(octree, camera, Mode::Depth), what);
    assert_normals_sane(&render_octree(octree, camera, Mode::Normal), what);
    hits
}

/// The octree's leaves by coordinate.
pub fn leaf_map(octree: &PackedOctree) -> BTreeMap<[u32; 3], Vec<Voxel>> {
    octree.leaves().collect()
}

/// Asserts every decoded corner value of the octree is finite.
pub fn assert_corners_finite(octree: &PackedOctree, what: &str) {
    for (coord, voxels) in octree.leaves() {
        for v in &voxels {
            assert!(
                v.corners.iter().all(|c| c.is_finite()),
                "{what}: leaf {coord:?} corners {:?}",
                v.corners
            );
        }
    }
}

/// A camera in the normalised frame.
pub fn camera(eye: Vec3, target: Vec3, size: u32) -> Camera {
    Camera::new(eye, target, 60.0, size, size)
}

/// Six cameras on the axes at distance 3, looking at the origin.
pub fn axis_cameras(size: u32) -> Vec<(String, Camera)> {
    [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
        .into_iter()
        .map(|a| {
            (
                format!("eye {}", a * 3.0),
                camera(a * 3.0, Vec3::ZERO, size),
            )
        })
        .collect()
}

/// The shared test meshes, as `build.rs` resolved them (`sdfmo-testdata`). Tests that read them
/// carry `#[cfg_attr(sdfmo_no_test_data, ignore = …)]`: ignored when the directory is absent and
/// `SDFMO_REQUIRE_TEST_DATA` is not `1`.
pub fn data_dir() -> PathBuf {
    PathBuf::from(env!("SDFMO_TEST_DATA_DIR"))
}
