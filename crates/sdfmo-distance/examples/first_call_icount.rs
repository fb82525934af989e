//! One-thread instruction counts of `signed_distances`' first call on a fresh structure
//! (`MeshDistance::new`, no `prepare_sign`: the winding sign's per-leaf radii are made for the
//! leaves the points reach) and of a second call on the same points (the steady state), each in
//! a function of its own for callgrind. The points are `query_icount`'s mix: half within 0.02
//! of the surface, half uniform in the root cube. With a third argument, writes both calls'
//! signed distances' bits there (4 bytes each, first call then second) to compare two versions
//! byte for byte.
//!
//! ```text
//! cargo build --release -p sdfmo-distance --example first_call_icount
//! valgrind --tool=callgrind --callgrind-out-file=cg.out \
//!     target/release/examples/first_call_icount ../shared/data/stanford-bunny.obj 50000
//! callgrind_annotate --inclusive=yes cg.out | grep -E 'run_(first|again)'
//! ```
//!
//! (each function's inclusive count over the point count is instructions per point, the
//! Morton sort included; first minus again is the one-time work the first call does).

use glam::Vec3;
use sdfmo_distance::MeshDistance;

mod support;

/// The first call: every reached leaf's radii are made here.
#[inline(never)]
fn run_first(md: &MeshDistance, pts: &[Vec3]) -> Vec<f32> {
    md.signed_distances(pts)
}

/// The same points again: nothing left to make. (Its `black_box` keeps the two functions
/// apart: identical bodies were merged into one symbol.)
#[inline(never)]
fn run_again(md: &MeshDistance, pts: &[Vec3]) -> Vec<f32> {
    md.signed_distances(std::hint::black_box(pts))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let q = support::queries("first_call_icount")?;
    let (md, pts) = (&q.md, &q.points);
    let first = q.pool.install(|| run_first(md, pts));
    let again = q.pool.install(|| run_again(md, pts));
    assert!(
        first
            .iter()
            .zip(&again)
            .all(|(a, b)| a.to_bits() == b.to_bits()),
        "the first call's answers differ from the second's"
    );
    if let Some(out) = &q.out {
        let bytes: Vec<u8> = first
            .iter()
            .chain(&again)
            .flat_map(|d| d.to_bits().to_le_bytes())
            .collect();
        std::fs::write(out, bytes)?;
    }
    Ok(())
}
