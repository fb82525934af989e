//! Issue 19 item 8: a voxel whose corner codes are all 0 is never hit, as a volume, surface or
//! intersect voxel, and as a clip voxel it keeps everything (`FORMAT.md`, surface section: the
//! kernels' reading, now the specification's; the specification's "zero along the whole span"
//! clause used to hit an all-zero volume voxel at the cell entry). An octree with such voxels
//! added to every leaf, and leaves of them alone in empty cells, traces exactly as without
//! them: the same hits, distances and normals, bit for bit.

use glam::Vec3;
use sdfmo_format::testing::{pinhole_dirs, sphere_leaves, with_all_zero_voxels};
use sdfmo_format::{LeafInput, OctreeMeta, PackedOctree, ValueBits};
use sdfmo_trace::{hit_normal, intersect, Ray};

const DEPTH: u8 = 4;

/// The sphere of radius 0.6 as an SVO (one volume voxel per leaf where it crosses zero).
fn sphere() -> Vec<LeafInput> {
    sphere_leaves(DEPTH, 0.6)
}

fn octree(leaves: Vec<LeafInput>) -> PackedOctree {
    PackedOctree::from_leaves(OctreeMeta::unit(DEPTH, ValueBits::Eight), leaves).unwrap()
}

/// Rays from four eyes through a 64² grid each, and axis-parallel rays along cell faces.
fn rays() -> Vec<Ray> {
    let mut out = Vec::new();
    for eye in [
        Vec3::new(2.2, 1.6, 2.9),
        Vec3::new(-3.1, 0.7, 1.3),
        Vec3::new(0.4, -2.8, -2.2),
        Vec3::new(0.0, 0.0, 3.0),
    ] {
        out.extend(
            pinhole_dirs(eye, 64, 0.2)
                .into_iter()
                .map(|dir| Ray { origin: eye, dir }),
        );
    }
    for k in -8..=8 {
        // Along the cell faces x = k/8 (an all-zero voxel's face is in its zero set, too).
        out.push(Ray {
            origin: Vec3::new(k as f32 / 8.0, 0.05, -3.0),
            dir: Vec3::Z,
        });
    }
    out
}

#[test]
fn all_zero_voxels_are_never_hit() {
    let plain = octree(sphere());
    let rays = rays();
    let reference: Vec<_> = rays
        .iter()
        .map(|r| intersect(&plain, r, 0.0, f32::INFINITY).map(|h| (h.t, hit_normal(r, &h))))
        .collect();
    let hits = reference.iter().filter(|h| h.is_some()).count();
    assert!(hits > 4000, "{hits} hits");
    for (surface, clip, kind) in [
        (false, false, "volume"),
        (true, false, "surface"),
        (false, true, "intersect"),
        (true, true, "clip-only"),
    ] {
        let o = octree(with_all_zero_voxels(DEPTH, sphere(), surface, clip));
        assert!(o.voxel_count() > plain.voxel_count() + 100, "{kind}");
        assert_eq!(o.has_clip_voxels(), clip);
        for (r, want) in rays.iter().zip(&reference) {
            let got = intersect(&o, r, 0.0, f32::INFINITY).map(|h| (h.t, hit_normal(r, &h)));
            let bits = |h: &Option<(f32, Vec3)>| {
                h.map(|(t, n)| (t.to_bits(), n.to_array().map(f32::to_bits)))
            };
            assert_eq!(bits(&got), bits(want), "{kind} all-zero voxels, ray {r:?}");
        }
    }
}
