//! Build time of the octree builder: depths 6–10, SVO and multi-octree, on abc1 (79k
//! triangles, the 2 s target at depth 9) and abc5 (5k triangles, ten parts side by side).
//!
//! Every configuration is built once before it is measured and its statistics checked (leaves
//! present, the SVO one voxel per leaf), so a broken build cannot be timed.
//!
//! Knobs (environment): `SDFMO_TEST_DATA` (mesh directory), `SDFMO_BENCH_MESHES` (default
//! `abc1,abc5`), `SDFMO_BENCH_DEPTHS` (default `6,7,8,9,10`), `SDFMO_BENCH_THREADS` (default
//! 2). Narrow a run with criterion's filter, e.g.
//! `cargo bench -p sdfmo-benches --bench build -- 'build/abc1/d9/multi'`.

use sdfmo_benches::{data_dir, env_list};
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_mesh::{load_mesh, TriMesh};

fn load(name: &str) -> Option<TriMesh> {
    let path = data_dir().join(format!("{name}.stl"));
    match load_mesh(&path) {
        Ok(m) => Some(m.mesh),
        Err(e) => {
            eprintln!("note: skipping {name}: {e}");
            None
        }
    }
}

fn bench_build(c: &mut Criterion) {
    let threads: usize = std::env::var("SDFMO_BENCH_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2);
    let depths: Vec<u8> = env_list("SDFMO_BENCH_DEPTHS", "6,7,8,9,10")
        .iter()
        .filter_map(|d| d.parse().ok())
        .collect();
    for name in env_list("SDFMO_BENCH_MESHES", "abc1,abc5") {
        let Some(mesh) = load(&name) else { continue };
        let mut group = c.benchmark_group(format!("build/{name}"));
        for &depth in &depths {
            // Deep builds take seconds: the fewest samples criterion allows, a budget to match.
            group.sample_size(10);
            group.measurement_time(Duration::from_secs(if depth >= 10 {
                40
            } else if depth == 9 {
                15
            } else {
                5
            }));
            group.warm_up_time(Duration::from_millis(500));
            for (label, method) in [
                ("svo", Method::Svo),
                ("multi", Method::Multi { max_voxels: 8 }),
            ] {
                let settings = BuildSettings {
                    depth,
                    method,
                    threads: Some(threads),
                    ..Default::default()
                };
                let (_, stats) = build(&mesh, &settings, None).expect("build");
                assert!(stats.leaves > 0, "{name} d{depth} {label}: no leaves");
                if method == Method::Svo {
                    assert_eq!(stats.voxels, stats.leaves);
                }
                eprintln!(
                    "{name} d{depth} {label}: {} leaves, {} voxels ({} surface), {} bytes",
                    stats.leaves, stats.voxels, stats.surface_voxels, stats.bytes
                );
                group.bench_function(format!("d{depth}/{label}"), |b| {
                    b.iter(|| build(black_box(&mesh), black_box(&settings), None).expect("build"))
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, bench_build);
criterion_main!(benches);
