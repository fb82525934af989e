//! Single-thread CPU time per query stage (closest point, winding number at several β, whole
//! signed distance) on the benchmark's point sets, from `/proc/thread-self/schedstat` (Linux;
//! wall time elsewhere), so other processes on a shared machine distort it less.
//!
//! ```text
//! cargo run --release -p sdfmo-distance --example distance_profile -- MESH [N]
//! ```

use std::time::Instant;

use glam::Vec3;
use sdfmo_distance::sample::{near_surface_points, uniform_points};
use sdfmo_distance::{MeshDistance, SignMode};

/// CPU time of this thread in seconds (wall time when schedstat is unavailable).
fn cpu_now(start: Instant) -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map(|ns| ns * 1e-9)
        .unwrap_or_else(|| start.elapsed().as_secs_f64())
}

fn time_us(pts: &[Vec3], f: impl Fn(Vec3) -> f32) -> (f64, f32) {
    let start = Instant::now();
    let t0 = cpu_now(start);
    let mut acc = 0.0f32;
    for &p in pts {
        acc += f(p);
    }
    ((cpu_now(start) - t0) * 1e6 / pts.len() as f64, acc)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: distance_profile MESH [N]");
        std::process::exit(2);
    };
    let n: usize = args
        .get(2)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(10_000);
    let loaded = sdfmo_mesh::load_mesh(std::path::Path::new(path))?;
    let (mesh, _) = loaded.mesh.normalized(0.05);
    let md = MeshDistance::new(&mesh, SignMode::Auto)?;
    let sets = [
        ("near", near_surface_points(&mesh, n, 0.02, 1)),
        ("uniform", uniform_points(n, 2)),
    ];
    for (name, pts) in &sets {
        let (closest, _) = time_us(pts, |p| md.closest_point(p).distance);
        let (w2, _) = time_us(pts, |p| md.winding_number(p));
        let (w15, _) = time_us(pts, |p| md.winding_number_with_beta(p, 1.5));
        let (w12, _) = time_us(pts, |p| md.winding_number_with_beta(p, 1.2));
        let (sd, _) = time_us(pts, |p| md.signed_distance(p));
        // The batch call on one thread: Morton order (cache coherence) without parallelism.
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
        // Wall time (the pool's thread is not this one), next to the wall time of the loop.
        let start = Instant::now();
        let single: Vec<f32> = pts.iter().map(|&p| md.signed_distance(p)).collect();
        let loop_us = start.elapsed().as_secs_f64() * 1e6 / pts.len() as f64;
        let start = Instant::now();
        let batch = pool.install(|| md.signed_distances(pts));
        let batch_us = start.elapsed().as_secs_f64() * 1e6 / pts.len() as f64;
        assert_eq!(batch, single);
        assert_eq!(batch.len(), pts.len());
        let full: Vec<f32> = pts.iter().map(|&p| md.winding_number(p)).collect();
        let mut line = format!(
            "{name}: closest {closest:.2} µs, w(β=2) {w2:.2}, w(1.5) {w15:.2}, w(1.2) {w12:.2}, signed {sd:.2}, wall: loop {loop_us:.2} vs batch on 1 thread {batch_us:.2}"
        );
        for beta in [1.25f32, 1.5] {
            let coarse: Vec<f32> = pts
                .iter()
                .map(|&p| md.winding_number_with_beta(p, beta))
                .collect();
            let max_err = coarse
                .iter()
                .zip(&full)
                .map(|(c, f)| (c - f).abs())
                .fold(0.0f32, f32::max);
            let flips = coarse
                .iter()
                .zip(&full)
                .filter(|(c, f)| (**c > 0.5) != (**f > 0.5))
                .count();
            let undecided = coarse.iter().filter(|c| (*c - 0.5).abs() <= 0.3).count();
            line += &format!(
                "; β {beta}: max |Δw| {max_err:.3}, sign flips {flips}, |w−½| ≤ 0.3: {undecided}"
            );
        }
        println!("{line}");
    }
    Ok(())
}
