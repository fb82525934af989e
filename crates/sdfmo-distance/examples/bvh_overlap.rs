//! Which BVH builder each mesh gets, and why: the triangles' box overlap
//! ([`sdfmo_distance::box_overlap`]), the builder, the tree's depth and the build time, for the
//! meshes named on the command line and for generated fans.
//!
//! ```sh
//! cargo run --release -p sdfmo-distance --example bvh_overlap -- ../shared/data/*.stl
//! ```

use std::time::Instant;

use glam::Vec3;
use sdfmo_distance::{box_overlap, MeshDistance, SignMode};
use sdfmo_mesh::procedural::{fan_cylinder, fan_disc};
use sdfmo_mesh::TriMesh;

fn report(name: &str, mesh: &TriMesh) -> Result<(), Box<dyn std::error::Error>> {
    let tris: Vec<[Vec3; 3]> = (0..mesh.triangle_count())
        .map(|i| mesh.triangle(i))
        .collect();
    // The builder choice's pre-pass (box overlap and valence) against the whole construction,
    // interleaved, median of 5.
    let (mut pre, mut total) = (Vec::new(), Vec::new());
    let (mut overlap, mut max_valence) = (0.0, 0);
    let mut dist = None;
    for _ in 0..5 {
        let start = Instant::now();
        overlap = box_overlap(&tris);
        let mut valence = vec![0u32; mesh.vertex_count()];
        for t in mesh.triangles() {
            for &v in t {
                valence[v as usize] += 1;
            }
        }
        max_valence = valence.iter().max().copied().unwrap_or(0);
        pre.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        dist = Some(MeshDistance::new(mesh, SignMode::Auto)?);
        total.push(start.elapsed().as_secs_f64() * 1e3);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (pre_ms, ms) = (median(&mut pre), median(&mut total));
    let dist = dist.expect("built");
    println!(
        "| {name} | {} | {overlap:.1} | {max_valence} | {:?} | {} | {ms:.1} | {pre_ms:.2} |",
        mesh.triangle_count(),
        dist.bvh_builder(),
        dist.bvh_depth()
    );
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "| mesh | triangles | box overlap | max valence | builder | depth | construction ms | pre-pass ms |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for path in std::env::args().skip(1) {
        let loaded = sdfmo_mesh::load_mesh(std::path::Path::new(&path))?;
        let (mesh, _) = loaded.mesh.normalized(0.05);
        let name = std::path::Path::new(&path)
            .file_name()
            .map_or(path.clone(), |n| n.to_string_lossy().into_owned());
        report(&name, &mesh)?;
    }
    for segments in [400, 600, 5_000, 50_000] {
        report(
            &format!("fan cylinder {segments}"),
            &fan_cylinder(segments, 1.0, 1.0),
        )?;
    }
    for n in [50_000, 100_000] {
        report(&format!("fan disc {n}"), &fan_disc(n))?;
    }
    Ok(())
}
