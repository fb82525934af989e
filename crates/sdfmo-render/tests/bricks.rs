//! A 3.0 file (`BrickOctree`, traced in place) renders the same images as its 1.x octree, byte
//! for byte: the shared models built by `sdfmo-build`, encoded with `BrickOctree::encode`,
//! rendered in lambert, normal and depth modes from the paper's four views; the PNG bytes and
//! the kept f32 normals and depths compared. abc1 and abc5 at depth 8, multi, 256² here; every
//! model, depths 8 and 9, both methods at 1024² with
//! `cargo test --release -p sdfmo-render --test bricks -- --ignored`.

use std::path::{Path, PathBuf};

use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_format::{BrickOctree, PackedOctree};
use sdfmo_render::{encode_png, render, Camera, Mode, OctreeScene, RenderSettings, Rendered};

const MODES: [Mode; 3] = [Mode::Lambert, Mode::Normal, Mode::Depth];

fn build_model(name: &str, depth: u8, method: Method) -> PackedOctree {
    let path = PathBuf::from(env!("SDFMO_TEST_DATA_DIR")).join(name);
    let mesh = sdfmo_mesh::load_mesh(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .mesh;
    build(&mesh, &BuildSettings::new(depth, method))
        .expect("build")
        .0
}

/// A render's PNG bytes, and the bits of its kept depths and normals.
type ImageBytes = (Vec<u8>, Option<Vec<u32>>, Option<Vec<[u32; 3]>>);

/// [`ImageBytes`] of a render.
fn image_bytes(r: &Rendered) -> ImageBytes {
    (
        encode_png(r, Path::new("test.png")).expect("png"),
        r.depth
            .as_ref()
            .map(|d| d.iter().map(|x| x.to_bits()).collect()),
        r.normals
            .as_ref()
            .map(|n| n.iter().map(|v| v.to_array().map(f32::to_bits)).collect()),
    )
}

/// Renders `octree` and its 3.0 encoding from the four paper views in every mode at `size`²
/// and asserts identical images; the number of image pairs compared, and of hits.
fn compare(octree: &PackedOctree, size: u32, what: &str) -> (usize, u64) {
    let bricks = BrickOctree::encode(octree).expect("encode");
    let (mut pairs, mut hits) = (0, 0);
    for camera in Camera::paper_views(size, size) {
        for mode in MODES {
            let settings = RenderSettings::new(mode);
            let a = render(&OctreeScene(octree), &camera, &settings).expect("1.x render");
            let b = render(&OctreeScene(&bricks), &camera, &settings).expect("3.0 render");
            assert!(
                image_bytes(&a) == image_bytes(&b),
                "{what}, {mode:?}, eye {}: the 3.0 image differs",
                camera.eye
            );
            assert_eq!(a.counters.hits, b.counters.hits);
            pairs += 1;
            hits += a.counters.hits;
        }
    }
    (pairs, hits)
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn bricks_render_byte_identical_images() {
    let multi = Method::Multi { max_voxels: 8 };
    for model in ["abc1.stl", "abc5.stl"] {
        let octree = build_model(model, 8, multi);
        let (pairs, hits) = compare(&octree, 256, model);
        assert_eq!(pairs, 12);
        assert!(hits > 20_000, "{model}: {hits} hits");
    }
}

/// The full comparison: five models, depths 8 and 9, SVO and multi, 1024², four views, three
/// modes (240 image pairs). Release builds: a few minutes.
#[test]
#[ignore = "release, minutes: cargo test --release -p sdfmo-render --test bricks -- --ignored"]
fn bricks_render_byte_identical_images_on_every_shared_model() {
    let mut pairs = 0;
    for model in ["abc1.stl", "abc3.stl", "abc5.stl", "abc8.stl", "teapot.obj"] {
        for depth in [8, 9] {
            for method in [Method::Svo, Method::Multi { max_voxels: 8 }] {
                let octree = build_model(model, depth, method);
                let what = format!("{model} depth {depth} {method:?}");
                let (n, hits) = compare(&octree, 1024, &what);
                println!("{what}: {n} image pairs identical, {hits} hits");
                pairs += n;
            }
        }
    }
    assert_eq!(pairs, 240);
}
