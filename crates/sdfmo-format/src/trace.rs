//! The queries a tracer's walk makes of an octree, over both traced layouts: [`TracedOctree`],
//! implemented by the 1.x octree ([`Octree`]) and the 3.0 brick octree ([`BrickOctree`]), so
//! one tracer (`sdfmo-trace`, monomorphised per layout) reads either in place.
//!
//! Both layouts present the same tree: the same cells at the same levels, children in octant
//! order. A 3.0 brick is a node at `depth − 2` whose two lowest levels are walked from its
//! occupancy ([`BrickNode`]), so a walk sees the cells of the 1.x file of the same octree in the
//! same order, and a leaf's voxels in the same order with the same corner values and flags
//! ([`BrickOctree::encode`] is lossless): its hits are the 1.x file's, bit for bit.

use core::fmt::Debug;
use core::ops::Range;

use crate::header::record::{FIRST_PRIVATE_LEAF, OCCUPANCY, PLANE, PRIVATE, RESIDUALS};
use crate::header::{
    plane_fraction_bits, residual_widths, BRICK_RECORD_SIZE, RESIDUAL_OFFSET_BITS,
    RESIDUAL_OFFSET_MASK,
};
use crate::narrow::{corner_offset, private_codes, private_leaf_at};
use crate::octree::{bytes_at, low_bits};
use crate::quant::max_code;
use crate::{
    cell_grid_index, point_mask, BrickNode, BrickOctree, NodeRef, Octree, OctreeMeta, ValueBits,
    CORNER_POINT_OFFSETS,
};

/// An octree as a tracer walks it (see the module docs): nodes from the root down by child
/// masks, a leaf's voxels, each voxel's corners and flags. Every query reads the validated
/// buffer in place (no allocation); a node, child base or voxel from another octree may panic.
pub trait TracedOctree {
    /// A node (`Copy`, cheap).
    type Node: Copy + Debug;
    /// What [`TracedOctree::child_of`] needs of an inner node to name its children (read once
    /// per node, however many children a walk takes).
    type Children: Copy;
    /// A voxel, as a hit names it (for [`TracedOctree::voxel_corners`]).
    type Voxel: Copy + PartialEq + Debug;
    /// A leaf's voxels, in storage order.
    type Voxels: Iterator<Item = Self::Voxel> + Clone;
    /// What a walk may keep from one leaf's voxels to the next for
    /// [`TracedOctree::voxel_corners_with`] (`()` where nothing is worth keeping).
    type LeafCache: Default;

    /// Depth, quantisation and normalisation transform.
    fn meta(&self) -> &OctreeMeta;
    /// The root; `None` for an empty octree.
    fn root(&self) -> Option<Self::Node>;
    /// Whether `node` is a leaf.
    fn is_leaf(&self, node: Self::Node) -> bool;
    /// Child mask of an inner node: bit `i` set = a child in octant `i = 4x + 2y + z`.
    fn child_mask(&self, node: Self::Node) -> u8;
    /// What names the children of the inner node `node` (see [`TracedOctree::child_of`]).
    fn children(&self, node: Self::Node) -> Self::Children;
    /// The child in `octant` (present in `mask`, the node's [`TracedOctree::child_mask`]) of
    /// the node whose [`TracedOctree::children`] is `children`.
    fn child_of(&self, children: Self::Children, mask: u32, octant: u32) -> Self::Node;
    /// The child of `node` in `octant` (`4x + 2y + z`, 0..8), if there is one.
    fn child(&self, node: Self::Node, octant: u8) -> Option<Self::Node>;
    /// The voxels of the leaf `node` (none for an inner node).
    fn leaf_voxels(&self, node: Self::Node) -> Self::Voxels;
    /// Whether any voxel of `voxels` (one leaf's) has the clip bit: the test that picks the
    /// clip rule over the plain nearest hit.
    fn any_clip_voxel(&self, voxels: &Self::Voxels) -> bool;
    /// The voxel's eight corner distances (`4x + 2y + z`), dequantised, normalised units.
    fn voxel_corners(&self, voxel: Self::Voxel) -> [f32; 8];
    /// [`TracedOctree::voxel_corners`], reusing what `cache` (one walk's, made with
    /// `Default`) keeps from the voxels fetched before: the same corners. A cache filled by
    /// another octree may give wrong corners or panic (as a voxel of another octree may).
    #[inline(always)]
    fn voxel_corners_with(&self, voxel: Self::Voxel, cache: &mut Self::LeafCache) -> [f32; 8] {
        let _ = cache;
        self.voxel_corners(voxel)
    }
    /// Whether the voxel is a surface (thin) voxel.
    fn voxel_is_surface(&self, voxel: Self::Voxel) -> bool;
    /// Whether the voxel has the clip bit.
    fn voxel_is_clip(&self, voxel: Self::Voxel) -> bool;
    /// Whether `voxel` names a voxel of this octree (a hit from another octree may not).
    fn has_voxel(&self, voxel: Self::Voxel) -> bool;
}

/// Trait methods that answer with the octree's inherent method of the same name, one line each
/// instead of a forwarding body each. `#[inline(always)]`, as every query of a walk: the trait
/// adds no call to the inherent method's.
macro_rules! inherent_queries {
    ($octree:ident: $(fn $name:ident(&self $(, $arg:ident: $ty:ty)*) -> $ret:ty;)*) => {$(
        #[inline(always)]
        fn $name(&self $(, $arg: $ty)*) -> $ret {
            $octree::$name(self $(, $arg)*)
        }
    )*};
}

impl<B: AsRef<[u8]>> TracedOctree for Octree<B> {
    type LeafCache = ();
    type Node = NodeRef;
    /// The index of the first child.
    type Children = u32;
    /// The voxel's index.
    type Voxel = u32;
    type Voxels = Range<u32>;

    inherent_queries! { Octree:
        fn meta(&self) -> &OctreeMeta;
        fn root(&self) -> Option<NodeRef>;
        fn is_leaf(&self, node: NodeRef) -> bool;
        fn child_mask(&self, node: NodeRef) -> u8;
        fn child(&self, node: NodeRef, octant: u8) -> Option<NodeRef>;
        fn leaf_voxels(&self, node: NodeRef) -> Range<u32>;
        fn voxel_corners(&self, voxel: u32) -> [f32; 8];
        fn voxel_is_surface(&self, voxel: u32) -> bool;
        fn voxel_is_clip(&self, voxel: u32) -> bool;
    }

    #[inline(always)]
    fn children(&self, node: NodeRef) -> u32 {
        self.first_child_index(node)
    }

    /// Children are contiguous in octant order: the first plus those below `octant`.
    #[inline(always)]
    fn child_of(&self, first: u32, mask: u32, octant: u32) -> NodeRef {
        let below = mask & ((1u32 << octant) - 1);
        NodeRef::from_index(first + below.count_ones())
    }

    #[inline(always)]
    fn any_clip_voxel(&self, voxels: &Range<u32>) -> bool {
        Octree::any_clip_voxel(self, voxels.clone())
    }

    #[inline(always)]
    fn has_voxel(&self, voxel: u32) -> bool {
        (voxel as usize) < self.voxel_count()
    }
}

/// A voxel of a [`BrickOctree`], as a hit names it: the one voxel of a shared leaf (its corners
/// are points of the brick), or a private voxel by its index in the private sections.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BrickVoxel {
    /// The voxel of the shared leaf in `cell` (Morton index, 0..64) of `brick`.
    Shared {
        /// The brick.
        brick: u32,
        /// The leaf's cell in it.
        cell: u8,
    },
    /// A private voxel.
    Private {
        /// Its number in the private flag section.
        voxel: u32,
        /// Wide private voxels before it: its codes are at `2·b·(3·voxel + wide_before)` of the
        /// private corners (`FORMAT.md`, "Narrow private voxels (version 3.1)").
        wide_before: u32,
        /// Whether its eight codes are stored whole (else narrow; always in 3.0).
        wide: bool,
    },
}

/// The voxels of one [`BrickOctree`] leaf, in storage order.
#[derive(Clone, Debug)]
pub struct BrickVoxels {
    /// The shared leaf's voxel, until taken; `None` for a private leaf.
    shared: Option<BrickVoxel>,
    /// The private voxels not yet taken.
    private: Range<u32>,
    /// Wide private voxels before the next one taken.
    wide_before: u32,
    /// Whether the leaf's voxels are wide.
    wide: bool,
}

impl Iterator for BrickVoxels {
    type Item = BrickVoxel;

    #[inline(always)]
    fn next(&mut self) -> Option<BrickVoxel> {
        if let Some(v) = self.shared.take() {
            return Some(v);
        }
        let voxel = self.private.next()?;
        let wide_before = self.wide_before;
        self.wide_before += u32::from(self.wide);
        Some(BrickVoxel::Private {
            voxel,
            wide_before,
            wide: self.wide,
        })
    }
}

/// The `u64` at `at` of a brick record.
#[inline(always)]
fn u64_in(r: &[u8; BRICK_RECORD_SIZE], at: usize) -> u64 {
    u64::from_le_bytes(bytes_at::<8>(r, at))
}

/// The `u32` at `at` of a brick record.
#[inline(always)]
fn u32_in(r: &[u8; BRICK_RECORD_SIZE], at: usize) -> u32 {
    u32::from_le_bytes(bytes_at::<4>(r, at))
}

/// The eight `W`-bit residuals (W = 0, 2, 4, 8 or 16, sign-extended) of the points `ranks` in
/// a brick's residual bytes `res` (LSB first; fields below 16 bits never straddle a byte).
#[inline(always)]
fn residuals<const W: u32>(res: &[u8], ranks: &[u32; 8]) -> [i32; 8] {
    // Plain loops, not `array::map`: the map's closure was not inlined (callgrind).
    let mut out = [0i32; 8];
    if W == 0 {
        return out;
    }
    for i in 0..8 {
        let rank = ranks[i];
        out[i] = if W == 16 {
            i32::from(i16::from_le_bytes(bytes_at::<2>(res, 2 * rank as usize)))
        } else {
            let bit = rank * W;
            let field = u32::from(res[(bit >> 3) as usize]) >> (bit & 7);
            ((field << (32 - W)) as i32) >> (32 - W)
        };
    }
    out
}

/// Bytes [`shared_residuals`] copies at once: the eight corners' residuals lie within 32
/// consecutive ranks, so within `(31·16 + 7) / 8 + 4 = 66` bytes of the first one's byte.
const RESIDUAL_SPAN: usize = 72;

/// The eight `w`-bit residuals (w = 0, 2, 4, 8 or 16, sign-extended) of the points `ranks`
/// (ascending, within 31 of the first) of the residual bytes starting at `base` of `bytes`.
///
/// Why not [`residuals`] alone: it pays a bounds check and a byte load per corner after a
/// match on the width; here one bounds check for [`RESIDUAL_SPAN`] bytes, then one four-byte
/// read per corner within them (its index masked below 64, so unchecked) and one path for every
/// width. With the point table of `point_mask`: abc1 / abc5 depth 9 multi, paper view 0,
/// 223.3 → 219.5 M and 319.3 → 306.1 M instructions per 3.1 frame (callgrind). Where fewer
/// bytes remain (the file's last bricks), the exact per-byte reads.
#[inline(always)]
fn shared_residuals(bytes: &[u8], base: usize, w: u32, ranks: &[u32; 8]) -> [i32; 8] {
    let mut out = [0i32; 8];
    if w == 0 {
        return out;
    }
    let first = ((ranks[0] * w) >> 3) as usize;
    let Some(span) = bytes
        .get(base + first..)
        .and_then(|b| b.first_chunk::<RESIDUAL_SPAN>())
    else {
        let res = &bytes[base..];
        return match w {
            2 => residuals::<2>(res, ranks),
            4 => residuals::<4>(res, ranks),
            8 => residuals::<8>(res, ranks),
            _ => residuals::<16>(res, ranks),
        };
    };
    for (v, &rank) in out.iter_mut().zip(ranks) {
        let bit = rank * w;
        let at = ((bit >> 3) as usize - first) & 63;
        let field = u32::from_le_bytes(bytes_at::<4>(span, at)) >> (bit & 7);
        *v = ((field << (32 - w)) as i32) >> (32 - w);
    }
    out
}

/// What a walk keeps of the brick whose shared voxel it fetched last
/// ([`TracedOctree::voxel_corners_with`] of a [`BrickOctree`]): its point mask, plane and
/// residuals' place. Opaque; made empty by `Default`.
#[derive(Clone, Copy, Debug)]
pub struct BrickCache {
    /// The brick (`u32::MAX`: none yet; no file has that many bricks).
    brick: u32,
    points: u128,
    plane: [i32; 4],
    base: usize,
    width: u32,
}

impl Default for BrickCache {
    fn default() -> Self {
        BrickCache {
            brick: u32::MAX,
            points: 0,
            plane: [0; 4],
            base: 0,
            width: 0,
        }
    }
}

/// What a shared voxel's eight codes are made from ([`BrickOctree::shared_fetch`]).
#[derive(Clone, Debug)]
struct SharedFetch {
    /// Points of the brick below the voxel's lowest corner.
    below: u32,
    /// The brick's points from the lowest corner on (bit `o`: the point `o` above it).
    window: u32,
    /// The plane at the lowest corner, in 1/2^f code units.
    t0: i32,
    /// The plane's steps along x, y and z.
    steps: [i32; 3],
    /// Where the brick's residuals start in the bytes.
    base: usize,
    /// Their width in bits (0, 2, 4, 8 or 16).
    width: u32,
    bits: ValueBits,
}

/// The eight codes `fetch` describes: seven popcounts of the window, the plane by adding its
/// terms, and the residuals by [`shared_residuals`].
#[inline(always)]
fn shared_codes(fetch: &SharedFetch, bytes: &[u8]) -> [i32; 8] {
    let mut ranks = [0u32; 8];
    for (rank, o) in ranks.iter_mut().zip(CORNER_POINT_OFFSETS) {
        *rank = fetch.below + (fetch.window & ((1u32 << o) - 1)).count_ones();
    }
    let bits = fetch.bits;
    let (f, q) = (plane_fraction_bits(bits), max_code(bits));
    let res = shared_residuals(bytes, fetch.base, fetch.width, &ranks);
    let [b, c, d] = fetch.steps;
    let mut codes = [0i32; 8];
    for (i, code) in codes.iter_mut().enumerate() {
        let t = fetch.t0 + b * (i >> 2) as i32 + c * (i >> 1 & 1) as i32 + d * (i & 1) as i32;
        let pred = ((t + ((1 << f) >> 1)) >> f).clamp(-q, q);
        // A full-width residual wraps modulo 2^bits (FORMAT.md).
        *code = match bits {
            ValueBits::Eight => i32::from((pred + res[i]) as i8),
            ValueBits::Sixteen => i32::from((pred + res[i]) as i16),
        };
    }
    codes
}

/// A shared voxel's corners with AVX2: the eight ranks, residuals and predictions in one
/// register each.
///
/// Why: decoding a shared voxel lane by lane (seven popcounts, eight residual reads, eight
/// predictions) was about 325 instructions, against about 10 for a 1.x voxel's corners; the
/// largest part of what a 3.1 frame costs more than a 1.x frame (callgrind, abc1 depth 9
/// multi, paper view 0). Same integer operations, so the same codes (tested against the
/// scalar path), and the same f32 product per corner.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{SharedFetch, RESIDUAL_SPAN};
    use crate::header::plane_fraction_bits;
    use crate::quant::max_code;
    use crate::ValueBits;
    use core::arch::x86_64::*;

    /// The corners, or `None` where fewer than [`RESIDUAL_SPAN`] bytes follow the first
    /// corner's residual (the caller takes the scalar path).
    ///
    /// # Safety
    /// The CPU has AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn shared_corners(
        fetch: &SharedFetch,
        bytes: &[u8],
        scale: f32,
    ) -> Option<[f32; 8]> {
        // SAFETY (the whole body): AVX2 is the caller's contract; the gather reads 4 bytes at
        // offsets below 64 + 4 of a span of RESIDUAL_SPAN (72) bytes checked to lie in `bytes`.
        unsafe {
            // Ranks: `below` plus the points of the window below each corner's offset,
            // counted by nibbles (a shuffle table) and summed per 32-bit lane.
            let below_masks = _mm256_setr_epi32(
                0,
                1,
                0x1f,
                0x3f,
                0x1ff_ffff,
                0x3ff_ffff,
                0x3fff_ffff,
                0x7fff_ffff,
            );
            let v = _mm256_and_si256(_mm256_set1_epi32(fetch.window as i32), below_masks);
            let nibble_counts = _mm256_setr_epi8(
                0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4, 0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3,
                2, 3, 3, 4,
            );
            let low = _mm256_set1_epi8(0x0f);
            let per_byte = _mm256_add_epi8(
                _mm256_shuffle_epi8(nibble_counts, _mm256_and_si256(v, low)),
                _mm256_shuffle_epi8(
                    nibble_counts,
                    _mm256_and_si256(_mm256_srli_epi32(v, 4), low),
                ),
            );
            let per_lane = _mm256_madd_epi16(
                _mm256_maddubs_epi16(per_byte, _mm256_set1_epi8(1)),
                _mm256_set1_epi16(1),
            );
            let ranks = _mm256_add_epi32(per_lane, _mm256_set1_epi32(fetch.below as i32));

            let w = fetch.width;
            let res = if w == 0 {
                _mm256_setzero_si256()
            } else {
                let first = ((fetch.below * w) >> 3) as usize;
                let span = bytes
                    .get(fetch.base + first..)?
                    .first_chunk::<RESIDUAL_SPAN>()?;
                let bit = _mm256_mullo_epi32(ranks, _mm256_set1_epi32(w as i32));
                let at = _mm256_and_si256(
                    _mm256_sub_epi32(_mm256_srli_epi32(bit, 3), _mm256_set1_epi32(first as i32)),
                    _mm256_set1_epi32(63),
                );
                let word = _mm256_i32gather_epi32::<1>(span.as_ptr().cast(), at);
                let field = _mm256_srlv_epi32(word, _mm256_and_si256(bit, _mm256_set1_epi32(7)));
                let shift = _mm_cvtsi32_si128(32 - w as i32);
                _mm256_sra_epi32(_mm256_sll_epi32(field, shift), shift)
            };

            // Predictions: the plane at each corner (x = i >> 2, y = i >> 1 & 1, z = i & 1),
            // rounded to codes and clamped, plus the residual, wrapped to the code width.
            let [b, c, d] = fetch.steps;
            let dx = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
            let dy = _mm256_setr_epi32(0, 0, 1, 1, 0, 0, 1, 1);
            let dz = _mm256_setr_epi32(0, 1, 0, 1, 0, 1, 0, 1);
            let t = _mm256_add_epi32(
                _mm256_add_epi32(
                    _mm256_set1_epi32(fetch.t0),
                    _mm256_mullo_epi32(_mm256_set1_epi32(b), dx),
                ),
                _mm256_add_epi32(
                    _mm256_mullo_epi32(_mm256_set1_epi32(c), dy),
                    _mm256_mullo_epi32(_mm256_set1_epi32(d), dz),
                ),
            );
            let f = plane_fraction_bits(fetch.bits);
            let q = max_code(fetch.bits);
            let half = _mm256_set1_epi32((1 << f) >> 1);
            let pred = _mm256_sra_epi32(_mm256_add_epi32(t, half), _mm_cvtsi32_si128(f as i32));
            let pred = _mm256_min_epi32(
                _mm256_max_epi32(pred, _mm256_set1_epi32(-q)),
                _mm256_set1_epi32(q),
            );
            let wrap = _mm_cvtsi32_si128(match fetch.bits {
                ValueBits::Eight => 24,
                ValueBits::Sixteen => 16,
            });
            let code = _mm256_sra_epi32(_mm256_sll_epi32(_mm256_add_epi32(pred, res), wrap), wrap);
            let corners = _mm256_mul_ps(_mm256_cvtepi32_ps(code), _mm256_set1_ps(scale));
            let mut out = [0.0f32; 8];
            _mm256_storeu_ps(out.as_mut_ptr(), corners);
            Some(out)
        }
    }
}

impl<B: AsRef<[u8]>> BrickOctree<B> {
    /// The record of `brick` (one bounds-checked load of its 32 bytes).
    #[inline(always)]
    fn record(&self, brick: u32) -> [u8; BRICK_RECORD_SIZE] {
        bytes_at::<BRICK_RECORD_SIZE>(
            self.as_bytes(),
            self.layout.bricks.0 as usize + brick as usize * BRICK_RECORD_SIZE,
        )
    }

    /// Inner nodes plus leaves of the same octree in the 1.x layout
    /// ([`Octree::node_count`]), counted without expanding it: the nodes above the bricks,
    /// the bricks, each brick's occupied half-bricks (its non-zero occupancy bytes) and the
    /// leaves. One pass over the brick records.
    pub fn node_count(&self) -> usize {
        let halves: usize = (0..self.brick_count() as u32)
            .map(|b| {
                let occupancy = self.occupancy(b);
                (0..8).filter(|k| occupancy >> (8 * k) & 0xff != 0).count()
            })
            .sum();
        self.upper_node_count() + self.brick_count() + halves + self.leaf_count()
    }

    /// The occupancy of `brick` (one load).
    #[inline(always)]
    fn occupancy(&self, brick: u32) -> u64 {
        u64::from_le_bytes(bytes_at::<8>(
            self.as_bytes(),
            self.layout.bricks.0 as usize + brick as usize * BRICK_RECORD_SIZE + OCCUPANCY,
        ))
    }

    /// What the codes of every shared leaf of `brick` are made from: its point mask, its plane
    /// and where its residuals are (one read of the brick's record).
    #[inline(always)]
    fn brick_fetch(&self, brick: u32) -> BrickCache {
        let r = self.record(brick);
        let shared = u64_in(&r, OCCUPANCY) & !u64_in(&r, PRIVATE);
        let word = u32_in(&r, RESIDUALS);
        BrickCache {
            brick,
            points: point_mask(shared),
            plane: core::array::from_fn(|i| {
                i32::from(i16::from_le_bytes(bytes_at::<2>(&r, PLANE + 2 * i)))
            }),
            base: self.layout.residuals.0 as usize + (word & RESIDUAL_OFFSET_MASK) as usize,
            width: residual_widths(self.meta().bits)[(word >> RESIDUAL_OFFSET_BITS) as usize],
        }
    }

    /// What the eight codes of the shared leaf in `cell` of the brick `b` describes are made
    /// from: one rank below the cell and a 32-bit window of points above it, and the plane at
    /// the cell's lowest corner.
    #[inline(always)]
    fn shared_fetch(&self, b: &BrickCache, cell: u8) -> SharedFetch {
        let g = cell_grid_index(u32::from(cell));
        let c = u32::from(cell);
        let (x, y, z) = (
            ((c >> 5 & 1) * 2 + (c >> 2 & 1)) as i32,
            ((c >> 4 & 1) * 2 + (c >> 1 & 1)) as i32,
            ((c >> 3 & 1) * 2 + (c & 1)) as i32,
        );
        let plane = b.plane;
        SharedFetch {
            below: (b.points & ((1u128 << g) - 1)).count_ones(),
            // The corners lie within 31 points of the lowest one.
            window: (b.points >> g) as u32,
            t0: plane[0] + plane[1] * x + plane[2] * y + plane[3] * z,
            steps: [plane[1], plane[2], plane[3]],
            base: b.base,
            width: b.width,
            bits: self.meta().bits,
        }
    }

    /// [`TracedOctree::voxel_corners`] of a shared voxel of the brick `b` describes: its codes
    /// times the scale, all eight at once with AVX2 where the CPU has it and the residual span
    /// lies in the bytes.
    #[inline(always)]
    fn shared_corners(&self, b: &BrickCache, cell: u8) -> [f32; 8] {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            let fetch = self.shared_fetch(b, cell);
            // SAFETY: the CPU has AVX2.
            if let Some(corners) =
                unsafe { avx2::shared_corners(&fetch, self.as_bytes(), self.dequant_scale()) }
            {
                return corners;
            }
        }
        let s = self.dequant_scale();
        shared_codes(&self.shared_fetch(b, cell), self.as_bytes()).map(|c| c as f32 * s)
    }

    /// The two flag bits (surface, clip) of private voxel `v`.
    #[inline(always)]
    fn private_flags(&self, v: u32) -> u8 {
        assert!(v < self.counts.private_voxels, "voxel {v} out of range");
        let bit = 2 * v as usize;
        self.as_bytes()[self.layout.private_flags.0 as usize + bit / 8] >> (bit % 8) & 3
    }
}

impl<B: AsRef<[u8]>> TracedOctree for BrickOctree<B> {
    type Node = BrickNode;
    /// The inner node, and for a node above the bricks the index of its first child.
    type Children = (BrickNode, u32);
    type Voxel = BrickVoxel;
    type Voxels = BrickVoxels;
    type LeafCache = BrickCache;

    inherent_queries! { BrickOctree:
        fn meta(&self) -> &OctreeMeta;
        fn root(&self) -> Option<BrickNode>;
        fn child(&self, node: BrickNode, octant: u8) -> Option<BrickNode>;
    }

    #[inline(always)]
    fn is_leaf(&self, node: BrickNode) -> bool {
        matches!(node, BrickNode::Leaf { .. })
    }

    /// Above the bricks a node group's byte; a brick's and a half-brick's from one load of the
    /// brick's occupancy.
    #[inline(always)]
    fn child_mask(&self, node: BrickNode) -> u8 {
        match node {
            BrickNode::Upper(k) => self.upper_child_mask(k),
            BrickNode::Brick(b) => {
                // Bit o set when byte o of the occupancy is non-zero.
                let x = self.occupancy(b);
                let x = x | x >> 4;
                let x = x | x >> 2;
                let x = (x | x >> 1) & 0x0101_0101_0101_0101;
                (x.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u8
            }
            BrickNode::Half { brick, octant } => {
                (self.occupancy(brick) >> (8 * u32::from(octant & 7))) as u8
            }
            BrickNode::Leaf { .. } => 0,
        }
    }

    #[inline(always)]
    fn children(&self, node: BrickNode) -> (BrickNode, u32) {
        match node {
            BrickNode::Upper(k) => (node, self.first_child_index(k)),
            _ => (node, 0),
        }
    }

    #[inline(always)]
    fn child_of(&self, (node, first): (BrickNode, u32), mask: u32, octant: u32) -> BrickNode {
        match node {
            BrickNode::Upper(_) => {
                let below = mask & ((1u32 << octant) - 1);
                self.node(first + below.count_ones())
            }
            BrickNode::Brick(brick) => BrickNode::Half {
                brick,
                octant: octant as u8,
            },
            BrickNode::Half { brick, octant: h } => BrickNode::Leaf {
                brick,
                cell: (h << 3) | octant as u8,
            },
            // A leaf has no children (its mask is 0, so no walk asks).
            BrickNode::Leaf { .. } => node,
        }
    }

    /// A shared leaf from one load of the brick's private mask; a private leaf's voxels from
    /// its leaf group (one popcount, one byte sum), as [`BrickOctree::leaf`] finds them.
    #[inline(always)]
    fn leaf_voxels(&self, node: BrickNode) -> BrickVoxels {
        let none = BrickVoxels {
            shared: None,
            private: 0..0,
            wide_before: 0,
            wide: false,
        };
        let BrickNode::Leaf { brick, cell } = node else {
            return none;
        };
        let r = self.record(brick);
        let cell = cell & 63;
        if u64_in(&r, OCCUPANCY) >> cell & 1 == 0 {
            return none;
        }
        let private = u64_in(&r, PRIVATE);
        if private >> cell & 1 == 0 {
            return BrickVoxels {
                shared: Some(BrickVoxel::Shared { brick, cell }),
                private: 0..0,
                wide_before: 0,
                wide: false,
            };
        }
        let j = u32_in(&r, FIRST_PRIVATE_LEAF) + low_bits(private, u32::from(cell)).count_ones();
        let leaves = self.layout.private_leaves.0 as usize;
        let span = private_leaf_at(self.as_bytes(), leaves, self.counts.minor, j);
        BrickVoxels {
            shared: None,
            private: span.first..span.first + span.count,
            wide_before: span.wide_before,
            wide: span.wide,
        }
    }

    #[inline(always)]
    fn any_clip_voxel(&self, voxels: &BrickVoxels) -> bool {
        self.counts.tree.clip > 0
            && voxels
                .private
                .clone()
                .any(|v| self.private_flags(v) & 2 != 0)
    }

    #[inline(always)]
    fn voxel_corners(&self, voxel: BrickVoxel) -> [f32; 8] {
        let s = self.dequant_scale();
        match voxel {
            BrickVoxel::Shared { brick, cell } => {
                self.shared_corners(&self.brick_fetch(brick), cell)
            }
            BrickVoxel::Private {
                voxel,
                wide_before,
                wide,
            } => {
                assert!(
                    voxel < self.counts.private_voxels,
                    "voxel {voxel} out of range"
                );
                let bits = self.meta().bits;
                let at = self.layout.private_corners.0 as usize
                    + corner_offset(voxel, wide_before, bits);
                let codes = private_codes(self.as_bytes(), at, wide, bits);
                let mut out = [0.0f32; 8];
                for (v, c) in out.iter_mut().zip(codes) {
                    *v = c as f32 * s;
                }
                out
            }
        }
    }

    /// A shared voxel's brick is read once while the walk's voxels stay in it (three in four
    /// consecutive shared voxels of a paper view of abc1 depth 9 did).
    #[inline(always)]
    fn voxel_corners_with(&self, voxel: BrickVoxel, cache: &mut BrickCache) -> [f32; 8] {
        match voxel {
            BrickVoxel::Shared { brick, cell } => {
                if cache.brick != brick {
                    *cache = self.brick_fetch(brick);
                }
                self.shared_corners(cache, cell)
            }
            BrickVoxel::Private { .. } => TracedOctree::voxel_corners(self, voxel),
        }
    }

    #[inline(always)]
    fn voxel_is_surface(&self, voxel: BrickVoxel) -> bool {
        match voxel {
            BrickVoxel::Shared { .. } => false,
            BrickVoxel::Private { voxel, .. } => self.private_flags(voxel) & 1 != 0,
        }
    }

    #[inline(always)]
    fn voxel_is_clip(&self, voxel: BrickVoxel) -> bool {
        match voxel {
            BrickVoxel::Shared { .. } => false,
            BrickVoxel::Private { voxel, .. } => self.private_flags(voxel) & 2 != 0,
        }
    }

    fn has_voxel(&self, voxel: BrickVoxel) -> bool {
        let c = &self.counts;
        match voxel {
            BrickVoxel::Shared { brick, cell } => {
                brick < c.bricks && cell < 64 && {
                    let r = self.record(brick);
                    (u64_in(&r, OCCUPANCY) & !u64_in(&r, PRIVATE)) >> cell & 1 != 0
                }
            }
            // The wide voxels before it and its own size within the corners (3.1: `3·W + X`
            // units of 2·b bytes; 3.0: every voxel wide, `wide_before = voxel`).
            BrickVoxel::Private {
                voxel,
                wide_before,
                wide,
            } => {
                voxel < c.private_voxels
                    && wide_before <= voxel
                    && (c.minor > 0 || (wide && wide_before == voxel))
                    && 3 * u64::from(voxel) + u64::from(wide_before) + 3 + u64::from(wide)
                        <= 3 * u64::from(c.private_voxels) + u64::from(c.wide_voxels)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::sphere_leaves;
    use crate::{BrickOctreeView, LeafInput, PackedOctree, Voxel};

    /// The point mask by its definition: the cells placed in the grid, dilated by one along
    /// +x, +y and +z.
    fn point_mask_by_dilation(shared: u64) -> u128 {
        let mut cells = 0u128;
        for cell in 0..64 {
            if shared >> cell & 1 != 0 {
                cells |= 1 << cell_grid_index(cell);
            }
        }
        let d = cells | cells << 1;
        let d = d | d << 5;
        d | d << 25
    }

    /// A shared voxel's fetch with arbitrary fields (the window and `below` as a brick gives
    /// them: ranks within 31 of the first).
    fn any_fetch() -> impl proptest::strategy::Strategy<Value = SharedFetch> {
        use proptest::prelude::*;
        (
            0u32..100,
            any::<u32>(),
            -40_000i32..40_000,
            proptest::array::uniform3(-4_000i32..4_000),
            0usize..8,
            0usize..5,
            any::<bool>(),
        )
            .prop_map(|(below, window, t0, steps, base, width, sixteen)| {
                let bits = if sixteen {
                    ValueBits::Sixteen
                } else {
                    ValueBits::Eight
                };
                SharedFetch {
                    below,
                    window,
                    t0,
                    steps,
                    base,
                    width: [0, 2, 4, 8, 16][width],
                    bits,
                }
            })
    }

    proptest::proptest! {
        /// The AVX2 corners are the scalar codes times the scale, bit for bit, wherever the
        /// residual span fits (and `None` only where it does not).
        #[cfg(target_arch = "x86_64")]
        #[test]
        fn avx2_corners_are_the_scalar_codes_scaled(
            fetch in any_fetch(),
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 300..400),
            scale in 1e-4f32..1.0,
        ) {
            if std::is_x86_feature_detected!("avx2") {
                // The whole bytes (the span fits) and cut just after the last residual (it
                // may not).
                let last = fetch.below + (fetch.window & 0x7fff_ffff).count_ones();
                let end = fetch.base + ((last + 1) * fetch.width).div_ceil(8) as usize;
                for bytes in [&bytes[..], &bytes[..end]] {
                    let scalar = shared_codes(&fetch, bytes).map(|c| (c as f32 * scale).to_bits());
                    // SAFETY: the CPU has AVX2.
                    let wide = unsafe { avx2::shared_corners(&fetch, bytes, scale) };
                    let first = ((fetch.below * fetch.width) >> 3) as usize;
                    let fits =
                        fetch.width == 0 || fetch.base + first + RESIDUAL_SPAN <= bytes.len();
                    proptest::prop_assert_eq!(wide.is_some(), fits);
                    if let Some(wide) = wide {
                        proptest::prop_assert_eq!(wide.map(f32::to_bits), scalar);
                    }
                }
            }
        }

        #[test]
        fn point_mask_is_the_dilated_cells(shared: u64) {
            proptest::prop_assert_eq!(point_mask(shared), point_mask_by_dilation(shared));
        }

        /// The span read and the exact per-byte read agree on every width, for ranks as a
        /// cell's corners have them (ascending, within 31 of the first), near and far from the
        /// end of the bytes.
        #[test]
        fn shared_residuals_match_the_per_byte_read(
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 200..300),
            first in 0u32..40,
            steps in proptest::array::uniform7(0u32..5),
            width in 0usize..5,
            base in 0usize..8,
        ) {
            let w = [0, 2, 4, 8, 16][width];
            let mut ranks = [first; 8];
            for k in 1..8 {
                ranks[k] = (ranks[k - 1] + steps[k - 1]).min(first + 31);
            }
            let res = &bytes[base..];
            let exact = match w {
                0 => residuals::<0>(res, &ranks),
                2 => residuals::<2>(res, &ranks),
                4 => residuals::<4>(res, &ranks),
                8 => residuals::<8>(res, &ranks),
                _ => residuals::<16>(res, &ranks),
            };
            // The whole bytes (the span fits) and cut just after the last field (it does not).
            let end = base + ((ranks[7] + 1) * w).div_ceil(8) as usize;
            for b in [&bytes[..], &bytes[..end.min(bytes.len())]] {
                proptest::prop_assert_eq!(shared_residuals(b, base, w, &ranks), exact);
            }
        }
    }

    /// The node count read from the bricks is the 1.x octree's.
    #[test]
    fn node_count_is_the_1x_octrees() {
        for octree in octrees() {
            let bricks = BrickOctree::encode(&octree).unwrap();
            assert_eq!(bricks.node_count(), octree.node_count());
        }
    }

    /// Spheres at 8 and 16 bits, some leaves with a second (surface, or clip) voxel: bricks of
    /// every residual width and both kinds of leaf.
    fn octrees() -> Vec<PackedOctree> {
        let mut out = Vec::new();
        for bits in [ValueBits::Eight, ValueBits::Sixteen] {
            for depth in [4, 6] {
                let mut leaves: Vec<LeafInput> = sphere_leaves(depth, 0.6);
                for (i, leaf) in leaves.iter_mut().enumerate() {
                    if i % 7 == 3 {
                        let mut extra: Voxel = leaf.voxels[0];
                        extra.corners = extra.corners.map(|c| c * 0.5 + 0.01);
                        extra.surface = i % 2 == 0;
                        extra.clip = i % 3 == 0;
                        if extra.surface && extra.clip {
                            extra.clip = false;
                        }
                        leaf.voxels.push(extra);
                    }
                }
                let meta = OctreeMeta::unit(depth, bits);
                out.push(PackedOctree::from_leaves(meta, leaves).unwrap());
            }
        }
        out
    }

    /// The traced children of every node are the ones [`BrickOctree::child`] names.
    #[test]
    fn traced_children_are_the_brick_children() {
        for o in octrees() {
            let b = BrickOctree::encode(&o).unwrap();
            let mut todo: Vec<BrickNode> = TracedOctree::root(&b).into_iter().collect();
            let mut visited = 0;
            while let Some(node) = todo.pop() {
                visited += 1;
                let mask = u32::from(TracedOctree::child_mask(&b, node));
                assert_eq!(mask, u32::from(b.child_mask(node)));
                let children = TracedOctree::children(&b, node);
                for octant in 0..8u32 {
                    let expected = b.child(node, octant as u8);
                    assert_eq!(mask >> octant & 1 != 0, expected.is_some());
                    if let Some(expected) = expected {
                        let child = TracedOctree::child_of(&b, children, mask, octant);
                        assert_eq!(child, expected);
                        assert_eq!(TracedOctree::child(&b, node, octant as u8), Some(child));
                        todo.push(child);
                    }
                }
            }
            assert_eq!(visited, b.node_count());
        }
    }

    #[test]
    fn brick_queries_answer_as_the_random_access_does() {
        let (mut shared, mut private) = (0, 0);
        for o in octrees() {
            let b = BrickOctree::encode(&o).unwrap();
            let v = BrickOctreeView::new(b.as_bytes()).unwrap();
            for (coord, leaf) in b.leaves() {
                let node = BrickNode::Leaf {
                    brick: leaf.brick(),
                    cell: leaf.cell(),
                };
                assert!(TracedOctree::is_leaf(&v, node));
                let voxels: Vec<BrickVoxel> = TracedOctree::leaf_voxels(&v, node).collect();
                assert_eq!(voxels.len() as u32, leaf.voxel_count(), "{coord:?}");
                let clip = (0..leaf.voxel_count()).any(|k| b.voxel_is_clip(&leaf, k));
                assert_eq!(
                    TracedOctree::any_clip_voxel(&v, &TracedOctree::leaf_voxels(&v, node)),
                    clip
                );
                for (k, &voxel) in voxels.iter().enumerate() {
                    let k = k as u32;
                    assert!(TracedOctree::has_voxel(&v, voxel));
                    assert_eq!(
                        TracedOctree::voxel_corners(&v, voxel).map(f32::to_bits),
                        b.voxel_corners(&leaf, k).map(f32::to_bits),
                        "{coord:?} voxel {k}"
                    );
                    assert_eq!(
                        TracedOctree::voxel_is_surface(&v, voxel),
                        b.voxel_is_surface(&leaf, k)
                    );
                    assert_eq!(
                        TracedOctree::voxel_is_clip(&v, voxel),
                        b.voxel_is_clip(&leaf, k)
                    );
                    match voxel {
                        BrickVoxel::Shared { .. } => shared += 1,
                        BrickVoxel::Private { .. } => private += 1,
                    }
                }
            }
            // Names that are not voxels of this octree.
            let bricks = b.brick_count() as u32;
            assert!(!TracedOctree::has_voxel(
                &v,
                BrickVoxel::Shared {
                    brick: bricks,
                    cell: 0
                }
            ));
            assert!(!TracedOctree::has_voxel(
                &v,
                BrickVoxel::Private {
                    voxel: b.private_voxel_count() as u32,
                    wide_before: 0,
                    wide: true,
                }
            ));
        }
        assert!(
            shared > 1000 && private > 200,
            "{shared} shared, {private} private"
        );
    }
}
