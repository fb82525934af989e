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

use sdfmo_benches::{build_at, env_depths, env_list, env_num, load_stl, pool, METHODS};
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use sdfmo_build::{build, BuildSettings, Method};

fn bench_build(c: &mut Criterion) {
    let pool = pool(env_num("SDFMO_BENCH_THREADS", 2));
    let depths = env_depths("SDFMO_BENCH_DEPTHS", "6,7,8,9,10");
    for name in env_list("SDFMO_BENCH_MESHES", "abc1,abc5") {
        let Some(mesh) = load_stl(&name) else {
            continue;
        };
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
            for (label, method) in METHODS {
                let (_, stats) = build_at(&mesh, depth, method, &pool);
                let settings = BuildSettings::new(depth, method);
                assert!(stats.leaves > 0, "{name} d{depth} {label}: no leaves");
                if method == Method::Svo {
                    assert_eq!(stats.voxels, stats.leaves);
                }
                eprintln!(
                    "{name} d{depth} {label}: {} leaves, {} voxels ({} surface), {} bytes",
                    stats.leaves, stats.voxels, stats.surface_voxels, stats.bytes
                );
                group.bench_function(format!("d{depth}/{label}"), |b| {
                    b.iter(|| {
                        pool.install(|| build(black_box(&mesh), black_box(&settings)))
                            .expect("build")
                    })
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, bench_build);
criterion_main!(benches);
