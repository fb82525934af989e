//! The `.smo` file: header constants, layout, writing, atomic save and load.
//!
//! The crate's `FORMAT.md` is the byte-by-byte specification; [`HEADER_FIELDS`] is the same table in
//! code, and a test checks the two against each other and against real bytes.

use std::path::Path;

use crate::error::Result;
use crate::octree::{Octree, PackedOctree, PackedOctreeView};
use crate::{OctreeMeta, ValueBits, MAX_FILE_SIZE};

/// The eight magic bytes, hex `89 53 4D 4F 0D 0A 1A 0A`: `\x89 S M O \r \n \x1a \n`
/// (PNG's trick: a high byte, the name, and the line endings and EOF character that text-mode
/// transfers would mangle).
pub const MAGIC: [u8; 8] = [0x89, b'S', b'M', b'O', b'\r', b'\n', 0x1A, b'\n'];

/// Major version: a change means the layout changed and old readers must refuse the file.
pub const FORMAT_VERSION_MAJOR: u16 = 1;
/// Newest minor version this crate reads and writes: 1 (clip voxels, [`FLAG_CLIP_VOXELS`]).
///
/// The writer writes the lowest minor that describes the file: 0 when no voxel has the clip bit
/// (the file is then byte for byte what a 1.0 writer writes), 1 when one has. Every 1.x reader
/// accepts a longer header; a 1.0 reader refuses a 1.1 file with clip voxels by its unknown flag
/// bit.
pub const FORMAT_VERSION_MINOR: u16 = 1;

/// The minor version of a file with (`true`) or without clip voxels: 1 or 0.
#[inline]
pub(crate) const fn minor_version(clip: bool) -> u16 {
    if clip {
        1
    } else {
        0
    }
}

/// Size of the version-1.0 header in bytes (a 1.x header may be longer; see `header_size`).
pub const HEADER_SIZE: usize = 128;

/// Header flag bit 0: at least one leaf holds more than one voxel (a multi-octree).
pub const FLAG_MULTI_VOXEL: u32 = 1 << 0;
/// Header flag bit 1: at least one voxel is a surface (thin) voxel.
pub const FLAG_SURFACE_VOXELS: u32 = 1 << 1;
/// Header flag bit 2 (version 1.1): at least one voxel has the clip bit; the file then holds the
/// clip bitmap after the corners.
pub const FLAG_CLIP_VOXELS: u32 = 1 << 2;
/// Flag bits defined in this version; every other bit must be zero.
pub const KNOWN_FLAGS: u32 = FLAG_MULTI_VOXEL | FLAG_SURFACE_VOXELS | FLAG_CLIP_VOXELS;

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

/// The table entry named `name` (compile-time lookup; panics on an unknown name).
const fn field_named(name: &str) -> HeaderField {
    let mut i = 0;
    while i < HEADER_FIELDS.len() {
        let f = HEADER_FIELDS[i];
        if str_eq(f.name, name) {
            return f;
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

/// A header value as the zero-extended little-endian bits of its field.
trait FieldBits: Copy {
    fn to_bits(self) -> u64;
    fn from_bits(bits: u64) -> Self;
}

macro_rules! field_bits_int {
    ($($t:ty),*) => {$(
        impl FieldBits for $t {
            #[inline]
            fn to_bits(self) -> u64 {
                u64::from(self)
            }
            #[inline]
            fn from_bits(bits: u64) -> Self {
                // The reader passes only the field's own bytes, so nothing is cut off.
                bits as $t
            }
        }
    )*};
}
field_bits_int!(u8, u16, u32, u64);

impl FieldBits for f32 {
    fn to_bits(self) -> u64 {
        u64::from(f32::to_bits(self))
    }
    fn from_bits(bits: u64) -> Self {
        f32::from_bits(bits as u32)
    }
}

impl FieldBits for [u8; 8] {
    fn to_bits(self) -> u64 {
        u64::from_le_bytes(self)
    }
    fn from_bits(bits: u64) -> Self {
        bits.to_le_bytes()
    }
}

/// Declares [`Header`]: one struct field per entry of [`HEADER_FIELDS`], with the same name.
/// The table alone says where each field sits: [`Header::read`] and [`Header::write`] walk it
/// and look each value up by name, so the order of the fields is written down once. Checked at
/// compile time: every struct field is in the table with the size of its type, and the table
/// has no other field.
macro_rules! header_values {
    ($($name:ident: $ty:ty,)*) => {
        /// The values of a `.smo` header, one per [`HEADER_FIELDS`] entry of the same name.
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        pub(crate) struct Header {
            $(pub(crate) $name: $ty,)*
        }

        const _: () = {
            $(assert!(field_named(stringify!($name)).size == std::mem::size_of::<$ty>());)*
            assert!([$(stringify!($name)),*].len() == HEADER_FIELDS.len());
        };

        impl Header {
            /// The bits of the field `name`.
            fn get(&self, name: &str) -> u64 {
                match name {
                    $(stringify!($name) => FieldBits::to_bits(self.$name),)*
                    _ => unreachable!("header field {name} has no value"),
                }
            }

            /// Sets the field `name` from its bits.
            fn set(&mut self, name: &str, bits: u64) {
                match name {
                    $(stringify!($name) => self.$name = FieldBits::from_bits(bits),)*
                    _ => unreachable!("header field {name} has no value"),
                }
            }
        }
    };
}

header_values! {
    magic: [u8; 8],
    version_major: u16,
    version_minor: u16,
    header_size: u32,
    flags: u32,
    depth: u8,
    value_bits: u8,
    reserved: u16,
    center_x: f32,
    center_y: f32,
    center_z: f32,
    scale: f32,
    inner_node_count: u32,
    leaf_count: u32,
    voxel_count: u32,
    surface_voxel_count: u32,
    file_size: u64,
    nodes_offset: u64,
    nodes_size: u64,
    leaves_offset: u64,
    leaves_size: u64,
    surface_offset: u64,
    surface_size: u64,
    corners_offset: u64,
    corners_size: u64,
}

impl Header {
    /// The header the writer puts in front of an octree with these counts: version 1.0 (1.1
    /// with clip voxels), a [`HEADER_SIZE`]-byte header and the sections where [`Layout`] puts
    /// them.
    pub(crate) fn canonical(meta: &OctreeMeta, counts: Counts) -> Header {
        let layout = Layout::new(HEADER_SIZE as u64, counts, meta.bits);
        Header {
            magic: MAGIC,
            version_major: FORMAT_VERSION_MAJOR,
            version_minor: minor_version(counts.clip > 0),
            header_size: HEADER_SIZE as u32,
            flags: counts.flags(),
            depth: meta.depth,
            value_bits: meta.bits.bits(),
            reserved: 0,
            center_x: meta.center.x,
            center_y: meta.center.y,
            center_z: meta.center.z,
            scale: meta.scale,
            inner_node_count: counts.inner,
            leaf_count: counts.leaves,
            voxel_count: counts.voxels,
            surface_voxel_count: counts.surface,
            file_size: layout.file_size,
            nodes_offset: layout.nodes.0,
            nodes_size: layout.nodes.1,
            leaves_offset: layout.leaves.0,
            leaves_size: layout.leaves.1,
            surface_offset: layout.surface.0,
            surface_size: layout.surface.1,
            corners_offset: layout.corners.0,
            corners_size: layout.corners.1,
        }
    }

    /// Reads every field of [`HEADER_FIELDS`] from the first [`HEADER_SIZE`] bytes of `bytes`
    /// (panics if shorter: the caller checks the length). Nothing is validated.
    pub(crate) fn read(bytes: &[u8]) -> Header {
        let mut header = Header::default();
        for f in &HEADER_FIELDS {
            let mut le = [0u8; 8];
            le[..f.size].copy_from_slice(&bytes[f.offset..f.offset + f.size]);
            header.set(f.name, u64::from_le_bytes(le));
        }
        header
    }

    /// Writes every field of [`HEADER_FIELDS`] into the first [`HEADER_SIZE`] bytes of `out`.
    pub(crate) fn write(&self, out: &mut [u8]) {
        for f in &HEADER_FIELDS {
            out[f.offset..f.offset + f.size]
                .copy_from_slice(&self.get(f.name).to_le_bytes()[..f.size]);
        }
    }

    /// The counts the header declares. The header has no clip count: `clip` is 1 when the
    /// [`FLAG_CLIP_VOXELS`] bit is set (enough for the layout), 0 otherwise; validation replaces
    /// it with the popcount of the clip bitmap.
    pub(crate) fn counts(&self) -> Counts {
        Counts {
            inner: self.inner_node_count,
            leaves: self.leaf_count,
            voxels: self.voxel_count,
            surface: self.surface_voxel_count,
            clip: u32::from(self.flags & FLAG_CLIP_VOXELS != 0),
        }
    }
}

/// What the layout of a file follows from: its counts (and whether it has clip voxels).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Counts {
    /// Inner nodes `I`.
    pub(crate) inner: u32,
    /// Leaves `L`.
    pub(crate) leaves: u32,
    /// Voxels `V`.
    pub(crate) voxels: u32,
    /// Surface voxels `S`.
    pub(crate) surface: u32,
    /// Voxels with the clip bit (not stored in the header: the popcount of the clip bitmap,
    /// which exists iff this is > 0).
    pub(crate) clip: u32,
}

impl Counts {
    /// The header flags these counts imply.
    pub(crate) fn flags(self) -> u32 {
        let mut flags = 0;
        if self.voxels > self.leaves {
            flags |= FLAG_MULTI_VOXEL;
        }
        if self.surface > 0 {
            flags |= FLAG_SURFACE_VOXELS;
        }
        if self.clip > 0 {
            flags |= FLAG_CLIP_VOXELS;
        }
        flags
    }
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
    /// The clip bitmap: size 0 (at the end of the corners) in a file without clip voxels.
    pub(crate) clip: (u64, u64),
    pub(crate) checksum_offset: u64,
    pub(crate) file_size: u64,
}

impl Layout {
    pub(crate) fn new(header_size: u64, counts: Counts, bits: ValueBits) -> Layout {
        let nodes_size = u64::from(counts.inner).div_ceil(8) * 12;
        let leaves_size = u64::from(counts.leaves).div_ceil(8) * 12;
        let surface_size = u64::from(counts.voxels).div_ceil(64) * 8;
        let corners_size = u64::from(counts.voxels) * 8 * bits.bytes() as u64;
        // Only a file with clip voxels has the section (a file without is 1.0's layout).
        let clip_size = if counts.clip > 0 { surface_size } else { 0 };
        let n = align8(header_size);
        let l = align8(n + nodes_size);
        let s = align8(l + leaves_size);
        let c = align8(s + surface_size);
        let k = align8(c + corners_size);
        let checksum_offset = align8(k + clip_size);
        Layout {
            nodes: (n, nodes_size),
            leaves: (l, leaves_size),
            surface: (s, surface_size),
            corners: (c, corners_size),
            clip: (k, clip_size),
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
    /// Clip bitmap (8 bytes per 64 voxels; 0 in a file without clip voxels).
    pub clip: usize,
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

impl<B: AsRef<[u8]>> Octree<B> {
    /// Bytes of the saved file.
    pub fn byte_size(&self) -> usize {
        self.as_bytes().len()
    }

    /// Bytes of each part of the file (the sections a 1.0 writer writes; for a view over a file
    /// with a longer header, `header` is that header's size).
    pub fn section_sizes(&self) -> SectionSizes {
        let header = self.sections.header_size();
        let l = Layout::new(header as u64, self.counts, self.meta.bits);
        let used = header as u64 + l.nodes.1 + l.leaves.1 + l.surface.1 + l.corners.1 + l.clip.1;
        SectionSizes {
            header,
            nodes: l.nodes.1 as usize,
            leaves: l.leaves.1 as usize,
            surface: l.surface.1 as usize,
            corners: l.corners.1 as usize,
            clip: l.clip.1 as usize,
            padding: (l.checksum_offset - used) as usize,
            checksum: CHECKSUM_SIZE,
            total: l.file_size as usize,
        }
    }

    /// Header flags: [`FLAG_MULTI_VOXEL`], [`FLAG_SURFACE_VOXELS`], [`FLAG_CLIP_VOXELS`].
    pub fn flags(&self) -> u32 {
        self.counts.flags()
    }

    /// The `.smo` file (specified in the crate's `FORMAT.md`): a copy of [`Octree::as_bytes`].
    pub fn to_bytes(&self) -> Vec<u8> {
        self.as_bytes().to_vec()
    }

    /// Writes [`Octree::as_bytes`] atomically ([`sdfmo_io::write_atomic`]): a fresh temporary
    /// file in the same directory, fsync, rename. A destination that is a directory, a device or
    /// a FIFO is refused; a symbolic link is followed (its target is replaced).
    pub fn save(&self, path: &Path) -> Result<()> {
        Ok(sdfmo_io::write_atomic(path, self.as_bytes())?)
    }
}

impl PackedOctree {
    /// Reads a `.smo` file from bytes, validating everything first (see [`Octree::new`]), into
    /// an owned octree in the canonical encoding (version 1.0, or 1.1 with clip voxels; a
    /// 128-byte header). Time and memory
    /// O(bytes.len()).
    pub fn from_bytes(bytes: &[u8]) -> Result<PackedOctree> {
        Ok(PackedOctreeView::new(bytes)?.to_octree())
    }

    /// [`PackedOctree::from_bytes`] for bytes the caller owns: they become the octree's buffer
    /// (no copy) when they are already in the canonical encoding, as every file this crate
    /// writes is.
    pub fn from_vec(bytes: Vec<u8>) -> Result<PackedOctree> {
        Ok(PackedOctree::new(bytes)?.into_canonical())
    }

    /// Reads and validates a `.smo` file of at most [`MAX_FILE_SIZE`] bytes (a regular file:
    /// devices and FIFOs are refused without reading).
    pub fn load(path: &Path) -> Result<PackedOctree> {
        PackedOctree::load_with_limit(path, MAX_FILE_SIZE)
    }

    /// [`PackedOctree::load`] with an explicit size limit in bytes, checked before reading (and,
    /// for a compressed file, on the decoded size). The bytes read (or decoded) become the
    /// octree's buffer ([`PackedOctree::from_vec`]).
    pub fn load_with_limit(path: &Path, max_bytes: u64) -> Result<PackedOctree> {
        // Header first: a file whose header declares another size is refused before its body
        // is read (the 1.x checks only: a 2.0 file is `UnsupportedVersion`, as from bytes).
        let bytes = sdfmo_io::read_regular_checked(path, max_bytes, HEADER_SIZE, |head, len| {
            if crate::compressed::is_compressed(head) {
                return Ok(len);
            }
            crate::validate::check_header_size(head, len).map(|_| len)
        })?;
        if crate::compressed::is_compressed(&bytes) {
            return PackedOctree::from_vec(crate::compressed::decompress(&bytes, max_bytes)?);
        }
        PackedOctree::from_vec(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::crc32::crc32;
    use crate::error::FormatError;
    use crate::{LeafInput, OctreeMeta, Voxel};
    use glam::Vec3;

    /// Leaves of a sphere shell of radius 0.6 at `depth`: every cell the sphere passes through,
    /// corners = exact sphere distance; every third leaf gets a second, negated surface voxel.
    fn sphere_leaves(depth: u8) -> Vec<LeafInput> {
        let n = 1u32 << depth;
        let sd = |p: Vec3| p.length() - 0.6;
        let mut out = Vec::new();
        for x in 0..n {
            for y in 0..n {
                for z in 0..n {
                    let corners = crate::cell_corners(depth, [x, y, z], sd);
                    let min = corners.iter().cloned().fold(f32::INFINITY, f32::min);
                    let max = corners.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
                    if min <= 0.0 && max >= 0.0 {
                        let mut voxels = vec![Voxel {
                            corners,
                            surface: false,
                            clip: false,
                        }];
                        if (x + y + z) % 3 == 0 {
                            voxels.push(Voxel {
                                corners: corners.map(|c| -c),
                                surface: true,
                                clip: false,
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
            assert_eq!(s.clip, 0);
        }
    }

    /// `sphere_leaves` with the clip bit on the second voxel of some leaves, making each of
    /// them an intersect voxel (volume + clip) or a clip-only voxel (surface + clip).
    fn clipped_sphere_leaves(depth: u8) -> Vec<LeafInput> {
        let mut leaves = sphere_leaves(depth);
        for (i, l) in leaves.iter_mut().enumerate() {
            if l.voxels.len() == 2 && i % 2 == 0 {
                l.voxels[1].clip = true;
                l.voxels[1].surface = i % 4 == 0;
            }
        }
        leaves
    }

    #[test]
    fn clip_voxels_add_one_bitmap_after_the_corners_and_minor_version_1() {
        for bits in [ValueBits::Eight, ValueBits::Sixteen] {
            let leaves = clipped_sphere_leaves(5);
            // The same leaves without clip bits.
            let mut unclipped = leaves.clone();
            unclipped
                .iter_mut()
                .flat_map(|l| &mut l.voxels)
                .for_each(|v| v.clip = false);
            let plain = PackedOctree::from_leaves(meta(5, bits), unclipped).unwrap();
            let clip_count = leaves
                .iter()
                .flat_map(|l| &l.voxels)
                .filter(|v| v.clip)
                .count();
            assert!(clip_count > 10);
            let o = PackedOctree::from_leaves(meta(5, bits), leaves.clone()).unwrap();
            assert_eq!(o.clip_voxel_count(), clip_count);
            assert!(o.has_clip_voxels() && !plain.has_clip_voxels());
            assert_eq!(o.flags(), plain.flags() | FLAG_CLIP_VOXELS);
            let b = o.to_bytes();
            let h = Header::read(&b);
            assert_eq!((h.version_major, h.version_minor), (1, 1));
            assert_eq!(h.flags, o.flags());
            // Everything before the checksum is the plain file's, then the bitmap.
            let s = o.section_sizes();
            assert_eq!(s.clip, o.voxel_count().div_ceil(64) * 8);
            assert_eq!(s.total, plain.byte_size() + s.clip);
            assert_eq!(
                s.header
                    + s.nodes
                    + s.leaves
                    + s.surface
                    + s.corners
                    + s.clip
                    + s.padding
                    + s.checksum,
                s.total
            );
            let p = plain.as_bytes();
            let crc_at = p.len() - CHECKSUM_SIZE;
            // Header fields other than version, flags and file size are the plain file's.
            for f in HEADER_FIELDS
                .iter()
                .filter(|f| !["version_minor", "flags", "file_size"].contains(&f.name))
            {
                assert_eq!(
                    b[f.offset..f.offset + f.size],
                    p[f.offset..f.offset + f.size]
                );
            }
            assert_eq!(b[HEADER_SIZE..crc_at], p[HEADER_SIZE..crc_at]);
            let bitmap = &b[crc_at..crc_at + s.clip];
            let mut v = 0usize;
            for (_, voxels) in o.leaves() {
                for voxel in voxels {
                    assert_eq!(bitmap[v / 8] >> (v % 8) & 1 == 1, voxel.clip);
                    assert_eq!(o.voxel_is_clip(v as u32), voxel.clip);
                    v += 1;
                }
            }
            // Round trip, and the decoded leaves carry the bits.
            let back = PackedOctree::from_bytes(&b).unwrap();
            assert_eq!(back, o);
            let mut sorted = leaves;
            sorted.sort_by_key(|l| crate::morton::encode(l.coord));
            for ((_, got), want) in back.leaves().zip(&sorted) {
                let flags = |v: &[Voxel]| v.iter().map(|x| (x.surface, x.clip)).collect::<Vec<_>>();
                assert_eq!(flags(&got), flags(&want.voxels));
            }
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
        // No clip voxel: version 1.0, what a 1.0 writer writes.
        assert_eq!(at("version_minor"), &0u16.to_le_bytes());
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
    fn header_is_written_and_read_through_the_table() {
        let o = PackedOctree::from_leaves(meta(4, ValueBits::Sixteen), sphere_leaves(4)).unwrap();
        let h = Header::read(o.as_bytes());
        assert_eq!(h, Header::canonical(o.meta(), o.counts));
        let mut out = [0xAAu8; HEADER_SIZE];
        h.write(&mut out);
        assert_eq!(&out[..], &o.as_bytes()[..HEADER_SIZE]);
        // Every field is written: a header of distinct values reads back field by field.
        let mut distinct = [0u8; HEADER_SIZE];
        for (i, b) in distinct.iter_mut().enumerate() {
            *b = i as u8 ^ 0x5A;
        }
        let mut again = [0u8; HEADER_SIZE];
        Header::read(&distinct).write(&mut again);
        assert_eq!(again, distinct);
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
