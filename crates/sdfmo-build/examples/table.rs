//! Prints the markdown table of `docs/results/build.md`: per mesh, depth and method the build
//! time (median wall time of `RUNS` builds, and the process CPU time per build), bytes, leaves,
//! voxels, surface voxels, cap hits, the voxels-per-leaf histogram and the growth factor of the
//! size per level.
//!
//! `cargo run --release -p sdfmo-build --example table -- DEPTH_FROM DEPTH_TO RUNS MESH...`

use std::path::Path;
use std::time::Instant;

use sdfmo_build::{build, BuildSettings, Method};

/// User + system CPU time of this process in seconds (Linux `/proc/self/stat`, clock ticks).
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = s.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let tick = 100.0;
    let ut: f64 = f.get(11).and_then(|v| v.parse().ok()).unwrap_or(0.0);
    let st: f64 = f.get(12).and_then(|v| v.parse().ok()).unwrap_or(0.0);
    (ut + st) / tick
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Two workers, as the tables were measured (the builder runs on the caller's pool).
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global()?;
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (from, to, runs): (u8, u8, usize) = (a[0].parse()?, a[1].parse()?, a[2].parse()?);
    println!("| mesh | depth | method | build ms (median wall) | CPU s per build | bytes | leaves | voxels | surface | cap hits | size growth | voxels per leaf (1, 2, 3, …) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for path in &a[3..] {
        let mesh = sdfmo_mesh::load_mesh(Path::new(path))?.mesh;
        let name = sdfmo_mesh::mesh_name(Path::new(path));
        for (label, method) in [
            ("svo", Method::Svo),
            ("multi", Method::Multi { max_voxels: 8 }),
        ] {
            let mut prev: Option<usize> = None;
            for depth in from..=to {
                let s = BuildSettings::new(depth, method);
                let mut walls = Vec::new();
                let c0 = cpu_seconds();
                let mut stats = None;
                for _ in 0..runs {
                    let t = Instant::now();
                    let (_, st) = build(&mesh, &s)?;
                    walls.push(t.elapsed().as_secs_f64() * 1e3);
                    stats = Some(st);
                }
                let cpu = (cpu_seconds() - c0) / runs as f64;
                walls.sort_by(|x, y| x.total_cmp(y));
                let st = stats.expect("at least one run");
                let growth = prev
                    .map(|p| format!("×{:.2}", st.bytes as f64 / p as f64))
                    .unwrap_or_else(|| "–".into());
                prev = Some(st.bytes);
                let hist: Vec<String> = st
                    .voxels_per_leaf
                    .iter()
                    .skip(1)
                    .map(|c| c.to_string())
                    .collect();
                let hist = hist
                    .iter()
                    .rev()
                    .skip_while(|c| *c == "0")
                    .collect::<Vec<_>>()
                    .into_iter()
                    .rev()
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(", ");
                println!(
                    "| {name} | {depth} | {label} | {:.0} | {:.2} | {} | {} | {} | {} | {} | {growth} | {hist} |",
                    walls[walls.len() / 2], cpu, st.bytes, st.leaves, st.voxels, st.surface_voxels, st.cap_hits
                );
            }
        }
    }
    Ok(())
}
