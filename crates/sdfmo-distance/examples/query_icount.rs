//! One-thread batches for instruction counts: `signed_distances` and the closest points (with
//! their triangle and feature) of the same points, half within 0.02 of the surface and half
//! uniform in the root cube, each in a function of its own for callgrind's `--toggle-collect`.
//! With a third argument, writes every answer's bits there (16 bytes per point: signed
//! distance, closest distance, triangle, feature code, 4 bytes each) to compare two versions
//! byte for byte.
//!
//! ```text
//! cargo build --release -p sdfmo-distance --example query_icount
//! valgrind --tool=callgrind --callgrind-out-file=/dev/null \
//!     --toggle-collect='query_icount::run_signed' \
//!     target/release/examples/query_icount ../shared/data/abc1.stl 4000
//! ```
//!
//! (`run_closest` for the closest points; "Collected" over the point count is instructions per
//! point, the Morton sort included.)

use glam::Vec3;
use sdfmo_distance::sample::{near_surface_points, uniform_points};
use sdfmo_distance::{Feature, MeshDistance, SignMode};

#[inline(never)]
fn run_signed(md: &MeshDistance, pts: &[Vec3]) -> Vec<f32> {
    md.signed_distances(pts)
}

#[inline(never)]
fn run_closest(md: &MeshDistance, pts: &[Vec3]) -> Vec<(u32, u32, u8)> {
    md.map_points(pts, |md, p| {
        let c = md.closest_point(p);
        let feature = match c.feature {
            Feature::Vertex(k) => k,
            Feature::Edge(k) => 3 + k,
            Feature::Face => 6,
        };
        (c.distance.to_bits(), c.triangle, feature)
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(path), Some(n)) = (args.get(1), args.get(2)) else {
        eprintln!("usage: query_icount MESH POINTS [OUT]");
        std::process::exit(2);
    };
    let n: usize = n.parse()?;
    let loaded = sdfmo_mesh::load_mesh(std::path::Path::new(path))?;
    let (mesh, _) = loaded.mesh.normalized(0.05);
    let md = MeshDistance::new(&mesh, SignMode::Auto)?;
    md.prepare_sign();
    let mut pts = near_surface_points(&mesh, n / 2, 0.02, 1);
    pts.extend(uniform_points(n - n / 2, 2));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let signed = pool.install(|| run_signed(&md, &pts));
    let closest = pool.install(|| run_closest(&md, &pts));
    if let Some(out) = args.get(3) {
        let mut bytes = Vec::with_capacity(pts.len() * 16);
        for (d, (c, t, f)) in signed.iter().zip(&closest) {
            bytes.extend(d.to_bits().to_le_bytes());
            bytes.extend(c.to_le_bytes());
            bytes.extend(t.to_le_bytes());
            bytes.extend(u32::from(*f).to_le_bytes());
        }
        std::fs::write(out, bytes)?;
    }
    Ok(())
}
