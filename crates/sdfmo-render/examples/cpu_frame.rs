//! Frame times of saved octrees on the CPU, for A/B runs of two builds on a shared machine:
//! paper view 0 (or `VIEW`), 1024² (or `SIZE`), lambert, on pools of 1 and 2 threads (or
//! `THREADS`), the configurations interleaved round by round, and per configuration the median
//! wall time and the median **CPU time** per frame (the sum over the process's threads of
//! `/proc/self/task/*/schedstat`, ns resolution; other processes competing for the cores do not
//! inflate it), and the median CPU time of the busiest thread (what the frame takes on free
//! cores, one thread each: CPU at 1 thread over this at 2 threads is the two-core speed-up
//! that load balance allows, measurable on a shared machine).
//!
//! ```text
//! cargo run --release -p sdfmo-render --example cpu_frame -- [--threads 1,2] [--repeat 9] \
//!     [--size 1024] [--view 0] [--png DIR] A.smo [B.smo …]
//! ```
//! `--png DIR` saves each octree's first render (`DIR/<stem>.png`) for byte comparisons. A 3.0
//! file is traced as it is (`BrickOctree`), any other as its 1.x octree. `--write-v3 DIR`
//! renders nothing: it writes each 1.x file as 3.1 (`DIR/<stem>.v3.smo`, `BrickOctree::encode`;
//! with `--v3-minor 0` as 3.0, `BrickOctree::encode_minor`).

use std::path::PathBuf;
use std::time::Instant;

use sdfmo_format::{is_v3, BrickOctree, PackedOctree};
use sdfmo_render::{render, save_png, Camera, Mode, OctreeScene, RenderSettings, Traceable};

/// CPU time of each of the process's live threads, ns, by thread id (Linux; empty elsewhere).
fn thread_cpu_ns() -> Vec<(String, u64)> {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return Vec::new();
    };
    dir.filter_map(|e| e.ok())
        .filter_map(|e| {
            let s = std::fs::read_to_string(e.path().join("schedstat")).ok()?;
            let ns = s.split_whitespace().next()?.parse::<u64>().ok()?;
            Some((e.file_name().to_string_lossy().into_owned(), ns))
        })
        .collect()
}

/// Total and largest per-thread CPU time between two [`thread_cpu_ns`] samples, ns. The largest
/// is what the frame would take on free cores (one thread per core), whatever else shares the
/// machine: with two threads, `total / largest` is the speed-up two free cores would give.
fn cpu_between(before: &[(String, u64)], after: &[(String, u64)]) -> (u64, u64) {
    let mut total = 0;
    let mut largest = 0;
    for (tid, ns) in after {
        let start = before.iter().find(|(t, _)| t == tid).map_or(0, |(_, n)| *n);
        let d = ns.saturating_sub(start);
        total += d;
        largest = largest.max(d);
    }
    (total, largest)
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
    let mut write_v3: Option<PathBuf> = None;
    let mut v3_minor: Option<u16> = None;
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
            "--write-v3" => write_v3 = Some(PathBuf::from(value()?)),
            "--v3-minor" => v3_minor = Some(value()?.parse()?),
            _ => files.push(PathBuf::from(a)),
        }
    }
    if let Some(dir) = write_v3 {
        for file in &files {
            let stem = file
                .file_stem()
                .map_or("octree".into(), |s| s.to_string_lossy());
            let octree = PackedOctree::load(file)?;
            let v3 = match v3_minor {
                Some(m) => BrickOctree::encode_minor(&octree, m)?,
                None => BrickOctree::encode(&octree)?,
            };
            std::fs::write(dir.join(format!("{stem}.v3.smo")), v3.as_bytes())?;
        }
        return Ok(());
    }
    let pools: Vec<rayon::ThreadPool> = threads
        .iter()
        .map(|&n| rayon::ThreadPoolBuilder::new().num_threads(n).build())
        .collect::<Result<_, _>>()?;
    let camera = Camera::paper_view(view, size, size);
    let settings = RenderSettings::new(Mode::Lambert);
    println!(
        "| octree | threads | hits | median wall ms | median CPU ms / frame | median busiest-thread CPU ms | runs |"
    );
    println!("|---|---|---|---|---|---|---|");
    let run = Run {
        pools: &pools,
        threads: &threads,
        camera: &camera,
        settings: &settings,
        repeat,
        png: png.as_deref(),
    };
    for file in &files {
        if is_v3(&std::fs::read(file)?) {
            let octree = BrickOctree::new(std::fs::read(file)?)?;
            run.frames(&OctreeScene(&octree), file)?;
        } else {
            let octree = PackedOctree::load(file)?;
            run.frames(&OctreeScene(&octree), file)?;
        }
    }
    Ok(())
}

/// What every file is rendered with.
struct Run<'a> {
    pools: &'a [rayon::ThreadPool],
    threads: &'a [usize],
    camera: &'a Camera,
    settings: &'a RenderSettings,
    repeat: usize,
    png: Option<&'a std::path::Path>,
}

impl Run<'_> {
    /// The first render (saved with `--png`), then `repeat` rounds over the pools, one row per
    /// pool.
    fn frames<S: Traceable>(
        &self,
        scene: &S,
        file: &std::path::Path,
    ) -> Result<(), Box<dyn std::error::Error>> {
        let Run {
            pools,
            threads,
            camera,
            settings,
            repeat,
            png,
        } = *self;
        let first = pools[0].install(|| render(scene, camera, settings))?;
        if let Some(dir) = &png {
            let stem = file
                .file_stem()
                .map_or("octree".into(), |s| s.to_string_lossy());
            save_png(&first, dir.join(format!("{stem}.png")))?;
        }
        let mut wall = vec![Vec::new(); pools.len()];
        let mut cpu = vec![Vec::new(); pools.len()];
        let mut busiest = vec![Vec::new(); pools.len()];
        for _ in 0..repeat {
            for (k, pool) in pools.iter().enumerate() {
                let (c0, t0) = (thread_cpu_ns(), Instant::now());
                let r = pool.install(|| render(scene, camera, settings))?;
                wall[k].push(t0.elapsed().as_secs_f64() * 1e3);
                let (total, largest) = cpu_between(&c0, &thread_cpu_ns());
                cpu[k].push(total as f64 * 1e-6);
                busiest[k].push(largest as f64 * 1e-6);
                assert_eq!(r.counters.hits, first.counters.hits);
            }
        }
        for (k, n) in threads.iter().enumerate() {
            println!(
                "| {} | {n} | {} | {:.1} | {:.1} | {:.1} | {repeat} |",
                file.display(),
                first.counters.hits,
                median(&mut wall[k]),
                median(&mut cpu[k]),
                median(&mut busiest[k]),
            );
        }
        Ok(())
    }
}
