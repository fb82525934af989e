//! A catalogue of malformed files, written into a temporary directory and loaded through
//! `load_mesh`: each must give the right `MeshError` variant, name the file, and never panic.

use std::path::{Path, PathBuf};

use glam::Vec3;
use sdfmo_mesh::{load_mesh, load_mesh_with_limits, procedural, write, LoadLimits, MeshError};

/// Which variant a case must produce.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Want {
    Io,
    UnknownFormat,
    Truncated,
    HeaderMismatch,
    TooLarge,
    NonFinite,
    IndexOutOfRange,
    NoTriangles,
    Parse,
    Unsupported,
}

fn variant(e: &MeshError) -> Want {
    match e {
        MeshError::Io { .. } | MeshError::ExternalBuffer { .. } => Want::Io,
        MeshError::UnknownFormat { .. } => Want::UnknownFormat,
        MeshError::Truncated { .. } => Want::Truncated,
        MeshError::HeaderMismatch { .. } => Want::HeaderMismatch,
        MeshError::TooLarge { .. } => Want::TooLarge,
        MeshError::NonFinite { .. } => Want::NonFinite,
        MeshError::IndexOutOfRange { .. } => Want::IndexOutOfRange,
        MeshError::NoTriangles { .. } => Want::NoTriangles,
        MeshError::Parse { .. } => Want::Parse,
        MeshError::Unsupported { .. } => Want::Unsupported,
        other => panic!("unexpected variant {other:?}"),
    }
}

struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Self {
        let p = std::env::temp_dir().join(format!(
            "sdfmo-mesh-malformed-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    write::glb_container(json, bin)
}

/// One triangle: 3 positions (36 bytes) then 3 u16 indices (6 bytes).
fn tri_bin(p: [[f32; 3]; 3], idx: [u16; 3]) -> Vec<u8> {
    let mut b = Vec::new();
    for v in p {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in idx {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// glTF JSON for one triangle primitive; `pos_count`, `mode`, `nodes` and `buffer` vary.
fn tri_json(pos_count: u32, mode: u32, nodes: &str, buffer: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":{nodes},
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":{mode}}}]}}],
"buffers":[{buffer}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{pos_count},"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#
    )
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

fn cases() -> Vec<(&'static str, Vec<u8>, Want)> {
    let cube = procedural::box_mesh(Vec3::ZERO, Vec3::ONE);
    let bin_stl = write::to_stl_binary(&cube);
    let ascii_stl = write::to_stl_ascii(&cube);
    let with_count = |n: u32| {
        let mut b = bin_stl.clone();
        b[80..84].copy_from_slice(&n.to_le_bytes());
        b
    };
    let mut nan_stl = bin_stl.clone();
    nan_stl[84 + 50 * 3 + 16..84 + 50 * 3 + 20].copy_from_slice(&f32::NAN.to_le_bytes());
    let mut trailing = bin_stl.clone();
    trailing.extend_from_slice(&[0; 7]);
    // A box squashed onto the x axis: every triangle collinear (zero area).
    let flat_only = procedural::box_mesh(Vec3::ZERO, Vec3::ONE).transformed(|p| p * Vec3::X);
    let one_buf = r#"{"byteLength":42}"#;
    let node0 = r#"[{"mesh":0}]"#;
    let good_glb = glb(&tri_json(3, 4, node0, one_buf), &tri_bin(TRI, [0, 1, 2]));
    let mut glb_v1 = good_glb.clone();
    glb_v1[4] = 1;
    let mut glb_long = good_glb.clone();
    glb_long[8..12].copy_from_slice(&10_000u32.to_le_bytes());
    let mut glb_short = good_glb.clone();
    glb_short[8..12].copy_from_slice(&16u32.to_le_bytes());
    let nan_tri = [[0.0, 0.0, 0.0], [f32::INFINITY, 0.0, 0.0], [0.0, 1.0, 0.0]];
    vec![
        ("empty.stl", vec![], Want::Truncated),
        ("empty.mesh", vec![], Want::UnknownFormat),
        (
            "notes.txt",
            b"hello, this is not a mesh\n".to_vec(),
            Want::UnknownFormat,
        ),
        ("short_header.stl", vec![7u8; 50], Want::Truncated),
        ("count_lies.stl", with_count(1000), Want::HeaderMismatch),
        ("count_4g.stl", with_count(u32::MAX), Want::HeaderMismatch),
        // Binary, but the header starts with "solid" (as many exporters write it): still a
        // binary STL with a wrong count, not broken ASCII.
        (
            "solid_header_count_lies.stl",
            {
                let mut b = with_count(1000);
                b[..12].copy_from_slice(b"solid binary");
                b
            },
            Want::HeaderMismatch,
        ),
        (
            "cut_record.stl",
            bin_stl[..bin_stl.len() - 17].to_vec(),
            Want::Truncated,
        ),
        ("trailing.stl", trailing, Want::HeaderMismatch),
        (
            "zero_count.stl",
            with_count(0)[..84].to_vec(),
            Want::NoTriangles,
        ),
        ("nan.stl", nan_stl, Want::NonFinite),
        (
            "flat_only.stl",
            write::to_stl_binary(&flat_only),
            Want::NoTriangles,
        ),
        (
            "inf_ascii.stl",
            ascii_stl
                .replacen("vertex 0e0", "vertex inf", 1)
                .into_bytes(),
            Want::NonFinite,
        ),
        (
            "cut_ascii.stl",
            ascii_stl.as_bytes()[..300].to_vec(),
            Want::Truncated,
        ),
        (
            "bad_number.stl",
            ascii_stl
                .replacen("vertex 0e0", "vertex zero", 1)
                .into_bytes(),
            Want::Parse,
        ),
        (
            "quad_loop.stl",
            ascii_stl
                .replacen("endloop", "vertex 1 1 1\n    endloop", 1)
                .into_bytes(),
            Want::Parse,
        ),
        (
            "ascii_no_facets.stl",
            b"solid empty\nendsolid empty\n".to_vec(),
            Want::NoTriangles,
        ),
        (
            "out_of_range.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n".to_vec(),
            Want::IndexOutOfRange,
        ),
        (
            "negative.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -9\n".to_vec(),
            Want::IndexOutOfRange,
        ),
        (
            "zero_index.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n".to_vec(),
            Want::IndexOutOfRange,
        ),
        (
            "nan.obj",
            b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
            Want::NonFinite,
        ),
        (
            "huge.obj",
            b"v 1e39 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
            Want::NonFinite,
        ),
        (
            "no_faces.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\n".to_vec(),
            Want::NoTriangles,
        ),
        (
            "bad_index.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n".to_vec(),
            Want::Parse,
        ),
        (
            "w_zero.obj",
            b"v 0 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
            Want::Parse,
        ),
        (
            "collinear.obj",
            write::to_obj(&flat_only).into_bytes(),
            Want::NoTriangles,
        ),
        (
            "cut.glb",
            good_glb[..good_glb.len() - 30].to_vec(),
            Want::Truncated,
        ),
        ("v1.glb", glb_v1, Want::Unsupported),
        ("length_lies.glb", glb_long, Want::Truncated),
        ("length_short.glb", glb_short, Want::HeaderMismatch),
        ("tiny.glb", b"glTF\x02\0\0".to_vec(), Want::Truncated),
        (
            "bad_json.gltf",
            b"{ \"asset\": [ nope".to_vec(),
            Want::Parse,
        ),
        (
            "accessor_oob.glb",
            glb(&tri_json(1000, 4, node0, one_buf), &tri_bin(TRI, [0, 1, 2])),
            Want::Truncated,
        ),
        (
            "index_oob.glb",
            glb(&tri_json(3, 4, node0, one_buf), &tri_bin(TRI, [0, 1, 7])),
            Want::IndexOutOfRange,
        ),
        (
            "inf.glb",
            glb(
                &tri_json(3, 4, node0, one_buf),
                &tri_bin(nan_tri, [0, 1, 2]),
            ),
            Want::NonFinite,
        ),
        (
            "points_only.glb",
            glb(&tri_json(3, 0, node0, one_buf), &tri_bin(TRI, [0, 1, 2])),
            Want::NoTriangles,
        ),
        (
            "cycle.glb",
            glb(
                &tri_json(
                    3,
                    4,
                    r#"[{"mesh":0,"children":[1]},{"children":[1]}]"#,
                    one_buf,
                ),
                &tri_bin(TRI, [0, 1, 2]),
            ),
            Want::Parse,
        ),
        (
            "instanced_bomb.glb",
            glb(
                &tri_json(
                    3,
                    4,
                    &format!(
                        "[{}]",
                        (0..24)
                            .map(|i| format!(
                                r#"{{"mesh":0,"children":[{0},{0}]}}"#,
                                (i + 1).min(23)
                            ))
                            .collect::<Vec<_>>()
                            .join(",")
                    )
                    .replace(r#""children":[23,23]}]"#, r#""children":[]}]"#),
                    one_buf,
                ),
                &tri_bin(TRI, [0, 1, 2]),
            ),
            Want::TooLarge,
        ),
        (
            "http_buffer.gltf",
            tri_json(
                3,
                4,
                node0,
                r#"{"byteLength":42,"uri":"http://example.invalid/a.bin"}"#,
            )
            .into_bytes(),
            Want::Unsupported,
        ),
        (
            "absolute_buffer.gltf",
            tri_json(3, 4, node0, r#"{"byteLength":42,"uri":"/etc/hostname"}"#).into_bytes(),
            Want::Unsupported,
        ),
        (
            "missing_buffer.gltf",
            tri_json(3, 4, node0, r#"{"byteLength":42,"uri":"missing.bin"}"#).into_bytes(),
            Want::Io,
        ),
        (
            "short_buffer.gltf",
            tri_json(
                3,
                4,
                node0,
                r#"{"byteLength":42,"uri":"data:application/octet-stream;base64,AAAA"}"#,
            )
            .into_bytes(),
            Want::Truncated,
        ),
    ]
}

fn check(path: &Path, want: Want) {
    match load_mesh(path) {
        Ok(l) => panic!(
            "{}: loaded {} triangles, expected {want:?}",
            path.display(),
            l.mesh.triangle_count()
        ),
        Err(e) => {
            assert_eq!(variant(&e), want, "{}: got `{e}`", path.display());
            let msg = e.to_string();
            assert!(
                msg.contains(path.file_name().unwrap().to_str().unwrap()),
                "the error must name the file: {msg}"
            );
        }
    }
}

#[test]
fn malformed_catalogue() {
    let dir = TempDir::new();
    let cases = cases();
    assert!(cases.len() >= 20);
    for (name, bytes, want) in &cases {
        let path = dir.0.join(name);
        std::fs::write(&path, bytes).unwrap();
        check(&path, *want);
    }
    // I/O failures: a missing file and a directory.
    check(&dir.0.join("does_not_exist.stl"), Want::Io);
    let sub = dir.0.join("a_directory.obj");
    std::fs::create_dir_all(&sub).unwrap();
    check(&sub, Want::Io);
    // Limits: a valid file above the caller's triangle limit.
    let path = dir.0.join("limited.stl");
    std::fs::write(
        &path,
        write::to_stl_binary(&procedural::sphere(Vec3::ZERO, 1.0, 2)),
    )
    .unwrap();
    let limits = LoadLimits {
        max_triangles: 100,
        ..LoadLimits::default()
    };
    let e = load_mesh_with_limits(&path, &limits).unwrap_err();
    assert_eq!(variant(&e), Want::TooLarge, "{e}");
    assert!(load_mesh(&path).is_ok());
}

#[test]
fn the_good_cases_behind_the_catalogue_load() {
    // The unmodified inputs the catalogue breaks do load, so each failure above is caused by
    // the one defect introduced.
    let dir = TempDir::new();
    let one_buf = r#"{"byteLength":42}"#;
    let good = [
        (
            "good.glb",
            glb(
                &tri_json(3, 4, r#"[{"mesh":0}]"#, one_buf),
                &tri_bin(TRI, [0, 1, 2]),
            ),
        ),
        (
            "good.stl",
            write::to_stl_binary(&procedural::box_mesh(Vec3::ZERO, Vec3::ONE)),
        ),
        ("good.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec()),
        (
            "good_neg.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n".to_vec(),
        ),
    ];
    for (name, bytes) in good {
        let p = dir.0.join(name);
        std::fs::write(&p, bytes).unwrap();
        let l = load_mesh(&p).unwrap_or_else(|e| panic!("{e}"));
        assert!(l.mesh.triangle_count() >= 1);
    }
    // An external buffer next to the file is read (relative paths only).
    std::fs::write(dir.0.join("tri.bin"), tri_bin(TRI, [0, 1, 2])).unwrap();
    let p = dir.0.join("external.gltf");
    std::fs::write(
        &p,
        tri_json(
            3,
            4,
            r#"[{"mesh":0}]"#,
            r#"{"byteLength":42,"uri":"tri.bin"}"#,
        ),
    )
    .unwrap();
    assert_eq!(load_mesh(&p).unwrap().mesh.triangle_count(), 1);
}
