//! The compressed `.smo` container: a `.smo` file (1.x or 2.0) as a few zstd streams, decoded on
//! load into exactly the bytes it was made from.
//!
//! The traced layout spends 8 of its ≈ 10 bytes per voxel on corner codes, and every corner that
//! neighbouring voxels share is stored by each of them (FORMAT.md, "Size per voxel"). For disk
//! and network the container removes that redundancy before an entropy coder sees it:
//!
//! * the node and leaf groups keep only their masks and counts (the `first_child` and
//!   `first_voxel` fields are prefix sums of them, recomputed on decode);
//! * each voxel's eight corner codes become *residuals* against a prediction made from codes the
//!   decoder already has: the same grid point in the leaf before it along −x, −y or −z (the
//!   shared corner of a volume voxel is the same global distance, so the residual is 0), else an
//!   earlier corner of the same voxel;
//! * every stream is one zstd frame (the `zstd` crate: the reference C library, RFC 8878).
//!
//! Decoding is the exact inverse: [`decompress`] returns the original file byte for byte (checked
//! against the CRC-32 of the whole file stored in the container, then by the reader's own
//! validation, which checks every level's CRC-32 again). Nothing the tracers read changes: a
//! compressed file decodes to the traced layout. Layout: the crate's `FORMAT.md`, "Compressed
//! files".

use crate::brick::{is_v3, v3_sections};
use crate::crc32::crc32;
use crate::error::{FormatError, Result};
use crate::header::lod_header_size;
use crate::header::record::{FIRST_PRIVATE_LEAF, RESIDUALS};
use crate::header::{
    Header, Layout, BRICK_RECORD_SIZE, CHECKSUM_SIZE, FORMAT_VERSION_MAJOR, HEADER_SIZE, MAGIC,
    RESIDUAL_OFFSET_MASK, V3_HEADER_SIZE,
};
use crate::lod::{LodOctree, SmoFile};
use crate::narrow::{slots, WIDE_BIT};
use crate::validate::check_major;
use crate::{BrickOctreeView, PackedOctreeView, ValueBits, MAX_DEPTH};

/// The first eight bytes of a compressed file: `\x89 S M Z \r \n \x1a \n` (the `.smo` magic with
/// `Z` for `O`, so a reader that knows only `.smo` refuses it as a bad magic).
pub const COMPRESSED_MAGIC: [u8; 8] = [0x89, b'S', b'M', b'Z', b'\r', b'\n', 0x1A, b'\n'];
/// The container's version (major): a different one is refused.
pub const COMPRESSED_VERSION_MAJOR: u16 = 1;
/// The container's version (minor): 1 when it holds a 3.0 file (its prelude is the 3.0 header),
/// which a 1.0 reader cannot decode; files of 1.x and 2.0 are written as 1.0, as before.
pub const COMPRESSED_VERSION_MINOR: u16 = 1;
/// The minor version written for 1.x and 2.0 files (their streams are unchanged since 1.0).
const COMPRESSED_VERSION_MINOR_1X: u16 = 0;
/// The minor version written for a 4.0 file (levels of bricks): the whole file as its prelude,
/// one zstd frame (it is already a coded stream, with nothing left to split out).
const COMPRESSED_VERSION_MINOR_BRICK_LEVELS: u16 = 2;
/// Bytes of the container's fixed header (before the stream table).
pub const COMPRESSED_HEADER_SIZE: usize = 32;
/// Bytes per entry of the stream table: compressed size, decoded size (two `u64`).
pub const COMPRESSED_STREAM_ENTRY: usize = 16;
/// The zstd level [`compress`] and `sdfmo build --compress` use: every size and decode speed
/// in `docs/results/format.md` ("Compressed files") is measured at it; 19 is about 10 %
/// smaller and several times slower to write.
pub const DEFAULT_COMPRESSION_LEVEL: i32 = 9;

/// The most bytes a container may decode to per byte of it: a bound on the memory a small
/// hostile file can ask for (real octrees compress 3–30×, `docs/results/format.md`).
pub const MAX_EXPANSION: u64 = 1024;

/// Streams per level: header (the 128-byte header and the 4-byte CRC-32), masks, counts,
/// surface bitmap, corner residuals, clip bitmap.
const STREAMS_PER_LEVEL: usize = 6;
/// The most streams a container may declare: a prelude and 17 levels.
const MAX_STREAMS: usize = 1 + STREAMS_PER_LEVEL * (MAX_DEPTH as usize + 1);
/// The decoded header stream: the 1.x header and its trailing CRC-32.
const LEVEL_HEADER_STREAM: usize = HEADER_SIZE + CHECKSUM_SIZE;
/// The decoded prelude of a 3.0 file: its header and its trailing CRC-32.
const BRICK_HEADER_STREAM: usize = V3_HEADER_SIZE + CHECKSUM_SIZE;
/// No neighbour leaf along an axis.
const NONE: u32 = u32::MAX;

/// Whether `bytes` start with [`COMPRESSED_MAGIC`].
pub fn is_compressed(bytes: &[u8]) -> bool {
    bytes.len() >= 8 && bytes[..8] == COMPRESSED_MAGIC
}

/// Compresses a `.smo` file (1.x or 2.0, as this crate writes it) at [`DEFAULT_COMPRESSION_LEVEL`].
///
/// The file is validated first; the result is checked to decode to `smo` byte for byte.
///
/// # Errors
/// `smo`'s validation errors; [`FormatError::Corrupt`] (field `compressed`) if a level is not in
/// the canonical encoding (a 128-byte header), which every file this crate writes is.
pub fn compress(smo: &[u8]) -> Result<Vec<u8>> {
    compress_with_level(smo, DEFAULT_COMPRESSION_LEVEL)
}

/// [`compress`] at a chosen zstd level (1..=22: higher is smaller and slower to write; decoding
/// speed hardly depends on it).
///
/// # Errors
/// As [`compress`]; a level outside 1..=22 is [`FormatError::Corrupt`] (field `level`).
pub fn compress_with_level(smo: &[u8], level: i32) -> Result<Vec<u8>> {
    if !(1..=22).contains(&level) {
        return Err(FormatError::corrupt(
            "level",
            format!("zstd level {level} (must be 1..=22)"),
        ));
    }
    let mut raw: Vec<Vec<u8>> = Vec::new();
    let mut minor = COMPRESSED_VERSION_MINOR_1X;
    if is_v3(smo) {
        encode_bricks(BrickOctreeView::new(smo)?.as_bytes(), &mut raw)?;
        minor = COMPRESSED_VERSION_MINOR;
    } else if crate::is_brick_levels(smo) {
        crate::decode_levels(smo)?;
        raw.push(smo.to_vec());
        minor = COMPRESSED_VERSION_MINOR_BRICK_LEVELS;
    } else if crate::SmoFile::has_levels(smo) {
        let lod = LodOctree::from_bytes(smo)?;
        raw.push(smo[..lod_header_size(lod.levels().len())].to_vec());
        for level in lod.levels() {
            encode_level(level.as_bytes(), &mut raw)?;
        }
    } else {
        let octree = PackedOctreeView::new(smo)?;
        raw.push(Vec::new());
        encode_level(octree.as_bytes(), &mut raw)?;
    }
    let mut out = vec![0u8; COMPRESSED_HEADER_SIZE + COMPRESSED_STREAM_ENTRY * raw.len()];
    out[..8].copy_from_slice(&COMPRESSED_MAGIC);
    out[8..10].copy_from_slice(&COMPRESSED_VERSION_MAJOR.to_le_bytes());
    out[10..12].copy_from_slice(&minor.to_le_bytes());
    out[12..16].copy_from_slice(&(raw.len() as u32).to_le_bytes());
    out[16..24].copy_from_slice(&(smo.len() as u64).to_le_bytes());
    out[24..28].copy_from_slice(&crc32(smo).to_le_bytes());
    for (i, stream) in raw.iter().enumerate() {
        let packed = zstd::bulk::compress(stream, level).map_err(|e| {
            FormatError::corrupt("compressed", format!("zstd could not compress: {e}"))
        })?;
        let entry = COMPRESSED_HEADER_SIZE + COMPRESSED_STREAM_ENTRY * i;
        out[entry..entry + 8].copy_from_slice(&(packed.len() as u64).to_le_bytes());
        out[entry + 8..entry + 16].copy_from_slice(&(stream.len() as u64).to_le_bytes());
        out.extend_from_slice(&packed);
    }
    let crc = crc32(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    // The round trip is the encoder's contract: never write a file that decodes otherwise.
    if decompress(&out, smo.len() as u64)? != smo {
        return Err(FormatError::corrupt(
            "compressed",
            "the input is not in the canonical encoding (it would not decode to the same bytes)",
        ));
    }
    Ok(out)
}

/// Decodes a compressed file into the `.smo` bytes it was made from, refusing one that declares
/// more than `max_decoded` bytes before allocating them.
///
/// Every count, size and index is checked before use; the decoded file's CRC-32 is compared
/// with the one stored. The result is not otherwise validated (the caller's `from_bytes` does).
/// Time and memory O(decoded size).
///
/// # Errors
/// [`FormatError::BadMagic`], [`FormatError::UnsupportedVersion`], [`FormatError::Truncated`],
/// [`FormatError::ChecksumMismatch`] (the container's or the decoded file's), and
/// [`FormatError::Corrupt`] naming the stream or field that is inconsistent.
pub fn decompress(bytes: &[u8], max_decoded: u64) -> Result<Vec<u8>> {
    let table = read_container(bytes, max_decoded)?;
    let mut streams = Vec::with_capacity(table.entries.len());
    let mut at = table.data_start;
    for &(packed, size) in &table.entries {
        let end = at + packed;
        streams.push((&bytes[at..end], size));
        at = end;
    }
    let mut out = Vec::new();
    out.try_reserve_exact(table.decoded_size).map_err(|_| {
        FormatError::corrupt(
            "compressed decoded_size",
            format!("{} bytes: out of memory", table.decoded_size),
        )
    })?;
    out.resize(table.decoded_size, 0);
    let prelude = streams[0].1;
    unpack(streams[0].0, &mut out[..prelude], "prelude")?;
    let at = if prelude == BRICK_HEADER_STREAM && is_v3(&out[..prelude]) {
        if streams.len() != 1 + STREAMS_PER_LEVEL {
            return Err(FormatError::corrupt(
                "compressed stream_count",
                "a 3.0 file is a prelude and six streams",
            ));
        }
        decode_bricks(&streams[1..], &mut out)?
    } else if streams.len() == 1 && crate::is_brick_levels(&out[..prelude]) {
        // A 4.0 file is its prelude.
        prelude
    } else {
        decode_levels(&streams, &mut out)?
    };
    if at != out.len() {
        return Err(FormatError::corrupt(
            "compressed",
            format!(
                "the streams decode to {at} bytes, the header declares {}",
                out.len()
            ),
        ));
    }
    let computed = crc32(&out);
    if computed != table.decoded_crc {
        return Err(FormatError::ChecksumMismatch {
            stored: table.decoded_crc,
            computed,
        });
    }
    Ok(out)
}

/// The container's header and stream table, checked.
struct Container {
    decoded_size: usize,
    decoded_crc: u32,
    /// `(compressed, decoded)` bytes per stream.
    entries: Vec<(usize, usize)>,
    data_start: usize,
}

fn read_container(bytes: &[u8], max_decoded: u64) -> Result<Container> {
    let len = bytes.len();
    if len < 8 || bytes[..8] != COMPRESSED_MAGIC {
        let mut found = [0u8; 8];
        let n = len.min(8);
        found[..n].copy_from_slice(&bytes[..n]);
        return Err(FormatError::BadMagic { found });
    }
    if len < COMPRESSED_HEADER_SIZE + CHECKSUM_SIZE {
        return Err(FormatError::Truncated {
            len,
            needed: (COMPRESSED_HEADER_SIZE + CHECKSUM_SIZE) as u64,
        });
    }
    let (major, minor) = (u16_at(bytes, 8), u16_at(bytes, 10));
    check_major(major, minor, COMPRESSED_VERSION_MAJOR)?;
    let stored = u32::from_le_bytes(bytes_at(bytes, len - 4));
    let computed = crc32(&bytes[..len - 4]);
    if stored != computed {
        return Err(FormatError::ChecksumMismatch { stored, computed });
    }
    let count = u32::from_le_bytes(bytes_at(bytes, 12)) as usize;
    if count == 0 || count > MAX_STREAMS || !(count - 1).is_multiple_of(STREAMS_PER_LEVEL) {
        return Err(FormatError::corrupt(
            "compressed stream_count",
            format!("{count} (must be 1 + {STREAMS_PER_LEVEL} per level, at most {MAX_STREAMS})"),
        ));
    }
    let decoded = u64::from_le_bytes(bytes_at(bytes, 16));
    let limit = max_decoded.min((len as u64).saturating_mul(MAX_EXPANSION));
    if decoded > limit {
        return Err(FormatError::corrupt(
            "compressed decoded_size",
            format!(
                "{decoded} bytes, over the limit of {limit} (the smaller of {max_decoded} and \
                 {MAX_EXPANSION} × the {len}-byte file)"
            ),
        ));
    }
    if u32::from_le_bytes(bytes_at(bytes, 28)) != 0 {
        return Err(FormatError::corrupt("compressed reserved", "not zero"));
    }
    let data_start = COMPRESSED_HEADER_SIZE + COMPRESSED_STREAM_ENTRY * count;
    if len < data_start + CHECKSUM_SIZE {
        return Err(FormatError::Truncated {
            len,
            needed: (data_start + CHECKSUM_SIZE) as u64,
        });
    }
    let mut entries = Vec::with_capacity(count);
    let (mut packed_total, mut decoded_total) = (0u64, 0u64);
    for i in 0..count {
        let entry = COMPRESSED_HEADER_SIZE + COMPRESSED_STREAM_ENTRY * i;
        let packed = u64::from_le_bytes(bytes_at(bytes, entry));
        let size = u64::from_le_bytes(bytes_at(bytes, entry + 8));
        packed_total = packed_total.saturating_add(packed);
        decoded_total = decoded_total.saturating_add(size);
        if decoded_total > decoded {
            return Err(FormatError::corrupt(
                "compressed stream table",
                format!("streams decode to more than the declared {decoded} bytes"),
            ));
        }
        entries.push((packed as usize, size as usize));
    }
    let body = (len - CHECKSUM_SIZE - data_start) as u64;
    if packed_total != body {
        return Err(FormatError::corrupt(
            "compressed stream table",
            format!("streams of {packed_total} bytes, the file holds {body}"),
        ));
    }
    Ok(Container {
        decoded_size: decoded as usize,
        decoded_crc: u32::from_le_bytes(bytes_at(bytes, 24)),
        entries,
        data_start,
    })
}

/// Decodes the levels of a 1.x or 2.0 file (after the prelude, already in `out`); returns where
/// the last ends.
fn decode_levels(streams: &[(&[u8], usize)], out: &mut [u8]) -> Result<usize> {
    let mut at = streams[0].1;
    if at == 0 && streams.len() != 1 + STREAMS_PER_LEVEL {
        return Err(FormatError::corrupt(
            "compressed stream_count",
            "several levels without a 2.0 header (prelude)",
        ));
    }
    if at > 0 && !SmoFile::has_levels(&out[..at]) {
        return Err(FormatError::corrupt(
            "compressed prelude",
            "not a 2.0 or 3.0 header (magic and major version 2 or 3)",
        ));
    }
    for (i, level) in streams[1..].chunks_exact(STREAMS_PER_LEVEL).enumerate() {
        if i > 0 {
            // Padding between levels stays zero (`out` starts zeroed).
            at = at.div_ceil(8) * 8;
        }
        at = decode_level(level, out, at)?;
    }
    Ok(at)
}

/// Decompresses one zstd frame into exactly `out`.
fn unpack(frame: &[u8], out: &mut [u8], stream: &'static str) -> Result<()> {
    if out.is_empty() && frame.is_empty() {
        return Ok(());
    }
    let n = zstd::bulk::decompress_to_buffer(frame, out)
        .map_err(|e| FormatError::corrupt(stream, format!("zstd: {e}")))?;
    if n != out.len() {
        return Err(FormatError::corrupt(
            stream,
            format!("decodes to {n} bytes, the table declares {}", out.len()),
        ));
    }
    Ok(())
}

/// Splits one canonical 1.x file into its six raw streams.
fn encode_level(file: &[u8], raw: &mut Vec<Vec<u8>>) -> Result<()> {
    let header = Header::read(file);
    if usize::try_from(header.header_size) != Ok(HEADER_SIZE) {
        return Err(FormatError::corrupt(
            "compressed",
            format!(
                "a level with a {}-byte header (the container stores canonical {HEADER_SIZE}-byte headers)",
                header.header_size
            ),
        ));
    }
    let bits = value_bits(header.value_bits)?;
    let layout = Layout::new(HEADER_SIZE as u64, header.counts(), bits);
    let mut head = file[..HEADER_SIZE].to_vec();
    head.extend_from_slice(&file[file.len() - CHECKSUM_SIZE..]);
    let masks = group_bytes(section(file, layout.nodes), header.inner_node_count);
    let counts = group_bytes(section(file, layout.leaves), header.leaf_count);
    let tree = LeafTree::walk(header.depth, &masks, &counts, header.voxel_count)?;
    let corners = section(file, layout.corners);
    let mut residuals = vec![0u8; corners.len()];
    match bits {
        ValueBits::Eight => tree.encode(corners, &mut residuals),
        ValueBits::Sixteen => {
            let mut out = vec![0u16; residuals.len() / 2];
            tree.encode(&words(corners), &mut out);
            put_words(&out, &mut residuals);
        }
    }
    raw.extend([
        head,
        masks,
        counts,
        section(file, layout.surface).to_vec(),
        residuals,
        section(file, layout.clip).to_vec(),
    ]);
    Ok(())
}

/// Decodes one level's six streams into `out` at `start`; returns where the level ends.
fn decode_level(streams: &[(&[u8], usize)], out: &mut [u8], start: usize) -> Result<usize> {
    let [head, masks, counts, surface, corners, clip] = streams else {
        unreachable!("chunks_exact(STREAMS_PER_LEVEL)")
    };
    if head.1 != LEVEL_HEADER_STREAM {
        return Err(FormatError::corrupt(
            "compressed header stream",
            format!("{} bytes (must be {LEVEL_HEADER_STREAM})", head.1),
        ));
    }
    let mut head_bytes = [0u8; LEVEL_HEADER_STREAM];
    unpack(head.0, &mut head_bytes, "compressed header stream")?;
    if head_bytes[..8] != MAGIC || u16_at(&head_bytes, 8) != FORMAT_VERSION_MAJOR {
        return Err(FormatError::corrupt(
            "compressed header stream",
            "not a 1.x header (magic and major version 1)",
        ));
    }
    let header = Header::read(&head_bytes);
    if header.depth > MAX_DEPTH || u64::from(header.header_size) != HEADER_SIZE as u64 {
        return Err(FormatError::corrupt(
            "compressed header stream",
            format!(
                "depth {} (at most {MAX_DEPTH}), header_size {} (must be {HEADER_SIZE})",
                header.depth, header.header_size
            ),
        ));
    }
    let bits = value_bits(header.value_bits)?;
    let layout = Layout::new(HEADER_SIZE as u64, header.counts(), bits);
    let size = usize::try_from(layout.file_size).unwrap_or(usize::MAX);
    let left = out.len().saturating_sub(start);
    if header.file_size != layout.file_size || size > left {
        return Err(FormatError::corrupt(
            "compressed header stream",
            format!(
                "file_size {} (the counts give {}, {} bytes are left)",
                header.file_size, layout.file_size, left
            ),
        ));
    }
    let expect = [
        (masks.1, header.inner_node_count as usize, "masks"),
        (counts.1, header.leaf_count as usize, "counts"),
        (surface.1, layout.surface.1 as usize, "surface"),
        (corners.1, layout.corners.1 as usize, "corners"),
        (clip.1, layout.clip.1 as usize, "clip"),
    ];
    for (got, want, name) in expect {
        if got != want {
            return Err(FormatError::corrupt(
                "compressed stream table",
                format!("the {name} stream declares {got} bytes, the header implies {want}"),
            ));
        }
    }
    let file = &mut out[start..start + size];
    file[..HEADER_SIZE].copy_from_slice(&head_bytes[..HEADER_SIZE]);
    file[size - CHECKSUM_SIZE..].copy_from_slice(&head_bytes[HEADER_SIZE..]);
    let mut mask_bytes = vec![0u8; masks.1];
    unpack(masks.0, &mut mask_bytes, "compressed masks stream")?;
    let mut count_bytes = vec![0u8; counts.1];
    unpack(counts.0, &mut count_bytes, "compressed counts stream")?;
    write_groups(
        section_mut(file, layout.nodes),
        &mask_bytes,
        |m| u64::from(m.count_ones()),
        1,
    )?;
    write_groups(section_mut(file, layout.leaves), &count_bytes, u64::from, 0)?;
    unpack(
        surface.0,
        section_mut(file, layout.surface),
        "compressed surface stream",
    )?;
    unpack(
        clip.0,
        section_mut(file, layout.clip),
        "compressed clip stream",
    )?;
    let tree = LeafTree::walk(header.depth, &mask_bytes, &count_bytes, header.voxel_count)?;
    let codes = section_mut(file, layout.corners);
    match bits {
        // The residuals go straight where the codes belong and are decoded in place.
        ValueBits::Eight => {
            unpack(corners.0, codes, "compressed corners stream")?;
            tree.decode(codes);
        }
        ValueBits::Sixteen => {
            unpack(corners.0, codes, "compressed corners stream")?;
            let mut values = words(codes);
            tree.decode(&mut values);
            put_words(&values, codes);
        }
    }
    Ok(start + size)
}

/// Splits a validated 3.0 file into the prelude (its header and CRC-32) and six streams, one
/// per section (measured separately smaller than one stream: `docs/results/format.md`):
/// the upper nodes' masks, the brick records ([`records_to_stream`]), the residuals, the
/// private leaves' counts, the private flags and the private corners ([`predict_voxels`]).
fn encode_bricks(file: &[u8], raw: &mut Vec<Vec<u8>>) -> Result<()> {
    let v3 = v3_sections(file, file.len() as u64)?;
    let c = &v3.counts;
    let [nodes, bricks, residuals, leaves, flags, corners] = v3.layout.sections();
    let mut head = file[..V3_HEADER_SIZE].to_vec();
    head.extend_from_slice(&file[file.len() - CHECKSUM_SIZE..]);
    let mut codes = section(file, corners).to_vec();
    let counts: Vec<u8> = slots(section(file, leaves), c.minor)
        .take(c.private_leaves as usize)
        .map(|(n, wide)| n as u8 | if wide && c.minor > 0 { WIDE_BIT } else { 0 })
        .collect();
    match v3.bits {
        _ if c.minor > 0 => predict_corners31(&counts, &mut codes, &v3, false)?,
        ValueBits::Eight => predict_voxels(&mut codes),
        ValueBits::Sixteen => {
            let mut values = words(&codes);
            predict_voxels(&mut values);
            put_words(&values, &mut codes);
        }
    }
    raw.extend([
        head,
        group_bytes(section(file, nodes), c.tree.inner),
        records_to_stream(section(file, bricks)),
        section(file, residuals).to_vec(),
        counts,
        section(file, flags).to_vec(),
        codes,
    ]);
    Ok(())
}

/// Decodes a 3.0 file's six streams into `out`, whose first [`BRICK_HEADER_STREAM`] bytes
/// hold the prelude; returns the file's size (all of `out`).
fn decode_bricks(streams: &[(&[u8], usize)], out: &mut [u8]) -> Result<usize> {
    let [nodes_s, bricks_s, residuals_s, leaves_s, flags_s, corners_s] = streams else {
        unreachable!("the caller checked six streams")
    };
    let crc: [u8; CHECKSUM_SIZE] = bytes_at(out, V3_HEADER_SIZE);
    // The header's section sizes are checked against its counts; every stream against them.
    let v3 = v3_sections(&out[..V3_HEADER_SIZE], out.len() as u64)?;
    let c = &v3.counts;
    if v3.layout.file_size != out.len() as u64 {
        return Err(FormatError::corrupt(
            "compressed header stream",
            format!(
                "a 3.0 file of {} bytes, the container declares {}",
                v3.layout.file_size,
                out.len()
            ),
        ));
    }
    // The prelude's CRC-32 sat where the node groups start: move it to the end.
    out[V3_HEADER_SIZE..BRICK_HEADER_STREAM].fill(0);
    let size = out.len();
    out[size - CHECKSUM_SIZE..].copy_from_slice(&crc);
    let [nodes, bricks, residuals, leaves, flags, corners] = v3.layout.sections();
    let expect = [
        (nodes_s.1, c.tree.inner as usize, "masks"),
        (bricks_s.1, bricks.1 as usize, "bricks"),
        (residuals_s.1, residuals.1 as usize, "residuals"),
        (leaves_s.1, c.private_leaves as usize, "private leaves"),
        (flags_s.1, flags.1 as usize, "private flags"),
        (corners_s.1, corners.1 as usize, "private corners"),
    ];
    for (got, want, name) in expect {
        if got != want {
            return Err(FormatError::corrupt(
                "compressed stream table",
                format!("the {name} stream declares {got} bytes, the header implies {want}"),
            ));
        }
    }
    let mut masks = vec![0u8; nodes_s.1];
    unpack(nodes_s.0, &mut masks, "compressed masks stream")?;
    write_groups(
        section_mut(out, nodes),
        &masks,
        |m| u64::from(m.count_ones()),
        1,
    )?;
    let mut records = vec![0u8; bricks_s.1];
    unpack(bricks_s.0, &mut records, "compressed bricks stream")?;
    stream_to_records(&records, section_mut(out, bricks));
    unpack(
        residuals_s.0,
        section_mut(out, residuals),
        "compressed residuals stream",
    )?;
    let mut counts = vec![0u8; leaves_s.1];
    unpack(leaves_s.0, &mut counts, "compressed private leaves stream")?;
    if c.minor == 0 {
        write_groups(section_mut(out, leaves), &counts, u64::from, 0)?;
    } else {
        write_groups31(section_mut(out, leaves), &counts, &v3)?;
    }
    unpack(
        flags_s.0,
        section_mut(out, flags),
        "compressed private flags stream",
    )?;
    let codes = section_mut(out, corners);
    unpack(corners_s.0, codes, "compressed private corners stream")?;
    match v3.bits {
        _ if c.minor > 0 => predict_corners31(&counts, codes, &v3, true)?,
        ValueBits::Eight => unpredict_voxels(codes),
        ValueBits::Sixteen => {
            let mut values = words(codes);
            unpredict_voxels(&mut values);
            put_words(&values, codes);
        }
    }
    Ok(size)
}

/// Private corners of a 3.1 file to residuals (`forward = false`, coding) or back
/// (`forward = true`, decoding), in place: the 3.0 prediction ([`predict_voxels`]) on each
/// wide voxel; on a narrow voxel its base codes `c001 c010 c100` minus its `c000`, its `c000`
/// minus the voxel before's, its difference fields unchanged. `counts` are the private leaves'
/// count bytes, whose sums are checked against `v3` first, so every voxel lies in `corners`.
fn predict_corners31(
    counts: &[u8],
    corners: &mut [u8],
    v3: &crate::brick::V3Sections,
    forward: bool,
) -> Result<()> {
    let total: u64 = counts.iter().map(|&c| u64::from(c & !WIDE_BIT)).sum();
    let wide: u64 = counts
        .iter()
        .filter(|&&c| c & WIDE_BIT != 0)
        .map(|&c| u64::from(c & !WIDE_BIT))
        .sum();
    if total != u64::from(v3.counts.private_voxels) || wide != u64::from(v3.counts.wide_voxels) {
        return Err(FormatError::corrupt(
            "compressed private leaves stream",
            format!(
                "{total} voxels, {wide} wide; the header implies {} and {}",
                v3.counts.private_voxels, v3.counts.wide_voxels
            ),
        ));
    }
    match v3.bits {
        ValueBits::Eight => code_corners31(counts, corners, forward),
        ValueBits::Sixteen => {
            let mut values = words(corners);
            code_corners31(counts, &mut values, forward);
            put_words(&values, corners);
        }
    }
    Ok(())
}

/// [`predict_corners31`] over codes `T` (a narrow voxel is 6 of them: four codes, then its
/// difference fields as two more): forwards, each prediction from codes already restored;
/// coding reads the originals from a copy.
fn code_corners31<T: Code>(counts: &[u8], codes: &mut [T], forward: bool) {
    let original = if forward { Vec::new() } else { codes.to_vec() };
    let (mut at, mut prev) = (0usize, T::ZERO);
    for &c in counts {
        let (n, size): (usize, usize) = if c & WIDE_BIT != 0 { (8, 8) } else { (4, 6) };
        let own: &[usize] = if n == 8 { &OWN_CORNER } else { &[0, 0, 0, 0] };
        for _ in 0..c & !WIDE_BIT {
            let v = &mut codes[at..at + size];
            if forward {
                v[0] = v[0].add(prev);
                for k in 1..n {
                    v[k] = v[k].add(v[own[k]]);
                }
                prev = v[0];
            } else {
                let o = &original[at..at + size];
                v[0] = o[0].sub(prev);
                for k in 1..n {
                    v[k] = o[k].sub(o[own[k]]);
                }
                prev = o[0];
            }
            at += size;
        }
    }
}

/// Writes 3.1 private leaf groups (24 bytes, 16 leaves each): the running sums of voxels and
/// of wide voxels, then the sixteen count bytes (zero past the end).
fn write_groups31(groups: &mut [u8], counts: &[u8], v3: &crate::brick::V3Sections) -> Result<()> {
    let (mut voxels, mut wide) = (0u64, 0u64);
    for (group, chunk) in groups.chunks_exact_mut(24).zip(counts.chunks(16)) {
        if voxels > u64::from(v3.counts.private_voxels) {
            break; // narrow_corners refuses the counts
        }
        group[..4].copy_from_slice(&(voxels as u32).to_le_bytes());
        group[4..8].copy_from_slice(&(wide as u32).to_le_bytes());
        group[8..8 + chunk.len()].copy_from_slice(chunk);
        for &c in chunk {
            voxels += u64::from(c & !WIDE_BIT);
            if c & WIDE_BIT != 0 {
                wide += u64::from(c & !WIDE_BIT);
            }
        }
    }
    Ok(())
}

/// Brick records as a stream: the residual offset and first private leaf of each record as the
/// difference from the record before (both running sums, so small and repetitive), then the
/// records transposed byte by byte (byte 0 of every record, then byte 1, …), so that each
/// field's bytes sit together (measured smaller than records in place:
/// `docs/results/format.md`).
fn records_to_stream(records: &[u8]) -> Vec<u8> {
    let n = records.len() / BRICK_RECORD_SIZE;
    let mut deltas = records.to_vec();
    // Last to first, so that each record is taken from the one before while that is intact.
    for i in (1..n).rev() {
        delta_step(&mut deltas, i, u32::wrapping_sub);
    }
    let mut out = vec![0u8; records.len()];
    for (i, record) in deltas.chunks_exact(BRICK_RECORD_SIZE).enumerate() {
        for (j, &b) in record.iter().enumerate() {
            out[j * n + i] = b;
        }
    }
    out
}

/// The inverse of [`records_to_stream`], into `records` (as long as `stream`).
fn stream_to_records(stream: &[u8], records: &mut [u8]) {
    let n = records.len() / BRICK_RECORD_SIZE;
    for (i, record) in records.chunks_exact_mut(BRICK_RECORD_SIZE).enumerate() {
        for (j, b) in record.iter_mut().enumerate() {
            *b = stream[j * n + i];
        }
    }
    // First to last, so that each record is added to the one before once that is restored.
    for i in 1..n {
        delta_step(records, i, u32::wrapping_add);
    }
}

/// One step of the records' delta coding: record `i`'s residual offset and first private leaf
/// become `op` of themselves and record `i - 1`'s (`wrapping_sub` to code, `wrapping_add` to
/// decode); the rest of the record stays.
fn delta_step(records: &mut [u8], i: usize, op: fn(u32, u32) -> u32) {
    let (before, here) = records.split_at_mut(i * BRICK_RECORD_SIZE);
    let prev = &before[(i - 1) * BRICK_RECORD_SIZE..];
    let (p_res, p_first) = (u32_at(prev, RESIDUALS), u32_at(prev, FIRST_PRIVATE_LEAF));
    let (res, first) = (u32_at(here, RESIDUALS), u32_at(here, FIRST_PRIVATE_LEAF));
    let offset = op(res & RESIDUAL_OFFSET_MASK, p_res & RESIDUAL_OFFSET_MASK);
    put_u32(
        here,
        RESIDUALS,
        res & !RESIDUAL_OFFSET_MASK | offset & RESIDUAL_OFFSET_MASK,
    );
    put_u32(here, FIRST_PRIVATE_LEAF, op(first, p_first));
}

/// Private voxels' codes (eight per voxel) to residuals, in place: corner `o > 0` minus corner
/// [`OWN_CORNER`]`[o]` of the same voxel (its neighbour along one axis), corner 0 minus the
/// previous voxel's corner 0. Backwards, so every prediction reads an original code.
fn predict_voxels<T: Code>(codes: &mut [T]) {
    let voxels = codes.len() / 8;
    for v in (0..voxels).rev() {
        let at = v * 8;
        for o in (1..8).rev() {
            codes[at + o] = codes[at + o].sub(codes[at + OWN_CORNER[o]]);
        }
        if v > 0 {
            codes[at] = codes[at].sub(codes[at - 8]);
        }
    }
}

/// The inverse of [`predict_voxels`], in place, forwards.
fn unpredict_voxels<T: Code>(codes: &mut [T]) {
    let voxels = codes.len() / 8;
    for v in 0..voxels {
        let at = v * 8;
        if v > 0 {
            codes[at] = codes[at].add(codes[at - 8]);
        }
        for o in 1..8 {
            codes[at + o] = codes[at + o].add(codes[at + OWN_CORNER[o]]);
        }
    }
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes_at(b, at))
}

fn put_u32(b: &mut [u8], at: usize, value: u32) {
    b[at..at + 4].copy_from_slice(&value.to_le_bytes());
}

fn value_bits(bits: u8) -> Result<ValueBits> {
    match bits {
        8 => Ok(ValueBits::Eight),
        16 => Ok(ValueBits::Sixteen),
        other => Err(FormatError::corrupt(
            "value_bits",
            format!("{other} (must be 8 or 16)"),
        )),
    }
}

fn section(file: &[u8], (offset, size): (u64, u64)) -> &[u8] {
    &file[offset as usize..(offset + size) as usize]
}

fn section_mut(file: &mut [u8], (offset, size): (u64, u64)) -> &mut [u8] {
    &mut file[offset as usize..(offset + size) as usize]
}

/// The first `n` of the eight bytes after each 12-byte group's `u32` (masks or counts).
fn group_bytes(groups: &[u8], n: u32) -> Vec<u8> {
    let mut out: Vec<u8> = groups
        .chunks_exact(12)
        .flat_map(|g| g[4..].iter().copied())
        .collect();
    out.truncate(n as usize);
    out
}

/// Writes 12-byte groups: the running sum (`base` plus `weight` of every earlier byte) as a
/// `u32`, then eight bytes (zero past the end).
fn write_groups(
    groups: &mut [u8],
    bytes: &[u8],
    weight: impl Fn(u8) -> u64,
    base: u64,
) -> Result<()> {
    let mut sum = base;
    for (group, chunk) in groups.chunks_exact_mut(12).zip(bytes.chunks(8)) {
        let value = u32::try_from(sum).map_err(|_| {
            FormatError::corrupt("compressed", format!("a group index {sum} over 32 bits"))
        })?;
        group[..4].copy_from_slice(&value.to_le_bytes());
        group[4..4 + chunk.len()].copy_from_slice(chunk);
        sum += chunk.iter().map(|&b| weight(b)).sum::<u64>();
    }
    Ok(())
}

/// The leaves of an octree as the corner predictor sees them: each leaf's first voxel and its
/// neighbour leaf along −x, −y and −z (or [`NONE`]), from the masks and counts alone.
struct LeafTree {
    /// Per leaf: first voxel index, then the −x, −y, −z neighbour leaves.
    leaves: Vec<[u32; 4]>,
    /// Voxels in all leaves.
    voxels: usize,
}

impl LeafTree {
    /// Walks the breadth-first masks level by level (the leaves come out in Morton order, so a
    /// lower neighbour always comes before its leaf).
    fn walk(depth: u8, masks: &[u8], counts: &[u8], voxel_count: u32) -> Result<LeafTree> {
        let bad = |reason: String| FormatError::corrupt("compressed masks stream", reason);
        let leaf_count = counts.len();
        // A leaf without voxels would make a neighbour's first voxel this leaf's own, which the
        // residuals must never read before it is decoded (the format forbids it anyway).
        if let Some(j) = counts.iter().position(|&c| c == 0) {
            return Err(FormatError::corrupt(
                "compressed counts stream",
                format!("leaf {j} has no voxel (counts are 1..=255)"),
            ));
        }
        let voxels: u64 = counts.iter().map(|&c| u64::from(c)).sum();
        if voxels != u64::from(voxel_count) {
            return Err(FormatError::corrupt(
                "compressed counts stream",
                format!("{voxels} voxels, the header declares {voxel_count}"),
            ));
        }
        if leaf_count == 0 {
            return if masks.is_empty() {
                Ok(LeafTree {
                    leaves: Vec::new(),
                    voxels: 0,
                })
            } else {
                Err(bad(format!("{} inner nodes and no leaf", masks.len())))
            };
        }
        // Level by level, each node's lower neighbours along x, y and z at its own level (or
        // NONE): a child's neighbour along an axis is its sibling when its octant has that
        // axis's bit, else the matching child of its parent's neighbour. No coordinates, no
        // lookups: O(1) per node (with a hash of Morton codes the walk was most of a
        // perf profile of decoding).
        let mut around: Vec<[u32; 3]> = vec![[NONE; 3]];
        let mut used = 0usize;
        // Each node of a level as (first child at the next level) << 8 | mask.
        let mut nodes: Vec<u64> = Vec::new();
        for l in 0..depth {
            let end = used + around.len();
            if end > masks.len() {
                return Err(bad(format!(
                    "level {l} needs {end} inner nodes, the stream has {}",
                    masks.len()
                )));
            }
            let level = &masks[used..end];
            nodes.clear();
            let mut children = 0u64;
            for &m in level {
                nodes.push(children << 8 | u64::from(m));
                children += u64::from(m.count_ones());
            }
            if children > (leaf_count + masks.len()) as u64 {
                return Err(bad(format!(
                    "level {} has {children} nodes, more than the file",
                    l + 1
                )));
            }
            // A missing neighbour is node 0 with mask 0: no child, no branch.
            let child = |node: u64, octant: u32| -> u32 {
                let m = node as usize & 0xff;
                if m >> octant & 1 == 1 {
                    (node >> 8) as u32 + u32::from(RANK[m][octant as usize])
                } else {
                    NONE
                }
            };
            let mut below = Vec::with_capacity(children as usize);
            for (&node, nb) in nodes.iter().zip(&around) {
                let beside = nb.map(|n| if n == NONE { 0 } else { nodes[n as usize] });
                let mut bits = node as u32 & 0xff;
                while bits != 0 {
                    let octant = bits.trailing_zeros();
                    bits &= bits - 1;
                    // Along each axis: the sibling when the octant has the axis's bit, else the
                    // child of the neighbour with that bit set (`octant ^ bit` either way).
                    let along = |axis: usize, bit: u32| {
                        child(
                            if octant & bit != 0 {
                                node
                            } else {
                                beside[axis]
                            },
                            octant ^ bit,
                        )
                    };
                    below.push([along(0, 4), along(1, 2), along(2, 1)]);
                }
            }
            used = end;
            around = below;
        }
        if used != masks.len() || around.len() != leaf_count {
            return Err(bad(format!(
                "the masks make {used} inner nodes and {} leaves, the header declares {} and {leaf_count}",
                around.len(),
                masks.len()
            )));
        }
        let mut first = 0u32;
        let leaves = around
            .iter()
            .zip(counts)
            .map(|(nb, &count)| {
                let entry = [first, nb[0], nb[1], nb[2]];
                first += u32::from(count);
                entry
            })
            .collect();
        Ok(LeafTree {
            leaves,
            voxels: voxels as usize,
        })
    }

    /// Where each corner's prediction comes from in a voxel of `leaf`: the prediction of
    /// corner `o = 4x + 2y + z` is, in order: corner `o` with that axis's bit set of the first
    /// voxel of the neighbour leaf along −x (if `x = 0`), −y (if `y = 0`) or −z (if `z = 0`),
    /// the first neighbour that exists (an index into the codes, before this leaf's); else
    /// ([`OWN`]) the voxel's own corner `o` without its highest bit; else (corner 0,
    /// [`ZERO_SOURCE`]) zero.
    #[inline(always)]
    fn sources(&self, leaf: &[u32; 4]) -> [usize; 8] {
        let mut source = [ZERO_SOURCE; 8];
        for (o, src) in source.iter_mut().enumerate() {
            *src = if o & 4 == 0 && leaf[1] != NONE {
                self.leaves[leaf[1] as usize][0] as usize * 8 + (o | 4)
            } else if o & 2 == 0 && leaf[2] != NONE {
                self.leaves[leaf[2] as usize][0] as usize * 8 + (o | 2)
            } else if o & 1 == 0 && leaf[3] != NONE {
                self.leaves[leaf[3] as usize][0] as usize * 8 + (o | 1)
            } else if o == 0 {
                ZERO_SOURCE
            } else {
                OWN
            };
        }
        source
    }

    /// The voxel range `[first, end)` of leaf `j`.
    #[inline(always)]
    fn voxel_range(&self, j: usize) -> (usize, usize) {
        let end = self.leaves.get(j + 1).map_or(self.voxels as u32, |l| l[0]);
        (self.leaves[j][0] as usize, end as usize)
    }

    /// Codes to residuals: each corner minus its prediction ([`LeafTree::sources`]), wrapping
    /// (`u8` and `u16` wrap as the `i8` and `i16` codes do).
    fn encode<T: Code>(&self, codes: &[T], residuals: &mut [T]) {
        debug_assert_eq!(codes.len(), self.voxels * 8);
        for (j, leaf) in self.leaves.iter().enumerate() {
            let source = self.sources(leaf);
            let (first, end) = self.voxel_range(j);
            for at in (first * 8..end * 8).step_by(8) {
                let here: &[T; 8] = codes[at..at + 8].try_into().expect("8 codes");
                let before = &codes[..at];
                for o in 0..8 {
                    let p = match source[o] {
                        ZERO_SOURCE => T::ZERO,
                        OWN => here[OWN_CORNER[o]],
                        from => before[from],
                    };
                    residuals[at + o] = here[o].sub(p);
                }
            }
        }
    }

    /// Residuals to codes, in place: voxel by voxel in file order, so every prediction reads a
    /// code already decoded (a neighbour's, or an earlier corner of the same voxel).
    fn decode<T: Code>(&self, values: &mut [T]) {
        debug_assert_eq!(values.len(), self.voxels * 8);
        for (j, leaf) in self.leaves.iter().enumerate() {
            let source = self.sources(leaf);
            let (first, end) = self.voxel_range(j);
            for at in (first * 8..end * 8).step_by(8) {
                let (before, rest) = values.split_at_mut(at);
                let out: &mut [T; 8] = (&mut rest[..8]).try_into().expect("8 codes");
                for o in 0..8 {
                    let p = match source[o] {
                        ZERO_SOURCE => T::ZERO,
                        OWN => out[OWN_CORNER[o]],
                        from => before[from],
                    };
                    out[o] = out[o].add(p);
                }
            }
        }
    }
}

/// [`LeafTree::sources`]' source of a corner with no prediction (corner 0, no neighbour).
const ZERO_SOURCE: usize = usize::MAX;
/// [`LeafTree::sources`]' source of a corner predicted by an earlier corner of its voxel.
const OWN: usize = usize::MAX - 1;

/// The corner of the same voxel that predicts corner `o` when no neighbour does: `o` without
/// its highest bit (corner 0 has none: [`ZERO_SOURCE`]).
const OWN_CORNER: [usize; 8] = [0, 0, 0, 1, 0, 1, 2, 3];

/// `RANK[m][o]`: the set bits of mask `m` below bit `o` (a child's offset among its siblings),
/// a table because the portable build has no `popcnt` instruction (measured: the software
/// popcount was a third of the tree walk's instructions).
const RANK: [[u8; 8]; 256] = {
    let mut table = [[0u8; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let mut o = 0;
        while o < 8 {
            table[m][o] = (m as u32 & ((1u32 << o) - 1)).count_ones() as u8;
            o += 1;
        }
        m += 1;
    }
    table
};

/// A corner code as unsigned bits (8 or 16), whose wrapping arithmetic is the signed codes'.
trait Code: Copy {
    const ZERO: Self;
    fn add(self, other: Self) -> Self;
    fn sub(self, other: Self) -> Self;
}

macro_rules! code_impl {
    ($($t:ty),*) => {$(
        impl Code for $t {
            const ZERO: $t = 0;
            fn add(self, other: $t) -> $t {
                self.wrapping_add(other)
            }
            fn sub(self, other: $t) -> $t {
                self.wrapping_sub(other)
            }
        }
    )*};
}
code_impl!(u8, u16);

/// Little-endian 16-bit codes as numbers.
fn words(bytes: &[u8]) -> Vec<u16> {
    bytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect()
}

/// Numbers back to little-endian bytes.
fn put_words(words: &[u16], bytes: &mut [u8]) {
    for (w, b) in words.iter().zip(bytes.chunks_exact_mut(2)) {
        b.copy_from_slice(&w.to_le_bytes());
    }
}

fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes(bytes_at(b, at))
}

fn bytes_at<const N: usize>(b: &[u8], at: usize) -> [u8; N] {
    b[at..at + N].try_into().expect("N bytes")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_leaf_without_voxels_is_refused_before_any_residual_is_read() {
        // Depth 1, leaves in octants 0 and 4: the second's −x neighbour is the first.
        let err = LeafTree::walk(1, &[0b0001_0001], &[0, 1], 1)
            .err()
            .expect("refused");
        assert!(err.to_string().contains("leaf 0 has no voxel"), "{err}");
        assert!(LeafTree::walk(1, &[0b0001_0001], &[1, 1], 2).is_ok());
    }
}
