//! `sdfmo build`: mesh → octree file.

use std::fmt::Write as _;

use anyhow::Context;
use sdf_multioctree::build::{self, BuildRequest, BuildSettings, BuildStats};
use sdf_multioctree::format::{
    decode_levels_prefix, encode_levels, BrickOctree, BRICK_LEVELS, BRICK_LOD_VERSION_MAJOR,
    BRICK_LOD_VERSION_MINOR,
};
use serde_json::json;

use crate::args::{BuildArgs, FormatArg};
use crate::commands::{load_input, memory_budget, Workers};
use crate::output::{check_output, ensure_parent, print_json, print_text};
use crate::progress;

/// The version `--lod` writes, as `--json` and the summary name it: levels of bricks (4.1) with
/// `--format 3`, else 2.0.
fn levels_version(format: FormatArg) -> String {
    if format == FormatArg::V3 {
        format!("{BRICK_LOD_VERSION_MAJOR}.{BRICK_LOD_VERSION_MINOR}")
    } else {
        "2.0".to_string()
    }
}

/// Builds the octree with a progress bar, saves it atomically and prints the statistics.
pub fn run(args: &BuildArgs) -> anyhow::Result<()> {
    // A bad destination fails now, not after the build.
    check_output(
        &args.output,
        "the octree file (-o)",
        &[sdf_multioctree::format::FILE_EXTENSION],
    )?;
    if args.format == FormatArg::V3 && args.depth < BRICK_LEVELS {
        anyhow::bail!(
            "--format 3 needs a depth of at least {BRICK_LEVELS} (a brick spans {BRICK_LEVELS} levels), got {}",
            args.depth
        );
    }
    if let Some(coarsest) = args.coarsest_level() {
        if args.format == FormatArg::V3 && coarsest < BRICK_LEVELS {
            anyhow::bail!(
                "--lod --format 3 needs a coarsest level of at least {BRICK_LEVELS} (a brick spans {BRICK_LEVELS} levels), got {coarsest}"
            );
        }
    }
    let input = load_input(args.mesh.as_deref())?;
    let settings = BuildSettings::new(args.depth, args.method.method(args.max_voxels))
        .with_bits(args.bits.bits())
        .with_margin(sdf_multioctree::DEFAULT_MARGIN)
        .with_sign(args.sign.mode())
        .with_fit_corners(args.fit_corners);
    let workers = Workers::new(args.threads)?;
    if let Some(coarsest) = args.coarsest_level() {
        return run_lod(args, &input, &settings, coarsest, &workers);
    }
    let budget = memory_budget(args.max_memory);
    let bar = progress::fraction(&format!("building {} depth {}", input.name, args.depth));
    let on_progress = |f: f32| progress::set_fraction(&bar, f);
    let built = workers.install(|| {
        BuildRequest::new(&input.mesh, settings)
            .memory_budget(budget)
            .progress(&on_progress)
            .octree()
    });
    bar.finish_and_clear();
    let (octree, stats) =
        built.with_context(|| format!("cannot build an octree of {}", input.source))?;
    ensure_parent(&args.output)?;
    let v3 = match args.format {
        FormatArg::V1 => None,
        FormatArg::V3 => {
            Some(BrickOctree::encode(&octree).context("cannot encode the octree as format 3")?)
        }
    };
    let file = v3.as_ref().map_or(octree.as_bytes(), |b| b.as_bytes());
    let stored = save(args, file)?;

    if args.json {
        let mut j = stats_json(&stats);
        j["mesh"] = json!(input.source);
        j["method"] = json!(args.method.name());
        j["depth"] = json!(args.depth);
        j["bits"] = json!(args.bits.count());
        if args.method == crate::args::MethodArg::Multi {
            j["max_voxels"] = json!(args.max_voxels);
        }
        j["output"] = json!(args.output.display().to_string());
        j["format"] = json!(v3
            .as_ref()
            .map_or("1.x".to_string(), |b| format!("3.{}", b.version_minor())));
        j["file_bytes"] = json!(file.len());
        j["compress_level"] = json!(args.compress_level());
        j["stored_bytes"] = json!(stored);
        let estimate = build::estimate_memory(&input.mesh, &settings);
        j["memory_estimate"] = json!(estimate.bytes);
        j["candidate_cells_estimate"] = json!(estimate.candidate_cells.round());
        j["memory_budget"] = json!(budget);
        return print_json(&j);
    }
    let mut s = headline(args, &input, &format!("depth {}", args.depth));
    s.push('\n');
    let _ = writeln!(
        s,
        "  nodes {}, leaves {}, voxels {} ({} surface), {} bytes ({:.3} MB), {:.1} ms",
        stats.nodes,
        stats.leaves,
        stats.voxels,
        stats.surface_voxels,
        stats.bytes,
        stats.bytes as f64 / 1e6,
        stats.build_ms
    );
    if let Some(b) = &v3 {
        let _ = writeln!(
            s,
            "  format 3.{}: {} bytes ({:.3} MB, {:.2} bytes per voxel; 1.x {:.2}), {} bricks, {} of {} voxels private",
            b.version_minor(),
            file.len(),
            file.len() as f64 / 1e6,
            file.len() as f64 / stats.voxels.max(1) as f64,
            stats.bytes as f64 / stats.voxels.max(1) as f64,
            b.brick_count(),
            b.private_voxel_count(),
            b.voxel_count()
        );
    }
    s.push_str(&stored_note(args, file.len(), stored, stats.voxels));
    let hist: Vec<String> = stats
        .voxels_per_leaf
        .iter()
        .enumerate()
        .filter(|(_, &n)| n > 0)
        .map(|(k, n)| format!("{k}:{n}"))
        .collect();
    let _ = writeln!(s, "  voxels per leaf (count:leaves) {}", hist.join(" "));
    if stats.cap_hits > 0 {
        let _ = writeln!(
            s,
            "  warning: {} leaves hit the cap of {} voxels (voxels were merged or dropped)",
            stats.cap_hits, args.max_voxels
        );
    }
    let phases: Vec<String> = stats
        .phases
        .iter()
        .map(|(name, ms)| format!("{name} {ms:.1} ms"))
        .collect();
    let _ = writeln!(s, "  phases: {}", phases.join(", "));
    print_text(&s)
}

/// The first line of a build's text report, without its end: `mesh → file (method levels,
/// N-bit)`, `levels` saying which depth or depths were built.
fn headline(args: &BuildArgs, input: &crate::commands::InputMesh, levels: &str) -> String {
    format!(
        "{} → {} ({} {levels}, {}-bit)",
        input.source,
        args.output.display(),
        args.method.name(),
        args.bits.count()
    )
}

/// Writes the file atomically, compressed with `--compress`; returns the bytes written.
fn save(args: &BuildArgs, smo: &[u8]) -> anyhow::Result<usize> {
    let Some(level) = args.compress_level() else {
        sdf_multioctree::io::write_atomic(&args.output, smo)?;
        return Ok(smo.len());
    };
    let packed = sdf_multioctree::format::compressed::compress_with_level(smo, level)
        .context("cannot compress the octree")?;
    sdf_multioctree::io::write_atomic(&args.output, &packed)?;
    Ok(packed.len())
}

/// The summary's note on a compressed file: its size on disk against the traced bytes.
fn stored_note(args: &BuildArgs, traced: usize, stored: usize, voxels: usize) -> String {
    match args.compress_level() {
        Some(level) => format!(
            "  compressed (zstd {level}): {stored} bytes on disk ({:.3} MB, {:.3} bytes per voxel, {:.1}x smaller)\n",
            stored as f64 / 1e6,
            stored as f64 / voxels.max(1) as f64,
            traced as f64 / stored.max(1) as f64
        ),
        None => String::new(),
    }
}

/// `sdfmo build --lod`: every level from the coarsest to the depth, one build each, in one
/// version-2.0 file (4.0 with `--format 3`).
fn run_lod(
    args: &BuildArgs,
    input: &crate::commands::InputMesh,
    settings: &BuildSettings,
    coarsest: u8,
    workers: &Workers,
) -> anyhow::Result<()> {
    let budget = memory_budget(args.max_memory);
    let bar = progress::fraction(&format!(
        "building {} levels {coarsest}..={}",
        input.name, args.depth
    ));
    let on_progress = |f: f32| progress::set_fraction(&bar, f);
    let built = workers.install(|| {
        BuildRequest::new(&input.mesh, *settings)
            .memory_budget(budget)
            .progress(&on_progress)
            .levels(coarsest)
    });
    bar.finish_and_clear();
    let (lod, stats) =
        built.with_context(|| format!("cannot build the levels of {}", input.source))?;
    ensure_parent(&args.output)?;
    let (file, entries) = match args.format {
        FormatArg::V1 => (lod.to_bytes(), lod.entries()),
        FormatArg::V3 => {
            let file = encode_levels(&lod).context("cannot encode the levels as format 4")?;
            // The header's level table; decoding also checks the file before it is written.
            let declared = decode_levels_prefix(&file)
                .context("the 4.0 encoding does not decode")?
                .declared;
            (file, declared)
        }
    };
    let stored = save(args, &file)?;
    let bytes = file.len() as u64;
    let total_ms: f64 = stats.iter().map(|s| s.build_ms).sum();
    if args.json {
        let levels: Vec<serde_json::Value> = stats
            .iter()
            .zip(&entries)
            .map(|(st, e)| {
                let mut j = stats_json(st);
                j["level"] = json!(e.level);
                j["offset"] = json!(e.offset);
                j
            })
            .collect();
        let j = json!({
            "mesh": input.source,
            "method": args.method.name(),
            "depth": args.depth,
            "coarsest": coarsest,
            "bits": args.bits.count(),
            "bytes": bytes,
            "format": levels_version(args.format),
            "build_ms": total_ms,
            "levels": levels,
            "output": args.output.display().to_string(),
            "compress_level": args.compress_level(),
            "stored_bytes": stored,
        });
        return print_json(&j);
    }
    let mut s = headline(args, input, &format!("levels {coarsest}..={}", args.depth));
    let _ = writeln!(
        s,
        ": {bytes} bytes ({:.3} MB, format {}), {total_ms:.1} ms",
        bytes as f64 / 1e6,
        levels_version(args.format),
    );
    let voxels: usize = stats.iter().map(|st| st.voxels).sum();
    s.push_str(&stored_note(args, bytes as usize, stored, voxels));
    for (st, e) in stats.iter().zip(&entries) {
        let _ = writeln!(
            s,
            "  level {:>2}: leaves {}, voxels {} ({} surface), {} bytes at {}, {:.1} ms",
            e.level, st.leaves, st.voxels, st.surface_voxels, e.size, e.offset, st.build_ms
        );
        if st.cap_hits > 0 {
            let _ = writeln!(
                s,
                "    warning: {} leaves hit the cap of {} voxels",
                st.cap_hits, args.max_voxels
            );
        }
    }
    print_text(&s)
}

/// The builder's statistics as a JSON object (phases as an ordered list).
pub fn stats_json(stats: &BuildStats) -> serde_json::Value {
    json!({
        "nodes": stats.nodes,
        "leaves": stats.leaves,
        "voxels": stats.voxels,
        "surface_voxels": stats.surface_voxels,
        "bytes": stats.bytes,
        "build_ms": stats.build_ms,
        "voxels_per_leaf": stats.voxels_per_leaf,
        "cap_hits": stats.cap_hits,
        "phases": stats.phases.iter().map(|(name, ms)| json!({"name": name, "ms": ms})).collect::<Vec<_>>(),
    })
}
