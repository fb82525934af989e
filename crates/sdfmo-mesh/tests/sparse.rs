//! A mesh file whose header declares another size than the file has (a binary STL's triangle
//! count, a GLB's length) is refused after reading its first bytes, whatever the file's
//! length: the loader checks the header against the file's length before reading the body
//! (issue 32).
//!
//! This file holds one test so that the process's peak resident memory is this test's alone.

use std::path::Path;
use std::time::{Duration, Instant};

use glam::Vec3;
use sdfmo_mesh::procedural::box_mesh;
use sdfmo_mesh::write::{to_glb, to_stl_binary};
use sdfmo_mesh::{load_mesh, MeshError};
use sdfmo_testdata::sparse::{peak_rss, reset_peak_rss, sparse_file};

/// Loads `path`, checks it failed within a second and 100 MB of peak memory.
fn refused_quickly(path: &Path) -> MeshError {
    reset_peak_rss();
    let t = Instant::now();
    let e = load_mesh(path).expect_err("refused");
    let took = t.elapsed();
    assert!(
        took < Duration::from_secs(1),
        "{}: {took:?}",
        path.display()
    );
    if let Some(peak) = peak_rss() {
        // Before the fix the loader read the whole 3 GiB before looking at the header.
        assert!(
            peak < 100 << 20,
            "{}: peak RSS {peak} bytes",
            path.display()
        );
    }
    e
}

#[test]
fn a_3_gib_sparse_mesh_whose_header_says_kilobytes_is_refused_before_reading_it() {
    let dir = tempfile::tempdir().unwrap();
    // A binary STL whose header announces 6,000 triangles (300,084 bytes).
    let mut stl = vec![0u8; 84];
    stl[80..84].copy_from_slice(&6000u32.to_le_bytes());
    let e = refused_quickly(&sparse_file(dir.path(), "big.stl", &stl));
    assert!(matches!(e, MeshError::HeaderMismatch { .. }), "{e}");
    assert!(
        e.to_string()
            .contains("announces 6000 triangles (300084 bytes), the file has 3221225472 bytes"),
        "{e}"
    );
    // The same header starting with "solid", as many exporters write it: still binary (the
    // NUL bytes), still refused from the header.
    stl[..12].copy_from_slice(b"solid part  ");
    let e = refused_quickly(&sparse_file(dir.path(), "solid.stl", &stl));
    assert!(matches!(e, MeshError::HeaderMismatch { .. }), "{e}");
    let m = box_mesh(Vec3::ZERO, Vec3::ONE);
    // A GLB whose header declares its own length: the 3 GiB behind it are never read.
    let glb = to_glb(&m);
    let p = sparse_file(dir.path(), "big.glb", &glb);
    reset_peak_rss();
    let t = Instant::now();
    let l = load_mesh(&p).unwrap();
    assert!(t.elapsed() < Duration::from_secs(1), "{:?}", t.elapsed());
    if let Some(peak) = peak_rss() {
        assert!(peak < 100 << 20, "GLB: peak RSS {peak} bytes");
    }
    assert_eq!(l.mesh.triangle_count(), 12);
    // A GLB that declares more than the file has: refused from the header.
    let mut short = glb.clone();
    short.truncate(glb.len() - 8);
    let p = dir.path().join("short.glb");
    std::fs::write(&p, &short).unwrap();
    let e = load_mesh(&p).unwrap_err();
    assert!(matches!(e, MeshError::Truncated { .. }), "{e}");
    // Files at their declared size load as before.
    let p = dir.path().join("box.stl");
    std::fs::write(&p, to_stl_binary(&m)).unwrap();
    assert_eq!(load_mesh(&p).unwrap().mesh.triangle_count(), 12);
}
