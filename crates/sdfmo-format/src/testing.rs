//! Test octrees shared by the tests of several crates (feature `test-support`, enabled only in
//! their dev-dependencies, and in this crate's own tests): convex solids built by hand from
//! *intersect* voxels (format 1.1) and the analytic ray hit they must reproduce, the sphere's
//! SVO, the clip rule's worst-case leaf, and a pinhole camera's rays. Kept here, once, so the
//! tracer's, the renderer's, the GPU's and the command line's tests check the same solid the
//! same way.

use glam::{Mat3, Vec3};

use crate::{cell_corners, LeafInput, Voxel};

/// A plane `n·p − d` (negative inside, `n` unit): a distance, reproduced exactly by a voxel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit outward normal.
    pub n: Vec3,
    /// Offset along `n`: the plane is `n·p = d`.
    pub d: f32,
}

impl Plane {
    /// The signed distance `n·p − d`.
    pub fn at(&self, p: Vec3) -> f32 {
        self.n.dot(p) - self.d
    }
}

/// The cube of half-edge `r`, rotated by `rot`, centred at `c`: its six face planes, in the
/// order +x, −x, +y, −y, +z, −z of the rotated axes.
pub fn cube_planes(rot: Mat3, c: Vec3, r: f32) -> [Plane; 6] {
    core::array::from_fn(|k| {
        let axis = rot.col(k / 2);
        let n = if k % 2 == 0 { axis } else { -axis };
        Plane { n, d: n.dot(c) + r }
    })
}

/// The convex solid ⋂ `planes` in the leaf cell `coord` at `depth`, as intersect voxels: the
/// planes that cut the cell (a plane whose corners are all ≤ 0 there is redundant; one whose
/// corners are all > 0 leaves the cell empty, and then no voxel is returned).
pub fn convex_cell_voxels(depth: u8, coord: [u32; 3], planes: &[Plane]) -> Vec<Voxel> {
    let mut voxels = Vec::new();
    for p in planes {
        let corners = cell_corners(depth, coord, |q| p.at(q));
        if corners.iter().all(|&v| v > 0.0) {
            return Vec::new();
        }
        if corners.iter().any(|&v| v > 0.0) {
            voxels.push(Voxel {
                corners,
                surface: false,
                clip: true,
            });
        }
    }
    voxels
}

/// The leaves at `depth` with the voxels `voxels(coord)` gives each cell, in the order x, y, z
/// (outermost first); cells given no voxel are not stored.
pub fn leaves_by_cell(depth: u8, mut voxels: impl FnMut([u32; 3]) -> Vec<Voxel>) -> Vec<LeafInput> {
    let n = 1u32 << depth;
    let mut out = Vec::new();
    for x in 0..n {
        for y in 0..n {
            for z in 0..n {
                let coord = [x, y, z];
                let voxels = voxels(coord);
                if !voxels.is_empty() {
                    out.push(LeafInput { coord, voxels });
                }
            }
        }
    }
    out
}

/// [`convex_cell_voxels`] over every leaf cell at `depth`; cells cut by no plane are inside or
/// outside: not stored.
pub fn convex_leaves(depth: u8, planes: &[Plane]) -> Vec<LeafInput> {
    leaves_by_cell(depth, |coord| convex_cell_voxels(depth, coord, planes))
}

/// The analytic entry of the ray `origin + t·dir` (t ≥ 0) into the convex solid ⋂ `planes`
/// grown by `grow` (in distance units), slab by slab: (t, index of the entry plane; `usize::MAX`
/// when the ray starts inside).
pub fn analytic_hit(planes: &[Plane], origin: Vec3, dir: Vec3, grow: f32) -> Option<(f32, usize)> {
    let (mut t_in, mut t_out, mut entry) = (0.0f32, f32::INFINITY, usize::MAX);
    for (k, p) in planes.iter().enumerate() {
        let (f0, df) = (p.at(origin) - grow, p.n.dot(dir));
        if df == 0.0 {
            if f0 > 0.0 {
                return None;
            }
            continue;
        }
        let t = -f0 / df;
        if df < 0.0 {
            if t > t_in {
                t_in = t;
                entry = k;
            }
        } else {
            t_out = t_out.min(t);
        }
    }
    (t_in <= t_out).then_some((t_in, entry))
}

/// The tests' cube: rotated about a skew axis, off centre, half-edge chosen so that its faces
/// and edges lie inside leaf cells (rotation, centre, half-edge).
pub fn skew_cube() -> (Mat3, Vec3, f32) {
    let rot = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.6);
    (rot, Vec3::new(0.031, -0.047, 0.023), 0.513)
}

/// The sphere of radius `r` about the origin as an SVO at `depth`: one volume voxel sampling
/// `|p| − r` in every leaf cell whose corners straddle zero (some ≤ 0, some > 0).
pub fn sphere_leaves(depth: u8, r: f32) -> Vec<LeafInput> {
    leaves_by_cell(depth, |coord| {
        let c = cell_corners(depth, coord, |p| p.length() - r);
        if c.iter().any(|&v| v <= 0.0) && c.iter().any(|&v| v > 0.0) {
            vec![Voxel {
                corners: c,
                surface: false,
                clip: false,
            }]
        } else {
            Vec::new()
        }
    })
}

/// The 255 volume voxels of a leaf at `depth` that make the clip rule's worst case, the last
/// `clips` with the clip bit: voxels 0..254 are the plane `x = 0.49` (local cell coordinates,
/// inside below), voxel 254 the plane `x = 0.51` (inside above). The solid the clip rule makes
/// of them is empty, and every candidate of a voxel passes every clip voxel but the last one,
/// which rejects it. `clips` above [`MAX_CLIP_VOXELS_PER_LEAF`](crate::MAX_CLIP_VOXELS_PER_LEAF)
/// is a leaf the writer refuses.
pub fn clip_flood_voxels(depth: u8, clips: usize) -> Vec<Voxel> {
    const VOXELS: usize = 255;
    let h = crate::cell_size(depth);
    (0..VOXELS)
        .map(|k| Voxel {
            corners: core::array::from_fn(|i| {
                let x = (i >> 2) as f32;
                h * if k == VOXELS - 1 { 0.51 - x } else { x - 0.49 }
            }),
            surface: false,
            clip: k >= VOXELS - clips,
        })
        .collect()
}

/// The unit directions of a `side`² pinhole camera at `eye` looking at the origin (up +y),
/// spread `spread` at the image's edge, row by row from the bottom: the primary rays the
/// tracer's tests shoot.
pub fn pinhole_dirs(eye: Vec3, side: u32, spread: f32) -> Vec<Vec3> {
    let fwd = (-eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    let half = side as f32 / 2.0;
    let mut out = Vec::new();
    for py in 0..side {
        for px in 0..side {
            let u = (px as f32 + 0.5) / half - 1.0;
            let v = (py as f32 + 0.5) / half - 1.0;
            out.push((fwd + spread * (u * right + v * up)).normalize());
        }
    }
    out
}

/// Issue 19 item 8: `leaves` (at `depth`) with a voxel whose corners are all 0, of the kind
/// `surface`/`clip`, appended to every leaf, plus a leaf of such a voxel alone in every empty
/// cell whose coordinates have an even sum (not for clip-only voxels, which cannot fill a leaf
/// alone). `FORMAT.md`: an all-zero voxel is never hit and, as a clip voxel, keeps everything
/// (`0 ≤ 0`), so the result must trace exactly as `leaves` does.
pub fn with_all_zero_voxels(
    depth: u8,
    leaves: Vec<LeafInput>,
    surface: bool,
    clip: bool,
) -> Vec<LeafInput> {
    let zero = Voxel {
        corners: [0.0; 8],
        surface,
        clip,
    };
    let mut by_coord: std::collections::HashMap<[u32; 3], Vec<Voxel>> =
        leaves.into_iter().map(|l| (l.coord, l.voxels)).collect();
    leaves_by_cell(depth, |coord| match by_coord.remove(&coord) {
        Some(mut voxels) => {
            voxels.push(zero);
            voxels
        }
        None if !(surface && clip) && (coord[0] + coord[1] + coord[2]) % 2 == 0 => vec![zero],
        None => Vec::new(),
    })
}
