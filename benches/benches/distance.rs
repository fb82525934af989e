//! Signed-distance throughput (points per second) of `sdfmo-distance` on abc1 (79k triangles,
//! non-manifold: winding-number sign) and the Stanford bunny (69k triangles, open: winding-number
//! sign), for points near the surface and uniform in the root cube, one query at a time
//! (`single`, one thread) and as a batch (`batch`, `signed_distances`, rayon on all cores).
//!
//! The points come from `sdfmo_distance::sample` (seeded SplitMix64, built outside the timed
//! loop): the same points `crates/sdfmo-distance/examples/distance_peer_data.rs` writes for the
//! libigl comparison (`benches/peers/libigl_distance.py`). Before timing, every configuration is
//! checked: batch and single agree bit for bit, and a sample of distances matches a brute-force
//! scan over all triangles.
//!
//! Knobs (environment): `SDFMO_TEST_DATA` (mesh directory), `SDFMO_BENCH_POINTS` (default
//! 10000). Narrow a run with criterion's filter, e.g.
//! `cargo bench -p sdfmo-benches --bench distance -- 'distance/abc1'`.

use sdfmo_benches::data_dir;
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use sdfmo_distance::sample::{near_surface_points, uniform_points};
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_mesh::{load_mesh, TriMesh};

fn load(file: &str) -> Option<TriMesh> {
    let path = data_dir().join(file);
    match load_mesh(&path) {
        Ok(m) => Some(m.mesh.normalized(0.05).0),
        Err(e) => {
            eprintln!("note: skipping {file}: {e}");
            None
        }
    }
}

/// Checks a configuration before it is timed.
fn check(md: &MeshDistance, points: &[Vec3]) {
    let batch = md.signed_distances(points);
    assert_eq!(batch.len(), points.len());
    let all: Vec<u32> = (0..md.mesh().triangle_count() as u32).collect();
    for (i, &p) in points.iter().enumerate() {
        let single = md.signed_distance(p);
        assert!(
            single.to_bits() == batch[i].to_bits(),
            "batch and single agree"
        );
        assert!(single.is_finite());
        if i % 97 == 0 {
            let brute = md.closest_point_in_subset(&all, p).distance;
            assert!(
                (single.abs() - brute).abs() <= 1e-6,
                "p {p:?}: {single} vs brute force {brute}"
            );
        }
    }
}

fn bench_distance(c: &mut Criterion) {
    let n: usize = std::env::var("SDFMO_BENCH_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000);
    for (name, file) in [("abc1", "abc1.stl"), ("bunny", "stanford-bunny.obj")] {
        let Some(mesh) = load(file) else { continue };
        let md = MeshDistance::new(&mesh, SignMode::Auto).expect("distance structure");
        let mut group = c.benchmark_group(format!("distance/{name}"));
        group
            .sample_size(10)
            .measurement_time(Duration::from_secs(4))
            .warm_up_time(Duration::from_secs(1));
        group.throughput(Throughput::Elements(1));
        group.bench_function("build", |b| {
            b.iter(|| MeshDistance::new(black_box(&mesh), SignMode::Auto).expect("build"))
        });
        // The same seeds as the peer-data example.
        let sets = [
            ("near", near_surface_points(&mesh, n, 0.02, 1)),
            ("uniform", uniform_points(n, 2)),
        ];
        for (set, points) in &sets {
            check(&md, points);
            group.throughput(Throughput::Elements(points.len() as u64));
            group.bench_function(format!("{set}/single"), |b| {
                b.iter(|| {
                    let mut acc = 0.0f32;
                    for &p in points {
                        acc += md.signed_distance(black_box(p));
                    }
                    acc
                })
            });
            group.bench_function(format!("{set}/batch"), |b| {
                b.iter(|| md.signed_distances(black_box(points)))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_distance);
criterion_main!(benches);
