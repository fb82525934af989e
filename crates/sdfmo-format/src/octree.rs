//! The octree: one type over the `.smo` bytes, owned or borrowed, built from leaves by writing
//! the file straight into its buffer, and the traversal accessors that read it.

use std::fmt;
use std::ops::Range;

use crate::crc32::crc32;
use crate::error::{FormatError, Result};
use crate::header::{minor_version, Counts, Header, Layout, CHECKSUM_SIZE, HEADER_SIZE};
use crate::quant::{self, dequant_scale, quantize};
use crate::{
    morton, LeafInput, OctreeMeta, ValueBits, Voxel, MAX_CLIP_VOXELS_PER_LEAF, MAX_VOXELS_PER_LEAF,
};

/// A node of an [`Octree`]: its breadth-first index (root = 0). Cheap to copy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeRef(pub(crate) u32);

impl NodeRef {
    /// The node's breadth-first index (inner nodes first, then the leaves in Morton order).
    #[inline]
    pub fn index(self) -> u32 {
        self.0
    }

    /// The node with breadth-first index `index` (for tools that store node indices; the
    /// accessors panic on an index outside the octree they are given).
    #[inline]
    pub fn from_index(index: u32) -> NodeRef {
        NodeRef(index)
    }
}

/// Byte offsets of the sections in the buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Sections {
    /// Node groups: 12 bytes per 8 inner nodes (`first_child` u32, then 8 masks).
    nodes: usize,
    /// Leaf groups: 12 bytes per 8 leaves (`first_voxel` u32, then 8 counts).
    leaves: usize,
    /// Surface bitmap: bit `v % 8` of byte `v / 8`.
    surface: usize,
    /// Corner codes: `8 · value_bits / 8` bytes per voxel.
    corners: usize,
    /// Clip bitmap (bit `v % 8` of byte `v / 8`), only when the octree has clip voxels (else
    /// the end of the corners: nothing is read there).
    clip: usize,
}

impl Sections {
    /// The sections of `layout`.
    pub(crate) fn of(layout: &Layout) -> Sections {
        // Every offset is ≤ the file size, which is the length of a buffer in memory.
        Sections {
            nodes: layout.nodes.0 as usize,
            leaves: layout.leaves.0 as usize,
            surface: layout.surface.0 as usize,
            corners: layout.corners.0 as usize,
            clip: layout.clip.0 as usize,
        }
    }

    /// The header's size: the node section starts right after it (headers are a multiple of
    /// 8 bytes).
    pub(crate) fn header_size(&self) -> usize {
        self.nodes
    }
}

/// The packed sparse multi-octree: a validated `.smo` file (see the crate docs for the layout
/// and `FORMAT.md` for the bytes) in a buffer `B`, read in place by one set of accessors.
///
/// The octree *is* its file: [`PackedOctree`] (`Octree<Vec<u8>>`) owns the bytes,
/// [`PackedOctreeView`] (`Octree<&[u8]>`) borrows them (e.g. a memory-mapped file), and any
/// other `B: AsRef<[u8]>` works the same. An octree is only made by [`PackedOctree::from_leaves`]
/// (which writes the file into a new buffer) or by [`Octree::new`] (which validates bytes first),
/// so every index a traversal computes from it is in bounds; the accessors still bounds-check,
/// and panic on a [`NodeRef`] or voxel index from another octree.
///
/// `B::as_ref` must give the same bytes every time (as `Vec`, slices, `Box<[u8]>`, `Arc<[u8]>`
/// and memory maps do): validation reads them once. Two octrees are equal when their bytes are.
#[derive(Clone, Copy)]
pub struct Octree<B = Vec<u8>> {
    bytes: B,
    pub(crate) meta: OctreeMeta,
    pub(crate) counts: Counts,
    pub(crate) sections: Sections,
    /// `dmax / Q`: code → distance.
    dequant: f32,
}

/// The owned octree: its buffer is the `.smo` file. Made by [`PackedOctree::from_leaves`],
/// [`PackedOctree::from_bytes`], [`PackedOctree::load`] or [`Octree::to_octree`] it is in the canonical
/// encoding (what the writer writes: version 1.0, a 128-byte header); `PackedOctree::new(bytes)`
/// keeps the bytes it is given, as every [`Octree::new`] does.
pub type PackedOctree = Octree<Vec<u8>>;

/// The octree over borrowed bytes: zero copy, the file as given (any 1.x version).
pub type PackedOctreeView<'a> = Octree<&'a [u8]>;

/// Sum of the eight bytes of `x` (each ≤ 255; the sum fits easily).
#[inline]
pub(crate) fn byte_sum(x: u64) -> u32 {
    let pairs = (x & 0x00ff_00ff_00ff_00ff) + ((x >> 8) & 0x00ff_00ff_00ff_00ff);
    // Four 16-bit lanes ≤ 510 each: the top lane of the product is their sum (≤ 2040).
    (pairs.wrapping_mul(0x0001_0001_0001_0001) >> 48) as u32
}

/// Bits of `x` below bit `n` (`n` ≤ 63).
#[inline]
pub(crate) fn low_bits(x: u64, n: u32) -> u64 {
    x & ((1u64 << n) - 1)
}

/// `u32::try_from` with a typed error.
pub(crate) fn to_u32(count: u64, what: &'static str) -> Result<u32> {
    u32::try_from(count).map_err(|_| FormatError::TooLarge { what, count })
}

/// The `N` bytes at `at` (one bounds check; the copy compiles to a single unaligned load).
#[inline]
pub(crate) fn bytes_at<const N: usize>(b: &[u8], at: usize) -> [u8; N] {
    match b[at..].first_chunk::<N>() {
        Some(a) => *a,
        None => panic!(
            "read of {N} bytes at {at} past the end of {} bytes",
            b.len()
        ),
    }
}

/// A 12-byte group record at `at`: its u32 base and its eight bytes as one little-endian u64.
#[inline]
pub(crate) fn group_at(b: &[u8], at: usize) -> (u32, u64) {
    let r = bytes_at::<12>(b, at);
    let (base, bytes) = r.split_at(4);
    (
        u32::from_le_bytes([base[0], base[1], base[2], base[3]]),
        u64::from_le_bytes([
            bytes[0], bytes[1], bytes[2], bytes[3], bytes[4], bytes[5], bytes[6], bytes[7],
        ]),
    )
}

/// Writes a 12-byte group record (base, eight bytes) at `at`.
pub(crate) fn put_group(out: &mut [u8], at: usize, base: u32, bytes: [u8; 8]) {
    out[at..at + 4].copy_from_slice(&base.to_le_bytes());
    out[at + 4..at + 12].copy_from_slice(&bytes);
}

/// The child masks of the inner levels above sorted, distinct Morton `codes` of nodes at level
/// `depth`, level 0 (the root) first: breadth-first order. Empty when `codes` is.
pub(crate) fn inner_levels(mut codes: Vec<u64>, depth: u8) -> Vec<Vec<u8>> {
    // Bottom-up: the parents of a sorted level are its codes >> 3, deduplicated.
    let mut levels: Vec<Vec<u8>> = Vec::with_capacity(depth as usize);
    if !codes.is_empty() {
        for _ in 0..depth {
            let mut parents: Vec<u64> = Vec::with_capacity(codes.len() / 2 + 1);
            let mut masks: Vec<u8> = Vec::with_capacity(codes.len() / 2 + 1);
            for &c in &codes {
                let p = c >> 3;
                if parents.last() != Some(&p) {
                    parents.push(p);
                    masks.push(0);
                }
                if let Some(m) = masks.last_mut() {
                    *m |= 1 << (c & 7);
                }
            }
            levels.push(masks);
            codes = parents;
        }
    }
    levels.reverse();
    levels
}

/// Writes the node groups of `levels` ([`inner_levels`]) at `at`: the base of group `g` is
/// the first child of node `8g`.
pub(crate) fn write_node_groups(out: &mut [u8], mut at: usize, levels: &[Vec<u8>]) {
    let mut next_child = 1u32;
    let mut masks = [0u8; 8];
    let mut base = next_child;
    let mut count = 0usize;
    for (k, &mask) in levels.iter().flatten().enumerate() {
        let slot = k % 8;
        if slot == 0 {
            base = next_child;
        }
        masks[slot] = mask;
        next_child += mask.count_ones();
        if slot == 7 {
            put_group(out, at, base, masks);
            at += 12;
            masks = [0; 8];
        }
        count = k + 1;
    }
    if !count.is_multiple_of(8) {
        put_group(out, at, base, masks);
    }
}

impl PackedOctree {
    /// Builds the inner nodes; deterministic whatever the order of `leaves` (sorted by Morton
    /// code; the voxels of a leaf keep their order). Corners are quantised over ± the voxel
    /// diagonal (clamped), rounding to nearest. The `.smo` file is written straight into the
    /// octree's buffer.
    ///
    /// Errors: depth above [`MAX_DEPTH`](crate::MAX_DEPTH), a bad transform, a coordinate
    /// outside `[0, 2^depth)`, two leaves with the same coordinate, a leaf with 0 or more than 255
    /// voxels, with clip-only voxels alone or with more than
    /// [`MAX_CLIP_VOXELS_PER_LEAF`](crate::MAX_CLIP_VOXELS_PER_LEAF) clip voxels, a non-finite corner, or more than 2³² − 1 nodes or
    /// voxels. The file is version 1.0 when no voxel has the clip bit (byte for byte what a 1.0
    /// writer writes), 1.1 with the clip bitmap when one has.
    pub fn from_leaves(meta: OctreeMeta, leaves: Vec<LeafInput>) -> Result<PackedOctree> {
        meta.validate()?;
        let depth = meta.depth;
        let side = 1u64 << depth;
        let mut total_voxels = 0u64;
        let mut total_surface = 0u64;
        let mut total_clip = 0u64;
        let mut keyed = Vec::with_capacity(leaves.len());
        for (index, leaf) in leaves.iter().enumerate() {
            if leaf.coord.iter().any(|&c| u64::from(c) >= side) {
                return Err(FormatError::CoordOutOfRange {
                    index,
                    coord: leaf.coord,
                    depth,
                    side,
                });
            }
            let count = leaf.voxels.len();
            if count == 0 || count > MAX_VOXELS_PER_LEAF {
                return Err(FormatError::VoxelCount {
                    coord: leaf.coord,
                    count,
                    max: MAX_VOXELS_PER_LEAF,
                });
            }
            for (v, voxel) in leaf.voxels.iter().enumerate() {
                if let Some(corner) = voxel.corners.iter().position(|c| !c.is_finite()) {
                    return Err(FormatError::NonFiniteCorner {
                        coord: leaf.coord,
                        voxel: v,
                        corner,
                        value: voxel.corners[corner],
                    });
                }
                total_surface += u64::from(voxel.surface);
                total_clip += u64::from(voxel.clip);
            }
            if leaf.voxels.iter().all(Voxel::is_clip_only) {
                return Err(FormatError::ClipOnlyLeaf { coord: leaf.coord });
            }
            let clips = leaf.voxels.iter().filter(|v| v.clip).count();
            if clips > MAX_CLIP_VOXELS_PER_LEAF {
                return Err(FormatError::ClipCount {
                    coord: leaf.coord,
                    count: clips,
                    max: MAX_CLIP_VOXELS_PER_LEAF,
                });
            }
            total_voxels += count as u64;
            keyed.push((morton::encode(leaf.coord), index));
        }
        let leaf_count = to_u32(leaves.len() as u64, "leaves")?;
        let voxel_count = to_u32(total_voxels, "voxels")?;
        // Codes are unique once duplicates are refused, so the order is total: deterministic.
        keyed.sort_unstable();
        if let Some(w) = keyed.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(FormatError::DuplicateLeaf {
                coord: leaves[w[1].1].coord,
            });
        }

        let levels = inner_levels(keyed.iter().map(|&(c, _)| c).collect(), depth);
        let inner_total: u64 = levels.iter().map(|l| l.len() as u64).sum();
        let inner_count = to_u32(inner_total, "inner nodes")?;
        to_u32(inner_total + u64::from(leaf_count), "nodes")?;

        let counts = Counts {
            inner: inner_count,
            leaves: leaf_count,
            voxels: voxel_count,
            // ≤ voxel_count, which fits.
            surface: total_surface as u32,
            clip: total_clip as u32,
        };
        let header = Header::canonical(&meta, counts);
        let layout = Layout::new(HEADER_SIZE as u64, counts, meta.bits);
        let file_size = usize::try_from(layout.file_size).map_err(|_| FormatError::TooLarge {
            what: "file bytes",
            count: layout.file_size,
        })?;
        let sections = Sections::of(&layout);
        // Zeroed: the padding (between sections and in the last groups) stays 0.
        let mut out = vec![0u8; file_size];
        header.write(&mut out);

        write_node_groups(&mut out, sections.nodes, &levels);

        // Leaf groups, surface bits and corner codes, leaf by leaf in Morton order.
        let dmax = meta.dmax();
        let bits = meta.bits;
        let code_bytes = bits.bytes();
        let mut voxel = 0usize;
        let mut counts8 = [0u8; 8];
        let mut base = 0u32;
        let mut at = sections.leaves;
        for (j, &(_, index)) in keyed.iter().enumerate() {
            let slot = j % 8;
            if slot == 0 {
                base = voxel as u32; // ≤ voxel_count, which fits
            }
            let leaf = &leaves[index];
            counts8[slot] = leaf.voxels.len() as u8; // 1..=255, checked above
            for vx in &leaf.voxels {
                if vx.surface {
                    out[sections.surface + voxel / 8] |= 1 << (voxel % 8);
                }
                if vx.clip {
                    out[sections.clip + voxel / 8] |= 1 << (voxel % 8);
                }
                let codes_at = sections.corners + voxel * 8 * code_bytes;
                for (i, &v) in vx.corners.iter().enumerate() {
                    let q = quantize(v, dmax, bits);
                    let c = codes_at + i * code_bytes;
                    match bits {
                        ValueBits::Eight => out[c] = q as i8 as u8,
                        ValueBits::Sixteen => {
                            out[c..c + 2].copy_from_slice(&(q as i16).to_le_bytes())
                        }
                    }
                }
                voxel += 1;
            }
            if slot == 7 {
                put_group(&mut out, at, base, counts8);
                at += 12;
                counts8 = [0; 8];
            }
        }
        if !leaves.len().is_multiple_of(8) {
            put_group(&mut out, at, base, counts8);
        }

        let crc_at = file_size - CHECKSUM_SIZE;
        let crc = crc32(&out[..crc_at]);
        out[crc_at..].copy_from_slice(&crc.to_le_bytes());
        Ok(Octree::from_parts(out, meta, counts, sections))
    }

    /// This octree in the canonical encoding: itself when it already is (every octree this
    /// crate writes), else the same sections re-written behind a 1.0 header.
    pub(crate) fn into_canonical(self) -> PackedOctree {
        if self.is_canonical() {
            self
        } else {
            self.as_view().to_octree()
        }
    }
}

impl<B> Octree<B> {
    /// Assembles an octree from a buffer whose header and sections have been written or
    /// validated (the caller's guarantee: every accessor then reads in bounds).
    pub(crate) fn from_parts(
        bytes: B,
        meta: OctreeMeta,
        counts: Counts,
        sections: Sections,
    ) -> Octree<B> {
        Octree {
            bytes,
            meta,
            counts,
            sections,
            dequant: dequant_scale(meta.depth, meta.bits),
        }
    }

    /// The buffer back (the `.smo` file).
    pub fn into_bytes(self) -> B {
        self.bytes
    }
}

impl<B: AsRef<[u8]>> Octree<B> {
    /// The same octree over borrowed bytes (no copy, no validation).
    #[inline]
    pub fn as_view(&self) -> PackedOctreeView<'_> {
        Octree {
            bytes: self.as_bytes(),
            meta: self.meta,
            counts: self.counts,
            sections: self.sections,
            dequant: self.dequant,
        }
    }

    /// Whether the bytes are what [`PackedOctree::from_leaves`] would write for this octree:
    /// version 1.0 (1.1 with clip voxels) with a 128-byte header (validation has checked
    /// everything else).
    pub(crate) fn is_canonical(&self) -> bool {
        let h = Header::read(self.as_bytes());
        h.version_minor == minor_version(self.counts.clip > 0)
            && h.header_size as usize == HEADER_SIZE
    }

    /// An owned copy in the canonical encoding (version 1.0, or 1.1 with clip voxels; a
    /// 128-byte header): the bytes themselves when they already are, else the sections
    /// re-written behind a new header. O(size).
    pub fn to_octree(&self) -> PackedOctree {
        let bytes = self.as_bytes();
        if self.is_canonical() {
            return Octree::from_parts(bytes.to_vec(), self.meta, self.counts, self.sections);
        }
        let layout = Layout::new(HEADER_SIZE as u64, self.counts, self.meta.bits);
        let from = Layout::new(self.sections.nodes as u64, self.counts, self.meta.bits);
        let mut out = vec![0u8; layout.file_size as usize];
        Header::canonical(&self.meta, self.counts).write(&mut out);
        for (to, from) in [
            (layout.nodes, from.nodes),
            (layout.leaves, from.leaves),
            (layout.surface, from.surface),
            (layout.corners, from.corners),
            (layout.clip, from.clip),
        ] {
            let (to, from, size) = (to.0 as usize, from.0 as usize, from.1 as usize);
            out[to..to + size].copy_from_slice(&bytes[from..from + size]);
        }
        let crc_at = out.len() - CHECKSUM_SIZE;
        let crc = crc32(&out[..crc_at]);
        out[crc_at..].copy_from_slice(&crc.to_le_bytes());
        Octree::from_parts(out, self.meta, self.counts, Sections::of(&layout))
    }

    buffer_accessors!();

    /// Inner nodes plus leaves.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.counts.inner as usize + self.counts.leaves as usize
    }

    count_getters! {
        /// Inner nodes only (levels `0..depth`).
        inner_node_count => inner,
        /// Leaves (level `depth`).
        leaf_count => leaves,
        /// Voxels in all leaves.
        voxel_count => voxels,
        /// Voxels flagged surface (thin).
        surface_voxel_count => surface,
        /// Voxels with the clip bit (intersect and clip-only voxels); 0 in a 1.0 file.
        clip_voxel_count => clip,
    }

    /// Whether any voxel has the clip bit (header flag [`FLAG_CLIP_VOXELS`](crate::FLAG_CLIP_VOXELS)):
    /// when not, every leaf's hit is the nearest over its voxels and the clip rule never applies.
    #[inline]
    pub fn has_clip_voxels(&self) -> bool {
        self.counts.clip > 0
    }

    // ---- Traversal access (sdfmo-trace) -------------------------------------------------
    //
    // Each accessor reads the little-endian bytes in place with fixed-size loads. An index
    // that validation (or the writer) allows is in bounds; an index from another octree fails
    // an explicit check or the slice's bounds check and panics.

    /// The root node; `None` for an empty octree (no leaves).
    #[inline]
    pub fn root(&self) -> Option<NodeRef> {
        (self.counts.leaves > 0).then_some(NodeRef(0))
    }

    /// Byte offset of the group record of inner node `k` (`k < inner_count`).
    #[inline]
    fn node_group_at(&self, k: u32) -> usize {
        self.sections.nodes + (k as usize >> 3) * 12
    }

    /// Child mask of `node`: bit `i` set = a child in octant `i = 4x + 2y + z`; 0 for a leaf.
    #[inline]
    pub fn child_mask(&self, node: NodeRef) -> u8 {
        if node.0 >= self.counts.inner {
            return 0;
        }
        self.as_bytes()[self.node_group_at(node.0) + 4 + (node.0 as usize & 7)]
    }

    /// The child of `node` in `octant` (`4x + 2y + z`, 0..8), if there is one.
    #[inline]
    pub fn child(&self, node: NodeRef, octant: u8) -> Option<NodeRef> {
        if node.0 >= self.counts.inner || octant > 7 {
            return None;
        }
        let (first_child, masks) = group_at(self.as_bytes(), self.node_group_at(node.0));
        let bit = (node.0 & 7) * 8 + u32::from(octant);
        if masks >> bit & 1 == 0 {
            return None;
        }
        Some(NodeRef(first_child + low_bits(masks, bit).count_ones()))
    }

    /// Index of the first child of an inner node: its children (in octant order) are
    /// `first_child_index + 0 .. popcount(mask)`, and the one in octant `o` is
    /// `first_child_index + popcount(mask & ((1 << o) − 1))` — so a traversal that visits several
    /// children of one node can read the group once.
    ///
    /// Panics if `node` is not an inner node of this octree.
    #[inline]
    pub fn first_child_index(&self, node: NodeRef) -> u32 {
        assert!(node.0 < self.counts.inner, "not an inner node");
        let (first_child, masks) = group_at(self.as_bytes(), self.node_group_at(node.0));
        first_child + low_bits(masks, (node.0 & 7) * 8).count_ones()
    }

    /// Whether `node` is a leaf (leaves sit at level == depth).
    #[inline]
    pub fn is_leaf(&self, node: NodeRef) -> bool {
        node.0 >= self.counts.inner
    }

    /// Leaf number of `node` in Morton order (`node − inner_node_count`), `None` for an inner node.
    #[inline]
    pub fn leaf_index(&self, node: NodeRef) -> Option<u32> {
        node.0.checked_sub(self.counts.inner)
    }

    /// The voxel indices of a leaf (empty for an inner node).
    ///
    /// Panics if `leaf` does not belong to this octree (index out of range).
    #[inline]
    pub fn leaf_voxels(&self, leaf: NodeRef) -> Range<u32> {
        let Some(j) = self.leaf_index(leaf) else {
            return 0..0;
        };
        assert!(j < self.counts.leaves, "node {} out of range", leaf.0);
        let at = self.sections.leaves + (j as usize >> 3) * 12;
        let (first_voxel, counts) = group_at(self.as_bytes(), at);
        let shift = (j & 7) * 8;
        let start = first_voxel + byte_sum(low_bits(counts, shift));
        start..start + (counts >> shift & 0xff) as u32
    }

    /// The voxel's 8 corner distances (`4x + 2y + z`), dequantised, in normalised units.
    ///
    /// Panics if `voxel` is out of range.
    #[inline]
    pub fn voxel_corners(&self, voxel: u32) -> [f32; 8] {
        assert!(voxel < self.counts.voxels, "voxel {voxel} out of range");
        let (b, s, v) = (self.as_bytes(), self.dequant, voxel as usize);
        match self.meta.bits {
            ValueBits::Eight => {
                bytes_at::<8>(b, self.sections.corners + v * 8).map(|c| f32::from(c as i8) * s)
            }
            ValueBits::Sixteen => {
                let c = bytes_at::<16>(b, self.sections.corners + v * 16);
                std::array::from_fn(|i| f32::from(i16::from_le_bytes([c[2 * i], c[2 * i + 1]])) * s)
            }
        }
    }

    /// The voxel's stored integer codes (−Q..=Q); `value = code · dequant_scale()`.
    ///
    /// Panics if `voxel` is out of range.
    #[inline]
    pub fn voxel_codes(&self, voxel: u32) -> [i16; 8] {
        assert!(voxel < self.counts.voxels, "voxel {voxel} out of range");
        let b = self.as_bytes();
        let v = voxel as usize;
        match self.meta.bits {
            ValueBits::Eight => {
                bytes_at::<8>(b, self.sections.corners + v * 8).map(|c| i16::from(c as i8))
            }
            ValueBits::Sixteen => {
                let c = bytes_at::<16>(b, self.sections.corners + v * 16);
                std::array::from_fn(|i| i16::from_le_bytes([c[2 * i], c[2 * i + 1]]))
            }
        }
    }

    /// Whether the voxel is a surface (thin) voxel.
    ///
    /// Panics if `voxel` is out of range.
    #[inline]
    pub fn voxel_is_surface(&self, voxel: u32) -> bool {
        assert!(voxel < self.counts.voxels, "voxel {voxel} out of range");
        self.as_bytes()[self.sections.surface + (voxel as usize >> 3)] >> (voxel & 7) & 1 != 0
    }

    /// Whether the voxel has the clip bit: with [`Octree::voxel_is_surface`] a *clip-only*
    /// voxel (never hit, only clips the other voxels of its leaf), else an *intersect* voxel
    /// (hit as a volume voxel and clips the others). Always `false` in a file without clip
    /// voxels.
    ///
    /// Panics if `voxel` is out of range.
    #[inline]
    pub fn voxel_is_clip(&self, voxel: u32) -> bool {
        assert!(voxel < self.counts.voxels, "voxel {voxel} out of range");
        self.counts.clip > 0
            && self.as_bytes()[self.sections.clip + (voxel as usize >> 3)] >> (voxel & 7) & 1 != 0
    }

    /// Whether any voxel of `voxels` (a leaf's range from [`Octree::leaf_voxels`]) has the clip
    /// bit: the one test a traversal needs to choose the plain nearest-hit rule (`false`, and
    /// always so in a file without clip voxels) or the clip rule. Reads whole bitmap words.
    ///
    /// Panics if the range ends past the last voxel.
    #[inline]
    pub fn any_clip_voxel(&self, voxels: Range<u32>) -> bool {
        if self.counts.clip == 0 || voxels.is_empty() {
            return false;
        }
        assert!(
            voxels.end <= self.counts.voxels,
            "voxel {} out of range",
            voxels.end - 1
        );
        let b = self.as_bytes();
        let (first, last) = (voxels.start >> 6, (voxels.end - 1) >> 6);
        (first..=last).any(|w| {
            let word = u64::from_le_bytes(bytes_at::<8>(b, self.sections.clip + w as usize * 8));
            let lo = if w == first { voxels.start & 63 } else { 0 };
            let hi = if w == last { (voxels.end - 1) & 63 } else { 63 };
            // Bits lo..=hi of the word.
            let mask = (u64::MAX >> (63 - hi)) & (u64::MAX << lo);
            word & mask != 0
        })
    }

    // ---- Whole-octree helpers -----------------------------------------------------------

    /// Cell coordinates of every leaf, in Morton (storage) order. Allocates; for tools.
    pub fn leaf_coords(&self) -> Vec<[u32; 3]> {
        let mut coords: Vec<[u32; 3]> = Vec::with_capacity(self.node_count());
        if self.counts.leaves == 0 {
            return coords;
        }
        coords.push([0, 0, 0]);
        // Breadth first: appending each node's children in order reproduces the node numbering.
        for k in 0..self.counts.inner {
            let parent = coords[k as usize];
            let mask = self.child_mask(NodeRef(k));
            for o in 0..8u8 {
                if mask >> o & 1 != 0 {
                    coords.push(crate::child_coord(parent, o));
                }
            }
        }
        coords.drain(..self.counts.inner as usize);
        coords
    }

    /// Iterates the leaves in Morton order: (coord, decoded voxels). For tests and tools.
    pub fn leaves(&self) -> impl Iterator<Item = ([u32; 3], Vec<Voxel>)> + '_ {
        let coords = self.leaf_coords();
        coords.into_iter().enumerate().map(move |(j, coord)| {
            let range = self.leaf_voxels(NodeRef(self.counts.inner + j as u32));
            let voxels = range
                .map(|v| Voxel {
                    corners: self.voxel_corners(v),
                    surface: self.voxel_is_surface(v),
                    clip: self.voxel_is_clip(v),
                })
                .collect();
            (coord, voxels)
        })
    }

    /// The leaf diagonal `dmax` over which corners are quantised.
    #[inline]
    pub fn dmax(&self) -> f32 {
        quant::voxel_diagonal(self.meta.depth)
    }
}

equal_by_bytes!(Octree);

impl<B: AsRef<[u8]>> fmt::Debug for Octree<B> {
    /// The header's content, not the bytes.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Octree")
            .field("meta", &self.meta)
            .field("inner_nodes", &self.counts.inner)
            .field("leaves", &self.counts.leaves)
            .field("voxels", &self.counts.voxels)
            .field("surface_voxels", &self.counts.surface)
            .field("clip_voxels", &self.counts.clip)
            .field("bytes", &self.as_bytes().len())
            .field("crc32", &format_args!("{:#010x}", self.stored_crc()))
            .finish()
    }
}

impl<B: AsRef<[u8]>> Octree<B> {
    /// The CRC-32 stored in the last four bytes.
    fn stored_crc(&self) -> u32 {
        let b = self.as_bytes();
        u32::from_le_bytes(bytes_at::<4>(b, b.len() - CHECKSUM_SIZE))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta(depth: u8) -> OctreeMeta {
        OctreeMeta::unit(depth, ValueBits::Eight)
    }

    fn leaf(coord: [u32; 3], n: usize) -> LeafInput {
        LeafInput {
            coord,
            voxels: (0..n)
                .map(|i| Voxel {
                    corners: [0.01 * i as f32; 8],
                    surface: i % 2 == 1,
                    clip: false,
                })
                .collect(),
        }
    }

    /// A generic depth-first walk: (leaf coord, Σ corners, surface count) per leaf.
    fn summary<B: AsRef<[u8]>>(o: &Octree<B>) -> Vec<([u32; 3], f32, usize)> {
        let mut out = Vec::new();
        let mut stack: Vec<(NodeRef, [u32; 3])> =
            o.root().map(|r| (r, [0; 3])).into_iter().collect();
        while let Some((n, c)) = stack.pop() {
            if o.is_leaf(n) {
                let r = o.leaf_voxels(n);
                let sum = r
                    .clone()
                    .map(|v| o.voxel_corners(v).iter().sum::<f32>())
                    .sum();
                let surf = r.filter(|&v| o.voxel_is_surface(v)).count();
                out.push((c, sum, surf));
                continue;
            }
            for oct in 0..8u8 {
                if let Some(ch) = o.child(n, oct) {
                    stack.push((ch, crate::child_coord(c, oct)));
                }
            }
        }
        out
    }

    fn mixed_octree(bits: ValueBits) -> PackedOctree {
        let leaves: Vec<LeafInput> = (0..40u32)
            .map(|i| LeafInput {
                coord: [i % 8, i / 8, (i * 3) % 8],
                voxels: (0..1 + i as usize % 3)
                    .map(|k| Voxel {
                        corners: [0.05 * k as f32 - 0.04; 8],
                        surface: k == 2,
                        clip: false,
                    })
                    .collect(),
            })
            .collect();
        PackedOctree::from_leaves(OctreeMeta::unit(3, bits), leaves).unwrap()
    }

    /// `mixed_octree` with the clip bit on the third voxel of some leaves (a clip-only voxel,
    /// since it is a surface voxel) and on the first voxel of others (an intersect voxel).
    fn clipped_octree(bits: ValueBits) -> PackedOctree {
        let mut leaves: Vec<LeafInput> = mixed_octree(bits)
            .leaves()
            .map(|(coord, voxels)| LeafInput { coord, voxels })
            .collect();
        for (i, l) in leaves.iter_mut().enumerate() {
            let n = l.voxels.len();
            if n == 3 || i % 5 == 0 {
                l.voxels[n - 1].clip = true;
            }
            if i % 7 == 0 {
                l.voxels[0].clip = true;
            }
        }
        PackedOctree::from_leaves(*mixed_octree(bits).meta(), leaves).unwrap()
    }

    #[test]
    fn clip_bits_read_back_and_any_clip_voxel_agrees() {
        let o = clipped_octree(ValueBits::Eight);
        assert!(o.has_clip_voxels());
        let n = o.voxel_count() as u32;
        let clip: Vec<bool> = (0..n).map(|v| o.voxel_is_clip(v)).collect();
        assert_eq!(clip.iter().filter(|&&c| c).count(), o.clip_voxel_count());
        for a in 0..n {
            for b in a..=n.min(a + 140) {
                let want = clip[a as usize..b as usize].iter().any(|&c| c);
                assert_eq!(o.any_clip_voxel(a..b), want, "{a}..{b}");
            }
        }
        let plain = mixed_octree(ValueBits::Eight);
        assert!(!plain.has_clip_voxels());
        assert!(!plain.any_clip_voxel(0..plain.voxel_count() as u32));
        assert!(!(0..plain.voxel_count() as u32).any(|v| plain.voxel_is_clip(v)));
    }

    #[test]
    fn a_leaf_of_clip_only_voxels_is_refused() {
        let v = |surface, clip| Voxel {
            corners: [0.1; 8],
            surface,
            clip,
        };
        for voxels in [vec![v(true, true)], vec![v(true, true), v(true, true)]] {
            let e = PackedOctree::from_leaves(
                meta(2),
                vec![LeafInput {
                    coord: [1, 2, 3],
                    voxels,
                }],
            )
            .unwrap_err();
            assert!(matches!(e, FormatError::ClipOnlyLeaf { coord: [1, 2, 3] }));
        }
        // One voxel that is hit is enough (a clip-only voxel with a surface or intersect voxel,
        // a lone intersect voxel).
        for voxels in [
            vec![v(true, true), v(true, false)],
            vec![v(false, true), v(true, true)],
            vec![v(false, true)],
        ] {
            let leaf = LeafInput {
                coord: [1, 2, 3],
                voxels,
            };
            PackedOctree::from_leaves(meta(2), vec![leaf]).unwrap();
        }
    }

    #[test]
    fn owned_and_borrowed_walk_identically() {
        let o = mixed_octree(ValueBits::Sixteen);
        let bytes = o.to_bytes();
        let v = PackedOctreeView::new(&bytes).unwrap();
        let a = summary(&o);
        assert_eq!(a.len(), o.leaf_count());
        assert!(a.iter().any(|&(_, _, s)| s > 0));
        assert_eq!(a, summary(&v));
        assert_eq!(a, summary(&o.as_view()));
        assert_eq!(v.voxel_count(), o.voxel_count());
        assert_eq!(v.meta(), o.meta());
        assert_eq!(v, o);
        assert_eq!(v.as_bytes(), o.as_bytes());
        // An owned octree over bytes it was handed (no copy) is the same octree.
        let w = PackedOctree::new(bytes.clone()).unwrap();
        assert_eq!(w, o);
        assert_eq!(w.into_bytes(), bytes);
    }

    /// `bytes` with the 1.0 header grown by `extra` zero bytes (a later 1.x writer's fields)
    /// and the minor version set to `minor`, resealed.
    fn newer_file(bytes: &[u8], extra: usize, minor: u16) -> Vec<u8> {
        let mut h = Header::read(bytes);
        h.version_minor = minor;
        h.header_size += extra as u32;
        h.file_size += extra as u64;
        for off in [
            &mut h.nodes_offset,
            &mut h.leaves_offset,
            &mut h.surface_offset,
            &mut h.corners_offset,
        ] {
            *off += extra as u64;
        }
        let mut out = vec![0u8; HEADER_SIZE + extra];
        h.write(&mut out);
        out.extend_from_slice(&bytes[HEADER_SIZE..]);
        let crc_at = out.len() - CHECKSUM_SIZE;
        let crc = crc32(&out[..crc_at]);
        out[crc_at..].copy_from_slice(&crc.to_le_bytes());
        out
    }

    #[test]
    fn a_later_minor_version_is_read_in_place_and_copied_canonically() {
        for bits in [ValueBits::Eight, ValueBits::Sixteen] {
            for o in [mixed_octree(bits), clipped_octree(bits)] {
                for (extra, minor) in [(0, 1), (8, 1), (64, 7)] {
                    if o.has_clip_voxels() && extra == 0 {
                        continue; // that one is canonical
                    }
                    let newer = newer_file(o.as_bytes(), extra, minor);
                    let v = PackedOctreeView::new(&newer).unwrap();
                    // Read in place: the same octree, from other bytes.
                    assert_eq!(v.as_bytes(), &newer[..]);
                    assert_eq!(summary(&v), summary(&o));
                    assert_eq!(v.leaf_coords(), o.leaf_coords());
                    assert_eq!(v.section_sizes().header, HEADER_SIZE + extra);
                    assert_eq!(v.section_sizes().total, newer.len());
                    // Owned forms are canonical: what the writer writes.
                    assert_eq!(v.to_octree(), o);
                    assert_eq!(PackedOctree::from_bytes(&newer).unwrap(), o);
                    assert_eq!(
                        PackedOctree::new(newer.clone()).unwrap().into_canonical(),
                        o
                    );
                }
            }
        }
    }

    #[test]
    #[should_panic(expected = "out of range")]
    fn a_voxel_past_the_end_panics() {
        let o = mixed_octree(ValueBits::Eight);
        // The corner section is followed by padding and the checksum: still a panic.
        o.voxel_corners(o.voxel_count() as u32);
    }

    #[test]
    #[should_panic(expected = "out of range")]
    fn a_surface_bit_past_the_end_panics() {
        let o = mixed_octree(ValueBits::Eight);
        // Bits after the last voxel share its byte: still a panic.
        o.voxel_is_surface(o.voxel_count() as u32);
    }

    #[test]
    #[should_panic(expected = "out of range")]
    fn a_node_past_the_end_panics() {
        let o = PackedOctree::from_leaves(meta(3), vec![leaf([5, 2, 7], 2)]).unwrap();
        // A padding slot of the last leaf group: still a panic.
        assert!(!o.leaf_count().is_multiple_of(8));
        o.leaf_voxels(NodeRef(o.node_count() as u32));
    }

    #[test]
    fn byte_sum_is_exact() {
        assert_eq!(byte_sum(0), 0);
        assert_eq!(byte_sum(u64::MAX), 8 * 255);
        assert_eq!(byte_sum(u64::from_le_bytes([1, 2, 3, 4, 5, 6, 7, 8])), 36);
        assert_eq!(
            byte_sum(u64::from_le_bytes([255, 255, 255, 255, 255, 255, 255, 0])),
            7 * 255
        );
    }

    #[test]
    fn empty_octree_has_no_root() {
        let o = PackedOctree::from_leaves(meta(4), vec![]).unwrap();
        assert_eq!(o.root(), None);
        assert_eq!(o.node_count(), 0);
        assert_eq!(o.voxel_count(), 0);
        assert_eq!(o.leaves().count(), 0);
    }

    #[test]
    fn depth_zero_root_is_the_leaf() {
        let o = PackedOctree::from_leaves(meta(0), vec![leaf([0, 0, 0], 3)]).unwrap();
        let root = o.root().unwrap();
        assert!(o.is_leaf(root));
        assert_eq!(o.child_mask(root), 0);
        assert_eq!(o.leaf_voxels(root), 0..3);
        assert_eq!(o.node_count(), 1);
    }

    #[test]
    fn single_leaf_path_down_the_tree() {
        // Depth 3, leaf at (5, 2, 7) = binary x 101, y 010, z 111: octants 5, 3, 5 from the top.
        let o = PackedOctree::from_leaves(meta(3), vec![leaf([5, 2, 7], 2)]).unwrap();
        assert_eq!(o.inner_node_count(), 3);
        let mut n = o.root().unwrap();
        for expected in [5u8, 3, 5] {
            assert!(!o.is_leaf(n));
            assert_eq!(o.child_mask(n), 1 << expected);
            for oct in 0..8 {
                assert_eq!(o.child(n, oct).is_some(), oct == expected);
            }
            n = o.child(n, expected).unwrap();
        }
        assert!(o.is_leaf(n));
        assert_eq!(o.leaf_voxels(n), 0..2);
        assert!(!o.voxel_is_surface(0));
        assert!(o.voxel_is_surface(1));
        assert_eq!(o.leaf_coords(), vec![[5, 2, 7]]);
    }

    #[test]
    fn descending_every_coordinate_finds_its_leaf() {
        // A dense-ish random set at depth 4 with varying counts, > 8 per group everywhere.
        let depth = 4;
        let mut leaves = Vec::new();
        let mut rng = sdfmo_io::SplitMix64::new(12345);
        for x in 0..16u32 {
            for y in 0..16u32 {
                for z in 0..16u32 {
                    let bits = rng.next_u64();
                    if bits >> 61 == 0 {
                        leaves.push(leaf([x, y, z], 1 + (bits >> 40) as usize % 5));
                    }
                }
            }
        }
        let o = PackedOctree::from_leaves(meta(depth), leaves.clone()).unwrap();
        assert_eq!(o.leaf_count(), leaves.len());
        let mut expected_voxels = 0;
        for l in &leaves {
            let mut n = o.root().unwrap();
            for level in (0..depth).rev() {
                let [x, y, z] = l.coord.map(|c| (c >> level) & 1);
                let oct = (4 * x + 2 * y + z) as u8;
                n = o.child(n, oct).expect("child on the leaf's path");
            }
            assert!(o.is_leaf(n));
            let r = o.leaf_voxels(n);
            assert_eq!(r.len(), l.voxels.len());
            for (k, v) in r.clone().enumerate() {
                assert_eq!(o.voxel_is_surface(v), l.voxels[k].surface);
                let c = o.voxel_corners(v);
                for (a, b) in c.iter().zip(l.voxels[k].corners) {
                    assert!((a - b).abs() <= o.dmax() / 254.0 + 1e-6);
                }
            }
            expected_voxels += l.voxels.len();
        }
        assert_eq!(o.voxel_count(), expected_voxels);
        // Leaves come out in Morton order and match the input set.
        let mut sorted = leaves.clone();
        sorted.sort_by_key(|l| morton::encode(l.coord));
        let coords: Vec<_> = o.leaves().map(|(c, _)| c).collect();
        assert_eq!(coords, sorted.iter().map(|l| l.coord).collect::<Vec<_>>());
    }

    #[test]
    fn first_child_index_agrees_with_child() {
        let leaves: Vec<_> = (0..64u32)
            .filter(|i| i % 3 != 1)
            .map(|i| leaf([i % 4, i / 16, (i / 4) % 4], 1))
            .collect();
        let o = PackedOctree::from_leaves(meta(2), leaves).unwrap();
        for k in 0..o.inner_node_count() as u32 {
            let n = NodeRef(k);
            let mask = o.child_mask(n);
            let first = o.first_child_index(n);
            for oct in 0..8u8 {
                let expected = (mask >> oct & 1 == 1)
                    .then(|| NodeRef(first + (u32::from(mask) & ((1 << oct) - 1)).count_ones()));
                assert_eq!(o.child(n, oct), expected);
            }
        }
    }

    #[test]
    fn input_errors_are_typed() {
        let e = PackedOctree::from_leaves(meta(17), vec![]).unwrap_err();
        assert!(matches!(e, FormatError::InvalidDepth { depth: 17, .. }));
        let e = PackedOctree::from_leaves(meta(2), vec![leaf([4, 0, 0], 1)]).unwrap_err();
        assert!(matches!(
            e,
            FormatError::CoordOutOfRange {
                coord: [4, 0, 0],
                ..
            }
        ));
        let e = PackedOctree::from_leaves(meta(2), vec![leaf([1, 0, 0], 1), leaf([1, 0, 0], 2)])
            .unwrap_err();
        assert!(matches!(e, FormatError::DuplicateLeaf { coord: [1, 0, 0] }));
        let e = PackedOctree::from_leaves(meta(2), vec![leaf([1, 0, 0], 0)]).unwrap_err();
        assert!(matches!(e, FormatError::VoxelCount { count: 0, .. }));
        let e = PackedOctree::from_leaves(meta(2), vec![leaf([1, 0, 0], 256)]).unwrap_err();
        assert!(matches!(e, FormatError::VoxelCount { count: 256, .. }));
        let mut bad = leaf([1, 0, 0], 1);
        bad.voxels[0].corners[3] = f32::NAN;
        let e = PackedOctree::from_leaves(meta(2), vec![bad]).unwrap_err();
        assert!(matches!(e, FormatError::NonFiniteCorner { corner: 3, .. }));
        let mut m = meta(2);
        m.scale = 0.0;
        assert!(matches!(
            PackedOctree::from_leaves(m, vec![]).unwrap_err(),
            FormatError::InvalidTransform { .. }
        ));
    }

    #[test]
    fn max_depth_coordinates_work() {
        let depth = crate::MAX_DEPTH;
        let top = (1u32 << depth) - 1;
        let o = PackedOctree::from_leaves(
            meta(depth),
            vec![
                leaf([top, 0, top], 1),
                leaf([0, top, 0], 1),
                leaf([top, top, top], 255),
            ],
        )
        .unwrap();
        assert_eq!(
            o.leaf_coords(),
            vec![[0, top, 0], [top, 0, top], [top, top, top]]
        );
        let last = NodeRef(o.node_count() as u32 - 1);
        assert_eq!(o.leaf_voxels(last), 2..257);
    }
}
