//! Degenerate input built directly (no cleaning): zero-area, needle and duplicate triangles,
//! duplicate and unused vertices. It must build and render without NaN, like the cleaned mesh.

use glam::Vec3;
use sdf_multioctree::mesh::{procedural, TriMesh};
use sdf_multioctree::render::Mode;
use sdf_multioctree::{compare, paper_views};

use crate::common::{
    assert_corners_finite, assert_renders_sane, build, count, mask, missing, render_octree, METHODS,
};

/// The demo part with every kind of dirt added; the geometry (the set of points on triangles)
/// is unchanged, so the cleaned mesh is the demo part up to vertex numbering.
fn dirty_demo() -> TriMesh {
    let m = procedural::demo_part();
    let n = m.triangle_count();
    let (mut positions, mut triangles, mut parts) = m.into_arrays();
    let mut extra: Vec<[u32; 3]> = Vec::new();
    // Zero-area: a repeated vertex on the surface, and, in the empty space between the
    // parts, three exactly collinear vertices and a triangle with all three indices equal: as
    // segments or points they would add geometry if the builder did not ignore them.
    let [a, b, c] = triangles[0];
    extra.push([a, a, b]);
    let free = positions.len() as u32;
    positions.extend([
        Vec3::new(0.3, 0.2, -0.1),
        Vec3::new(0.45, 0.2, -0.1),
        Vec3::new(0.6, 0.2, -0.1),
    ]);
    extra.extend([[free, free + 1, free + 2], [free + 1, free + 1, free + 1]]);
    // Needles: slivers lying inside an existing face (a point very close to a corner, inside
    // the triangle, and a point very close to an edge), so the surface does not change.
    let [pa, pb, pc] = [a, b, c].map(|v| positions[v as usize]);
    let near_a = positions.len() as u32;
    positions.push(pa * (1.0 - 2e-6) + pb * 1e-6 + pc * 1e-6);
    extra.push([a, b, near_a]);
    let near_ab = positions.len() as u32;
    positions.push((pa + pb) * 0.5 * (1.0 - 1e-6) + pc * 1e-6);
    extra.push([a, near_ab, b]);
    // Duplicates: the same triangle again, rotated, and reversed.
    let [d0, d1, d2] = triangles[n / 2];
    extra.extend([[d0, d1, d2], [d1, d2, d0], [d0, d2, d1]]);
    // Duplicate vertices: every third triangle refers to a bit-identical copy of its first
    // vertex instead (breaks welding by index; the cleaner welds them again).
    for i in (0..n).step_by(3) {
        let v = triangles[i][0];
        positions.push(positions[v as usize]);
        triangles[i][0] = positions.len() as u32 - 1;
    }
    // Unused vertices: inside the part and far outside it (bounds ignore unreferenced ones).
    positions.push(Vec3::ZERO);
    positions.push(Vec3::splat(1e6));
    positions.push(Vec3::splat(-3.0e4));
    for t in extra {
        triangles.push(t);
        parts.push(parts[0]);
    }
    TriMesh::new(positions, triangles, parts).expect("dirty but valid")
}

#[test]
fn dirty_mesh_builds_and_renders_like_the_cleaned_mesh() {
    let dirty = dirty_demo();
    let (clean, report) = dirty.cleaned().expect("clean");
    eprintln!("dirty demo: {report:?}");
    assert!(report.degenerate_triangles >= 3, "{report:?}");
    assert!(report.duplicate_triangles >= 3, "{report:?}");
    assert!(report.welded_vertices > 0, "{report:?}");
    assert_eq!(
        dirty.bounds(),
        clean.bounds(),
        "unused vertices must not count in the bounds"
    );
    let cameras = paper_views(64);
    let depth = 6;
    for (mname, method) in METHODS {
        let od = build(&dirty, depth, method);
        let oc = build(&clean, depth, method);
        let what = format!("dirty demo {mname} depth {depth}");
        assert_corners_finite(&od, &what);
        for cam in &cameras {
            assert_renders_sane(&od, cam, &what);
        }
        let mut worst_psnr = f64::INFINITY;
        let mut worst_mask = 0usize;
        let mut clean_pixels = 0usize;
        for cam in &cameras {
            let (a, b) = (
                render_octree(&oc, cam, Mode::Lambert),
                render_octree(&od, cam, Mode::Lambert),
            );
            worst_psnr = worst_psnr.min(compare(&a, &b).unwrap().psnr);
            let (ma, mb) = (mask(&a), mask(&b));
            clean_pixels += count(&ma);
            worst_mask = worst_mask.max(missing(&ma, &mb) + missing(&mb, &ma));
        }
        eprintln!(
            "{what}: leaves {} vs clean {}, voxels {} vs {}, worst-view PSNR vs clean {worst_psnr:.2} dB, \
             worst-view mask difference {worst_mask} px (clean: {clean_pixels} px over 4 views)",
            od.leaf_count(),
            oc.leaf_count(),
            od.voxel_count(),
            oc.voxel_count()
        );
        // Duplicate vertices make the dirty mesh look open by index (not watertight), which may
        // change how a corner's sign is decided: allow a leaf in a thousand to differ.
        let dl = od.leaf_count().abs_diff(oc.leaf_count());
        assert!(dl * 1000 <= oc.leaf_count(), "{what}: {dl} leaves differ");
        assert!(
            worst_psnr >= 35.0,
            "{what}: PSNR {worst_psnr} dB vs the cleaned mesh"
        );
        assert!(
            worst_mask <= 8,
            "{what}: {worst_mask} mask pixels differ from the cleaned mesh"
        );
    }
}

/// Only degenerate triangles besides one real one: builds (from the one real triangle), no NaN.
#[test]
fn one_real_triangle_among_degenerate_ones_builds_without_nan() {
    // The real triangle's corners, then two more points on the line of its edge 0–1.
    let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0, Vec3::X * 0.5];
    let triangles = vec![[0, 0, 0], [0, 1, 3], [0, 4, 1], [1, 1, 2], [0, 1, 2]];
    let mesh = TriMesh::new(positions, triangles, vec![0; 5]).unwrap();
    let cam = crate::common::camera(Vec3::new(0.3, 0.4, 3.0), Vec3::ZERO, 48);
    for (mname, method) in METHODS {
        let o = build(&mesh, 5, method);
        let what = format!("one real triangle {mname}");
        assert_corners_finite(&o, &what);
        let hits = assert_renders_sane(&o, &cam, &what);
        eprintln!("{what}: {} leaves, {hits} hit pixels", o.leaf_count());
        if mname == "multi" {
            assert!(hits > 0, "{what}: the open triangle must be visible");
        }
    }
}

/// Only zero-area triangles: a typed error, never a panic.
#[test]
fn all_degenerate_is_a_typed_error() {
    let positions = vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
    let mesh = TriMesh::new(positions, vec![[0, 1, 2], [0, 0, 1]], vec![0; 2]).unwrap();
    for (_, method) in METHODS {
        let e = sdf_multioctree::build_octree(&mesh, 5, method).unwrap_err();
        assert!(matches!(e, sdf_multioctree::Error::Build(_)), "{e}");
    }
}
