// sdfmo.wgsl: ray tracing a packed SDF multi-octree (`.smo` 1.x, or 3.0 bricks) in WGSL.
//
// A port of `sdfmo-trace` (traversal.rs, ray_voxel.rs, normal.rs) with the same hit rules:
// front-to-back traversal, first leaf with a hit; in a leaf every voxel is tested and the
// nearest hit inside the leaf's [t_enter, t_exit] is kept; volume voxels are hit at the first
// point inside (f < 0, the segment start when it starts inside), surface voxels at the first
// zero crossing from either side; in a leaf with clip voxels (format 1.1, flag CLIP_VOXELS) a
// hit counts only where every other clip voxel of the leaf is ≤ 0 (sdfmo-trace clip.rs; the
// clip rule of FORMAT.md; at most SMO_MAX_CLIP_VOXELS clip voxels per leaf); a voxel whose
// corners are all 0 is never hit (FORMAT.md, surface section); the normal is the
// interpolant's unit gradient facing the viewer. Include this library in your own pipeline
// (WGSL has no #include: put `sdfmo_gpu::trace_wgsl()`, this file after its generated
// constants, before your source) and call `smo_info`, `smo_intersect` and `smo_hit_normal`;
// for a file with levels of detail (`.smo` 2.0, bound as saved), `smo_lod` and
// `smo_intersect_lod` (each ray at the level its screen-space error needs, as
// sdfmo_trace::intersect_lod), then `smo_hit_normal` over `smo_lod_level_info` of the hit's
// level. A 3.0 brick file (FORMAT.md, "Bricks (version 3.0)") is bound and traced as it is:
// `smo_info` tells it by its major version (see "Bricks" below).
//
// BINDING LAYOUT (one binding; change the group/binding numbers on the next line if your
// pipeline needs that slot):
//
//     @group(0) @binding(0) var<storage, read> smo: array<u32>;
//
//   The whole `.smo` file exactly as saved (header, sections, padding, checksum: FORMAT.md in
//   sdfmo-format), uploaded unchanged as a storage buffer read as little-endian u32 words. A
//   file's length is always a multiple of 4 and every section starts at a multiple of 8 bytes,
//   so every field below is word-aligned. The file must have been validated on the host first
//   (`PackedOctreeView::new`): the kernel trusts every count and index.
//
// What the kernel reads, in words of the file (the SMO_HEADER_* word indices are generated
// from sdfmo_format's header tables, HEADER_FIELDS and LOD_HEADER_FIELDS / LOD_LEVEL_FIELDS):
//   header  flags (CLIP_VOXELS: the file has the clip bitmap), depth and value_bits,
//           inner_node_count I, leaf_count L, voxel_count V, the byte offsets of the nodes,
//           leaves, surface and corners sections, corners_size (the clip bitmap starts at
//           corners_offset + corners_size)
//   (a file with levels, 2.0: its header's depth and coarsest level, and the low word of each
//   level's 64-bit offset in the level table; each level is read as above at its own offset,
//   see "Levels of detail" at the end of this file)
//   (the low words of the header's 64-bit offsets and size: exact only for a file shorter than
//   4 GiB. The host refuses a longer one before uploading it, sdfmo_gpu::MAX_GPU_FILE_BYTES;
//   an engine binding the file itself must do the same.)
//   nodes    3 words per group of 8 inner nodes: first_child, masks of nodes 8g..8g+3 (one byte
//            each), masks of nodes 8g+4..8g+7
//   leaves   3 words per group of 8 leaves: first_voxel, counts of leaves 8g..8g+3, 8g+4..8g+7
//   surface  bit v % 32 of word v / 32: voxel v is a surface voxel
//   clip     (only with flag CLIP_VOXELS) bit v % 32 of word v / 32: voxel v has the clip bit
//            (an intersect voxel if it is a volume voxel, clip-only if a surface voxel)
//   corners  8-bit: 2 words per voxel, corner i in byte i (i8); 16-bit: 4 words, corner i in
//            half i (i16); value = code · dequant, dequant = diagonal / Q, passed in by the host
//            (`sdfmo_format::quant::dequant_scale`, computed in f64 there: WGSL division is not
//            correctly rounded, and the CPU tracer uses that exact factor).
//
// Differences from the CPU kernel: f32 arithmetic here may be contracted into fused
// multiply-adds and WGSL's division and inverseSqrt are not correctly rounded, so results agree
// to a few ulps, not bit for bit (the crate's tests bound the difference). +∞ is written as
// SMO_FAR (WGSL has no infinity literal).

@group(0) @binding(0) var<storage, read> smo: array<u32>;

// CONSTANTS shared with the CPU kernel are not written here: `sdfmo_gpu::trace_wgsl()` puts
// their `const` declarations, generated from the Rust values, before this file (one source:
// `sdfmo_format::kernel` and `sdfmo_format::MAX_CLIP_VOXELS_PER_LEAF` for the kernels, the
// `sdfmo_gpu` crate for SMO_FAR; `sdfmo_gpu::kernel_constants_wgsl()` lists them):
//   SMO_FAR               f32  stands for +∞ (a ray parameter no hit can reach)
//   SMO_MAX_FINITE        f32  largest finite f32
//   SMO_MIN_POSITIVE      f32  smallest normal f32
//   SMO_TINY_DIR          f32  direction components smaller than this are treated as this
//   SMO_MAX_DEPTH         u32  deepest octree a file holds: the traversal stack's levels
//   SMO_MAX_POLISH_STEPS  u32  Newton/bisection steps at most when polishing a root
//   SMO_REL_TOLERANCE     f32  root tolerance as a fraction of the segment
//   SMO_CLIP_TOLERANCE    f32  slack of the clip test at a polished root, relative to the clip
//                              voxel's largest |corner|; none at the span start
//   SMO_MAX_CLIP_VOXELS   u32  most clip voxels in one leaf (host validation refuses more): the
//                              clip test of a candidate reads at most this many voxels

/// Counts and section offsets (in words) of the bound octree.
struct SmoInfo {
    depth: u32,
    value_bits: u32,
    inner_count: u32,
    leaf_count: u32,
    voxel_count: u32,
    nodes: u32,
    leaves: u32,
    surface: u32,
    corners: u32,
    /// Word offset of the clip bitmap, 0 when the file has no clip voxels.
    clip: u32,
    dequant: f32,
    /// A 3.0 brick file (see "Bricks" below): then `inner_count` counts the nodes above the
    /// bricks, `voxel_count` the private voxels, `leaves`, `surface` (= `clip`, when it has clip
    /// voxels) and `corners` are its private leaves, flags and corners, and these are set:
    v3: bool,
    /// Word offset of the brick records, their count, and the level of the bricks (depth − 2).
    bricks: u32,
    brick_count: u32,
    brick_level: u32,
    /// Byte offset of the residuals section.
    residuals: u32,
    /// The 3.x minor version: 1 for narrow private voxels (private leaf groups of 16).
    minor: u32,
}

/// A ray `origin + t·dir`, `dir` of unit length.
struct SmoRay {
    origin: vec3<f32>,
    dir: vec3<f32>,
}

/// The first hit: ray parameter, voxel index, the leaf cell (minimum corner and edge), whether
/// the voxel is a surface voxel. `hit` is false for a miss (the other fields are then 0).
struct SmoHit {
    t: f32,
    voxel: u32,
    /// Where the voxel's codes are (3.x private voxels): its leaf's `smo_leaf_voxels`.
    leaf: vec4<u32>,
    cell_min: vec3<f32>,
    cell_size: f32,
    surface: bool,
    hit: bool,
}

/// A cubic a s³ + b s² + c s + d in the segment parameter s.
struct SmoCubic {
    a: f32,
    b: f32,
    c: f32,
    d: f32,
}

struct SmoCell {
    node: u32,
    min: vec3<f32>,
    size: f32,
    t_enter: f32,
    t_exit: f32,
}

/// Reads the header of the bound file. `dequant` = diagonal / Q (see the top of the file).
fn smo_info(dequant: f32) -> SmoInfo {
    return smo_info_at(0u, dequant);
}

/// Reads the header of the 1.x octree that starts at word `base` of the bound buffer (0 for a
/// 1.x or 3.0 file; a level of a 2.0 file, `smo_lod_level_info`): its section offsets,
/// relative to its own start, become word offsets in the buffer. A 3.0 file is read by
/// `smo_v3_info`.
fn smo_info_at(base: u32, dequant: f32) -> SmoInfo {
    let major = (smo[base + SMO_HEADER_VERSION_MAJOR] >> SMO_HEADER_VERSION_MAJOR_SHIFT) & 0xffffu;
    if major == SMO_V3_MAJOR {
        return smo_v3_info(dequant);
    }
    var info: SmoInfo;
    info.v3 = false;
    info.depth = (smo[base + SMO_HEADER_DEPTH] >> SMO_HEADER_DEPTH_SHIFT) & 0xffu;
    info.value_bits = (smo[base + SMO_HEADER_VALUE_BITS] >> SMO_HEADER_VALUE_BITS_SHIFT) & 0xffu;
    info.inner_count = smo[base + SMO_HEADER_INNER_COUNT];
    info.leaf_count = smo[base + SMO_HEADER_LEAF_COUNT];
    info.voxel_count = smo[base + SMO_HEADER_VOXEL_COUNT];
    info.nodes = base + (smo[base + SMO_HEADER_NODES_OFFSET] >> 2u);
    info.leaves = base + (smo[base + SMO_HEADER_LEAVES_OFFSET] >> 2u);
    info.surface = base + (smo[base + SMO_HEADER_SURFACE_OFFSET] >> 2u);
    let corners = smo[base + SMO_HEADER_CORNERS_OFFSET];
    info.corners = base + (corners >> 2u);
    info.clip = 0u;
    if (smo[base + SMO_HEADER_FLAGS] & SMO_FLAG_CLIP_VOXELS) != 0u {
        info.clip = base + ((corners + smo[base + SMO_HEADER_CORNERS_SIZE]) >> 2u);
    }
    info.dequant = dequant;
    return info;
}

// ---- Octree access (FORMAT.md: node groups, leaf groups, surface bitmap, corners) ----

/// Set bits among the low `bits` (0..=63) bits of the u64 `hi:lo`.
fn smo_popcount_low(lo: u32, hi: u32, bits: u32) -> u32 {
    if bits < 32u {
        return countOneBits(lo & ((1u << bits) - 1u));
    }
    return countOneBits(lo) + countOneBits(hi & ((1u << (bits - 32u)) - 1u));
}

/// Byte `k` (0..8) of the u64 `hi:lo`.
fn smo_byte(lo: u32, hi: u32, k: u32) -> u32 {
    let w = select(lo, hi, k >= 4u);
    return (w >> ((k & 3u) * 8u)) & 0xffu;
}

/// Child mask of a node (bit 4x + 2y + z); 0 for a leaf.
fn smo_child_mask(info: SmoInfo, node: u32) -> u32 {
    if node >= info.inner_count {
        return 0u;
    }
    let at = info.nodes + (node >> 3u) * 3u;
    return smo_byte(smo[at + 1u], smo[at + 2u], node & 7u);
}

/// Index of an inner node's first child.
fn smo_first_child(info: SmoInfo, node: u32) -> u32 {
    let at = info.nodes + (node >> 3u) * 3u;
    return smo[at] + smo_popcount_low(smo[at + 1u], smo[at + 2u], (node & 7u) * 8u);
}

/// A leaf's voxels: (first voxel, count, wide voxels before the first, 1 when they are wide).
/// In a 3.x file, `smo_v3_leaf_voxels`; elsewhere every voxel is wide (3.0's rule: the wide
/// voxels before voxel v are v).
fn smo_leaf_voxels(info: SmoInfo, node: u32) -> vec4<u32> {
    if info.v3 {
        return smo_v3_leaf_voxels(info, node);
    }
    let r = smo_leaf_group_voxels(info, node - info.inner_count);
    return vec4<u32>(r.x, r.y, r.x, 1u);
}

/// Leaf `j`'s voxels in the leaf groups at `info.leaves` (1.x leaves, 3.0 private leaves).
fn smo_leaf_group_voxels(info: SmoInfo, j: u32) -> vec2<u32> {
    let at = info.leaves + (j >> 3u) * 3u;
    let lo = smo[at + 1u];
    let hi = smo[at + 2u];
    let slot = j & 7u;
    var start = smo[at];
    for (var k = 0u; k < slot; k++) {
        start += smo_byte(lo, hi, k);
    }
    return vec2<u32>(start, smo_byte(lo, hi, slot));
}

/// The voxel's dequantised corners (corner order 4x + 2y + z), normalised units; `leaf` is the
/// `smo_leaf_voxels` of its leaf (where a 3.x private voxel's codes are).
fn smo_voxel_corners(info: SmoInfo, voxel: u32, leaf: vec4<u32>) -> array<f32, 8> {
    if info.v3 && (voxel & SMO_SHARED_VOXEL) != 0u {
        return smo_v3_shared_corners(info, voxel & ~SMO_SHARED_VOXEL);
    }
    if info.v3 {
        return smo_v3_private_corners(info, voxel, leaf);
    }
    var c: array<f32, 8>;
    if info.value_bits == 8u {
        let at = info.corners + voxel * 2u;
        for (var i = 0u; i < 8u; i++) {
            let w = bitcast<i32>(smo[at + (i >> 2u)]);
            c[i] = f32(extractBits(w, (i & 3u) * 8u, 8u)) * info.dequant;
        }
    } else {
        let at = info.corners + voxel * 4u;
        for (var i = 0u; i < 8u; i++) {
            let w = bitcast<i32>(smo[at + (i >> 1u)]);
            c[i] = f32(extractBits(w, (i & 1u) * 16u, 16u)) * info.dequant;
        }
    }
    return c;
}

/// Whether the voxel is a surface (thin) voxel.
fn smo_voxel_is_surface(info: SmoInfo, voxel: u32) -> bool {
    if info.v3 {
        return (smo_v3_voxel_flags(info, voxel) & 1u) != 0u;
    }
    return ((smo[info.surface + (voxel >> 5u)] >> (voxel & 31u)) & 1u) != 0u;
}

/// Whether the voxel has the clip bit (always false in a file without clip voxels).
fn smo_voxel_is_clip(info: SmoInfo, voxel: u32) -> bool {
    if info.clip == 0u {
        return false;
    }
    if info.v3 {
        return (smo_v3_voxel_flags(info, voxel) & 2u) != 0u;
    }
    return ((smo[info.clip + (voxel >> 5u)] >> (voxel & 31u)) & 1u) != 0u;
}

/// Whether any voxel of [first, first + count) has the clip bit (sdfmo_format's
/// any_clip_voxel): the leaf then takes the clip rule.
fn smo_any_clip(info: SmoInfo, first: u32, count: u32) -> bool {
    if info.clip == 0u {
        return false;
    }
    for (var v = first; v < first + count; v++) {
        if smo_voxel_is_clip(info, v) {
            return true;
        }
    }
    return false;
}

// ---- Bricks (.smo 3.0; sdfmo-format brick.rs, FORMAT.md "Bricks (version 3.0)") ----
//
// A 3.0 file bound as it is (decompressed first when it was compressed): node groups above the
// bricks (levels 0 … depth − 3, as 1.x's), one 32-byte record per brick (the node at level
// depth − 2, 4³ leaf cells: occupancy, private mask, plane, residual word, first private leaf),
// the residuals, and the private leaves, flags (two bits per voxel: surface, clip) and corners
// (as 1.x's leaf groups and corners). The walk is `smo_intersect`'s, the same cells in the same
// order with the same spans; only the nodes' children and voxels are found differently:
//   level < depth − 2   node = breadth-first index k of the upper tree (a brick from k ≥
//                       inner_count on: brick k − inner_count), children as in 1.x
//   level = depth − 2   node = inner_count + brick (the root at depth 2: node 0 = brick 0);
//                       child mask: the occupancy bytes that are non-zero
//   level = depth − 1   node = brick · 8 + octant; child mask: occupancy byte `octant`
//   level = depth       node = brick · 64 + cell (the cell's Morton index in its brick), a leaf
// A shared leaf's one voxel is SMO_SHARED_VOXEL | its leaf node (the host refuses a file with
// more bricks than that leaves room for); a private voxel is its index in the private sections.
// Header and record fields are read at the SMO_V3_HEADER_* and SMO_BRICK_* words generated from
// sdfmo_format's V3_HEADER_FIELDS and BRICK_RECORD_FIELDS.

/// Reads the header of the bound 3.0 file (it starts at word 0).
fn smo_v3_info(dequant: f32) -> SmoInfo {
    var info: SmoInfo;
    info.v3 = true;
    info.depth = (smo[SMO_V3_HEADER_DEPTH] >> SMO_V3_HEADER_DEPTH_SHIFT) & 0xffu;
    info.value_bits = (smo[SMO_V3_HEADER_VALUE_BITS] >> SMO_V3_HEADER_VALUE_BITS_SHIFT) & 0xffu;
    info.inner_count = smo[SMO_V3_HEADER_UPPER_COUNT];
    info.leaf_count = smo[SMO_V3_HEADER_LEAF_COUNT];
    info.voxel_count = smo[SMO_V3_HEADER_PRIVATE_VOXEL_COUNT];
    info.nodes = smo[SMO_V3_HEADER_NODES_OFFSET] >> 2u;
    info.leaves = smo[SMO_V3_HEADER_PRIVATE_LEAVES_OFFSET] >> 2u;
    info.surface = smo[SMO_V3_HEADER_PRIVATE_FLAGS_OFFSET] >> 2u;
    info.corners = smo[SMO_V3_HEADER_PRIVATE_CORNERS_OFFSET] >> 2u;
    info.clip = 0u;
    if (smo[SMO_V3_HEADER_FLAGS] & SMO_FLAG_CLIP_VOXELS) != 0u {
        info.clip = info.surface;
    }
    info.dequant = dequant;
    info.bricks = smo[SMO_V3_HEADER_BRICKS_OFFSET] >> 2u;
    info.brick_count = smo[SMO_V3_HEADER_BRICK_COUNT];
    info.brick_level = info.depth - SMO_BRICK_LEVELS;
    info.residuals = smo[SMO_V3_HEADER_RESIDUALS_OFFSET];
    info.minor = (smo[SMO_V3_HEADER_VERSION_MINOR] >> SMO_V3_HEADER_VERSION_MINOR_SHIFT) & 0xffffu;
    return info;
}

/// Whether the node at `level` is a leaf.
fn smo_is_leaf(info: SmoInfo, node: u32, level: u32) -> bool {
    if info.v3 {
        return level == info.depth;
    }
    return node >= info.inner_count;
}

/// Word `k` of brick `b`'s record.
fn smo_brick_word(info: SmoInfo, b: u32, k: u32) -> u32 {
    return smo[info.bricks + b * SMO_BRICK_WORDS + k];
}

/// The bits of the 4 bytes of `w` that are non-zero (bit k: byte k).
fn smo_nonzero_bytes(w: u32) -> u32 {
    var x = w | (w >> 4u);
    x = x | (x >> 2u);
    x = (x | (x >> 1u)) & 0x01010101u;
    return (x | (x >> 7u) | (x >> 14u) | (x >> 21u)) & 0xfu;
}

/// Child mask of the node at `level` (bit 4x + 2y + z); 0 for a leaf.
fn smo_node_mask(info: SmoInfo, node: u32, level: u32) -> u32 {
    if !info.v3 || level < info.brick_level {
        return smo_child_mask(info, node);
    }
    if level == info.brick_level {
        let b = node - info.inner_count;
        let lo = smo_brick_word(info, b, SMO_BRICK_OCCUPANCY);
        let hi = smo_brick_word(info, b, SMO_BRICK_OCCUPANCY + 1u);
        return smo_nonzero_bytes(lo) | (smo_nonzero_bytes(hi) << 4u);
    }
    if level < info.depth {
        let b = node >> 3u;
        let lo = smo_brick_word(info, b, SMO_BRICK_OCCUPANCY);
        let hi = smo_brick_word(info, b, SMO_BRICK_OCCUPANCY + 1u);
        return smo_byte(lo, hi, node & 7u);
    }
    return 0u;
}

/// The child in octant `oct` (present in `mask`, the node's child mask) of the node at `level`.
fn smo_node_child(info: SmoInfo, node: u32, level: u32, mask: u32, oct: u32) -> u32 {
    if !info.v3 || level < info.brick_level {
        return smo_first_child(info, node) + countOneBits(mask & ((1u << oct) - 1u));
    }
    if level == info.brick_level {
        return ((node - info.inner_count) << 3u) | oct;
    }
    return (node << 3u) | oct;
}

/// A 3.0 leaf's voxels: (first voxel, count); a shared leaf's one voxel is
/// SMO_SHARED_VOXEL | leaf.
fn smo_v3_leaf_voxels(info: SmoInfo, leaf: u32) -> vec4<u32> {
    let b = leaf >> 6u;
    let cell = leaf & 63u;
    let lo = smo_brick_word(info, b, SMO_BRICK_PRIVATE);
    let hi = smo_brick_word(info, b, SMO_BRICK_PRIVATE + 1u);
    if ((select(lo, hi, cell >= 32u) >> (cell & 31u)) & 1u) == 0u {
        return vec4<u32>(SMO_SHARED_VOXEL | leaf, 1u, 0u, 1u);
    }
    let j = smo_brick_word(info, b, SMO_BRICK_FIRST_PRIVATE_LEAF) + smo_popcount_low(lo, hi, cell);
    if info.minor == 0u {
        let r = smo_leaf_group_voxels(info, j);
        return vec4<u32>(r.x, r.y, r.x, 1u);
    }
    return smo_v31_leaf_voxels(info, j);
}

/// Private leaf `j` of a 3.1 file (FORMAT.md "Narrow private voxels (version 3.1)"): groups of
/// 16 leaves in 6 words (first voxel, wide voxels before, 16 count bytes: bits 0–6 the count,
/// bit 7 wide). (first voxel, count, wide voxels before it, 1 when wide).
fn smo_v31_leaf_voxels(info: SmoInfo, j: u32) -> vec4<u32> {
    let at = info.leaves + (j >> 4u) * 6u;
    let slot = j & 15u;
    var start = smo[at];
    var wide = smo[at + 1u];
    for (var k = 0u; k < slot; k++) {
        let byte = (smo[at + 2u + (k >> 2u)] >> ((k & 3u) * 8u)) & 0xffu;
        start += byte & 0x7fu;
        wide += select(0u, byte & 0x7fu, byte >= 0x80u);
    }
    let byte = (smo[at + 2u + (slot >> 2u)] >> ((slot & 3u) * 8u)) & 0xffu;
    return vec4<u32>(start, byte & 0x7fu, wide, byte >> 7u);
}

/// The eight codes of a 3.x private voxel of the leaf `leaf` (`smo_leaf_voxels`), dequantised:
/// at byte 2·b·(3·voxel + wide voxels before it) of the private corners, whole (wide) or
/// narrow (four base codes, four mixed differences in half-width fields).
fn smo_v3_private_corners(info: SmoInfo, voxel: u32, leaf: vec4<u32>) -> array<f32, 8> {
    let wide = leaf.w != 0u;
    let before = leaf.z + select(0u, voxel - leaf.x, wide);
    let b = info.value_bits / 8u;
    let a = info.corners * 4u + 2u * b * (3u * voxel + before);
    var k: array<i32, 8>;
    if b == 1u {
        if wide {
            for (var i = 0u; i < 8u; i++) {
                k[i] = bitcast<i32>(smo_byte_at(a + i) << 24u) >> 24u;
            }
        } else {
            var base: array<i32, 4>;
            for (var i = 0u; i < 4u; i++) {
                base[i] = bitcast<i32>(smo_byte_at(a + i) << 24u) >> 24u;
            }
            let n = smo_byte_at(a + 4u) | (smo_byte_at(a + 5u) << 8u);
            let d = vec4<i32>(
                bitcast<i32>(n << 28u) >> 28u,
                bitcast<i32>(n << 24u) >> 28u,
                bitcast<i32>(n << 20u) >> 28u,
                bitcast<i32>(n << 16u) >> 28u,
            );
            k = smo_narrow_codes(base, d);
        }
    } else {
        let w = a >> 2u;
        if wide {
            for (var i = 0u; i < 8u; i++) {
                k[i] = extractBits(bitcast<i32>(smo[w + (i >> 1u)]), (i & 1u) * 16u, 16u);
            }
        } else {
            let w0 = bitcast<i32>(smo[w]);
            let w1 = bitcast<i32>(smo[w + 1u]);
            let w2 = bitcast<i32>(smo[w + 2u]);
            let base = array<i32, 4>(
                extractBits(w0, 0u, 16u), extractBits(w0, 16u, 16u),
                extractBits(w1, 0u, 16u), extractBits(w1, 16u, 16u),
            );
            let d = vec4<i32>(extractBits(w2, 0u, 8u), extractBits(w2, 8u, 8u),
                              extractBits(w2, 16u, 8u), extractBits(w2, 24u, 8u));
            k = smo_narrow_codes(base, d);
        }
    }
    var c: array<f32, 8>;
    for (var i = 0u; i < 8u; i++) {
        c[i] = f32(k[i]) * info.dequant;
    }
    return c;
}

/// A narrow voxel's eight codes from its base codes c000 c001 c010 c100 and its mixed
/// differences (xy, xz, yz, xyz).
fn smo_narrow_codes(base: array<i32, 4>, d: vec4<i32>) -> array<i32, 8> {
    let c000 = base[0];
    let c001 = base[1];
    let c010 = base[2];
    let c100 = base[3];
    let c011 = c010 + c001 - c000 + d.z;
    let c101 = c100 + c001 - c000 + d.y;
    let c110 = c100 + c010 - c000 + d.x;
    let c111 = c110 + c101 + c011 - c100 - c010 - c001 + c000 + d.w;
    return array<i32, 8>(c000, c001, c010, c011, c100, c101, c110, c111);
}

/// The two flag bits of a 3.0 voxel (bit 0 surface, bit 1 clip); 0 for a shared voxel.
fn smo_v3_voxel_flags(info: SmoInfo, voxel: u32) -> u32 {
    if (voxel & SMO_SHARED_VOXEL) != 0u {
        return 0u;
    }
    return (smo[info.surface + (voxel >> 4u)] >> ((voxel & 15u) * 2u)) & 3u;
}

/// Whether `voxel` names a voxel of the bound file.
fn smo_voxel_exists(info: SmoInfo, voxel: u32) -> bool {
    if info.v3 && (voxel & SMO_SHARED_VOXEL) != 0u {
        return ((voxel & ~SMO_SHARED_VOXEL) >> 6u) < info.brick_count;
    }
    return voxel < info.voxel_count;
}

/// The 128-bit `v` (word i: bits 32i … 32i + 31) shifted left by `n` (0..128) bits.
fn smo_shl128(v: vec4<u32>, n: u32) -> vec4<u32> {
    let ws = n >> 5u;
    let bs = n & 31u;
    var out = vec4<u32>(0u);
    for (var i = ws; i < 4u; i++) {
        let j = i - ws;
        var w = v[j] << bs;
        if bs != 0u && j > 0u {
            w = w | (v[j - 1u] >> (32u - bs));
        }
        out[i] = w;
    }
    return out;
}

/// Grid index (25x + 5y + z) of the lowest corner of brick cell `cell` (Morton index: the
/// half-brick octant in bits 3–5, the octant in it in bits 0–2): sdfmo_format::cell_grid_index.
fn smo_cell_grid_index(cell: u32) -> u32 {
    let hi = cell >> 3u;
    let lo = cell & 7u;
    let x = ((hi >> 2u) & 1u) * 2u + ((lo >> 2u) & 1u);
    let y = ((hi >> 1u) & 1u) * 2u + ((lo >> 1u) & 1u);
    let z = (hi & 1u) * 2u + (lo & 1u);
    return (x * SMO_BRICK_POINT_EDGE + y) * SMO_BRICK_POINT_EDGE + z;
}

/// The points of a brick whose shared cells are `lo:hi` (sdfmo_format::point_mask): the cells
/// placed in the 5³ grid and dilated by one along +x, +y and +z, in four words.
fn smo_point_mask(lo: u32, hi: u32) -> vec4<u32> {
    var cells = vec4<u32>(0u);
    for (var half = 0u; half < 8u; half++) {
        let m = smo_byte(lo, hi, half);
        // The eight cells of a half-brick sit at the corner offsets of its lowest cell.
        let spread = (m & 0x3u) | ((m & 0xcu) << 3u) | ((m & 0x30u) << 21u) | ((m & 0xc0u) << 24u);
        cells = cells | smo_shl128(vec4<u32>(spread, 0u, 0u, 0u), smo_cell_grid_index(half << 3u));
    }
    let e = SMO_BRICK_POINT_EDGE;
    var d = cells | smo_shl128(cells, 1u);
    d = d | smo_shl128(d, e);
    return d | smo_shl128(d, e * e);
}

/// Points of `mask` below grid index `g` (< 128): a point's rank.
fn smo_rank_below(mask: vec4<u32>, g: u32) -> u32 {
    var n = 0u;
    let wi = g >> 5u;
    for (var i = 0u; i < wi; i++) {
        n += countOneBits(mask[i]);
    }
    let bs = g & 31u;
    if bs != 0u {
        n += countOneBits(mask[wi] & ((1u << bs) - 1u));
    }
    return n;
}

/// Byte `at` of the bound buffer.
fn smo_byte_at(at: u32) -> u32 {
    return (smo[at >> 2u] >> ((at & 3u) * 8u)) & 0xffu;
}

/// The `w`-bit residual (0, 2, 4, 8 or 16 bits; fields below 16 bits never straddle a byte) of
/// point `rank` of the residuals starting at byte `start`, sign-extended.
fn smo_residual(start: u32, rank: u32, w: u32) -> i32 {
    if w == 0u {
        return 0;
    }
    if w == 16u {
        let at = start + 2u * rank;
        return extractBits(bitcast<i32>(smo_byte_at(at) | (smo_byte_at(at + 1u) << 8u)), 0u, 16u);
    }
    let bit = rank * w;
    let field = smo_byte_at(start + (bit >> 3u)) >> (bit & 7u);
    return extractBits(bitcast<i32>(field), 0u, w);
}

/// Half `shift / 16` of word `k` of brick `b`'s record, as the i16 it holds.
fn smo_brick_i16(info: SmoInfo, b: u32, k: u32, shift: u32) -> i32 {
    return extractBits(bitcast<i32>(smo_brick_word(info, b, k)), shift, 16u);
}

/// The dequantised corners of the shared leaf `leaf` (brick · 64 + cell), as
/// sdfmo_format's BrickOctree::voxel_codes decodes them, in the same integer arithmetic: each
/// corner is a point of the brick's grid, its rank a popcount of the point mask below it, its
/// code the plane's prediction clamp(floor((a + b·x + c·y + d·z + 2^f / 2) / 2^f), −Q, Q) plus
/// its residual, modulo 2^bits.
fn smo_v3_shared_corners(info: SmoInfo, leaf: u32) -> array<f32, 8> {
    let b = leaf >> 6u;
    let occ_lo = smo_brick_word(info, b, SMO_BRICK_OCCUPANCY);
    let occ_hi = smo_brick_word(info, b, SMO_BRICK_OCCUPANCY + 1u);
    let prv_lo = smo_brick_word(info, b, SMO_BRICK_PRIVATE);
    let prv_hi = smo_brick_word(info, b, SMO_BRICK_PRIVATE + 1u);
    let points = smo_point_mask(occ_lo & ~prv_lo, occ_hi & ~prv_hi);
    let pa = smo_brick_i16(info, b, SMO_BRICK_PLANE_A, SMO_BRICK_PLANE_A_SHIFT);
    let pb = smo_brick_i16(info, b, SMO_BRICK_PLANE_B, SMO_BRICK_PLANE_B_SHIFT);
    let pc = smo_brick_i16(info, b, SMO_BRICK_PLANE_C, SMO_BRICK_PLANE_C_SHIFT);
    let pd = smo_brick_i16(info, b, SMO_BRICK_PLANE_D, SMO_BRICK_PLANE_D_SHIFT);
    let word = smo_brick_word(info, b, SMO_BRICK_RESIDUALS);
    let start = info.residuals + (word & ((1u << SMO_RESIDUAL_OFFSET_BITS) - 1u));
    let code = word >> SMO_RESIDUAL_OFFSET_BITS;
    let eight = info.value_bits == 8u;
    let w = (select(SMO_RESIDUAL_WIDTHS_16, SMO_RESIDUAL_WIDTHS_8, eight) >> (code * 8u)) & 0xffu;
    let f = select(SMO_PLANE_FRACTION_BITS_16, SMO_PLANE_FRACTION_BITS_8, eight);
    let q = select(SMO_MAX_CODE_16, SMO_MAX_CODE_8, eight);
    let g = smo_cell_grid_index(leaf & 63u);
    let e = SMO_BRICK_POINT_EDGE;
    var c: array<f32, 8>;
    for (var k = 0u; k < 8u; k++) {
        let p = g + (((k >> 2u) & 1u) * e + ((k >> 1u) & 1u)) * e + (k & 1u);
        let x = i32(p / (e * e));
        let y = i32((p / e) % e);
        let z = i32(p % e);
        let t = pa + pb * x + pc * y + pd * z;
        let predicted = clamp((t + ((1i << f) >> 1u)) >> f, -q, q);
        let value = extractBits(predicted + smo_residual(start, smo_rank_below(points, p), w), 0u, info.value_bits);
        c[k] = f32(value) * info.dequant;
    }
    return c;
}

// ---- The interpolant (sdfmo-format interpolant.rs) ----

/// Trilinear interpolation of the corners at local `l` in [0,1]³.
fn smo_trilinear(c: array<f32, 8>, l: vec3<f32>) -> f32 {
    let c00 = c[0] + (c[1] - c[0]) * l.z;
    let c01 = c[2] + (c[3] - c[2]) * l.z;
    let c10 = c[4] + (c[5] - c[4]) * l.z;
    let c11 = c[6] + (c[7] - c[6]) * l.z;
    let c0 = c00 + (c01 - c00) * l.y;
    let c1 = c10 + (c11 - c10) * l.y;
    return c0 + (c1 - c0) * l.x;
}

fn smo_lerp(a: f32, b: f32, t: f32) -> f32 {
    return a + (b - a) * t;
}

/// Gradient of the interpolant in the local frame.
fn smo_trilinear_gradient(c: array<f32, 8>, l: vec3<f32>) -> vec3<f32> {
    let dx = smo_lerp(smo_lerp(c[4] - c[0], c[5] - c[1], l.z), smo_lerp(c[6] - c[2], c[7] - c[3], l.z), l.y);
    let dy = smo_lerp(smo_lerp(c[2] - c[0], c[3] - c[1], l.z), smo_lerp(c[6] - c[4], c[7] - c[5], l.z), l.x);
    let dz = smo_lerp(smo_lerp(c[1] - c[0], c[3] - c[2], l.y), smo_lerp(c[5] - c[4], c[7] - c[6], l.y), l.x);
    return vec3<f32>(dx, dy, dz);
}

// ---- Ray vs one voxel (sdfmo-trace ray_voxel.rs) ----

/// |x| with the sign of y (the sign bit, so −0 counts as negative, as f32::copysign).
fn smo_copysign(x: f32, y: f32) -> f32 {
    return select(abs(x), -abs(x), (bitcast<u32>(y) & 0x80000000u) != 0u);
}

/// The interpolant of `c` along `p + s·dir` as a cubic in s (Taylor expansion around p).
fn smo_ray_cubic(c: array<f32, 8>, p: vec3<f32>, dir: vec3<f32>) -> SmoCubic {
    let kx = c[4] - c[0];
    let ky = c[2] - c[0];
    let kz = c[1] - c[0];
    let kxy = (c[6] - c[4]) - (c[2] - c[0]);
    let kxz = (c[5] - c[4]) - (c[1] - c[0]);
    let kyz = (c[3] - c[2]) - (c[1] - c[0]);
    let kxyz = ((c[7] - c[6]) - (c[5] - c[4])) - ((c[3] - c[2]) - (c[1] - c[0]));
    let gx = kx + kxy * p.y + kxz * p.z + kxyz * p.y * p.z;
    let gy = ky + kxy * p.x + kyz * p.z + kxyz * p.x * p.z;
    let gz = kz + kxz * p.x + kyz * p.y + kxyz * p.x * p.y;
    let b = kxy * dir.x * dir.y + kxz * dir.x * dir.z + kyz * dir.y * dir.z
        + kxyz * (p.x * dir.y * dir.z + p.y * dir.x * dir.z + p.z * dir.x * dir.y);
    return SmoCubic(kxyz * dir.x * dir.y * dir.z, b, gx * dir.x + gy * dir.y + gz * dir.z, smo_trilinear(c, p));
}

fn smo_cubic_eval(q: SmoCubic, s: f32) -> f32 {
    return ((q.a * s + q.b) * s + q.c) * s + q.d;
}

fn smo_cubic_derivative(q: SmoCubic, s: f32) -> f32 {
    return (3.0 * q.a * s + 2.0 * q.b) * s + q.c;
}

/// Roots of the derivative strictly inside (0, len), ascending: (roots, count in z).
/// The CPU version divides by zero and lets the range test drop the infinite or NaN root;
/// here a zero divisor gives the sentinel −1, which the range test drops the same way.
fn smo_critical_points(q: SmoCubic, len: f32) -> vec3<f32> {
    let qa = 3.0 * q.a;
    let qb = 2.0 * q.b;
    let qc = q.c;
    let disc = qb * qb - 4.0 * qa * qc;
    var out = vec2<f32>(0.0, 0.0);
    var n = 0u;
    if disc >= 0.0 {
        let qq = -0.5 * (qb + smo_copysign(sqrt(disc), qb));
        var r0 = select(-1.0, qq / qa, qa != 0.0);
        var r1 = select(-1.0, qc / qq, qq != 0.0);
        if r1 < r0 {
            let t = r0;
            r0 = r1;
            r1 = t;
        }
        if r0 > 0.0 && r0 < len {
            out[n] = r0;
            n += 1u;
        }
        if r1 > 0.0 && r1 < len && (n == 0u || r1 > out[0]) {
            out[n] = r1;
            n += 1u;
        }
    }
    return vec3<f32>(out, f32(n));
}

/// The root of `q` in [lo, hi], on which it is monotone with g(lo) = glo, g(hi) = ghi of
/// opposite signs: Newton steps, bisection when they leave the bracket.
fn smo_polish(q: SmoCubic, lo_in: f32, hi_in: f32, glo: f32, ghi: f32, tol: f32) -> f32 {
    var lo = lo_in;
    var hi = hi_in;
    if glo == 0.0 {
        return lo;
    }
    if ghi == 0.0 {
        return hi;
    }
    let lo_positive = glo > 0.0;
    var s = lo + (hi - lo) * (glo / (glo - ghi));
    if !(s > lo && s < hi) {
        s = 0.5 * (lo + hi);
    }
    for (var i = 0u; i < SMO_MAX_POLISH_STEPS; i++) {
        let gs = smo_cubic_eval(q, s);
        if gs == 0.0 {
            return s;
        }
        if (gs > 0.0) == lo_positive {
            lo = s;
        } else {
            hi = s;
        }
        // The CPU's gs / 0 is ±∞, outside the bracket: bisect. WGSL leaves x / 0
        // indeterminate, so the zero derivative is tested first.
        let slope = smo_cubic_derivative(q, s);
        var next = 0.5 * (lo + hi);
        if slope != 0.0 {
            let newton = s - gs / slope;
            if newton > lo && newton < hi {
                next = newton;
            }
        }
        if abs(next - s) <= tol || hi - lo <= tol {
            return next;
        }
        s = next;
    }
    return s;
}

/// The first root in [0, len] of a cubic (volume: first point inside; surface: first zero from
/// either side), or −1 for none.
fn smo_first_root(q: SmoCubic, len: f32, surface: bool) -> f32 {
    let g0 = q.d;
    if (g0 < 0.0 && !surface) || (g0 == 0.0 && surface) {
        return 0.0;
    }
    if g0 == 0.0 && q.a == 0.0 && q.b == 0.0 && q.c == 0.0 {
        return 0.0;
    }
    if !(len >= 0.0) || g0 != g0 {
        return -1.0;
    }
    let crit = smo_critical_points(q, len);
    let n = u32(crit.z);
    var sa = 0.0;
    var ga = g0;
    for (var i = 0u; i <= n; i++) {
        var sb = len;
        if i < n {
            sb = crit[i];
        }
        let gb = smo_cubic_eval(q, sb);
        var crosses = gb < 0.0;
        if surface {
            crosses = (ga > 0.0 && gb <= 0.0) || (ga < 0.0 && gb >= 0.0);
        }
        if crosses {
            return smo_polish(q, sa, sb, ga, gb, len * SMO_REL_TOLERANCE);
        }
        sa = sb;
        ga = gb;
    }
    return -1.0;
}

/// The corners divided by their largest magnitude `m` (as sdfmo_trace's prepare_voxel): the
/// kernel's cubic is then bounded by 1, whatever the corner scale.
fn smo_scaled_corners(c: array<f32, 8>, m: f32) -> array<f32, 8> {
    let inv = 1.0 / m;
    var scaled: array<f32, 8>;
    for (var i = 0u; i < 8u; i++) {
        scaled[i] = c[i] * inv;
    }
    return scaled;
}

/// The kernel on one voxel in its local frame [0,1]³: the first root in [t0, t1] with
/// t0 ≥ 0, or −1 for none (sdfmo_trace::intersect_voxel).
fn smo_intersect_voxel(c: array<f32, 8>, origin: vec3<f32>, dir: vec3<f32>, t0: f32, t1: f32, surface: bool) -> f32 {
    let len = t1 - t0;
    if !(len >= 0.0 && len < SMO_FAR) {
        return -1.0;
    }
    let lo = min(min(min(c[0], c[1]), min(c[2], c[3])), min(min(c[4], c[5]), min(c[6], c[7])));
    let hi = max(max(max(c[0], c[1]), max(c[2], c[3])), max(max(c[4], c[5]), max(c[6], c[7])));
    // A trilinear interpolant is a convex combination of its corners inside the cube.
    if lo > 0.0 {
        return -1.0;
    }
    if hi < 0.0 {
        return select(t0, -1.0, surface);
    }
    let m = max(hi, -lo);
    if !(m >= SMO_MIN_POSITIVE) {
        return -1.0;
    }
    let scaled = smo_scaled_corners(c, m);
    let cubic = smo_ray_cubic(scaled, origin + dir * t0, dir * len);
    let u = smo_first_root(cubic, 1.0, surface);
    if u < 0.0 {
        return -1.0;
    }
    return min(t0 + u * len, t1);
}

// ---- The clip rule (sdfmo-trace clip.rs) ----

/// The smallest and largest corner.
fn smo_min_max(c: array<f32, 8>) -> vec2<f32> {
    let lo = min(min(min(c[0], c[1]), min(c[2], c[3])), min(min(c[4], c[5]), min(c[6], c[7])));
    let hi = max(max(max(c[0], c[1]), max(c[2], c[3])), max(max(c[4], c[5]), max(c[6], c[7])));
    return vec2<f32>(lo, hi);
}

/// The clip voxels of one leaf, gathered once per leaf (sdfmo_trace::clip::LeafClips).
struct SmoLeafClips {
    voxels: array<u32, SMO_MAX_CLIP_VOXELS>,
    count: u32,
    /// The leaf's `smo_leaf_voxels` (where its voxels' codes are).
    leaf: vec4<u32>,
}

/// The clip voxels among the leaf's voxels [first, first + count), in order (at most
/// SMO_MAX_CLIP_VOXELS in a validated file; any beyond would be ignored, never read out of
/// bounds).
fn smo_gather_clips(info: SmoInfo, first: u32, count: u32, leaf: vec4<u32>) -> SmoLeafClips {
    var clips: SmoLeafClips;
    clips.count = 0u;
    clips.leaf = leaf;
    for (var j = first; j < first + count; j++) {
        if smo_voxel_is_clip(info, j) && clips.count < SMO_MAX_CLIP_VOXELS {
            clips.voxels[clips.count] = j;
            clips.count += 1u;
        }
    }
    return clips;
}

/// Whether the local point `p` is kept by every clip voxel of the leaf (`clips`) other than
/// `skip`: f ≤ SMO_CLIP_TOLERANCE · max|corner| at a polished root (`slack`), f ≤ 0 at the span
/// start (sdfmo_trace::clip::inside_clip).
fn smo_clips_keep(info: SmoInfo, clips: SmoLeafClips, skip: u32, p: vec3<f32>, slack: bool) -> bool {
    for (var k = 0u; k < clips.count; k++) {
        let j = clips.voxels[k];
        if j == skip {
            continue;
        }
        let c = smo_voxel_corners(info, j, clips.leaf);
        let f = smo_trilinear(c, p);
        var limit = 0.0;
        if slack {
            let mm = smo_min_max(c);
            limit = SMO_CLIP_TOLERANCE * max(mm.y, -mm.x);
        }
        if !(f <= limit) {
            return false;
        }
    }
    return true;
}

/// The first candidate hit in [0, best] of voxel `voxel` (corners `c`) that the other clip
/// voxels of the leaf keep, on the segment local_o + s·local_d, or −1
/// (sdfmo_trace::clip::intersect_voxel_where with t0 = 0, the leaf's clip test as predicate).
fn smo_clipped_voxel_hit(info: SmoInfo, clips: SmoLeafClips, voxel: u32, c: array<f32, 8>,
                         local_o: vec3<f32>, local_d: vec3<f32>, best: f32, surface: bool) -> f32 {
    let len = best;
    if !(len >= 0.0 && len < SMO_FAR) {
        return -1.0;
    }
    let mm = smo_min_max(c);
    if mm.x > 0.0 {
        return -1.0;
    }
    if mm.y < 0.0 {
        // Inside everywhere: a volume voxel's only candidate is the segment start.
        if !surface && smo_clips_keep(info, clips, voxel, local_o, false) {
            return 0.0;
        }
        return -1.0;
    }
    let m = max(mm.y, -mm.x);
    if !(m >= SMO_MIN_POSITIVE) {
        return -1.0;
    }
    let scaled = smo_scaled_corners(c, m);
    let q = smo_ray_cubic(scaled, local_o, local_d * len);
    let g0 = q.d;
    if ((g0 < 0.0 && !surface) || (g0 == 0.0 && surface))
        && smo_clips_keep(info, clips, voxel, local_o, false) {
        return 0.0;
    }
    if g0 == 0.0 && q.a == 0.0 && q.b == 0.0 && q.c == 0.0 {
        if !surface && smo_clips_keep(info, clips, voxel, local_o, false) {
            return 0.0;
        }
        return -1.0;
    }
    if g0 != g0 {
        return -1.0;
    }
    let crit = smo_critical_points(q, 1.0);
    let n = u32(crit.z);
    var sa = 0.0;
    var ga = g0;
    for (var i = 0u; i <= n; i++) {
        var sb = 1.0;
        if i < n {
            sb = crit[i];
        }
        let gb = smo_cubic_eval(q, sb);
        var crosses = ga >= 0.0 && gb < 0.0;
        if surface {
            crosses = (ga > 0.0 && gb <= 0.0) || (ga < 0.0 && gb >= 0.0);
        }
        if crosses {
            let u = smo_polish(q, sa, sb, ga, gb, SMO_REL_TOLERANCE);
            let s = min(u * len, len);
            if smo_clips_keep(info, clips, voxel, local_o + local_d * s, true) {
                return s;
            }
        }
        sa = sb;
        ga = gb;
    }
    return -1.0;
}

// ---- Traversal (sdfmo-trace traversal.rs) ----

fn smo_safe_inv(d: f32) -> f32 {
    if abs(d) < SMO_TINY_DIR {
        return 1.0 / smo_copysign(SMO_TINY_DIR, d);
    }
    return 1.0 / d;
}

/// 1 / size for a cell edge size = 2^k (exact, unlike WGSL's division).
fn smo_inv_pow2(size: f32) -> f32 {
    return ldexp(1.0, 1 - frexp(size).exp);
}

/// The nearest hit of the leaf's voxels inside the cell's [t_enter, t_exit]; in a leaf with
/// clip voxels the nearest candidate the clip rule accepts (clip-only voxels are never hit), as
/// in sdfmo_trace::clip::leaf_hit. One loop for both: they differ only in the voxel test.
fn smo_leaf_hit(info: SmoInfo, cell: SmoCell, o: vec3<f32>, d: vec3<f32>) -> SmoHit {
    let inv_size = smo_inv_pow2(cell.size);
    let local_o = (o + d * cell.t_enter - cell.min) * inv_size;
    let local_d = d * inv_size;
    let range = smo_leaf_voxels(info, cell.node);
    let clip = smo_any_clip(info, range.x, range.y);
    var clips: SmoLeafClips;
    clips.count = 0u;
    if clip {
        clips = smo_gather_clips(info, range.x, range.y, range);
    }
    var best_s = cell.t_exit - cell.t_enter;
    var hit: SmoHit;
    hit.hit = false;
    for (var v = range.x; v < range.x + range.y; v++) {
        let surface = smo_voxel_is_surface(info, v);
        if clip && surface && smo_voxel_is_clip(info, v) {
            continue;
        }
        let corners = smo_voxel_corners(info, v, range);
        var s: f32;
        if clip {
            s = smo_clipped_voxel_hit(info, clips, v, corners, local_o, local_d, best_s, surface);
        } else {
            s = smo_intersect_voxel(corners, local_o, local_d, 0.0, best_s, surface);
        }
        if s >= 0.0 && (!hit.hit || s < best_s) {
            best_s = s;
            hit.hit = true;
            hit.voxel = v;
            hit.leaf = range;
            hit.surface = surface;
        }
    }
    if hit.hit {
        hit.t = min(cell.t_enter + best_s, cell.t_exit);
        hit.cell_min = cell.min;
        hit.cell_size = cell.size;
    }
    return hit;
}

/// The ray's span in the root cube [-1, 1]³ within [t_min, t_max], as `smo_intersect` clips
/// it: (t_enter, t_exit); the ray misses where !(t_enter <= t_exit). A caller may test it
/// before calling `smo_intersect` (render.wgsl does, to skip the traversal's set-up).
fn smo_root_span(ray: SmoRay, t_min: f32, t_max: f32) -> vec2<f32> {
    let o = ray.origin;
    let d = ray.dir;
    let inv = vec3<f32>(smo_safe_inv(d.x), smo_safe_inv(d.y), smo_safe_inv(d.z));
    let ta = (vec3<f32>(-1.0) - o) * inv;
    let tb = (vec3<f32>(1.0) - o) * inv;
    let lo = min(ta, tb);
    let hi = max(ta, tb);
    let t_enter = max(max(max(lo.x, lo.y), lo.z), t_min);
    let t_exit = min(min(min(hi.x, hi.y), hi.z), t_max);
    return vec2<f32>(t_enter, t_exit);
}

// Traversal stack. The walk visits the cells of sdfmo_trace::intersect in the same order with
// the same spans, but keeps one entry per level instead of one per pending cell: the node and
// span of each ancestor of the current cell (12 bytes; at most MAX_DEPTH of them, as a validated
// file's leaves all sit at its depth). A cell's next sibling in ray order is derived again from
// its parent when the cell is done (`smo_next_child`, the same arithmetic as on the way down,
// so the same octants and spans bit for bit), as ESVO's "advance" does (Laine & Karras 2010),
// instead of pushing up to three siblings per level as the CPU kernel does (here that was 50
// cells of 48 bytes, 2400 bytes). Why it matters: WGSL zero-initialises every function
// variable, lavapipe does so for every invocation, reached or not, and writes it through masks;
// a real GPU keeps a small stack in registers or L1 instead of spilling a large one.

/// `smo_next_child`'s `after` for a node just entered: its nearest present child.
const SMO_FIRST_CHILD: u32 = 8u;

/// `smo_next_child`'s node when no child follows (no node has this index: a file is shorter
/// than 4 GiB, and a 3.0 file's node numbers stay below 2^31, see "Bricks").
const SMO_NO_NODE: u32 = 0xffffffffu;

/// The present child of the inner node `cell` at `level` that follows, in ray order, its child
/// of octant `after` (the nearest present child for SMO_FIRST_CHILD): that child's cell, or a
/// cell of node SMO_NO_NODE when none follows. The node's span is split at its mid-planes as
/// sdfmo_trace's split_span and inner_step split it (entry octant from the planes behind the
/// entry point, the planes crossed inside the span flipping their bit in crossing order, equal
/// times in axis order x, y, z), so a child's span is the same whenever it is derived.
fn smo_next_child(info: SmoInfo, cell: SmoCell, level: u32, o: vec3<f32>, inv: vec3<f32>, negative: u32, after: u32) -> SmoCell {
    let half = 0.5 * cell.size;
    let mid = cell.min + vec3<f32>(half);
    let tm = (mid - o) * inv;
    let te = cell.t_enter;
    let tx = cell.t_exit;
    let behind = select(0u, 4u, tm.x <= te) | select(0u, 2u, tm.y <= te) | select(0u, 1u, tm.z <= te);
    // Sort keys: a plane crossed inside (te, tx) has its time, the others tx and bit 0, which
    // sort after every crossing; a three-comparator network with strict comparisons.
    let crossed = (tm > vec3<f32>(te)) & (tm < vec3<f32>(tx));
    var k = select(vec3<f32>(tx), tm, crossed);
    var b = select(vec3<u32>(0u), vec3<u32>(4u, 2u, 1u), crossed);
    if k.y < k.x {
        k = k.yxz;
        b = b.yxz;
    }
    if k.z < k.y {
        k = k.xzy;
        b = b.xzy;
    }
    if k.y < k.x {
        k = k.yxz;
        b = b.yxz;
    }
    // Child i of the ray order: octant octants[i], span [starts[i], ends[i]]; it exists for
    // i = 0 and where the crossing before it does (b[i - 1] != 0).
    let o0 = behind ^ negative;
    let octants = vec4<u32>(o0, o0 ^ b.x, o0 ^ b.x ^ b.y, o0 ^ b.x ^ b.y ^ b.z);
    let starts = vec4<f32>(te, k);
    let ends = vec4<f32>(k, tx);
    let valid = vec4<bool>(true, b != vec3<u32>(0u));
    // Start after `after`: the octants along the ray are distinct, and a position past the last
    // valid one repeats its octant, so the last match is `after` itself or lies past the end.
    var i = 0u;
    for (var j = 0u; j < 4u; j++) {
        if octants[j] == after {
            i = j + 1u;
        }
    }
    let mask = smo_node_mask(info, cell.node, level);
    for (; i < 4u; i++) {
        let oct = octants[i];
        if valid[i] && ((mask >> oct) & 1u) != 0u {
            let node = smo_node_child(info, cell.node, level, mask, oct);
            // `min + half` is `mid`, so selecting is exact (as sdfmo_trace's child_at).
            let upper = (vec3<u32>(oct) >> vec3<u32>(2u, 1u, 0u)) & vec3<u32>(1u);
            let min = select(cell.min, mid, upper != vec3<u32>(0u));
            return SmoCell(node, min, half, starts[i], ends[i]);
        }
    }
    return SmoCell(SMO_NO_NODE, cell.min, half, te, tx);
}

/// The first hit along the ray in [t_min, t_max] (sdfmo_trace::intersect). Pass SMO_FAR for
/// an unbounded ray.
fn smo_intersect(info: SmoInfo, ray: SmoRay, t_min: f32, t_max: f32) -> SmoHit {
    var none: SmoHit;
    none.hit = false;
    if info.leaf_count == 0u || !(t_min <= t_max) {
        return none;
    }
    let o = ray.origin;
    let d = ray.dir;
    let inv = vec3<f32>(smo_safe_inv(d.x), smo_safe_inv(d.y), smo_safe_inv(d.z));
    let root = smo_root_span(ray, t_min, t_max);
    let t_enter = root.x;
    let t_exit = root.y;
    if !(t_enter <= t_exit) {
        return none;
    }
    // Axes along which the ray moves towards − (bit 4 = x, 2 = y, 1 = z, as in octants).
    let negative = select(0u, 4u, inv.x < 0.0) | select(0u, 2u, inv.y < 0.0) | select(0u, 1u, inv.z < 0.0);

    // The ancestors of `cell`, one per level (see "Traversal stack" above): node and span.
    // `level` is the cell's level (the root's is 0).
    var nodes: array<u32, SMO_MAX_DEPTH>;
    var spans: array<vec2<f32>, SMO_MAX_DEPTH>;
    var level = 0u;
    var cell = SmoCell(0u, vec3<f32>(-1.0), 2.0, t_enter, t_exit);
    loop {
        // Down to the first leaf along the ray (a loop of its own: lavapipe runs every branch of
        // a loop's body for its whole SIMD group, so the leaf test stays out of this one).
        loop {
            if smo_is_leaf(info, cell.node, level) {
                break;
            }
            let child = smo_next_child(info, cell, level, o, inv, negative, SMO_FIRST_CHILD);
            if child.node == SMO_NO_NODE {
                break;
            }
            nodes[level] = cell.node;
            spans[level] = vec2<f32>(cell.t_enter, cell.t_exit);
            level += 1u;
            cell = child;
        }
        if smo_is_leaf(info, cell.node, level) {
            let hit = smo_leaf_hit(info, cell, o, d);
            if hit.hit {
                return hit;
            }
        }
        // The cell is done: the next present sibling in ray order, else its parent's, and so on
        // up. The parent's box comes back exactly from the child's (edges are powers of two and
        // corners multiples of them, exact in f32 down to MAX_DEPTH).
        loop {
            if level == 0u {
                return none;
            }
            level -= 1u;
            let upper = vec3<u32>((cell.min + vec3<f32>(1.0)) * smo_inv_pow2(cell.size)) & vec3<u32>(1u);
            let parent_min = select(cell.min, cell.min - vec3<f32>(cell.size), upper != vec3<u32>(0u));
            let parent = SmoCell(nodes[level], parent_min, 2.0 * cell.size, spans[level].x, spans[level].y);
            let octant = (upper.x << 2u) | (upper.y << 1u) | upper.z;
            let sibling = smo_next_child(info, parent, level, o, inv, negative, octant);
            if sibling.node != SMO_NO_NODE {
                level += 1u;
                cell = sibling;
                break;
            }
            cell = parent;
        }
    }
    return none;
}

/// `v` scaled to unit length if its length is a positive finite number with a finite
/// reciprocal (glam's try_normalize), else `fallback`.
fn smo_try_normalize(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    // Tested before dividing: WGSL leaves x / 0 indeterminate.
    let l = length(v);
    if l > 0.0 && l <= SMO_MAX_FINITE {
        let rcp = 1.0 / l;
        if rcp <= SMO_MAX_FINITE {
            return v * rcp;
        }
    }
    return fallback;
}

/// Unit gradient of the hit voxel's interpolant at the hit, flipped so dot(n, dir) ≤ 0
/// (sdfmo_trace::hit_normal); −dir where the gradient vanishes.
fn smo_hit_normal(info: SmoInfo, ray: SmoRay, hit: SmoHit) -> vec3<f32> {
    let facing = smo_try_normalize(-ray.dir, vec3<f32>(0.0, 0.0, 1.0));
    if !smo_voxel_exists(info, hit.voxel) || !(hit.cell_size > 0.0) {
        return facing;
    }
    let corners = smo_voxel_corners(info, hit.voxel, hit.leaf);
    let p = ray.origin + ray.dir * hit.t;
    let local = clamp((p - hit.cell_min) * smo_inv_pow2(hit.cell_size), vec3<f32>(0.0), vec3<f32>(1.0));
    let g = smo_trilinear_gradient(corners, local);
    let n = smo_try_normalize(g, vec3<f32>(0.0));
    if all(n == vec3<f32>(0.0)) {
        return facing;
    }
    if dot(n, ray.dir) > 0.0 {
        return -n;
    }
    return n;
}

// ---- Levels of detail (.smo 2.0; sdfmo-trace lod.rs) ----
//
// A file with levels bound as it is saved (FORMAT.md, "Levels of detail"): the 2.0 header
// (depth D, coarsest c; in the level table, entry i the u64 offset of level c + i),
// then each level as a complete 1.x file of its own, at a multiple of 8 bytes. Level k is
// traced by `smo_intersect` over `smo_lod_level_info(lod, k)`; `smo_intersect_lod` picks the
// level per ray by screen-space error exactly as sdfmo_trace::intersect_lod does (the same
// levels in the same order; only the f32 rounding of the traces differs, as everywhere here).

/// The levels of the bound 2.0 file, and the finest level's dequantisation factor.
struct SmoLod {
    coarsest: u32,
    depth: u32,
    dequant: f32,
}

/// Reads the 2.0 header of the bound file. `dequant` = the finest level's diagonal / Q
/// (`sdfmo_format::quant::dequant_scale(D, bits)`, from the host).
fn smo_lod(dequant: f32) -> SmoLod {
    let coarsest = (smo[SMO_LOD_HEADER_COARSEST] >> SMO_LOD_HEADER_COARSEST_SHIFT) & 0xffu;
    let depth = (smo[SMO_LOD_HEADER_DEPTH] >> SMO_LOD_HEADER_DEPTH_SHIFT) & 0xffu;
    return SmoLod(coarsest, depth, dequant);
}

/// Level `level` (coarsest ≤ level ≤ depth) of the bound 2.0 file. Its dequantisation factor
/// is the finest level's times 2^(D − level): exact, because `dequant_scale` is a power-of-two
/// multiple of the cell size rounded once to f32 (the crate's tests check every depth).
fn smo_lod_level_info(lod: SmoLod, level: u32) -> SmoInfo {
    let entry = SMO_LOD_TABLE + SMO_LOD_ENTRY * (level - lod.coarsest);
    let base = smo[entry + SMO_LOD_LEVEL_OFFSET] >> 2u;
    return smo_info_at(base, ldexp(lod.dequant, i32(lod.depth) - i32(level)));
}

/// Edge of a cell at `level`, 2 / 2^level (exact; sdfmo_format::cell_size).
fn smo_cell_size(level: u32) -> f32 {
    return ldexp(1.0, 1 - i32(level));
}

/// The coarsest level in coarsest..=finest whose voxel edge projects to at most `pixels`
/// pixels at distance `t` (sdfmo_trace::level_for_distance, the same arithmetic).
fn smo_level_for_distance(t: f32, pixels: f32, pixel_angle: f32, coarsest: u32, finest: u32) -> u32 {
    let budget = pixels * t * pixel_angle;
    for (var k = coarsest; k <= finest; k++) {
        if smo_cell_size(k) <= budget {
            return k;
        }
    }
    return finest;
}

/// The ray's span in the unit cube [0,1]³: (t_enter, t_exit, 1) or (.., .., 0) when it misses
/// (sdfmo_trace::unit_cube_span; ±SMO_FAR stand for ±∞).
fn smo_unit_cube_span(origin: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    var t_enter = -SMO_FAR;
    var t_exit = SMO_FAR;
    for (var k = 0u; k < 3u; k++) {
        let o = origin[k];
        let d = dir[k];
        if d == 0.0 {
            if !(o >= 0.0 && o <= 1.0) {
                return vec3<f32>(0.0);
            }
        } else {
            let inv = 1.0 / d;
            let ta = -o * inv;
            let tb = (1.0 - o) * inv;
            t_enter = max(t_enter, min(ta, tb));
            t_exit = min(t_exit, max(ta, tb));
        }
    }
    return vec3<f32>(t_enter, t_exit, select(0.0, 1.0, t_enter <= t_exit));
}

/// A hit of `smo_intersect_lod`: the hit in the octree of `level`, and the level.
struct SmoLodHit {
    hit: SmoHit,
    level: u32,
}

/// A pixel-error trace between two of its traversals (`smo_intersect_lod` one step at a time):
/// the level to trace next, and the level the near end of the ray's span needs.
struct SmoLodTrace {
    /// False: the ray misses the root cube, there is nothing to trace.
    tracing: bool,
    level: u32,
    near: u32,
    /// |dir|: hit parameters times this are distances.
    scale: f32,
}

/// The first step of `smo_intersect_lod`: the levels of the ray's span [t_in, t_out] in the root
/// cube (within [t_min, t_max]); the first trace is at the level t_out needs.
fn smo_lod_trace_start(lod: SmoLod, ray: SmoRay, t_min: f32, t_max: f32, pixels: f32, pixel_angle: f32) -> SmoLodTrace {
    var trace: SmoLodTrace;
    trace.tracing = false;
    trace.level = lod.depth;
    trace.near = lod.depth;
    // span_levels: the root cube [-1, 1]³ is the unit cube at (p + 1) / 2, with the same t.
    let span = smo_unit_cube_span((ray.origin + vec3<f32>(1.0)) * 0.5, ray.dir * 0.5);
    if span.z == 0.0 {
        return trace;
    }
    let t_in = max(span.x, t_min);
    let t_out = min(span.y, t_max);
    if t_in > t_out {
        return trace;
    }
    let d = ray.dir;
    trace.scale = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    trace.near = smo_level_for_distance(t_in * trace.scale, pixels, pixel_angle, lod.coarsest, lod.depth);
    trace.level = smo_level_for_distance(t_out * trace.scale, pixels, pixel_angle, lod.coarsest, lod.depth);
    trace.tracing = true;
    return trace;
}

/// The step after a traversal at `trace.level` returned `hit`: true with the next level to
/// trace in `trace.level`, or false when `hit` (a hit, or a miss) is the answer. A hit that
/// needs a finer level is traced again at that level (the level only grows); a miss at a level
/// coarser than the near end's is traced once more at the near end's.
fn smo_lod_trace_next(lod: SmoLod, trace: ptr<function, SmoLodTrace>, hit: SmoHit, pixels: f32, pixel_angle: f32) -> bool {
    if !hit.hit {
        if (*trace).level >= (*trace).near {
            return false;
        }
        (*trace).level = (*trace).near;
        return true;
    }
    let need = smo_level_for_distance(hit.t * (*trace).scale, pixels, pixel_angle, lod.coarsest, lod.depth);
    if need <= (*trace).level {
        return false;
    }
    (*trace).level = need;
    return true;
}

/// The first hit of `ray` in [t_min, t_max] at the coarsest level whose voxel edge projects to
/// at most `pixels` pixels at the hit distance (`pixel_angle` radians per pixel), as
/// sdfmo_trace::intersect_lod with LevelChoice::PixelError: with [t_in, t_out] the ray's span
/// in the root cube, trace at the level t_out needs; where the hit needs a finer level,
/// trace again at that level (the level only grows); where a level coarser than t_in's misses,
/// trace once more at t_in's level (`smo_lod_trace_start`, `smo_lod_trace_next`).
fn smo_intersect_lod(lod: SmoLod, ray: SmoRay, t_min: f32, t_max: f32, pixels: f32, pixel_angle: f32) -> SmoLodHit {
    var none: SmoLodHit;
    none.hit.hit = false;
    none.level = lod.depth;
    var trace = smo_lod_trace_start(lod, ray, t_min, t_max, pixels, pixel_angle);
    if !trace.tracing {
        return none;
    }
    loop {
        let hit = smo_intersect(smo_lod_level_info(lod, trace.level), ray, t_min, t_max);
        if !smo_lod_trace_next(lod, &trace, hit, pixels, pixel_angle) {
            if hit.hit {
                return SmoLodHit(hit, trace.level);
            }
            return none;
        }
    }
    return none;
}
