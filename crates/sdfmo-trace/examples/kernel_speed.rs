//! Time the ray–voxel kernel `sdfmo_trace::intersect_voxel` on random voxels whose corners
//! change sign (so the exact min/max early-out never applies) and random rays through the unit
//! cube: nanoseconds per call, best of several runs, in thread CPU time on Linux
//! (`/proc/thread-self/schedstat`, not inflated by other load) and wall time.
//!
//! `cargo run --release -p sdfmo-trace --example kernel_speed`

use std::hint::black_box;
use std::time::Instant;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sdfmo_trace::{intersect_voxel, unit_cube_span};

fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut cases = Vec::new();
    while cases.len() < 4096 {
        let corners: [f32; 8] = core::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let (lo, hi) = corners
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &c| (a.min(c), b.max(c)));
        if lo > 0.0 || hi < 0.0 {
            continue;
        }
        let dir = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize();
        let target = Vec3::new(
            rng.random_range(0.0..1.0),
            rng.random_range(0.0..1.0),
            rng.random_range(0.0..1.0),
        );
        let origin = target - dir * 3.0;
        if let Some((t0, t1)) = unit_cube_span(origin, dir) {
            cases.push((corners, origin, dir, t0, t1));
        }
    }
    const REPS: usize = 200;
    for surface in [false, true] {
        let mut best_wall = f64::INFINITY;
        let mut best_cpu = f64::INFINITY;
        let mut hits = 0;
        for _ in 0..7 {
            let cpu = thread_cpu_ns();
            let start = Instant::now();
            hits = 0;
            for _ in 0..REPS {
                for (c, o, d, t0, t1) in &cases {
                    let r = intersect_voxel(
                        black_box(c),
                        black_box(*o),
                        black_box(*d),
                        *t0,
                        *t1,
                        surface,
                    );
                    hits += usize::from(r.is_some());
                }
            }
            let calls = (REPS * cases.len()) as f64;
            best_wall = best_wall.min(start.elapsed().as_secs_f64() * 1e9 / calls);
            if let (Some(a), Some(b)) = (cpu, thread_cpu_ns()) {
                best_cpu = best_cpu.min((b - a) as f64 / calls);
            }
        }
        println!(
            "{}: {:.1} ns per call CPU, {:.1} ns wall ({} of {} calls hit)",
            if surface { "surface" } else { "volume" },
            best_cpu,
            best_wall,
            hits,
            REPS * cases.len()
        );
    }
}

/// Nanoseconds this thread has run on a CPU (Linux), `None` elsewhere.
fn thread_cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}
