//! Trace the paper's four views (eye 3·(sin θ, 0, cos θ), θ = 2πk/4, fov 60°) of a
//! mesh's octree with
//! `sdfmo_trace::intersect`, one thread, and print the best time per frame of a few runs: wall
//! time, and on Linux the thread's CPU time from `/proc/thread-self/schedstat`, which other load
//! on the machine does not inflate.
//!
//! `cargo run --release -p sdfmo-trace --example paper_view -- MESH [DEPTH] [svo|multi] [SIZE] [RUNS]`
//! Without arguments it uses the procedural demo part at depth 7.

use std::time::Instant;

use glam::Vec3;
use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_mesh::{load_mesh, procedural};
use sdfmo_trace::{intersect, Ray};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mesh = match args.first() {
        Some(path) => load_mesh(path.as_ref())?.mesh,
        None => procedural::demo_part(),
    };
    let depth: u8 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(7);
    let method = match args.get(2).map(String::as_str) {
        Some("svo") => Method::Svo,
        _ => Method::Multi { max_voxels: 8 },
    };
    let size: u32 = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(1024);
    let runs: usize = args.get(4).map(|s| s.parse()).transpose()?.unwrap_or(5);

    let settings = BuildSettings::new(depth, method);
    let (octree, stats) = build(&mesh, &settings)?;
    println!(
        "{} leaves, {} voxels, built in {:.0} ms",
        stats.leaves, stats.voxels, stats.build_ms
    );

    for view in 0..4 {
        let theta = std::f32::consts::FRAC_PI_2 * view as f32;
        let eye = 3.0 * Vec3::new(theta.sin(), 0.0, theta.cos());
        let fwd = (-eye).normalize();
        let right = fwd.cross(Vec3::Y).normalize();
        let up = right.cross(fwd);
        let tan_half = 30f32.to_radians().tan();
        let rays: Vec<Ray> = (0..size * size)
            .map(|i| {
                let (px, py) = ((i % size) as f32, (i / size) as f32);
                let u = (2.0 * (px + 0.5) / size as f32 - 1.0) * tan_half;
                let v = (1.0 - 2.0 * (py + 0.5) / size as f32) * tan_half;
                Ray {
                    origin: eye,
                    dir: (fwd + u * right + v * up).normalize(),
                }
            })
            .collect();

        let mut best = f64::INFINITY;
        let mut best_cpu = f64::INFINITY;
        let mut hits = 0;
        for _ in 0..runs {
            let cpu = thread_cpu_ns();
            let start = Instant::now();
            hits = rays
                .iter()
                .filter(|r| intersect(&octree, r, 0.0, f32::INFINITY).is_some())
                .count();
            best = best.min(start.elapsed().as_secs_f64() * 1e3);
            if let (Some(a), Some(b)) = (cpu, thread_cpu_ns()) {
                best_cpu = best_cpu.min((b - a) as f64 * 1e-6);
            }
        }
        let per_ray = |ms: f64| ms * 1e6 / rays.len() as f64;
        println!(
            "view {view}: {size}x{size}, {hits} hits: best {best:.1} ms wall ({:.1} ns per ray), {best_cpu:.1} ms CPU ({:.1} ns per ray), one thread",
            per_ray(best),
            per_ray(best_cpu)
        );
    }
    Ok(())
}

/// Nanoseconds this thread has run on a CPU (Linux), `None` elsewhere.
fn thread_cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}
