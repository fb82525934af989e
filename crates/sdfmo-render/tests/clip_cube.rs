//! A cube built by hand from *intersect* voxels (format 1.1: in every leaf the cube's face
//! planes that cut it, one plane voxel each, combined by `max`), rendered by the octree renderer
//! on the paper views: the silhouette is the analytic cube's (no pixel differs except within
//! 1e-4 leaf of the silhouette) and the faces are flat (every pixel away from an edge has its
//! face's normal).

use glam::{Mat3, Vec3};
use sdfmo_format::{LeafInput, OctreeMeta, PackedOctree, ValueBits, Voxel};
use sdfmo_render::{render, Camera, Mode, OctreeScene, RenderSettings};

/// Image side.
const SIZE: u32 = 160;

/// The face planes `(n, d)` (inside `n·p ≤ d`) of the cube of half-edge `r` at `c`, rotated.
fn cube_planes(rot: Mat3, c: Vec3, r: f32) -> Vec<(Vec3, f32)> {
    (0..6)
        .map(|k| {
            let axis = rot.col(k / 2);
            let n = if k % 2 == 0 { axis } else { -axis };
            (n, n.dot(c) + r)
        })
        .collect()
}

/// In each leaf, the planes that cut it as intersect voxels (the others are all ≤ 0 there and
/// redundant, or all > 0 and the leaf is empty).
fn cube_octree(depth: u8, planes: &[(Vec3, f32)]) -> PackedOctree {
    let n = 1u32 << depth;
    let h = 2.0 / n as f32;
    let mut leaves = Vec::new();
    for x in 0..n {
        for y in 0..n {
            for z in 0..n {
                let lo = Vec3::new(x as f32, y as f32, z as f32) * h - 1.0;
                let mut voxels = Vec::new();
                let mut outside = false;
                for &(normal, d) in planes {
                    let corners: [f32; 8] = core::array::from_fn(|i| {
                        let o = Vec3::new((i >> 2) as f32, ((i >> 1) & 1) as f32, (i & 1) as f32);
                        normal.dot(lo + o * h) - d
                    });
                    if corners.iter().all(|&v| v > 0.0) {
                        outside = true;
                    } else if corners.iter().any(|&v| v > 0.0) {
                        voxels.push(Voxel {
                            corners,
                            surface: false,
                            clip: true,
                        });
                    }
                }
                if !outside && !voxels.is_empty() {
                    leaves.push(LeafInput {
                        coord: [x, y, z],
                        voxels,
                    });
                }
            }
        }
    }
    let meta = OctreeMeta {
        depth,
        bits: ValueBits::Sixteen,
        center: Vec3::ZERO,
        scale: 1.0,
    };
    PackedOctree::from_leaves(meta, leaves).expect("cube octree")
}

/// The ray's entry into the cube grown by `grow`: (t, entry face).
fn analytic_hit(planes: &[(Vec3, f32)], o: Vec3, d: Vec3, grow: f32) -> Option<(f32, usize)> {
    let (mut t_in, mut t_out, mut face) = (0.0f32, f32::INFINITY, usize::MAX);
    for (k, &(n, dist)) in planes.iter().enumerate() {
        let (f0, df) = (n.dot(o) - dist - grow, n.dot(d));
        if df == 0.0 {
            if f0 > 0.0 {
                return None;
            }
            continue;
        }
        let t = -f0 / df;
        if df < 0.0 {
            if t > t_in {
                (t_in, face) = (t, k);
            }
        } else {
            t_out = t_out.min(t);
        }
    }
    (t_in <= t_out).then_some((t_in, face))
}

#[test]
fn a_cube_of_intersect_voxels_renders_sharp_and_flat() {
    let rot = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.6);
    let planes = cube_planes(rot, Vec3::new(0.031, -0.047, 0.023), 0.513);
    for depth in [4u8, 6] {
        let octree = cube_octree(depth, &planes);
        assert!(octree.has_clip_voxels());
        let margin = 1e-4 * 2.0 / (1u32 << depth) as f32;
        let settings = RenderSettings {
            mode: Mode::Normal,
            shadows: false,
            ao_samples: 0,
            threads: Some(2),
        };
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
                        .any(|(k, &(m, dist))| k != face && m.dot(p) - dist > -margin);
                    if !on_edge {
                        flat += 1;
                        worst = worst.max((n - planes[face].0).length());
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
