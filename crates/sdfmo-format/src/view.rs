//! Validation of `.smo` bytes and a zero-copy view over them.

use std::ops::Range;

use glam::Vec3;

use crate::crc32::crc32;
use crate::error::{FormatError, Result};
use crate::file::{
    offset_of, Layout, CHECKSUM_SIZE, FLAG_MULTI_VOXEL, FLAG_SURFACE_VOXELS, FORMAT_VERSION_MAJOR,
    HEADER_SIZE, KNOWN_FLAGS, MAGIC,
};
use crate::octree::{byte_sum, low_bits, Corners, LeafGroup, NodeGroup, NodeRef, PackedOctree};
use crate::quant::{dequant_scale, max_code};
use crate::{OctreeMeta, ValueBits, MAX_DEPTH};

/// A validated `.smo` file read in place: the same traversal accessors as [`PackedOctree`],
/// reading the little-endian sections of the byte slice directly (no copy, no allocation; e.g.
/// over a memory-mapped file).
#[derive(Clone, Copy, Debug)]
pub struct PackedOctreeView<'a> {
    meta: OctreeMeta,
    inner_count: u32,
    leaf_count: u32,
    voxel_count: u32,
    surface_count: u32,
    nodes: &'a [u8],
    leaves: &'a [u8],
    surface: &'a [u8],
    corners: &'a [u8],
    dequant: f32,
}

#[inline]
fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

#[inline]
fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

#[inline]
fn u64_at(b: &[u8], at: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[at..at + 8]);
    u64::from_le_bytes(a)
}

#[inline]
fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_bits(u32_at(b, at))
}

fn corrupt<T>(field: &'static str, reason: impl Into<String>) -> Result<T> {
    Err(FormatError::corrupt(field, reason))
}

impl<'a> PackedOctreeView<'a> {
    /// Validates `bytes` as a `.smo` file and views it in place. Checked before anything is used,
    /// in this order: magic, major version, header size, declared file size against the length,
    /// the CRC-32, flags, depth, value bits, reserved bytes, transform, counts, every section's
    /// offset and size against those the counts imply (and zero padding), the node groups
    /// (first-child bases, a breadth-first walk proving every level is complete and the leaves
    /// sit exactly at `depth`), the leaf groups (counts 1..=255, first-voxel bases, total), the
    /// surface bitmap (popcount, padding bits), the corner codes (−Q..=Q). O(len), no allocation.
    pub fn new(bytes: &'a [u8]) -> Result<PackedOctreeView<'a>> {
        let len = bytes.len();
        if len < MAGIC.len() {
            return Err(FormatError::Truncated {
                len,
                needed: HEADER_SIZE as u64,
            });
        }
        if bytes[..8] != MAGIC {
            let mut found = [0u8; 8];
            found.copy_from_slice(&bytes[..8]);
            return Err(FormatError::BadMagic { found });
        }
        if len < HEADER_SIZE {
            return Err(FormatError::Truncated {
                len,
                needed: HEADER_SIZE as u64,
            });
        }
        let major = u16_at(bytes, offset_of("version_major"));
        let minor = u16_at(bytes, offset_of("version_minor"));
        if major != FORMAT_VERSION_MAJOR {
            return Err(FormatError::UnsupportedVersion {
                major,
                minor,
                supported: FORMAT_VERSION_MAJOR,
            });
        }
        let header_size = u64::from(u32_at(bytes, offset_of("header_size")));
        if header_size < HEADER_SIZE as u64 || header_size % 8 != 0 {
            return corrupt(
                "header_size",
                format!("{header_size} (must be a multiple of 8, at least {HEADER_SIZE})"),
            );
        }
        let file_size = u64_at(bytes, offset_of("file_size"));
        if file_size > len as u64 {
            return Err(FormatError::Truncated {
                len,
                needed: file_size,
            });
        }
        if file_size < len as u64 {
            return corrupt("file_size", format!("{file_size}, but {len} bytes follow"));
        }
        if len < HEADER_SIZE + CHECKSUM_SIZE {
            return corrupt(
                "file_size",
                format!("{len} is smaller than header + checksum"),
            );
        }
        let crc_at = len - CHECKSUM_SIZE;
        let stored = u32_at(bytes, crc_at);
        let computed = crc32(&bytes[..crc_at]);
        if stored != computed {
            return Err(FormatError::ChecksumMismatch { stored, computed });
        }

        // ---- Header fields (the checksum is right; is the content consistent?) ----
        let flags = u32_at(bytes, offset_of("flags"));
        if flags & !KNOWN_FLAGS != 0 {
            return corrupt("flags", format!("unknown bits {:#x}", flags & !KNOWN_FLAGS));
        }
        let depth = bytes[offset_of("depth")];
        if depth > MAX_DEPTH {
            return corrupt("depth", format!("{depth} > {MAX_DEPTH}"));
        }
        let raw_bits = bytes[offset_of("value_bits")];
        let Some(bits) = ValueBits::from_bits(raw_bits) else {
            return corrupt("value_bits", format!("{raw_bits} (must be 8 or 16)"));
        };
        let reserved = u16_at(bytes, offset_of("reserved"));
        if reserved != 0 {
            return corrupt("reserved", format!("{reserved:#x} (must be 0)"));
        }
        let center = Vec3::new(
            f32_at(bytes, offset_of("center_x")),
            f32_at(bytes, offset_of("center_y")),
            f32_at(bytes, offset_of("center_z")),
        );
        let scale = f32_at(bytes, offset_of("scale"));
        let meta = OctreeMeta {
            depth,
            bits,
            center,
            scale,
        };
        if !center.is_finite() {
            return corrupt("center", format!("{center:?} is not finite"));
        }
        if !scale.is_finite() || scale <= 0.0 {
            return corrupt("scale", format!("{scale} (must be finite and > 0)"));
        }
        let inner = u32_at(bytes, offset_of("inner_node_count"));
        let leaves = u32_at(bytes, offset_of("leaf_count"));
        let voxels = u32_at(bytes, offset_of("voxel_count"));
        let surface_count = u32_at(bytes, offset_of("surface_voxel_count"));
        if u64::from(inner) + u64::from(leaves) > u64::from(u32::MAX) {
            return corrupt("inner_node_count", "nodes exceed 2^32 - 1");
        }
        if surface_count > voxels {
            return corrupt(
                "surface_voxel_count",
                format!("{surface_count} > voxel_count {voxels}"),
            );
        }
        if voxels < leaves || u64::from(voxels) > 255 * u64::from(leaves) {
            return corrupt(
                "voxel_count",
                format!("{voxels} voxels in {leaves} leaves (each must hold 1..=255)"),
            );
        }
        if depth == 0 && (inner != 0 || leaves > 1) {
            return corrupt(
                "leaf_count",
                format!("depth 0 holds at most the root leaf ({inner} inner, {leaves} leaves)"),
            );
        }
        if (inner == 0) != (leaves == 0) && depth > 0 {
            return corrupt(
                "inner_node_count",
                format!("{inner} inner nodes for {leaves} leaves"),
            );
        }
        let multi = voxels > leaves;
        if (flags & FLAG_MULTI_VOXEL != 0) != multi {
            return corrupt("flags", "multi-voxel bit disagrees with the counts");
        }
        if (flags & FLAG_SURFACE_VOXELS != 0) != (surface_count > 0) {
            return corrupt("flags", "surface bit disagrees with surface_voxel_count");
        }

        // ---- Sections: exactly where the counts put them ----
        let layout = Layout::new(header_size, inner, leaves, voxels, bits);
        if layout.file_size != file_size {
            return corrupt(
                "file_size",
                format!("{file_size}, but the counts imply {}", layout.file_size),
            );
        }
        let table = [
            ("nodes_offset", "nodes_size", layout.nodes),
            ("leaves_offset", "leaves_size", layout.leaves),
            ("surface_offset", "surface_size", layout.surface),
            ("corners_offset", "corners_size", layout.corners),
        ];
        for (off_name, size_name, (off, size)) in table {
            let stored_off = u64_at(bytes, offset_of(off_name));
            if stored_off != off {
                return corrupt(off_name, format!("{stored_off}, expected {off}"));
            }
            let stored_size = u64_at(bytes, offset_of(size_name));
            if stored_size != size {
                return corrupt(size_name, format!("{stored_size}, expected {size}"));
            }
        }
        // All offsets are ≤ file_size == len here, so these casts and slices are in bounds.
        let section = |(off, size): (u64, u64)| &bytes[off as usize..(off + size) as usize];
        let gaps = [
            (header_size, layout.nodes.0),
            (layout.nodes.0 + layout.nodes.1, layout.leaves.0),
            (layout.leaves.0 + layout.leaves.1, layout.surface.0),
            (layout.surface.0 + layout.surface.1, layout.corners.0),
            (layout.corners.0 + layout.corners.1, layout.checksum_offset),
        ];
        for (from, to) in gaps {
            if bytes[from as usize..to as usize].iter().any(|&b| b != 0) {
                return corrupt("padding", format!("non-zero byte in {from}..{to}"));
            }
        }
        let view = PackedOctreeView {
            meta,
            inner_count: inner,
            leaf_count: leaves,
            voxel_count: voxels,
            surface_count,
            nodes: section(layout.nodes),
            leaves: section(layout.leaves),
            surface: section(layout.surface),
            corners: section(layout.corners),
            dequant: dequant_scale(depth, bits),
        };
        view.validate_nodes()?;
        view.validate_leaves()?;
        view.validate_surface()?;
        view.validate_corners()?;
        Ok(view)
    }

    #[inline]
    fn mask_at(&self, k: u32) -> u8 {
        self.nodes[(k as usize >> 3) * 12 + 4 + (k as usize & 7)]
    }

    fn validate_nodes(&self) -> Result<()> {
        // Bases: group g's first child is 1 + the popcount of every mask before node 8g.
        let mut next = 1u64;
        for (g, rec) in self.nodes.chunks_exact(12).enumerate() {
            let base = u32_at(rec, 0);
            if u64::from(base) != next {
                return corrupt(
                    "nodes",
                    format!("group {g} first_child {base}, expected {next}"),
                );
            }
            for (s, &m) in rec[4..].iter().enumerate() {
                let k = g as u64 * 8 + s as u64;
                if k >= u64::from(self.inner_count) && m != 0 {
                    return corrupt("nodes", format!("padding mask of slot {k} is {m:#x}"));
                }
                next += u64::from(m.count_ones());
            }
        }
        if self.inner_count == 0 {
            return Ok(());
        }
        // Breadth-first walk: level ℓ is the node range [start, end); its children are the next
        // `Σ popcount` nodes. Levels above depth − 1 must stay among the inner nodes; the last
        // inner level must end exactly at inner_count and have exactly leaf_count children.
        let depth = self.meta.depth;
        let (mut start, mut end) = (0u64, 1u64);
        for level in 0..depth {
            let mut children = 0u64;
            for k in start..end {
                let m = self.mask_at(k as u32);
                if m == 0 {
                    return corrupt(
                        "nodes",
                        format!("inner node {k} at level {level} has no child"),
                    );
                }
                children += u64::from(m.count_ones());
            }
            if level + 1 < depth {
                if end + children > u64::from(self.inner_count) {
                    return corrupt(
                        "nodes",
                        format!(
                            "level {} would end at node {}, past the {} inner nodes",
                            level + 1,
                            end + children,
                            self.inner_count
                        ),
                    );
                }
            } else if end != u64::from(self.inner_count) || children != u64::from(self.leaf_count) {
                return corrupt(
                    "nodes",
                    format!(
                        "the tree has {end} inner nodes and {children} leaves, header says {} and {}",
                        self.inner_count, self.leaf_count
                    ),
                );
            }
            (start, end) = (end, end + children);
        }
        Ok(())
    }

    fn validate_leaves(&self) -> Result<()> {
        let mut next = 0u64;
        for (g, rec) in self.leaves.chunks_exact(12).enumerate() {
            let base = u32_at(rec, 0);
            if u64::from(base) != next {
                return corrupt(
                    "leaves",
                    format!("group {g} first_voxel {base}, expected {next}"),
                );
            }
            for (s, &c) in rec[4..].iter().enumerate() {
                let j = g as u64 * 8 + s as u64;
                let real = j < u64::from(self.leaf_count);
                if real && c == 0 {
                    return corrupt("leaves", format!("leaf {j} has no voxel"));
                }
                if !real && c != 0 {
                    return corrupt("leaves", format!("padding count of slot {j} is {c}"));
                }
                next += u64::from(c);
            }
        }
        if next != u64::from(self.voxel_count) {
            return corrupt(
                "leaves",
                format!("counts sum to {next}, voxel_count is {}", self.voxel_count),
            );
        }
        Ok(())
    }

    fn validate_surface(&self) -> Result<()> {
        let mut ones = 0u64;
        for (w, word) in self.surface.chunks_exact(8).enumerate() {
            let mut x = u64_at(word, 0);
            let first = w as u64 * 64;
            let valid = u64::from(self.voxel_count).saturating_sub(first).min(64);
            if valid < 64 {
                if x >> valid != 0 {
                    return corrupt("surface", format!("padding bits set in word {w}"));
                }
                x = low_bits(x, valid as u32);
            }
            ones += u64::from(x.count_ones());
        }
        if ones != u64::from(self.surface_count) {
            return corrupt(
                "surface",
                format!(
                    "{ones} bits set, surface_voxel_count is {}",
                    self.surface_count
                ),
            );
        }
        Ok(())
    }

    fn validate_corners(&self) -> Result<()> {
        let bad = match self.meta.bits {
            ValueBits::Eight => self.corners.iter().position(|&b| b as i8 == i8::MIN),
            ValueBits::Sixteen => self
                .corners
                .chunks_exact(2)
                .position(|c| i16::from_le_bytes([c[0], c[1]]) == i16::MIN),
        };
        if let Some(i) = bad {
            return corrupt(
                "corners",
                format!(
                    "code {} at value {i} is outside ±{}",
                    -max_code(self.meta.bits) - 1,
                    max_code(self.meta.bits)
                ),
            );
        }
        Ok(())
    }

    /// Copies the view into an owned [`PackedOctree`]. O(size).
    pub fn to_octree(&self) -> PackedOctree {
        let nodes = self
            .nodes
            .chunks_exact(12)
            .map(|r| NodeGroup {
                first_child: u32_at(r, 0),
                masks: [r[4], r[5], r[6], r[7], r[8], r[9], r[10], r[11]],
            })
            .collect();
        let leaves = self
            .leaves
            .chunks_exact(12)
            .map(|r| LeafGroup {
                first_voxel: u32_at(r, 0),
                counts: [r[4], r[5], r[6], r[7], r[8], r[9], r[10], r[11]],
            })
            .collect();
        let surface = self.surface.chunks_exact(8).map(|w| u64_at(w, 0)).collect();
        let corners = match self.meta.bits {
            ValueBits::Eight => Corners::Eight(
                self.corners
                    .chunks_exact(8)
                    .map(|c| std::array::from_fn(|i| c[i] as i8))
                    .collect(),
            ),
            ValueBits::Sixteen => Corners::Sixteen(
                self.corners
                    .chunks_exact(16)
                    .map(|c| std::array::from_fn(|i| i16::from_le_bytes([c[2 * i], c[2 * i + 1]])))
                    .collect(),
            ),
        };
        PackedOctree {
            meta: self.meta,
            inner_count: self.inner_count,
            leaf_count: self.leaf_count,
            voxel_count: self.voxel_count,
            surface_count: self.surface_count,
            nodes,
            leaves,
            surface,
            corners,
            dequant: self.dequant,
        }
    }

    /// Depth, quantisation and normalisation transform.
    #[inline]
    pub fn meta(&self) -> &OctreeMeta {
        &self.meta
    }

    /// Leaves sit at this level.
    #[inline]
    pub fn depth(&self) -> u8 {
        self.meta.depth
    }

    /// Inner nodes plus leaves.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.inner_count as usize + self.leaf_count as usize
    }

    /// Inner nodes only.
    #[inline]
    pub fn inner_node_count(&self) -> usize {
        self.inner_count as usize
    }

    /// Leaves.
    #[inline]
    pub fn leaf_count(&self) -> usize {
        self.leaf_count as usize
    }

    /// Voxels.
    #[inline]
    pub fn voxel_count(&self) -> usize {
        self.voxel_count as usize
    }

    /// Surface voxels.
    #[inline]
    pub fn surface_voxel_count(&self) -> usize {
        self.surface_count as usize
    }

    /// The root node; `None` for an empty octree.
    #[inline]
    pub fn root(&self) -> Option<NodeRef> {
        (self.leaf_count > 0).then_some(NodeRef(0))
    }

    /// Child mask of `node` (0 for a leaf). Panics if `node` is out of range.
    #[inline]
    pub fn child_mask(&self, node: NodeRef) -> u8 {
        if node.0 >= self.inner_count {
            return 0;
        }
        self.mask_at(node.0)
    }

    /// The child of `node` in `octant`, if any. Panics if `node` is out of range.
    #[inline]
    pub fn child(&self, node: NodeRef, octant: u8) -> Option<NodeRef> {
        if node.0 >= self.inner_count || octant > 7 {
            return None;
        }
        let at = (node.0 as usize >> 3) * 12;
        let masks = u64_at(self.nodes, at + 4);
        let bit = (node.0 & 7) * 8 + u32::from(octant);
        if masks >> bit & 1 == 0 {
            return None;
        }
        Some(NodeRef(
            u32_at(self.nodes, at) + low_bits(masks, bit).count_ones(),
        ))
    }

    /// Index of the first child of an inner node (see [`PackedOctree::first_child_index`]).
    /// Panics if `node` is not an inner node.
    #[inline]
    pub fn first_child_index(&self, node: NodeRef) -> u32 {
        assert!(node.0 < self.inner_count, "not an inner node");
        let at = (node.0 as usize >> 3) * 12;
        let masks = u64_at(self.nodes, at + 4);
        u32_at(self.nodes, at) + low_bits(masks, (node.0 & 7) * 8).count_ones()
    }

    /// Whether `node` is a leaf.
    #[inline]
    pub fn is_leaf(&self, node: NodeRef) -> bool {
        node.0 >= self.inner_count
    }

    /// The voxel indices of a leaf (empty for an inner node). Panics if out of range.
    #[inline]
    pub fn leaf_voxels(&self, leaf: NodeRef) -> Range<u32> {
        let Some(j) = leaf.0.checked_sub(self.inner_count) else {
            return 0..0;
        };
        let at = (j as usize >> 3) * 12;
        let slot = j & 7;
        let counts = u64_at(self.leaves, at + 4);
        let start = u32_at(self.leaves, at) + byte_sum(low_bits(counts, slot * 8));
        start..start + (counts >> (slot * 8) & 0xff) as u32
    }

    /// The voxel's dequantised corners. Panics if out of range.
    #[inline]
    pub fn voxel_corners(&self, voxel: u32) -> [f32; 8] {
        let s = self.dequant;
        match self.meta.bits {
            ValueBits::Eight => {
                let c = &self.corners[voxel as usize * 8..voxel as usize * 8 + 8];
                std::array::from_fn(|i| f32::from(c[i] as i8) * s)
            }
            ValueBits::Sixteen => {
                let c = &self.corners[voxel as usize * 16..voxel as usize * 16 + 16];
                std::array::from_fn(|i| f32::from(i16::from_le_bytes([c[2 * i], c[2 * i + 1]])) * s)
            }
        }
    }

    /// Whether the voxel is a surface voxel. Panics if out of range.
    #[inline]
    pub fn voxel_is_surface(&self, voxel: u32) -> bool {
        self.surface[(voxel as usize >> 6) * 8 + (voxel as usize & 63) / 8] >> (voxel & 7) & 1 != 0
    }
}
