//! Format 3.0 (bricks, `sdfmo_format::BrickOctree`) on the builder's real output: the five
//! shared models, both methods, depths 8 and 9 (10 in release builds, run with
//! `--ignored`). Every voxel of the 1.x octree equals the 3.0 view's answer, the 3.0 file
//! decodes to the same 1.x bytes, and its size per voxel is what `docs/format-3.md` measured.

use std::path::PathBuf;

use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_format::{decode_levels_prefix, encode_levels, BrickOctree, BrickOctreeView};

const MODELS: [&str; 5] = ["abc1.stl", "abc3.stl", "abc5.stl", "abc8.stl", "teapot.obj"];
const METHODS: [Method; 2] = [Method::Svo, Method::Multi { max_voxels: 8 }];

fn load(name: &str) -> sdfmo_mesh::TriMesh {
    let path = PathBuf::from(env!("SDFMO_TEST_DATA_DIR")).join(name);
    sdfmo_mesh::load_mesh(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .mesh
}

/// `measure(model, mesh, method, what)` on every model and method, `what` naming the three
/// (`"{model} {method:?} {setting}"`); each label with what `measure` returned.
fn on_every_model(
    setting: &str,
    mut measure: impl FnMut(&str, &sdfmo_mesh::TriMesh, Method, &str) -> f64,
) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for model in MODELS {
        let mesh = load(model);
        for method in METHODS {
            let what = format!("{model} {method:?} {setting}");
            let value = measure(model, &mesh, method, &what);
            out.push((what, value));
        }
    }
    out
}

/// Builds, encodes and checks every model and method at `depth`; the 3.0 bytes per voxel.
fn check_depth(depth: u8) -> Vec<(String, f64)> {
    on_every_model(&format!("depth {depth}"), |model, mesh, method, what| {
        let (o, _) = build(mesh, &BuildSettings::new(depth, method)).expect("build");
        let b = BrickOctree::encode(&o).expect("encode");
        let v = BrickOctreeView::new(b.as_bytes()).expect("valid 3.0 bytes");
        assert_eq!(v.first_difference(&o), None, "{what}");
        assert_eq!(b.to_octree(), o, "{what}: decodes to the same 1.x file");
        let bpv = b.as_bytes().len() as f64 / o.voxel_count() as f64;
        // docs/format-3.md: ≤ 5.0 bytes per voxel but on abc5's multi-octree at depths
        // 8 and 9 (5.60 and 5.13 measured: a third of its voxels are private).
        let bar = if model == "abc5.stl" && method != Method::Svo && depth < 10 {
            5.7
        } else {
            5.0
        };
        assert!(bpv <= bar, "{what}: {bpv:.2} bytes per voxel");
        bpv
    })
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn shared_models_depth_8_are_lossless_in_format_3() {
    assert_eq!(check_depth(8).len(), 10);
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn shared_models_depth_9_are_lossless_in_format_3() {
    assert_eq!(check_depth(9).len(), 10);
}

/// Depth 10 (3.3 M voxels per model at most): `cargo test --release -- --ignored`.
#[test]
#[ignore = "release only: cargo test --release -p sdfmo-build --test format_v3 -- --ignored"]
fn shared_models_depth_10_are_lossless_in_format_3() {
    assert_eq!(check_depth(10).len(), 10);
}

/// Builds levels `coarsest..=depth` of every model and method, writes them as format 4.1
/// (levels of bricks) and checks that every level decodes to the octree the 2.0 file holds, that
/// every level-boundary prefix decodes to exactly its levels, and, with a `bar`, that the file
/// costs at most that many times the leaf-only 3.1 file of its finest level. The ratios.
fn check_levels(depth: u8, coarsest: u8, bar: Option<f64>) -> Vec<(String, f64)> {
    let setting = format!("levels {coarsest}..={depth}");
    on_every_model(&setting, |_, mesh, method, what| {
        let (lod, _) = sdfmo_build::BuildRequest::new(mesh, BuildSettings::new(depth, method))
            .levels(coarsest)
            .expect("build");
        let bytes = encode_levels(&lod).expect("encode");
        let p = decode_levels_prefix(&bytes).expect("decode");
        assert_eq!(
            p.octree, lod,
            "{what}: every level decodes to its 1.x octree"
        );
        for (i, e) in p.declared.iter().enumerate() {
            let q = decode_levels_prefix(&bytes[..e.end() as usize]).expect("a prefix");
            assert_eq!(q.octree.levels(), &lod.levels()[..=i], "{what}: prefix {i}");
        }
        let leaf_only = BrickOctree::encode(lod.finest())
            .expect("3.1")
            .as_bytes()
            .len();
        let ratio = bytes.len() as f64 / leaf_only as f64;
        if let Some(bar) = bar {
            assert!(ratio <= bar, "{what}: {ratio:.3}× the leaf-only 3.1 file");
        }
        ratio
    })
}

/// Levels 4–7: lossless, every prefix (no size bar: the coarse levels weigh more at low depths,
/// above 1.10× the leaf-only 3.1 file; docs/results/lod.md measures 5–9 and 6–10 at ≤ 1.10×).
#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn shared_models_levels_are_lossless_in_format_4() {
    assert_eq!(check_levels(7, 4, None).len(), 10);
}

/// Levels 6–10 (the bar, ≤ 1.10× the leaf-only 3.1 file): `cargo test --release --
/// --ignored`.
#[test]
#[ignore = "release only: cargo test --release -p sdfmo-build --test format_v3 -- --ignored"]
fn shared_models_levels_6_to_10_cost_at_most_1_1_in_format_4() {
    assert_eq!(check_levels(10, 6, Some(1.10)).len(), 10);
}
