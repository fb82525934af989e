//! The packed SDF multi-octree: its in-memory layout, its `.smo` file and its validation.
//!
//! A [`PackedOctree`] is built from the leaves the builder produces ([`LeafInput`]: a cell at the
//! target depth and its voxels, each 8 corner signed distances plus a *surface* and a *clip*
//! flag) with [`PackedOctree::from_leaves`], saved with [`PackedOctree::save`] / [`PackedOctree::to_bytes`]
//! and read back with [`PackedOctree::load`] / [`PackedOctree::from_bytes`], which validate every
//! count, offset and index, and the CRC-32, before using anything.
//!
//! # One reader: the octree is its file
//!
//! There is one octree type, [`Octree<B>`](Octree), over any buffer `B: AsRef<[u8]>` holding a
//! validated `.smo` file, with one set of accessors that read its little-endian bytes in place
//! (as NanoVDB's grid is its buffer). [`PackedOctree`] = `Octree<Vec<u8>>` owns the bytes
//! ([`Octree::as_bytes`] is the file; `to_bytes` copies it, `save` writes it);
//! [`PackedOctreeView`] = `Octree<&[u8]>` borrows them (zero copy, e.g. a memory-mapped file or a
//! buffer shared with a GPU). An octree is made only by [`PackedOctree::from_leaves`], which
//! writes the file straight into its buffer, or by [`Octree::new`], which validates bytes once;
//! code generic over the buffer takes `&Octree<B>` (static dispatch). The header is read and
//! written through one table, [`HEADER_FIELDS`], so the field order is written down once.
//!
//! # Layout (the crate's `FORMAT.md` specifies it byte by byte)
//!
//! Nodes are numbered breadth first: the root is node 0, and the children of every node follow
//! in order, so the children of one node are contiguous and, because a child's octant is
//! `4x + 2y + z`, the leaves come out in Morton order. All inner nodes (levels `0..depth`) come
//! before all leaves (level `depth`); node `k` is a leaf iff `k >= inner_count`.
//!
//! * **Inner nodes** are stored in groups of eight (a 12-byte record): the eight child
//!   masks (bit `i` set = a child in octant `i = 4x + 2y + z`) and the node index of the first
//!   child of the group's first node. The first child of any node is that base plus the popcount
//!   of the masks before it in the group, and its child in octant `o` adds the popcount of its own
//!   mask below bit `o`: one 64-bit popcount in all ([`Octree::child`]). 1.5 bytes per
//!   inner node.
//! * **Leaves** are not nodes with records of their own: they are stored in groups of eight
//!   (a 12-byte record): the eight voxel counts (1..=255) and the index of the first voxel
//!   of the group's first leaf; a leaf's voxels start after its predecessors' in the group.
//!   1.5 bytes per leaf.
//! * **Surface flags**: one bit per voxel (bit `v % 64` of 64-bit word `v / 64`).
//! * **Clip flags** (only in files with clip voxels, version 1.1): one bit per voxel, the same
//!   way, after the corners. A clip voxel intersects the other voxels of its leaf (see
//!   [`Voxel::clip`]).
//! * **Corners**: 8 signed codes per voxel, corner `i = 4x + 2y + z`, quantised symmetrically over
//!   `± dmax` (the leaf diagonal, see [`quant`]): 8 bytes per voxel at 8 bits, 16 at 16 bits.
//!
//! With one voxel per leaf (the SVO) and about four children per inner node that is
//! 8 + 1.5 + 1.5 / 3 + 1/8 ≈ 10.1 bytes per voxel at 8 bits, everything included.
//!
//! # Traversal access
//!
//! The tracer walks the octree with [`Octree::root`], [`Octree::child_mask`],
//! [`Octree::child`], [`Octree::first_child_index`], [`Octree::is_leaf`],
//! [`Octree::leaf_voxels`], [`Octree::voxel_corners`], [`Octree::voxel_is_surface`],
//! [`Octree::voxel_is_clip`] and [`Octree::any_clip_voxel`]:
//! `#[inline]`, allocation-free, a couple of fixed-size unaligned loads each, bounds-checked (an
//! index from another octree panics). A [`NodeRef`] is a `Copy` node index.

#![deny(missing_docs)]

/// Public getters of an octree's counts, one per `doc name => field` row (`field` a path such
/// as `tree.leaves`): `name` returns `self.counts.field` (a `u32`) as `usize`. The 1.x octree and the 3.0 brick octree list theirs
/// through it.
macro_rules! count_getters {
    ($($(#[$doc:meta])* $name:ident => $($field:ident).+,)*) => {$(
        $(#[$doc])*
        #[inline]
        pub fn $name(&self) -> usize {
            self.counts.$($field).+ as usize
        }
    )*};
}

/// The accessors of an octree type over bytes `B: AsRef<[u8]>` that read its `bytes`, `meta`
/// and `dequant` fields as they are: the 1.x octree and the 3.0 brick octree have them alike.
macro_rules! buffer_accessors {
    () => {
        /// The whole `.smo` file, header to checksum.
        #[inline]
        pub fn as_bytes(&self) -> &[u8] {
            self.bytes.as_ref()
        }

        /// Depth, quantisation and normalisation transform.
        #[inline]
        pub fn meta(&self) -> &OctreeMeta {
            &self.meta
        }

        /// Leaves sit at this level (in a brick octree at least
        /// [`BRICK_LEVELS`](crate::BRICK_LEVELS), 2).
        #[inline]
        pub fn depth(&self) -> u8 {
            self.meta.depth
        }

        /// `dmax / Q`: multiply a stored code by this to get a distance in normalised units.
        #[inline]
        pub fn dequant_scale(&self) -> f32 {
            self.dequant
        }
    };
}

/// `PartialEq` across buffer types and `Eq` for an octree type over bytes `B: AsRef<[u8]>`
/// with an `as_bytes`: equal when their bytes are (the rest is derived from them). The 1.x
/// octree and the 3.0 brick octree compare through it.
macro_rules! equal_by_bytes {
    ($octree:ident) => {
        impl<A: AsRef<[u8]>, B: AsRef<[u8]>> PartialEq<$octree<B>> for $octree<A> {
            /// Equal bytes (the rest is derived from them).
            fn eq(&self, other: &$octree<B>) -> bool {
                self.as_bytes() == other.as_bytes()
            }
        }

        impl<B: AsRef<[u8]>> Eq for $octree<B> {}
    };
}

mod brick;
mod brick_lod;
pub mod compressed;
mod crc32;
mod error;
mod file;
mod header;
mod interpolant;
pub mod kernel;
mod lod;
mod morton;
mod narrow;
mod octree;
pub mod quant;
#[cfg(any(test, feature = "test-support"))]
pub mod testing;
mod trace;
mod validate;

use glam::Vec3;

pub use brick::{
    brick_residual_bits, cell_grid_index, fit_brick_plane, is_v3, plane_predict, point_mask,
    BrickLeaf, BrickNode, BrickOctree, BrickOctreeView, BrickSectionSizes, CORNER_POINT_OFFSETS,
};
pub use brick_lod::{
    decode_levels, decode_levels_prefix, decode_levels_stats, encode_levels, is_brick_levels,
    LevelBlockStats, BRICK_LOD_VERSION_MAJOR, BRICK_LOD_VERSION_MINOR, LEVEL_BLOCK_HEAD,
};
pub use crc32::crc32;
pub use error::{FormatError, Result};
pub use file::SectionSizes;
pub use header::{
    lod_header_size, plane_fraction_bits, residual_widths, HeaderField, BRICK_EDGE, BRICK_LEVELS,
    BRICK_POINT_EDGE, BRICK_RECORD_FIELDS, BRICK_RECORD_SIZE, CHECKSUM_SIZE, FLAG_CLIP_VOXELS,
    FLAG_MULTI_VOXEL, FLAG_SURFACE_VOXELS, FORMAT_VERSION_MAJOR, FORMAT_VERSION_MINOR,
    HEADER_FIELDS, HEADER_SIZE, KNOWN_FLAGS, LOD_HEADER_FIELDS, LOD_HEADER_FIXED,
    LOD_HEADER_TRAILER, LOD_LEVEL_ENTRY, LOD_LEVEL_FIELDS, LOD_TRAILER_FIELDS, LOD_VERSION_MAJOR,
    LOD_VERSION_MINOR, MAGIC, RESIDUAL_OFFSET_BITS, V31_MAX_LEAF_VOXELS, V3_HEADER_FIELDS,
    V3_HEADER_SIZE, V3_VERSION_MAJOR, V3_VERSION_MINOR,
};
pub use interpolant::{
    cell_corners, cell_size, child_coord, corner_offset, trilinear, trilinear_gradient,
};
pub use lod::{
    check_smo_head, read_smo, LevelEntry, LodOctree, LodPrefix, SmoFile, SmoLevel, SmoPrefix,
    SmoRead, SMO_HEAD_BYTES,
};
pub use octree::{NodeRef, Octree, PackedOctree, PackedOctreeView};
pub use trace::{BrickCache, BrickVoxel, BrickVoxels, TracedOctree};

/// Deepest supported octree (leaf coordinates up to 2^16 per axis).
pub const MAX_DEPTH: u8 = 16;

/// Most voxels one leaf may hold (its count is one byte).
pub const MAX_VOXELS_PER_LEAF: usize = 255;

/// Most voxels with the clip bit one leaf may hold (format 1.1; `FORMAT.md`, section `clip`).
///
/// The clip rule tests every candidate hit of a leaf's voxels against every *other* clip voxel
/// of the leaf, so its work per leaf is at most (voxels × 4 candidates × clip voxels) interpolant
/// evaluations: with this bound, linear in the leaf's voxels. Without it a valid file of
/// 4,096 leaves of 255 intersect voxels took 51 s to render 128² on the CPU (issue 19). The
/// builder emits at most 3 (a sharp corner of three faces; 2 rim planes of an open sheet):
/// measured on the shared meshes at depths 5–10, see `sdfmo-build`'s tests. 8 leaves room for
/// a vertex of up to 8 faces.
pub const MAX_CLIP_VOXELS_PER_LEAF: usize = 8;

/// The extension of a `.smo` file, without the dot: the command-line tool and the Python package
/// refuse to write an octree under any other (`sdfmo_io::check_extension`).
pub const FILE_EXTENSION: &str = "smo";

/// Largest `.smo` file [`PackedOctree::load`] reads (16 GiB); a larger file is refused before
/// any memory is allocated (use [`PackedOctree::load_with_limit`] to change it).
pub const MAX_FILE_SIZE: u64 = 1 << 34;

/// Bits per quantised corner value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ValueBits {
    /// 8-bit codes in −127..=127 (the default: 8 bytes per voxel).
    #[default]
    Eight,
    /// 16-bit codes in −32767..=32767 (16 bytes per voxel).
    Sixteen,
}

impl ValueBits {
    /// 8 or 16.
    #[inline]
    pub const fn bits(self) -> u8 {
        match self {
            ValueBits::Eight => 8,
            ValueBits::Sixteen => 16,
        }
    }

    /// Bytes of one corner code (1 or 2).
    #[inline]
    pub const fn bytes(self) -> usize {
        self.bits() as usize / 8
    }

    /// `ValueBits` from 8 or 16.
    pub const fn from_bits(bits: u8) -> Option<ValueBits> {
        match bits {
            8 => Some(ValueBits::Eight),
            16 => Some(ValueBits::Sixteen),
            _ => None,
        }
    }
}

/// One voxel as the builder produces it: corner signed distances in normalised units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Voxel {
    /// Signed distances at the cell corners, index `4x + 2y + z`, negative inside.
    pub corners: [f32; 8],
    /// Surface (thin) voxel: its zero set is a surface without inside or outside.
    pub surface: bool,
    /// Clip voxel: it clips (intersects) the other voxels of its leaf — a hit of any other
    /// voxel of the leaf counts only where this voxel's interpolant is ≤ 0. A volume voxel with
    /// the clip bit (an *intersect* voxel) is also hit itself, as a volume voxel; a surface voxel
    /// with the clip bit (a *clip-only* voxel) is never hit itself. So two intersect voxels make
    /// the solid `max(a, b) ≤ 0` (a sharp convex edge), and a surface voxel with a clip-only
    /// voxel is the sheet cut where the clip voxel turns positive (an open rim). A leaf may not
    /// consist of clip-only voxels alone. `FORMAT.md` (section `clip`) states the rule exactly.
    pub clip: bool,
}

impl Voxel {
    /// A clip-only voxel (surface + clip): it only clips the other voxels of its leaf.
    #[inline]
    pub fn is_clip_only(&self) -> bool {
        self.surface && self.clip
    }
}

/// A leaf at the target depth: integer cell coordinates in `[0, 2^depth)³` and its voxels (≥ 1).
#[derive(Clone, Debug, PartialEq)]
pub struct LeafInput {
    /// Cell coordinates; the cell spans `[-1 + c·h, -1 + (c + 1)·h]` with `h = 2 / 2^depth`.
    pub coord: [u32; 3],
    /// The leaf's voxels (1..=255), in the order they are stored.
    pub voxels: Vec<Voxel>,
}

/// What describes the octree as a whole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctreeMeta {
    /// Leaves sit at this level; the root cube `[-1, 1]³` is level 0.
    pub depth: u8,
    /// Corner quantisation.
    pub bits: ValueBits,
    /// Normalisation: `normalized = (model − center) · scale`.
    pub center: Vec3,
    /// Normalisation scale (finite, > 0).
    pub scale: f32,
}

impl OctreeMeta {
    /// An octree whose normalised frame is the model frame (`center` 0, `scale` 1): the root
    /// cube is `[-1, 1]³` in model units, as for leaves sampled there directly.
    pub fn unit(depth: u8, bits: ValueBits) -> OctreeMeta {
        OctreeMeta {
            depth,
            bits,
            center: Vec3::ZERO,
            scale: 1.0,
        }
    }

    /// Checks depth and transform.
    pub fn validate(&self) -> Result<()> {
        if self.depth > MAX_DEPTH {
            return Err(FormatError::InvalidDepth {
                depth: self.depth,
                max: MAX_DEPTH,
            });
        }
        if !self.center.is_finite() || !self.scale.is_finite() || self.scale <= 0.0 {
            return Err(FormatError::InvalidTransform {
                center: self.center.to_array(),
                scale: self.scale,
            });
        }
        Ok(())
    }

    /// Edge of a leaf cell: `2 / 2^depth` ([`cell_size`]).
    #[inline]
    pub fn leaf_size(&self) -> f32 {
        cell_size(self.depth)
    }

    /// The quantisation range `dmax`: the leaf diagonal `√3 · 2 / 2^depth`.
    #[inline]
    pub fn dmax(&self) -> f32 {
        quant::voxel_diagonal(self.depth)
    }
}
