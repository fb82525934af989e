//! Levels of bricks: the version-4.0 `.smo` file, every level of a build coarse to fine, each
//! finer level coded from the one before it (`FORMAT.md`, section "Levels of bricks (version
//! 4.0)"; the design and its measurements: `docs/format-3.md`, "Levels").
//!
//! A level is what a 3.0 file holds (bricks of 4³ cells, shared points, private leaves), coded
//! as a stream, not laid out for random access: the offsets a tracer needs are left out (they
//! follow from the counts), each brick's occupancy is given relative to the coarser level's
//! cells where it lies within them, and each brick's points are residuals of either its own
//! plane (as in 3.0) or of the coarser level's codes (a coarse point `P` is the fine point `2P`
//! at twice the code: codes are in units of each level's voxel diagonal), whichever is
//! smaller. Any prefix that ends on a level boundary is a file of fewer levels.
//!
//! [`encode_levels`] writes a [`LodOctree`]; [`decode_levels`] and [`decode_levels_prefix`]
//! validate every count, size, mask, width and code and give each level as the 1.x octree the
//! 2.0 file holds for it, byte for byte (what the tracers read today).

use std::collections::HashMap;

use crate::brick::{
    cell_grid_index, encode_points, fits, gather_bricks, grid_point, plane_predict, point_mask,
    put_residuals, rank_below, residual_at, wrap, CORNER_POINT_OFFSETS,
};
use crate::crc32::crc32;
use crate::error::{corrupt, FormatError, Result};
use crate::header::{align8, lod_header_size, residual_widths, BRICK_LEVELS, CHECKSUM_SIZE};
use crate::lod::{read_prefix, write_header, LevelsVersion};
use crate::narrow::{fits_narrow, private_codes, put_private};
use crate::quant::{dequant_scale, dequantize, max_code};
use crate::{
    morton, LeafInput, LevelEntry, LodOctree, LodPrefix, OctreeMeta, PackedOctree, ValueBits,
    Voxel, MAGIC,
};

/// Major version of a file with levels of bricks.
pub const BRICK_LOD_VERSION_MAJOR: u16 = 4;
/// Minor version of a file with levels of bricks that the writer writes: 4.1 stores a level's
/// private voxels narrow where they fit (as format 3.1 does, `FORMAT.md`); readers take 4.0
/// (every private voxel whole) and 4.1.
pub const BRICK_LOD_VERSION_MINOR: u16 = 1;

/// Bytes of a level block's head: six `u32` counts and sizes.
pub const LEVEL_BLOCK_HEAD: usize = 24;

pub(crate) const LEVELS_V4: LevelsVersion = LevelsVersion {
    major: BRICK_LOD_VERSION_MAJOR,
    minor: BRICK_LOD_VERSION_MINOR,
    // 4.1 changed the private voxels' layout: a newer minor may change it again.
    max_minor: BRICK_LOD_VERSION_MINOR,
    min_block: (LEVEL_BLOCK_HEAD + CHECKSUM_SIZE) as u64,
};

/// Brick mode byte: the residual width code (bits 0–1).
const MODE_WIDTH: u8 = 0b11;
/// Brick mode byte: the points are residuals of the coarser level's prediction (else of the
/// brick's plane, stored after the masks).
const MODE_COARSE: u8 = 1 << 2;
/// Brick mode byte: the occupancy is stored for the cells under the coarser level's leaves only.
const MODE_RELATIVE: u8 = 1 << 3;
/// Brick mode byte: a private mask over the occupied cells follows.
const MODE_PRIVATE: u8 = 1 << 4;
const MODE_KNOWN: u8 = MODE_WIDTH | MODE_COARSE | MODE_RELATIVE | MODE_PRIVATE;

/// One brick of a level: what its 3.0 record says, less the offsets.
#[derive(Clone, Copy, Debug)]
struct LevelBrick {
    /// Morton code of the brick (a node at `depth − 2`).
    code: u64,
    occupancy: u64,
    private: u64,
    /// Index of the brick's first point code in [`Level::codes`].
    first_code: usize,
}

/// One level as the coder sees it: a 1.x octree split as a 3.0 file splits it.
#[derive(Debug, Default)]
struct Level {
    bricks: Vec<LevelBrick>,
    /// Shared point codes, brick by brick, each brick's in grid-index order.
    codes: Vec<i32>,
    /// Voxel count of each private leaf (1..=255), in Morton order.
    private_counts: Vec<u8>,
    /// Each private voxel: its eight codes and flags (bit 0 surface, bit 1 clip).
    private_voxels: Vec<([i32; 8], u8)>,
}

impl Level {
    /// The level of a 1.x octree of depth ≥ 2.
    fn of(octree: &PackedOctree) -> Level {
        let (builds, private) = gather_bricks(octree);
        let mut level = Level::default();
        for b in &builds {
            let first_code = level.codes.len();
            let mask = point_mask(b.occupancy & !b.private);
            level.codes.extend(
                (0..125usize)
                    .filter(|&g| mask >> g & 1 != 0)
                    .map(|g| b.points[g].expect("a shared cell's corners are points")),
            );
            level.bricks.push(LevelBrick {
                code: b.code,
                occupancy: b.occupancy,
                private: b.private,
                first_code,
            });
        }
        for r in private {
            level.private_counts.push(r.len() as u8); // 1..=255 in a valid octree
            for v in r {
                let flags =
                    u8::from(octree.voxel_is_surface(v)) | u8::from(octree.voxel_is_clip(v)) << 1;
                level
                    .private_voxels
                    .push((octree.voxel_codes(v).map(i32::from), flags));
            }
        }
        level
    }

    /// The 1.x octree of this level (depth `meta.depth`).
    fn to_octree(&self, meta: OctreeMeta) -> Result<PackedOctree> {
        let scale = dequant_scale(meta.depth, meta.bits);
        let mut leaves = Vec::new();
        let (mut pl, mut pv) = (0usize, 0usize);
        for b in &self.bricks {
            let bc = morton::decode(b.code);
            let mask = point_mask(b.occupancy & !b.private);
            for cell in (0..64u32).filter(|c| b.occupancy >> c & 1 != 0) {
                let g = cell_grid_index(cell);
                let [x, y, z] = grid_point(g);
                let coord = [4 * bc[0] + x, 4 * bc[1] + y, 4 * bc[2] + z];
                let voxels = if b.private >> cell & 1 != 0 {
                    let n = usize::from(self.private_counts[pl]);
                    pl += 1;
                    let v = self.private_voxels[pv..pv + n]
                        .iter()
                        .map(|(codes, flags)| Voxel {
                            corners: codes.map(|c| dequantize(c, scale)),
                            surface: flags & 1 != 0,
                            clip: flags & 2 != 0,
                        })
                        .collect();
                    pv += n;
                    v
                } else {
                    let corners = std::array::from_fn(|k| {
                        let rank = rank_below(mask, g + CORNER_POINT_OFFSETS[k]) as usize;
                        dequantize(self.codes[b.first_code + rank], scale)
                    });
                    vec![Voxel {
                        corners,
                        surface: false,
                        clip: false,
                    }]
                };
                leaves.push(LeafInput { coord, voxels });
            }
        }
        // Codes × dmax/Q re-quantise to the same codes (as BrickOctree::to_octree relies on).
        PackedOctree::from_leaves(meta, leaves).map_err(|e| FormatError::Corrupt {
            field: "level block",
            reason: format!("level {}: {e}", meta.depth),
        })
    }
}

/// What a level tells the next finer one: its shared point codes by grid point and its
/// occupancy by brick.
struct Coarse {
    points: HashMap<u64, i32>,
    occupancy: HashMap<u64, u64>,
}

/// A key for grid point `p` (each coordinate ≤ 2^16).
#[inline]
fn point_key(p: [u32; 3]) -> u64 {
    u64::from(p[0]) << 42 | u64::from(p[1]) << 21 | u64::from(p[2])
}

impl Coarse {
    fn of(level: &Level) -> Coarse {
        let mut points = HashMap::with_capacity(level.codes.len());
        let mut occupancy = HashMap::with_capacity(level.bricks.len());
        for b in &level.bricks {
            occupancy.insert(b.code, b.occupancy);
            let bc = morton::decode(b.code);
            let mask = point_mask(b.occupancy & !b.private);
            for (rank, g) in (0..125u32).filter(|g| mask >> g & 1 != 0).enumerate() {
                let [x, y, z] = grid_point(g);
                let p = [4 * bc[0] + x, 4 * bc[1] + y, 4 * bc[2] + z];
                // A point on a brick face may be in two bricks: the first one's code is used.
                points
                    .entry(point_key(p))
                    .or_insert(level.codes[b.first_code + rank]);
            }
        }
        Coarse { points, occupancy }
    }

    /// The code the coarser level predicts at fine grid point `g`: twice its code where a
    /// coarse point coincides (`g` even), else the mean of the 2, 4 or 8 coarse points around
    /// it doubled and rounded half up (`⌊(Σ + 2^(m−2)) / 2^(m−1)⌋` for `m` odd coordinates),
    /// clamped to ±Q; 0 when one of those coarse points is missing.
    fn predict(&self, g: [u32; 3], bits: ValueBits) -> i32 {
        let odd = [g[0] & 1, g[1] & 1, g[2] & 1];
        let m = odd.iter().sum::<u32>();
        let base = [g[0] >> 1, g[1] >> 1, g[2] >> 1];
        let mut sum = 0i32;
        for dx in 0..=odd[0] {
            for dy in 0..=odd[1] {
                for dz in 0..=odd[2] {
                    let p = [base[0] + dx, base[1] + dy, base[2] + dz];
                    match self.points.get(&point_key(p)) {
                        Some(&c) => sum += c,
                        None => return 0,
                    }
                }
            }
        }
        let pred = if m == 0 {
            2 * sum
        } else {
            (sum + ((1 << (m - 1)) >> 1)) >> (m - 1)
        };
        let q = max_code(bits);
        pred.clamp(-q, q)
    }

    /// The coarser level's occupancy byte over fine brick `code`: bit `j` says whether the
    /// coarse cell above the fine brick's half-brick `j` is a leaf.
    fn cells_above(&self, code: u64) -> u8 {
        self.occupancy
            .get(&(code >> 3))
            .map_or(0, |o| (o >> (8 * (code & 7))) as u8)
    }
}

/// The fine cells under the coarse cells of `above` (Morton bits of a fine brick).
#[inline]
fn under(above: u8) -> u64 {
    (0..8)
        .filter(|j| above >> j & 1 != 0)
        .fold(0, |m, j| m | 0xff << (8 * j))
}

/// Residual bytes of `n` points at `w` bits (each brick starts on a byte).
#[inline]
fn residual_bytes(n: usize, w: u32) -> usize {
    (n * w as usize).div_ceil(8)
}

/// The grid point of brick `bc`'s local point `g`.
#[inline]
fn global_point(bc: [u32; 3], g: u32) -> [u32; 3] {
    let [x, y, z] = grid_point(g);
    [4 * bc[0] + x, 4 * bc[1] + y, 4 * bc[2] + z]
}

fn to_u32(n: usize, what: &'static str) -> Result<u32> {
    u32::try_from(n).map_err(|_| FormatError::TooLarge {
        what,
        count: n as u64,
    })
}

/// The child masks of the nodes above bricks `codes` (Morton codes at `levels` below the root,
/// sorted), breadth first.
fn upper_masks(codes: &[u64], levels: u8) -> Vec<u8> {
    let mut per_level: Vec<Vec<u8>> = Vec::new();
    let mut cur = codes.to_vec();
    for _ in 0..levels {
        let (mut parents, mut masks) = (Vec::new(), Vec::<u8>::new());
        for &c in &cur {
            if parents.last() != Some(&(c >> 3)) {
                parents.push(c >> 3);
                masks.push(0);
            }
            if let Some(m) = masks.last_mut() {
                *m |= 1 << (c & 7);
            }
        }
        per_level.push(masks);
        cur = parents;
    }
    per_level.into_iter().rev().flatten().collect()
}

/// The level block of `level` (depth `depth`), coded from `coarse` (the level before it).
fn encode_block(
    level: &Level,
    depth: u8,
    bits: ValueBits,
    coarse: &Option<Coarse>,
) -> Result<Vec<u8>> {
    let codes: Vec<u64> = level.bricks.iter().map(|b| b.code).collect();
    let masks = upper_masks(&codes, depth - BRICK_LEVELS);
    let widths = residual_widths(bits);
    let (mut records, mut residuals) = (Vec::new(), Vec::new());
    for b in &level.bricks {
        let bc = morton::decode(b.code);
        let mut mode = 0u8;
        let mut rec = Vec::with_capacity(25);
        // Occupancy: under the coarser level's leaves when it lies there.
        let above = coarse.as_ref().map(|c| c.cells_above(b.code));
        match above {
            Some(a) if b.occupancy & !under(a) == 0 => {
                mode |= MODE_RELATIVE;
                rec.extend(
                    (0..8)
                        .filter(|j| a >> j & 1 != 0)
                        .map(|j| (b.occupancy >> (8 * j)) as u8),
                );
            }
            _ => rec.extend(b.occupancy.to_le_bytes()),
        }
        if b.private != 0 {
            mode |= MODE_PRIVATE;
            let bits_over_occupied = (0..64)
                .filter(|c| b.occupancy >> c & 1 != 0)
                .map(|c| (b.private >> c & 1) as u8);
            let mut packed = vec![0u8; (b.occupancy.count_ones() as usize).div_ceil(8)];
            for (i, bit) in bits_over_occupied.enumerate() {
                packed[i / 8] |= bit << (i % 8);
            }
            rec.extend(packed);
        }
        // Points: the plane's residuals (as 3.0) or the coarser level's, the fewer bytes.
        let mask = point_mask(b.occupancy & !b.private);
        let n = mask.count_ones() as usize;
        let points = &level.codes[b.first_code..b.first_code + n];
        let grid: Vec<u32> = (0..125u32).filter(|g| mask >> g & 1 != 0).collect();
        let samples: Vec<([u32; 3], i32)> = grid
            .iter()
            .zip(points)
            .map(|(&g, &c)| (grid_point(g), c))
            .collect();
        let (plane, plane_code, plane_res) = encode_points(&samples, bits);
        let from_coarse: Vec<i32> = grid
            .iter()
            .zip(points)
            .map(|(&g, &c)| {
                let pred = coarse
                    .as_ref()
                    .map_or(0, |k| k.predict(global_point(bc, g), bits));
                wrap(c - pred, bits)
            })
            .collect();
        let coarse_code = (0..3).find(|&k| fits(&from_coarse, widths[k])).unwrap_or(3) as u32;
        let plane_cost = 8 + residual_bytes(n, widths[plane_code as usize]);
        let coarse_cost = residual_bytes(n, widths[coarse_code as usize]);
        if coarse_cost < plane_cost {
            mode |= MODE_COARSE | coarse_code as u8;
            put_residuals(&mut residuals, &from_coarse, widths[coarse_code as usize]);
        } else {
            mode |= plane_code as u8;
            for t in plane {
                rec.extend(t.to_le_bytes());
            }
            put_residuals(&mut residuals, &plane_res, widths[plane_code as usize]);
        }
        records.push(mode);
        records.extend(rec);
    }
    let code_bytes = bits.bytes();
    let pv = level.private_voxels.len();
    let head = [
        to_u32(masks.len(), "upper nodes")?,
        to_u32(level.bricks.len(), "bricks")?,
        to_u32(level.private_counts.len(), "private leaves")?,
        to_u32(pv, "private voxels")?,
        to_u32(records.len(), "brick record bytes")?,
        to_u32(residuals.len(), "residual bytes")?,
    ];
    let mut out = Vec::with_capacity(
        LEVEL_BLOCK_HEAD
            + masks.len()
            + records.len()
            + residuals.len()
            + pv * (8 * code_bytes + 1),
    );
    for v in head {
        out.extend(v.to_le_bytes());
    }
    out.extend(&masks);
    out.extend(&records);
    out.extend(&residuals);
    out.extend(&level.private_counts);
    let mut flags = vec![0u8; (2 * pv).div_ceil(8)];
    for (i, (_, f)) in level.private_voxels.iter().enumerate() {
        flags[2 * i / 8] |= f << (2 * i % 8);
    }
    out.extend(flags);
    // 4.1: a wide bit per private voxel, then each voxel narrow (6·b bytes) or whole (8·b).
    let narrow: Vec<bool> = level
        .private_voxels
        .iter()
        .map(|(codes, _)| fits_narrow(*codes, bits))
        .collect();
    let mut wide = vec![0u8; pv.div_ceil(8)];
    for (i, &n) in narrow.iter().enumerate() {
        wide[i / 8] |= u8::from(!n) << (i % 8);
    }
    out.extend(wide);
    for ((codes, _), &n) in level.private_voxels.iter().zip(&narrow) {
        let mut v = [0u8; 16];
        let len = put_private(&mut v, *codes, !n, bits);
        out.extend(&v[..len]);
    }
    let crc = crc32(&out);
    out.extend(crc.to_le_bytes());
    Ok(out)
}

/// Writes `lod` as a version-4.1 file: the 2.0 header (version 4.1) with its level table, then
/// one level block per level, coarsest first, each at a multiple of 8 and coded from the one
/// before it. Deterministic.
///
/// Errors: [`FormatError::Unrepresentable`] when the coarsest level is below depth 2 (a brick
/// spans two levels); [`FormatError::TooLarge`] when a count overflows 32 bits.
pub fn encode_levels(lod: &LodOctree) -> Result<Vec<u8>> {
    if lod.coarsest() < BRICK_LEVELS {
        return Err(FormatError::Unrepresentable {
            major: BRICK_LOD_VERSION_MAJOR,
            reason: format!(
                "coarsest level {} is below the brick's {BRICK_LEVELS} levels",
                lod.coarsest()
            ),
        });
    }
    let bits = lod.meta().bits;
    let mut blocks = Vec::with_capacity(lod.levels().len());
    let mut coarse: Option<Coarse> = None;
    for octree in lod.levels() {
        let level = Level::of(octree);
        blocks.push(encode_block(&level, octree.depth(), bits, &coarse)?);
        coarse = Some(Coarse::of(&level));
    }
    let mut offset = lod_header_size(blocks.len()) as u64;
    let entries: Vec<LevelEntry> = blocks
        .iter()
        .zip(lod.levels())
        .map(|(b, o)| {
            let e = LevelEntry {
                level: o.depth(),
                offset,
                size: b.len() as u64,
            };
            offset = align8(e.end());
            e
        })
        .collect();
    let size = entries.last().map_or(0, LevelEntry::end);
    let mut out = vec![
        0u8;
        usize::try_from(size).map_err(|_| FormatError::TooLarge {
            what: "file bytes",
            count: size,
        })?
    ];
    write_header(&mut out, LEVELS_V4, &lod.meta(), &entries);
    for (e, b) in entries.iter().zip(&blocks) {
        out[e.offset as usize..e.end() as usize].copy_from_slice(b);
    }
    Ok(out)
}

/// Whether `bytes` start like a version-4.0 file (magic and major version 4).
pub fn is_brick_levels(bytes: &[u8]) -> bool {
    bytes.len() >= 10
        && bytes[..8] == MAGIC
        && u16::from_le_bytes([bytes[8], bytes[9]]) == BRICK_LOD_VERSION_MAJOR
}

/// Reads a whole version-4.0 file: every level decoded (and validated) to the 1.x octree of
/// that level. A file shorter or longer than its `file_size` is refused.
pub fn decode_levels(bytes: &[u8]) -> Result<LodOctree> {
    let p = decode_levels_prefix(bytes)?;
    if (bytes.len() as u64) < p.file_size {
        return Err(FormatError::Truncated {
            len: bytes.len(),
            needed: p.file_size,
        });
    }
    Ok(p.octree)
}

/// Reads the complete levels of a prefix of a version-4.0 file, as
/// [`LodOctree::from_prefix`] reads a 2.0 file's: the header must be complete; every level
/// block that ends within the prefix is validated (its CRC-32, every count, size, mask, width
/// and code) and decoded, coarsest first; a cut level and those after it are left out.
pub fn decode_levels_prefix(bytes: &[u8]) -> Result<LodPrefix> {
    decode_prefix(bytes, &mut Vec::new())
}

/// What one level block of a 4.0 file spends its bytes on, and how its bricks were coded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LevelBlockStats {
    /// The level (its depth).
    pub level: u8,
    /// Bytes of the block, head to CRC-32.
    pub bytes: u64,
    /// Bricks of the level.
    pub bricks: u64,
    /// Bytes of the child masks above the bricks.
    pub upper_bytes: u64,
    /// Bytes of the brick records (mode, occupancy, private mask, plane).
    pub record_bytes: u64,
    /// Bytes of the point residuals.
    pub residual_bytes: u64,
    /// Bytes of the private leaves, flags and corners.
    pub private_bytes: u64,
    /// Bricks whose occupancy is coded under the coarser level's leaves.
    pub relative_bricks: u64,
    /// Bricks whose points are residuals of the coarser level's codes.
    pub coarse_bricks: u64,
}

/// [`decode_levels_prefix`], and what each complete level's block holds (for `sdfmo info` and
/// the measurements of `docs/format-3.md`).
pub fn decode_levels_stats(bytes: &[u8]) -> Result<(LodPrefix, Vec<LevelBlockStats>)> {
    let mut stats = Vec::new();
    let p = decode_prefix(bytes, &mut stats)?;
    Ok((p, stats))
}

fn decode_prefix(bytes: &[u8], stats: &mut Vec<LevelBlockStats>) -> Result<LodPrefix> {
    let mut coarse: Option<Coarse> = None;
    read_prefix(bytes, LEVELS_V4, |block, entry, header| {
        let meta = OctreeMeta {
            depth: entry.level,
            ..header.meta
        };
        // The minor decides how the block stores its private voxels (4.0: all whole).
        let minor = header.minor;
        if meta.depth < BRICK_LEVELS {
            return corrupt("levels", format!("level {} is below depth 2", meta.depth));
        }
        let mut st = LevelBlockStats {
            level: entry.level,
            bytes: entry.size,
            ..LevelBlockStats::default()
        };
        let level = decode_block(block, meta.depth, meta.bits, minor, &coarse, &mut st).map_err(
            |e| match e {
                FormatError::Corrupt { field, reason } => FormatError::Corrupt {
                    field,
                    reason: format!("level {}: {reason}", entry.level),
                },
                e => e,
            },
        )?;
        let octree = level.to_octree(meta)?;
        coarse = Some(Coarse::of(&level));
        stats.push(st);
        Ok(octree)
    })
}

/// A bounds-checked reader over one section of a level block.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
    section: &'static str,
}

impl<'a> Cursor<'a> {
    fn new(bytes: &'a [u8], section: &'static str) -> Cursor<'a> {
        Cursor {
            bytes,
            at: 0,
            section,
        }
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        if self.bytes.len() - self.at < n {
            return corrupt(
                self.section,
                format!(
                    "needs {n} bytes at {}, has {}",
                    self.at,
                    self.bytes.len() - self.at
                ),
            );
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn byte(&mut self) -> Result<u8> {
        Ok(self.take(1)?[0])
    }

    fn finish(&self) -> Result<()> {
        if self.at != self.bytes.len() {
            return corrupt(
                self.section,
                format!("{} bytes declared, {} used", self.bytes.len(), self.at),
            );
        }
        Ok(())
    }
}

/// Splits `n` bytes off the front of `rest`.
fn split<'a>(rest: &mut &'a [u8], n: u64, section: &'static str) -> Result<&'a [u8]> {
    if (rest.len() as u64) < n {
        return corrupt(
            section,
            format!("{n} bytes declared, {} left in the block", rest.len()),
        );
    }
    let (s, r) = rest.split_at(n as usize);
    *rest = r;
    Ok(s)
}

/// Decodes and validates one level block (its bytes from head to CRC-32).
fn decode_block(
    block: &[u8],
    depth: u8,
    bits: ValueBits,
    minor: u16,
    coarse: &Option<Coarse>,
    st: &mut LevelBlockStats,
) -> Result<Level> {
    let len = block.len();
    if len < LEVEL_BLOCK_HEAD + CHECKSUM_SIZE {
        return corrupt("level block", format!("{len} bytes (at least 28)"));
    }
    let crc_at = len - CHECKSUM_SIZE;
    let stored = u32::from_le_bytes(block[crc_at..].try_into().expect("4 bytes"));
    let computed = crc32(&block[..crc_at]);
    if stored != computed {
        return Err(FormatError::ChecksumMismatch { stored, computed });
    }
    let head: [u32; 6] = std::array::from_fn(|i| {
        u32::from_le_bytes(block[4 * i..4 * i + 4].try_into().expect("4 bytes"))
    });
    let [upper, bricks, private_leaves, private_voxels, record_bytes, res_bytes] = head;
    let code_bytes = bits.bytes() as u64;
    let pv = u64::from(private_voxels);
    let mut rest = &block[LEVEL_BLOCK_HEAD..crc_at];
    let masks = split(&mut rest, u64::from(upper), "upper masks")?;
    let records = split(&mut rest, u64::from(record_bytes), "brick records")?;
    let res = split(&mut rest, u64::from(res_bytes), "residuals")?;
    let counts = split(&mut rest, u64::from(private_leaves), "private leaves")?;
    let flags = split(&mut rest, (2 * pv).div_ceil(8), "private flags")?;
    // 4.0: every private voxel whole; 4.1: a wide bit per voxel, narrow voxels in 6·b bytes.
    let wide_bits = if minor == 0 {
        None
    } else {
        Some(split(&mut rest, pv.div_ceil(8), "private wide bits")?)
    };
    let wide_count = wide_bits.map_or(pv, |w| {
        w.iter().map(|b| u64::from(b.count_ones())).sum::<u64>()
    });
    let corners = split(
        &mut rest,
        2 * code_bytes * (3 * pv + wide_count),
        "private corners",
    )?;
    if !rest.is_empty() {
        return corrupt(
            "level block",
            format!("{} bytes after the private corners", rest.len()),
        );
    }
    st.bricks = u64::from(bricks);
    st.upper_bytes = masks.len() as u64;
    st.record_bytes = records.len() as u64;
    st.residual_bytes = res.len() as u64;
    st.private_bytes =
        (counts.len() + flags.len() + wide_bits.map_or(0, <[u8]>::len) + corners.len()) as u64;

    // Bricks: the child masks above them, breadth first.
    let mut codes: Vec<u64> = if bricks == 0 { Vec::new() } else { vec![0] };
    let mut m = Cursor::new(masks, "upper masks");
    for _ in BRICK_LEVELS..depth {
        if codes.is_empty() {
            break;
        }
        let mut next = Vec::new();
        for &node in &codes {
            let mask = m.byte()?;
            if mask == 0 {
                return corrupt("upper masks", format!("an empty mask at byte {}", m.at - 1));
            }
            next.extend(
                (0..8u64)
                    .filter(|o| mask >> o & 1 != 0)
                    .map(|o| node << 3 | o),
            );
        }
        codes = next;
    }
    m.finish()?;
    if codes.len() != bricks as usize {
        return corrupt(
            "bricks",
            format!("{bricks} declared, the upper masks give {}", codes.len()),
        );
    }

    let q = max_code(bits);
    let widths = residual_widths(bits);
    let mut level = Level::default();
    let mut r = Cursor::new(records, "brick records");
    let mut rs = Cursor::new(res, "residuals");
    for code in codes {
        let mode = r.byte()?;
        if mode & !MODE_KNOWN != 0 {
            return corrupt("brick records", format!("mode byte {mode:#x}"));
        }
        st.relative_bricks += u64::from(mode & MODE_RELATIVE != 0);
        st.coarse_bricks += u64::from(mode & MODE_COARSE != 0);
        let occupancy = if mode & MODE_RELATIVE != 0 {
            let Some(c) = coarse else {
                return corrupt("brick records", "relative occupancy in the coarsest level");
            };
            let above = c.cells_above(code);
            let bytes = r.take(above.count_ones() as usize)?;
            (0..8)
                .filter(|j| above >> j & 1 != 0)
                .zip(bytes)
                .fold(0u64, |o, (j, &b)| o | u64::from(b) << (8 * j))
        } else {
            u64::from_le_bytes(r.take(8)?.try_into().expect("8 bytes"))
        };
        if occupancy == 0 {
            return corrupt("brick records", format!("brick {code:#x} has no leaf"));
        }
        let private = if mode & MODE_PRIVATE != 0 {
            let n = occupancy.count_ones() as usize;
            let packed = r.take(n.div_ceil(8))?;
            let mut p = 0u64;
            for (i, c) in (0..64).filter(|c| occupancy >> c & 1 != 0).enumerate() {
                p |= u64::from(packed[i / 8] >> (i % 8) & 1) << c;
            }
            if !n.is_multiple_of(8) && packed[n / 8] >> (n % 8) != 0 {
                return corrupt(
                    "brick records",
                    "bits past the occupied cells of a private mask",
                );
            }
            if p == 0 {
                return corrupt("brick records", "an empty private mask");
            }
            p
        } else {
            0
        };
        let plane = if mode & MODE_COARSE == 0 {
            let t = r.take(8)?;
            Some(std::array::from_fn(|i| {
                i16::from_le_bytes([t[2 * i], t[2 * i + 1]])
            }))
        } else {
            None
        };
        let mask = point_mask(occupancy & !private);
        let n = mask.count_ones() as usize;
        let w = widths[usize::from(mode & MODE_WIDTH)];
        let rb = rs.take(residual_bytes(n, w))?;
        let bc = morton::decode(code);
        let first_code = level.codes.len();
        for (rank, g) in (0..125u32).filter(|g| mask >> g & 1 != 0).enumerate() {
            let pred = match (plane, coarse) {
                (Some(p), _) => plane_predict(p, grid_point(g), bits),
                (None, Some(c)) => c.predict(global_point(bc, g), bits),
                (None, None) => 0,
            };
            let c = wrap(pred + residual_at(rb, rank as u32, w), bits);
            if c.abs() > q {
                return corrupt("residuals", format!("code {c} outside ±{q}"));
            }
            level.codes.push(c);
        }
        level.bricks.push(LevelBrick {
            code,
            occupancy,
            private,
            first_code,
        });
    }
    r.finish()?;
    rs.finish()?;

    let declared: u64 = level
        .bricks
        .iter()
        .map(|b| u64::from(b.private.count_ones()))
        .sum();
    if declared != u64::from(private_leaves) {
        return corrupt(
            "private leaves",
            format!("{private_leaves} declared, the private masks give {declared}"),
        );
    }
    if counts.contains(&0) {
        return corrupt("private leaves", "a private leaf of 0 voxels");
    }
    let sum: u64 = counts.iter().map(|&c| u64::from(c)).sum();
    if sum != pv {
        return corrupt(
            "private voxels",
            format!("{pv} declared, the private leaves hold {sum}"),
        );
    }
    if !pv.is_multiple_of(4) && flags[flags.len() - 1] >> (2 * (pv % 4)) != 0 {
        return corrupt("private flags", "bits past the last voxel");
    }
    if let Some(w) = wide_bits {
        if !pv.is_multiple_of(8) && w[w.len() - 1] >> (pv % 8) != 0 {
            return corrupt("private wide bits", "bits past the last voxel");
        }
    }
    level.private_counts = counts.to_vec();
    let cb = code_bytes as usize;
    let mut at = 0usize;
    for i in 0..pv as usize {
        let wide = wide_bits.is_none_or(|w| w[i / 8] >> (i % 8) & 1 != 0);
        // In bounds: the section's size is the sum of the voxels' sizes (split above).
        let codes = private_codes(corners, at, wide, bits);
        at += if wide { 8 * cb } else { 6 * cb };
        if let Some(c) = codes.iter().find(|c| c.abs() > q) {
            return corrupt("private corners", format!("code {c} outside ±{q}"));
        }
        level
            .private_voxels
            .push((codes, flags[i / 4] >> (2 * (i % 4)) & 3));
    }
    Ok(level)
}
