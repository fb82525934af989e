//! Estimates the traced size of a brick layout (the candidate format 3.0 of `docs/format-3.md`)
//! from existing `.smo` files, exactly and without building it: bytes are counted, not timed.
//!
//! The layout counted here:
//! - **bricks**: the nodes at `depth − 2`, each covering 4³ leaf cells, replace the two lowest
//!   levels of node groups and the leaf groups: per brick a `u64` occupancy (which of its 64
//!   cells are leaves), a `u64` private mask (which leaves keep private voxels) and two `u32`
//!   bases (first shared point, first private voxel): 24 bytes;
//! - **shared points**: a leaf with one volume voxel (not surface, not clip) whose corner codes
//!   agree with every code already stored at the same grid point of its brick reads its eight
//!   corners from the brick's points. The points a brick stores are the union of its shared
//!   leaves' corners, so a reader derives their set (and a point's rank) from the occupancy and
//!   private masks: nothing but the codes is stored;
//! - **plane-predicted codes**: per brick a plane `a + b·x + c·y + d·z` (four `i16` in 1/16 code
//!   units) and one residual width out of 0, 2, 4 or 8 bits for all its points (9 bytes per
//!   brick); a point's code is `clamp(round(plane) + residual, −Q, Q)`, lossless;
//! - **private voxels**: every other leaf keeps a count byte and, per voxel, its eight codes and
//!   two flag bits (surface, clip), as today;
//! - the node groups above the bricks and the header, as today.
//!
//! ```text
//! cargo run --release -p sdfmo-format --example brick_estimate -- FILE.smo… > estimate.csv
//! ```
//! One CSV row per file (8-bit `.smo` files with one level). The last columns are the file
//! that [`BrickOctree::encode`] writes (format 3.1, the layout built: 3.0 with narrow private
//! voxels, `FORMAT.md`): its bytes, bytes per
//! voxel, and its residual bytes beside the estimate's (the plane fits differ: see
//! `docs/format-3.md`). Then the compressed container over it and over the 1.x file
//! ([`compress_with_level`] at [`ZSTD_LEVEL`], `sdfmo build --compress`'s default), the whole
//! 3.0 file as one zstd frame at the same
//! level (what splitting it into streams saves), and the container's decode speed: MB/s of
//! decoded 3.0 bytes, the median and the best of seven single-threaded [`decompress`] calls (a
//! timing: under other load both are lower bounds). Last, the same octree as a 3.0 file
//! ([`BrickOctree::encode_minor`] at 0): its bytes and bytes per voxel.

use std::collections::{HashMap, HashSet};

use std::time::Instant;

use sdfmo_format::compressed::{compress_with_level, decompress};
use sdfmo_format::{fit_brick_plane, BrickOctree, NodeRef, PackedOctree, ValueBits};

/// The zstd level of `sdfmo build --compress` (and of `benches/compressed_sizes.sh`).
const ZSTD_LEVEL: i32 = 9;
/// Decode timings per file; the median and the best are reported.
const DECODE_RUNS: usize = 7;

/// Integer grid point (a leaf corner) in `[0, 2^depth]³`.
type Point = [u32; 3];

/// Grid point of corner `k` (index `4x + 2y + z`) of the leaf at `cell`.
fn corner_point(cell: [u32; 3], k: u32) -> Point {
    [
        cell[0] + (k >> 2 & 1),
        cell[1] + (k >> 1 & 1),
        cell[2] + (k & 1),
    ]
}

/// Brick of a leaf cell (4³ cells per brick).
fn brick_of(cell: [u32; 3]) -> [u32; 3] {
    [cell[0] >> 2, cell[1] >> 2, cell[2] >> 2]
}

/// The counts one file yields.
#[derive(Default)]
struct Estimate {
    voxels: usize,
    traced_bytes: usize,
    upper_nodes: usize,
    bricks: usize,
    private_leaves: usize,
    private_voxels: usize,
    points: usize,
    /// Bits of the points' residuals plus the per-brick plane and width.
    predicted_point_bits: usize,
    /// Bricks by residual width: 0, 2, 4, 8 bits.
    widths: [usize; 4],
}

impl Estimate {
    /// Header and checksum, node groups above the bricks, brick records, private leaves.
    fn structure_bytes(&self) -> usize {
        128 + 4
            + self.upper_nodes.div_ceil(8) * 12
            + self.bricks * 24
            + self.private_leaves
            + self.private_voxels * 8
            + self.private_voxels.div_ceil(4)
    }

    /// Bytes per voxel with one byte per shared point.
    fn plain_bytes_per_voxel(&self) -> f64 {
        (self.structure_bytes() + self.points) as f64 / self.voxels as f64
    }

    /// Bytes per voxel with plane-predicted points.
    fn predicted_bytes_per_voxel(&self) -> f64 {
        (self.structure_bytes() + self.predicted_point_bits.div_ceil(8)) as f64 / self.voxels as f64
    }
}

/// The encoder's least-squares plane ([`fit_brick_plane`]) through `(local point, code)`, in
/// code units.
fn fit_plane(samples: &[([f64; 3], i32)]) -> [f64; 4] {
    let points: Vec<([u32; 3], i32)> = samples
        .iter()
        .map(|(p, c)| (p.map(|x| x as u32), *c))
        .collect();
    fit_brick_plane(&points, ValueBits::Eight).map(|t| f64::from(t) / 16.0)
}

/// The residual width (0, 2, 4 or 8 bits) that stores every point of the brick losslessly.
fn residual_width(samples: &[([f64; 3], i32)], plane: [f64; 4], q: i32) -> usize {
    let mut widest = 0i32;
    for (x, code) in samples {
        let predicted = (plane[0] + plane[1] * x[0] + plane[2] * x[1] + plane[3] * x[2])
            .round()
            .clamp(-f64::from(q), f64::from(q)) as i32;
        let residual = code - predicted;
        // Two's complement width: r in [−2^(w−1), 2^(w−1) − 1].
        widest = widest.max(if residual < 0 {
            -residual - 1
        } else {
            residual
        });
        if residual != 0 {
            widest = widest.max(1);
        }
    }
    match widest {
        0 => 0,
        1 => 2,
        2..=7 => 4,
        _ => 8,
    }
}

fn estimate(octree: &PackedOctree, traced_bytes: usize) -> Estimate {
    let inner = octree.inner_node_count();
    let cells = octree.leaf_coords();
    let mut e = Estimate {
        voxels: octree.voxel_count(),
        traced_bytes,
        ..Estimate::default()
    };
    for shift in 3..=u32::from(octree.depth()) {
        let level: HashSet<[u32; 3]> = cells
            .iter()
            .map(|c| [c[0] >> shift, c[1] >> shift, c[2] >> shift])
            .collect();
        e.upper_nodes += level.len();
    }
    // Points of each brick, filled by its shared leaves in storage (Morton) order.
    let mut bricks: HashMap<[u32; 3], HashMap<Point, i32>> = HashMap::new();
    for (j, &cell) in cells.iter().enumerate() {
        let voxels = octree.leaf_voxels(NodeRef::from_index((inner + j) as u32));
        let points = bricks.entry(brick_of(cell)).or_default();
        let first = voxels.start;
        let codes = octree.voxel_codes(first);
        let shared = voxels.len() == 1
            && !octree.voxel_is_surface(first)
            && !octree.voxel_is_clip(first)
            && (0..8).all(|k| {
                points
                    .get(&corner_point(cell, k))
                    .is_none_or(|&c| c == i32::from(codes[k as usize]))
            });
        if shared {
            for k in 0..8 {
                points.insert(corner_point(cell, k), i32::from(codes[k as usize]));
            }
        } else {
            e.private_leaves += 1;
            e.private_voxels += voxels.len();
        }
    }
    e.bricks = bricks.len();
    let q = 127;
    for (brick, points) in &bricks {
        let origin = brick.map(|c| f64::from(c * 4));
        let samples: Vec<([f64; 3], i32)> = points
            .iter()
            .map(|(p, &c)| ([0, 1, 2].map(|a| f64::from(p[a]) - origin[a]), c))
            .collect();
        let width = residual_width(&samples, fit_plane(&samples), q);
        e.widths[match width {
            0 => 0,
            2 => 1,
            4 => 2,
            _ => 3,
        }] += 1;
        e.points += points.len();
        e.predicted_point_bits += points.len() * width + 9 * 8;
    }
    e
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "file,voxels,traced_bytes,traced_bpv,upper_nodes,bricks,private_leaves,private_voxels,\
         points,points_per_voxel,bricks_w0,bricks_w2,bricks_w4,bricks_w8,plain_bpv,predicted_bpv,\
         v3_bytes,v3_bpv,estimated_residual_bytes,v3_residual_bytes,v3_compressed_bytes,\
         v3_compressed_bpv,v3_one_frame_bytes,v1_compressed_bytes,v1_compressed_bpv,\
         v3_decode_mb_per_s,v3_decode_best_mb_per_s,v30_bytes,v30_bpv"
    );
    for path in std::env::args().skip(1) {
        let bytes = std::fs::read(&path)?;
        let traced = bytes.len();
        let octree = PackedOctree::from_vec(bytes)?;
        let e = estimate(&octree, traced);
        let brick = BrickOctree::encode(&octree)?;
        // Lossless, or no row: every voxel reads back alike, and the 3.0 file decodes to the
        // same 1.x bytes.
        if let Some(diff) = brick.first_difference(&octree) {
            return Err(format!("{path}: the 3.0 encoding differs: {diff}").into());
        }
        if brick.to_octree() != octree {
            return Err(format!("{path}: the 3.0 encoding does not decode to the file").into());
        }
        let v3 = brick.as_bytes().len();
        let v30 = BrickOctree::encode_minor(&octree, 0)?.as_bytes().len();
        let packed = compress_with_level(brick.as_bytes(), ZSTD_LEVEL)?;
        let one_frame = zstd::bulk::compress(brick.as_bytes(), ZSTD_LEVEL)?.len();
        let v1_packed = compress_with_level(octree.as_bytes(), ZSTD_LEVEL)?.len();
        let mut seconds: Vec<f64> = (0..DECODE_RUNS)
            .map(|_| {
                let start = Instant::now();
                let decoded = decompress(std::hint::black_box(&packed), v3 as u64);
                let elapsed = start.elapsed().as_secs_f64();
                assert!(decoded.is_ok_and(|d| d == brick.as_bytes()), "{path}");
                elapsed
            })
            .collect();
        seconds.sort_by(f64::total_cmp);
        let mb_per_s = v3 as f64 / seconds[DECODE_RUNS / 2] / 1e6;
        let best_mb_per_s = v3 as f64 / seconds[0] / 1e6;
        let v3_residuals = brick.section_sizes().residuals;
        let name = std::path::Path::new(&path)
            .file_name()
            .map_or(path.clone(), |n| n.to_string_lossy().into_owned());
        println!(
            "{name},{},{},{:.2},{},{},{},{},{},{:.2},{},{},{},{},{:.2},{:.2},{v3},{:.2},{},{v3_residuals},{},{:.2},{one_frame},{v1_packed},{:.2},{mb_per_s:.0},{best_mb_per_s:.0},{v30},{:.2}",
            e.voxels,
            e.traced_bytes,
            e.traced_bytes as f64 / e.voxels as f64,
            e.upper_nodes,
            e.bricks,
            e.private_leaves,
            e.private_voxels,
            e.points,
            e.points as f64 / e.voxels as f64,
            e.widths[0],
            e.widths[1],
            e.widths[2],
            e.widths[3],
            e.plain_bytes_per_voxel(),
            e.predicted_bytes_per_voxel(),
            v3 as f64 / e.voxels as f64,
            (e.predicted_point_bits - 72 * e.bricks).div_ceil(8),
            packed.len(),
            packed.len() as f64 / e.voxels as f64,
            v1_packed as f64 / e.voxels as f64,
            v30 as f64 / e.voxels as f64,
        );
    }
    Ok(())
}
