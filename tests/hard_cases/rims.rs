//! Open rims: a surface voxel must stop at the free edge of the sheet it represents, so an open
//! sheet's silhouette matches the mesh's. Flat and bent open sheets (procedural), tilted so the
//! cameras see their faces, depths 7–9: the multi-octree's mask against the mesh's, beside the
//! SVO's (IoU, and pixels the octree adds outside the mesh's silhouette). The multi-octree's
//! IoU must be at least the SVO's, and the pixels it adds at most 0.1 % of the mesh's.
//!
//! `cargo test --release --test hard_cases -- --ignored --nocapture rim_table` prints the table
//! of `docs/results/hard-cases.md` (512² images); the CI test runs depth 7 at 128².

use glam::{EulerRot, Mat3, Vec3};
use sdf_multioctree::mesh::{procedural, TriMesh};
use sdf_multioctree::render::Mode;

use crate::common::METHODS;
use crate::common::{build, camera, count, extra, mask, missing, render_mesh, render_octree};

/// A flat sheet and the same sheet bent (a parabola across its width), tilted.
fn sheets() -> [(&'static str, TriMesh); 2] {
    let rot = Mat3::from_euler(EulerRot::XYZ, 0.5, 0.35, 0.2);
    let flat = procedural::open_sheet(1.2, 0.8, 24);
    let bent = flat.transformed(|p| Vec3::new(p.x, p.y + 0.5 * p.x * p.x, p.z));
    [
        ("flat sheet", flat.transformed(|p| rot * p)),
        ("bent sheet", bent.transformed(|p| rot * p)),
    ]
}

/// Cameras seeing the sheets' faces from both sides.
const EYES: [Vec3; 3] = [
    Vec3::new(0.3, 2.8, 1.2),
    Vec3::new(-0.5, -2.6, 1.0),
    Vec3::new(2.0, 1.2, 2.0),
];

/// Over all cameras: (reference pixels, IoU, extra pixels) per method (svo, multi).
fn masks(mesh: &TriMesh, depth: u8, size: u32) -> (usize, [(f64, usize); 2]) {
    let octrees = METHODS.map(|(_, m)| build(mesh, depth, m));
    let mut reference_px = 0;
    let mut inter = [0usize; 2];
    let mut union = [0usize; 2];
    let mut extra_px = [0usize; 2];
    for eye in EYES {
        let cam = camera(eye, Vec3::ZERO, size);
        let r = mask(&render_mesh(mesh, &cam, Mode::Mask));
        reference_px += count(&r);
        for (i, o) in octrees.iter().enumerate() {
            let t = mask(&render_octree(o, &cam, Mode::Mask));
            let add = extra(&r, &t);
            let miss = missing(&r, &t);
            inter[i] += count(&r) - miss;
            union[i] += count(&r) + add;
            extra_px[i] += add;
        }
    }
    let stat = |i: usize| (inter[i] as f64 / union[i].max(1) as f64, extra_px[i]);
    (reference_px, [stat(0), stat(1)])
}

fn check(depth: u8, size: u32, table: bool) {
    for (name, mesh) in sheets() {
        let (reference, [svo, multi]) = masks(&mesh, depth, size);
        let multi_extra_pct = 100.0 * multi.1 as f64 / reference as f64;
        if table {
            eprintln!(
                "| {name} | {depth} | {reference} | {:.4} / {} | {:.4} / {} ({multi_extra_pct:.3} %) |",
                svo.0, svo.1, multi.0, multi.1
            );
        }
        let what = format!("{name} depth {depth} {size}²: svo {svo:?}, multi {multi:?}");
        assert!(
            multi.0 >= svo.0,
            "{what}: the multi-octree's IoU is below the SVO's"
        );
        // Issue 11's bound: at most 0.1 % of the silhouette (docs/results/hard-cases.md).
        assert!(
            multi_extra_pct <= 0.1 && multi.1 <= svo.1,
            "{what}: the multi-octree adds {multi_extra_pct:.3} % of the silhouette (SVO: {} px)",
            svo.1
        );
    }
}

#[test]
fn open_sheets_stop_at_their_rims() {
    check(7, 128, false);
}

#[test]
#[ignore = "the full table: cargo test --release --test hard_cases -- --ignored --nocapture rim_table"]
fn rim_table() {
    eprintln!("| sheet | depth | mesh px | SVO IoU / extra px | multi IoU / extra px |\n|---|---|---|---|---|");
    for depth in [7, 8, 9] {
        check(depth, 512, true);
    }
}
