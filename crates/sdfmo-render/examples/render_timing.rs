//! Builds an octree of a mesh, renders paper view 0 of it and of the source mesh (the
//! reference), saves both PNGs and prints render times and counters.
//!
//! ```text
//! cargo run --release -p sdfmo-render --example render_timing -- MESH [DEPTHS] [METHODS] [MODES] [THREADS] [REPEAT] [OUT_DIR]
//! ```
//! Lists are comma-separated (`7,8,9,10`, `svo,multi`, `mask,lambert`, `1,2`). Prints a
//! markdown table: best wall time, CPU time per frame (robust when other processes share the
//! cores), rays per second per core from the CPU time. Without arguments it renders the
//! procedural demo part at depth 7 into the system temp dir.

use std::path::PathBuf;

use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_mesh::{load_mesh, mesh_name, procedural};
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
/// The fastest of `repeat` renders on a pool of `threads` workers, and the process's CPU ms
/// per render.
fn best_of<T: Traceable>(
    scene: &T,
    camera: &Camera,
    s: &RenderSettings,
    threads: usize,
    repeat: usize,
) -> (Rendered, f64) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a pool");
    pool.install(|| {
        let mut best = render(scene, camera, s).expect("render");
        let c0 = cpu_ns();
        for _ in 0..repeat {
            let r = render(scene, camera, s).expect("render");
            if r.render_ms < best.render_ms {
                best = r;
            }
        }
        (best, (cpu_ns() - c0) as f64 / 1e6 / repeat as f64)
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let (mesh, name) = match arg(0) {
        Some(p) => (load_mesh(p.as_ref())?.mesh, mesh_name(p.as_ref())),
        None => (procedural::demo_part(), "demo".to_string()),
    };
    let depths: Vec<u8> = arg(1)
        .unwrap_or("7")
        .split(',')
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    let methods: Vec<(&str, Method)> = arg(2)
        .unwrap_or("multi")
        .split(',')
        .map(|m| match m {
            "svo" => ("svo", Method::Svo),
            _ => ("multi", Method::Multi { max_voxels: 8 }),
        })
        .collect();
    let modes: Vec<Mode> = arg(3)
        .unwrap_or("lambert")
        .split(',')
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    let threads: Vec<usize> = arg(4)
        .unwrap_or("2")
        .split(',')
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    let repeat: usize = arg(5).unwrap_or("5").parse()?;
    let out = arg(6).map_or_else(std::env::temp_dir, PathBuf::from);
    let camera = Camera::paper_view(0, 1024, 1024);

    println!("| scene | mode | threads | best wall ms | CPU ms / frame | Mrays/s per core (CPU) | hits |");
    println!("|---|---|---|---|---|---|---|");
    let row = |label: &str, mode: Mode, t: usize, r: &Rendered, cpu: f64| {
        println!(
            "| {label} | {mode} | {t} | {:.1} | {cpu:.0} | {:.1} | {} |",
            r.render_ms,
            r.counters.rays as f64 / (cpu * 1e-3) / 1e6,
            r.counters.hits
        );
    };
    for &t in &threads {
        let s = RenderSettings::new(Mode::Mask);
        let (r, cpu) = best_of(&Spheres::default(), &camera, &s, t, repeat);
        row("empty (renderer overhead)", Mode::Mask, t, &r, cpu);
    }
    let mut reference_done = false;
    for &depth in &depths {
        for &(method_name, method) in &methods {
            let settings = BuildSettings::new(depth, method);
            let (octree, stats) = build(&mesh, &settings)?;
            eprintln!(
                "{name} depth {depth} {method_name}: {} voxels, {} bytes, build {:.0} ms",
                stats.voxels, stats.bytes, stats.build_ms
            );
            if !reference_done {
                let dist =
                    MeshDistance::new(&mesh_in_octree_frame(&mesh, octree.meta()), SignMode::Auto)?;
                for &mode in &modes {
                    for &t in &threads {
                        let s = RenderSettings::new(mode);
                        let (m, cpu) = best_of(&MeshScene(&dist), &camera, &s, t, repeat);
                        row(&format!("{name} mesh (BVH)"), mode, t, &m, cpu);
                        save_png(&m, out.join(format!("{name}_mesh_{mode}.png")))?;
                    }
                }
                reference_done = true;
            }
            for &mode in &modes {
                for &t in &threads {
                    let s = RenderSettings::new(mode);
                    let (o, cpu) = best_of(&OctreeScene(&octree), &camera, &s, t, repeat);
                    row(&format!("{name} d{depth} {method_name}"), mode, t, &o, cpu);
                    save_png(
                        &o,
                        out.join(format!("{name}_d{depth}_{method_name}_{mode}.png")),
                    )?;
                }
            }
        }
    }
    eprintln!("images in {}", out.display());
    Ok(())
}
