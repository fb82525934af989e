//! The `.smo` headers as data: the constants, one field table per version ([`HEADER_FIELDS`] for
//! 1.x, [`LOD_HEADER_FIELDS`] and [`LOD_LEVEL_FIELDS`] for 2.0) and the values read and written
//! through them, and where a 1.x file's sections sit ([`Layout`]). The readers, the writers, the
//! `FORMAT.md` test and the header word offsets the WGSL kernel reads all come from these tables.

use crate::{OctreeMeta, ValueBits};

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

/// The fields every `.smo` header starts with, 1.x, 2.0 and 3.0 alike: a reader tells the versions
/// apart by them.
const PREAMBLE: [HeaderField; 5] = [
    field("magic", 0, 8),
    field("version_major", 8, 2),
    field("version_minor", 10, 2),
    field("header_size", 12, 4),
    field("flags", 16, 4),
];

/// Depth, value bits and a reserved u16 at bytes 20–24: the 1.x and 3.0 headers.
const GRID: [HeaderField; 3] = [
    field("depth", 20, 1),
    field("value_bits", 21, 1),
    field("reserved", 22, 2),
];

/// The normalisation transform at bytes 24–40: every header (1.x, 2.0, 3.0).
const TRANSFORM: [HeaderField; 4] = [
    field("center_x", 24, 4),
    field("center_y", 28, 4),
    field("center_z", 32, 4),
    field("scale", 36, 4),
];

/// `parts` one after the other, as one table of `N` fields (compile time).
const fn joined<const N: usize>(parts: &[&[HeaderField]]) -> [HeaderField; N] {
    let mut table = [field("", 0, 0); N];
    let (mut n, mut p) = (0, 0);
    while p < parts.len() {
        let mut i = 0;
        while i < parts[p].len() {
            table[n] = parts[p][i];
            n += 1;
            i += 1;
        }
        p += 1;
    }
    assert!(n == N);
    table
}

/// The version-1.0 header, field by field, in order (contiguous, 128 bytes).
pub const HEADER_FIELDS: [HeaderField; 25] = joined(&[
    &PREAMBLE,
    &GRID,
    &TRANSFORM,
    &[
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
    ],
]);

/// Major version of a file with levels of detail (the 1.x layout is one octree; 2.0 is a
/// header, a level table and one 1.x octree per level).
pub const LOD_VERSION_MAJOR: u16 = 2;
/// Minor version this crate writes for files with levels.
pub const LOD_VERSION_MINOR: u16 = 0;
/// Bytes of the fixed part of a 2.0 header (before the level table).
pub const LOD_HEADER_FIXED: usize = 64;
/// Bytes of one level-table entry (`offset` u64, `size` u64).
pub const LOD_LEVEL_ENTRY: usize = 16;
/// Bytes after the level table: the header's CRC-32 (u32) and 4 zero bytes.
pub const LOD_HEADER_TRAILER: usize = 8;

/// The fixed part of the version-2.0 header (a file with levels), field by field, in order
/// (contiguous, [`LOD_HEADER_FIXED`] bytes); the level table follows at byte 64.
pub const LOD_HEADER_FIELDS: [HeaderField; 15] = joined(&[
    &PREAMBLE,
    &[
        field("depth", 20, 1),
        field("coarsest", 21, 1),
        field("level_count", 22, 1),
        field("value_bits", 23, 1),
    ],
    &TRANSFORM,
    &[field("file_size", 40, 8), field("reserved", 48, 16)],
]);

/// One entry of the 2.0 level table: offsets from the entry's start, which is byte
/// `LOD_HEADER_FIXED + LOD_LEVEL_ENTRY · i` for level `coarsest + i`.
pub const LOD_LEVEL_FIELDS: [HeaderField; 2] = [field("offset", 0, 8), field("size", 8, 8)];

/// After the level table: offsets from its end (byte `H − LOD_HEADER_TRAILER`).
pub const LOD_TRAILER_FIELDS: [HeaderField; 2] =
    [field("header_crc", 0, 4), field("trailer_zero", 4, 4)];

/// Major version of a brick file (format 3.0: `FORMAT.md`, section "Bricks"): the leaves of
/// a 1.x octree regrouped into bricks of 4³ cells whose volume voxels share their corner codes.
pub const V3_VERSION_MAJOR: u16 = 3;
/// Minor version this crate writes for brick files: 1 (*narrow* private voxels: a private leaf
/// whose voxels are close to trilinear stores each in 6 codes' bytes instead of 8; `FORMAT.md`,
/// "Narrow private voxels (version 3.1)"). It reads 3.0 and 3.1; the layouts differ only in the
/// private leaf groups and the private corners.
pub const V3_VERSION_MINOR: u16 = 1;
/// Private leaves per private leaf group record: 8 in a 3.0 file (12 bytes, as 1.x's leaf
/// groups), 16 in a 3.1 file ([`V31_GROUP_SIZE`] bytes).
pub const fn private_group_leaves(minor: u16) -> usize {
    if minor == 0 {
        8
    } else {
        16
    }
}
/// Bytes of a 3.1 private leaf group: `u32` first voxel, `u32` wide voxels before the group,
/// sixteen count bytes (bits 0–6 the count 1..=127, bit 7 set when the leaf is wide).
pub const V31_GROUP_SIZE: usize = 24;
/// Bytes of one private leaf group record of a 3.x file of minor version `minor`.
pub const fn private_group_size(minor: u16) -> usize {
    if minor == 0 {
        12
    } else {
        V31_GROUP_SIZE
    }
}
/// The most voxels a private leaf of a 3.1 file holds (its count byte's low 7 bits); a 1.x
/// octree with a larger leaf is written as 3.0.
pub const V31_MAX_LEAF_VOXELS: usize = 127;
/// Size of the version-3.0 header in bytes (a 3.x header may be longer; see `header_size`).
pub const V3_HEADER_SIZE: usize = 176;

/// The version-3.0 header, field by field, in order (contiguous, [`V3_HEADER_SIZE`] bytes).
pub const V3_HEADER_FIELDS: [HeaderField; 33] = joined(&[
    &PREAMBLE,
    &GRID,
    &TRANSFORM,
    &[
        field("upper_node_count", 40, 4),
        field("brick_count", 44, 4),
        field("leaf_count", 48, 4),
        field("voxel_count", 52, 4),
        field("surface_voxel_count", 56, 4),
        field("clip_voxel_count", 60, 4),
        field("private_leaf_count", 64, 4),
        field("private_voxel_count", 68, 4),
        field("file_size", 72, 8),
        field("nodes_offset", 80, 8),
        field("nodes_size", 88, 8),
        field("bricks_offset", 96, 8),
        field("bricks_size", 104, 8),
        field("residuals_offset", 112, 8),
        field("residuals_size", 120, 8),
        field("private_leaves_offset", 128, 8),
        field("private_leaves_size", 136, 8),
        field("private_flags_offset", 144, 8),
        field("private_flags_size", 152, 8),
        field("private_corners_offset", 160, 8),
        field("private_corners_size", 168, 8),
    ],
]);

/// Bytes of one brick record (section `bricks` of a 3.0 file).
pub const BRICK_RECORD_SIZE: usize = 32;

/// One brick record of a 3.0 file, field by field (offsets from the record's start, which is
/// byte `bricks_offset + 32 · b` for brick `b`): the occupancy and private masks (bit `i` = the
/// brick's cell of Morton index `i`), the plane `a + b·x + c·y + d·z` that predicts its
/// points' codes (in 1/2^[`plane_fraction_bits`] code units), the residual word (byte offset
/// of its residuals in bits 0–29, width code in bits 30–31) and the index of its first private
/// leaf.
pub const BRICK_RECORD_FIELDS: [HeaderField; 8] = [
    field("occupancy", 0, 8),
    field("private", 8, 8),
    field("plane_a", 16, 2),
    field("plane_b", 18, 2),
    field("plane_c", 20, 2),
    field("plane_d", 22, 2),
    field("residuals", 24, 4),
    field("first_private_leaf", 28, 4),
];

/// Byte offsets in a brick record of the fields its readers load in place (the 3.0 reader,
/// the tracer's queries, the compressed container), from [`BRICK_RECORD_FIELDS`].
pub(crate) mod record {
    use super::{field_in, BRICK_RECORD_FIELDS};

    /// The occupancy mask (`u64`).
    pub(crate) const OCCUPANCY: usize = field_in(&BRICK_RECORD_FIELDS, "occupancy").offset;
    /// The private mask (`u64`).
    pub(crate) const PRIVATE: usize = field_in(&BRICK_RECORD_FIELDS, "private").offset;
    /// The plane's four `i16` terms, `a` first.
    pub(crate) const PLANE: usize = field_in(&BRICK_RECORD_FIELDS, "plane_a").offset;
    /// The residual word (`u32`).
    pub(crate) const RESIDUALS: usize = field_in(&BRICK_RECORD_FIELDS, "residuals").offset;
    /// The first private leaf (`u32`).
    pub(crate) const FIRST_PRIVATE_LEAF: usize =
        field_in(&BRICK_RECORD_FIELDS, "first_private_leaf").offset;
}

/// Leaf cells per brick edge: a brick is the node at `depth − 2`, 4 × 4 × 4 leaf cells.
pub const BRICK_EDGE: u32 = 4;
/// Octree levels a brick spans (`BRICK_EDGE = 2^BRICK_LEVELS`): the shallowest 3.0 depth.
pub const BRICK_LEVELS: u8 = 2;
/// Grid points per brick edge (`BRICK_EDGE + 1`): point `(x, y, z)` of a brick has the index
/// `25x + 5y + z` in its 125-bit point grid.
pub const BRICK_POINT_EDGE: u32 = BRICK_EDGE + 1;
/// Bits of the residual word that hold the byte offset (the rest is the width code).
pub const RESIDUAL_OFFSET_BITS: u32 = 30;
/// The residual word's offset bits, as a mask.
pub(crate) const RESIDUAL_OFFSET_MASK: u32 = (1 << RESIDUAL_OFFSET_BITS) - 1;

/// The residual widths in bits a brick may use, indexed by its 2-bit width code: 0, 2, 4, 8
/// for 8-bit codes; 0, 4, 8, 16 for 16-bit ones. The widest is the code width: with it any
/// code is stored (its residual taken modulo 2^bits), so every brick has a lossless width.
pub const fn residual_widths(bits: ValueBits) -> [u32; 4] {
    match bits {
        ValueBits::Eight => [0, 2, 4, 8],
        ValueBits::Sixteen => [0, 4, 8, 16],
    }
}

/// Fraction bits of the plane terms: 4 for 8-bit codes (1/16 code units: a plane term spans
/// ±2047 codes, enough for ±127 and its slopes), 0 for 16-bit ones (whole codes, ±32767).
pub const fn plane_fraction_bits(bits: ValueBits) -> u32 {
    match bits {
        ValueBits::Eight => 4,
        ValueBits::Sixteen => 0,
    }
}

const _: () = {
    check_contiguous(&HEADER_FIELDS, 0, HEADER_SIZE);
    check_contiguous(&V3_HEADER_FIELDS, 0, V3_HEADER_SIZE);
    check_contiguous(&BRICK_RECORD_FIELDS, 0, BRICK_RECORD_SIZE);
    check_contiguous(&LOD_HEADER_FIELDS, 0, LOD_HEADER_FIXED);
    check_contiguous(&LOD_LEVEL_FIELDS, 0, LOD_LEVEL_ENTRY);
    check_contiguous(&LOD_TRAILER_FIELDS, 0, LOD_HEADER_TRAILER);
};

/// Header bytes of a 2.0 file with `levels` levels (a multiple of 8).
pub const fn lod_header_size(levels: usize) -> usize {
    LOD_HEADER_FIXED + LOD_LEVEL_ENTRY * levels + LOD_HEADER_TRAILER
}

/// The entry of `table` named `name` (compile-time lookup; panics on an unknown name).
pub(crate) const fn field_in(table: &[HeaderField], name: &str) -> HeaderField {
    let mut i = 0;
    while i < table.len() {
        let f = table[i];
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

/// Checks at compile time that `table` is contiguous from `start` and ends at `end`.
const fn check_contiguous(table: &[HeaderField], start: usize, end: usize) {
    let mut at = start;
    let mut i = 0;
    while i < table.len() {
        assert!(table[i].offset == at);
        at += table[i].size;
        i += 1;
    }
    assert!(at == end);
}

/// A header value stored little-endian in exactly its field's bytes.
trait FieldValue: Copy {
    /// Reads the value from its field's bytes.
    fn read_le(bytes: &[u8]) -> Self;
    /// Writes the value into its field's bytes.
    fn write_le(self, out: &mut [u8]);
}

macro_rules! field_value_int {
    ($($t:ty),*) => {$(
        impl FieldValue for $t {
            #[inline]
            fn read_le(bytes: &[u8]) -> Self {
                // The table gives each field exactly the size of its type (checked at compile
                // time), so the slice has the right length.
                <$t>::from_le_bytes(bytes.try_into().expect("field size"))
            }
            #[inline]
            fn write_le(self, out: &mut [u8]) {
                out.copy_from_slice(&self.to_le_bytes());
            }
        }
    )*};
}
field_value_int!(u8, u16, i16, u32, u64, f32);

impl<const N: usize> FieldValue for [u8; N] {
    fn read_le(bytes: &[u8]) -> Self {
        bytes.try_into().expect("field size")
    }
    fn write_le(self, out: &mut [u8]) {
        out.copy_from_slice(&self);
    }
}

/// Declares a struct of header values, one field per entry of a field table, with the same
/// names. The table alone says where each field sits: `read` and `write` walk it and look each
/// value up by name, so the order of the fields is written down once. Checked at compile time:
/// every struct field is in the table with the size of its type, and the table has no other
/// field.
///
/// A field group the tables share ([`PREAMBLE`], [`GRID`], [`TRANSFORM`]) is named by its table
/// in the list and stands for its fields, whose types are written here once.
macro_rules! header_values {
    ($(#[$doc:meta])* $struct:ident, $table:ident, { $($fields:tt)* }) => {
        header_values!(@expand [$(#[$doc])*] $struct, $table, [] $($fields)*);
    };
    (@expand $doc:tt $struct:ident, $table:ident, [$($done:tt)*] PREAMBLE, $($rest:tt)*) => {
        header_values!(@expand $doc $struct, $table, [$($done)*
            magic: [u8; 8],
            version_major: u16,
            version_minor: u16,
            header_size: u32,
            flags: u32,
        ] $($rest)*);
    };
    (@expand $doc:tt $struct:ident, $table:ident, [$($done:tt)*] GRID, $($rest:tt)*) => {
        header_values!(@expand $doc $struct, $table, [$($done)*
            depth: u8,
            value_bits: u8,
            reserved: u16,
        ] $($rest)*);
    };
    (@expand $doc:tt $struct:ident, $table:ident, [$($done:tt)*] TRANSFORM, $($rest:tt)*) => {
        header_values!(@expand $doc $struct, $table, [$($done)*
            center_x: f32,
            center_y: f32,
            center_z: f32,
            scale: f32,
        ] $($rest)*);
    };
    (@expand $doc:tt $struct:ident, $table:ident, [$($done:tt)*] $name:ident: $ty:ty, $($rest:tt)*) => {
        header_values!(@expand $doc $struct, $table, [$($done)* $name: $ty,] $($rest)*);
    };
    (@expand [$(#[$doc:meta])*] $struct:ident, $table:ident, [$($name:ident: $ty:ty,)*]) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        pub(crate) struct $struct {
            $(pub(crate) $name: $ty,)*
        }

        const _: () = {
            $(assert!(field_in(&$table, stringify!($name)).size == std::mem::size_of::<$ty>());)*
            assert!([$(stringify!($name)),*].len() == $table.len());
        };

        impl $struct {
            /// Reads every field of the table from the bytes the table covers of `bytes`
            /// (panics if shorter: the caller checks the length). Nothing is validated.
            pub(crate) fn read(bytes: &[u8]) -> $struct {
                let mut values = $struct::default();
                for f in &$table {
                    let b = &bytes[f.offset..f.offset + f.size];
                    match f.name {
                        $(stringify!($name) => values.$name = FieldValue::read_le(b),)*
                        _ => unreachable!("header field {} has no value", f.name),
                    }
                }
                values
            }

            /// Writes every field of the table into the bytes the table covers of `out`.
            // Unused where the values are only read (`GridValues`: the writers put the grid
            // in with the rest of their header).
            #[allow(dead_code)]
            pub(crate) fn write(&self, out: &mut [u8]) {
                for f in &$table {
                    let b = &mut out[f.offset..f.offset + f.size];
                    match f.name {
                        $(stringify!($name) => FieldValue::write_le(self.$name, b),)*
                        _ => unreachable!("header field {} has no value", f.name),
                    }
                }
            }
        }
    };
}

header_values! {
    /// The values of a 1.x header, one per [`HEADER_FIELDS`] entry of the same name.
    Header, HEADER_FIELDS, {
    PREAMBLE,
    GRID,
    TRANSFORM,
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
}}

header_values! {
    /// The values of the fixed part of a 2.0 header, one per [`LOD_HEADER_FIELDS`] entry.
    LodHeaderValues, LOD_HEADER_FIELDS, {
    PREAMBLE,
    depth: u8,
    coarsest: u8,
    level_count: u8,
    value_bits: u8,
    TRANSFORM,
    file_size: u64,
    reserved: [u8; 16],
}}

header_values! {
    /// The values of a 3.0 header, one per [`V3_HEADER_FIELDS`] entry of the same name.
    V3Header, V3_HEADER_FIELDS, {
    PREAMBLE,
    GRID,
    TRANSFORM,
    upper_node_count: u32,
    brick_count: u32,
    leaf_count: u32,
    voxel_count: u32,
    surface_voxel_count: u32,
    clip_voxel_count: u32,
    private_leaf_count: u32,
    private_voxel_count: u32,
    file_size: u64,
    nodes_offset: u64,
    nodes_size: u64,
    bricks_offset: u64,
    bricks_size: u64,
    residuals_offset: u64,
    residuals_size: u64,
    private_leaves_offset: u64,
    private_leaves_size: u64,
    private_flags_offset: u64,
    private_flags_size: u64,
    private_corners_offset: u64,
    private_corners_size: u64,
}}

/// The grid and transform: bytes 20–40 of a 1.x and of a 3.x header alike.
const GRID_TRANSFORM: [HeaderField; 7] = joined(&[&GRID, &TRANSFORM]);

header_values! {
    /// The values of the grid and transform fields ([`GRID_TRANSFORM`]) of a 1.x or a 3.x
    /// header, which the readers of both check the same way.
    GridValues, GRID_TRANSFORM, {
    GRID,
    TRANSFORM,
}}

header_values! {
    /// The values of one brick record ([`BRICK_RECORD_FIELDS`]).
    BrickRecord, BRICK_RECORD_FIELDS, {
    occupancy: u64,
    private: u64,
    plane_a: i16,
    plane_b: i16,
    plane_c: i16,
    plane_d: i16,
    residuals: u32,
    first_private_leaf: u32,
}}

header_values! {
    /// One entry of a 2.0 level table ([`LOD_LEVEL_FIELDS`]).
    LevelValues, LOD_LEVEL_FIELDS, {
    offset: u64,
    size: u64,
}}

header_values! {
    /// The bytes after a 2.0 level table ([`LOD_TRAILER_FIELDS`]).
    TrailerValues, LOD_TRAILER_FIELDS, {
    header_crc: u32,
    trailer_zero: u32,
}}

/// The values of a 1.x or 3.x header (`$header`: [`Header`] or [`V3Header`]) for an octree of
/// `meta`: the preamble, grid and transform both start with (the [`MAGIC`], the version, the
/// header's size, the flags, a zero reserved field, `meta`'s depth, value bits and
/// transform), then the version's own fields as given.
macro_rules! octree_header {
    ($header:ident {
        version: ($major:expr, $minor:expr),
        header_size: $size:expr,
        flags: $flags:expr,
        meta: $meta:expr;
        $($field:ident: $value:expr,)*
    }) => {{
        let meta: &$crate::OctreeMeta = $meta;
        $header {
            magic: $crate::header::MAGIC,
            version_major: $major,
            version_minor: $minor,
            header_size: $size as u32,
            flags: $flags,
            depth: meta.depth,
            value_bits: meta.bits.bits(),
            reserved: 0,
            center_x: meta.center.x,
            center_y: meta.center.y,
            center_z: meta.center.z,
            scale: meta.scale,
            $($field: $value,)*
        }
    }};
}
pub(crate) use octree_header;

impl Header {
    /// The header the writer puts in front of an octree with these counts: version 1.0 (1.1
    /// with clip voxels), a [`HEADER_SIZE`]-byte header and the sections where [`Layout`] puts
    /// them.
    pub(crate) fn canonical(meta: &OctreeMeta, counts: Counts) -> Header {
        let layout = Layout::new(HEADER_SIZE as u64, counts, meta.bits);
        octree_header! { Header {
            version: (FORMAT_VERSION_MAJOR, minor_version(counts.clip > 0)),
            header_size: HEADER_SIZE,
            flags: counts.flags(),
            meta: meta;
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
        }}
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
