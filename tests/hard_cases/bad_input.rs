//! Bad input end to end: typed errors through the facade's high-level API, never a panic.

use std::path::PathBuf;

use glam::Vec3;
use sdf_multioctree::build::Method;
use sdf_multioctree::format::PackedOctree;
use sdf_multioctree::mesh::{procedural, TriMesh};
use sdf_multioctree::render::{Camera, Mode};
use sdf_multioctree::{build_octree, load_mesh, load_octree, Error};
use sdf_multioctree::{Device, LevelRequest, RenderSettings, Renderer, SmoFile};

use crate::common::MULTI;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sdfmo-hard-cases-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// What the facade makes of arrays no mesh can hold: `TriMesh`'s fields are private, so
/// `TriMesh::new` is the only way in and refuses them with a typed [`Error::Mesh`]; the builder
/// and the reference renderer never see such a mesh.
fn raw(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Error {
    let parts = vec![0; triangles.len()];
    Error::from(TriMesh::new(positions, triangles, parts).expect_err("an invalid mesh"))
}

fn tri() -> Vec<Vec3> {
    vec![Vec3::ZERO, Vec3::X, Vec3::Y]
}

#[test]
fn nan_and_infinite_coordinates_are_typed_errors() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut p = tri();
        p[1].y = bad;
        let e = raw(p, vec![[0, 1, 2]]);
        assert!(matches!(e, Error::Mesh(_)), "{bad}: {e}");
    }
    // From a file.
    for (ext, text) in [
        ("obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"),
        ("obj", "v 0 0 0\nv 1 inf 0\nv 0 1 0\nf 1 2 3\n"),
        ("stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 NaN\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n"),
    ] {
        let path = tmp(&format!("nan.{ext}"));
        std::fs::write(&path, text).unwrap();
        let e = load_mesh(&path).unwrap_err();
        assert!(matches!(e, Error::Mesh(_)), "{ext}: {e}");
        eprintln!("{ext} with a non-finite coordinate: {e}");
    }
}

#[test]
fn out_of_range_indices_are_typed_errors() {
    for idx in [3u32, 1000, u32::MAX] {
        let e = raw(tri(), vec![[0, 1, 2], [0, idx, 1]]);
        assert!(matches!(e, Error::Mesh(_)), "{idx}: {e}");
    }
    for text in [
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -7\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n",
    ] {
        let path = tmp("index.obj");
        std::fs::write(&path, text).unwrap();
        let e = load_mesh(&path).unwrap_err();
        assert!(matches!(e, Error::Mesh(_)), "{e}");
        eprintln!("OBJ with a bad index: {e}");
    }
    // Part ids that disagree with the triangles.
    let e = Error::from(TriMesh::new(tri(), vec![[0, 1, 2]], vec![]).unwrap_err());
    assert!(matches!(e, Error::Mesh(_)), "{e}");
}

#[test]
fn empty_meshes_are_typed_errors() {
    for e in [raw(vec![], vec![]), raw(tri(), vec![])] {
        assert!(matches!(e, Error::Mesh(_)), "{e}");
    }
    for (name, bytes) in [
        ("empty.obj", &b""[..]),
        ("points.obj", &b"v 0 0 0\nv 1 0 0\n"[..]),
        ("empty.stl", &b""[..]),
        ("zero.stl", &[0u8; 84][..]),
        ("empty.glb", &b""[..]),
    ] {
        let path = tmp(name);
        std::fs::write(&path, bytes).unwrap();
        let e = load_mesh(&path).unwrap_err();
        assert!(matches!(e, Error::Mesh(_)), "{name}: {e}");
    }
}

#[test]
fn invalid_settings_and_cameras_are_typed_errors() {
    let m = procedural::box_mesh(Vec3::ZERO, Vec3::ONE);
    assert!(matches!(
        build_octree(&m, 17, MULTI).unwrap_err(),
        Error::Build(_)
    ));
    assert!(matches!(
        build_octree(&m, 255, Method::Svo).unwrap_err(),
        Error::Build(_)
    ));
    assert!(matches!(
        build_octree(&m, 4, Method::Multi { max_voxels: 0 }).unwrap_err(),
        Error::Build(_)
    ));
    let (o, _) = build_octree(&m, 4, MULTI).unwrap();
    let file = SmoFile::Octree(o);
    let mut renderer = Renderer::new(Device::Cpu).unwrap();
    let good = Camera::paper_view(0, 16, 16);
    for cam in [
        Camera {
            eye: Vec3::NAN,
            ..good
        },
        Camera {
            target: good.eye,
            ..good
        },
        Camera {
            fov_y_deg: 0.0,
            ..good
        },
        Camera {
            fov_y_deg: f32::NAN,
            ..good
        },
        Camera { width: 0, ..good },
        Camera {
            up: Vec3::ZERO,
            ..good
        },
    ] {
        let e = renderer
            .prepare(&file, LevelRequest::Finest)
            .and_then(|mut p| p.render(&cam, &RenderSettings::new(Mode::Lambert)))
            .unwrap_err();
        assert!(matches!(e, Error::Render(_)), "{cam:?}: {e}");
    }
}

/// Every truncation and every single-byte corruption of a real `.smo` file is an error (the
/// checksum and validation catch them), and loading never panics.
#[test]
fn corrupt_octree_files_are_typed_errors() {
    let (o, _) = build_octree(&procedural::demo_part(), 4, MULTI).unwrap();
    let path = tmp("demo.smo");
    sdf_multioctree::save_octree(&o, &path).unwrap();
    let good = std::fs::read(&path).unwrap();
    assert_eq!(
        load_octree(&path).unwrap().file.to_bytes().into_owned(),
        good
    );
    let bad = tmp("bad.smo");
    // Through the file API for a sample (file writes are slow on a loaded machine), through the
    // same validation in memory for the sweep.
    let mut through_file = 0;
    let mut expect_err = |bytes: &[u8], what: &str| {
        if through_file < 64 || what.starts_with("garbage") || what.starts_with("trailing") {
            through_file += 1;
            std::fs::write(&bad, bytes).unwrap();
            match load_octree(&bad) {
                Err(Error::Format(_)) => {}
                Err(e) => panic!("{what}: wrong error kind {e}"),
                Ok(_) => panic!("{what}: a corrupt file loaded"),
            }
        }
        assert!(
            PackedOctree::from_bytes(bytes).is_err(),
            "{what}: corrupt bytes loaded"
        );
    };
    for len in (0..good.len()).step_by(3).chain([good.len() - 1]) {
        expect_err(&good[..len], &format!("truncated to {len}"));
    }
    let mut flips = 0;
    for i in 0..good.len() {
        for mask in [0x01u8, 0x80, 0xFF] {
            let mut b = good.clone();
            b[i] ^= mask;
            expect_err(&b, &format!("byte {i} ^ {mask:#x}"));
            flips += 1;
        }
    }
    let mut longer = good.clone();
    longer.extend_from_slice(&[0; 16]);
    expect_err(&longer, "trailing bytes");
    expect_err(&vec![0xAB; good.len()], "garbage");
    eprintln!(
        "corrupt .smo: {} bytes, {} truncations and {flips} corruptions, all typed errors",
        good.len(),
        good.len() / 3 + 2
    );
    assert!(matches!(
        load_octree(tmp("missing.smo")).unwrap_err(),
        Error::Format(_)
    ));
    std::fs::remove_dir_all(path.parent().unwrap()).ok();
}

/// Regression: the facade's `render_mesh` (now `Renderer::prepare_mesh`) used to normalise the mesh (`TriMesh::normalized` →
/// `bounds`) before anything validated it, so a `TriMesh` built without `TriMesh::new` (its fields
/// were public) with triangles [[0,1,2],[0,3,1]] over 3 vertices panicked with "index out of
/// bounds: the len is 3 but the index is 3" instead of returning an error. The fields are private
/// now: such a mesh cannot be made, and asking for it is a typed error, not a panic.
#[test]
fn render_mesh_with_out_of_range_index_is_a_typed_error() {
    for idx in [3u32, 1000, u32::MAX] {
        let r = std::panic::catch_unwind(|| raw(tri(), vec![[0, 1, 2], [0, idx, 1]]));
        assert!(
            matches!(r, Ok(Error::Mesh(_))),
            "index {idx}: the mesh was accepted or panicked"
        );
    }
}
