//! The `.smo` file: header constants, layout, writing, atomic save and load.
//!
//! The crate's `FORMAT.md` is the byte-by-byte specification; [`HEADER_FIELDS`] is the same table in
//! code, and a test checks the two against each other and against real bytes.

use std::path::Path;

use crate::crc32::crc32;
use crate::error::Result;
use crate::octree::{Corners, PackedOctree};
use crate::view::PackedOctreeView;
use crate::{ValueBits, MAX_FILE_SIZE};

/// The eight magic bytes, hex `89 53 4D 4F 0D 0A 1A 0A`: `\x89 S M O \r \n \x1a \n`
/// (PNG's trick: a high byte, the name, and the line endings and EOF character that text-mode
/// transfers would mangle).
pub const MAGIC: [u8; 8] = [0x89, b'S', b'M', b'O', b'\r', b'\n', 0x1A, b'\n'];

/// Major version: a change means the layout changed and old readers must refuse the file.
pub const FORMAT_VERSION_MAJOR: u16 = 1;
/// Minor version: compatible additions (a longer header, tolerated by every 1.x reader).
pub const FORMAT_VERSION_MINOR: u16 = 0;

/// Size of the version-1.0 header in bytes (a 1.x header may be longer; see `header_size`).
pub const HEADER_SIZE: usize = 128;

/// Header flag bit 0: at least one leaf holds more than one voxel (a multi-octree).
pub const FLAG_MULTI_VOXEL: u32 = 1 << 0;
/// Header flag bit 1: at least one voxel is a surface (thin) voxel.
pub const FLAG_SURFACE_VOXELS: u32 = 1 << 1;
/// Flag bits defined in this version; every other bit must be zero.
pub const KNOWN_FLAGS: u32 = FLAG_MULTI_VOXEL | FLAG_SURFACE_VOXELS;

/// Size in bytes of the trailing CRC-32.
pub const CHECKSUM_SIZE: usize = 4;

/// One header field: name, byte offset and size (all fields little-endian).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HeaderField {
    /// Field name as written in the crate's `FORMAT.md`.
    pub name: &'static str,
    /// Byte offset from the start of the file.
    pub offset: usize,
    /// Size in bytes.
    pub size: usize,
}

const fn field(name: &'static str, offset: usize, size: usize) -> HeaderField {
    HeaderField { name, offset, size }
}

/// The version-1.0 header, field by field, in order (contiguous, 128 bytes).
pub const HEADER_FIELDS: [HeaderField; 25] = [
    field("magic", 0, 8),
    field("version_major", 8, 2),
    field("version_minor", 10, 2),
    field("header_size", 12, 4),
    field("flags", 16, 4),
    field("depth", 20, 1),
    field("value_bits", 21, 1),
    field("reserved", 22, 2),
    field("center_x", 24, 4),
    field("center_y", 28, 4),
    field("center_z", 32, 4),
    field("scale", 36, 4),
    field("inner_node_count", 40, 4),
    field("leaf_count", 44, 4),
    field("voxel_count", 48, 4),
    field("surface_voxel_count", 52, 4),
    field("file_size", 56, 8),
    field("nodes_offset", 64, 8),
    field("nodes_size", 72, 8),
    field("leaves_offset", 80, 8),
    field("leaves_size", 88, 8),
    field("surface_offset", 96, 8),
    field("surface_size", 104, 8),
    field("corners_offset", 112, 8),
    field("corners_size", 120, 8),
];

const _: () = {
    // The table is contiguous and ends at HEADER_SIZE.
    let mut i = 1;
    while i < HEADER_FIELDS.len() {
        let prev = HEADER_FIELDS[i - 1];
        assert!(prev.offset + prev.size == HEADER_FIELDS[i].offset);
        i += 1;
    }
    let last = HEADER_FIELDS[HEADER_FIELDS.len() - 1];
    assert!(last.offset + last.size == HEADER_SIZE);
};

/// Offset of a header field by name (compile-time table lookup).
pub(crate) const fn offset_of(name: &str) -> usize {
    let mut i = 0;
    while i < HEADER_FIELDS.len() {
        let f = HEADER_FIELDS[i];
        if str_eq(f.name, name) {
            return f.offset;
        }
        i += 1;
    }
    panic!("unknown header field")
}

const fn str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// Rounds up to a multiple of 8.
#[inline]
pub(crate) fn align8(x: u64) -> u64 {
    x.div_ceil(8) * 8
}

/// Where every section sits, derived from the counts alone (u64: no overflow for u32 counts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Layout {
    pub(crate) nodes: (u64, u64),
    pub(crate) leaves: (u64, u64),
    pub(crate) surface: (u64, u64),
    pub(crate) corners: (u64, u64),
    pub(crate) checksum_offset: u64,
    pub(crate) file_size: u64,
}

impl Layout {
    pub(crate) fn new(
        header_size: u64,
        inner: u32,
        leaves: u32,
        voxels: u32,
        bits: ValueBits,
    ) -> Layout {
        let nodes_size = u64::from(inner).div_ceil(8) * 12;
        let leaves_size = u64::from(leaves).div_ceil(8) * 12;
        let surface_size = u64::from(voxels).div_ceil(64) * 8;
        let corners_size = u64::from(voxels) * 8 * bits.bytes() as u64;
        let n = align8(header_size);
        let l = align8(n + nodes_size);
        let s = align8(l + leaves_size);
        let c = align8(s + surface_size);
        let checksum_offset = align8(c + corners_size);
        Layout {
            nodes: (n, nodes_size),
            leaves: (l, leaves_size),
            surface: (s, surface_size),
            corners: (c, corners_size),
            checksum_offset,
            file_size: checksum_offset + CHECKSUM_SIZE as u64,
        }
    }
}

/// Bytes of each part of a saved `.smo` (for size accounting; they sum to `total`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SectionSizes {
    /// The fixed header.
    pub header: usize,
    /// Inner-node groups (12 bytes per 8 inner nodes).
    pub nodes: usize,
    /// Leaf groups (12 bytes per 8 leaves).
    pub leaves: usize,
    /// Surface bitmap (8 bytes per 64 voxels).
    pub surface: usize,
    /// Quantised corners (8 or 16 bytes per voxel).
    pub corners: usize,
    /// Zero padding that aligns each section to 8 bytes.
    pub padding: usize,
    /// The trailing CRC-32.
    pub checksum: usize,
    /// The whole file.
    pub total: usize,
}

impl SectionSizes {
    /// Bytes per voxel, everything included (0 for an empty octree).
    pub fn bytes_per_voxel(&self, voxels: usize) -> f64 {
        if voxels == 0 {
            0.0
        } else {
            self.total as f64 / voxels as f64
        }
    }
}

impl PackedOctree {
    fn layout(&self) -> Layout {
        Layout::new(
            HEADER_SIZE as u64,
            self.inner_count,
            self.leaf_count,
            self.voxel_count,
            self.meta.bits,
        )
    }

    /// Bytes of the saved file.
    pub fn byte_size(&self) -> usize {
        self.layout().file_size as usize
    }

    /// Bytes of each part of the saved file.
    pub fn section_sizes(&self) -> SectionSizes {
        let l = self.layout();
        let used = HEADER_SIZE as u64 + l.nodes.1 + l.leaves.1 + l.surface.1 + l.corners.1;
        SectionSizes {
            header: HEADER_SIZE,
            nodes: l.nodes.1 as usize,
            leaves: l.leaves.1 as usize,
            surface: l.surface.1 as usize,
            corners: l.corners.1 as usize,
            padding: (l.checksum_offset - used) as usize,
            checksum: CHECKSUM_SIZE,
            total: l.file_size as usize,
        }
    }

    /// Header flags: [`FLAG_MULTI_VOXEL`], [`FLAG_SURFACE_VOXELS`].
    pub fn flags(&self) -> u32 {
        let mut flags = 0;
        if self.voxel_count > self.leaf_count {
            flags |= FLAG_MULTI_VOXEL;
        }
        if self.surface_count > 0 {
            flags |= FLAG_SURFACE_VOXELS;
        }
        flags
    }

    /// The `.smo` file as bytes (specified in the crate's `FORMAT.md`).
    pub fn to_bytes(&self) -> Vec<u8> {
        let l = self.layout();
        let mut out = Vec::with_capacity(l.file_size as usize);
        let m = &self.meta;
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&FORMAT_VERSION_MAJOR.to_le_bytes());
        out.extend_from_slice(&FORMAT_VERSION_MINOR.to_le_bytes());
        out.extend_from_slice(&(HEADER_SIZE as u32).to_le_bytes());
        out.extend_from_slice(&self.flags().to_le_bytes());
        out.push(m.depth);
        out.push(m.bits.bits());
        out.extend_from_slice(&0u16.to_le_bytes());
        for v in [m.center.x, m.center.y, m.center.z, m.scale] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for c in [
            self.inner_count,
            self.leaf_count,
            self.voxel_count,
            self.surface_count,
        ] {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out.extend_from_slice(&l.file_size.to_le_bytes());
        for (offset, size) in [l.nodes, l.leaves, l.surface, l.corners] {
            out.extend_from_slice(&offset.to_le_bytes());
            out.extend_from_slice(&size.to_le_bytes());
        }
        debug_assert_eq!(out.len(), HEADER_SIZE);

        out.resize(l.nodes.0 as usize, 0);
        for g in &self.nodes {
            out.extend_from_slice(&g.first_child.to_le_bytes());
            out.extend_from_slice(&g.masks);
        }
        out.resize(l.leaves.0 as usize, 0);
        for g in &self.leaves {
            out.extend_from_slice(&g.first_voxel.to_le_bytes());
            out.extend_from_slice(&g.counts);
        }
        out.resize(l.surface.0 as usize, 0);
        for w in &self.surface {
            out.extend_from_slice(&w.to_le_bytes());
        }
        out.resize(l.corners.0 as usize, 0);
        match &self.corners {
            Corners::Eight(c) => {
                for v in c {
                    out.extend(v.iter().map(|&q| q as u8));
                }
            }
            Corners::Sixteen(c) => {
                for v in c {
                    for q in v {
                        out.extend_from_slice(&q.to_le_bytes());
                    }
                }
            }
        }
        out.resize(l.checksum_offset as usize, 0);
        let crc = crc32(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        debug_assert_eq!(out.len() as u64, l.file_size);
        out
    }

    /// Reads a `.smo` file from bytes, validating everything first (see [`PackedOctreeView::new`]).
    /// Time and memory O(bytes.len()).
    pub fn from_bytes(bytes: &[u8]) -> Result<PackedOctree> {
        Ok(PackedOctreeView::new(bytes)?.to_octree())
    }

    /// Writes the file atomically ([`sdfmo_io::write_atomic`]): a fresh temporary file in the
    /// same directory, fsync, rename. A destination that is a directory, a device or a FIFO is
    /// refused; a symbolic link is followed (its target is replaced).
    pub fn save(&self, path: &Path) -> Result<()> {
        Ok(sdfmo_io::write_atomic(path, self.to_bytes())?)
    }

    /// Reads and validates a `.smo` file of at most [`MAX_FILE_SIZE`] bytes (a regular file:
    /// devices and FIFOs are refused without reading).
    pub fn load(path: &Path) -> Result<PackedOctree> {
        PackedOctree::load_with_limit(path, MAX_FILE_SIZE)
    }

    /// [`PackedOctree::load`] with an explicit size limit in bytes, checked before reading.
    pub fn load_with_limit(path: &Path, max_bytes: u64) -> Result<PackedOctree> {
        let bytes = sdfmo_io::read_regular(path, max_bytes)?;
        PackedOctree::from_bytes(&bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::FormatError;
    use crate::{LeafInput, OctreeMeta, Voxel};
    use glam::Vec3;

    /// Leaves of a sphere shell of radius 0.6 at `depth`: every cell the sphere passes through,
    /// corners = exact sphere distance; every third leaf gets a second, negated surface voxel.
    fn sphere_leaves(depth: u8) -> Vec<LeafInput> {
        let n = 1u32 << depth;
        let h = 2.0 / n as f32;
        let sd = |p: Vec3| p.length() - 0.6;
        let mut out = Vec::new();
        for x in 0..n {
            for y in 0..n {
                for z in 0..n {
                    let lo = Vec3::new(x as f32, y as f32, z as f32) * h - 1.0;
                    let corners: [f32; 8] = std::array::from_fn(|i| {
                        let o = Vec3::new((i >> 2) as f32, (i >> 1 & 1) as f32, (i & 1) as f32);
                        sd(lo + o * h)
                    });
                    let min = corners.iter().cloned().fold(f32::INFINITY, f32::min);
                    let max = corners.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
                    if min <= 0.0 && max >= 0.0 {
                        let mut voxels = vec![Voxel {
                            corners,
                            surface: false,
                        }];
                        if (x + y + z) % 3 == 0 {
                            voxels.push(Voxel {
                                corners: corners.map(|c| -c),
                                surface: true,
                            });
                        }
                        out.push(LeafInput {
                            coord: [x, y, z],
                            voxels,
                        });
                    }
                }
            }
        }
        out
    }

    fn meta(depth: u8, bits: ValueBits) -> OctreeMeta {
        OctreeMeta {
            depth,
            bits,
            center: Vec3::new(0.5, -2.0, 3.25),
            scale: 0.125,
        }
    }

    #[test]
    fn round_trip_is_equal() {
        for bits in [ValueBits::Eight, ValueBits::Sixteen] {
            let o = PackedOctree::from_leaves(meta(5, bits), sphere_leaves(5)).unwrap();
            assert!(o.leaf_count() > 100);
            let bytes = o.to_bytes();
            assert_eq!(bytes.len(), o.byte_size());
            let back = PackedOctree::from_bytes(&bytes).unwrap();
            assert_eq!(back, o);
            assert_eq!(back.to_bytes(), bytes);
            let s = o.section_sizes();
            assert_eq!(
                s.header + s.nodes + s.leaves + s.surface + s.corners + s.padding + s.checksum,
                s.total
            );
        }
    }

    #[test]
    fn header_fields_hold_what_the_table_says() {
        let o = PackedOctree::from_leaves(meta(4, ValueBits::Sixteen), sphere_leaves(4)).unwrap();
        let b = o.to_bytes();
        let at = |name: &str| {
            let f = HEADER_FIELDS.iter().find(|f| f.name == name).unwrap();
            &b[f.offset..f.offset + f.size]
        };
        let u32_of = |name: &str| u32::from_le_bytes(at(name).try_into().unwrap());
        let u64_of = |name: &str| u64::from_le_bytes(at(name).try_into().unwrap());
        let f32_of = |name: &str| f32::from_le_bytes(at(name).try_into().unwrap());
        assert_eq!(at("magic"), &MAGIC);
        assert_eq!(at("version_major"), &FORMAT_VERSION_MAJOR.to_le_bytes());
        assert_eq!(at("version_minor"), &FORMAT_VERSION_MINOR.to_le_bytes());
        assert_eq!(u32_of("header_size"), HEADER_SIZE as u32);
        assert_eq!(u32_of("flags"), FLAG_MULTI_VOXEL | FLAG_SURFACE_VOXELS);
        assert_eq!(at("depth"), &[4]);
        assert_eq!(at("value_bits"), &[16]);
        assert_eq!(at("reserved"), &[0, 0]);
        assert_eq!(f32_of("center_x"), 0.5);
        assert_eq!(f32_of("center_y"), -2.0);
        assert_eq!(f32_of("center_z"), 3.25);
        assert_eq!(f32_of("scale"), 0.125);
        assert_eq!(u32_of("inner_node_count") as usize, o.inner_node_count());
        assert_eq!(u32_of("leaf_count") as usize, o.leaf_count());
        assert_eq!(u32_of("voxel_count") as usize, o.voxel_count());
        assert_eq!(
            u32_of("surface_voxel_count") as usize,
            o.surface_voxel_count()
        );
        assert_eq!(u64_of("file_size") as usize, b.len());
        let s = o.section_sizes();
        assert_eq!(u64_of("nodes_offset"), HEADER_SIZE as u64);
        assert_eq!(u64_of("nodes_size") as usize, s.nodes);
        assert_eq!(
            u64_of("leaves_offset"),
            align8(u64_of("nodes_offset") + u64_of("nodes_size"))
        );
        assert_eq!(u64_of("leaves_size") as usize, s.leaves);
        assert_eq!(
            u64_of("surface_offset"),
            align8(u64_of("leaves_offset") + u64_of("leaves_size"))
        );
        assert_eq!(u64_of("surface_size") as usize, s.surface);
        assert_eq!(
            u64_of("corners_offset"),
            align8(u64_of("surface_offset") + u64_of("surface_size"))
        );
        assert_eq!(u64_of("corners_size") as usize, s.corners);
        let crc_at = b.len() - CHECKSUM_SIZE;
        assert_eq!(
            crc_at as u64,
            align8(u64_of("corners_offset") + u64_of("corners_size"))
        );
        assert_eq!(
            u32::from_le_bytes(b[crc_at..].try_into().unwrap()),
            crc32(&b[..crc_at])
        );
    }

    #[test]
    fn save_is_atomic_and_loads_back() {
        let dir = std::env::temp_dir().join(format!("sdfmo-format-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("sphere.smo");
        let o = PackedOctree::from_leaves(meta(4, ValueBits::Eight), sphere_leaves(4)).unwrap();
        o.save(&path).unwrap();
        // Overwriting replaces the file whole; no temporary file is left behind.
        o.save(&path).unwrap();
        assert_eq!(PackedOctree::load(&path).unwrap(), o);
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("sphere.smo")]);
        // A failed save reports the path and leaves the old file untouched.
        let bad = PackedOctree::from_leaves(meta(3, ValueBits::Eight), sphere_leaves(3)).unwrap();
        let e = bad
            .save(&dir.join("no-such-dir").join("x.smo"))
            .unwrap_err();
        assert!(matches!(e, FormatError::Io { .. }));
        assert_eq!(PackedOctree::load(&path).unwrap(), o);
        let missing = PackedOctree::load(&dir.join("missing.smo")).unwrap_err();
        assert!(matches!(missing, FormatError::Io { .. }));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
