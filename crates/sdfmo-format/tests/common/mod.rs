//! Generated leaves for the integration tests: shells of analytic shapes, like a builder's output.
#![allow(dead_code)]

use glam::Vec3;
use sdfmo_format::{cell_corners, cell_size, LeafInput, OctreeMeta, ValueBits, Voxel};

/// The leaves a builder would emit for two concentric-ish shapes close together: a sphere of
/// radius 0.6 (volume voxels) and a thin plate y = 0.05 (surface voxels); leaves touched by
/// both hold two voxels. Found by descending only into cells near either surface.
pub fn shell_leaves(depth: u8) -> Vec<LeafInput> {
    shape_leaves(depth, true)
}

/// The leaves of the sphere of [`shell_leaves`], with its plate only if `with_plate` (also the
/// `smo_sizes` example's input, which includes this file).
pub fn shape_leaves(depth: u8, with_plate: bool) -> Vec<LeafInput> {
    let sphere = |p: Vec3| p.length() - 0.6;
    let plate = |p: Vec3| p.y - 0.05;
    let mut out = Vec::new();
    let mut stack = vec![(0u8, [0u32; 3])];
    while let Some((level, c)) = stack.pop() {
        let h = cell_size(level);
        let center = Vec3::new(c[0] as f32 + 0.5, c[1] as f32 + 0.5, c[2] as f32 + 0.5) * h - 1.0;
        let reach = h * 0.87;
        let near_sphere = sphere(center).abs() <= reach;
        let near_plate = with_plate
            && plate(center).abs() <= reach
            && center.x.abs() < 0.8
            && center.z.abs() < 0.8;
        if !near_sphere && !near_plate {
            continue;
        }
        if level < depth {
            for o in 0..8u8 {
                stack.push((level + 1, sdfmo_format::child_coord(c, o)));
            }
            continue;
        }
        let mut voxels = Vec::new();
        if near_sphere {
            voxels.push(Voxel {
                corners: cell_corners(depth, c, sphere),
                surface: false,
                clip: false,
            });
        }
        if near_plate {
            voxels.push(Voxel {
                corners: cell_corners(depth, c, plate),
                surface: true,
                clip: false,
            });
        }
        out.push(LeafInput { coord: c, voxels });
    }
    out
}

/// `shell_leaves` with clip bits (a version-1.1 file): in leaves where the sphere and the plate
/// meet, the plate's surface voxel becomes clip-only in every other one; on every third leaf
/// (of the rest) the first voxel becomes an intersect voxel (volume + clip).
pub fn clipped_shell_leaves(depth: u8) -> Vec<LeafInput> {
    let mut leaves = shell_leaves(depth);
    let mut both = 0;
    for (i, l) in leaves.iter_mut().enumerate() {
        if l.voxels.len() == 2 {
            both += 1;
            if both % 2 == 0 {
                l.voxels[1].clip = true;
                continue;
            }
        }
        if i % 3 == 0 && !l.voxels[0].surface {
            l.voxels[0].clip = true;
        }
    }
    leaves
}

/// A meta with a non-trivial transform.
pub fn meta(depth: u8, bits: ValueBits) -> OctreeMeta {
    OctreeMeta {
        depth,
        bits,
        center: Vec3::new(0.25, -1.5, 7.0),
        scale: 0.75,
    }
}

/// Recomputes the trailing CRC-32 after a deliberate edit (a hostile file with a valid checksum).
pub fn reseal(bytes: &mut [u8]) {
    let n = bytes.len();
    if n >= 4 {
        let crc = sdfmo_format::crc32(&bytes[..n - 4]);
        bytes[n - 4..].copy_from_slice(&crc.to_le_bytes());
    }
}

/// Offset of a header field by name.
pub fn field(name: &str) -> usize {
    sdfmo_format::HEADER_FIELDS
        .iter()
        .find(|f| f.name == name)
        .expect("field")
        .offset
}
