//! Fuzzes the glTF loader with external buffers resolved against a real folder: the input is a
//! `.gltf` JSON and, after the first 0xFF byte, the bytes of `buf.bin` beside it. The folder also
//! holds a link `out.bin` to a file outside it, and outside it a "secret" buffer whose first
//! vertex is (12345, 12345, 12345). Any input must give a `MeshError` or a valid mesh, never a
//! panic; a mesh must never hold the secret vertex (nothing outside the folder is read); and an
//! accepted mesh has the properties of `mesh_common::check`.
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

mod mesh_common;

use libfuzzer_sys::fuzz_target;
use mesh_common::{check, LIMITS};
use sdfmo_mesh::load_mesh_with_limits;

const SECRET: f32 = 12345.0;

/// The folder of the model (created once per process, removed by the OS's temp cleaning).
fn model_dir() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let root = std::env::temp_dir().join(format!("sdfmo-fuzz-gltf-{}", std::process::id()));
        let model = root.join("model");
        std::fs::create_dir_all(&model).expect("temp folder");
        let secret: Vec<u8> = [SECRET, SECRET, SECRET, SECRET, 0.0, 0.0, 0.0, SECRET, 0.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        std::fs::write(root.join("secret.bin"), &secret).expect("secret");
        let _ = std::os::unix::fs::symlink(root.join("secret.bin"), model.join("out.bin"));
        model
    })
}

fuzz_target!(|data: &[u8]| {
    let (json, buffer) = match data.iter().position(|&b| b == 0xFF) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let dir = model_dir();
    let gltf = dir.join("m.gltf");
    if std::fs::write(&gltf, json).is_err() || std::fs::write(dir.join("buf.bin"), buffer).is_err() {
        return;
    }
    let Ok(loaded) = load_mesh_with_limits(&gltf, &LIMITS) else {
        return;
    };
    let m = &loaded.mesh;
    assert!(
        !m.positions().iter().any(|p| p.x == SECRET || p.y == SECRET || p.z == SECRET),
        "a buffer outside the model's folder was read"
    );
    check(m);
});
