//! `sdfmo info`: what a mesh is made of.

use std::fmt::Write as _;
use std::io::Read as _;
use std::path::Path;

use anyhow::Context;
use sdf_multioctree::format::compressed::COMPRESSED_MAGIC;
use sdf_multioctree::format::{
    decode_levels_stats, is_brick_levels, is_v3, read_smo, BrickOctree, BrickOctreeView,
    FormatError, LevelBlockStats, LevelEntry, LodOctree, PackedOctree, SmoFile, SmoRead, MAGIC,
    MAX_FILE_SIZE,
};
use serde_json::json;

use crate::args::InfoArgs;
use crate::commands::load_input;
use crate::output::{json_f32, print_json, print_text};

/// Prints the triangle, vertex, part and component counts, the open and non-manifold edges, the
/// watertight flag, the bounds and what loading cleaned up.
pub fn run(args: &InfoArgs) -> anyhow::Result<()> {
    if let Some(path) = args.mesh.as_deref() {
        if is_smo(path) {
            return run_smo(path, args.json);
        }
    }
    let input = load_input(args.mesh.as_deref())?;
    let m = &input.mesh;
    let topo = m.topology();
    let b = m.bounds();
    let size = b.max - b.min;
    if args.json {
        let clean = input.report.as_ref().map(|r| {
            json!({
                "input_vertices": r.input_vertices,
                "input_triangles": r.input_triangles,
                "welded_vertices": r.welded_vertices,
                "unreferenced_vertices": r.unreferenced_vertices,
                "degenerate_triangles": r.degenerate_triangles,
                "duplicate_triangles": r.duplicate_triangles,
            })
        });
        return print_json(&json!({
            "source": input.source,
            "format": input.format,
            "part_names": input.part_names,
            "triangles": m.triangle_count(),
            "vertices": m.vertex_count(),
            "parts": m.part_count(),
            "components": topo.component_count,
            "boundary_edges": topo.boundary_edges,
            "non_manifold_edges": topo.non_manifold_edges,
            "watertight": topo.watertight,
            "bounds": {
                "min": b.min.to_array().map(json_f32),
                "max": b.max.to_array().map(json_f32),
            },
            "clean": clean,
        }));
    }
    let mut s = format!(
        "{}\n  triangles           {}\n  vertices            {}\n  parts               {}\n  \
         components          {}\n  boundary edges      {}\n  non-manifold edges  {}\n  \
         watertight          {}\n  bounds              [{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}]\n  \
         size                {:.6} x {:.6} x {:.6}\n",
        input.source,
        m.triangle_count(),
        m.vertex_count(),
        m.part_count(),
        topo.component_count,
        topo.boundary_edges,
        topo.non_manifold_edges,
        if topo.watertight { "yes" } else { "no" },
        b.min.x,
        b.min.y,
        b.min.z,
        b.max.x,
        b.max.y,
        b.max.z,
        size.x,
        size.y,
        size.z,
    );
    if let Some(r) = &input.report {
        s.push_str(&format!(
            "  cleaned             {} of {} input vertices welded, {} unreferenced dropped; \
             {} degenerate and {} duplicate of {} input triangles removed\n",
            r.welded_vertices,
            r.input_vertices,
            r.unreferenced_vertices,
            r.degenerate_triangles,
            r.duplicate_triangles,
            r.input_triangles
        ));
    }
    print_text(&s)
}

/// Whether the file starts with the `.smo` magic (an unreadable file is left to the mesh
/// loader, whose error names it).
fn is_smo(path: &Path) -> bool {
    file_magic(path).is_some_and(|m| m == MAGIC || m == COMPRESSED_MAGIC)
}

/// The first eight bytes of a regular file (`None` for anything else or a shorter file).
fn file_magic(path: &Path) -> Option<[u8; 8]> {
    // Only a regular file is opened: opening a FIFO blocks until a writer comes (hostile.rs).
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return None;
    }
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .ok()
        .map(|()| head)
}

/// One level of a `.smo` file as `info` lists it: level, bytes, and the counts when loaded.
fn level_json(e: &LevelEntry, octree: Option<&PackedOctree>) -> serde_json::Value {
    json!({
        "level": e.level,
        "offset": e.offset,
        "bytes": e.size,
        "loaded": octree.is_some(),
        "leaves": octree.map(|o| o.leaf_count()),
        "voxels": octree.map(|o| o.voxel_count()),
        "surface_voxels": octree.map(|o| o.surface_voxel_count()),
    })
}

/// `sdfmo info FILE.smo`: the levels (one for a 1.x file) with leaves, voxels and bytes. A
/// file with levels may be a prefix: its complete levels are listed as loaded, the others with
/// their declared bytes only.
fn run_smo(path: &Path, as_json: bool) -> anyhow::Result<()> {
    let cannot = || format!("cannot read octree {}", path.display());
    // Header first: a header declaring another size than the file has is refused before the
    // body is read (a prefix of a file with levels is accepted).
    let bytes = read_smo(path, MAX_FILE_SIZE, SmoRead::Prefix).map_err(|e| match e {
        FormatError::Io(io) => anyhow::Error::new(io),
        e => anyhow::Error::new(e).context(cannot()),
    })?;
    if is_v3(&bytes) {
        let b = BrickOctree::new(&bytes[..])
            .map_err(|e: FormatError| anyhow::Error::new(e))
            .with_context(cannot)?;
        return print_v3(path, &b, as_json);
    }
    // 4.0: how each level block was coded (bricks, and how many were predicted).
    let mut blocks: Vec<LevelBlockStats> = Vec::new();
    let (version, file_size, levels): (String, u64, Vec<(LevelEntry, Option<PackedOctree>)>) =
        if is_brick_levels(&bytes) {
            let (p, stats) = decode_levels_stats(&bytes).with_context(cannot)?;
            blocks = stats;
            let mut loaded = p.octree.levels().to_vec().into_iter();
            let rows = p.declared.iter().map(|e| (*e, loaded.next())).collect();
            let version = format!("4.{} (levels of bricks)", p.minor_version);
            (version, p.file_size, rows)
        } else if SmoFile::has_levels(&bytes) {
            let p = LodOctree::from_prefix(&bytes).with_context(cannot)?;
            let loaded = p.octree.levels().to_vec();
            let mut loaded = loaded.into_iter();
            let rows = p.declared.iter().map(|e| (*e, loaded.next())).collect();
            ("2.0 (levels)".to_string(), p.file_size, rows)
        } else {
            let o = PackedOctree::from_bytes(&bytes)
                .map_err(|e: FormatError| anyhow::Error::new(e))
                .with_context(cannot)?;
            let e = LevelEntry {
                level: o.depth(),
                offset: 0,
                size: o.byte_size() as u64,
            };
            ("1.x".to_string(), o.byte_size() as u64, vec![(e, Some(o))])
        };
    // A compressed file is read whole and decoded: its size on disk beside the `.smo`'s.
    let stored = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let compressed = file_magic(path) == Some(COMPRESSED_MAGIC);
    if as_json {
        return print_json(&json!({
            "source": path.display().to_string(),
            "kind": "octree",
            "version": version,
            "file_size": file_size,
            "bytes_read": bytes.len(),
            "compressed": compressed,
            "stored_bytes": stored,
            "levels": levels
                .iter()
                .enumerate()
                .map(|(i, (e, o))| {
                    let mut j = level_json(e, o.as_ref());
                    if let Some(b) = blocks.get(i) {
                        j["bricks"] = json!(b.bricks);
                        j["bricks_relative_occupancy"] = json!(b.relative_bricks);
                        j["bricks_coarse_points"] = json!(b.coarse_bricks);
                    }
                    j
                })
                .collect::<Vec<_>>(),
        }));
    }
    let mut s = format!(
        "{}\n  .smo {version}, {file_size} bytes ({} read)\n",
        path.display(),
        bytes.len()
    );
    if compressed {
        let _ = writeln!(
            s,
            "  compressed: {stored} bytes on disk ({:.1}x smaller)",
            bytes.len() as f64 / stored.max(1) as f64
        );
    }
    for (i, (e, o)) in levels.iter().enumerate() {
        match o {
            Some(o) => {
                let _ = write!(
                    s,
                    "  level {:>2}  leaves {:>9}  voxels {:>9} ({} surface)  {:>10} bytes",
                    e.level,
                    o.leaf_count(),
                    o.voxel_count(),
                    o.surface_voxel_count(),
                    e.size
                );
                match blocks.get(i) {
                    // The coarsest level has no level before it.
                    Some(b) if i == 0 => {
                        let _ = writeln!(s, "  {} bricks", b.bricks);
                    }
                    Some(b) => {
                        let _ = writeln!(
                            s,
                            "  {} bricks ({} with occupancy and {} with points from the level before)",
                            b.bricks, b.relative_bricks, b.coarse_bricks
                        );
                    }
                    None => s.push('\n'),
                }
            }
            None => {
                let _ = writeln!(
                    s,
                    "  level {:>2}  not in the {} bytes read  {:>10} bytes at {}",
                    e.level,
                    bytes.len(),
                    e.size,
                    e.offset
                );
            }
        }
    }
    print_text(&s)
}

/// `sdfmo info` of a 3.x file: its counts, bytes per voxel and section sizes.
fn print_v3(path: &Path, b: &BrickOctreeView<'_>, as_json: bool) -> anyhow::Result<()> {
    let stored = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let compressed = file_magic(path) == Some(COMPRESSED_MAGIC);
    let z = b.section_sizes();
    let voxels = b.voxel_count().max(1) as f64;
    if as_json {
        return print_json(&json!({
            "source": path.display().to_string(),
            "kind": "octree",
            "version": format!("3.{} (bricks)", b.version_minor()),
            "file_size": z.total,
            "compressed": compressed,
            "stored_bytes": stored,
            "depth": b.depth(),
            "bits": b.meta().bits.bits(),
            "bricks": b.brick_count(),
            "leaves": b.leaf_count(),
            "voxels": b.voxel_count(),
            "surface_voxels": b.surface_voxel_count(),
            "private_leaves": b.private_leaf_count(),
            "private_voxels": b.private_voxel_count(),
            "wide_voxels": b.wide_voxel_count(),
            "bytes_per_voxel": z.total as f64 / voxels,
            "sections": {
                "header": z.header,
                "nodes": z.nodes,
                "bricks": z.bricks,
                "residuals": z.residuals,
                "private_leaves": z.private_leaves,
                "private_flags": z.private_flags,
                "private_corners": z.private_corners,
                "padding": z.padding,
                "checksum": z.checksum,
            },
        }));
    }
    let mut s = format!(
        "{}\n  .smo 3.{} (bricks), {} bytes, {:.2} bytes per voxel (traced as it is)\n",
        path.display(),
        b.version_minor(),
        z.total,
        z.total as f64 / voxels
    );
    if compressed {
        let _ = writeln!(
            s,
            "  compressed: {stored} bytes on disk ({:.1}x smaller, {:.2} bytes per voxel)",
            z.total as f64 / stored.max(1) as f64,
            stored as f64 / voxels
        );
    }
    let _ = writeln!(
        s,
        "  depth {}, {}-bit, bricks {}, leaves {}, voxels {} ({} surface), private {} leaves / {} voxels ({} wide)",
        b.depth(),
        b.meta().bits.bits(),
        b.brick_count(),
        b.leaf_count(),
        b.voxel_count(),
        b.surface_voxel_count(),
        b.private_leaf_count(),
        b.private_voxel_count(),
        b.wide_voxel_count()
    );
    let _ = writeln!(
        s,
        "  sections (bytes): header {}, nodes {}, bricks {}, residuals {}, private leaves {}, \
         private flags {}, private corners {}, padding {}, checksum {}",
        z.header,
        z.nodes,
        z.bricks,
        z.residuals,
        z.private_leaves,
        z.private_flags,
        z.private_corners,
        z.padding,
        z.checksum
    );
    print_text(&s)
}
