//! GPU ray tracing of the packed SDF multi-octree: the traversal and ray–voxel kernel of
//! `sdfmo-trace` in WGSL, over the `.smo` file uploaded unchanged as a storage buffer (the
//! format is the GPU layout, as NanoVDB's is), driven by wgpu compute passes.
//!
//! Two WGSL files ship with the crate:
//!
//! - [`trace_wgsl`] (`src/sdfmo.wgsl` after the generated constants of
//!   [`kernel_constants_wgsl`]): the library an engine includes in its own pipeline (WGSL has
//!   no `#include`: put the source before yours). Functions `smo_info`,
//!   `smo_intersect`, `smo_hit_normal`, `smo_intersect_voxel`; the same hit rules as the CPU
//!   kernel (volume voxels: first point inside; surface voxels: first zero crossing from either
//!   side; in a multi-voxel leaf the nearest hit inside the leaf; in a leaf with clip voxels,
//!   format 1.1, the nearest hit that every other clip voxel of the leaf keeps — the clip rule
//!   of `sdfmo-format`'s FORMAT.md, read from the same buffer: the clip bitmap after the
//!   corners).
//! - [`render_wgsl`] (`src/render.wgsl` after the uniform struct generated from the host's):
//!   one primary ray per pixel, shaded as `sdfmo-render`
//!   shades it (mask, depth, normal, lambert; no shadows or occlusion), the entry point
//!   [`ENTRY_POINT`] with workgroups of [`WORKGROUP_SIZE`]², one per listed tile; the tiles
//!   whose rays all miss the octree's occupied box go to [`BACKGROUND_ENTRY_POINT`] instead.
//!
//! # Binding layout
//!
//! All in bind group 0:
//!
//! | binding | type | WGSL | contents |
//! |---:|---|---|---|
//! | 0 | storage, read | `smo: array<u32>` | the whole `.smo` file as saved, little-endian words (header, sections, checksum); validated on the host first. A 1.x file, a 3.0 brick file traced as it is ([`GpuRenderer::upload_bricks`]: no expansion to 1.x), or for a pixel-error render a 2.0 file with levels (every level, [`GpuRenderer::upload_lod`]) |
//! | 1 | uniform | `params: SmoRenderParams` | eye, image size, mode, shading, dequantisation factor, pixel error (64 bytes) |
//! | 2 | storage, read_write | `pixels: array<SmoPixel>` | per pixel: viewer-facing normal (vec3) and t (`3e38` for the background) |
//! | 3 | storage, read_write | `colors: array<u32>` | per pixel: `0x00BBGGRR` |
//! | 4 | storage, read | `rays: array<vec4<f32>>` | the camera's column and row terms ([`sdfmo_render::CameraFrame::column`], [`row`](sdfmo_render::CameraFrame::row)) as double-float pairs: every column's (hi.xyz, 0), (lo.xyz, 0), then every row's |
//! | 5 | storage, read | `tiles: array<u32>` | the tiles of [`WORKGROUP_SIZE`]² pixels the dispatch draws, tile (x, y) as `x \| y << 16`: [`ENTRY_POINT`] traces the tiles whose rays may meet the octree's occupied box, [`BACKGROUND_ENTRY_POINT`] fills the others |
//!
//! Only binding 0 belongs to the library ([`trace_wgsl`]); 1–5 are [`render_wgsl`]'s. The kernel
//! reads the header's counts and section offsets itself; the one value the host passes is
//! the dequantisation factor `diagonal / Q` ([`GpuOctree::dequant`], computed in f64 by
//! `sdfmo_format::quant::dequant_scale` so the corners decode exactly as on the CPU).
//!
//! # Agreement with the CPU kernel
//!
//! The WGSL is a line-by-line port of `sdfmo-trace`; f32 arithmetic may be contracted into fused
//! multiply-adds on the GPU and WGSL's division and `inverseSqrt` are not correctly rounded, so
//! hits agree to a few ulps, not bit for bit. The tests (`tests/match_cpu.rs`) hold the GPU image
//! to the CPU image on the paper views of the demo part, abc5 and the teapot: masks identical
//! except where the CPU's hit lies within 1e-4 voxel of a voxel boundary, depth within 1e-4 of
//! the voxel size, lambert PSNR ≥ 45 dB.
//!
//! # Example
//!
//! [`GpuRenderer::new`] opens an adapter (a typed [`GpuError::NoAdapter`] without one),
//! [`GpuRenderer::upload`] puts an octree on it, [`GpuRenderer::render`] renders and reads back
//! an image. The GPU is a backend of `sdfmo-render`: it takes the CPU renderer's
//! [`Camera`](sdfmo_render::Camera), [`RenderSettings`](sdfmo_render::RenderSettings) (its
//! [`Mode`](sdfmo_render::Mode); shadows and occlusion are CPU settings) and shading
//! constants, and returns its [`Rendered`](sdfmo_render::Rendered), with the kernel's time in
//! [`Rendered::kernel_ms`](sdfmo_render::Rendered::kernel_ms). The facade
//! `sdf-multioctree` chooses between the two devices (`Device`). See [`GpuRenderer`].
//!
//! # Levels of detail
//!
//! A level of a `.smo` 2.0 file is a 1.x octree: [`GpuRenderer::upload`] it and render it as
//! any. [`GpuRenderer::upload_lod`] puts the whole 2.0 file on the GPU as saved, and
//! [`GpuRenderer::render_lod`] lets each ray stop at the coarsest level whose voxels
//! project to at most a number of pixels at its hit distance (the tracer's
//! `LevelChoice::PixelError`): `smo_intersect_lod` in the WGSL, the rule of
//! `sdfmo_trace::intersect_lod` (the same levels, traced in the same order).
//!
//! Depends on `sdfmo-format`, `sdfmo-trace` (its level choice), `sdfmo-render` without its
//! mesh reference (the vocabulary) and wgpu; no CPU crate depends on this one.

#![deny(missing_docs)]

mod error;
mod renderer;
mod shared_struct;

pub use error::{GpuError, Result};
pub use renderer::{
    GpuLodOctree, GpuOctree, GpuRenderer, GpuTiming, DEFAULT_GPU_TIMEOUT, MAX_GPU_FILE_BYTES,
};

/// `src/sdfmo.wgsl` as written: the library without the constants it shares with the CPU
/// kernel ([`trace_wgsl`] puts them before it).
const TRACE_WGSL_BODY: &str = include_str!("sdfmo.wgsl");

/// The ray parameter `SMO_FAR` of the WGSL: stands for +∞ (WGSL has no infinity literal); a
/// pixel of the `pixels` binding whose `t` is this is background.
pub const SMO_FAR: f32 = 3.0e38;

/// A WGSL `f32` literal of exactly `v`: Rust's shortest representation that reads back as the
/// same f32, with the `f` suffix (a concrete f32, not an abstract float rounded twice).
fn wgsl_f32(v: f32) -> String {
    format!("{v:?}f")
}

/// The WGSL declaration `const name: f32 = value;`, the literal exact ([`wgsl_f32`]).
fn const_f32(name: &str, value: f32) -> String {
    format!("const {name}: f32 = {};", wgsl_f32(value))
}

/// The WGSL declaration `const name: u32 = valueu;`. Panics on a value a u32 cannot hold (a
/// test generates every declaration).
fn const_u32(name: &str, value: impl TryInto<u32>) -> String {
    let value: u32 = value
        .try_into()
        .unwrap_or_else(|_| panic!("{name} does not fit a WGSL u32"));
    format!("const {name}: u32 = {value}u;")
}

/// The `const` declarations the WGSL kernel shares with the CPU kernel, generated from the Rust
/// values so the two cannot drift apart (issue 20): the kernel constants of
/// [`sdfmo_format::kernel`], the clip bound [`sdfmo_format::MAX_CLIP_VOXELS_PER_LEAF`], the
/// depth bound [`sdfmo_format::MAX_DEPTH`] (the traversal stack's levels), [`SMO_FAR`], and the
/// f32 limits. [`trace_wgsl`] is this followed by the library.
pub fn kernel_constants_wgsl() -> String {
    use sdfmo_format::kernel::{CLIP_TOLERANCE, MAX_POLISH_STEPS, ROOT_REL_TOLERANCE, TINY_DIR};
    use sdfmo_format::{MAX_CLIP_VOXELS_PER_LEAF, MAX_DEPTH};
    [
        const_f32("SMO_FAR", SMO_FAR),
        const_f32("SMO_MAX_FINITE", f32::MAX),
        const_f32("SMO_MIN_POSITIVE", f32::MIN_POSITIVE),
        const_f32("SMO_TINY_DIR", TINY_DIR),
        const_u32("SMO_MAX_DEPTH", MAX_DEPTH),
        const_u32("SMO_MAX_POLISH_STEPS", MAX_POLISH_STEPS),
        const_f32("SMO_REL_TOLERANCE", ROOT_REL_TOLERANCE),
        const_f32("SMO_CLIP_TOLERANCE", CLIP_TOLERANCE),
        const_u32("SMO_MAX_CLIP_VOXELS", MAX_CLIP_VOXELS_PER_LEAF),
    ]
    .into_iter()
    .chain(header_words_wgsl())
    .chain(brick_constants_wgsl())
    .fold(
        String::from("// Generated by sdfmo_gpu::kernel_constants_wgsl() from the Rust values.\n"),
        |acc, line| acc + &line + "\n",
    )
}

/// Fields of one of the format's field tables, as `(table, [(WGSL name, field name)])`.
type TableFields = (
    &'static [sdfmo_format::HeaderField],
    &'static [(&'static str, &'static str)],
);

/// The header fields the kernel reads, grouped by the format's field table that holds them: the
/// word index of each comes from its table, never typed in the shader.
const HEADER_WORDS: [TableFields; 5] = {
    use sdfmo_format::{
        BRICK_RECORD_FIELDS as BRICK, HEADER_FIELDS as V1, LOD_HEADER_FIELDS as V2,
        LOD_LEVEL_FIELDS as LEVEL, V3_HEADER_FIELDS as V3,
    };
    [
        // Every header starts with the magic and the major version (1.x, 2.0, 3.0 alike).
        (
            &V1,
            &[
                ("SMO_HEADER_VERSION_MAJOR", "version_major"),
                ("SMO_HEADER_FLAGS", "flags"),
                ("SMO_HEADER_DEPTH", "depth"),
                ("SMO_HEADER_VALUE_BITS", "value_bits"),
                ("SMO_HEADER_INNER_COUNT", "inner_node_count"),
                ("SMO_HEADER_LEAF_COUNT", "leaf_count"),
                ("SMO_HEADER_VOXEL_COUNT", "voxel_count"),
                ("SMO_HEADER_NODES_OFFSET", "nodes_offset"),
                ("SMO_HEADER_LEAVES_OFFSET", "leaves_offset"),
                ("SMO_HEADER_SURFACE_OFFSET", "surface_offset"),
                ("SMO_HEADER_CORNERS_OFFSET", "corners_offset"),
                ("SMO_HEADER_CORNERS_SIZE", "corners_size"),
            ],
        ),
        (
            &V2,
            &[
                ("SMO_LOD_HEADER_DEPTH", "depth"),
                ("SMO_LOD_HEADER_COARSEST", "coarsest"),
            ],
        ),
        // Relative to a level-table entry, which starts at word SMO_LOD_TABLE + i · SMO_LOD_ENTRY.
        (&LEVEL, &[("SMO_LOD_LEVEL_OFFSET", "offset")]),
        (
            &V3,
            &[
                ("SMO_V3_HEADER_FLAGS", "flags"),
                ("SMO_V3_HEADER_VERSION_MINOR", "version_minor"),
                ("SMO_V3_HEADER_DEPTH", "depth"),
                ("SMO_V3_HEADER_VALUE_BITS", "value_bits"),
                ("SMO_V3_HEADER_UPPER_COUNT", "upper_node_count"),
                ("SMO_V3_HEADER_BRICK_COUNT", "brick_count"),
                ("SMO_V3_HEADER_LEAF_COUNT", "leaf_count"),
                ("SMO_V3_HEADER_PRIVATE_VOXEL_COUNT", "private_voxel_count"),
                ("SMO_V3_HEADER_NODES_OFFSET", "nodes_offset"),
                ("SMO_V3_HEADER_BRICKS_OFFSET", "bricks_offset"),
                ("SMO_V3_HEADER_RESIDUALS_OFFSET", "residuals_offset"),
                (
                    "SMO_V3_HEADER_PRIVATE_LEAVES_OFFSET",
                    "private_leaves_offset",
                ),
                ("SMO_V3_HEADER_PRIVATE_FLAGS_OFFSET", "private_flags_offset"),
                (
                    "SMO_V3_HEADER_PRIVATE_CORNERS_OFFSET",
                    "private_corners_offset",
                ),
            ],
        ),
        // Relative to a brick record, which starts at word bricks_offset / 4 + b · SMO_BRICK_WORDS.
        (
            &BRICK,
            &[
                ("SMO_BRICK_OCCUPANCY", "occupancy"),
                ("SMO_BRICK_PRIVATE", "private"),
                ("SMO_BRICK_PLANE_A", "plane_a"),
                ("SMO_BRICK_PLANE_B", "plane_b"),
                ("SMO_BRICK_PLANE_C", "plane_c"),
                ("SMO_BRICK_PLANE_D", "plane_d"),
                ("SMO_BRICK_RESIDUALS", "residuals"),
                ("SMO_BRICK_FIRST_PRIVATE_LEAF", "first_private_leaf"),
            ],
        ),
    ]
};

/// Most bricks of a 3.0 file the kernel traces: it numbers a leaf `brick · 64 + cell` and marks
/// a shared leaf's voxel with the bit above (`SMO_SHARED_VOXEL`), so both fit 32 bits. A file
/// with more (over 1 GiB of brick records alone) is refused on upload.
pub const MAX_GPU_BRICKS: u32 = 1 << 25;

/// `const` declarations of the brick layout the kernel decodes (3.0): record size, levels, point
/// grid edge, residual word, and per code width the residual widths (byte k: width code k), the
/// plane's fraction bits and Q, from `sdfmo_format`'s definitions.
fn brick_constants_wgsl() -> Vec<String> {
    use sdfmo_format::quant::max_code;
    use sdfmo_format::{plane_fraction_bits, residual_widths, ValueBits};
    use sdfmo_format::{BRICK_LEVELS, BRICK_POINT_EDGE, BRICK_RECORD_SIZE, RESIDUAL_OFFSET_BITS};
    let mut lines = vec![
        const_u32("SMO_V3_MAJOR", sdfmo_format::V3_VERSION_MAJOR),
        const_u32("SMO_BRICK_WORDS", BRICK_RECORD_SIZE / 4),
        const_u32("SMO_BRICK_LEVELS", BRICK_LEVELS),
        const_u32("SMO_BRICK_POINT_EDGE", BRICK_POINT_EDGE),
        const_u32("SMO_RESIDUAL_OFFSET_BITS", RESIDUAL_OFFSET_BITS),
        const_u32("SMO_SHARED_VOXEL", MAX_GPU_BRICKS * 64),
    ];
    for bits in [ValueBits::Eight, ValueBits::Sixteen] {
        let n = bits.bits();
        let widths = residual_widths(bits)
            .iter()
            .enumerate()
            .fold(0u32, |acc, (k, w)| acc | w << (8 * k));
        lines.push(format!(
            "const SMO_RESIDUAL_WIDTHS_{n}: u32 = {widths:#010x}u;"
        ));
        lines.push(const_u32(
            &format!("SMO_PLANE_FRACTION_BITS_{n}"),
            plane_fraction_bits(bits),
        ));
        lines.push(format!(
            "const SMO_MAX_CODE_{n}: i32 = {}i;",
            max_code(bits)
        ));
    }
    lines
}

/// `const` declarations for [`HEADER_WORDS`]: for each field its word (`NAME`, the low word of
/// a 64-bit field) and, for a field narrower than a word, its bit shift (`NAME_SHIFT`); then the
/// level table's start and stride in words. Panics on a name not in its table (a test runs it).
fn header_words_wgsl() -> Vec<String> {
    use sdfmo_format::{FLAG_CLIP_VOXELS, LOD_HEADER_FIXED, LOD_LEVEL_ENTRY};
    let mut lines = Vec::new();
    for (table, words) in HEADER_WORDS {
        for &(wgsl, name) in words {
            let field = table
                .iter()
                .find(|f| f.name == name)
                .unwrap_or_else(|| panic!("no header field {name}"));
            lines.push(const_u32(wgsl, field.offset / 4));
            if field.size < 4 {
                lines.push(const_u32(&format!("{wgsl}_SHIFT"), field.offset % 4 * 8));
            }
        }
    }
    lines.push(const_u32("SMO_LOD_TABLE", LOD_HEADER_FIXED / 4));
    lines.push(const_u32("SMO_LOD_ENTRY", LOD_LEVEL_ENTRY / 4));
    lines.push(const_u32("SMO_FLAG_CLIP_VOXELS", FLAG_CLIP_VOXELS));
    lines
}

/// The traversal and ray–voxel library, binding 0 only: [`kernel_constants_wgsl`] followed by
/// `src/sdfmo.wgsl`. Include it in an engine's own pipeline.
pub fn trace_wgsl() -> String {
    format!("{}\n{TRACE_WGSL_BODY}", kernel_constants_wgsl())
}

/// `src/render.wgsl` as written: the image kernel without the uniform struct it shares with the
/// host ([`render_wgsl`] puts it before it).
const RENDER_WGSL_BODY: &str = include_str!("render.wgsl");

/// The image kernel: one primary ray per pixel, shaded. The uniform `SmoRenderParams`
/// generated from the host's struct, followed by `src/render.wgsl`; needs [`trace_wgsl`]
/// before it ([`shader_source`]).
pub fn render_wgsl() -> String {
    format!("{}\n{RENDER_WGSL_BODY}", renderer::params_wgsl())
}

/// The compute entry point of [`render_wgsl`] that traces: each workgroup draws one listed tile
/// of [`WORKGROUP_SIZE`]² pixels (binding 5).
pub const ENTRY_POINT: &str = "smo_render";

/// The entry point of [`render_wgsl`] that fills the listed tiles with background, without
/// tracing (the tiles no primary ray of which meets the octree's occupied box).
pub const BACKGROUND_ENTRY_POINT: &str = "smo_background";

/// Workgroup edge of [`ENTRY_POINT`] and [`BACKGROUND_ENTRY_POINT`] (`@workgroup_size(8, 8,
/// 1)`), the edge of a tile.
pub const WORKGROUP_SIZE: u32 = 8;

/// The complete shader module: [`trace_wgsl`] followed by [`render_wgsl`].
pub fn shader_source() -> String {
    format!("{}\n{}", trace_wgsl(), render_wgsl())
}
