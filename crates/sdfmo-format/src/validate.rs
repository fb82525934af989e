//! Validation of `.smo` bytes: the one constructor of an [`Octree`] from bytes.

use glam::Vec3;

use crate::crc32::crc32;
use crate::error::{corrupt, FormatError, Result};
use crate::header::{
    minor_version, Counts, GridValues, Header, Layout, CHECKSUM_SIZE, FLAG_CLIP_VOXELS,
    FLAG_MULTI_VOXEL, FLAG_SURFACE_VOXELS, FORMAT_VERSION_MAJOR, HEADER_SIZE, KNOWN_FLAGS, MAGIC,
};
use crate::octree::{bytes_at, low_bits, Octree, Sections};
use crate::quant::max_code;
use crate::{OctreeMeta, ValueBits, MAX_CLIP_VOXELS_PER_LEAF, MAX_DEPTH};

#[inline]
fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes_at::<4>(b, at))
}

impl<B: AsRef<[u8]>> Octree<B> {
    /// Validates `bytes` as a `.smo` file and reads it in place: the only way from bytes to an
    /// octree (for a `&[u8]`, [`PackedOctreeView::new`](crate::PackedOctreeView); the bytes are
    /// used as given, any 1.x version). Checked before anything is used,
    /// in this order: magic, major version, header size, declared file size against the length,
    /// the CRC-32, flags, depth, value bits, reserved bytes, transform, counts, every section's
    /// offset and size against those the counts imply (and zero padding), the node groups
    /// (first-child bases, a breadth-first walk proving every level is complete and the leaves
    /// sit exactly at `depth`), the leaf groups (counts 1..=255, first-voxel bases, total), the
    /// surface bitmap (popcount, padding bits), the corner codes (−Q..=Q), and in a 1.1 file
    /// with clip voxels the clip bitmap (padding bits, at least one bit, no leaf of clip-only
    /// voxels alone, no leaf with more than
    /// [`MAX_CLIP_VOXELS_PER_LEAF`](crate::MAX_CLIP_VOXELS_PER_LEAF) clip voxels). O(len), no allocation (except for the message of an error).
    pub fn new(buffer: B) -> Result<Octree<B>> {
        let (meta, counts, sections) = validate(buffer.as_ref())?;
        Ok(Octree::from_parts(buffer, meta, counts, sections))
    }
}

/// The first check of every reader: `bytes` start with [`MAGIC`]. Shorter than the magic is
/// [`FormatError::Truncated`], needing `header_len` bytes (the header of the version read).
pub(crate) fn check_magic(bytes: &[u8], header_len: usize) -> Result<()> {
    if bytes.len() < MAGIC.len() {
        return Err(FormatError::Truncated {
            len: bytes.len(),
            needed: header_len as u64,
        });
    }
    if bytes[..8] != MAGIC {
        let mut found = [0u8; 8];
        found.copy_from_slice(&bytes[..8]);
        return Err(FormatError::BadMagic { found });
    }
    Ok(())
}

/// The checks of a 1.x header that need only its first [`HEADER_SIZE`] bytes and the length
/// of the whole file, `len` (which `head` may be a prefix of): magic, major version, header
/// size, the declared file size against `len`. Shared by [`validate`] and the readers of
/// files, which run it before reading the body ([`crate::read_smo`]).
pub(crate) fn check_header_size(head: &[u8], len: u64) -> Result<Header> {
    // The length as `Truncated` reports it (saturated on 32-bit targets).
    let len_usize = usize::try_from(len).unwrap_or(usize::MAX);
    check_magic(head, HEADER_SIZE)?;
    if len < HEADER_SIZE as u64 || head.len() < HEADER_SIZE {
        return Err(FormatError::Truncated {
            len: len_usize.min(head.len()),
            needed: HEADER_SIZE as u64,
        });
    }
    let h = Header::read(head);
    let (major, minor) = (h.version_major, h.version_minor);
    check_major(major, minor, FORMAT_VERSION_MAJOR)?;
    check_sizes(
        u64::from(h.header_size),
        HEADER_SIZE,
        h.file_size,
        len,
        (HEADER_SIZE + CHECKSUM_SIZE) as u64,
    )?;
    Ok(h)
}

/// A reader of major version `supported` refuses any other: [`FormatError::UnsupportedVersion`].
pub(crate) fn check_major(major: u16, minor: u16, supported: u16) -> Result<()> {
    if major != supported {
        return Err(FormatError::UnsupportedVersion {
            major,
            minor,
            supported,
        });
    }
    Ok(())
}

/// The size checks of a `.smo` header, 1.x and 3.0 alike: `header_size` a multiple of 8 and at
/// least `min_header`; the declared `file_size` equal to the length `len` (more is
/// [`FormatError::Truncated`], less is trailing bytes); `len` at least `min_len`.
pub(crate) fn check_sizes(
    header_size: u64,
    min_header: usize,
    file_size: u64,
    len: u64,
    min_len: u64,
) -> Result<()> {
    if header_size < min_header as u64 || !header_size.is_multiple_of(8) {
        return corrupt(
            "header_size",
            format!("{header_size} (must be a multiple of 8, at least {min_header})"),
        );
    }
    if file_size > len {
        return Err(FormatError::Truncated {
            // The length as `Truncated` reports it (saturated on 32-bit targets).
            len: usize::try_from(len).unwrap_or(usize::MAX),
            needed: file_size,
        });
    }
    if file_size < len {
        return corrupt("file_size", format!("{file_size}, but {len} bytes follow"));
    }
    if len < min_len {
        return corrupt(
            "file_size",
            format!("{len} is smaller than header + checksum"),
        );
    }
    Ok(())
}

/// The octree the grid and transform of a 1.x or 3.x header (`head`, at least the bytes they
/// end at) describe, checked in this order (both versions report the first fault the same
/// way): value bits 8 or 16, the reserved `u16` zero, the centre finite, the scale finite
/// and positive. The depth is taken as it is: its range differs by version, so the caller
/// has checked it.
pub(crate) fn check_grid(head: &[u8]) -> Result<OctreeMeta> {
    let g = GridValues::read(head);
    let Some(bits) = ValueBits::from_bits(g.value_bits) else {
        return corrupt("value_bits", format!("{} (must be 8 or 16)", g.value_bits));
    };
    if g.reserved != 0 {
        return corrupt("reserved", format!("{:#x} (must be 0)", g.reserved));
    }
    let center = Vec3::new(g.center_x, g.center_y, g.center_z);
    if !center.is_finite() {
        return corrupt("center", format!("{center:?} is not finite"));
    }
    if !g.scale.is_finite() || g.scale <= 0.0 {
        return corrupt("scale", format!("{} (must be finite and > 0)", g.scale));
    }
    Ok(OctreeMeta {
        depth: g.depth,
        bits,
        center,
        scale: g.scale,
    })
}

/// The checks of [`Octree::new`], in order; on success the octree's description.
fn validate(bytes: &[u8]) -> Result<(OctreeMeta, Counts, Sections)> {
    let len = bytes.len();
    let h = check_header_size(bytes, len as u64)?;
    let (header_size, file_size) = (u64::from(h.header_size), h.file_size);
    let (major, minor) = (h.version_major, h.version_minor);
    let crc_at = len - CHECKSUM_SIZE;
    let stored = u32_at(bytes, crc_at);
    let computed = crc32(&bytes[..crc_at]);
    if stored != computed {
        return Err(FormatError::ChecksumMismatch { stored, computed });
    }

    // ---- Header fields (the checksum is right; is the content consistent?) ----
    let flags = h.flags;
    if flags & !KNOWN_FLAGS != 0 {
        return corrupt("flags", format!("unknown bits {:#x}", flags & !KNOWN_FLAGS));
    }
    let depth = h.depth;
    if depth > MAX_DEPTH {
        return corrupt("depth", format!("{depth} > {MAX_DEPTH}"));
    }
    let meta = check_grid(bytes)?;
    let bits = meta.bits;
    let has_clip = flags & FLAG_CLIP_VOXELS != 0;
    if has_clip && minor < minor_version(true) {
        return corrupt(
            "flags",
            format!("clip voxels in a version {major}.{minor} file (they need 1.1)"),
        );
    }
    // `clip` is 1 if the flag is set (the layout needs only that), until the bitmap is counted.
    let mut counts = h.counts();
    let Counts {
        inner,
        leaves,
        voxels,
        surface: surface_count,
        ..
    } = counts;
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
    if has_clip && voxels == 0 {
        return corrupt("flags", "clip bit set in an octree without voxels");
    }

    // ---- Sections: exactly where the counts put them ----
    let layout = Layout::new(header_size, counts, bits);
    if layout.file_size != file_size {
        return corrupt(
            "file_size",
            format!("{file_size}, but the counts imply {}", layout.file_size),
        );
    }
    let table = [
        (
            "nodes_offset",
            h.nodes_offset,
            "nodes_size",
            h.nodes_size,
            layout.nodes,
        ),
        (
            "leaves_offset",
            h.leaves_offset,
            "leaves_size",
            h.leaves_size,
            layout.leaves,
        ),
        (
            "surface_offset",
            h.surface_offset,
            "surface_size",
            h.surface_size,
            layout.surface,
        ),
        (
            "corners_offset",
            h.corners_offset,
            "corners_size",
            h.corners_size,
            layout.corners,
        ),
    ];
    for (off_name, stored_off, size_name, stored_size, (off, size)) in table {
        if stored_off != off {
            return corrupt(off_name, format!("{stored_off}, expected {off}"));
        }
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
        (layout.corners.0 + layout.corners.1, layout.clip.0),
        (layout.clip.0 + layout.clip.1, layout.checksum_offset),
    ];
    for (from, to) in gaps {
        if bytes[from as usize..to as usize].iter().any(|&b| b != 0) {
            return corrupt("padding", format!("non-zero byte in {from}..{to}"));
        }
    }
    let s = SectionBytes {
        meta,
        counts,
        nodes: section(layout.nodes),
        leaves: section(layout.leaves),
        surface: section(layout.surface),
        corners: section(layout.corners),
        clip: section(layout.clip),
    };
    s.validate_nodes()?;
    s.validate_leaves()?;
    s.validate_surface()?;
    s.validate_corners()?;
    counts.clip = s.validate_clip()?;
    Ok((meta, counts, Sections::of(&layout)))
}

/// The sections of a file whose header has been checked.
struct SectionBytes<'a> {
    meta: OctreeMeta,
    counts: Counts,
    nodes: &'a [u8],
    leaves: &'a [u8],
    surface: &'a [u8],
    corners: &'a [u8],
    /// Empty in a file without clip voxels.
    clip: &'a [u8],
}

impl SectionBytes<'_> {
    fn validate_nodes(&self) -> Result<()> {
        validate_node_groups(
            self.nodes,
            self.meta.depth,
            self.counts.inner,
            self.counts.leaves,
        )
    }

    fn validate_leaves(&self) -> Result<()> {
        // Bases: group g's first voxel is the sum of every count before leaf 8g.
        let next = walk_groups("leaves", self.leaves, "first_voxel", 0, |j, c| {
            let real = j < u64::from(self.counts.leaves);
            if real && c == 0 {
                return corrupt("leaves", format!("leaf {j} has no voxel"));
            }
            if !real && c != 0 {
                return corrupt("leaves", format!("padding count of slot {j} is {c}"));
            }
            Ok(u64::from(c))
        })?;
        let voxels = self.counts.voxels;
        if next != u64::from(voxels) {
            return corrupt(
                "leaves",
                format!("counts sum to {next}, voxel_count is {voxels}"),
            );
        }
        Ok(())
    }

    /// Set bits of a per-voxel bitmap (`surface` or `clip`), refusing set padding bits.
    fn bitmap_ones(&self, name: &'static str, bitmap: &[u8]) -> Result<u64> {
        let mut ones = 0u64;
        for (w, word) in bitmap.chunks_exact(8).enumerate() {
            let mut x = u64::from_le_bytes(bytes_at::<8>(word, 0));
            let first = w as u64 * 64;
            let valid = u64::from(self.counts.voxels).saturating_sub(first).min(64);
            if valid < 64 {
                if x >> valid != 0 {
                    return corrupt(name, format!("padding bits set in word {w}"));
                }
                x = low_bits(x, valid as u32);
            }
            ones += u64::from(x.count_ones());
        }
        Ok(ones)
    }

    fn validate_surface(&self) -> Result<()> {
        let ones = self.bitmap_ones("surface", self.surface)?;
        if ones != u64::from(self.counts.surface) {
            return corrupt(
                "surface",
                format!(
                    "{ones} bits set, surface_voxel_count is {}",
                    self.counts.surface
                ),
            );
        }
        Ok(())
    }

    /// The clip bitmap (present iff the header's clip flag is): padding bits 0, at least one
    /// bit set, every leaf holds a voxel that is not clip-only (surface + clip) and at most
    /// [`MAX_CLIP_VOXELS_PER_LEAF`] voxels with the clip bit. Runs after
    /// [`Self::validate_leaves`], so the leaf groups are consistent. Returns the clip count.
    fn validate_clip(&self) -> Result<u32> {
        if self.counts.clip == 0 {
            return Ok(0);
        }
        let ones = self.bitmap_ones("clip", self.clip)?;
        if ones == 0 {
            return corrupt("clip", "the clip flag is set but no voxel has the clip bit");
        }
        let bit = |bitmap: &[u8], v: u64| bitmap[(v >> 3) as usize] >> (v & 7) & 1 != 0;
        let mut v = 0u64;
        for (g, rec) in self.leaves.chunks_exact(12).enumerate() {
            for (s, &c) in rec[4..].iter().enumerate() {
                let (start, end) = (v, v + u64::from(c));
                v = end;
                if c > 0 && (start..end).all(|x| bit(self.surface, x) && bit(self.clip, x)) {
                    return corrupt(
                        "clip",
                        format!("leaf {} has only clip-only voxels", g * 8 + s),
                    );
                }
                let clips = (start..end).filter(|&x| bit(self.clip, x)).count();
                if clips > MAX_CLIP_VOXELS_PER_LEAF {
                    return corrupt(
                        "clip",
                        format!(
                            "leaf {} has {clips} clip voxels, more than the {} the clip rule \
                             allows per leaf (its work per leaf is voxels x clip voxels)",
                            g * 8 + s,
                            MAX_CLIP_VOXELS_PER_LEAF
                        ),
                    );
                }
            }
        }
        // ≤ voxel_count (padding bits are 0), which fits.
        Ok(ones as u32)
    }

    fn validate_corners(&self) -> Result<()> {
        check_codes("corners", self.corners, self.meta.bits)
    }
}

/// Every code of `corners` (a section of 8- or 16-bit codes) within `−Q..=Q`: the one code
/// outside (−2^(bits−1)) is refused, naming `section`.
pub(crate) fn check_codes(section: &'static str, corners: &[u8], bits: ValueBits) -> Result<()> {
    let bad = match bits {
        ValueBits::Eight => corners.iter().position(|&b| b as i8 == i8::MIN),
        ValueBits::Sixteen => corners
            .chunks_exact(2)
            .position(|c| i16::from_le_bytes([c[0], c[1]]) == i16::MIN),
    };
    if let Some(i) = bad {
        return corrupt(
            section,
            format!(
                "code {} at value {i} is outside ±{}",
                -max_code(bits) - 1,
                max_code(bits)
            ),
        );
    }
    Ok(())
}

/// The node groups `nodes` of a tree whose `inner` inner nodes fill levels `0..depth` and
/// whose `leaves` nodes sit at level `depth` (the leaves of a 1.x file, the bricks of a 3.0
/// file): every first-child base, padding mask and level. O(nodes).
pub(crate) fn validate_node_groups(nodes: &[u8], depth: u8, inner: u32, leaves: u32) -> Result<()> {
    let mask_at = |k: u32| nodes[(k as usize >> 3) * 12 + 4 + (k as usize & 7)];
    // Bases: group g's first child is 1 + the popcount of every mask before node 8g.
    walk_groups("nodes", nodes, "first_child", 1, |k, m| {
        if k >= u64::from(inner) && m != 0 {
            return corrupt("nodes", format!("padding mask of slot {k} is {m:#x}"));
        }
        Ok(u64::from(m.count_ones()))
    })?;
    if inner == 0 {
        return Ok(());
    }
    // Breadth-first walk: level ℓ is the node range [start, end); its children are the next
    // `Σ popcount` nodes. Levels above depth − 1 must stay among the inner nodes; the last
    // inner level must end exactly at inner_count and have exactly leaf_count children.
    let (mut start, mut end) = (0u64, 1u64);
    for level in 0..depth {
        let mut children = 0u64;
        for k in start..end {
            let m = mask_at(k as u32);
            if m == 0 {
                return corrupt(
                    "nodes",
                    format!("inner node {k} at level {level} has no child"),
                );
            }
            children += u64::from(m.count_ones());
        }
        if level + 1 < depth {
            if end + children > u64::from(inner) {
                return corrupt(
                    "nodes",
                    format!(
                        "level {} would end at node {}, past the {} inner nodes",
                        level + 1,
                        end + children,
                        inner
                    ),
                );
            }
        } else if end != u64::from(inner) || children != u64::from(leaves) {
            return corrupt(
                "nodes",
                format!(
                    "the tree has {end} inner nodes and {children} leaves, header says {} and {}",
                    inner, leaves
                ),
            );
        }
        (start, end) = (end, end + children);
    }
    Ok(())
}

/// Walks the 12-byte group records of `section` (a u32 `base_name`, then 8 one-byte entries,
/// slot `8g + s`): every base must be `first` plus the sum of what `entry` returned for the
/// entries before it; `entry(slot, byte)` checks an entry and returns its weight. The total.
pub(crate) fn walk_groups(
    section: &'static str,
    bytes: &[u8],
    base_name: &str,
    first: u64,
    mut entry: impl FnMut(u64, u8) -> Result<u64>,
) -> Result<u64> {
    let mut next = first;
    for (g, rec) in bytes.chunks_exact(12).enumerate() {
        let base = u32_at(rec, 0);
        if u64::from(base) != next {
            let what = format!("group {g} {base_name} {base}, expected {next}");
            return corrupt(section, what);
        }
        for (s, &e) in rec[4..].iter().enumerate() {
            next += entry(g as u64 * 8 + s as u64, e)?;
        }
    }
    Ok(next)
}
