//! Writes the built-in demo part (or any procedural part) to a mesh file, to look at it in
//! another tool: `cargo run -p sdfmo-mesh --example export_demo -- demo.obj` (`.obj`, `.stl`,
//! `.glb` or `.gltf`, chosen by the extension; parts are kept except in STL).

use sdfmo_mesh::{procedural, write};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "demo.obj".into());
    let mesh = procedural::demo_part();
    let ext = std::path::Path::new(&out)
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let bytes = match ext.as_str() {
        "obj" => write::to_obj(&mesh).into_bytes(),
        "stl" => write::to_stl_binary(&mesh),
        "glb" => write::to_glb(&mesh),
        "gltf" => write::to_gltf_embedded(&mesh).into_bytes(),
        _ => return Err(format!("unknown extension in {out} (obj, stl, glb, gltf)").into()),
    };
    sdfmo_io::write_atomic(&out, bytes)?;
    println!(
        "{out}: {} triangles, {} parts",
        mesh.triangle_count(),
        mesh.part_count()
    );
    Ok(())
}
