//! One row of the sweep's table through the library API: the SVO baseline and the multi-octree
//! at one depth, rendered with the paper's four views and compared with the mesh reference.
//!
//! ```sh
//! cargo run --release --example compare_methods [MESH] [DEPTH] [SIZE]
//! ```
//!
//! Defaults: the demo part, depth 6, 256×256 views (a few seconds). The paper's protocol is
//! depth 9 and 1024×1024 (`sdfmo sweep` runs it over many models and depths).

use sdf_multioctree::{
    build_octree, compare, demo_mesh, load_mesh, paper_views, render_mesh, render_octree, Method,
    Mode,
};

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

    let cameras = paper_views(size);
    let references = cameras
        .iter()
        .map(|c| render_mesh(&mesh, c, Mode::Lambert))
        .collect::<Result<Vec<_>, _>>()?;

    println!(
        "{name}, depth {depth}, {} views of {size}x{size}",
        cameras.len()
    );
    println!("| method | PSNR dB | FLIP | MB | build ms | render ms |");
    println!("|---|---:|---:|---:|---:|---:|");
    let mut psnrs = Vec::new();
    for (label, method) in [
        ("SVO", Method::Svo),
        ("multi", Method::Multi { max_voxels: 8 }),
    ] {
        let (octree, stats) = build_octree(&mesh, depth, method)?;
        let (mut psnr, mut flip, mut ms) = (0.0, 0.0, 0.0);
        for (camera, reference) in cameras.iter().zip(&references) {
            let image = render_octree(&octree, camera, Mode::Lambert)?;
            let q = compare(reference, &image)?;
            psnr += q.psnr;
            flip += f64::from(q.flip);
            ms += image.render_ms;
        }
        let n = cameras.len() as f64;
        println!(
            "| {label} | {:.2} | {:.4} | {:.3} | {:.0} | {:.1} |",
            psnr / n,
            flip / n,
            stats.bytes as f64 / 1e6,
            stats.build_ms,
            ms / n
        );
        psnrs.push(psnr / n);
    }
    println!("multi − SVO: {:+.2} dB", psnrs[1] - psnrs[0]);
    Ok(())
}
