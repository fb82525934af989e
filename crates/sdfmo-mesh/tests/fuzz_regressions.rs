//! Replays the fuzzers' kept crashers (`fuzz/corpus/fuzz_{obj,stl,gltf}/regressions/`) as a
//! normal test, and pins each fixed bug with a named test on a minimal input.

use std::path::PathBuf;

use sdfmo_mesh::{load_mesh_from_bytes, MeshError, MeshFormat};

#[test]
fn replay_fuzz_regressions() {
    let root = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fuzz/corpus"));
    let mut replayed = 0;
    for (target, hint) in [
        ("fuzz_obj", MeshFormat::Obj),
        ("fuzz_stl", MeshFormat::Stl),
        ("fuzz_gltf", MeshFormat::Glb),
    ] {
        let Ok(dir) = std::fs::read_dir(root.join(target).join("regressions")) else {
            continue;
        };
        for entry in dir {
            let path = entry.unwrap().path();
            let bytes = std::fs::read(&path).unwrap();
            // Must return (either way) instead of panicking.
            let _ = load_mesh_from_bytes(&bytes, &path.display().to_string(), Some(hint));
            replayed += 1;
        }
    }
    assert!(
        replayed >= 1,
        "no regression inputs found under {}",
        root.display()
    );
}

/// Found by fuzz_gltf: gltf-json 1.4.1 validates a primitive's POSITION accessor by indexing
/// `root.accessors` before checking the index, so `"POSITION": 0` in a file without accessors
/// panicked ("index out of bounds: the len is 0 but the index is 0"). Now a parse error.
#[test]
fn gltf_position_accessor_missing_is_an_error() {
    let json =
        br#"{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#;
    let e = load_mesh_from_bytes(json, "pos.gltf", Some(MeshFormat::Gltf)).unwrap_err();
    assert!(matches!(e, MeshError::Parse { .. }), "{e}");
    assert!(
        e.to_string().contains("POSITION refers to accessor 0"),
        "{e}"
    );
}
