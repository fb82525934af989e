//! Writes small generated seed files for the mesh fuzz targets:
//! `cargo run -p sdfmo-mesh --example fuzz_seeds -- fuzz/corpus` creates
//! `fuzz_obj/`, `fuzz_stl/` and `fuzz_gltf/` below the given directory (no shared data is
//! copied: every seed comes from the procedural parts and the crate's writers).

use std::path::PathBuf;

use glam::Vec3;
use sdfmo_mesh::{procedural, write};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "fuzz/corpus".into()),
    );
    let meshes = [
        (
            "box",
            procedural::box_mesh(Vec3::ZERO, Vec3::new(1.0, 2.0, 0.5)),
        ),
        ("pair", procedural::gap_pair(1.0, 0.01)),
        ("sphere", procedural::sphere(Vec3::ONE, 0.5, 1)),
        ("sheet", procedural::open_sheet(1.0, 2.0, 2)),
    ];
    for dir in ["fuzz_obj", "fuzz_stl", "fuzz_gltf"] {
        std::fs::create_dir_all(root.join(dir))?;
    }
    for (name, m) in &meshes {
        let seeds: [(String, Vec<u8>); 5] = [
            (
                format!("fuzz_obj/{name}.obj"),
                write::to_obj(m).into_bytes(),
            ),
            (format!("fuzz_stl/{name}.stl"), write::to_stl_binary(m)),
            (
                format!("fuzz_stl/{name}_ascii.stl"),
                write::to_stl_ascii(m).into_bytes(),
            ),
            (format!("fuzz_gltf/{name}.glb"), write::to_glb(m)),
            (
                format!("fuzz_gltf/{name}.gltf"),
                write::to_gltf_embedded(m).into_bytes(),
            ),
        ];
        for (path, bytes) in seeds {
            sdfmo_io::write_atomic(root.join(path), bytes)?;
        }
    }
    // Hand-written OBJ features the writer does not produce: quads, polygons, negative
    // indices, texture/normal references, groups, w coordinates, comments.
    sdfmo_io::write_atomic(
        root.join("fuzz_obj/features.obj"),
        "# features\nmtllib x.mtl\no first\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\nvt 0 0\nvn 0 0 1\n\
         f 1/1/1 2/1/1 3/1/1 4/1/1\ng second\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0.5 1.5 1\nv 0 1 1\n\
         usemtl m\nf -5 -4 -3 -2 -1\nf 1//1 5//1 6//1\ns off\nl 1 2\n",
    )?;
    println!("seeds written under {}", root.display());
    Ok(())
}
