//! The WGSL compiles and validates with naga (no adapter needed), the documented binding
//! layout is the one the shader declares, and the constants it shares with the CPU kernel have
//! the Rust values (the uniform's layout is checked against the Rust struct in
//! `src/renderer.rs`'s tests).

use naga::valid::{Capabilities, ValidationFlags, Validator};

fn module(source: &str) -> naga::Module {
    naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{}", e.emit_to_string(source)))
}

#[test]
fn render_shader_validates() {
    let source = sdfmo_gpu::shader_source();
    let m = module(&source);
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&m)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&source)));
    for name in [sdfmo_gpu::ENTRY_POINT, sdfmo_gpu::BACKGROUND_ENTRY_POINT] {
        assert!(
            m.entry_points.iter().any(|e| e.name == name
                && e.workgroup_size == [sdfmo_gpu::WORKGROUP_SIZE, sdfmo_gpu::WORKGROUP_SIZE, 1]),
            "{name}"
        );
    }
}

#[test]
fn library_alone_validates_and_binds_only_the_octree() {
    let m = module(&sdfmo_gpu::trace_wgsl());
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&m)
        .expect("sdfmo.wgsl validates on its own");
    let bindings: Vec<_> = m
        .global_variables
        .iter()
        .filter_map(|(_, g)| {
            g.binding
                .as_ref()
                .map(|b| (g.name.clone(), b.group, b.binding))
        })
        .collect();
    assert_eq!(bindings, vec![(Some("smo".to_string()), 0, 0)]);
}

#[test]
fn render_bindings_match_the_documented_layout() {
    let m = module(&sdfmo_gpu::shader_source());
    let mut bindings: Vec<_> = m
        .global_variables
        .iter()
        .filter_map(|(_, g)| {
            g.binding
                .as_ref()
                .map(|b| (b.binding, g.name.clone().unwrap_or_default()))
        })
        .collect();
    bindings.sort();
    let names: Vec<_> = bindings.iter().map(|(b, n)| format!("{b}:{n}")).collect();
    assert_eq!(
        names,
        ["0:smo", "1:params", "2:pixels", "3:colors", "4:rays", "5:tiles"]
    );
}

/// The value of the module's `const NAME` (an f32 as its bits, or a u32).
fn const_value(m: &naga::Module, name: &str) -> u64 {
    let (_, c) = m
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no const {name}"));
    match m.global_expressions[c.init] {
        naga::Expression::Literal(naga::Literal::F32(v)) => u64::from(v.to_bits()),
        naga::Expression::Literal(naga::Literal::U32(v)) => u64::from(v),
        naga::Expression::Literal(naga::Literal::I32(v)) => v as u64,
        ref e => panic!("{name} is {e:?}"),
    }
}

/// Issue 20: the constants the WGSL shares with the CPU kernel were written twice, in Rust and
/// in WGSL. They are now generated from the Rust values (`kernel_constants_wgsl`); here the
/// compiled module has exactly those values, and exactly the literals the WGSL used to hold
/// (so images are unchanged).
#[test]
fn shared_constants_have_the_rust_values() {
    use sdfmo_format::kernel::{CLIP_TOLERANCE, MAX_POLISH_STEPS, ROOT_REL_TOLERANCE, TINY_DIR};
    let m = module(&sdfmo_gpu::shader_source());
    let f = |v: f32| u64::from(v.to_bits());
    let expected = [
        ("SMO_FAR", f(sdfmo_gpu::SMO_FAR), "3.0e38"),
        ("SMO_MAX_FINITE", f(f32::MAX), "3.40282347e38"),
        ("SMO_MIN_POSITIVE", f(f32::MIN_POSITIVE), "1.17549435e-38"),
        ("SMO_TINY_DIR", f(TINY_DIR), "1e-30"),
        // The traversal stack's levels (issue 35; it replaced SMO_STACK_SIZE, 50 cells).
        ("SMO_MAX_DEPTH", u64::from(sdfmo_format::MAX_DEPTH), "16u"),
        ("SMO_MAX_POLISH_STEPS", u64::from(MAX_POLISH_STEPS), "32u"),
        ("SMO_REL_TOLERANCE", f(ROOT_REL_TOLERANCE), "1e-6"),
        ("SMO_CLIP_TOLERANCE", f(CLIP_TOLERANCE), "1e-5"),
        (
            "SMO_MAX_CLIP_VOXELS",
            sdfmo_format::MAX_CLIP_VOXELS_PER_LEAF as u64,
            "8u",
        ),
    ];
    for (name, value, old_literal) in expected {
        assert_eq!(const_value(&m, name), value, "{name}");
        // The literal the hand-written WGSL had, read by naga as it read it then.
        let ty = if old_literal.ends_with('u') {
            "u32"
        } else {
            "f32"
        };
        let old = module(&format!("const {name}: {ty} = {old_literal};"));
        assert_eq!(const_value(&old, name), value, "{name} changed value");
    }
    // Every shared constant is generated, none is written in the WGSL files.
    let generated = sdfmo_gpu::kernel_constants_wgsl();
    assert_eq!(
        generated.matches("const ").count(),
        expected.len() + HEADER_WORDS.len() + BRICK_WORDS.len() + 1 // and SMO_FLAG_CLIP_VOXELS
    );
    let written = sdfmo_gpu::shader_source().replace(&generated, "");
    let names = expected
        .iter()
        .map(|e| e.0)
        .chain(HEADER_WORDS.iter().map(|e| e.0))
        .chain(BRICK_WORDS.iter().map(|e| e.0))
        .chain(["SMO_FLAG_CLIP_VOXELS"]);
    for name in names {
        assert!(
            !written.contains(&format!("const {name}")),
            "{name} written by hand"
        );
    }
}

/// The header words the kernel reads, with the word index (or bit shift) the WGSL used to have
/// as a literal before they were generated from the format's field tables.
const HEADER_WORDS: [(&str, u64); 20] = [
    ("SMO_HEADER_FLAGS", 4),
    ("SMO_HEADER_DEPTH", 5),
    ("SMO_HEADER_DEPTH_SHIFT", 0),
    ("SMO_HEADER_VALUE_BITS", 5),
    ("SMO_HEADER_VALUE_BITS_SHIFT", 8),
    ("SMO_HEADER_INNER_COUNT", 10),
    ("SMO_HEADER_LEAF_COUNT", 11),
    ("SMO_HEADER_VOXEL_COUNT", 12),
    ("SMO_HEADER_NODES_OFFSET", 16),
    ("SMO_HEADER_LEAVES_OFFSET", 20),
    ("SMO_HEADER_SURFACE_OFFSET", 24),
    ("SMO_HEADER_CORNERS_OFFSET", 28),
    ("SMO_HEADER_CORNERS_SIZE", 30),
    ("SMO_LOD_HEADER_DEPTH", 5),
    ("SMO_LOD_HEADER_DEPTH_SHIFT", 0),
    ("SMO_LOD_HEADER_COARSEST", 5),
    ("SMO_LOD_HEADER_COARSEST_SHIFT", 8),
    ("SMO_LOD_LEVEL_OFFSET", 0),
    ("SMO_LOD_TABLE", 16),
    ("SMO_LOD_ENTRY", 4),
];

/// What the kernel reads of a 3.0 file, as FORMAT.md ("Bricks (version 3.0)") places it: header
/// words (and bit shifts), brick-record words relative to the record, and the layout's
/// constants (the residual widths one byte per width code). Generated from `sdfmo_format`'s
/// `V3_HEADER_FIELDS`, `BRICK_RECORD_FIELDS` and definitions.
const BRICK_WORDS: [(&str, u64); 43] = [
    ("SMO_HEADER_VERSION_MAJOR", 2),
    ("SMO_HEADER_VERSION_MAJOR_SHIFT", 0),
    ("SMO_V3_HEADER_FLAGS", 4),
    // 3.1 (narrow private voxels): the minor version picks the private layout.
    ("SMO_V3_HEADER_VERSION_MINOR", 2),
    ("SMO_V3_HEADER_VERSION_MINOR_SHIFT", 16),
    ("SMO_V3_HEADER_DEPTH", 5),
    ("SMO_V3_HEADER_DEPTH_SHIFT", 0),
    ("SMO_V3_HEADER_VALUE_BITS", 5),
    ("SMO_V3_HEADER_VALUE_BITS_SHIFT", 8),
    ("SMO_V3_HEADER_UPPER_COUNT", 10),
    ("SMO_V3_HEADER_BRICK_COUNT", 11),
    ("SMO_V3_HEADER_LEAF_COUNT", 12),
    ("SMO_V3_HEADER_PRIVATE_VOXEL_COUNT", 17),
    ("SMO_V3_HEADER_NODES_OFFSET", 20),
    ("SMO_V3_HEADER_BRICKS_OFFSET", 24),
    ("SMO_V3_HEADER_RESIDUALS_OFFSET", 28),
    ("SMO_V3_HEADER_PRIVATE_LEAVES_OFFSET", 32),
    ("SMO_V3_HEADER_PRIVATE_FLAGS_OFFSET", 36),
    ("SMO_V3_HEADER_PRIVATE_CORNERS_OFFSET", 40),
    ("SMO_BRICK_OCCUPANCY", 0),
    ("SMO_BRICK_PRIVATE", 2),
    ("SMO_BRICK_PLANE_A", 4),
    ("SMO_BRICK_PLANE_A_SHIFT", 0),
    ("SMO_BRICK_PLANE_B", 4),
    ("SMO_BRICK_PLANE_B_SHIFT", 16),
    ("SMO_BRICK_PLANE_C", 5),
    ("SMO_BRICK_PLANE_C_SHIFT", 0),
    ("SMO_BRICK_PLANE_D", 5),
    ("SMO_BRICK_PLANE_D_SHIFT", 16),
    ("SMO_BRICK_RESIDUALS", 6),
    ("SMO_BRICK_FIRST_PRIVATE_LEAF", 7),
    ("SMO_V3_MAJOR", 3),
    ("SMO_BRICK_WORDS", 8),
    ("SMO_BRICK_LEVELS", 2),
    ("SMO_BRICK_POINT_EDGE", 5),
    ("SMO_RESIDUAL_OFFSET_BITS", 30),
    ("SMO_SHARED_VOXEL", 1 << 31),
    ("SMO_RESIDUAL_WIDTHS_8", 0x0804_0200),
    ("SMO_PLANE_FRACTION_BITS_8", 4),
    ("SMO_MAX_CODE_8", 127),
    ("SMO_RESIDUAL_WIDTHS_16", 0x1008_0400),
    ("SMO_PLANE_FRACTION_BITS_16", 0),
    ("SMO_MAX_CODE_16", 32767),
];

/// The 3.0 words and constants are the format's (FORMAT.md's offsets, checked as literals),
/// and a shared leaf's voxel number (`SMO_SHARED_VOXEL | brick · 64 + cell`) has room for every
/// brick the host uploads (`MAX_GPU_BRICKS`) below its marker bit, the top bit of a u32.
#[test]
fn brick_words_are_the_format_tables() {
    let m = module(&sdfmo_gpu::shader_source());
    for (name, value) in BRICK_WORDS {
        assert_eq!(const_value(&m, name), value, "{name}");
    }
    assert_eq!(u64::from(sdfmo_gpu::MAX_GPU_BRICKS) * 64, 1 << 31);
}

/// The header word indices come from `sdfmo_format`'s tables and equal what the kernel read
/// before (so images are unchanged); the clip flag is the format's.
#[test]
fn header_words_are_the_format_tables() {
    let m = module(&sdfmo_gpu::shader_source());
    for (name, word) in HEADER_WORDS {
        assert_eq!(const_value(&m, name), word, "{name}");
    }
    assert_eq!(
        const_value(&m, "SMO_FLAG_CLIP_VOXELS"),
        u64::from(sdfmo_format::FLAG_CLIP_VOXELS)
    );
}
