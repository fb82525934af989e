//! One row of the sweep's table through the library API: the SVO baseline and the multi-octree
//! at one depth, rendered with the paper's four views and compared with the mesh reference.
//!
//! ```sh
//! cargo run --release --example compare_methods [MESH] [DEPTH] [SIZE]
//! ```
//!
//! Defaults: the demo part, depth 6, 256×256 views (a few seconds). The paper's protocol is
//! depth 9 and 1024×1024 (`sdfmo sweep` runs it over many models and depths).

use sdf_multioctree::render::{OctreeScene, PaperProtocol};
use sdf_multioctree::{build_octree, demo_mesh, load_mesh, Method, DEFAULT_MARGIN};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mesh, name) = match args.first().filter(|a| a.as_str() != "demo") {
        Some(path) => (load_mesh(path)?, path.clone()),
        None => (demo_mesh(), "demo".to_owned()),
    };
    let depth: u8 = args
        .get(1)
        .map_or(Ok(6), |d| d.parse())
        .map_err(|_| "DEPTH must be a number")?;
    let size: u32 = args
        .get(2)
        .map_or(Ok(256), |s| s.parse())
        .map_err(|_| "SIZE must be a number")?;

    // The mesh's reference renders of the paper's views; each octree is scored against them.
    let protocol = PaperProtocol::new(&mesh, DEFAULT_MARGIN, size)?;
    println!(
        "{name}, depth {depth}, {} views of {size}x{size}",
        protocol.cameras().len()
    );
    println!("| method | PSNR dB | FLIP | MB | build ms | render ms |");
    println!("|---|---:|---:|---:|---:|---:|");
    let mut psnrs = Vec::new();
    for (label, method) in [
        ("SVO", Method::Svo),
        ("multi", Method::Multi { max_voxels: 8 }),
    ] {
        let (octree, stats) = build_octree(&mesh, depth, method)?;
        let score = protocol.score(&OctreeScene(&octree))?;
        println!(
            "| {label} | {:.2} | {:.4} | {:.3} | {:.0} | {:.1} |",
            score.psnr(),
            score.flip(),
            stats.bytes as f64 / 1e6,
            stats.build_ms,
            score.render_ms()
        );
        psnrs.push(score.psnr());
    }
    println!("multi − SVO: {:+.2} dB", psnrs[1] - psnrs[0]);
    Ok(())
}
