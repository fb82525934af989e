//! Loads one mesh file and prints its size after loading, for measuring the loader's peak memory
//! alone (no topology) with `/usr/bin/time -v`:
//!
//! ```sh
//! cargo build -p sdfmo-mesh --example load_memory
//! /usr/bin/time -v target/debug/examples/load_memory big.obj
//! ```
//!
//! `docs/results/mesh.md` records the numbers for a generated 75 MB OBJ.

use std::time::Instant;

fn main() -> Result<(), sdfmo_mesh::MeshError> {
    let Some(path) = std::env::args_os().nth(1) else {
        eprintln!("usage: load_memory MESH");
        std::process::exit(2);
    };
    let t = Instant::now();
    let loaded = sdfmo_mesh::load_mesh(path.as_ref())?;
    println!(
        "{}: {} triangles, {} vertices, {} parts, loaded in {:.0} ms",
        std::path::Path::new(&path).display(),
        loaded.mesh.triangle_count(),
        loaded.mesh.vertex_count(),
        loaded.mesh.part_count(),
        t.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}
