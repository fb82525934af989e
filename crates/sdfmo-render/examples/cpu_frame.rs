//! Frame times of saved octrees on the CPU, for A/B runs of two builds on a shared machine:
//! paper view 0 (or `VIEW`), 1024² (or `SIZE`), lambert, on pools of 1 and 2 threads (or
//! `THREADS`), the configurations interleaved round by round, and per configuration the median
//! wall time and the median **CPU time** per frame (the sum over the process's threads of
//! `/proc/self/task/*/schedstat`, ns resolution; other processes competing for the cores do not
//! inflate it).
//!
//! ```text
//! cargo run --release -p sdfmo-render --example cpu_frame -- [--threads 1,2] [--repeat 9] \
//!     [--size 1024] [--view 0] [--png DIR] A.smo [B.smo …]
//! ```
//! `--png DIR` saves each octree's first render (`DIR/<stem>.png`) for byte comparisons.

use std::path::PathBuf;
use std::time::Instant;

use sdfmo_format::PackedOctree;
use sdfmo_render::{
    render_with_plan, save_png, Camera, Mode, OctreeScene, RenderPlan, RenderSettings,
};

/// CPU time of all the process's live threads, ns (Linux; 0 elsewhere).
fn process_cpu_ns() -> u64 {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return 0;
    };
    dir.filter_map(|e| e.ok())
        .filter_map(|e| std::fs::read_to_string(e.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut threads = vec![1usize, 2];
    let mut repeat = 9usize;
    let mut size = 1024u32;
    let mut view = 0u32;
    let mut png: Option<PathBuf> = None;
    let mut files = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--threads" => {
                threads = value()?
                    .split(',')
                    .map(str::parse)
                    .collect::<Result<_, _>>()?
            }
            "--repeat" => repeat = value()?.parse()?,
            "--size" => size = value()?.parse()?,
            "--view" => view = value()?.parse()?,
            "--png" => png = Some(PathBuf::from(value()?)),
            _ => files.push(PathBuf::from(a)),
        }
    }
    let pools: Vec<rayon::ThreadPool> = threads
        .iter()
        .map(|&n| rayon::ThreadPoolBuilder::new().num_threads(n).build())
        .collect::<Result<_, _>>()?;
    let camera = Camera::paper_view(view, size, size);
    let plan = RenderPlan::new(&RenderSettings::new(Mode::Lambert))?;
    println!("| octree | threads | hits | median wall ms | median CPU ms / frame | runs |");
    println!("|---|---|---|---|---|---|");
    for file in &files {
        let octree = PackedOctree::load(file)?;
        let scene = OctreeScene(&octree);
        let first = pools[0].install(|| render_with_plan(&scene, &camera, &plan))?;
        if let Some(dir) = &png {
            let stem = file
                .file_stem()
                .map_or("octree".into(), |s| s.to_string_lossy());
            save_png(&first, dir.join(format!("{stem}.png")))?;
        }
        let mut wall = vec![Vec::new(); pools.len()];
        let mut cpu = vec![Vec::new(); pools.len()];
        for _ in 0..repeat {
            for (k, pool) in pools.iter().enumerate() {
                let (c0, t0) = (process_cpu_ns(), Instant::now());
                let r = pool.install(|| render_with_plan(&scene, &camera, &plan))?;
                wall[k].push(t0.elapsed().as_secs_f64() * 1e3);
                cpu[k].push((process_cpu_ns() - c0) as f64 * 1e-6);
                assert_eq!(r.counters.hits, first.counters.hits);
            }
        }
        for (k, n) in threads.iter().enumerate() {
            println!(
                "| {} | {n} | {} | {:.1} | {:.1} | {repeat} |",
                file.display(),
                first.counters.hits,
                median(&mut wall[k]),
                median(&mut cpu[k]),
            );
        }
    }
    Ok(())
}
