//! A cube built by hand from *intersect* voxels (format 1.1: in every leaf the cube's face
//! planes that cut it, one plane voxel each, combined by `max`), rendered by the octree renderer
//! on the paper views: the silhouette is the analytic cube's (no pixel differs except within
//! 1e-4 leaf of the silhouette) and the faces are flat (every pixel away from an edge has its
//! face's normal).

use glam::Vec3;
use sdfmo_format::testing::{analytic_hit, convex_leaves, cube_planes, skew_cube, Plane};
use sdfmo_format::{cell_size, OctreeMeta, PackedOctree, ValueBits};
use sdfmo_render::{render, Camera, Mode, OctreeScene, RenderSettings};

/// Image side.
const SIZE: u32 = 160;

/// In each leaf, the planes that cut it as intersect voxels.
fn cube_octree(depth: u8, planes: &[Plane]) -> PackedOctree {
    PackedOctree::from_leaves(
        OctreeMeta::unit(depth, ValueBits::Sixteen),
        convex_leaves(depth, planes),
    )
    .expect("cube octree")
}

#[test]
fn a_cube_of_intersect_voxels_renders_sharp_and_flat() {
    let (rot, c, r) = skew_cube();
    let planes = cube_planes(rot, c, r);
    for depth in [4u8, 6] {
        let octree = cube_octree(depth, &planes);
        assert!(octree.has_clip_voxels());
        let margin = 1e-4 * cell_size(depth);
        let settings = RenderSettings::new(Mode::Normal);
        let (mut clear, mut differ, mut flat, mut worst) = (0, 0, 0, 0.0f32);
        for cam in Camera::paper_views(SIZE, SIZE) {
            let image = render(&OctreeScene(&octree), &cam, &settings).expect("render");
            let normals = image.normals.as_ref().expect("normal mode keeps normals");
            for py in 0..SIZE {
                for px in 0..SIZE {
                    let (o, d) = cam.primary_ray(px, py);
                    let grown = analytic_hit(&planes, o, d, margin);
                    let shrunk = analytic_hit(&planes, o, d, -margin);
                    if grown.is_some() != shrunk.is_some() {
                        continue; // within the margin of the silhouette
                    }
                    clear += 1;
                    let n = normals[(py * SIZE + px) as usize];
                    let hit = n != Vec3::ZERO;
                    if hit != shrunk.is_some() {
                        differ += 1;
                        continue;
                    }
                    let Some((t, face)) = analytic_hit(&planes, o, d, 0.0) else {
                        continue;
                    };
                    let p = o + d * t;
                    let on_edge = planes
                        .iter()
                        .enumerate()
                        .any(|(k, m)| k != face && m.at(p) > -margin);
                    if !on_edge {
                        flat += 1;
                        worst = worst.max((n - planes[face].n).length());
                    }
                }
            }
        }
        println!(
            "depth {depth}: {differ} of {clear} clear pixels differ from the cube; normal \
             error {worst:.1e} on {flat} face pixels"
        );
        assert_eq!(differ, 0, "depth {depth}");
        assert!(flat > 10_000, "depth {depth}: {flat}");
        assert!(worst < 2e-4, "depth {depth}: {worst}");
    }
}
