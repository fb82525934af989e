//! Rendering throughput: primary rays per second per mode and method, paper view 0 at 1024²,
//! octree depths 7–10 on abc1 and abc5, on 1 and 2 threads; the source mesh through our BVH
//! (`MeshScene`) alongside. The Embree peer casting the same rays is
//! `benches/peers/embree_primary.py`.
//!
//! Octrees are built once, outside the timing; every configuration is rendered once and its
//! image checked non-empty before it is measured.
//!
//! Knobs (environment): `SDFMO_TEST_DATA` (mesh directory), `SDFMO_BENCH_MESHES` (default
//! `abc1,abc5`), `SDFMO_BENCH_DEPTHS` (default `7,8,9,10`), `SDFMO_BENCH_SIZE` (default 1024).
//! Narrow a run with criterion's filter, e.g.
//! `cargo bench -p sdfmo-benches --bench render -- 'render/abc1/d9/multi/lambert'`.

use sdfmo_benches::{build_at, env_depths, env_list, env_num, load_stl, pool, METHODS};
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_render::{
    mesh_in_octree_frame, render, Camera, MeshScene, Mode, OctreeScene, RenderSettings, Traceable,
};

/// (label, threads, settings) of the measured render configurations.
fn configs() -> Vec<(String, usize, RenderSettings)> {
    let mut out = Vec::new();
    for threads in [1, 2] {
        for mode in Mode::ALL {
            out.push((
                format!("{mode}/t{threads}"),
                threads,
                RenderSettings::new(mode),
            ));
        }
        let shadows = RenderSettings::new(Mode::Lambert).with_shadows(true);
        out.push((format!("lambert+shadows/t{threads}"), threads, shadows));
    }
    out
}

fn bench_scene<T: Traceable>(
    c: &mut Criterion,
    group: &str,
    method: &str,
    scene: &T,
    cam: &Camera,
) {
    let mut g = c.benchmark_group(group);
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .throughput(Throughput::Elements(
            u64::from(cam.width) * u64::from(cam.height),
        ));
    for (label, threads, settings) in configs() {
        let pool = pool(threads);
        let probe = pool
            .install(|| render(scene, cam, &settings))
            .expect("render");
        assert!(
            probe.counters.hits > 0,
            "{group}/{method}/{label}: empty image"
        );
        eprintln!(
            "{group}/{method}/{label}: {} hits, single render {:.1} ms",
            probe.counters.hits, probe.render_ms
        );
        g.bench_function(format!("{method}/{label}"), |b| {
            b.iter(|| {
                pool.install(|| render(black_box(scene), black_box(cam), black_box(&settings)))
                    .expect("render")
            })
        });
    }
    g.finish();
}

fn render_benches(c: &mut Criterion) {
    let size: u32 = env_num("SDFMO_BENCH_SIZE", 1024);
    let depths = env_depths("SDFMO_BENCH_DEPTHS", "7,8,9,10");
    let cam = Camera::paper_view(0, size, size);
    for name in env_list("SDFMO_BENCH_MESHES", "abc1,abc5") {
        let Some(mesh) = load_stl(&name) else {
            continue;
        };
        let mut reference_done = false;
        for &depth in &depths {
            for (method_name, method) in METHODS {
                let (octree, stats) = build_at(&mesh, depth, method, &pool(2));
                eprintln!(
                    "{name} d{depth} {method_name}: {} leaves, {} voxels, {} bytes, built in {:.0} ms",
                    stats.leaves, stats.voxels, stats.bytes, stats.build_ms
                );
                if !reference_done {
                    let normalised = mesh_in_octree_frame(&mesh, octree.meta());
                    let dist = MeshDistance::new(&normalised, SignMode::Auto).expect("mesh BVH");
                    bench_scene(
                        c,
                        &format!("render/{name}/mesh"),
                        "bvh",
                        &MeshScene(&dist),
                        &cam,
                    );
                    reference_done = true;
                }
                bench_scene(
                    c,
                    &format!("render/{name}/d{depth}"),
                    method_name,
                    &OctreeScene(&octree),
                    &cam,
                );
            }
        }
    }
}

criterion_group!(benches, render_benches);
criterion_main!(benches);
