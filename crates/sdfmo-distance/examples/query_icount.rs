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
use sdfmo_distance::{Feature, MeshDistance};

mod support;

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
    let q = support::queries("query_icount")?;
    let (md, pts) = (&q.md, &q.points);
    md.prepare_sign();
    let signed = q.pool.install(|| run_signed(md, pts));
    let closest = q.pool.install(|| run_closest(md, pts));
    if let Some(out) = &q.out {
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
