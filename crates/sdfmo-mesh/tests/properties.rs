//! Property tests (bounded case counts) on welding, cleaning and normalisation.

use std::collections::HashSet;

use glam::Vec3;
use proptest::prelude::*;
use sdfmo_mesh::{clean, load_mesh_from_bytes, write, MeshFormat, TriMesh};

/// A triangle soup drawn from a small pool of points, so welding, duplicates and degenerate
/// triangles all occur; −0.0 appears next to +0.0.
fn soup() -> impl Strategy<Value = (Vec<Vec3>, Vec<[u32; 3]>, Vec<u32>)> {
    let coord = prop_oneof![
        Just(0.0f32),
        Just(-0.0f32),
        (-4i32..4).prop_map(|c| c as f32)
    ];
    let point =
        (coord.clone(), coord.clone(), coord).prop_map(|(x, y, z)| Vec3::new(x * 0.5, y * 0.25, z));
    prop::collection::vec(point, 3..24)
        .prop_flat_map(|pool| {
            let n = pool.len() as u32;
            let tri = (0..n, 0..n, 0..n, 0u32..3).prop_map(|(a, b, c, p)| ([a, b, c], p));
            (Just(pool), prop::collection::vec(tri, 1..60))
        })
        .prop_map(|(pool, tris)| {
            // Expand to a soup: every triangle gets its own three vertices (as STL stores them).
            let mut positions = Vec::new();
            let mut triangles = Vec::new();
            let mut parts = Vec::new();
            for (t, p) in tris {
                let b = positions.len() as u32;
                positions.extend(t.map(|v| pool[v as usize]));
                triangles.push([b, b + 1, b + 2]);
                parts.push(p);
            }
            (positions, triangles, parts)
        })
}

fn key(p: Vec3) -> [u32; 3] {
    p.to_array().map(|c| (c + 0.0).to_bits())
}

fn sorted_corners(t: [Vec3; 3]) -> [[u32; 3]; 3] {
    let mut k = t.map(key);
    k.sort_unstable();
    k
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn welding_keeps_every_distinct_surface_triangle((positions, triangles, parts) in soup()) {
        let result = clean("soup", &positions, &triangles, &parts);
        let input: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|v| positions[v as usize])).collect();
        let nondegenerate: Vec<&[Vec3; 3]> = input
            .iter()
            .filter(|t| (t[1] - t[0]).as_dvec3().cross((t[2] - t[0]).as_dvec3()) != glam::DVec3::ZERO)
            .collect();
        let distinct: HashSet<[[u32; 3]; 3]> = nondegenerate.iter().map(|t| sorted_corners(**t)).collect();
        let Ok((mesh, report)) = result else {
            prop_assert!(distinct.is_empty());
            return Ok(());
        };
        // Vertices are unique (bit-identical ones welded, ±0 together).
        let keys: HashSet<[u32; 3]> = mesh.positions().iter().map(|&p| key(p)).collect();
        prop_assert_eq!(keys.len(), mesh.vertex_count());
        // Kept + removed = input; one triangle per distinct non-degenerate corner set.
        prop_assert_eq!(
            mesh.triangle_count() + report.degenerate_triangles + report.duplicate_triangles,
            triangles.len()
        );
        prop_assert_eq!(report.degenerate_triangles, input.len() - nondegenerate.len());
        let out: HashSet<[[u32; 3]; 3]> = (0..mesh.triangle_count()).map(|i| sorted_corners(mesh.triangle(i))).collect();
        prop_assert_eq!(out.len(), mesh.triangle_count());
        prop_assert_eq!(&out, &distinct);
        // Each kept triangle is its first input occurrence, corners in order, part kept.
        for i in 0..mesh.triangle_count() {
            let k = sorted_corners(mesh.triangle(i));
            let first = input.iter().position(|t| sorted_corners(*t) == k).unwrap();
            prop_assert_eq!(mesh.triangle(i).map(key), input[first].map(key));
            prop_assert_eq!(mesh.parts()[i], parts[first]);
        }
        // Idempotent, and the same through a binary STL file.
        let (again, r2) = mesh.cleaned().unwrap();
        prop_assert_eq!(&again, &mesh);
        prop_assert_eq!(r2.welded_vertices + r2.degenerate_triangles + r2.duplicate_triangles, 0);
        let soup = TriMesh::new(positions.clone(), triangles.clone(), vec![0; parts.len()]).unwrap();
        let l = load_mesh_from_bytes(&write::to_stl_binary(&soup), "soup.stl", Some(MeshFormat::Stl)).unwrap();
        prop_assert_eq!(l.mesh.triangles(), mesh.triangles());
        prop_assert_eq!(l.mesh.positions().iter().map(|&p| key(p)).collect::<Vec<_>>(), mesh.positions().iter().map(|&p| key(p)).collect::<Vec<_>>());
    }

    #[test]
    fn normalisation_fits_the_root_cube_and_inverts(
        pts in prop::collection::vec((-1e3f32..1e3, -1e3f32..1e3, -1e3f32..1e3), 3..40),
        scale in 1e-3f32..1e3,
        margin in 0.0f32..0.4,
    ) {
        let positions: Vec<Vec3> = pts.iter().map(|&(x, y, z)| Vec3::new(x, y, z) * scale).collect();
        let n = positions.len() as u32;
        let triangles: Vec<[u32; 3]> = (0..n - 2).map(|i| [i, i + 1, i + 2]).collect();
        let parts = vec![0; triangles.len()];
        let mesh = TriMesh::new(positions, triangles, parts).unwrap();
        let extent = mesh.bounds().longest_extent();
        prop_assume!(extent > 0.0);
        let (norm, t) = mesh.normalized(margin);
        let b = norm.bounds();
        let target = 2.0 * (1.0 - margin);
        prop_assert!((b.longest_extent() - target).abs() <= 1e-5 * target, "extent {} vs {}", b.longest_extent(), target);
        prop_assert!((b.min + b.max).abs().max_element() <= 1e-5, "not centred: {:?}", b);
        prop_assert!(b.min.cmpge(Vec3::splat(-1.0)).all() && b.max.cmple(Vec3::splat(1.0)).all());
        for (p, q) in mesh.positions().iter().zip(norm.positions()) {
            prop_assert_eq!(t.to_normalized(*p), *q);
            let back = t.to_model(*q);
            prop_assert!((back - *p).abs().max_element() <= 1e-5 * extent, "{:?} -> {:?} -> {:?}", p, q, back);
        }
        // Topology does not depend on the frame.
        prop_assert_eq!(norm.topology(), mesh.topology());
    }
}
