//! `FORMAT.md` (the `.smo` specification, shipped in the package) against the code: the header
//! table and the worked example's bytes.

use glam::Vec3;
use sdfmo_format::{
    decode_levels, decode_levels_prefix, encode_levels, plane_predict, point_mask, BrickNode,
    BrickOctree, BrickOctreeView, FormatError, HeaderField, LeafInput, LodOctree, OctreeMeta,
    PackedOctree, ValueBits, Voxel, BRICK_RECORD_FIELDS, HEADER_FIELDS, HEADER_SIZE,
    LOD_HEADER_FIELDS, LOD_HEADER_FIXED, LOD_LEVEL_ENTRY, LOD_LEVEL_FIELDS, LOD_TRAILER_FIELDS,
    V3_HEADER_FIELDS, V3_HEADER_SIZE,
};

fn format_md() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/FORMAT.md");
    std::fs::read_to_string(path).expect("FORMAT.md")
}

/// The rows `| offset | size | type | `name` | … |` of the section whose heading starts with
/// `heading`, up to the next `## ` heading: `(offset column, size, name)`.
fn documented_rows(md: &str, heading: &str) -> Vec<(String, usize, String)> {
    let start = md.find(&format!("\n{heading}")).expect("the section");
    let body = &md[start + 1..];
    let end = body[3..].find("\n## ").map_or(body.len(), |e| e + 3);
    body[..end]
        .lines()
        .filter_map(|line| {
            let cells: Vec<&str> = line.split('|').map(str::trim).collect();
            // ["", offset, size, type, `name`, meaning, ""]
            let size = cells.get(2)?.parse().ok()?;
            let name = cells.get(4)?.trim_matches('`').to_string();
            Some((cells[1].to_string(), size, name))
        })
        .collect()
}

fn code_rows(
    table: &[HeaderField],
    offset: impl Fn(usize) -> String,
) -> Vec<(String, usize, String)> {
    table
        .iter()
        .map(|f| (offset(f.offset), f.size, f.name.to_string()))
        .collect()
}

#[test]
fn docs_header_table_matches_code() {
    let documented = documented_rows(&format_md(), "## Header");
    assert_eq!(documented, code_rows(&HEADER_FIELDS, |o| o.to_string()));
    let last = HEADER_FIELDS.last().unwrap();
    assert_eq!(last.offset + last.size, HEADER_SIZE);
}

/// The 2.0 header's table, row for row: the fixed fields at their offsets, the level table's
/// entries at `64 + 16·i` (named `offset_i`, `size_i` in the text), the trailer at `H − 8`.
#[test]
fn docs_lod_header_table_matches_code() {
    let documented = documented_rows(&format_md(), "## Levels of detail");
    let mut code = code_rows(&LOD_HEADER_FIELDS, |o| o.to_string());
    code.extend(LOD_LEVEL_FIELDS.iter().map(|f| {
        (
            format!("{} + {LOD_LEVEL_ENTRY}·i", LOD_HEADER_FIXED + f.offset),
            f.size,
            format!("{}_i", f.name),
        )
    }));
    code.extend(code_rows(&LOD_TRAILER_FIELDS, |o| format!("H − {}", 8 - o)));
    assert_eq!(documented, code);
}

/// Bytes of the hex dump between the worked-example markers.
fn documented_example(md: &str) -> Vec<u8> {
    documented_hex(md, "worked-example-hex")
}

/// Bytes of the hex dump between the markers `<!-- NAME: begin -->` and `<!-- NAME: end -->`.
fn documented_hex(md: &str, name: &str) -> Vec<u8> {
    let begin = md
        .find(&format!("<!-- {name}: begin -->"))
        .expect("begin marker");
    let end = md
        .find(&format!("<!-- {name}: end -->"))
        .expect("end marker");
    let mut bytes = Vec::new();
    for line in md[begin..end].lines() {
        // Dump lines: a 4-digit hex address, two spaces, then hex bytes.
        let Some((addr, rest)) = line.split_once("  ") else {
            continue;
        };
        let Ok(addr) = usize::from_str_radix(addr, 16) else {
            continue;
        };
        assert_eq!(addr, bytes.len(), "address column of {line:?}");
        bytes.extend(
            rest.split_whitespace()
                .map(|w| u8::from_str_radix(w, 16).expect("hex byte")),
        );
    }
    bytes
}

#[test]
fn docs_worked_example_matches_writer() {
    let v = |corners: [f32; 8], surface: bool| Voxel {
        corners,
        surface,
        clip: false,
    };
    let leaves = vec![
        LeafInput {
            coord: [1, 0, 0],
            voxels: vec![v([-3.0, -1.0, 1.0, 3.0, -0.5, 0.5, 1.5, 2.0], false)],
        },
        LeafInput {
            coord: [0, 1, 1],
            voxels: vec![
                v([0.9, 0.4, 0.3, -0.2, 0.5, 0.0, -0.1, -0.6], false),
                v([0.2, 0.2, -0.2, -0.2, 0.2, 0.2, -0.2, -0.2], true),
            ],
        },
    ];
    let meta = OctreeMeta {
        depth: 1,
        bits: ValueBits::Eight,
        center: Vec3::new(1.0, 0.0, -2.0),
        scale: 0.5,
    };
    let leaves_again = leaves.clone();
    let o = PackedOctree::from_leaves(meta, leaves).unwrap();
    let bytes = o.to_bytes();
    assert_eq!(bytes, documented_example(&format_md()));
    assert_eq!(bytes.len(), 196);
    // The traversal walked through in the text.
    let root = o.root().unwrap();
    assert_eq!(o.child_mask(root), 0x18);
    let leaf = o.child(root, 4).unwrap();
    assert_eq!(leaf.index(), 2);
    assert_eq!(o.leaf_voxels(leaf), 2..3);
    assert_eq!(o.voxel_codes(2), [-127, -73, 73, 127, -37, 37, 110, 127]);
    assert!(o.voxel_is_surface(1));

    // The note on a clip bit for voxel 2 (the leaf (1, 0, 0)'s voxel, stored last).
    let mut clipped = leaves_again;
    clipped[0].voxels[0].clip = true;
    let c = PackedOctree::from_leaves(meta, clipped).unwrap().to_bytes();
    assert_eq!(c.len(), 204);
    assert_eq!(u16::from_le_bytes([c[10], c[11]]), 1);
    assert_eq!(c[16], 7);
    assert_eq!(c[0xc0..0xc8], 4u64.to_le_bytes());
    assert_eq!(c[0x18..0x38], bytes[0x18..0x38]);
    assert_eq!(c[0x40..0xc0], bytes[0x40..0xc0]);
}

/// The worked example of a file with levels: its header byte for byte, its levels' places, and
/// the prefix rule as the text states it.
#[test]
fn docs_lod_example_matches_writer() {
    let meta = |depth| OctreeMeta {
        depth,
        bits: ValueBits::Eight,
        center: Vec3::new(1.0, 0.0, -2.0),
        scale: 0.5,
    };
    let mut corners = [0.5f32; 8];
    corners[0] = -0.5;
    let level0 = PackedOctree::from_leaves(
        meta(0),
        vec![LeafInput {
            coord: [0, 0, 0],
            voxels: vec![Voxel {
                corners,
                surface: false,
                clip: false,
            }],
        }],
    )
    .unwrap();
    assert_eq!(level0.byte_size(), 164);
    let md = format_md();
    let level1 = PackedOctree::from_bytes(&documented_example(&md)).unwrap();
    let lod = LodOctree::from_levels(vec![level0.clone(), level1.clone()]).unwrap();
    let bytes = lod.to_bytes();
    assert_eq!(bytes.len(), 468);
    assert_eq!(bytes[..104], documented_hex(&md, "lod-example-hex")[..]);
    assert_eq!(bytes[104..268], level0.as_bytes()[..]);
    assert!(bytes[268..272].iter().all(|&b| b == 0));
    assert_eq!(bytes[272..], level1.as_bytes()[..]);
    for cut in 268..468 {
        let p = LodOctree::from_prefix(&bytes[..cut]).unwrap();
        assert_eq!(p.octree.levels(), std::slice::from_ref(&level0));
    }
    for cut in 104..268 {
        assert!(matches!(
            LodOctree::from_prefix(&bytes[..cut]),
            Err(FormatError::Truncated { needed: 268, .. })
        ));
    }
    assert_eq!(LodOctree::from_prefix(&bytes).unwrap().octree, lod);
}

/// The input of the 3.0 worked example (FORMAT.md, section "Bricks"): a depth-2 octree (one
/// brick, the root) of two shared leaves and one private leaf of two voxels, its corners given
/// as codes (`value = code · dmax / 127`).
fn brick_example() -> PackedOctree {
    let meta = OctreeMeta {
        depth: 2,
        bits: ValueBits::Eight,
        center: Vec3::new(1.0, 0.0, -2.0),
        scale: 0.5,
    };
    let v = |codes: [i8; 8], surface: bool| Voxel {
        corners: codes.map(|c| f32::from(c) * meta.dmax() / 127.0),
        surface,
        clip: false,
    };
    let leaves = vec![
        LeafInput {
            coord: [0, 0, 0],
            voxels: vec![v([10, 10, 6, 6, 30, 30, 26, 26], false)],
        },
        LeafInput {
            coord: [1, 0, 0],
            voxels: vec![v([30, 30, 26, 26, 50, 50, 46, 47], false)],
        },
        LeafInput {
            coord: [0, 1, 1],
            voxels: vec![
                v([-5, 1, 7, 9, -3, 2, 8, 10], false),
                v([4, 4, -4, -4, 4, 4, -4, -4], true),
            ],
        },
    ];
    PackedOctree::from_leaves(meta, leaves).unwrap()
}

/// The 3.0 header's table and the brick record's, row for row.
#[test]
fn docs_v3_tables_match_code() {
    let md = format_md();
    let header = documented_rows(&md, "## Bricks (version 3.0)");
    assert_eq!(header, code_rows(&V3_HEADER_FIELDS, |o| o.to_string()));
    let last = V3_HEADER_FIELDS.last().unwrap();
    assert_eq!(last.offset + last.size, V3_HEADER_SIZE);
    let record = documented_rows(&md, "## Bricks: records");
    assert_eq!(record, code_rows(&BRICK_RECORD_FIELDS, |o| o.to_string()));
}

/// The 3.0 worked example: the encoder's bytes equal the dump, and the reading walked through
/// in the text.
#[test]
fn docs_brick_example_matches_writer() {
    let o = brick_example();
    let b = BrickOctree::encode(&o).unwrap();
    let bytes = b.as_bytes();
    assert_eq!(bytes, documented_hex(&format_md(), "brick-example-hex"));
    assert_eq!(bytes.len(), 268);
    // The sections as the table under the dump lists them.
    let sizes = b.section_sizes();
    assert_eq!(
        [
            sizes.header,
            sizes.nodes,
            sizes.bricks,
            sizes.residuals,
            sizes.private_leaves
        ],
        [176, 0, 32, 3, 24]
    );
    assert_eq!(
        [
            sizes.private_flags,
            sizes.private_corners,
            sizes.padding,
            sizes.checksum,
            sizes.total
        ],
        [8, 12, 9, 4, 268]
    );
    let v = BrickOctreeView::new(bytes).unwrap();
    assert_eq!(v.to_octree(), o);
    // As 3.0 (every private voxel wide, groups of 8): 260 bytes, the same octree.
    let v30 = BrickOctree::encode_minor(&o, 0).unwrap();
    assert_eq!(v30.as_bytes().len(), 260);
    assert_eq!(v30.to_octree(), o);
    let root = v.root().unwrap();
    assert_eq!(root, BrickNode::Brick(0));
    assert_eq!(v.child_mask(root), 0x01);
    let half = v.child(root, 0).unwrap();
    assert_eq!(v.child_mask(half), 0x19);
    let node = v.child(half, 4).unwrap();
    assert_eq!(node, BrickNode::Leaf { brick: 0, cell: 4 });
    let leaf = v.leaf(node).unwrap();
    assert!(leaf.is_shared());
    assert_eq!(v.voxel_codes(&leaf, 0), [30, 30, 26, 26, 50, 50, 46, 47]);
    assert_eq!(v.find_leaf([1, 0, 0]), Some(leaf));
    assert_eq!(point_mask(0x11).count_ones(), 12);
    assert_eq!(
        plane_predict([157, 322, -61, 3], [2, 1, 1], ValueBits::Eight),
        46
    );
    let private = v.find_leaf([0, 1, 1]).unwrap();
    assert_eq!(private.first_private_voxel(), Some(0));
    assert_eq!(v.voxel_codes(&private, 0), [-5, 1, 7, 9, -3, 2, 8, 10]);
    assert!(v.voxel_is_surface(&private, 1) && !v.voxel_is_surface(&private, 0));
}

/// A 4.0 file (every private voxel whole: the 4.0 worked example as FORMAT.md showed it before
/// 4.1) still decodes to the levels of the 4.1 example; a minor version above 1 is refused.
#[test]
fn brick_lod_version_4_0_still_decodes() {
    let hex = concat!(
        "89534d4f0d0a1a0a040000006800000000000000030202080000803f00000000000000c00000003fd100000000000000",
        "0000000000000000000000000000000068000000000000004300000000000000b0000000000000002100000000000000",
        "148d2bd600000000000000000100000001000000020000001200000003000000111900000000000000029d004201c3ff",
        "03000000400204fb010709fd02080a0404fcfc0404fcfcf0f9accf000000000001000000010000000000000000000000",
        "0400000000000000010cff00007f444fc4",
    );
    let old: Vec<u8> = (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect();
    assert_eq!(old.len(), 209);
    assert_eq!(old[10], 0, "minor version 0");
    let new = documented_hex(&format_md(), "brick-lod-example-hex");
    assert_eq!(new[10], 1, "minor version 1");
    assert_eq!(decode_levels(&old).unwrap(), decode_levels(&new).unwrap());
    let mut newer = new.clone();
    newer[10] = 2;
    assert!(matches!(
        decode_levels(&newer),
        Err(FormatError::UnsupportedVersion {
            major: 4,
            minor: 2,
            ..
        })
    ));
}

/// The 4.1 worked example: levels 2 (the 3.0 example's octree) and 3 (eight leaves under its
/// cell (0, 0, 0), codes twice the coarse field), encoded byte for byte as the dump, decoded
/// back, and its level-boundary prefix holding level 2.
#[test]
fn docs_brick_lod_example_matches_writer() {
    let coarse = brick_example();
    let meta = OctreeMeta {
        depth: 3,
        ..*coarse.meta()
    };
    let code = |x: u32, y: u32| 20.0 + 20.0 * x as f32 - 4.0 * y as f32;
    let leaves = (0..8u32)
        .map(|i| {
            let c = [i >> 2 & 1, i >> 1 & 1, i & 1];
            let corners = std::array::from_fn(|k| {
                let k = k as u32;
                code(c[0] + (k >> 2 & 1), c[1] + (k >> 1 & 1)) * meta.dmax() / 127.0
            });
            LeafInput {
                coord: c,
                voxels: vec![Voxel {
                    corners,
                    surface: false,
                    clip: false,
                }],
            }
        })
        .collect();
    let fine = PackedOctree::from_leaves(meta, leaves).unwrap();
    let lod = LodOctree::from_levels(vec![coarse.clone(), fine]).unwrap();
    let bytes = encode_levels(&lod).unwrap();
    assert_eq!(bytes, documented_hex(&format_md(), "brick-lod-example-hex"));
    let p = decode_levels_prefix(&bytes).unwrap();
    let places: Vec<(u64, u64)> = p.declared.iter().map(|e| (e.offset, e.size)).collect();
    assert_eq!(places, [(104, 64), (168, 33)]);
    assert_eq!(p.octree, lod);
    assert_eq!(bytes.len(), 201);
    let two = decode_levels_prefix(&bytes[..168]).unwrap();
    assert_eq!(two.octree.levels(), std::slice::from_ref(&coarse));
    // Level 3's record as the text reads it: mode, then one byte per coarse leaf above.
    assert_eq!(bytes[0xc0..0xc5], [0x01, 0x0c, 0xff, 0x00, 0x00]);
}
