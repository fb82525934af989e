//! Clip voxels through the whole tracer (traversal, leaf rule, normals, occlusion, distances):
//!
//! * a rotated cube built by hand from *intersect* voxels (in every leaf the cube's face planes
//!   that cut it, one plane voxel each, combined by `max`) renders with the exact silhouette of
//!   the analytic cube and flat normals — where an SVO of the same cube (one trilinear voxel of
//!   the box distance per leaf) rounds its edges and corners;
//! * an open sheet whose leaves at the free edge hold a *clip-only* voxel stops exactly at the
//!   rim, where the plain surface voxel runs on to the end of its cell.

use glam::{Mat3, Vec3};
use sdfmo_format::testing::{
    analytic_hit, convex_leaves, cube_planes, leaves_by_cell, skew_cube, Plane,
};
use sdfmo_format::{
    cell_corners, cell_size, LeafInput, OctreeMeta, PackedOctree, ValueBits, Voxel,
};
use sdfmo_trace::{distance_at, hit_normal, intersect, occluded, Ray};

/// Pixels per side of the test images.
const SIZE: u32 = 96;

/// The test octrees: 16-bit, in the model frame.
fn meta(depth: u8) -> OctreeMeta {
    OctreeMeta::unit(depth, ValueBits::Sixteen)
}

/// The same solid as an SVO: one volume voxel per leaf, the exact box distance sampled at the
/// corners (trilinear rounds it at the edges), in the cells within a diagonal of the surface.
fn svo_leaves(depth: u8, rot: Mat3, c: Vec3, r: f32) -> Vec<LeafInput> {
    let sd = |p: Vec3| {
        let q = (rot.transpose() * (p - c)).abs() - Vec3::splat(r);
        q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
    };
    leaves_by_cell(depth, |coord| {
        let corners = cell_corners(depth, coord, sd);
        let (lo, hi) = corners
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        if lo <= 0.0 && hi > 0.0 {
            vec![Voxel {
                corners,
                surface: false,
                clip: false,
            }]
        } else {
            Vec::new()
        }
    })
}

/// Pinhole camera rays: `SIZE`² pixel centres, looking from `eye` at the origin.
fn camera_rays(eye: Vec3) -> Vec<Ray> {
    let fwd = (-eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    let tan_half = (0.5 * 40f32.to_radians()).tan();
    let mut rays = Vec::new();
    for py in 0..SIZE {
        for px in 0..SIZE {
            let u = (2.0 * (px as f32 + 0.5) / SIZE as f32 - 1.0) * tan_half;
            let v = (1.0 - 2.0 * (py as f32 + 0.5) / SIZE as f32) * tan_half;
            rays.push(Ray {
                origin: eye,
                dir: (fwd + u * right + v * up).normalize(),
            });
        }
    }
    rays
}

const EYES: [Vec3; 4] = [
    Vec3::new(2.2, 1.6, 2.9),
    Vec3::new(-3.1, 0.7, 1.3),
    Vec3::new(0.4, -2.8, -2.2),
    Vec3::new(1.9, 2.5, -2.0),
];

/// Mask mismatches against the analytic cube over the test views, counting only pixels whose
/// answer is the same for the cube grown and shrunk by `margin`; the normal error and the
/// depth error (across the face, relative to `h`) at the hits.
fn compare_with_cube(o: &PackedOctree, planes: &[Plane], margin: f32) -> (usize, usize, f32, f32) {
    let h = cell_size(o.depth());
    let (mut mismatched, mut clear, mut normal_err, mut depth_err) = (0, 0, 0.0f32, 0.0f32);
    for eye in EYES {
        for ray in camera_rays(eye) {
            let grown = analytic_hit(planes, ray.origin, ray.dir, margin);
            let shrunk = analytic_hit(planes, ray.origin, ray.dir, -margin);
            if grown.is_some() != shrunk.is_some() {
                continue; // within `margin` of the silhouette
            }
            clear += 1;
            let got = intersect(o, &ray, 0.0, f32::INFINITY);
            assert_eq!(got.is_some(), occluded(o, &ray, 0.0, f32::INFINITY));
            if got.is_some() != shrunk.is_some() {
                mismatched += 1;
                continue;
            }
            let (Some(hit), Some(_)) = (got, shrunk) else {
                continue;
            };
            let (t, face) = analytic_hit(planes, ray.origin, ray.dir, 0.0).unwrap();
            // Measured across the face (along a grazing ray a plane moved by δ moves the hit
            // by δ / |n·d|).
            depth_err = depth_err.max((hit.t - t).abs() * planes[face].n.dot(ray.dir).abs() / h);
            // Flat: the face's own normal, not a blend, unless the hit is on an edge.
            let p = ray.origin + ray.dir * t;
            let near_edge = planes
                .iter()
                .enumerate()
                .any(|(k, q)| k != face && q.at(p) > -margin);
            if !near_edge {
                let n = hit_normal(&ray, &hit);
                normal_err = normal_err.max((n - planes[face].n).length());
            }
        }
    }
    assert!(clear > EYES.len() * (SIZE * SIZE) as usize * 9 / 10);
    (mismatched, clear, normal_err, depth_err)
}

#[test]
fn a_cube_of_intersect_voxels_has_the_exact_silhouette_and_flat_normals() {
    let (rot, c, r) = skew_cube();
    let planes = cube_planes(rot, c, r);
    for depth in [3u8, 4, 5] {
        let h = cell_size(depth);
        let o = PackedOctree::from_leaves(meta(depth), convex_leaves(depth, &planes)).unwrap();
        assert!(o.has_clip_voxels() && o.voxel_count() > o.leaf_count());
        // Pixels more than 1e-4 leaf edges from the silhouette: all agree with the analytic
        // cube (16-bit corners move a plane by under 3e-5 edges).
        let (mismatched, clear, normal_err, depth_err) = compare_with_cube(&o, &planes, 1e-4 * h);
        println!(
            "depth {depth}: clip cube {mismatched} of {clear} clear pixels differ, normal error \
             {normal_err:.2e}, depth error {depth_err:.2e} edges"
        );
        assert_eq!(mismatched, 0, "depth {depth}");
        assert!(normal_err < 2e-4, "depth {depth}: {normal_err}");
        assert!(depth_err < 1e-4, "depth {depth}: {depth_err}");

        // The SVO of the same cube rounds the edges: many pixels differ even with a margin
        // of a tenth of a leaf.
        let svo = PackedOctree::from_leaves(meta(depth), svo_leaves(depth, rot, c, r)).unwrap();
        let (svo_mismatched, ..) = compare_with_cube(&svo, &planes, 0.1 * h);
        println!("depth {depth}: SVO cube {svo_mismatched} pixels differ by more than 0.1 leaf");
        assert!(svo_mismatched > 20, "depth {depth}: {svo_mismatched}");
    }
}

#[test]
fn distance_at_a_clip_leaf_is_the_max_of_its_intersect_voxels() {
    let (rot, c, r) = skew_cube();
    let planes = cube_planes(rot, c, r);
    let depth = 4;
    let o = PackedOctree::from_leaves(meta(depth), convex_leaves(depth, &planes)).unwrap();
    let h = cell_size(depth);
    let box_max = |p: Vec3| planes.iter().map(|q| q.at(p)).fold(f32::MIN, f32::max);
    let mut checked = 0;
    // Points near an edge and a corner of the cube (where leaves hold 2 and 3 planes), and on
    // a grid around the surface.
    for i in 0..4000 {
        let s = |k: u32| ((i * 7919 + k * 104729) % 1000) as f32 / 1000.0 - 0.5;
        let p = c + rot * Vec3::new(r + 0.3 * h * s(1), r + 0.3 * h * s(2), 2.0 * r * s(3));
        let Some(sample) = distance_at(&o, p) else {
            continue;
        };
        // In a leaf, the planes that do not cut it are ≤ 0 there: the max over the leaf's
        // planes is the max over all six.
        assert!(
            (sample.distance - box_max(p)).abs() < 1e-4 * h,
            "{p}: {} vs {}",
            sample.distance,
            box_max(p)
        );
        let active = planes
            .iter()
            .max_by(|a, b| a.at(p).total_cmp(&b.at(p)))
            .unwrap();
        if planes
            .iter()
            .filter(|q| (q.at(p) - active.at(p)).abs() < 1e-3 * h)
            .count()
            == 1
        {
            assert!((sample.gradient - active.n).length() < 1e-3, "{p}");
        }
        assert!(!sample.surface && o.voxel_is_clip(sample.voxel));
        checked += 1;
    }
    assert!(checked > 1000, "{checked}");
}

/// An open square sheet y = y0 for x ≤ rim (and |z| ≤ 0.5, on cell faces), one surface voxel per leaf; the
/// leaves that the rim x = rim crosses also hold a clip-only voxel `x − rim` when `clip`.
fn sheet_leaves(depth: u8, y0: f32, rim: f32, clip: bool) -> Vec<LeafInput> {
    let h = cell_size(depth);
    leaves_by_cell(depth, |coord| {
        let [x, y, z] = coord;
        let lo = Vec3::new(x as f32, y as f32, z as f32) * h - 1.0;
        let hi = lo + Vec3::splat(h);
        let crosses_sheet = lo.y < y0 && y0 < hi.y;
        let on_sheet = lo.x < rim && lo.z < 0.5 && hi.z > -0.5;
        if !crosses_sheet || !on_sheet {
            return Vec::new();
        }
        let mut voxels = vec![Voxel {
            corners: cell_corners(depth, coord, |p| p.y - y0),
            surface: true,
            clip: false,
        }];
        if clip && hi.x > rim {
            voxels.push(Voxel {
                corners: cell_corners(depth, coord, |p| p.x - rim),
                surface: true,
                clip: true,
            });
        }
        voxels
    })
}

#[test]
fn an_open_sheet_with_clip_only_voxels_stops_at_its_rim() {
    let (y0, rim) = (0.0371, 0.3127);
    for depth in [3u8, 4, 5] {
        let h = cell_size(depth);
        let clipped =
            PackedOctree::from_leaves(meta(depth), sheet_leaves(depth, y0, rim, true)).unwrap();
        let plain =
            PackedOctree::from_leaves(meta(depth), sheet_leaves(depth, y0, rim, false)).unwrap();
        assert!(clipped.has_clip_voxels() && !plain.has_clip_voxels());
        let (mut wrong, mut overshoot, mut hits) = (0, 0, 0);
        for eye in [Vec3::new(0.9, 2.7, 1.4), Vec3::new(-1.2, -2.5, 0.8)] {
            for ray in camera_rays(eye) {
                // The analytic sheet hit, and whether it is clearly inside or outside the rim.
                let t = (y0 - ray.origin.y) / ray.dir.y;
                let p = ray.origin + ray.dir * t;
                let on = t > 0.0 && p.z.abs() < 0.5 - 1e-3 && p.x > -1.0 + 1e-3;
                let keep = on && p.x < rim - 1e-4 * h;
                let off = t <= 0.0 || p.z.abs() > 0.5 + 1e-3 || p.x < -1.0 - 1e-3;
                let cut = off || (on && p.x > rim + 1e-4 * h);
                let got = intersect(&clipped, &ray, 0.0, f32::INFINITY);
                if let Some(hit) = got {
                    hits += 1;
                    assert!((hit.t - t).abs() < 1e-4 * h, "{} vs {t}", hit.t);
                    assert!(hit.surface && !clipped.voxel_is_clip(hit.voxel));
                    let n = hit_normal(&ray, &hit);
                    assert!((n.y.abs() - 1.0).abs() < 1e-5, "{n}");
                }
                if (keep && got.is_none()) || (cut && got.is_some()) {
                    wrong += 1;
                }
                if on
                    && p.x > rim + 1e-4 * h
                    && intersect(&plain, &ray, 0.0, f32::INFINITY).is_some()
                {
                    overshoot += 1;
                }
            }
        }
        println!(
            "depth {depth}: {hits} hits, {wrong} wrong with the rim clipped, {overshoot} \
             overshooting pixels without"
        );
        assert_eq!(wrong, 0, "depth {depth}");
        assert!(
            hits > 1000 && overshoot > 10,
            "depth {depth}: {hits} {overshoot}"
        );
    }
}

#[test]
fn octrees_without_clip_voxels_trace_as_before() {
    // The same leaves with the clip bit cleared on a cube whose leaves hold one plane each
    // trace identically (the bit only changes leaves with more than one voxel).
    let (rot, c, r) = skew_cube();
    let planes = cube_planes(rot, c, r);
    let depth = 4;
    let leaves = convex_leaves(depth, &planes);
    let single: Vec<LeafInput> = leaves
        .iter()
        .filter(|l| l.voxels.len() == 1)
        .cloned()
        .collect();
    let unclipped: Vec<LeafInput> = single
        .iter()
        .cloned()
        .map(|mut l| {
            l.voxels[0].clip = false;
            l
        })
        .collect();
    let a = PackedOctree::from_leaves(meta(depth), single).unwrap();
    let b = PackedOctree::from_leaves(meta(depth), unclipped).unwrap();
    assert!(a.has_clip_voxels() && !b.has_clip_voxels());
    for eye in EYES {
        for ray in camera_rays(eye) {
            assert_eq!(
                intersect(&a, &ray, 0.0, f32::INFINITY),
                intersect(&b, &ray, 0.0, f32::INFINITY)
            );
        }
    }
}
