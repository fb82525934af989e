//! Scale and translation invariance: the builder normalises the mesh, so the same part at any
//! model scale or position must give the same octree (up to float rounding of the input) and the
//! same images.

use glam::Vec3;
use sdf_multioctree::format::{cell_size, PackedOctree};
use sdf_multioctree::mesh::{procedural, TriMesh};
use sdf_multioctree::paper_views;
use sdf_multioctree::render::{OctreeScene, PaperProtocol};

use crate::common::{assert_renders_sane, build, leaf_map, METHODS, MULTI};
use sdf_multioctree::build::Method;

/// How two octrees of the same part differ.
#[derive(Debug, Default)]
struct Diff {
    /// Leaves present in one octree only.
    leaves_only_in_one: usize,
    /// Leaves present in both whose voxel counts or surface flags differ.
    leaves_differing_voxels: usize,
    /// Largest difference of a dequantised corner value in leaves present in both.
    max_corner_diff: f32,
    /// Corner values that differ at all.
    corners_differing: usize,
    /// The first few differing leaves, for failure messages.
    examples: Vec<String>,
}

fn diff(a: &PackedOctree, b: &PackedOctree) -> Diff {
    let (ma, mb) = (leaf_map(a), leaf_map(b));
    let mut d = Diff::default();
    for (coord, va) in &ma {
        let Some(vb) = mb.get(coord) else {
            d.leaves_only_in_one += 1;
            if d.examples.len() < 3 {
                d.examples
                    .push(format!("only in the first: {coord:?} {va:?}"));
            }
            continue;
        };
        let same_shape =
            va.len() == vb.len() && va.iter().zip(vb).all(|(x, y)| x.surface == y.surface);
        if !same_shape {
            d.leaves_differing_voxels += 1;
            if d.examples.len() < 3 {
                d.examples.push(format!("{coord:?}: {va:?} vs {vb:?}"));
            }
            continue;
        }
        for (x, y) in va.iter().zip(vb) {
            for (cx, cy) in x.corners.iter().zip(&y.corners) {
                let e = (cx - cy).abs();
                if e > 0.0 {
                    d.corners_differing += 1;
                }
                d.max_corner_diff = d.max_corner_diff.max(e);
            }
        }
    }
    for (coord, vb) in &mb {
        if !ma.contains_key(coord) {
            d.leaves_only_in_one += 1;
            if d.examples.len() < 6 {
                d.examples
                    .push(format!("only in the second: {coord:?} {vb:?}"));
            }
        }
    }
    d
}

/// Minimum PSNR over the paper's views (48²) of `test`'s renders against `reference`'s: the
/// paper protocol with an octree as the reference.
fn min_psnr(reference: &PackedOctree, test: &PackedOctree) -> f64 {
    PaperProtocol::of_scene(&OctreeScene(reference), 48)
        .and_then(|p| p.score(&OctreeScene(test)))
        .expect("render and compare")
        .min_psnr()
}

/// One quantisation step of an 8-bit corner at `depth`: 2·dmax/255 with dmax the voxel diagonal.
fn quant_step(depth: u8) -> f32 {
    let leaf = cell_size(depth);
    2.0 * leaf * 3f32.sqrt() / 255.0
}

/// Builds `part` at scales 1e-4 and 1e4 and compares with scale 1; returns, per scale, the
/// differences and the worst-view PSNR.
fn scales(name: &str, part: &TriMesh, depth: u8, method: Method) -> Vec<(String, Diff, f64)> {
    let cameras = paper_views(48);
    let unit = build(part, depth, method);
    assert!(unit.leaf_count() > 0);
    [1e-4f32, 1e4]
        .into_iter()
        .map(|s| {
            let scaled = part.transformed(|p| p * s);
            let oct = build(&scaled, depth, method);
            let what = format!("{name} {method:?} depth {depth} scale {s:e}");
            assert_renders_sane(&oct, &cameras[1], &what);
            let d = diff(&unit, &oct);
            let psnr = min_psnr(&unit, &oct);
            eprintln!(
                "{what}: leaves {} vs {}, voxels {} vs {}, {d:?}, min PSNR vs scale 1 {psnr:.2} dB",
                oct.leaf_count(),
                unit.leaf_count(),
                oct.voxel_count(),
                unit.voxel_count()
            );
            (what, d, psnr)
        })
        .collect()
}

/// Normalisation maps the scaled part onto the unit part up to one or two f32 roundings per
/// coordinate (~1e-7 relative): the same leaves and voxels, corner values at most one
/// quantisation step apart (a value on a rounding boundary), the same images.
fn assert_identical(results: &[(String, Diff, f64)], depth: u8) {
    for (what, d, psnr) in results {
        assert_eq!(d.leaves_only_in_one, 0, "{what}: {d:?}");
        assert_eq!(d.leaves_differing_voxels, 0, "{what}: {d:?}");
        assert!(
            d.max_corner_diff <= quant_step(depth) * 1.01,
            "{what}: {d:?}"
        );
        assert!(*psnr >= 40.0, "{what}: PSNR {psnr} dB vs scale 1");
    }
}

fn plate_and_sphere() -> TriMesh {
    let rot = glam::Mat3::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, 0.2);
    TriMesh::merge(&[
        procedural::thin_plate(Vec3::new(1.0, 0.01, 0.8)).transformed(|p| rot * p),
        procedural::sphere(Vec3::new(0.2, 0.3, -0.1), 0.3, 2),
    ])
}

#[test]
fn svo_is_identical_at_scales_1e_minus_4_1_and_1e4() {
    assert_identical(&scales("demo", &procedural::demo_part(), 6, Method::Svo), 6);
    assert_identical(
        &scales("plate+sphere", &plate_and_sphere(), 5, Method::Svo),
        5,
    );
}

/// What every multi-octree builder must do whatever its thresholds: on the demo part (boxes,
/// sphere, plate, sheet, slot) nearly the same leaves and images at any scale.
#[test]
fn multi_octree_demo_is_nearly_identical_at_scales_1e_minus_4_1_and_1e4() {
    let part = procedural::demo_part();
    let leaves = build(&part, 6, MULTI).leaf_count();
    for (what, d, psnr) in scales("demo", &part, 6, MULTI) {
        let changed = d.leaves_only_in_one + d.leaves_differing_voxels;
        assert!(
            changed * 100 <= leaves,
            "{what}: {changed} leaves of {leaves} changed: {d:?}"
        );
        assert!(psnr >= 35.0, "{what}: PSNR {psnr} dB vs scale 1");
    }
}

/// Power-of-two scales are exact in f32 (the normalised coordinates are bit-identical), so every
/// builder, whatever its thresholds, must give the same leaves and voxels bit for bit (the
/// file differs only in the stored transform).
#[test]
fn power_of_two_scales_give_identical_voxels() {
    let part = plate_and_sphere();
    for (mname, method) in METHODS {
        let unit = build(&part, 5, method);
        for s in [2f32.powi(-14), 2f32.powi(13)] {
            let oct = build(&part.transformed(|p| p * s), 5, method);
            let d = diff(&unit, &oct);
            let identical = d.leaves_only_in_one == 0
                && d.leaves_differing_voxels == 0
                && d.corners_differing == 0;
            assert!(
                identical && unit.leaf_count() == oct.leaf_count(),
                "{mname} scale {s}: {d:?}"
            );
            // The stored transform maps the scaled model exactly onto the same frame.
            assert_eq!(oct.meta().scale, unit.meta().scale / s, "{mname} scale {s}");
            assert_eq!(
                oct.meta().center,
                unit.meta().center * s,
                "{mname} scale {s}"
            );
        }
    }
}

/// Scaling the input by 1e-4 or 1e4 perturbs the normalised coordinates by about one ulp. The
/// multi-octree's decisions used to flip under it (26 + 29 leaves of the plate+sphere, 6 and
/// 14 + 9 of the demo part): a plate 0.3 of a leaf thick split or not, surface on a cell face
/// sampled on one side only, a corner in the plane of an open sheet beyond its rim signed by
/// rounding noise. The SVO (same distances) was always identical.
#[test]
fn multi_octree_is_identical_at_scales_1e_minus_4_1_and_1e4() {
    assert_identical(&scales("plate+sphere", &plate_and_sphere(), 5, MULTI), 5);
    assert_identical(&scales("demo", &procedural::demo_part(), 6, MULTI), 6);
}

/// Issue 11's "stable decisions" in its own words: the same octree, up to corner rounding,
/// under a one-ulp change of any vertex. Every coordinate of every vertex moves one ulp up,
/// down or not at all (chosen by a hash of the position, so welded copies move alike), in
/// three draws, for both methods, on the demo part (axis-aligned faces and rims on cell faces)
/// at depths 6–8 and the rotated plate + sphere at depths 5–6. Before the face slack and the
/// undecided side (session 6) the demo at depth 6 differed in 53 + 70 leaves. Not asserted: the
/// plate + sphere at depth 7, where one leaf of the 0.01-thick rotated plate flips between the
/// SVO voxel and its two face voxels under draw 2 (a score threshold crossed because one
/// corner rounds to the next quantisation step: a decision on quantised values cannot be
/// continuous everywhere).
#[test]
fn one_ulp_vertex_nudges_give_the_same_octree() {
    fn nudge(p: Vec3, seed: u32) -> Vec3 {
        let step = |v: f32, k: u32| {
            let h = (v.to_bits() ^ seed.wrapping_mul(0x9e37_79b9)).wrapping_mul(0x85eb_ca6b) ^ k;
            match h.wrapping_mul(0xc2b2_ae35) >> 30 {
                0 => v.next_up(),
                1 => v.next_down(),
                _ => v,
            }
        };
        Vec3::new(step(p.x, 1), step(p.y, 2), step(p.z, 3))
    }
    for (name, part, depth) in [
        ("demo", procedural::demo_part(), 6),
        ("demo", procedural::demo_part(), 7),
        ("demo", procedural::demo_part(), 8),
        ("plate+sphere", plate_and_sphere(), 6),
        ("plate+sphere", plate_and_sphere(), 7),
        ("plate+sphere", plate_and_sphere(), 5),
    ] {
        for (mname, method) in METHODS {
            let unit = build(&part, depth, method);
            for seed in 1..=3 {
                let moved = build(&part.transformed(|p| nudge(p, seed)), depth, method);
                let d = diff(&unit, &moved);
                let what = format!("{name} {mname} depth {depth} nudge {seed}");
                assert_eq!(d.leaves_only_in_one, 0, "{what}: {d:?}");
                assert_eq!(d.leaves_differing_voxels, 0, "{what}: {d:?}");
                assert!(
                    d.max_corner_diff <= quant_step(depth) * 1.01,
                    "{what}: {d:?}"
                );
            }
        }
    }
}

/// A copy of the demo part moved by +1e5 along x. At 1e5 an f32 has a spacing of 2⁻⁷, so the
/// far copy itself is a slightly different mesh (coordinates rounded to 1/128): the octree of the
/// far copy must equal that of the same rounded mesh moved back to the origin (the subtraction
/// is exact, Sterbenz), and render close to the original part.
#[test]
fn translated_far_from_the_origin_builds_like_the_same_mesh_at_the_origin() {
    let part = procedural::demo_part();
    let far = part.transformed(|p| p + Vec3::new(1e5, 0.0, 0.0));
    let back = far.transformed(|p| p - Vec3::new(1e5, 0.0, 0.0));
    let cameras = paper_views(48);
    let depth = 6;
    for (mname, method) in METHODS {
        let o_far = build(&far, depth, method);
        let o_back = build(&back, depth, method);
        let o_part = build(&part, depth, method);
        let what = format!("demo +1e5 {mname} depth {depth}");
        assert_renders_sane(&o_far, &cameras[0], &what);
        let d = diff(&o_back, &o_far);
        let psnr_back = min_psnr(&o_back, &o_far);
        let psnr_part = min_psnr(&o_part, &o_far);
        eprintln!(
            "{what}: vs the rounded copy at the origin {d:?}, min PSNR {psnr_back:.2} dB; \
             vs the exact part: {:?}, min PSNR {psnr_part:.2} dB",
            diff(&o_part, &o_far)
        );
        assert_eq!(d.leaves_only_in_one, 0, "{what}: {d:?}");
        assert_eq!(d.leaves_differing_voxels, 0, "{what}: {d:?}");
        assert!(
            d.max_corner_diff <= quant_step(depth) * 1.01,
            "{what}: {d:?}"
        );
        assert!(psnr_back >= 40.0, "{what}: {psnr_back} dB");
        // The input itself moved by up to 2⁻⁸ model units (0.002 normalised, a tenth of a
        // depth-6 leaf): the image stays close to the exact part's.
        assert!(
            psnr_part >= 20.0,
            "{what}: {psnr_part} dB vs the exact part"
        );
    }
}

/// The same input twice gives the same bytes (the builder is deterministic), for both methods.
#[test]
fn repeated_builds_are_identical() {
    let part = plate_and_sphere();
    for (mname, method) in METHODS {
        let a = build(&part, 5, method);
        for i in 0..2 {
            let b = build(&part, 5, method);
            assert!(
                a.to_bytes() == b.to_bytes(),
                "{mname} build {i}: {:?}",
                diff(&a, &b)
            );
        }
    }
}

/// Regression (fixed in sdfmo-build by making the thin split's face groups canonical): the
/// smallest reproduction of the instability above: one coordinate of one plate vertex moved
/// by one ulp (1e-7 relative) changed which voxels whole leaves hold, all over the plate (the
/// vertex's triangles span it). The SVO's corners do not change at all. A builder whose
/// decisions are continuous up to quantisation would change at most a handful of corners.
#[test]
fn multi_octree_is_stable_under_a_one_ulp_vertex_move() {
    let part = plate_and_sphere();
    let (mut positions, triangles, parts) = part.clone().into_arrays();
    positions[0].x = f32::from_bits(positions[0].x.to_bits() + 1);
    let moved = TriMesh::new(positions, triangles, parts).unwrap();
    for (mname, method) in METHODS {
        let d = diff(&build(&part, 5, method), &build(&moved, 5, method));
        eprintln!("{mname}, one ulp on vertex 0: {d:?}");
        assert_eq!(
            d.leaves_only_in_one + d.leaves_differing_voxels,
            0,
            "{mname}: {d:?}"
        );
    }
}
