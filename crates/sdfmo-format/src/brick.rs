//! Format 3.0: the leaves of a 1.x octree regrouped into bricks of 4³ cells whose volume voxels
//! share their corner codes, each code stored once as a residual of a per-brick plane
//! (`FORMAT.md`, section "Bricks (version 3.0)"; the design and its measurements:
//! `docs/format-3.md`).
//!
//! [`BrickOctree::encode`] writes a 1.x octree as 3.0 bytes, losslessly: every voxel's eight
//! codes and flags read back as the 1.x file has them. [`BrickOctree::new`] validates bytes once
//! (every count, offset, mask, width and code) and reads them in place, owned or borrowed
//! ([`BrickOctreeView`]), as [`Octree`] does for 1.x.
//!
//! # Traversal
//!
//! A tracer walks [`BrickNode`]s: the node groups above the bricks as in 1.x
//! ([`BrickNode::Upper`]), then inside a brick its two lowest levels from the brick's 64-bit
//! occupancy alone: the child mask of a brick is which bytes of the occupancy are non-zero,
//! that of a half-brick node ([`BrickNode::Half`]) is one byte of it. A leaf
//! ([`BrickOctree::leaf`]) is either *shared* (one volume voxel whose corners are points of
//! the brick's grid: eight masked popcounts of a 125-bit mask give their ranks) or *private*
//! (voxels stored whole, found through a 1.x-style leaf group: one popcount and one byte sum).
//! Every step is a fixed number of loads and popcounts: what a GPU kernel does in `u32` words.
//!
//! # 3.1
//!
//! The writer's minor version 1 stores a private leaf's voxels *narrow* when they are close to
//! trilinear (four base codes and four mixed differences in half-width fields: `6·b` bytes
//! instead of `8·b`), and groups private leaves by 16 with a count of the wide voxels before
//! each group ([`crate::narrow`]'s module docs; `FORMAT.md`, "Narrow private voxels (version
//! 3.1)"). The reader takes both minors.

use std::fmt;

use crate::crc32::crc32;
use crate::error::{corrupt, FormatError, Result};
use crate::header::record::{FIRST_PRIVATE_LEAF, OCCUPANCY, PLANE, PRIVATE, RESIDUALS};
use crate::header::{
    align8, octree_header, plane_fraction_bits, private_group_leaves, private_group_size,
    residual_widths, BrickRecord, Counts, V3Header, BRICK_LEVELS, BRICK_RECORD_SIZE, CHECKSUM_SIZE,
    FLAG_CLIP_VOXELS, FLAG_MULTI_VOXEL, FLAG_SURFACE_VOXELS, KNOWN_FLAGS, MAGIC,
    RESIDUAL_OFFSET_BITS, RESIDUAL_OFFSET_MASK, V31_MAX_LEAF_VOXELS, V3_HEADER_SIZE,
    V3_VERSION_MAJOR, V3_VERSION_MINOR,
};
use crate::narrow::{
    corner_offset, fits_narrow, private_codes, private_leaf_at, put_private, slots, WIDE_BIT,
};
use crate::octree::{
    bytes_at, group_at, inner_levels, low_bits, put_group, to_u32, write_node_groups,
};
use crate::quant::{dequant_scale, max_code};
use crate::validate::{
    check_codes, check_grid, check_magic, check_major, check_sizes, validate_node_groups,
    walk_groups,
};
use crate::{
    morton, LeafInput, NodeRef, Octree, OctreeMeta, PackedOctree, ValueBits, Voxel,
    MAX_CLIP_VOXELS_PER_LEAF, MAX_DEPTH,
};

/// Grid-index offsets of a cell's eight corners (`4x + 2y + z`) in a brick's 5³ point grid
/// (point `(x, y, z)` has index `25x + 5y + z`).
pub const CORNER_POINT_OFFSETS: [u32; 8] = [0, 1, 5, 6, 25, 26, 30, 31];

/// The grid index (`25x + 5y + z`) of the lowest corner of the brick cell with Morton index
/// `cell` (0..64: octant of the half-brick in bits 3–5, octant in it in bits 0–2).
#[inline]
pub const fn cell_grid_index(cell: u32) -> u32 {
    let (hi, lo) = (cell >> 3, cell & 7);
    let x = (hi >> 2 & 1) * 2 + (lo >> 2 & 1);
    let y = (hi >> 1 & 1) * 2 + (lo >> 1 & 1);
    let z = (hi & 1) * 2 + (lo & 1);
    25 * x + 5 * y + z
}

/// The points of a brick whose shared cells are `shared` (Morton bits): the union of their
/// corners in the 5³ grid (bit `25x + 5y + z`), i.e. the cells placed in the grid and dilated
/// by one along +x, +y and +z. A point's rank among them is a popcount below its bit.
// Always inlined: the tracer computes it per shared voxel fetch, and a call cost 6 % of a
// frame (callgrind, abc1 depth 9 multi, paper view 0). One table load per half-brick
// ([`HALF_POINTS`]) instead of spreading the cells and dilating them: 3 % fewer instructions
// per 3.1 frame (abc1 / abc5 depth 9 multi, paper view 0: 219.3 → 212.8 M, 308.8 → 299.6 M).
#[inline(always)]
pub fn point_mask(shared: u64) -> u128 {
    let mut points = 0u128;
    for half in 0..8u32 {
        let m = (shared >> (8 * half)) as usize & 0xff;
        points |= u128::from(HALF_POINTS[m]) << cell_grid_index(half << 3);
    }
    points
}

/// `HALF_POINTS[m]`: the points (bit `25x + 5y + z` from the half-brick's lowest point, so
/// within 63 bits) of the cells `m` (Morton bits) of one half-brick.
const HALF_POINTS: [u64; 256] = {
    let mut t = [0u64; 256];
    let mut m = 0;
    while m < 256 {
        let mut cell = 0;
        while cell < 8 {
            if m >> cell & 1 != 0 {
                let g = cell_grid_index(cell);
                let mut k = 0;
                while k < 8 {
                    t[m] |= 1 << (g + CORNER_POINT_OFFSETS[k]);
                    k += 1;
                }
            }
            cell += 1;
        }
        m += 1;
    }
    t
};

/// Points of `mask` below grid index `g`.
#[inline]
pub(crate) fn rank_below(mask: u128, g: u32) -> u32 {
    (mask & ((1u128 << g) - 1)).count_ones()
}

/// The code the plane `[a, b, c, d]` (in 1/2^f code units) predicts at brick point
/// `(x, y, z)`: `clamp(floor((a + b·x + c·y + d·z + 2^f / 2) / 2^f), −Q, Q)`.
#[inline]
pub fn plane_predict(plane: [i16; 4], p: [u32; 3], bits: ValueBits) -> i32 {
    let f = plane_fraction_bits(bits);
    let t = i32::from(plane[0])
        + i32::from(plane[1]) * p[0] as i32
        + i32::from(plane[2]) * p[1] as i32
        + i32::from(plane[3]) * p[2] as i32;
    let q = max_code(bits);
    ((t + ((1 << f) >> 1)) >> f).clamp(-q, q)
}

/// `x` taken modulo 2^bits as a two's complement value (how a full-width residual wraps).
#[inline]
pub(crate) fn wrap(x: i32, bits: ValueBits) -> i32 {
    match bits {
        ValueBits::Eight => i32::from(x as i8),
        ValueBits::Sixteen => i32::from(x as i16),
    }
}

/// The `w`-bit residual of point `rank` in `res` (a brick's residual bytes, LSB first),
/// sign-extended. `w` is 0, 2, 4, 8 or 16; fields never straddle a byte below 16 bits.
#[inline]
pub(crate) fn residual_at(res: &[u8], rank: u32, w: u32) -> i32 {
    match w {
        0 => 0,
        16 => i32::from(i16::from_le_bytes(bytes_at::<2>(res, 2 * rank as usize))),
        _ => {
            let bit = rank * w;
            let field = u32::from(res[(bit >> 3) as usize]) >> (bit & 7) & ((1 << w) - 1);
            // Sign-extend the w-bit field.
            ((field << (32 - w)) as i32) >> (32 - w)
        }
    }
}

/// Point `(x, y, z)` of grid index `g`.
#[inline]
pub(crate) fn grid_point(g: u32) -> [u32; 3] {
    [g / 25, g / 5 % 5, g % 5]
}

/// A brick record as read (the fields a traversal needs).
#[derive(Clone, Copy, Debug)]
struct Brick {
    occupancy: u64,
    private: u64,
    plane: [i16; 4],
    residuals: u32,
    first_private_leaf: u32,
}

impl Brick {
    #[inline]
    fn read(b: &[u8], at: usize) -> Brick {
        let r = bytes_at::<BRICK_RECORD_SIZE>(b, at);
        let u64_at = |o: usize| u64::from_le_bytes(bytes_at::<8>(&r, o));
        let u32_at = |o: usize| u32::from_le_bytes(bytes_at::<4>(&r, o));
        let p = bytes_at::<8>(&r, PLANE);
        Brick {
            occupancy: u64_at(OCCUPANCY),
            private: u64_at(PRIVATE),
            plane: std::array::from_fn(|i| i16::from_le_bytes([p[2 * i], p[2 * i + 1]])),
            residuals: u32_at(RESIDUALS),
            first_private_leaf: u32_at(FIRST_PRIVATE_LEAF),
        }
    }

    #[inline]
    fn shared(&self) -> u64 {
        self.occupancy & !self.private
    }

    #[inline]
    fn residual_offset(&self) -> usize {
        (self.residuals & RESIDUAL_OFFSET_MASK) as usize
    }

    #[inline]
    fn width(&self, bits: ValueBits) -> u32 {
        residual_widths(bits)[(self.residuals >> RESIDUAL_OFFSET_BITS) as usize]
    }
}

impl From<BrickRecord> for Brick {
    fn from(r: BrickRecord) -> Brick {
        Brick {
            occupancy: r.occupancy,
            private: r.private,
            plane: [r.plane_a, r.plane_b, r.plane_c, r.plane_d],
            residuals: r.residuals,
            first_private_leaf: r.first_private_leaf,
        }
    }
}

/// The counts a 3.0 header declares.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct V3Counts {
    /// The counts a 1.x file would declare, its inner nodes being the upper nodes (the inner
    /// nodes above the bricks).
    pub(crate) tree: Counts,
    /// Bricks.
    pub(crate) bricks: u32,
    /// Leaves with private corners.
    pub(crate) private_leaves: u32,
    /// Their voxels.
    pub(crate) private_voxels: u32,
    /// Minor version: 0 (every private voxel wide, groups of 8) or 1 (groups of 16).
    pub(crate) minor: u16,
    /// Wide private voxels (all of them in 3.0); in 3.1 implied by the private corners' size.
    pub(crate) wide_voxels: u32,
}

impl V3Counts {
    /// The counts `h` declares (not yet checked against anything but the minor version, and
    /// in 3.1 that the private corners' size is `6·b·W + 2·b·X` for some `X ≤ W`: the wide
    /// voxels).
    fn declared_by(h: &V3Header, bits: ValueBits) -> Result<V3Counts> {
        if h.version_minor > V3_VERSION_MINOR {
            return Err(FormatError::UnsupportedVersion {
                major: h.version_major,
                minor: h.version_minor,
                supported: V3_VERSION_MAJOR,
            });
        }
        let w = u64::from(h.private_voxel_count);
        let unit = 2 * bits.bytes() as u64;
        let wide_voxels = if h.version_minor == 0 {
            h.private_voxel_count
        } else {
            let narrow = 3 * unit * w;
            let extra = h.private_corners_size.checked_sub(narrow);
            match extra {
                Some(x) if x % unit == 0 && x / unit <= w => (x / unit) as u32,
                _ => {
                    return corrupt(
                        "private_corners_size",
                        format!(
                            "{} is not {narrow} + {unit}·(wide voxels ≤ {w})",
                            h.private_corners_size
                        ),
                    )
                }
            }
        };
        Ok(V3Counts {
            minor: h.version_minor,
            wide_voxels,
            tree: Counts {
                inner: h.upper_node_count,
                leaves: h.leaf_count,
                voxels: h.voxel_count,
                surface: h.surface_voxel_count,
                clip: h.clip_voxel_count,
            },
            bricks: h.brick_count,
            private_leaves: h.private_leaf_count,
            private_voxels: h.private_voxel_count,
        })
    }

    fn flags(&self) -> u32 {
        self.tree.flags()
    }
}

/// Where every section of a 3.0 file sits: `(offset, size)`, each at a multiple of 8.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct V3Layout {
    nodes: (u64, u64),
    pub(crate) bricks: (u64, u64),
    pub(crate) residuals: (u64, u64),
    pub(crate) private_leaves: (u64, u64),
    pub(crate) private_flags: (u64, u64),
    pub(crate) private_corners: (u64, u64),
    checksum_offset: u64,
    pub(crate) file_size: u64,
}

impl V3Layout {
    /// The layout of a file with these counts and `residual_bytes` of residuals (u64 sums of
    /// u32 counts and a residual size ≤ the file's length: no overflow).
    fn new(header_size: u64, c: &V3Counts, residual_bytes: u64, bits: ValueBits) -> V3Layout {
        let sizes = [
            u64::from(c.tree.inner).div_ceil(8) * 12,
            u64::from(c.bricks) * BRICK_RECORD_SIZE as u64,
            residual_bytes,
            u64::from(c.private_leaves).div_ceil(private_group_leaves(c.minor) as u64)
                * private_group_size(c.minor) as u64,
            // Two flag bits per private voxel, in whole 64-bit words.
            u64::from(c.private_voxels).div_ceil(32) * 8,
            // 6·b bytes per private voxel and 2·b more per wide one (3.0: all wide).
            (3 * u64::from(c.private_voxels) + u64::from(c.wide_voxels)) * 2 * bits.bytes() as u64,
        ];
        let mut at = align8(header_size);
        let mut s = [(0u64, 0u64); 6];
        for (slot, size) in s.iter_mut().zip(sizes) {
            *slot = (at, size);
            at = align8(at + size);
        }
        V3Layout {
            nodes: s[0],
            bricks: s[1],
            residuals: s[2],
            private_leaves: s[3],
            private_flags: s[4],
            private_corners: s[5],
            checksum_offset: at,
            file_size: at + CHECKSUM_SIZE as u64,
        }
    }

    /// `(offset, size)` of nodes, bricks, residuals, private leaves, private flags and private
    /// corners, in file order.
    pub(crate) fn sections(&self) -> [(u64, u64); 6] {
        [
            self.nodes,
            self.bricks,
            self.residuals,
            self.private_leaves,
            self.private_flags,
            self.private_corners,
        ]
    }
}

/// The header fields of the sections' offsets, in file order (as [`V3Layout::sections`]): what
/// a reader names when a section is not where the counts place it.
const SECTION_OFFSET_FIELDS: [&str; 6] = [
    "nodes_offset",
    "bricks_offset",
    "residuals_offset",
    "private_leaves_offset",
    "private_flags_offset",
    "private_corners_offset",
];

impl V3Header {
    /// `(offset, size)` of every section as the header declares them, in file order (as
    /// [`V3Layout::sections`]).
    fn sections(&self) -> [(u64, u64); 6] {
        [
            (self.nodes_offset, self.nodes_size),
            (self.bricks_offset, self.bricks_size),
            (self.residuals_offset, self.residuals_size),
            (self.private_leaves_offset, self.private_leaves_size),
            (self.private_flags_offset, self.private_flags_size),
            (self.private_corners_offset, self.private_corners_size),
        ]
    }
}

/// A validated 3.0 brick file in a buffer `B`, read in place (see the module docs).
///
/// Made only by [`BrickOctree::encode`] or [`BrickOctree::new`], so every index a traversal
/// derives from it is in bounds; the accessors still bounds-check and panic on a node or leaf
/// from another octree. Two brick octrees are equal when their bytes are.
#[derive(Clone, Copy)]
pub struct BrickOctree<B = Vec<u8>> {
    bytes: B,
    meta: OctreeMeta,
    /// The validated header's counts (the tracer's queries bound their indices by them).
    pub(crate) counts: V3Counts,
    /// Where the sections are (the tracer's queries read them in place).
    pub(crate) layout: V3Layout,
    dequant: f32,
}

/// A brick octree over borrowed bytes (zero copy).
pub type BrickOctreeView<'a> = BrickOctree<&'a [u8]>;

/// A node of a [`BrickOctree`], as a traversal walks it. Cheap to copy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BrickNode {
    /// A node above the bricks (levels `0 … depth − 3`): its breadth-first index, as in 1.x.
    Upper(u32),
    /// A brick (level `depth − 2`, 4³ leaf cells): its index in Morton order.
    Brick(u32),
    /// A half-brick node (level `depth − 1`, 2³ leaf cells): its brick and octant in it.
    Half {
        /// The brick.
        brick: u32,
        /// Octant in the brick (`4x + 2y + z`).
        octant: u8,
    },
    /// A leaf (level `depth`): its brick and the cell's Morton index in it (0..64).
    Leaf {
        /// The brick.
        brick: u32,
        /// Morton index of the cell in the brick: half-brick octant · 8 + octant.
        cell: u8,
    },
}

/// A leaf found in a [`BrickOctree`]: where its voxels are. Cheap to copy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BrickLeaf {
    brick: u32,
    cell: u8,
    /// Voxels of a private leaf (1..=255); 0 for a shared leaf (one volume voxel).
    count: u8,
    /// Index of the private leaf's first private voxel (0 for a shared leaf).
    first_voxel: u32,
    /// Wide private voxels before the leaf's first (0 for a shared leaf).
    wide_before: u32,
    /// Whether the private leaf's voxels are stored whole (3.0: always).
    wide: bool,
}

impl BrickLeaf {
    /// The leaf's brick.
    #[inline]
    pub fn brick(&self) -> u32 {
        self.brick
    }

    /// Morton index of the leaf's cell in its brick (0..64).
    #[inline]
    pub fn cell(&self) -> u8 {
        self.cell
    }

    /// Whether the leaf is shared: one volume voxel (not surface, not clip) whose corners are
    /// points of its brick.
    #[inline]
    pub fn is_shared(&self) -> bool {
        self.count == 0
    }

    /// The number of voxels (1 for a shared leaf).
    #[inline]
    pub fn voxel_count(&self) -> u32 {
        u32::from(self.count.max(1))
    }

    /// Index of the first private voxel of a private leaf (`None` for a shared one): its
    /// voxels are `first .. first + voxel_count()` of the private sections.
    #[inline]
    pub fn first_private_voxel(&self) -> Option<u32> {
        (self.count > 0).then_some(self.first_voxel)
    }
}

/// What a brick's residual width costs (for the encoder's choice).
pub(crate) fn fits(residuals: &[i32], w: u32) -> bool {
    match w {
        0 => residuals.iter().all(|&r| r == 0),
        _ => {
            let half = 1i32 << (w - 1);
            residuals.iter().all(|&r| (-half..half).contains(&r))
        }
    }
}

/// The least-squares plane through `(brick point, code)` samples (codes at ±`Q` are clamped
/// and left out) in 1/2^[`plane_fraction_bits`](crate::plane_fraction_bits) code units,
/// rounded and clamped to `i16`: the plane the encoder starts from (it may then move it by
/// whole codes, see [`BrickOctree::encode`]). The `brick_estimate` example sized the design
/// with it.
pub fn fit_brick_plane(samples: &[([u32; 3], i32)], bits: ValueBits) -> [i16; 4] {
    let q = max_code(bits);
    let mut ata = [[0f64; 4]; 4];
    let mut atb = [0f64; 4];
    for (p, code) in samples.iter().filter(|(_, c)| c.abs() < q) {
        let row = [1.0, f64::from(p[0]), f64::from(p[1]), f64::from(p[2])];
        for i in 0..4 {
            atb[i] += row[i] * f64::from(*code);
            for j in 0..4 {
                ata[i][j] += row[i] * row[j];
            }
        }
    }
    for (i, r) in ata.iter_mut().enumerate() {
        r[i] += 1e-6; // a brick whose points are all clamped or collinear still solves
    }
    // Gauss-Jordan on the 4×4 normal equations (symmetric positive definite).
    for i in 0..4 {
        let pivot = ata[i][i];
        for v in ata[i].iter_mut() {
            *v /= pivot;
        }
        atb[i] /= pivot;
        let (pivot_row, pivot_rhs) = (ata[i], atb[i]);
        for (k, (row, rhs)) in ata.iter_mut().zip(atb.iter_mut()).enumerate() {
            if k != i {
                let f = row[i];
                for (v, p) in row.iter_mut().zip(pivot_row) {
                    *v -= f * p;
                }
                *rhs -= f * pivot_rhs;
            }
        }
    }
    let unit = f64::from(1u32 << plane_fraction_bits(bits));
    atb.map(|c| {
        (c * unit)
            .round()
            .clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
    })
}

/// The plane, width code and residuals (in point order) that store `samples` losslessly with
/// the fewest bits: the least-squares plane, then the same plane moved by whole codes so its
/// residuals are centred, whichever needs the narrower width (the first on a tie).
pub(crate) fn encode_points(
    samples: &[([u32; 3], i32)],
    bits: ValueBits,
) -> ([i16; 4], u32, Vec<i32>) {
    let residuals = |plane: [i16; 4]| -> Vec<i32> {
        samples
            .iter()
            .map(|&(p, c)| wrap(c - plane_predict(plane, p, bits), bits))
            .collect()
    };
    let width_code = |r: &[i32]| -> u32 {
        let widths = residual_widths(bits);
        // The last width always fits: its residuals wrap (`wrap`).
        (0..3).find(|&k| fits(r, widths[k])).unwrap_or(3) as u32
    };
    let plane = fit_brick_plane(samples, bits);
    let r = residuals(plane);
    let code = width_code(&r);
    if code == 0 {
        return (plane, code, r);
    }
    let (lo, hi) = (
        r.iter().copied().min().unwrap_or(0),
        r.iter().copied().max().unwrap_or(0),
    );
    let shift = (lo + hi).div_euclid(2) + (lo + hi).rem_euclid(2);
    let mut moved = plane;
    let a = i32::from(plane[0]) + (shift << plane_fraction_bits(bits));
    moved[0] = a.clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16;
    let r2 = residuals(moved);
    let code2 = width_code(&r2);
    if code2 < code {
        (moved, code2, r2)
    } else {
        (plane, code, r)
    }
}

/// A brick's shared points (`points[25x + 5y + z]`, the codes its shared leaves put there) as
/// `(point, code)` samples in grid order: what its plane and residuals are made from.
fn point_samples(points: &[Option<i32>; 125]) -> Vec<([u32; 3], i32)> {
    (0..125u32)
        .filter_map(|g| points[g as usize].map(|c| (grid_point(g), c)))
        .collect()
}

/// The residual width in bits (one of [`residual_widths`](crate::residual_widths)) that
/// [`BrickOctree::encode`] writes a brick with whose shared grid points hold `points`
/// (`points[25x + 5y + z]`, `None` where no shared leaf has a corner; see
/// [`CORNER_POINT_OFFSETS`]). For a builder that changes codes and would keep the file's size.
pub fn brick_residual_bits(points: &[Option<i32>; 125], bits: ValueBits) -> u32 {
    residual_widths(bits)[encode_points(&point_samples(points), bits).1 as usize]
}

/// Appends `residuals` at `w` bits each (LSB first, two's complement; 16 bits little-endian)
/// to `out`, starting at a new byte.
pub(crate) fn put_residuals(out: &mut Vec<u8>, residuals: &[i32], w: u32) {
    if w == 0 {
        return;
    }
    let start = out.len();
    out.resize(start + (residuals.len() * w as usize).div_ceil(8), 0);
    for (i, &r) in residuals.iter().enumerate() {
        if w == 16 {
            out[start + 2 * i..start + 2 * i + 2].copy_from_slice(&(r as i16).to_le_bytes());
        } else {
            let bit = i * w as usize;
            out[start + bit / 8] |= ((r as u32 & ((1 << w) - 1)) << (bit % 8)) as u8;
        }
    }
}

/// The encoder's record of one brick while it is filled.
pub(crate) struct BrickBuild {
    /// Morton code of the brick (a node at `depth − 2`).
    pub(crate) code: u64,
    /// Which cells are leaves (Morton bits).
    pub(crate) occupancy: u64,
    /// Which leaves are private.
    pub(crate) private: u64,
    /// Code at each grid point set by a shared leaf.
    pub(crate) points: [Option<i32>; 125],
}

/// The bricks of `octree` (a 1.x octree) in Morton order, with each brick's shared points, and
/// the voxel ranges of its private leaves in Morton order: how [`BrickOctree::encode`] splits
/// the leaves (a leaf is shared when it holds one volume voxel whose corners agree with the
/// codes the brick's earlier shared leaves put at the same points). The 4.0 level coder splits
/// them alike.
pub(crate) fn gather_bricks<B: AsRef<[u8]>>(
    octree: &Octree<B>,
) -> (Vec<BrickBuild>, Vec<std::ops::Range<u32>>) {
    let inner = octree.inner_node_count() as u32;
    let mut bricks: Vec<BrickBuild> = Vec::new();
    // Private leaves in Morton order: (voxel range in the 1.x octree).
    let mut private_leaves: Vec<std::ops::Range<u32>> = Vec::new();
    for (j, coord) in octree.leaf_coords().into_iter().enumerate() {
        let code = morton::encode(coord);
        let brick_code = code >> (3 * BRICK_LEVELS);
        if bricks.last().is_none_or(|b| b.code != brick_code) {
            bricks.push(BrickBuild {
                code: brick_code,
                occupancy: 0,
                private: 0,
                points: [None; 125],
            });
        }
        let Some(brick) = bricks.last_mut() else {
            unreachable!("a brick was pushed above");
        };
        let cell = (code & 63) as u32;
        brick.occupancy |= 1 << cell;
        let voxels = octree.leaf_voxels(NodeRef::from_index(inner + j as u32));
        let v = voxels.start;
        let g = cell_grid_index(cell);
        let shared = voxels.len() == 1 && !octree.voxel_is_surface(v) && !octree.voxel_is_clip(v);
        let codes = octree.voxel_codes(v).map(i32::from);
        let agrees = (0..8).all(|k| {
            brick.points[(g + CORNER_POINT_OFFSETS[k]) as usize].is_none_or(|c| c == codes[k])
        });
        if shared && agrees {
            for k in 0..8 {
                brick.points[(g + CORNER_POINT_OFFSETS[k]) as usize] = Some(codes[k]);
            }
        } else {
            brick.private |= 1 << cell;
            private_leaves.push(voxels);
        }
    }
    (bricks, private_leaves)
}

impl BrickOctree<Vec<u8>> {
    /// Writes `octree` (a 1.x octree) as a 3.1 brick file ([`V3_VERSION_MINOR`]), or as 3.0
    /// when a private leaf holds more than [`V31_MAX_LEAF_VOXELS`] voxels, losslessly: every
    /// voxel's codes and flags read back as `octree` has them. See
    /// [`encode_minor`](Self::encode_minor).
    ///
    /// Errors: as [`encode_minor`](Self::encode_minor).
    pub fn encode<B: AsRef<[u8]>>(octree: &Octree<B>) -> Result<BrickOctree> {
        Self::encode_with(octree, None)
    }

    /// Writes `octree` (a 1.x octree) as a 3.x brick file of minor version `minor` (0 or 1),
    /// losslessly: every voxel's codes and flags read back as `octree` has them.
    ///
    /// A leaf is *shared* when it holds one volume voxel (not surface, not clip) whose eight
    /// codes agree with every code the brick's earlier shared leaves (in Morton order) put at
    /// the same grid points; every other leaf is *private*. Each brick's points get the
    /// least-squares plane of their codes and the narrowest residual width that stores them
    /// (see [`residual_widths`](crate::residual_widths)). Deterministic: the same octree gives
    /// the same bytes.
    ///
    /// In 3.1 a private leaf whose every voxel's mixed differences fit half-width fields is
    /// *narrow* (each voxel `6·b` bytes instead of `8·b`), the others *wide*.
    ///
    /// Errors: [`FormatError::Unrepresentable`] for a depth below 2, more than 1 GiB of
    /// residuals, a minor version other than 0 or 1, or at minor 1 a private leaf of more than
    /// [`V31_MAX_LEAF_VOXELS`] voxels; [`FormatError::TooLarge`] when a count overflows 32 bits.
    pub fn encode_minor<B: AsRef<[u8]>>(octree: &Octree<B>, minor: u16) -> Result<BrickOctree> {
        if minor > V3_VERSION_MINOR {
            return Err(FormatError::Unrepresentable {
                major: V3_VERSION_MAJOR,
                reason: format!("minor version {minor} (this writer knows 0 and 1)"),
            });
        }
        Self::encode_with(octree, Some(minor))
    }

    /// [`encode_minor`](Self::encode_minor) at `minor`, or when `None` the newest minor that
    /// holds the octree.
    fn encode_with<B: AsRef<[u8]>>(octree: &Octree<B>, minor: Option<u16>) -> Result<BrickOctree> {
        let meta = *octree.meta();
        let bits = meta.bits;
        let depth = meta.depth;
        if depth < BRICK_LEVELS {
            return Err(FormatError::Unrepresentable {
                major: V3_VERSION_MAJOR,
                reason: format!("depth {depth} is below the brick's {BRICK_LEVELS} levels"),
            });
        }
        let (bricks, private_leaves) = gather_bricks(octree);
        let largest = private_leaves.iter().map(|r| r.len()).max().unwrap_or(0);
        let minor = match minor {
            Some(1) if largest > V31_MAX_LEAF_VOXELS => {
                return Err(FormatError::Unrepresentable {
                    major: V3_VERSION_MAJOR,
                    reason: format!(
                        "a private leaf of {largest} voxels in 3.1 (at most {V31_MAX_LEAF_VOXELS})"
                    ),
                })
            }
            Some(m) => m,
            None if largest > V31_MAX_LEAF_VOXELS => 0,
            None => V3_VERSION_MINOR,
        };
        // Which private leaves are narrow: in 3.1, those whose every voxel fits.
        let narrow: Vec<bool> = private_leaves
            .iter()
            .map(|r| {
                minor > 0
                    && r.clone()
                        .all(|v| fits_narrow(octree.voxel_codes(v).map(i32::from), bits))
            })
            .collect();
        let wide_voxels: u64 = private_leaves
            .iter()
            .zip(&narrow)
            .filter(|(_, &n)| !n)
            .map(|(r, _)| r.len() as u64)
            .sum();

        // Planes, widths and residuals, brick by brick.
        let mut records = Vec::with_capacity(bricks.len());
        let mut residual_bytes: Vec<u8> = Vec::new();
        let mut first_private_leaf = 0u32;
        for b in &bricks {
            let samples = point_samples(&b.points);
            debug_assert_eq!(
                samples.len() as u32,
                point_mask(b.occupancy & !b.private).count_ones()
            );
            let (plane, width_code, residuals) = encode_points(&samples, bits);
            let offset = residual_bytes.len();
            if offset > RESIDUAL_OFFSET_MASK as usize {
                return Err(FormatError::Unrepresentable {
                    major: V3_VERSION_MAJOR,
                    reason: format!("more than {RESIDUAL_OFFSET_MASK} bytes of residuals"),
                });
            }
            put_residuals(
                &mut residual_bytes,
                &residuals,
                residual_widths(bits)[width_code as usize],
            );
            records.push(BrickRecord {
                occupancy: b.occupancy,
                private: b.private,
                plane_a: plane[0],
                plane_b: plane[1],
                plane_c: plane[2],
                plane_d: plane[3],
                residuals: offset as u32 | width_code << RESIDUAL_OFFSET_BITS,
                first_private_leaf,
            });
            first_private_leaf += b.private.count_ones();
        }

        let private_voxels: u64 = private_leaves.iter().map(|r| r.len() as u64).sum();
        let mut counts = V3Counts {
            tree: Counts {
                inner: 0, // set below, once the upper levels are known
                leaves: octree.leaf_count() as u32,
                voxels: octree.voxel_count() as u32,
                surface: octree.surface_voxel_count() as u32,
                clip: octree.clip_voxel_count() as u32,
            },
            bricks: to_u32(bricks.len() as u64, "bricks")?,
            private_leaves: to_u32(private_leaves.len() as u64, "private leaves")?,
            private_voxels: to_u32(private_voxels, "private voxels")?,
            minor,
            wide_voxels: wide_voxels as u32,
        };
        let levels = inner_levels(
            bricks.iter().map(|b| b.code).collect(),
            depth - BRICK_LEVELS,
        );
        counts.tree.inner = to_u32(levels.iter().map(|l| l.len() as u64).sum(), "upper nodes")?;
        to_u32(
            u64::from(counts.tree.inner) + u64::from(counts.bricks),
            "nodes",
        )?;

        let layout = V3Layout::new(
            V3_HEADER_SIZE as u64,
            &counts,
            residual_bytes.len() as u64,
            bits,
        );
        let file_size = usize::try_from(layout.file_size).map_err(|_| FormatError::TooLarge {
            what: "file bytes",
            count: layout.file_size,
        })?;
        let mut out = vec![0u8; file_size];
        header(&meta, &counts, &layout).write(&mut out);
        write_node_groups(&mut out, layout.nodes.0 as usize, &levels);
        for (b, r) in records.iter().enumerate() {
            let at = layout.bricks.0 as usize + b * BRICK_RECORD_SIZE;
            r.write(&mut out[at..at + BRICK_RECORD_SIZE]);
        }
        let res = layout.residuals.0 as usize;
        out[res..res + residual_bytes.len()].copy_from_slice(&residual_bytes);

        // Private leaf groups, flags and corners, in Morton order.
        let (per_group, group_size) = (private_group_leaves(minor), private_group_size(minor));
        let (mut voxel, mut wide_before) = (0u32, 0u32);
        for (g, group) in private_leaves.chunks(per_group).enumerate() {
            let at = layout.private_leaves.0 as usize + group_size * g;
            let narrow = &narrow[g * per_group..g * per_group + group.len()];
            if minor == 0 {
                let mut counts8 = [0u8; 8];
                for (slot, range) in group.iter().enumerate() {
                    counts8[slot] = range.len() as u8; // 1..=255 in a valid 1.x octree
                }
                put_group(&mut out, at, voxel, counts8);
            } else {
                out[at..at + 4].copy_from_slice(&voxel.to_le_bytes());
                out[at + 4..at + 8].copy_from_slice(&wide_before.to_le_bytes());
                for (slot, (range, &n)) in group.iter().zip(narrow).enumerate() {
                    // 1..=127, checked above.
                    out[at + 8 + slot] = range.len() as u8 | if n { 0 } else { WIDE_BIT };
                }
            }
            for (range, &n) in group.iter().zip(narrow) {
                for v in range.clone() {
                    let flags = u8::from(octree.voxel_is_surface(v))
                        | u8::from(octree.voxel_is_clip(v)) << 1;
                    let bit = 2 * voxel as usize;
                    out[layout.private_flags.0 as usize + bit / 8] |= flags << (bit % 8);
                    let at =
                        layout.private_corners.0 as usize + corner_offset(voxel, wide_before, bits);
                    put_private(
                        &mut out[at..],
                        octree.voxel_codes(v).map(i32::from),
                        !n,
                        bits,
                    );
                    wide_before += u32::from(!n);
                    voxel += 1;
                }
            }
        }
        let crc_at = file_size - CHECKSUM_SIZE;
        let crc = crc32(&out[..crc_at]);
        out[crc_at..].copy_from_slice(&crc.to_le_bytes());
        Ok(BrickOctree {
            bytes: out,
            meta,
            counts,
            layout,
            dequant: dequant_scale(depth, bits),
        })
    }
}

/// The header the writer puts in front of a 3.x file.
fn header(meta: &OctreeMeta, c: &V3Counts, l: &V3Layout) -> V3Header {
    octree_header! { V3Header {
        version: (V3_VERSION_MAJOR, c.minor),
        header_size: V3_HEADER_SIZE,
        flags: c.flags(),
        meta: meta;
        upper_node_count: c.tree.inner,
        brick_count: c.bricks,
        leaf_count: c.tree.leaves,
        voxel_count: c.tree.voxels,
        surface_voxel_count: c.tree.surface,
        clip_voxel_count: c.tree.clip,
        private_leaf_count: c.private_leaves,
        private_voxel_count: c.private_voxels,
        file_size: l.file_size,
        nodes_offset: l.nodes.0,
        nodes_size: l.nodes.1,
        bricks_offset: l.bricks.0,
        bricks_size: l.bricks.1,
        residuals_offset: l.residuals.0,
        residuals_size: l.residuals.1,
        private_leaves_offset: l.private_leaves.0,
        private_leaves_size: l.private_leaves.1,
        private_flags_offset: l.private_flags.0,
        private_flags_size: l.private_flags.1,
        private_corners_offset: l.private_corners.0,
        private_corners_size: l.private_corners.1,
    }}
}

/// A 3.0 file as its header declares it, for the compressed container, which stores each
/// section as its own stream and puts it back at its offset.
pub(crate) struct V3Sections {
    /// Code width.
    pub(crate) bits: ValueBits,
    /// The declared counts (and minor version).
    pub(crate) counts: V3Counts,
    /// Where the sections sit ([`V3Layout::sections`] in file order) and the file's size.
    pub(crate) layout: V3Layout,
}

/// Reads the sections of a 3.0 header (`header` holds at least [`V3_HEADER_SIZE`] bytes) and
/// checks them canonical (as [`BrickOctree::encode`] places them, from the counts and the
/// residual size) and the file no larger than `max_file` bytes. Nothing else is validated:
/// the container's CRC-32 and the reader's `new` do that on the whole file.
pub(crate) fn v3_sections(header: &[u8], max_file: u64) -> Result<V3Sections> {
    check_magic(header, V3_HEADER_SIZE)?;
    let h = V3Header::read(header);
    check_major(h.version_major, h.version_minor, V3_VERSION_MAJOR)?;
    let Some(bits) = ValueBits::from_bits(h.value_bits) else {
        return corrupt("value_bits", format!("{} (must be 8 or 16)", h.value_bits));
    };
    if usize::try_from(h.header_size) != Ok(V3_HEADER_SIZE) || h.residuals_size > max_file {
        return corrupt(
            "header_size",
            format!(
                "header_size {} (must be {V3_HEADER_SIZE}), residuals_size {} (at most {max_file})",
                h.header_size, h.residuals_size
            ),
        );
    }
    let c = V3Counts::declared_by(&h, bits)?;
    let layout = V3Layout::new(V3_HEADER_SIZE as u64, &c, h.residuals_size, bits);
    if h.sections() != layout.sections()
        || h.file_size != layout.file_size
        || layout.file_size > max_file
    {
        return corrupt(
            "file_size",
            format!(
                "{} bytes, sections not where the counts place them or over the limit of {max_file}",
                h.file_size
            ),
        );
    }
    Ok(V3Sections {
        bits,
        counts: c,
        layout,
    })
}

/// Refuses `section` unless every total counted in the data equals the header's count, each
/// `(what, counted, declared)`: "3 leaves and 1 private leaves, the header says 4 and 1".
fn check_counted(section: &'static str, totals: &[(&str, u64, u32)]) -> Result<()> {
    if totals
        .iter()
        .all(|&(_, n, declared)| n == u64::from(declared))
    {
        return Ok(());
    }
    let counted: Vec<String> = totals
        .iter()
        .map(|(what, n, _)| format!("{n} {what}"))
        .collect();
    let declared: Vec<String> = totals.iter().map(|(_, _, d)| d.to_string()).collect();
    corrupt(
        section,
        format!(
            "{}, the header says {}",
            counted.join(" and "),
            declared.join(" and ")
        ),
    )
}

impl<B: AsRef<[u8]>> BrickOctree<B> {
    /// Validates `bytes` as a 3.0 or 3.1 brick file and reads it in place. Checked before
    /// anything is used, in this order: magic, major version (3), header size, declared file size
    /// against the length, the CRC-32, flags, depth (2..=16), value bits, reserved bytes,
    /// transform, counts (and the flags they imply), every section's offset and size (and zero
    /// padding), the node groups above the bricks (as in 1.x, with the bricks as their
    /// leaves), every brick record (occupancy non-zero, private mask within it, residual
    /// offset and first private leaf equal to the running sums, every point's code in
    /// −Q..=Q), the totals of leaves, private leaves and residual bytes, the private leaf
    /// groups (3.0: counts 1..=255, bases, total; 3.1: counts 1..=127, both bases, both
    /// totals, every private voxel's codes, narrow ones rebuilt, in −Q..=Q), the private flags (padding bits 0, popcounts,
    /// no leaf of clip-only voxels alone, at most
    /// [`MAX_CLIP_VOXELS_PER_LEAF`](crate::MAX_CLIP_VOXELS_PER_LEAF) clip voxels per leaf)
    /// and the private corner codes (−Q..=Q). O(len), no allocation but an error's message.
    pub fn new(bytes: B) -> Result<BrickOctree<B>> {
        let (meta, counts, layout) = validate(bytes.as_ref())?;
        Ok(BrickOctree {
            bytes,
            meta,
            counts,
            layout,
            dequant: dequant_scale(meta.depth, meta.bits),
        })
    }

    /// The buffer back.
    pub fn into_bytes(self) -> B {
        self.bytes
    }

    /// The same octree over borrowed bytes (no copy, no validation).
    pub fn as_view(&self) -> BrickOctreeView<'_> {
        BrickOctree {
            bytes: self.as_bytes(),
            meta: self.meta,
            counts: self.counts,
            layout: self.layout,
            dequant: self.dequant,
        }
    }

    buffer_accessors!();

    count_getters! {
        /// Nodes above the bricks (levels `0 … depth − 3`).
        upper_node_count => tree.inner,
        /// Bricks (nodes at level `depth − 2`).
        brick_count => bricks,
        /// Leaves (level `depth`).
        leaf_count => tree.leaves,
        /// Voxels in all leaves (a shared leaf holds one).
        voxel_count => tree.voxels,
        /// Voxels flagged surface (all private).
        surface_voxel_count => tree.surface,
        /// Voxels with the clip bit (all private).
        clip_voxel_count => tree.clip,
        /// Leaves whose voxels are stored whole.
        private_leaf_count => private_leaves,
        /// Voxels of the private leaves.
        private_voxel_count => private_voxels,
    }

    // ---- Traversal access ---------------------------------------------------------------

    #[inline]
    fn brick(&self, brick: u32) -> Brick {
        assert!(brick < self.counts.bricks, "brick {brick} out of range");
        Brick::read(
            self.as_bytes(),
            self.layout.bricks.0 as usize + brick as usize * BRICK_RECORD_SIZE,
        )
    }

    /// The node with breadth-first index `k` of the upper tree: a brick from `upper` on.
    #[inline]
    pub(crate) fn node(&self, k: u32) -> BrickNode {
        match k.checked_sub(self.counts.tree.inner) {
            Some(b) => BrickNode::Brick(b),
            None => BrickNode::Upper(k),
        }
    }

    /// The root; `None` for an empty octree. At depth 2 the root is the only brick.
    #[inline]
    pub fn root(&self) -> Option<BrickNode> {
        (self.counts.bricks > 0).then(|| self.node(0))
    }

    /// Child mask of `node`: bit `i` set = a child in octant `i = 4x + 2y + z`; 0 for a leaf.
    #[inline]
    pub fn child_mask(&self, node: BrickNode) -> u8 {
        match node {
            BrickNode::Upper(k) => {
                assert!(k < self.counts.tree.inner, "node {k} out of range");
                let at = self.layout.nodes.0 as usize + (k as usize >> 3) * 12;
                self.as_bytes()[at + 4 + (k as usize & 7)]
            }
            BrickNode::Brick(b) => {
                // Bit o set when byte o of the occupancy is non-zero.
                let x = self.brick(b).occupancy;
                let x = x | x >> 4;
                let x = x | x >> 2;
                let x = (x | x >> 1) & 0x0101_0101_0101_0101;
                (x.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u8
            }
            BrickNode::Half { brick, octant } => {
                (self.brick(brick).occupancy >> (8 * u32::from(octant & 7))) as u8
            }
            BrickNode::Leaf { .. } => 0,
        }
    }

    /// The child of `node` in `octant` (`4x + 2y + z`, 0..8), if there is one.
    #[inline]
    pub fn child(&self, node: BrickNode, octant: u8) -> Option<BrickNode> {
        if octant > 7 {
            return None;
        }
        match node {
            BrickNode::Upper(k) => {
                assert!(k < self.counts.tree.inner, "node {k} out of range");
                let at = self.layout.nodes.0 as usize + (k as usize >> 3) * 12;
                let (first_child, masks) = group_at(self.as_bytes(), at);
                let bit = (k & 7) * 8 + u32::from(octant);
                (masks >> bit & 1 != 0)
                    .then(|| self.node(first_child + low_bits(masks, bit).count_ones()))
            }
            BrickNode::Brick(brick) => {
                let occ = self.brick(brick).occupancy;
                (occ >> (8 * u32::from(octant)) & 0xff != 0)
                    .then_some(BrickNode::Half { brick, octant })
            }
            BrickNode::Half { brick, octant: h } => {
                let cell = (h & 7) * 8 + octant;
                (self.brick(brick).occupancy >> cell & 1 != 0)
                    .then_some(BrickNode::Leaf { brick, cell })
            }
            BrickNode::Leaf { .. } => None,
        }
    }

    /// The breadth-first index (see [`Self::node`]) of the first child of upper node `k`: its
    /// children are that index plus the popcount of its mask below their octant (as in 1.x).
    #[inline(always)]
    pub(crate) fn first_child_index(&self, k: u32) -> u32 {
        assert!(k < self.counts.tree.inner, "node {k} out of range");
        let at = self.layout.nodes.0 as usize + (k as usize >> 3) * 12;
        let (first_child, masks) = group_at(self.as_bytes(), at);
        first_child + low_bits(masks, (k & 7) * 8).count_ones()
    }

    /// The child mask of upper node `k` (`k` < the upper node count, else a panic).
    #[inline(always)]
    pub(crate) fn upper_child_mask(&self, k: u32) -> u8 {
        let at = self.layout.nodes.0 as usize + (k as usize >> 3) * 12;
        assert!(k < self.counts.tree.inner, "node {k} out of range");
        self.as_bytes()[at + 4 + (k as usize & 7)]
    }

    /// Whether `node` is a leaf.
    #[inline]
    pub fn is_leaf(&self, node: BrickNode) -> bool {
        matches!(node, BrickNode::Leaf { .. })
    }

    /// The leaf at `node` (`None` unless it is a [`BrickNode::Leaf`] whose cell is a leaf):
    /// where its voxels are. One popcount; for a private leaf one group read and byte sum.
    #[inline]
    pub fn leaf(&self, node: BrickNode) -> Option<BrickLeaf> {
        let BrickNode::Leaf { brick, cell } = node else {
            return None;
        };
        let cell = cell & 63;
        let r = self.brick(brick);
        if r.occupancy >> cell & 1 == 0 {
            return None;
        }
        if r.private >> cell & 1 == 0 {
            return Some(BrickLeaf {
                brick,
                cell,
                count: 0,
                first_voxel: 0,
                wide_before: 0,
                wide: false,
            });
        }
        let j = r.first_private_leaf + low_bits(r.private, u32::from(cell)).count_ones();
        let span = private_leaf_at(
            self.as_bytes(),
            self.layout.private_leaves.0 as usize,
            self.counts.minor,
            j,
        );
        Some(BrickLeaf {
            brick,
            cell,
            count: span.count as u8,
            first_voxel: span.first,
            wide_before: span.wide_before,
            wide: span.wide,
        })
    }

    /// The leaf at cell `coord` (in `[0, 2^depth)³`), if there is one: a descent from the root.
    pub fn find_leaf(&self, coord: [u32; 3]) -> Option<BrickLeaf> {
        let depth = self.meta.depth;
        if coord.iter().any(|&c| u64::from(c) >> depth != 0) {
            return None;
        }
        let mut node = self.root()?;
        for level in (0..depth).rev() {
            let [x, y, z] = coord.map(|c| (c >> level) & 1);
            node = self.child(node, (4 * x + 2 * y + z) as u8)?;
        }
        self.leaf(node)
    }

    /// The eight codes (`4x + 2y + z`, −Q..=Q) of voxel `k` of `leaf`; `value = code ·
    /// dequant_scale()`. A shared leaf's come from its brick's points (eight ranks, eight
    /// residuals), a private leaf's are read whole.
    ///
    /// Panics if `k` is not below the leaf's voxel count or the leaf is from another octree.
    #[inline]
    pub fn voxel_codes(&self, leaf: &BrickLeaf, k: u32) -> [i16; 8] {
        assert!(k < leaf.voxel_count(), "voxel {k} out of range");
        let bits = self.meta.bits;
        let b = self.as_bytes();
        if leaf.count > 0 {
            let v = leaf.first_voxel as usize + k as usize;
            assert!(
                v < self.counts.private_voxels as usize,
                "voxel {v} out of range"
            );
            let wide_before = leaf.wide_before + if leaf.wide { k } else { 0 };
            let at =
                self.layout.private_corners.0 as usize + corner_offset(v as u32, wide_before, bits);
            return private_codes(b, at, leaf.wide, bits).map(|c| c as i16);
        }
        let r = self.brick(leaf.brick);
        let points = point_mask(r.shared());
        let g = cell_grid_index(u32::from(leaf.cell));
        let res = &b[self.layout.residuals.0 as usize + r.residual_offset()..];
        let w = r.width(bits);
        std::array::from_fn(|c| {
            let p = g + CORNER_POINT_OFFSETS[c];
            let rank = rank_below(points, p);
            let pred = plane_predict(r.plane, grid_point(p), bits);
            wrap(pred + residual_at(res, rank, w), bits) as i16
        })
    }

    /// The eight corner distances of voxel `k` of `leaf`, dequantised (normalised units).
    #[inline]
    pub fn voxel_corners(&self, leaf: &BrickLeaf, k: u32) -> [f32; 8] {
        self.voxel_codes(leaf, k)
            .map(|c| f32::from(c) * self.dequant)
    }

    /// The two flag bits of private voxel `k` of `leaf` (bit 0 surface, bit 1 clip).
    #[inline]
    fn voxel_flags(&self, leaf: &BrickLeaf, k: u32) -> u8 {
        assert!(k < leaf.voxel_count(), "voxel {k} out of range");
        if leaf.count == 0 {
            return 0;
        }
        let v = leaf.first_voxel as usize + k as usize;
        assert!(
            v < self.counts.private_voxels as usize,
            "voxel {v} out of range"
        );
        let bit = 2 * v;
        self.as_bytes()[self.layout.private_flags.0 as usize + bit / 8] >> (bit % 8) & 3
    }

    /// Whether voxel `k` of `leaf` is a surface (thin) voxel (never, in a shared leaf).
    #[inline]
    pub fn voxel_is_surface(&self, leaf: &BrickLeaf, k: u32) -> bool {
        self.voxel_flags(leaf, k) & 1 != 0
    }

    /// Whether voxel `k` of `leaf` has the clip bit (never, in a shared leaf); with
    /// [`Self::voxel_is_surface`] a clip-only voxel, as in 1.x ([`Voxel::clip`]).
    #[inline]
    pub fn voxel_is_clip(&self, leaf: &BrickLeaf, k: u32) -> bool {
        self.voxel_flags(leaf, k) & 2 != 0
    }

    /// Whether any voxel of `leaf` has the clip bit (the test that picks the clip rule).
    #[inline]
    pub fn any_clip_voxel(&self, leaf: &BrickLeaf) -> bool {
        self.counts.tree.clip > 0 && (0..leaf.voxel_count()).any(|k| self.voxel_is_clip(leaf, k))
    }

    // ---- Whole-octree helpers -----------------------------------------------------------

    /// Cell coordinates of every brick's lowest cell ÷ 4 (brick coordinates), in Morton order.
    pub fn brick_coords(&self) -> Vec<[u32; 3]> {
        let mut coords: Vec<[u32; 3]> = Vec::new();
        if self.counts.bricks == 0 {
            return coords;
        }
        coords.push([0, 0, 0]);
        // Breadth first: appending each node's children in order reproduces the numbering.
        for k in 0..self.counts.tree.inner {
            let parent = coords[k as usize];
            let mask = self.child_mask(BrickNode::Upper(k));
            for o in 0..8u8 {
                if mask >> o & 1 != 0 {
                    coords.push(crate::child_coord(parent, o));
                }
            }
        }
        coords.drain(..self.counts.tree.inner as usize);
        coords
    }

    /// Every leaf in Morton order with its cell coordinates. Allocates; for tools and tests.
    pub fn leaves(&self) -> impl Iterator<Item = ([u32; 3], BrickLeaf)> + '_ {
        self.brick_coords()
            .into_iter()
            .enumerate()
            .flat_map(move |(b, bc)| {
                let occ = self.brick(b as u32).occupancy;
                (0..64u8)
                    .filter(move |c| occ >> c & 1 != 0)
                    .map(move |cell| {
                        let g = cell_grid_index(u32::from(cell));
                        let [x, y, z] = grid_point(g);
                        let coord = [4 * bc[0] + x, 4 * bc[1] + y, 4 * bc[2] + z];
                        let leaf = self.leaf(BrickNode::Leaf {
                            brick: b as u32,
                            cell,
                        });
                        (coord, leaf.expect("an occupied cell is a leaf"))
                    })
            })
    }

    /// The first leaf of `o` (a 1.x octree, in its Morton order) whose voxels this octree does
    /// not answer alike through its random access ([`Self::find_leaf`], then every voxel's
    /// codes, surface and clip bit), with what differs; `None` when every voxel of `o` reads back
    /// the same (and the leaf and voxel counts are equal): the encoder's lossless promise,
    /// checked by the tests, the fuzzer and the `brick_estimate` example.
    pub fn first_difference<C: AsRef<[u8]>>(&self, o: &Octree<C>) -> Option<String> {
        if (self.leaf_count(), self.voxel_count()) != (o.leaf_count(), o.voxel_count()) {
            return Some(format!(
                "{} leaves and {} voxels, the 1.x octree has {} and {}",
                self.leaf_count(),
                self.voxel_count(),
                o.leaf_count(),
                o.voxel_count()
            ));
        }
        let inner = o.inner_node_count() as u32;
        for (j, coord) in o.leaf_coords().into_iter().enumerate() {
            let voxels = o.leaf_voxels(NodeRef::from_index(inner + j as u32));
            let Some(leaf) = self.find_leaf(coord) else {
                return Some(format!("leaf {coord:?} is missing"));
            };
            if leaf.voxel_count() as usize != voxels.len() {
                return Some(format!(
                    "leaf {coord:?} has {} voxels, not {}",
                    leaf.voxel_count(),
                    voxels.len()
                ));
            }
            for (k, v) in (0..leaf.voxel_count()).zip(voxels) {
                let got = (
                    self.voxel_codes(&leaf, k),
                    self.voxel_is_surface(&leaf, k),
                    self.voxel_is_clip(&leaf, k),
                );
                let want = (o.voxel_codes(v), o.voxel_is_surface(v), o.voxel_is_clip(v));
                if got != want {
                    return Some(format!(
                        "leaf {coord:?} voxel {k}: (codes, surface, clip) {got:?}, not {want:?}"
                    ));
                }
            }
        }
        None
    }

    /// The 1.x octree with the same leaves, voxels, codes and flags (the canonical 1.x file):
    /// `BrickOctree::encode(&o)?.to_octree() == o` for every 1.x octree `o` of depth ≥ 2.
    pub fn to_octree(&self) -> PackedOctree {
        let leaves = self
            .leaves()
            .map(|(coord, leaf)| LeafInput {
                coord,
                voxels: (0..leaf.voxel_count())
                    .map(|k| Voxel {
                        corners: self.voxel_corners(&leaf, k),
                        surface: self.voxel_is_surface(&leaf, k),
                        clip: self.voxel_is_clip(&leaf, k),
                    })
                    .collect(),
            })
            .collect();
        // Codes × dmax/Q re-quantise to the same codes (the error is far below half a code),
        // and a validated file holds what from_leaves accepts.
        PackedOctree::from_leaves(self.meta, leaves).expect("a valid 3.0 file is a valid octree")
    }

    /// The file's minor version: 0 (every private voxel stored whole) or 1 (narrow private
    /// voxels, `FORMAT.md` "Narrow private voxels (version 3.1)").
    #[inline]
    pub fn version_minor(&self) -> u16 {
        self.counts.minor
    }

    /// Private voxels stored whole (*wide*): all of them in a 3.0 file; in 3.1 those of the
    /// private leaves whose mixed differences do not all fit.
    #[inline]
    pub fn wide_voxel_count(&self) -> usize {
        self.counts.wide_voxels as usize
    }

    /// Bytes per section of the file.
    pub fn section_sizes(&self) -> BrickSectionSizes {
        let l = &self.layout;
        let s = |x: (u64, u64)| x.1 as usize;
        let header = l.nodes.0 as usize;
        let named: usize = l.sections().iter().map(|x| x.1 as usize).sum();
        let total = self.as_bytes().len();
        BrickSectionSizes {
            header,
            nodes: s(l.nodes),
            bricks: s(l.bricks),
            residuals: s(l.residuals),
            private_leaves: s(l.private_leaves),
            private_flags: s(l.private_flags),
            private_corners: s(l.private_corners),
            padding: total - header - named - CHECKSUM_SIZE,
            checksum: CHECKSUM_SIZE,
            total,
        }
    }
}

/// Bytes per section of a 3.0 file ([`BrickOctree::section_sizes`]), in file order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BrickSectionSizes {
    /// The header (176 bytes in 3.0).
    pub header: usize,
    /// Node groups above the bricks (12 bytes per 8 nodes).
    pub nodes: usize,
    /// Brick records (32 bytes per brick).
    pub bricks: usize,
    /// The shared points' residuals.
    pub residuals: usize,
    /// Private leaf groups (12 bytes per 8 private leaves).
    pub private_leaves: usize,
    /// Two flag bits per private voxel (8 bytes per 32).
    pub private_flags: usize,
    /// The private voxels' codes (8 or 16 bytes per voxel).
    pub private_corners: usize,
    /// Zero padding that aligns each section to 8 bytes.
    pub padding: usize,
    /// The trailing CRC-32.
    pub checksum: usize,
    /// The whole file.
    pub total: usize,
}

equal_by_bytes!(BrickOctree);

impl<B: AsRef<[u8]>> fmt::Debug for BrickOctree<B> {
    /// The header's content, not the bytes.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("BrickOctree")
            .field("meta", &self.meta)
            .field("counts", &self.counts)
            .field("bytes", &self.as_bytes().len())
            .finish()
    }
}

/// The checks of [`BrickOctree::new`], in order.
/// Whether `bytes` start as a 3.0 file: the `.smo` magic and major version 3.
pub fn is_v3(bytes: &[u8]) -> bool {
    bytes.len() >= 10
        && bytes[..8] == MAGIC
        && u16::from_le_bytes([bytes[8], bytes[9]]) == V3_VERSION_MAJOR
}

/// The checks of a 3.0 header that need only its first [`V3_HEADER_SIZE`] bytes (`head`, or
/// a shorter prefix) and the length `len` of the whole file: magic, major version, header
/// size, the declared file size against `len`. Run by [`BrickOctree::new`] and, before the
/// body is read, by the readers of files ([`crate::read_smo`]).
pub(crate) fn check_v3_head(head: &[u8], len: u64) -> Result<V3Header> {
    check_magic(head, V3_HEADER_SIZE)?;
    if len < V3_HEADER_SIZE as u64 || head.len() < V3_HEADER_SIZE {
        return Err(FormatError::Truncated {
            len: usize::try_from(len).unwrap_or(usize::MAX).min(head.len()),
            needed: V3_HEADER_SIZE as u64,
        });
    }
    let h = V3Header::read(head);
    check_major(h.version_major, h.version_minor, V3_VERSION_MAJOR)?;
    let header_size = u64::from(h.header_size);
    let min_len = header_size + CHECKSUM_SIZE as u64;
    check_sizes(header_size, V3_HEADER_SIZE, h.file_size, len, min_len)?;
    Ok(h)
}

fn validate(bytes: &[u8]) -> Result<(OctreeMeta, V3Counts, V3Layout)> {
    let len = bytes.len();
    let h = check_v3_head(bytes, len as u64)?;
    let header_size = u64::from(h.header_size);
    let crc_at = len - CHECKSUM_SIZE;
    let stored = u32::from_le_bytes(bytes_at::<4>(bytes, crc_at));
    let computed = crc32(&bytes[..crc_at]);
    if stored != computed {
        return Err(FormatError::ChecksumMismatch { stored, computed });
    }

    // ---- Header fields ----
    if h.flags & !KNOWN_FLAGS != 0 {
        return corrupt(
            "flags",
            format!("unknown bits {:#x}", h.flags & !KNOWN_FLAGS),
        );
    }
    let depth = h.depth;
    if !(BRICK_LEVELS..=MAX_DEPTH).contains(&depth) {
        return corrupt(
            "depth",
            format!("{depth} (must be {BRICK_LEVELS}..={MAX_DEPTH})"),
        );
    }
    let meta = check_grid(bytes)?;
    let bits = meta.bits;
    let c = V3Counts::declared_by(&h, bits)?;
    let (upper, bricks, leaves) = (
        u64::from(c.tree.inner),
        u64::from(c.bricks),
        u64::from(c.tree.leaves),
    );
    let (pl, pv) = (u64::from(c.private_leaves), u64::from(c.private_voxels));
    if upper + bricks > u64::from(u32::MAX) {
        return corrupt("upper_node_count", "nodes exceed 2^32 - 1");
    }
    if leaves < bricks || leaves > 64 * bricks {
        return corrupt(
            "leaf_count",
            format!("{leaves} leaves in {bricks} bricks (each holds 1..=64)"),
        );
    }
    if pl > leaves || pv < pl || pv > 255 * pl {
        return corrupt(
            "private_voxel_count",
            format!("{pv} private voxels in {pl} private leaves of {leaves}"),
        );
    }
    if u64::from(c.tree.voxels) != leaves - pl + pv {
        return corrupt(
            "voxel_count",
            format!(
                "{}, but {} shared leaves and {pv} private voxels",
                c.tree.voxels,
                leaves - pl
            ),
        );
    }
    if u64::from(c.tree.surface) > pv || u64::from(c.tree.clip) > pv {
        return corrupt(
            "surface_voxel_count",
            format!(
                "{} surface, {} clip of {pv} private voxels",
                c.tree.surface, c.tree.clip
            ),
        );
    }
    let top = depth - BRICK_LEVELS;
    if (top == 0 && (upper != 0 || bricks > 1)) || (top > 0 && (upper == 0) != (bricks == 0)) {
        return corrupt(
            "upper_node_count",
            format!("{upper} upper nodes for {bricks} bricks at depth {depth}"),
        );
    }
    for (bit, name, set) in [
        (
            FLAG_MULTI_VOXEL,
            "multi-voxel",
            c.tree.voxels > c.tree.leaves,
        ),
        (FLAG_SURFACE_VOXELS, "surface", c.tree.surface > 0),
        (FLAG_CLIP_VOXELS, "clip", c.tree.clip > 0),
    ] {
        if (h.flags & bit != 0) != set {
            return corrupt("flags", format!("{name} bit disagrees with the counts"));
        }
    }

    // ---- Sections: exactly where the counts (and the residual size) put them ----
    if h.residuals_size > len as u64 {
        return corrupt("residuals_size", format!("{} > the file", h.residuals_size));
    }
    let layout = V3Layout::new(header_size, &c, h.residuals_size, bits);
    if layout.file_size != h.file_size {
        return corrupt(
            "file_size",
            format!("{}, but the counts imply {}", h.file_size, layout.file_size),
        );
    }
    let stored = SECTION_OFFSET_FIELDS.into_iter().zip(h.sections());
    let mut end = header_size;
    for ((name, (off, size)), (want_off, want_size)) in stored.zip(layout.sections()) {
        if (off, size) != (want_off, want_size) {
            return corrupt(
                name,
                format!("section at {off} + {size}, expected {want_off} + {want_size}"),
            );
        }
        if bytes[end as usize..off as usize].iter().any(|&b| b != 0) {
            return corrupt("padding", format!("non-zero byte in {end}..{off}"));
        }
        end = off + size;
    }
    if bytes[end as usize..layout.checksum_offset as usize]
        .iter()
        .any(|&b| b != 0)
    {
        return corrupt(
            "padding",
            format!("non-zero byte in {end}..{}", layout.checksum_offset),
        );
    }
    let section = |(off, size): (u64, u64)| &bytes[off as usize..(off + size) as usize];

    validate_node_groups(section(layout.nodes), top, c.tree.inner, c.bricks)?;
    validate_bricks(section(layout.bricks), section(layout.residuals), &c, bits)?;
    let private_leaves = section(layout.private_leaves);
    if c.minor > 0 {
        validate_private_v31(private_leaves, section(layout.private_corners), &c, bits)?;
        validate_flags(section(layout.private_flags), private_leaves, &c)?;
        return Ok((meta, c, layout));
    }
    let total = walk_groups(
        "private_leaves",
        private_leaves,
        "first_voxel",
        0,
        |j, n| {
            let real = j < pl;
            if real && n == 0 {
                return corrupt("private_leaves", format!("private leaf {j} has no voxel"));
            }
            if !real && n != 0 {
                return corrupt(
                    "private_leaves",
                    format!("padding count of slot {j} is {n}"),
                );
            }
            Ok(u64::from(n))
        },
    )?;
    if total != pv {
        return corrupt(
            "private_leaves",
            format!("counts sum to {total}, private_voxel_count is {pv}"),
        );
    }
    validate_flags(section(layout.private_flags), private_leaves, &c)?;
    check_codes("private_corners", section(layout.private_corners), bits)?;
    Ok((meta, c, layout))
}

/// Every brick record and its points: occupancy non-zero, private mask within it, residual
/// offset and first private leaf the running sums, every point's code in −Q..=Q; the totals.
fn validate_bricks(records: &[u8], residuals: &[u8], c: &V3Counts, bits: ValueBits) -> Result<()> {
    let q = max_code(bits);
    let (mut leaves, mut private, mut offset) = (0u64, 0u64, 0u64);
    for (b, rec) in records.chunks_exact(BRICK_RECORD_SIZE).enumerate() {
        let r = Brick::from(BrickRecord::read(rec));
        if r.occupancy == 0 {
            return corrupt("bricks", format!("brick {b} has no leaf"));
        }
        if r.private & !r.occupancy != 0 {
            return corrupt(
                "bricks",
                format!(
                    "brick {b}: private cells {:#x} are not leaves",
                    r.private & !r.occupancy
                ),
            );
        }
        if u64::from(r.first_private_leaf) != private {
            return corrupt(
                "bricks",
                format!(
                    "brick {b} first_private_leaf {}, expected {private}",
                    r.first_private_leaf
                ),
            );
        }
        if r.residual_offset() as u64 != offset {
            return corrupt(
                "bricks",
                format!(
                    "brick {b} residual offset {}, expected {offset}",
                    r.residual_offset()
                ),
            );
        }
        let points = point_mask(r.shared());
        let n = u64::from(points.count_ones());
        let w = r.width(bits);
        let size = (n * u64::from(w)).div_ceil(8);
        if offset + size > residuals.len() as u64 {
            return corrupt(
                "residuals",
                format!(
                    "brick {b} needs bytes {offset}..{}, the section has {}",
                    offset + size,
                    residuals.len()
                ),
            );
        }
        let res = &residuals[offset as usize..(offset + size) as usize];
        let mut rest = points;
        let mut rank = 0;
        while rest != 0 {
            let g = rest.trailing_zeros();
            rest &= rest - 1;
            let code = wrap(
                plane_predict(r.plane, grid_point(g), bits) + residual_at(res, rank, w),
                bits,
            );
            if code.abs() > q {
                return corrupt(
                    "residuals",
                    format!("brick {b} point {rank} decodes to {code}, outside ±{q}"),
                );
            }
            rank += 1;
        }
        // Bits after the last residual in its byte are padding.
        if (n * u64::from(w)) % 8 != 0 {
            let used = (n * u64::from(w)) % 8;
            if res[res.len() - 1] >> used != 0 {
                return corrupt("residuals", format!("brick {b}: padding bits set"));
            }
        }
        leaves += u64::from(r.occupancy.count_ones());
        private += u64::from(r.private.count_ones());
        offset += size;
    }
    check_counted(
        "bricks",
        &[
            ("leaves", leaves, c.tree.leaves),
            ("private leaves", private, c.private_leaves),
        ],
    )?;
    if offset != residuals.len() as u64 {
        return corrupt(
            "residuals_size",
            format!("{}, but the bricks use {offset}", residuals.len()),
        );
    }
    Ok(())
}

/// The private leaf groups and corners of a 3.1 file: each group's first voxel and wide voxels
/// before it equal the running sums, each real slot's count 1..=127, each padding slot 0, the
/// sums equal the header's private voxels and the wide voxels its corners' size implies, and
/// every private voxel's codes (narrow ones decoded) in −Q..=Q.
fn validate_private_v31(
    groups: &[u8],
    corners: &[u8],
    c: &V3Counts,
    bits: ValueBits,
) -> Result<()> {
    let q = max_code(bits);
    let pl = u64::from(c.private_leaves);
    let (mut voxel, mut wide) = (0u64, 0u64);
    for (g, rec) in groups.chunks_exact(private_group_size(1)).enumerate() {
        let (first, before, _) = crate::narrow::group31_at(rec, 0);
        if (u64::from(first), u64::from(before)) != (voxel, wide) {
            return corrupt(
                "private_leaves",
                format!(
                    "group {g}: first voxel {first}, wide before {before}; expected {voxel}, {wide}"
                ),
            );
        }
        for (s, &byte) in rec[8..].iter().enumerate() {
            let j = (g * 16 + s) as u64;
            let n = u64::from(byte & !WIDE_BIT);
            if j >= pl {
                if byte != 0 {
                    return corrupt("private_leaves", format!("padding slot {j} is {byte:#x}"));
                }
                continue;
            }
            if n == 0 {
                return corrupt("private_leaves", format!("private leaf {j} has no voxel"));
            }
            let is_wide = byte & WIDE_BIT != 0;
            if voxel + n > u64::from(c.private_voxels)
                || (is_wide && wide + n > u64::from(c.wide_voxels))
            {
                return corrupt(
                    "private_leaves",
                    format!("private leaf {j} runs past the private voxels or wide voxels"),
                );
            }
            for _ in 0..n {
                let at = corner_offset(voxel as u32, wide as u32, bits);
                let codes = private_codes(corners, at, is_wide, bits);
                if let Some(k) = codes.iter().position(|x| x.abs() > q) {
                    return corrupt(
                        "private_corners",
                        format!(
                            "private voxel {voxel} corner {k} is {}, outside ±{q}",
                            codes[k]
                        ),
                    );
                }
                voxel += 1;
                wide += u64::from(is_wide);
            }
        }
    }
    check_counted("private_leaves", &[("voxels", voxel, c.private_voxels)])?;
    // (The wide voxels are implied by the private corners' size.)
    if wide != u64::from(c.wide_voxels) {
        let size_says = c.wide_voxels;
        return corrupt(
            "private_corners_size",
            format!("{wide} wide voxels in the counts, {size_says} by the size"),
        );
    }
    Ok(())
}

/// The private flags: padding bits 0, popcounts equal to the surface and clip counts, every
/// private leaf with a voxel that is not clip-only and at most
/// [`MAX_CLIP_VOXELS_PER_LEAF`] clip voxels (the private leaf groups are valid).
fn validate_flags(flags: &[u8], private_leaves: &[u8], c: &V3Counts) -> Result<()> {
    let pv = u64::from(c.private_voxels);
    let flag = |v: u64| flags[(2 * v / 8) as usize] >> (2 * v % 8) & 3;
    let (mut surface, mut clip) = (0u64, 0u64);
    for (w, word) in flags.chunks_exact(8).enumerate() {
        let x = u64::from_le_bytes(bytes_at::<8>(word, 0));
        let valid = pv.saturating_sub(w as u64 * 32).min(32);
        if valid < 32 && x >> (2 * valid) != 0 {
            return corrupt("private_flags", format!("padding bits set in word {w}"));
        }
        surface += u64::from((x & 0x5555_5555_5555_5555).count_ones());
        clip += u64::from((x & 0xaaaa_aaaa_aaaa_aaaa).count_ones());
    }
    check_counted(
        "private_flags",
        &[
            ("surface bits", surface, c.tree.surface),
            ("clip bits", clip, c.tree.clip),
        ],
    )?;
    if c.tree.clip == 0 {
        return Ok(());
    }
    let mut v = 0u64;
    for (j, (n, _)) in slots(private_leaves, c.minor).enumerate() {
        let (start, end) = (v, v + u64::from(n));
        v = end;
        if n > 0 && (start..end).all(|x| flag(x) == 3) {
            return corrupt(
                "private_flags",
                format!("private leaf {j} has only clip-only voxels"),
            );
        }
        let clips = (start..end).filter(|&x| flag(x) & 2 != 0).count();
        if clips > MAX_CLIP_VOXELS_PER_LEAF {
            return corrupt(
                "private_flags",
                format!(
                    "private leaf {j} has {clips} clip voxels (at most {MAX_CLIP_VOXELS_PER_LEAF})"
                ),
            );
        }
    }
    Ok(())
}
