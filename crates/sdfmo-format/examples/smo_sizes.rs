//! Builds packed octrees from generated leaves and prints the size of every `.smo` section.
//!
//! The leaves are what a builder would emit for analytic shapes: the cells within a leaf
//! diagonal of the surface, corners = exact signed distance. "svo" is a sphere of radius 0.6
//! (one volume voxel per leaf); "multi" adds a thin plate (surface voxels) crossing it, so
//! leaves near both hold two voxels.
//!
//! ```text
//! cargo run -p sdfmo-format --example smo_sizes -- [--max-depth 8] [--write DIR]
//! ```
//! `--write DIR` also saves each octree as `DIR/<shape>_d<depth>_<bits>.smo` (and, of depth
//! ≥ 2, its format-3.0 encoding as `….v3.smo`: seeds for `fuzz_v3`); `--time` also
//! prints the best of 5 timings of `from_leaves`, `to_bytes`, `from_bytes` (validate + copy)
//! and `PackedOctreeView::new` (validate only, read in place) — run it with `--release` for that.
//! `--load FILE…` instead reports the sections and the load time of existing `.smo` files;
//! `--compressed FILE…` the size of each file in the compressed container at three zstd levels,
//! with the time to write it and to decode it (best of 5; decoding includes the CRC-32 checks);
//! `--compressed-at LEVEL FILE…` at one level.

use std::path::PathBuf;
use std::time::Instant;

// The leaves of analytic shapes the integration tests use.
#[path = "../tests/common/mod.rs"]
mod common;

use glam::Vec3;
use sdfmo_format::{
    compressed, LeafInput, OctreeMeta, PackedOctree, PackedOctreeView, ValueBits, Voxel,
};

/// Best of 5 wall-clock timings of `f`, in milliseconds.
fn best_ms(f: &mut dyn FnMut()) -> f64 {
    (0..5)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

/// Sections and load times of existing files.
fn load_files(paths: Vec<String>) -> Result<(), Box<dyn std::error::Error>> {
    println!("| file | voxels | total B | B/voxel | read+from_bytes ms | from_bytes ms | MB/s | view ms |");
    println!("|---|---|---|---|---|---|---|---|");
    for p in paths {
        let path = std::path::Path::new(&p);
        let bytes = std::fs::read(path)?;
        let o = PackedOctree::from_bytes(&bytes)?;
        let load = best_ms(&mut || {
            std::hint::black_box(PackedOctree::load(path).ok());
        });
        let decode = best_ms(&mut || {
            std::hint::black_box(PackedOctree::from_bytes(&bytes).ok());
        });
        let view = best_ms(&mut || {
            std::hint::black_box(PackedOctreeView::new(&bytes).ok());
        });
        println!(
            "| {} | {} | {} | {:.3} | {load:.2} | {decode:.2} | {:.0} | {view:.2} |",
            path.file_name().unwrap_or_default().to_string_lossy(),
            o.voxel_count(),
            bytes.len(),
            o.section_sizes().bytes_per_voxel(o.voxel_count()),
            bytes.len() as f64 / 1e3 / decode,
        );
    }
    Ok(())
}

/// Compressed sizes and decode speed of existing `.smo` files (1.x or 2.0).
fn compressed_files(paths: Vec<String>, levels: &[i32]) -> Result<(), Box<dyn std::error::Error>> {
    use sdfmo_format::compressed::{compress_with_level, decompress};
    use sdfmo_format::SmoFile;
    println!("| file | voxels (finest) | voxels (all levels) | traced B | level | compressed B | B/voxel (all) | ratio | write ms | decode ms | decode MB/s |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for p in paths {
        let path = std::path::Path::new(&p);
        let bytes = std::fs::read(path)?;
        let (finest, all) = match SmoFile::from_bytes(&bytes)? {
            SmoFile::Octree(o) => (o.voxel_count(), o.voxel_count()),
            SmoFile::Bricks(b) => (b.voxel_count(), b.voxel_count()),
            SmoFile::Levels(l) => (
                l.finest().voxel_count(),
                l.levels().iter().map(|o| o.voxel_count()).sum(),
            ),
        };
        for &level in levels {
            let t = Instant::now();
            let packed = compress_with_level(&bytes, level)?;
            let write = t.elapsed().as_secs_f64() * 1e3;
            let decode = best_ms(&mut || {
                std::hint::black_box(decompress(&packed, u64::MAX).ok());
            });
            println!(
                "| {} | {finest} | {all} | {} | {level} | {} | {:.3} | {:.2} | {write:.0} | {decode:.2} | {:.0} |",
                path.file_name().unwrap_or_default().to_string_lossy(),
                bytes.len(),
                packed.len(),
                packed.len() as f64 / all as f64,
                bytes.len() as f64 / packed.len() as f64,
                bytes.len() as f64 / 1e3 / decode,
            );
        }
    }
    Ok(())
}

/// Saves `o` as `DIR/NAME.smo` and, at depth ≥ 2, its 3.0 encoding as `DIR/NAME.v3.smo`.
fn save(
    dir: &std::path::Path,
    name: &str,
    o: &PackedOctree,
) -> Result<(), Box<dyn std::error::Error>> {
    o.save(&dir.join(format!("{name}.smo")))?;
    if o.depth() >= sdfmo_format::BRICK_LEVELS {
        let v3 = sdfmo_format::BrickOctree::encode(o)?;
        std::fs::write(dir.join(format!("{name}.v3.smo")), v3.as_bytes())?;
    }
    Ok(())
}

/// Small files (fuzzing seeds): empty, a lone root leaf, a few leaves at depth 2 and 3, and a
/// version-1.1 file with clip voxels (an intersect pair, a surface voxel with a clip-only one).
fn write_tiny(dir: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(dir)?;
    let v = |d: f32, surface: bool| Voxel {
        corners: [d, -d, d, -d, 0.5 * d, 0.0, -0.25 * d, d],
        surface,
        clip: false,
    };
    let clipped = |mut x: Voxel| {
        x.clip = true;
        x
    };
    let cases: [(&str, u8, ValueBits, Vec<LeafInput>); 5] = [
        ("tiny_empty", 3, ValueBits::Eight, vec![]),
        (
            "tiny_root_leaf",
            0,
            ValueBits::Sixteen,
            vec![LeafInput {
                coord: [0, 0, 0],
                voxels: vec![v(1.0, false), v(0.5, true)],
            }],
        ),
        (
            "tiny_d2",
            2,
            ValueBits::Eight,
            (0..3)
                .map(|i| LeafInput {
                    coord: [i, 3 - i, 1],
                    voxels: vec![v(0.3, i == 1)],
                })
                .collect(),
        ),
        (
            "tiny_d3_multi",
            3,
            ValueBits::Sixteen,
            (0..11)
                .map(|i| LeafInput {
                    coord: [i % 8, i / 2, 7 - i % 8],
                    voxels: (0..1 + i as usize % 3)
                        .map(|k| v(0.1 * k as f32, k == 1))
                        .collect(),
                })
                .collect(),
        ),
        (
            "tiny_d2_clip",
            2,
            ValueBits::Eight,
            vec![
                LeafInput {
                    coord: [1, 2, 3],
                    voxels: vec![clipped(v(0.3, false)), clipped(v(-0.2, false))],
                },
                LeafInput {
                    coord: [2, 2, 3],
                    voxels: vec![v(0.3, true), clipped(v(0.1, true))],
                },
                LeafInput {
                    coord: [0, 0, 0],
                    voxels: vec![v(0.4, false)],
                },
            ],
        ),
    ];
    for (name, depth, bits, leaves) in cases {
        let meta = OctreeMeta {
            depth,
            bits,
            center: Vec3::new(1.0, 2.0, 3.0),
            scale: 0.5,
        };
        save(dir, name, &PackedOctree::from_leaves(meta, leaves)?)?;
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mut max_depth = 8u8;
    let mut write: Option<PathBuf> = None;
    let mut time = false;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--max-depth" => max_depth = args.next().ok_or("--max-depth N")?.parse()?,
            "--write" => write = Some(args.next().ok_or("--write DIR")?.into()),
            "--time" => time = true,
            "--load" => return load_files(args.collect()),
            "--compressed" => {
                return compressed_files(
                    args.collect(),
                    &[3, 9, compressed::DEFAULT_COMPRESSION_LEVEL],
                )
            }
            "--compressed-at" => {
                let level = args.next().ok_or("--compressed-at LEVEL FILE…")?.parse()?;
                return compressed_files(args.collect(), &[level]);
            }
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    if let Some(dir) = &write {
        write_tiny(dir)?;
    }
    println!("| shape | depth | bits | inner | leaves | voxels | surface | header | nodes | leaves B | surface B | corners | padding+crc | total B | B/voxel | B/leaf |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for depth in 4..=max_depth {
        for (shape, plate) in [("svo", false), ("multi", true)] {
            let input = common::shape_leaves(depth, plate);
            for bits in [ValueBits::Eight, ValueBits::Sixteen] {
                let meta = OctreeMeta::unit(depth, bits);
                let o = PackedOctree::from_leaves(meta, input.clone())?;
                let s = o.section_sizes();
                let bytes = o.to_bytes();
                assert_eq!(bytes.len(), s.total);
                assert_eq!(PackedOctree::from_bytes(&bytes)?, o);
                println!(
                    "| {shape} | {depth} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.3} | {:.3} |",
                    bits.bits(),
                    o.inner_node_count(),
                    o.leaf_count(),
                    o.voxel_count(),
                    o.surface_voxel_count(),
                    s.header,
                    s.nodes,
                    s.leaves,
                    s.surface,
                    s.corners,
                    s.padding + s.checksum,
                    s.total,
                    s.bytes_per_voxel(o.voxel_count()),
                    s.total as f64 / o.leaf_count() as f64,
                );
                if time {
                    let best = best_ms;
                    let build = best(&mut || {
                        std::hint::black_box(PackedOctree::from_leaves(meta, input.clone()).ok());
                    });
                    let encode = best(&mut || {
                        std::hint::black_box(o.to_bytes());
                    });
                    let decode = best(&mut || {
                        std::hint::black_box(PackedOctree::from_bytes(&bytes).ok());
                    });
                    let view = best(&mut || {
                        std::hint::black_box(PackedOctreeView::new(&bytes).ok());
                    });
                    let mb = bytes.len() as f64 / 1e6;
                    println!(
                        "  timing: from_leaves {build:.2} ms (incl. clone of the input), to_bytes {encode:.2} ms, from_bytes {decode:.2} ms ({:.0} MB/s), view {view:.2} ms ({:.0} MB/s)",
                        mb / decode * 1e3,
                        mb / view * 1e3
                    );
                }
                if let Some(dir) = &write {
                    std::fs::create_dir_all(dir)?;
                    save(dir, &format!("{shape}_d{depth}_{}", bits.bits()), &o)?;
                }
            }
        }
    }
    Ok(())
}
