//! Separate parts closer than a voxel (the paper's Fig. 3): the gap between two closed parts must
//! stay open whatever the grid's alignment. Gap pairs and stacks of six plates, gaps 0.1–0.5 of
//! a voxel, 16 grid phases of the gap, axis-aligned and rotated about the viewing axis.
//!
//! A gap is *open* when the rays along its mid-plane (an orthographic camera looking along the
//! gap, where the mesh shows a dark line) pass through the octree: at least [`OPEN_RAYS`] of
//! them. The same rays against the mesh itself must all pass (checked: the set-up is right).
//!
//! `cargo test --release --test hard_cases -- --ignored --nocapture gap_table` prints the whole
//! table (depths 6–9, both methods) of `docs/results/hard-cases.md`; the CI test runs a subset.

use glam::{Mat3, Vec3};
use sdf_multioctree::distance::{MeshDistance, SignMode};
use sdf_multioctree::format::{cell_size, PackedOctree};
use sdf_multioctree::mesh::{procedural, TriMesh};
use sdf_multioctree::trace::{intersect, Ray};

use crate::common::{build, METHODS};

/// Fraction of a gap's rays that must pass for it to count as open.
const OPEN_RAYS: f64 = 0.95;
/// Rays per gap, spread over 80 % of the plates' width.
const RAYS: usize = 33;
/// Plate half-width (y) and half-length (z, the viewing axis) in voxels.
const HALF_WIDTH: f32 = 8.0;
const HALF_LENGTH: f32 = 16.0;
/// Grid phases of a gap's mid-plane within a cell.
const PHASES: u32 = 16;
/// The paper's Fig. 3 stack: six plates, gaps of 0.13–0.27 voxel.
const STACK_GAPS: [f32; 5] = [0.13, 0.27, 0.2, 0.17, 0.23];

/// A test part in the normalised frame and the mid-planes of its gaps.
struct GapPart {
    mesh: TriMesh,
    /// Per gap: a point of its mid-plane at the plates' centre.
    mids: Vec<Vec3>,
    /// Width in voxels of each gap.
    widths: Vec<f32>,
    /// Direction across the plates' width (in the mid-plane, perpendicular to the rays).
    along: Vec3,
}

/// Plates of thickness `thickness` (voxels) separated by `gaps` (voxels), stacked along x, the
/// first gap's mid-plane at `phase` of the cell `[0, h]`, rotated by `angle` about z (the
/// rays' direction). Two small boxes at opposite corners of `[-0.95, 0.95]³` fix the bounding
/// box, so normalisation maps the part onto itself and the phase is where the builder sees it.
fn plates(depth: u8, thickness: f32, gaps: &[f32], phase: f32, angle: f32) -> GapPart {
    let h = cell_size(depth);
    let rot = Mat3::from_rotation_z(angle);
    let (w, l, t) = (HALF_WIDTH * h, HALF_LENGTH * h, thickness * h);
    let mut x = phase * h - 0.5 * gaps[0] * h - t;
    let mut meshes = Vec::new();
    let mut mids = Vec::new();
    for i in 0..=gaps.len() {
        let plate = procedural::box_mesh(Vec3::new(x, -w, -l), Vec3::new(x + t, w, l));
        meshes.push(plate.transformed(|p| rot * p));
        x += t;
        if let Some(&g) = gaps.get(i) {
            mids.push(rot * Vec3::new(x + 0.5 * g * h, 0.0, 0.0));
            x += g * h;
        }
    }
    let m = Vec3::splat(0.95);
    meshes.push(procedural::box_mesh(-m, -m + Vec3::splat(h)));
    meshes.push(procedural::box_mesh(m - Vec3::splat(h), m));
    GapPart {
        mesh: TriMesh::merge(&meshes),
        mids,
        widths: gaps.to_vec(),
        along: rot * Vec3::Y,
    }
}

/// The rays along gap `i`'s mid-plane, in the normalised frame of `octree` (or of the part
/// itself with `None`).
fn gap_rays(part: &GapPart, i: usize, depth: u8, octree: Option<&PackedOctree>) -> Vec<Ray> {
    let h = cell_size(depth);
    let (center, scale) = octree.map_or((Vec3::ZERO, 1.0), |o| (o.meta().center, o.meta().scale));
    (0..RAYS)
        .map(|k| {
            let s = (k as f32 / (RAYS - 1) as f32 * 2.0 - 1.0) * 0.8 * HALF_WIDTH * h;
            let p = part.mids[i] + part.along * s;
            let n = (Vec3::new(p.x, p.y, 0.0) - center) * scale;
            Ray {
                origin: Vec3::new(n.x, n.y, -2.0),
                dir: Vec3::Z,
            }
        })
        .collect()
}

/// Fraction of gap `i`'s rays that pass through the octree.
fn passing(part: &GapPart, i: usize, depth: u8, octree: &PackedOctree) -> f64 {
    let rays = gap_rays(part, i, depth, Some(octree));
    let pass = rays
        .iter()
        .filter(|r| intersect(octree, r, 0.0, f32::INFINITY).is_none())
        .count();
    pass as f64 / rays.len() as f64
}

/// Every ray along every gap passes the mesh itself.
fn assert_mesh_gaps_open(part: &GapPart, depth: u8, what: &str) {
    let dist = MeshDistance::new(&part.mesh, SignMode::Auto).expect("mesh distance");
    for i in 0..part.mids.len() {
        for r in gap_rays(part, i, depth, None) {
            assert!(
                dist.ray_hit(r.origin, r.dir, 0.0, f32::INFINITY).is_none(),
                "{what} gap {i}: the mesh itself blocks a ray at {:?}",
                r.origin
            );
        }
    }
}

/// Open gaps / gaps per method (svo, multi), and the widths of the multi-octree's closed gaps.
#[derive(Debug, Default)]
struct Tally {
    open: [usize; 2],
    total: usize,
    closed_multi: Vec<String>,
}

/// Builds every case of `parts` at `depth` with both methods and counts open gaps.
fn tally(depth: u8, parts: impl IntoIterator<Item = (String, GapPart)>) -> Tally {
    let mut t = Tally::default();
    for (what, part) in parts {
        assert_mesh_gaps_open(&part, depth, &what);
        let octrees = METHODS.map(|(_, m)| build(&part.mesh, depth, m));
        for i in 0..part.mids.len() {
            t.total += 1;
            for (mi, o) in octrees.iter().enumerate() {
                let f = passing(&part, i, depth, o);
                if f >= OPEN_RAYS {
                    t.open[mi] += 1;
                } else if mi == 1 {
                    t.closed_multi
                        .push(format!("{what} gap {i} ({} voxel): {f:.2}", part.widths[i]));
                }
            }
        }
    }
    t
}

/// Pairs of plates 2.4 voxels thick, every gap width and `phases` of the grid.
fn pairs(depth: u8, widths: &[f32], phases: &[u32], angle: f32) -> Vec<(String, GapPart)> {
    let mut out = Vec::new();
    for &g in widths {
        for &k in phases {
            let phase = k as f32 / PHASES as f32;
            out.push((
                format!("pair d{depth} gap {g} phase {k}/{PHASES} angle {angle}"),
                plates(depth, 2.4, &[g], phase, angle),
            ));
        }
    }
    out
}

/// The Fig. 3 stack (plates 1.37 voxels thick) at `phases` of the grid.
fn stacks(depth: u8, phases: &[u32], angle: f32) -> Vec<(String, GapPart)> {
    phases
        .iter()
        .map(|&k| {
            let phase = k as f32 / PHASES as f32;
            (
                format!("stack d{depth} phase {k}/{PHASES} angle {angle}"),
                plates(depth, 1.37, &STACK_GAPS, phase, angle),
            )
        })
        .collect()
}

fn report(kind: &str, depth: u8, t: &Tally) {
    let pct = |n: usize| 100.0 * n as f64 / t.total.max(1) as f64;
    eprintln!(
        "| {kind} | {depth} | {} | {} ({:.1} %) | {} ({:.1} %) |",
        t.total,
        t.open[0],
        pct(t.open[0]),
        t.open[1],
        pct(t.open[1])
    );
}

/// CI subset: depths 6–7, six phases, pairs at four gap widths and the stack, axis-aligned
/// and rotated. The multi-octree keeps every gap open; the SVO's figure is printed beside it.
/// (The 0.4-voxel pair at phases 2 and 14 closed until session 7: the leaves at the plates'
/// ends kept the SVO voxel, because the other plate, gathered but outside the cell, barred
/// the sharp-feature voxels.)
#[test]
fn gaps_between_separate_parts_stay_open() {
    let phases = [0, 2, 5, 10, 14, 15];
    for depth in [6, 7] {
        for angle in [0.0, 0.3] {
            let mut cases = pairs(depth, &[0.15, 0.3, 0.4, 0.5], &phases, angle);
            cases.extend(stacks(depth, &phases, angle));
            let t = tally(depth, cases);
            report(&format!("pairs+stack angle {angle}"), depth, &t);
            assert!(
                t.open[1] == t.total,
                "depth {depth} angle {angle}: multi keeps {} of {} gaps open; closed: {:?}",
                t.open[1],
                t.total,
                t.closed_multi
            );
        }
    }
}

/// The whole table: depths 6–9, gaps 0.1–0.5 voxel, 16 phases, pairs and stacks, axis-aligned
/// and rotated by 0.3 rad (17°) about the rays.
#[test]
#[ignore = "the full table (~1 min in release): cargo test --release --test hard_cases -- --ignored --nocapture gap_table"]
fn gap_table() {
    let phases: Vec<u32> = (0..PHASES).collect();
    let widths = [0.1, 0.2, 0.3, 0.4, 0.5];
    eprintln!("| case | depth | gaps | SVO open | multi open |\n|---|---|---|---|---|");
    let mut all = [0usize; 3];
    for depth in 6..=9 {
        for angle in [0.0, 0.3] {
            for (kind, cases) in [
                ("pairs", pairs(depth, &widths, &phases, angle)),
                ("stacks", stacks(depth, &phases, angle)),
            ] {
                let t = tally(depth, cases);
                report(&format!("{kind}, angle {angle}"), depth, &t);
                all[0] += t.open[0];
                all[1] += t.open[1];
                all[2] += t.total;
                for c in t.closed_multi.iter().take(4) {
                    eprintln!("  closed (multi): {c}");
                }
            }
        }
    }
    let pct = |n: usize| 100.0 * n as f64 / all[2] as f64;
    eprintln!(
        "all: {} gaps, SVO open {} ({:.1} %), multi open {} ({:.1} %)",
        all[2],
        all[0],
        pct(all[0]),
        all[1],
        pct(all[1])
    );
    assert!(all[1] as f64 >= 0.95 * all[2] as f64);
}
