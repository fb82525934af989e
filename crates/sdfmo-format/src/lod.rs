//! Levels of detail: the version-2.0 `.smo` file, one complete 1.x octree per level, coarsest
//! first, so that any prefix of the file that ends on a level boundary is itself a file of
//! fewer levels (`FORMAT.md`, section "Levels of detail").
//!
//! A file without levels is a 1.x file, written and read by [`Octree`](crate::Octree) exactly
//! as before; [`SmoFile`] reads either.

use std::path::Path;

use glam::Vec3;

use crate::crc32::crc32;
use crate::error::{corrupt, FormatError, Result};
use crate::header::{
    align8, lod_header_size, LevelValues, LodHeaderValues, TrailerValues, LOD_HEADER_FIXED,
    LOD_HEADER_TRAILER, LOD_LEVEL_ENTRY, LOD_VERSION_MAJOR, LOD_VERSION_MINOR, MAGIC,
};
use crate::validate::{check_header_size, check_magic, check_major};
use crate::{
    BrickOctree, OctreeMeta, PackedOctree, PackedOctreeView, ValueBits, FORMAT_VERSION_MAJOR,
    MAX_DEPTH, MAX_FILE_SIZE,
};

/// The smallest 1.x file: a 128-byte header and the checksum (an empty octree).
const MIN_BLOCK: u64 = 132;

/// Where one level lies in a 2.0 file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LevelEntry {
    /// The level: its leaves have edge `2 / 2^level`.
    pub level: u8,
    /// Byte offset of the level's 1.x octree (a multiple of 8).
    pub offset: u64,
    /// Bytes of the level's 1.x octree (its own header to its own CRC-32).
    pub size: u64,
}

impl LevelEntry {
    /// One past the level's last byte: a prefix of at least this many bytes holds the level.
    pub fn end(&self) -> u64 {
        self.offset + self.size
    }
}

/// An octree with levels of detail: level `k` (coarsest ≤ k ≤ depth) is a complete octree of
/// depth `k`, as a depth-`k` build would make it, all sharing one transform and quantisation.
///
/// Made by [`LodOctree::from_levels`] (from builds), or read by [`LodOctree::from_bytes`]
/// (the whole file), [`LodOctree::from_prefix`] (the complete levels of a prefix) and
/// [`LodOctree::load`]. Its file is [`LodOctree::to_bytes`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LodOctree {
    levels: Vec<PackedOctree>,
}

/// What [`LodOctree::from_prefix`] read: the complete levels, and what the file declares.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LodPrefix {
    /// The complete levels of the prefix (at least the coarsest).
    pub octree: LodOctree,
    /// Every level the whole file holds, with its place (from the header).
    pub declared: Vec<LevelEntry>,
    /// The whole file's size (from the header).
    pub file_size: u64,
    /// The file's minor version (from the header): 2.0; 4.0 or 4.1 for levels of bricks.
    pub minor_version: u16,
}

impl LodPrefix {
    /// Whether every declared level was loaded.
    pub fn is_complete(&self) -> bool {
        self.octree.levels.len() == self.declared.len()
    }
}

/// The description a 2.0 or 4.0 header gives (validated, CRC checked).
pub(crate) struct LodHeader {
    /// The file's minor version (at most its [`LevelsVersion::max_minor`]).
    pub(crate) minor: u16,
    pub(crate) meta: OctreeMeta,
    pub(crate) coarsest: u8,
    pub(crate) entries: Vec<LevelEntry>,
    pub(crate) file_size: u64,
}

/// The two files with levels share their header (`FORMAT.md`, "Levels of detail"): 2.0 holds a
/// 1.x octree per level, 4.0 a level block of bricks ([`crate::brick_lod`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct LevelsVersion {
    pub(crate) major: u16,
    /// The minor version the writer writes.
    pub(crate) minor: u16,
    /// The newest minor version a reader takes; a file of a newer one is
    /// [`FormatError::UnsupportedVersion`].
    pub(crate) max_minor: u16,
    /// The fewest bytes a level of this version has.
    pub(crate) min_block: u64,
}

/// Version 2.0: a level is a 1.x octree.
pub(crate) const LEVELS_V2: LevelsVersion = LevelsVersion {
    major: LOD_VERSION_MAJOR,
    minor: LOD_VERSION_MINOR,
    // 2.x minors only add (FORMAT.md, "Versioning").
    max_minor: u16::MAX,
    min_block: MIN_BLOCK,
};

/// The version of a file with levels that `bytes` start like (magic, then major 2 or 4).
pub(crate) fn levels_version(bytes: &[u8]) -> Option<LevelsVersion> {
    if bytes.len() < 10 || bytes[..8] != MAGIC {
        return None;
    }
    match fixed_header(bytes).version_major {
        LOD_VERSION_MAJOR => Some(LEVELS_V2),
        crate::brick_lod::BRICK_LOD_VERSION_MAJOR => Some(crate::brick_lod::LEVELS_V4),
        _ => None,
    }
}

/// The fixed part of a 2.0 header read from `bytes` zero-padded to [`LOD_HEADER_FIXED`]: a
/// short prefix reads its fields, the rest as 0 (the callers check the length after the magic
/// and version).
fn fixed_header(bytes: &[u8]) -> LodHeaderValues {
    let mut fixed = [0u8; LOD_HEADER_FIXED];
    let n = bytes.len().min(LOD_HEADER_FIXED);
    fixed[..n].copy_from_slice(&bytes[..n]);
    LodHeaderValues::read(&fixed)
}

/// Reads and checks a header of `version` from the first bytes of `bytes` (which may be a
/// prefix of the file: only the header must be complete). O(levels).
pub(crate) fn read_header(bytes: &[u8], version: LevelsVersion) -> Result<LodHeader> {
    let len = bytes.len();
    check_magic(bytes, LOD_HEADER_FIXED)?;
    if len < 12 {
        return Err(FormatError::Truncated {
            len,
            needed: LOD_HEADER_FIXED as u64,
        });
    }
    // Zero-padded: the version is read (and a newer major refused) before the length check.
    let h = fixed_header(bytes);
    let (major, minor) = (h.version_major, h.version_minor);
    check_major(major, minor, version.major)?;
    if minor > version.max_minor {
        return Err(FormatError::UnsupportedVersion {
            major,
            minor,
            supported: version.major,
        });
    }
    if len < LOD_HEADER_FIXED {
        return Err(FormatError::Truncated {
            len,
            needed: LOD_HEADER_FIXED as u64,
        });
    }
    let (depth, coarsest, count) = (h.depth, h.coarsest, h.level_count);
    if depth > MAX_DEPTH {
        return Err(FormatError::InvalidDepth {
            depth,
            max: MAX_DEPTH,
        });
    }
    if coarsest > depth || u16::from(count) != u16::from(depth - coarsest) + 1 {
        return corrupt(
            "levels",
            format!(
                "coarsest {coarsest}, depth {depth}, {count} levels (must be depth − coarsest + 1)"
            ),
        );
    }
    let header_size = u64::from(h.header_size);
    let expected = lod_header_size(count as usize) as u64;
    if header_size != expected {
        return corrupt(
            "header_size",
            format!("{header_size} (a {major}.0 header with {count} levels has {expected} bytes)"),
        );
    }
    if (len as u64) < header_size {
        return Err(FormatError::Truncated {
            len,
            needed: header_size,
        });
    }
    let hs = header_size as usize;
    let crc_at = hs - LOD_HEADER_TRAILER;
    let trailer = TrailerValues::read(&bytes[crc_at..hs]);
    let computed = crc32(&bytes[..crc_at]);
    if trailer.header_crc != computed {
        return Err(FormatError::ChecksumMismatch {
            stored: trailer.header_crc,
            computed,
        });
    }
    if trailer.trailer_zero != 0 {
        return corrupt("header padding", "non-zero byte after the header's CRC-32");
    }
    if h.flags != 0 {
        return corrupt(
            "flags",
            format!("{:#x} (a {major}.0 header defines no flag)", h.flags),
        );
    }
    let Some(bits) = ValueBits::from_bits(h.value_bits) else {
        return corrupt("value_bits", format!("{} (must be 8 or 16)", h.value_bits));
    };
    let meta = OctreeMeta {
        depth,
        bits,
        center: Vec3::new(h.center_x, h.center_y, h.center_z),
        scale: h.scale,
    };
    meta.validate()?;
    if h.reserved.iter().any(|&b| b != 0) {
        return corrupt("reserved", "bytes 48..64 must be 0");
    }
    let file_size = h.file_size;
    if file_size > MAX_FILE_SIZE {
        return corrupt(
            "file_size",
            format!("{file_size} (above the limit {MAX_FILE_SIZE})"),
        );
    }
    let mut entries = Vec::with_capacity(count as usize);
    let mut next = header_size;
    for i in 0..count as usize {
        let at = LOD_HEADER_FIXED + i * LOD_LEVEL_ENTRY;
        let LevelValues { offset, size } = LevelValues::read(&bytes[at..at + LOD_LEVEL_ENTRY]);
        if offset != next {
            return corrupt(
                "level table",
                format!(
                    "level {} at offset {offset} (must be {next})",
                    coarsest as usize + i
                ),
            );
        }
        if !(version.min_block..=MAX_FILE_SIZE).contains(&size) {
            return corrupt(
                "level table",
                format!("level {} of {size} bytes", coarsest as usize + i),
            );
        }
        let entry = LevelEntry {
            level: coarsest + i as u8,
            offset,
            size,
        };
        // Both ≤ 2^34: no overflow.
        next = align8(entry.end());
        entries.push(entry);
    }
    let end = entries.last().map_or(header_size, LevelEntry::end);
    if file_size != end {
        return corrupt(
            "file_size",
            format!("{file_size} (the level table ends at {end})"),
        );
    }
    Ok(LodHeader {
        minor,
        meta,
        coarsest,
        entries,
        file_size,
    })
}

/// Validates the 1.x octree of 2.0 level `entry` (its bytes: `block`) and checks it against
/// the header.
fn read_level(block: &[u8], entry: &LevelEntry, header: &LodHeader) -> Result<PackedOctree> {
    let meta = &header.meta;
    let view = PackedOctreeView::new(block).map_err(|e| FormatError::Corrupt {
        field: "level",
        reason: format!("level {}: {e}", entry.level),
    })?;
    let m = view.meta();
    let same = m.depth == entry.level
        && m.bits == meta.bits
        && m.center.to_array().map(f32::to_bits) == meta.center.to_array().map(f32::to_bits)
        && m.scale.to_bits() == meta.scale.to_bits();
    if !same {
        return corrupt(
            "level",
            format!(
                "level {}'s octree has depth {}, {} bits, center {:?}, scale {} (the header: \
                 {} bits, center {:?}, scale {})",
                entry.level,
                m.depth,
                m.bits.bits(),
                m.center.to_array(),
                m.scale,
                meta.bits.bits(),
                meta.center.to_array(),
                meta.scale
            ),
        );
    }
    Ok(view.to_octree())
}

/// That `len` bytes of data do not run past the `file_size` the header declares.
pub(crate) fn check_no_trailing(header: &LodHeader, len: u64) -> Result<()> {
    if len > header.file_size {
        return corrupt(
            "file_size",
            format!(
                "{} (the data has {len} bytes: trailing bytes)",
                header.file_size
            ),
        );
    }
    Ok(())
}

/// The zero padding between the end of level `entry` and the next level (or nothing after the
/// last), as far as `bytes` reaches.
pub(crate) fn check_gap(bytes: &[u8], entry: &LevelEntry, next: Option<&LevelEntry>) -> Result<()> {
    if let Some(n) = next {
        let to = (n.offset as usize).min(bytes.len());
        if bytes[entry.end() as usize..to].iter().any(|&b| b != 0) {
            return corrupt(
                "padding",
                format!("non-zero byte after level {}", entry.level),
            );
        }
    }
    Ok(())
}

/// Writes the header of a file with levels of `version` (its level table and CRC-32) into the
/// start of `out`, whose length is the file size.
pub(crate) fn write_header(
    out: &mut [u8],
    version: LevelsVersion,
    meta: &OctreeMeta,
    entries: &[LevelEntry],
) {
    let hs = lod_header_size(entries.len());
    LodHeaderValues {
        magic: MAGIC,
        version_major: version.major,
        version_minor: version.minor,
        header_size: hs as u32,
        flags: 0,
        depth: meta.depth,
        coarsest: entries.first().map_or(meta.depth, |e| e.level),
        level_count: entries.len() as u8,
        value_bits: meta.bits.bits(),
        center_x: meta.center.x,
        center_y: meta.center.y,
        center_z: meta.center.z,
        scale: meta.scale,
        file_size: out.len() as u64,
        reserved: [0; 16],
    }
    .write(out);
    for (i, e) in entries.iter().enumerate() {
        let at = LOD_HEADER_FIXED + i * LOD_LEVEL_ENTRY;
        LevelValues {
            offset: e.offset,
            size: e.size,
        }
        .write(&mut out[at..at + LOD_LEVEL_ENTRY]);
    }
    let crc_at = hs - LOD_HEADER_TRAILER;
    TrailerValues {
        header_crc: crc32(&out[..crc_at]),
        trailer_zero: 0,
    }
    .write(&mut out[crc_at..hs]);
}

/// The complete levels of a prefix of a file with levels of `version`, each read by
/// `read_level(level bytes, entry, header)` coarsest first (a 4.0 level needs the one
/// before it), with the checks both versions share: the header, no trailing bytes, zero
/// padding between levels, at least the coarsest level.
pub(crate) fn read_prefix(
    bytes: &[u8],
    version: LevelsVersion,
    mut read_level: impl FnMut(&[u8], &LevelEntry, &LodHeader) -> Result<PackedOctree>,
) -> Result<LodPrefix> {
    let header = read_header(bytes, version)?;
    let len = bytes.len() as u64;
    check_no_trailing(&header, len)?;
    let mut levels = Vec::new();
    for (i, e) in header.entries.iter().enumerate() {
        if e.end() > len {
            break;
        }
        levels.push(read_level(
            &bytes[e.offset as usize..e.end() as usize],
            e,
            &header,
        )?);
        check_gap(bytes, e, header.entries.get(i + 1))?;
    }
    if levels.is_empty() {
        return Err(FormatError::Truncated {
            len: bytes.len(),
            needed: header.entries[0].end(),
        });
    }
    debug_assert_eq!(levels[0].depth(), header.coarsest);
    Ok(LodPrefix {
        octree: LodOctree { levels },
        declared: header.entries,
        file_size: header.file_size,
        minor_version: header.minor,
    })
}

impl LodOctree {
    /// The levels of one file, coarsest first: `levels[i]` must have depth `levels[0]`'s + `i`,
    /// and all the same value bits, centre and scale (bit for bit). Errors when empty, or when
    /// a level breaks that rule.
    pub fn from_levels(levels: Vec<PackedOctree>) -> Result<LodOctree> {
        let Some(first) = levels.first() else {
            return corrupt("levels", "a file with levels needs at least one");
        };
        let m0 = *first.meta();
        for (i, l) in levels.iter().enumerate() {
            let m = l.meta();
            let depth_ok = usize::from(m.depth) == usize::from(m0.depth) + i;
            let frame_ok = m.bits == m0.bits
                && m.center.to_array().map(f32::to_bits) == m0.center.to_array().map(f32::to_bits)
                && m.scale.to_bits() == m0.scale.to_bits();
            if !depth_ok || !frame_ok {
                return corrupt(
                    "levels",
                    format!(
                        "level {i} has depth {}, {} bits, center {:?}, scale {} (expected \
                         depth {}, {} bits, center {:?}, scale {})",
                        m.depth,
                        m.bits.bits(),
                        m.center.to_array(),
                        m.scale,
                        usize::from(m0.depth) + i,
                        m0.bits.bits(),
                        m0.center.to_array(),
                        m0.scale
                    ),
                );
            }
        }
        // Canonical bytes, so that the file is a function of the octrees.
        let levels = levels.into_iter().map(|l| l.into_canonical()).collect();
        Ok(LodOctree { levels })
    }

    /// The coarsest level.
    pub fn coarsest(&self) -> u8 {
        self.levels[0].depth()
    }

    /// The finest level (the leaf depth).
    pub fn depth(&self) -> u8 {
        self.coarsest() + (self.levels.len() - 1) as u8
    }

    /// Transform and quantisation, with `depth` the finest level.
    pub fn meta(&self) -> OctreeMeta {
        OctreeMeta {
            depth: self.depth(),
            ..*self.levels[0].meta()
        }
    }

    /// The levels, coarsest first.
    pub fn levels(&self) -> &[PackedOctree] {
        &self.levels
    }

    /// The octree of level `level` (its leaves at that depth), if the file has it.
    pub fn level(&self, level: u8) -> Option<&PackedOctree> {
        let i = level.checked_sub(self.coarsest())?;
        self.levels.get(i as usize)
    }

    /// The finest level's octree.
    pub fn finest(&self) -> &PackedOctree {
        &self.levels[self.levels.len() - 1]
    }

    /// Where each level lies in [`LodOctree::to_bytes`].
    pub fn entries(&self) -> Vec<LevelEntry> {
        let mut offset = lod_header_size(self.levels.len()) as u64;
        self.levels
            .iter()
            .map(|l| {
                let e = LevelEntry {
                    level: l.depth(),
                    offset,
                    size: l.byte_size() as u64,
                };
                offset = align8(e.end());
                e
            })
            .collect()
    }

    /// Bytes of the file [`LodOctree::to_bytes`] writes.
    pub fn byte_size(&self) -> u64 {
        self.entries().last().map_or(0, LevelEntry::end)
    }

    /// The version-2.0 file (`FORMAT.md`, "Levels of detail"): the header with the level table
    /// and its CRC-32, then each level's 1.x octree, coarsest first, each at a multiple of 8.
    pub fn to_bytes(&self) -> Vec<u8> {
        let entries = self.entries();
        let mut out = vec![0u8; self.byte_size() as usize];
        write_header(&mut out, LEVELS_V2, &self.meta(), &entries);
        for (e, l) in entries.iter().zip(&self.levels) {
            out[e.offset as usize..e.end() as usize].copy_from_slice(l.as_bytes());
        }
        out
    }

    /// Reads a whole version-2.0 file: the header (its CRC-32, fields, level table), then every
    /// level as a 1.x octree ([`Octree::new`](crate::Octree::new)'s checks) with the header's
    /// depth, bits and transform, and zero padding between levels. A file shorter or longer
    /// than its `file_size` is refused. O(bytes.len()) time and memory.
    pub fn from_bytes(bytes: &[u8]) -> Result<LodOctree> {
        let header = read_header(bytes, LEVELS_V2)?;
        let len = bytes.len() as u64;
        if len < header.file_size {
            return Err(FormatError::Truncated {
                len: bytes.len(),
                needed: header.file_size,
            });
        }
        // A longer file is refused by `from_prefix`.
        Ok(LodOctree::from_prefix(bytes)?.octree)
    }

    /// Reads the complete levels of a prefix of a version-2.0 file (a download in progress, a
    /// read of the first N bytes): the header must be complete; every level that ends within
    /// the prefix is validated and loaded, coarsest first; a level cut by the end of the prefix
    /// and those after it are left out. Errors: no complete level (a
    /// [`FormatError::Truncated`] that names the bytes the coarsest level needs), a corrupt
    /// header or complete level, non-zero padding, or more bytes than the file declares.
    pub fn from_prefix(bytes: &[u8]) -> Result<LodPrefix> {
        read_prefix(bytes, LEVELS_V2, read_level)
    }

    /// Reads and validates a whole version-2.0 file of at most [`MAX_FILE_SIZE`] bytes.
    pub fn load(path: &Path) -> Result<LodOctree> {
        LodOctree::from_bytes(&read_smo(path, MAX_FILE_SIZE, SmoRead::Whole)?)
    }

    /// Writes [`LodOctree::to_bytes`] atomically ([`sdfmo_io::write_atomic`]).
    pub fn save(&self, path: &Path) -> Result<()> {
        Ok(sdfmo_io::write_atomic(path, self.to_bytes())?)
    }
}

/// Bytes [`read_smo`] reads before anything else: every header of either kind (a 1.x header is
/// [`HEADER_SIZE`](crate::HEADER_SIZE) bytes, a 2.0 header at most
/// `lod_header_size(MAX_DEPTH + 1)`) fits.
pub const SMO_HEAD_BYTES: usize = 4096;

const _: () = assert!(lod_header_size(MAX_DEPTH as usize + 1) <= SMO_HEAD_BYTES);
const _: () = assert!(crate::HEADER_SIZE <= SMO_HEAD_BYTES);

/// What [`read_smo`] accepts of a file's length against the size its header declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SmoRead {
    /// Exactly the declared size (loading a file).
    Whole,
    /// At most the declared size for a 2.0 file (a download in progress, read by
    /// [`LodOctree::from_prefix`]); exactly for a 1.x file, which has no usable prefix.
    Prefix,
}

/// Checks the header at the start of a `.smo` file of `len` bytes against that length, before
/// its body is read: magic, major version, header size (and for a 2.0 header its CRC-32 and
/// level table), and the declared file size against `len` as `read` accepts it. `head` holds
/// the file's first [`SMO_HEAD_BYTES`] bytes (or the whole file when it is shorter). The
/// errors are those [`SmoFile::from_bytes`] gives for the whole file.
pub fn check_smo_head(head: &[u8], len: u64, read: SmoRead) -> Result<()> {
    if crate::brick::is_v3(head) {
        crate::brick::check_v3_head(head, len)?;
        return Ok(());
    }
    let Some(version) = levels_version(head) else {
        check_header_size(head, len)?;
        return Ok(());
    };
    let header = read_header(head, version)?;
    if len < header.file_size && read == SmoRead::Whole {
        return Err(FormatError::Truncated {
            len: usize::try_from(len).unwrap_or(usize::MAX),
            needed: header.file_size,
        });
    }
    check_no_trailing(&header, len)
}

/// Reads a `.smo` file of at most `max_bytes` bytes, header first: its first
/// [`SMO_HEAD_BYTES`] bytes are checked by [`check_smo_head`] against the file's length before
/// the rest is read ([`sdfmo_io::read_regular_checked`]), so a file whose header declares
/// another size than it has is refused after one small read, whatever its length. The bytes
/// are not validated further (the caller's `from_bytes` does that). A compressed file
/// ([`crate::compressed`]) is decoded, to at most `max_bytes` bytes: the result is the `.smo`
/// it was made from.
///
/// # Errors
/// The file's I/O errors ([`FormatError::Io`]: not a regular file, over `max_bytes`, out of
/// memory) and [`check_smo_head`]'s.
pub fn read_smo(path: &Path, max_bytes: u64, read: SmoRead) -> Result<Vec<u8>> {
    let bytes = sdfmo_io::read_regular_checked(path, max_bytes, SMO_HEAD_BYTES, |head, len| {
        if crate::compressed::is_compressed(head) {
            // A compressed file checks itself as a whole (its CRC-32 and stream table).
            return Ok(len);
        }
        check_smo_head(head, len, read).map(|()| len)
    })?;
    if crate::compressed::is_compressed(&bytes) {
        return crate::compressed::decompress(&bytes, max_bytes);
    }
    Ok(bytes)
}

/// What [`SmoFile::from_prefix`] read: the levels the data holds (the whole file, or a file
/// with levels cut where a level ends) and the levels the whole file has.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SmoPrefix {
    /// The levels held (of a prefix: those before the cut, as a file of their own).
    pub file: SmoFile,
    /// The levels the whole file has, `(coarsest, finest)`, from its header (a 1.x file: its
    /// depth twice).
    pub declared: (u8, u8),
}

impl SmoPrefix {
    /// The levels held, `(coarsest, finest)` ([`SmoFile::level_range`]).
    pub fn held(&self) -> (u8, u8) {
        self.file.level_range()
    }

    /// Whether every level the file declares is held (the data is the whole file).
    pub fn is_complete(&self) -> bool {
        self.held() == self.declared
    }
}

/// A `.smo` file of any kind: one octree (version 1.x), levels of detail (2.0) or one octree
/// of bricks (3.0, traced as it is).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SmoFile {
    /// A 1.x file: one octree, leaves at one depth.
    Octree(PackedOctree),
    /// A 2.0 file: one octree per level.
    Levels(LodOctree),
    /// A 3.0 file: one octree in bricks, read and traced in place (`sdfmo-trace` through
    /// [`TracedOctree`](crate::TracedOctree)).
    Bricks(BrickOctree),
}

/// One octree of a [`SmoFile`], in the layout the file holds it (both are
/// [`TracedOctree`](crate::TracedOctree)s: the tracers read either in place).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SmoLevel<'a> {
    /// A 1.x octree (of a 1.x file, or a level of a 2.0 file).
    Octree(&'a PackedOctree),
    /// The octree of a 3.0 file.
    Bricks(&'a BrickOctree),
}

impl<'a> SmoLevel<'a> {
    /// Depth, quantisation and normalisation transform (borrowed from the file, not from this
    /// handle).
    pub fn meta(&self) -> &'a OctreeMeta {
        match *self {
            SmoLevel::Octree(o) => o.meta(),
            SmoLevel::Bricks(b) => b.meta(),
        }
    }

    /// Leaves sit at this level.
    pub fn depth(&self) -> u8 {
        self.meta().depth
    }

    /// Inner nodes plus leaves (of a 3.0 octree, its 1.x octree's: [`BrickOctree::node_count`]).
    pub fn node_count(&self) -> usize {
        match self {
            SmoLevel::Octree(o) => o.node_count(),
            SmoLevel::Bricks(b) => b.node_count(),
        }
    }

    /// Leaves.
    pub fn leaf_count(&self) -> usize {
        match self {
            SmoLevel::Octree(o) => o.leaf_count(),
            SmoLevel::Bricks(b) => b.leaf_count(),
        }
    }

    /// Voxels in all leaves.
    pub fn voxel_count(&self) -> usize {
        match self {
            SmoLevel::Octree(o) => o.voxel_count(),
            SmoLevel::Bricks(b) => b.voxel_count(),
        }
    }

    /// Voxels flagged surface (thin).
    pub fn surface_voxel_count(&self) -> usize {
        match self {
            SmoLevel::Octree(o) => o.surface_voxel_count(),
            SmoLevel::Bricks(b) => b.surface_voxel_count(),
        }
    }

    /// Bytes of the octree's file.
    pub fn byte_size(&self) -> usize {
        match self {
            SmoLevel::Octree(o) => o.byte_size(),
            SmoLevel::Bricks(b) => b.as_bytes().len(),
        }
    }
}

impl SmoFile {
    /// Reads any kind from bytes, by the major version (bytes 8..10): 1 → [`PackedOctree::from_bytes`],
    /// 2 → [`LodOctree::from_bytes`], 3 → [`BrickOctree::new`] (kept as 3.0: the tracers read
    /// it in place), 4 → [`decode_levels`](crate::decode_levels) (levels of bricks, each
    /// decoded to its 1.x octree); anything else is the 1.x reader's error. A compressed
    /// container ([`crate::compressed`]) is decoded first (to at most [`MAX_FILE_SIZE`] bytes:
    /// a compressed 3.0 file to its 3.0 bytes).
    pub fn from_bytes(bytes: &[u8]) -> Result<SmoFile> {
        if crate::compressed::is_compressed(bytes) {
            return SmoFile::from_bytes(&crate::compressed::decompress(bytes, MAX_FILE_SIZE)?);
        }
        if SmoFile::has_levels(bytes) {
            return Ok(SmoFile::Levels(LodOctree::from_bytes(bytes)?));
        }
        if crate::brick_lod::is_brick_levels(bytes) {
            // Levels of bricks are decoded to the 1.x octree of each level (as 3.0 files are).
            return Ok(SmoFile::Levels(crate::brick_lod::decode_levels(bytes)?));
        }
        if crate::brick::is_v3(bytes) {
            return Ok(SmoFile::Bricks(BrickOctree::new(bytes.to_vec())?));
        }
        debug_assert_eq!(FORMAT_VERSION_MAJOR, 1);
        Ok(SmoFile::Octree(PackedOctree::from_bytes(bytes)?))
    }

    /// Reads and validates a `.smo` file of either kind of at most [`MAX_FILE_SIZE`] bytes.
    pub fn load(path: &Path) -> Result<SmoFile> {
        SmoFile::load_with_limit(path, MAX_FILE_SIZE)
    }

    /// [`SmoFile::load`] with an explicit size limit in bytes, checked before reading.
    pub fn load_with_limit(path: &Path, max_bytes: u64) -> Result<SmoFile> {
        SmoFile::from_bytes(&read_smo(path, max_bytes, SmoRead::Whole)?)
    }

    /// Reads either kind from the whole file or, for a file with levels, from a prefix that
    /// ends where a level ends (or in the zero padding after it): the levels it holds, and
    /// those the whole file declares. A 1.x file must be whole ([`SmoFile::from_bytes`]).
    ///
    /// # Errors
    /// [`SmoFile::from_bytes`]'s for a 1.x file; [`LodOctree::from_prefix`]'s for a file with
    /// levels (a prefix without its coarsest level is [`FormatError::Truncated`]), and
    /// [`FormatError::CutInsideLevel`] for a prefix that ends inside a later level: data cut
    /// off in the middle of a level is a broken copy, not a file of fewer levels.
    pub fn from_prefix(bytes: &[u8]) -> Result<SmoPrefix> {
        if crate::compressed::is_compressed(bytes) {
            // A compressed file is whole or refused (its CRC-32): no prefix of it decodes.
            return SmoFile::from_prefix(&crate::compressed::decompress(bytes, MAX_FILE_SIZE)?);
        }
        let p = if SmoFile::has_levels(bytes) {
            LodOctree::from_prefix(bytes)?
        } else if crate::brick_lod::is_brick_levels(bytes) {
            crate::brick_lod::decode_levels_prefix(bytes)?
        } else {
            let file = SmoFile::from_bytes(bytes)?;
            let declared = file.level_range();
            return Ok(SmoPrefix { file, declared });
        };
        let len = bytes.len() as u64;
        if let Some(next) = p.declared.get(p.octree.levels.len()) {
            if len > next.offset {
                return Err(FormatError::CutInsideLevel {
                    len,
                    level: next.level,
                    start: next.offset,
                    end: next.end(),
                });
            }
        }
        // `from_prefix` read a valid table: at least one level, coarsest first.
        let declared = (p.declared[0].level, p.declared[p.declared.len() - 1].level);
        Ok(SmoPrefix {
            file: SmoFile::Levels(p.octree),
            declared,
        })
    }

    /// Reads a `.smo` file of at most `max_bytes` bytes, header first ([`read_smo`] with
    /// [`SmoRead::Prefix`]), as [`SmoFile::from_prefix`] reads its bytes.
    pub fn load_prefix(path: &Path, max_bytes: u64) -> Result<SmoPrefix> {
        SmoFile::from_prefix(&read_smo(path, max_bytes, SmoRead::Prefix)?)
    }

    /// Whether `bytes` start like a version-2.0 file (magic and major version 2).
    pub fn has_levels(bytes: &[u8]) -> bool {
        bytes.len() >= 10
            && bytes[..8] == MAGIC
            && fixed_header(bytes).version_major == LOD_VERSION_MAJOR
    }

    /// The octree to draw at `level`, or the finest one with `None`: a 1.x or 3.0 file has the
    /// one level `depth`. `None` when the file has no such level.
    pub fn level(&self, level: Option<u8>) -> Option<SmoLevel<'_>> {
        match (self, level) {
            (SmoFile::Octree(o), None) => Some(SmoLevel::Octree(o)),
            (SmoFile::Octree(o), Some(l)) => (l == o.depth()).then_some(SmoLevel::Octree(o)),
            (SmoFile::Levels(l), None) => Some(SmoLevel::Octree(l.finest())),
            (SmoFile::Levels(l), Some(k)) => l.level(k).map(SmoLevel::Octree),
            (SmoFile::Bricks(b), None) => Some(SmoLevel::Bricks(b)),
            (SmoFile::Bricks(b), Some(l)) => (l == b.depth()).then_some(SmoLevel::Bricks(b)),
        }
    }

    /// The levels the file holds: `(coarsest, finest)`.
    pub fn level_range(&self) -> (u8, u8) {
        match self {
            SmoFile::Octree(o) => (o.depth(), o.depth()),
            SmoFile::Levels(l) => (l.coarsest(), l.depth()),
            SmoFile::Bricks(b) => (b.depth(), b.depth()),
        }
    }

    /// The finest octree.
    pub fn finest(&self) -> SmoLevel<'_> {
        match self {
            SmoFile::Octree(o) => SmoLevel::Octree(o),
            SmoFile::Levels(l) => SmoLevel::Octree(l.finest()),
            SmoFile::Bricks(b) => SmoLevel::Bricks(b),
        }
    }

    /// The file's bytes (of a prefix of a file with levels: its levels as a file of their
    /// own).
    pub fn to_bytes(&self) -> std::borrow::Cow<'_, [u8]> {
        match self {
            SmoFile::Octree(o) => o.as_bytes().into(),
            SmoFile::Levels(l) => l.to_bytes().into(),
            SmoFile::Bricks(b) => b.as_bytes().into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::sphere_leaves;
    use crate::LeafInput;

    /// A sphere of radius 0.6 at `depth`, as the leaf cells it passes through, some of its
    /// voxels surface voxels.
    fn sphere(depth: u8) -> PackedOctree {
        let mut leaves = sphere_leaves(depth, 0.6);
        for leaf in &mut leaves {
            leaf.voxels[0].surface = (leaf.coord[0] + leaf.coord[1]) % 5 == 0;
        }
        let meta = OctreeMeta {
            depth,
            bits: ValueBits::Eight,
            center: Vec3::new(0.5, -1.0, 2.0),
            scale: 0.25,
        };
        PackedOctree::from_leaves(meta, leaves).unwrap()
    }

    fn lod() -> LodOctree {
        LodOctree::from_levels((1..=4).map(sphere).collect()).unwrap()
    }

    #[test]
    fn round_trip_is_identical() {
        let l = lod();
        let bytes = l.to_bytes();
        assert_eq!(bytes.len() as u64, l.byte_size());
        let back = LodOctree::from_bytes(&bytes).unwrap();
        assert_eq!(back, l);
        assert_eq!(back.to_bytes(), bytes);
        assert_eq!((back.coarsest(), back.depth()), (1, 4));
        for k in 1..=4 {
            assert_eq!(back.level(k).unwrap(), &sphere(k));
        }
        assert!(back.level(0).is_none() && back.level(5).is_none());
        match SmoFile::from_bytes(&bytes).unwrap() {
            SmoFile::Levels(x) => assert_eq!(x, l),
            SmoFile::Octree(_) | SmoFile::Bricks(_) => panic!("read as one octree"),
        }
    }

    #[test]
    fn one_x_files_stay_one_x() {
        let o = sphere(4);
        match SmoFile::from_bytes(o.as_bytes()).unwrap() {
            SmoFile::Octree(x) => assert_eq!(x.as_bytes(), o.as_bytes()),
            SmoFile::Levels(_) | SmoFile::Bricks(_) => panic!("read as levels or bricks"),
        }
        // Neither reader takes the other's files.
        assert!(matches!(
            LodOctree::from_bytes(o.as_bytes()),
            Err(FormatError::UnsupportedVersion { major: 1, .. })
        ));
        assert!(matches!(
            PackedOctree::from_bytes(&lod().to_bytes()),
            Err(FormatError::UnsupportedVersion { major: 2, .. })
        ));
    }

    /// Every level boundary loads exactly the levels before it; every cut inside a level loads
    /// the levels before that one (or, inside the coarsest or the header, is refused).
    #[test]
    fn prefixes_load_the_complete_levels() {
        let l = lod();
        let bytes = l.to_bytes();
        let entries = l.entries();
        for cut in 0..=bytes.len() {
            let complete = entries.iter().filter(|e| e.end() <= cut as u64).count();
            match LodOctree::from_prefix(&bytes[..cut]) {
                Ok(p) => {
                    assert_eq!(p.octree.levels().len(), complete, "cut {cut}");
                    assert_eq!(p.declared, entries);
                    assert_eq!(p.is_complete(), complete == entries.len());
                    assert_eq!(p.octree.levels(), &l.levels()[..complete]);
                }
                Err(e) => {
                    assert_eq!(complete, 0, "cut {cut}: {e}");
                    assert!(matches!(e, FormatError::Truncated { .. }), "cut {cut}: {e}");
                }
            }
            if cut < bytes.len() {
                assert!(LodOctree::from_bytes(&bytes[..cut]).is_err());
            }
        }
        // A level-boundary prefix is itself a valid file's levels: re-written, it is the file
        // of those levels.
        let e = entries[1];
        let p = LodOctree::from_prefix(&bytes[..e.end() as usize]).unwrap();
        let two = LodOctree::from_levels(l.levels()[..2].to_vec()).unwrap();
        assert_eq!(p.octree.to_bytes(), two.to_bytes());
    }

    /// `SmoFile::from_prefix` takes the whole file and every cut where a level ends (or in
    /// the padding after it), and refuses every other cut: inside a later level with
    /// `CutInsideLevel` naming it, before the coarsest level's end with `Truncated`.
    #[test]
    fn smo_prefixes_end_on_level_boundaries() {
        let l = lod();
        let bytes = l.to_bytes();
        let entries = l.entries();
        let mut boundaries = 0;
        for cut in 0..=bytes.len() {
            let len = cut as u64;
            let held = entries.iter().filter(|e| e.end() <= len).count();
            let inside = entries.get(held).filter(|e| len > e.offset);
            match SmoFile::from_prefix(&bytes[..cut]) {
                Ok(p) => {
                    assert!(held > 0 && inside.is_none(), "cut {cut}");
                    assert_eq!(p.declared, (1, 4));
                    assert_eq!(p.held(), (1, held as u8));
                    assert_eq!(p.is_complete(), held == entries.len());
                    match p.file {
                        SmoFile::Levels(x) => assert_eq!(x.levels(), &l.levels()[..held]),
                        SmoFile::Octree(_) | SmoFile::Bricks(_) => panic!("read as one octree"),
                    }
                    boundaries += 1;
                }
                Err(FormatError::CutInsideLevel {
                    len: at,
                    level,
                    start,
                    end,
                }) => {
                    let e = inside.expect("refused at a boundary");
                    assert!(held > 0, "cut {cut}");
                    assert_eq!((at, level, start, end), (len, e.level, e.offset, e.end()));
                }
                Err(e) => {
                    assert_eq!(held, 0, "cut {cut}: {e}");
                    assert!(matches!(e, FormatError::Truncated { .. }), "cut {cut}: {e}");
                }
            }
        }
        // Each level's end plus the padding bytes before the next level, and the whole file.
        let padding: u64 = entries.windows(2).map(|w| w[1].offset - w[0].end()).sum();
        assert_eq!(boundaries as u64, entries.len() as u64 + padding);
        // A 1.x file is read whole only, as `from_bytes` reads it.
        let o = sphere(3);
        let whole = SmoFile::from_prefix(o.as_bytes()).unwrap();
        assert_eq!((whole.held(), whole.declared), ((3, 3), (3, 3)));
        assert!(whole.is_complete());
        let cut = &o.as_bytes()[..o.byte_size() - 1];
        assert!(matches!(
            SmoFile::from_prefix(cut),
            Err(FormatError::Truncated { .. })
        ));
    }

    #[test]
    fn corrupt_bytes_are_refused() {
        let bytes = lod().to_bytes();
        // Any single flipped byte is an error (header CRC, a level's CRC, padding), never a panic.
        for at in 0..bytes.len() {
            let mut b = bytes.clone();
            b[at] ^= 0x20;
            assert!(LodOctree::from_bytes(&b).is_err(), "byte {at}");
            let _ = LodOctree::from_prefix(&b);
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(LodOctree::from_bytes(&longer).is_err());
    }

    #[test]
    fn levels_must_be_consecutive_and_share_a_frame() {
        assert!(LodOctree::from_levels(vec![]).is_err());
        assert!(LodOctree::from_levels(vec![sphere(2), sphere(4)]).is_err());
        let mut other = sphere(3).meta().to_owned();
        other.scale = 0.5;
        let moved = PackedOctree::from_leaves(
            other,
            sphere(3)
                .leaves()
                .map(|(c, v)| LeafInput {
                    coord: c,
                    voxels: v,
                })
                .collect(),
        )
        .unwrap();
        assert!(LodOctree::from_levels(vec![sphere(2), moved]).is_err());
    }
}
