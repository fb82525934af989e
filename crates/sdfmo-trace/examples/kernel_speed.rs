//! Time the ray–voxel kernel `sdfmo_trace::intersect_voxel` on random voxels whose corners
//! change sign (so the exact min/max early-out never applies) and random rays through the unit
//! cube: nanoseconds per call, best of several runs, in thread CPU time on Linux
//! (`/proc/thread-self/schedstat`, not inflated by other load) and wall time.
//!
//! `cargo run --release -p sdfmo-trace --example kernel_speed`

use std::time::Instant;

#[path = "../benches/support/kernel_cases.rs"]
mod kernel_cases;
use kernel_cases::kernel_cases;

fn main() {
    const REPS: usize = 200;
    // The bench's cases: all volume voxels, then all surface voxels.
    for (label, share) in [("volume", 0.0), ("surface", 1.0)] {
        let cases = kernel_cases(4096, share);
        let mut best_wall = f64::INFINITY;
        let mut best_cpu = f64::INFINITY;
        let mut hits = 0;
        for _ in 0..7 {
            let cpu = thread_cpu_ns();
            let start = Instant::now();
            hits = 0;
            for _ in 0..REPS {
                hits += kernel_cases::hits(&cases) as usize;
            }
            let calls = (REPS * cases.len()) as f64;
            best_wall = best_wall.min(start.elapsed().as_secs_f64() * 1e9 / calls);
            if let (Some(a), Some(b)) = (cpu, thread_cpu_ns()) {
                best_cpu = best_cpu.min((b - a) as f64 / calls);
            }
        }
        println!(
            "{}: {:.1} ns per call CPU, {:.1} ns wall ({} of {} calls hit)",
            label,
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
