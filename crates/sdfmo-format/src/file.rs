//! The `.smo` file: writing, atomic save and load, size accounting (the header and layout are
//! in `header.rs`).

use std::path::Path;

use crate::error::Result;
use crate::header::{Layout, CHECKSUM_SIZE};
use crate::octree::{Octree, PackedOctree, PackedOctreeView};
use crate::MAX_FILE_SIZE;

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

    /// Header flags: [`FLAG_MULTI_VOXEL`](crate::FLAG_MULTI_VOXEL),
    /// [`FLAG_SURFACE_VOXELS`](crate::FLAG_SURFACE_VOXELS),
    /// [`FLAG_CLIP_VOXELS`](crate::FLAG_CLIP_VOXELS).
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
    /// devices and FIFOs are refused without reading). A 3.0 file (plain or compressed) is
    /// validated and decoded to its 1.x octree ([`BrickOctree::to_octree`](crate::BrickOctree::to_octree)):
    /// this type is the 1.x layout (what the GPU kernel uploads). [`SmoFile::load`](crate::SmoFile::load)
    /// keeps a 3.0 file as 3.0, traced in place.
    pub fn load(path: &Path) -> Result<PackedOctree> {
        PackedOctree::load_with_limit(path, MAX_FILE_SIZE)
    }

    /// [`PackedOctree::load`] with an explicit size limit in bytes, checked before reading (and,
    /// for a compressed file, on the decoded size). The bytes read (or decoded) become the
    /// octree's buffer ([`PackedOctree::from_vec`]).
    pub fn load_with_limit(path: &Path, max_bytes: u64) -> Result<PackedOctree> {
        // Header first: a file whose header declares another size is refused before its body
        // is read (the 1.x checks only: a 2.0 file is `UnsupportedVersion`, as from bytes).
        let bytes =
            sdfmo_io::read_regular_checked(path, max_bytes, crate::V3_HEADER_SIZE, |head, len| {
                if crate::compressed::is_compressed(head) {
                    return Ok(len);
                }
                if crate::brick::is_v3(head) {
                    return crate::brick::check_v3_head(head, len).map(|_| len);
                }
                crate::validate::check_header_size(head, len).map(|_| len)
            })?;
        let bytes = if crate::compressed::is_compressed(&bytes) {
            crate::compressed::decompress(&bytes, max_bytes)?
        } else {
            bytes
        };
        if crate::brick::is_v3(&bytes) {
            // The 1.x layout was asked for: the 1.x octree of a 3.0 file.
            return Ok(crate::BrickOctree::new(bytes)?.to_octree());
        }
        PackedOctree::from_vec(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::crc32::crc32;
    use crate::error::FormatError;
    use crate::header::*;
    use crate::ValueBits;
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
