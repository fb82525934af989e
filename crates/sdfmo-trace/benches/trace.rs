//! Micro-benchmarks of the tracer: the ray–voxel kernel (ns per call) and octree traversal
//! (primary rays per second, one thread, no shading) on the paper's view 0 at 1024².
//!
//! `cargo bench -p sdfmo-trace --bench trace` (filter e.g. `-- kernel`). The traversal group
//! builds abc1 from `SDFMO_TEST_DATA` (default `../shared/data`) at `SDFMO_BENCH_DEPTH`
//! (default 9), SVO and multi-octree; without the data it uses the procedural demo part.

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_format::PackedOctree;
use sdfmo_mesh::{load_mesh, procedural, TriMesh};
use sdfmo_trace::{intersect, Ray};

#[path = "support/kernel_cases.rs"]
mod kernel_cases;
use kernel_cases::kernel_cases;

fn bench_kernel(c: &mut Criterion) {
    let mut g = c.benchmark_group("kernel");
    g.measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
    for (label, share) in [("volume", 0.0), ("surface", 1.0)] {
        let cases = kernel_cases(4096, share);
        let hits = kernel_cases::hits(&cases);
        assert!(hits > 1000, "{label}: only {hits} hits");
        eprintln!("kernel/{label}: {hits} of {} rays hit", cases.len());
        g.throughput(Throughput::Elements(cases.len() as u64));
        g.bench_function(label, |b| b.iter(|| kernel_cases::hits(&cases)));
    }
    g.finish();
}

fn data_dir() -> PathBuf {
    sdfmo_testdata::test_data_dir(env!("CARGO_MANIFEST_DIR").as_ref())
}

fn bench_mesh() -> (String, TriMesh) {
    let path = data_dir().join("abc1.stl");
    match load_mesh(&path) {
        Ok(loaded) => ("abc1".into(), loaded.mesh),
        Err(e) => {
            eprintln!("{}: {e}; using the procedural demo part", path.display());
            ("demo".into(), procedural::demo_part())
        }
    }
}

/// Paper view 0: eye (0, 0, 3), looking at the origin, fov 60°, square image.
fn paper_view_rays(size: u32) -> Vec<Ray> {
    let eye = Vec3::new(0.0, 0.0, 3.0);
    let fwd = (-eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    let tan_half = 30f32.to_radians().tan();
    (0..size * size)
        .map(|i| {
            let (px, py) = (i % size, i / size);
            let u = (2.0 * (px as f32 + 0.5) / size as f32 - 1.0) * tan_half;
            let v = (1.0 - 2.0 * (py as f32 + 0.5) / size as f32) * tan_half;
            Ray {
                origin: eye,
                dir: (fwd + u * right + v * up).normalize(),
            }
        })
        .collect()
}

fn trace_all(octree: &PackedOctree, rays: &[Ray]) -> usize {
    rays.iter()
        .filter(|r| intersect(octree, r, 0.0, f32::INFINITY).is_some())
        .count()
}

fn bench_traversal(c: &mut Criterion) {
    let depth: u8 = std::env::var("SDFMO_BENCH_DEPTH")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(9);
    let (name, mesh) = bench_mesh();
    let rays = paper_view_rays(1024);
    let mut g = c.benchmark_group(format!("traversal/{name}/d{depth}"));
    g.sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    g.throughput(Throughput::Elements(rays.len() as u64));
    for (label, method) in [
        ("svo", Method::Svo),
        ("multi", Method::Multi { max_voxels: 8 }),
    ] {
        let settings = BuildSettings::new(depth, method);
        let (octree, stats) = build(&mesh, &settings).expect("build");
        let hits = trace_all(&octree, &rays);
        assert!(hits > 10_000, "{label}: only {hits} hits");
        eprintln!(
            "traversal/{name}/d{depth}/{label}: {} leaves, {} voxels, {hits} of {} rays hit",
            stats.leaves,
            stats.voxels,
            rays.len()
        );
        g.bench_function(label, |b| {
            b.iter(|| trace_all(black_box(&octree), black_box(&rays)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench_kernel, bench_traversal);
criterion_main!(benches);
