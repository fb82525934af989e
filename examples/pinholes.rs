//! Rays slipping through an octree where the mesh is solid: over random views of a closed mesh,
//! the pixels the mesh covers and the octree does not, inside the mesh's silhouette eroded by one
//! pixel (a pinhole, a slot that opens, a hole that grows), per octree file.
//!
//! ```sh
//! cargo run --release --example pinholes -- MESH VIEWS SIZE OCTREE.smo [OCTREE.smo ...]
//! ```
//!
//! Views: eye at distance 2.5–4 from the origin in a uniformly random direction, target within
//! 0.3 of the origin, vertical fov 40–70°, from a fixed seed (the same views for every file and
//! every run). Prints one line per octree: pinholes, the views that have any, and all missing
//! pixels (the silhouette's edge included).

use glam::Vec3;
use sdf_multioctree::render::Camera;
use sdf_multioctree::{load_mesh, load_octree, Device, LevelRequest, Mode, RenderSettings};
use sdf_multioctree::{Rendered, Renderer};

/// xorshift64*: a fixed, dependency-free sequence of uniform numbers in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn direction(&mut self) -> Vec3 {
        let z = 2.0 * self.next() - 1.0;
        let phi = std::f32::consts::TAU * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), z, r * phi.sin())
    }
}

fn hits(r: &Rendered) -> Vec<bool> {
    r.rgb
        .chunks_exact(3)
        .map(|p| p.iter().any(|&c| c > 0))
        .collect()
}

/// The mask eroded by one pixel (4-neighbourhood; the border is cleared).
fn eroded(m: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut out = vec![false; m.len()];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let i = y * w + x;
            out[i] = m[i] && m[i - 1] && m[i + 1] && m[i - w] && m[i + w];
        }
    }
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 {
        return Err("usage: pinholes MESH VIEWS SIZE OCTREE.smo [OCTREE.smo ...]".into());
    }
    let mesh = load_mesh(&args[0])?;
    let views: usize = args[1].parse().map_err(|_| "VIEWS must be a number")?;
    let size: u32 = args[2].parse().map_err(|_| "SIZE must be a number")?;
    let octrees = args[3..]
        .iter()
        .map(|p| load_octree(p).map(|o| (p.clone(), o)))
        .collect::<Result<Vec<_>, _>>()?;
    let mask = RenderSettings::new(Mode::Mask);
    // The mesh's ray queries are prepared once, on a renderer of their own.
    let mut mesh_renderer = Renderer::new(Device::Cpu)?;
    let mut mesh_scene = mesh_renderer.prepare_mesh(&mesh)?;
    let mut renderer = Renderer::new(Device::Cpu)?;
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    // Per octree: pinholes, views with any, all missing pixels.
    let mut totals = vec![(0usize, 0usize, 0usize); octrees.len()];
    let mut silhouette = 0usize;
    for _ in 0..views {
        let eye = rng.direction() * (2.5 + 1.5 * rng.next());
        let target = rng.direction() * (0.3 * rng.next());
        let fov = 40.0 + 30.0 * rng.next();
        let cam = Camera::new(eye, target, fov, size, size);
        let reference = hits(&mesh_scene.render(&cam, &mask)?);
        let inner = eroded(&reference, size as usize, size as usize);
        silhouette += inner.iter().filter(|&&b| b).count();
        for ((_, octree), total) in octrees.iter().zip(&mut totals) {
            let test = hits(
                &renderer
                    .prepare(&octree.file, LevelRequest::Finest)?
                    .render(&cam, &mask)?,
            );
            let holes = inner.iter().zip(&test).filter(|(&r, &t)| r && !t).count();
            let missing = reference
                .iter()
                .zip(&test)
                .filter(|(&r, &t)| r && !t)
                .count();
            total.0 += holes;
            total.1 += usize::from(holes > 0);
            total.2 += missing;
        }
    }
    println!("{views} views of {size}², {silhouette} eroded silhouette pixels in all");
    for ((path, _), (holes, with, missing)) in octrees.iter().zip(&totals) {
        println!("{path}: {holes} pinholes in {with} views; {missing} pixels missing in all");
    }
    Ok(())
}
