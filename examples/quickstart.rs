//! Quickstart: the built-in demo part → multi-octree → `.smo` file → a rendered PNG.
//!
//! ```sh
//! cargo run --release --example quickstart [DEPTH] [OUT_DIR]
//! ```
//!
//! Defaults: depth 6, output in the system's temporary directory (created if missing). Runs in
//! about a second.

use sdf_multioctree::{
    build_octree, demo_mesh, load_octree, paper_views, save_octree, save_png, Device, LevelRequest,
    Method, Mode, RenderSettings, Renderer,
};

fn main() -> std::process::ExitCode {
    // Errors print as one line with their causes (`cannot create …: No such file or
    // directory`), not as the Debug dump `?` in `main` gives.
    if let Err(e) = run() {
        let mut line = format!("error: {e}");
        let mut source = e.source();
        while let Some(s) = source {
            line += &format!(": {s}");
            source = s.source();
        }
        eprintln!("{line}");
        return std::process::ExitCode::FAILURE;
    }
    std::process::ExitCode::SUCCESS
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let depth: u8 = match args.next() {
        Some(d) => d
            .parse()
            .map_err(|_| format!("depth {d:?} is not a number"))?,
        None => 6,
    };
    let out_dir: std::path::PathBuf = args.next().map_or_else(std::env::temp_dir, Into::into);
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;

    // 1. A mesh: the demo part (or `sdf_multioctree::load_mesh("part.stl")?`).
    let mesh = demo_mesh();
    println!("demo part: {} triangles", mesh.triangle_count());

    // 2. Build the multi-octree.
    let (octree, stats) = build_octree(&mesh, depth, Method::Multi { max_voxels: 8 })?;
    println!(
        "depth {depth}: {} leaves, {} voxels ({} surface), {} bytes, built in {:.1} ms",
        stats.leaves, stats.voxels, stats.surface_voxels, stats.bytes, stats.build_ms
    );

    // 3. Save it and load it back (the loader validates the whole file).
    let smo = out_dir.join("quickstart.smo");
    save_octree(&octree, &smo)?;
    let file = load_octree(&smo)?.file;

    // 4. Render the paper's first view (on the CPU; `Device::Gpu` with the `gpu` feature) and
    //    save it.
    let camera = &paper_views(512)[0];
    let image = Renderer::new(Device::Cpu)?
        .prepare(&file, LevelRequest::Finest)?
        .render(camera, &RenderSettings::new(Mode::Lambert))?;
    let png = out_dir.join("quickstart.png");
    save_png(&image, &png)?;
    println!(
        "rendered {}x{} in {:.1} ms: {} and {}",
        image.width,
        image.height,
        image.render_ms,
        smo.display(),
        png.display()
    );
    Ok(())
}
