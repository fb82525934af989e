//! Builds an octree of a mesh, renders paper view 0 of it and of the source mesh (the
//! reference), saves both PNGs and prints render times and counters.
//!
//! ```text
//! cargo run --release -p sdfmo-render --example render_timing -- MESH [DEPTH] [svo|multi] [MODE] [THREADS] [REPEAT] [OUT_DIR]
//! ```
//! Without arguments it renders the procedural demo part at depth 7 into the system temp dir.

use std::path::PathBuf;

use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_mesh::{load_mesh, procedural};
use sdfmo_render::{
    mesh_in_octree_frame, render, save_png, Camera, MeshScene, Mode, OctreeScene, RenderSettings,
    Rendered, Spheres, Traceable,
};

/// CPU time (user + system) of the process so far, including threads that have exited, ns
/// (Linux: /proc/self/stat, clock ticks of 10 ms); unlike wall time it does not grow when other
/// processes compete for the cores.
fn cpu_ns() -> u64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = after.split_whitespace().collect();
    // The tail starts at field 3 (state): utime and stime, fields 14 and 15, are indices 11, 12.
    let tick = |i: usize| f.get(i).and_then(|x| x.parse::<u64>().ok()).unwrap_or(0);
    (tick(11) + tick(12)) * 10_000_000
}

/// The fastest of `repeat` renders (wall time) and the mean CPU time per render, ms.
fn best_of<T: Traceable>(
    scene: &T,
    camera: &Camera,
    s: &RenderSettings,
    repeat: usize,
) -> (Rendered, f64) {
    let mut best = render(scene, camera, s).expect("render");
    let c0 = cpu_ns();
    for _ in 0..repeat {
        let r = render(scene, camera, s).expect("render");
        if r.render_ms < best.render_ms {
            best = r;
        }
    }
    (best, (cpu_ns() - c0) as f64 / 1e6 / repeat as f64)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let (mesh, name) = match arg(0) {
        Some(p) => (
            load_mesh(p.as_ref())?.mesh,
            PathBuf::from(p)
                .file_stem()
                .unwrap()
                .to_string_lossy()
                .into_owned(),
        ),
        None => (procedural::demo_part(), "demo".to_string()),
    };
    let depth: u8 = arg(1).unwrap_or("7").parse()?;
    let method = match arg(2).unwrap_or("multi") {
        "svo" => Method::Svo,
        _ => Method::Multi { max_voxels: 8 },
    };
    let mode: Mode = arg(3).unwrap_or("lambert").parse()?;
    let threads: usize = arg(4).unwrap_or("2").parse()?;
    let repeat: usize = arg(5).unwrap_or("5").parse()?;
    let out = arg(6).map_or_else(std::env::temp_dir, PathBuf::from);

    let settings = BuildSettings {
        depth,
        method,
        ..BuildSettings::default()
    };
    let (octree, stats) = build(&mesh, &settings, None)?;
    println!(
        "{name} depth {depth} {method:?}: {} voxels, {} bytes, build {:.0} ms",
        stats.voxels, stats.bytes, stats.build_ms
    );
    let dist = MeshDistance::new(&mesh_in_octree_frame(&mesh, octree.meta()), SignMode::Auto)?;
    let camera = Camera::paper_view(0, 1024, 1024);
    let s = RenderSettings::new(mode).with_threads(threads);

    let (empty, cpu) = best_of(&Spheres::default(), &camera, &s, repeat);
    println!(
        "empty scene (renderer overhead) t{threads}: wall {:.1} ms, cpu {cpu:.1} ms",
        empty.render_ms
    );
    let (o, cpu) = best_of(&OctreeScene(&octree), &camera, &s, repeat);
    println!(
        "octree {mode} t{threads}: wall {:.1} ms ({:.2} Mrays/s), cpu {cpu:.1} ms, {:?}",
        o.render_ms,
        o.rays_per_second() / 1e6,
        o.counters
    );
    let (m, cpu) = best_of(&MeshScene(&dist), &camera, &s, repeat);
    println!(
        "mesh   {mode} t{threads}: wall {:.1} ms ({:.2} Mrays/s), cpu {cpu:.1} ms, {:?}",
        m.render_ms,
        m.rays_per_second() / 1e6,
        m.counters
    );
    save_png(&o, &out.join(format!("{name}_d{depth}_{mode}.png")))?;
    save_png(&m, &out.join(format!("{name}_mesh_{mode}.png")))?;
    println!("images in {}", out.display());
    Ok(())
}
