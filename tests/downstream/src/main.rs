//! The facade's pipeline from a downstream crate: load (or make) a mesh, build an octree, save
//! it, load it back, render it and the mesh, compare the images, query distances in model
//! units. Usage: `sdfmo-downstream [MESH]` (the built-in demo part without one).

use sdf_multioctree::glam::Vec3;
use sdf_multioctree::{
    build_octree, compare, demo_mesh, load_mesh, load_octree, octree_distance, paper_views,
    save_octree, save_png, Device, LevelRequest, Method, Mode, RenderSettings, Renderer,
};

fn main() -> Result<(), sdf_multioctree::Error> {
    let mesh = match std::env::args_os().nth(1) {
        Some(path) => load_mesh(path)?,
        None => demo_mesh(),
    };
    let (octree, stats) = build_octree(&mesh, 6, Method::Multi { max_voxels: 8 })?;
    println!("built: {} bytes", stats.bytes);

    let dir = std::env::temp_dir().join(format!("sdfmo-downstream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    let path = dir.join("part.smo");
    save_octree(&octree, &path)?;
    let file = load_octree(&path)?.file;
    let octree = file.finest();
    assert_eq!(octree.byte_size(), stats.bytes);

    let camera = &paper_views(128)[0];
    let lambert = RenderSettings::new(Mode::Lambert);
    let mut renderer = Renderer::new(Device::Cpu)?;
    let reference = renderer.prepare_mesh(&mesh)?.render(camera, &lambert)?;
    let image = renderer
        .prepare(&file, LevelRequest::Finest)?
        .render(camera, &lambert)?;
    save_png(&image, dir.join("part.png"))?;
    let quality = compare(&reference, &image)?;
    println!("PSNR {:.2} dB, FLIP {:.4}", quality.psnr, quality.flip);
    assert!(quality.psnr > 10.0);

    // On the surface (a vertex of the mesh) about zero; far away nothing is stored: NaN.
    let vertex: Vec3 = mesh.positions()[0];
    let on_surface = octree_distance(octree, vertex);
    let far = octree_distance(octree, vertex + Vec3::splat(1e4));
    println!("distance at a vertex {on_surface:.5}, far away {far}");
    assert!(on_surface.is_finite() && far.is_nan());

    std::fs::remove_dir_all(&dir).ok();
    Ok(())
}
