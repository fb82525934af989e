//! Builds a mesh as SVO and multi-octree at some depths, renders the paper's four views of each
//! and of the mesh reference (lambert), and prints mean PSNR and FLIP, sizes and the gain.
//!
//! `cargo run --release -p sdfmo-build --example psnr -- MESH SIZE DEPTH... [--save DIR] [--fit]`
//! (`--fit`: corners fitted to the surface, `BuildSettings::fit_corners`)

use std::path::Path;

use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_render::{OctreeScene, PaperProtocol};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .ok_or("usage: psnr MESH SIZE DEPTH... [--save DIR]")?;
    let size: u32 = args.get(1).ok_or("SIZE")?.parse()?;
    let save = args
        .iter()
        .position(|a| a == "--save")
        .map(|i| args[i + 1].clone());
    let fit = args.iter().any(|a| a == "--fit");
    let depths: Vec<u8> = args[2..]
        .iter()
        .take_while(|a| !a.starts_with("--"))
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let mesh = sdfmo_mesh::load_mesh(Path::new(path))?.mesh;
    let name = sdfmo_mesh::mesh_name(Path::new(path));
    let margin = BuildSettings::default().margin;
    let protocol = PaperProtocol::new(&mesh, margin, size)?;
    let refs = protocol.references();
    if let Some(dir) = &save {
        std::fs::create_dir_all(dir)?;
        for (i, r) in refs.iter().enumerate() {
            r.save(format!("{dir}/{name}_ref_{i}.png"))?;
        }
    }
    for depth in depths {
        let mut row = Vec::new();
        let mut svo_imgs: Vec<image::RgbImage> = Vec::new();
        for method in [Method::Svo, Method::Multi { max_voxels: 8 }] {
            let s = BuildSettings::new(depth, method).with_fit_corners(fit);
            let (oct, st) = build(&mesh, &s)?;
            let score = protocol.score(&OctreeScene(&oct))?;
            let mut imgs = Vec::new();
            for (i, view) in score.views.iter().enumerate() {
                if std::env::var("VERBOSE").is_ok() {
                    eprintln!("  view {i} {:?}: render {:.1} ms", method, view.render_ms);
                    eprintln!("  view {i} {:?}: {:.2} dB", method, view.psnr);
                }
                let img = &view.image;
                imgs.push(img.clone());
                if let Some(dir) = &save {
                    let m = if method == Method::Svo {
                        "svo"
                    } else {
                        "multi"
                    };
                    img.save(format!("{dir}/{name}_d{depth}_{m}_{i}.png"))?;
                    let mut d = img.clone();
                    for (o, r) in d.pixels_mut().zip(refs[i].pixels()) {
                        for c in 0..3 {
                            o[c] = (o[c] as i32 - r[c] as i32)
                                .unsigned_abs()
                                .saturating_mul(4)
                                .min(255) as u8;
                        }
                    }
                    d.save(format!("{dir}/{name}_d{depth}_{m}_{i}_diff.png"))?;
                    if let Some(prev) = svo_imgs.get(i) {
                        let mut d = img.clone();
                        let mut count = 0;
                        for (o, r) in d.pixels_mut().zip(prev.pixels()) {
                            let mut any = false;
                            for c in 0..3 {
                                let (a, b) = (o[c] as i32, r[c] as i32);
                                any |= a != b;
                                // red: multi brighter, green: SVO brighter
                                o[c] = 0;
                                if c == 0 && a > b {
                                    o[0] = 255;
                                }
                                if c == 1 && b > a {
                                    o[1] = 255;
                                }
                            }
                            count += any as usize;
                        }
                        eprintln!("  view {i}: {count} pixels differ between SVO and multi");
                        d.save(format!("{dir}/{name}_d{depth}_{i}_svo_vs_multi.png"))?;
                    }
                }
            }
            if method == Method::Svo {
                svo_imgs = imgs;
            }
            row.push((
                score.psnr(),
                score.flip(),
                st.bytes,
                st.voxels,
                st.surface_voxels,
                st.build_ms,
            ));
        }
        let (s, m) = (row[0], row[1]);
        println!(
            "{name} d{depth}: svo {:.2} dB flip {:.4} {:.3} MB | multi {:.2} dB flip {:.4} {:.3} MB ({} vox, {} surf) | gain {:+.2} dB, size x{:.2}",
            s.0, s.1, s.2 as f64 / 1e6, m.0, m.1, m.2 as f64 / 1e6, m.3, m.4, m.0 - s.0, m.2 as f64 / s.2 as f64
        );
    }
    Ok(())
}
