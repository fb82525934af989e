//! Counts, exactly and without building them, the bytes that *narrow* private voxels would save
//! in a 3.0 brick file (issue 34): a private voxel whose four mixed differences
//!
//! ```text
//! xy  = c110 − c100 − c010 + c000      xz = c101 − c100 − c001 + c000
//! yz  = c011 − c010 − c001 + c000      xyz = c111 − c110 − c101 − c011 + c100 + c010 + c001 − c000
//! ```
//!
//! (corner index `4x + 2y + z`) fit in signed half-width fields (4 bits at 8-bit codes) is
//! stored as its four base codes `c000 c001 c010 c100` and the four differences: 6 bytes
//! instead of 8 (8-bit files). The variants counted, each against the 3.0 file:
//!
//! - **per leaf**: a private leaf is narrow when all its voxels fit; the private leaf group
//!   grows from 12 to 16 bytes (a `u32` of wide voxels before the group) and a count byte's bit
//!   7 says the leaf is wide;
//! - **per voxel**: each voxel narrow when it fits, a third flag bit per voxel (its own bit
//!   section), the same 16-byte groups (the reader then counts wide bits over a range);
//! - **per leaf, groups of 16**: as per leaf, but a group record covers 16 private leaves in
//!   24 bytes (`u32` first voxel, `u32` wide voxels before, 16 count bytes): 1.5 bytes per
//!   private leaf as in 3.0;
//! - **first voxel from the points**: how many multi-voxel private leaves have a first voxel
//!   whose eight corners are all points of the brick with the same codes (it would need no
//!   codes of its own): the bound on that refinement.
//!
//! ```text
//! cargo run --release -p sdfmo-format --example narrow_estimate -- FILE.smo… > narrow.csv
//! ```
//!
//! One CSV row per file (1.x `.smo` files, 8 or 16 bits). Sizes round each section to 8 bytes
//! as the layout does.

use std::collections::HashMap;

use sdfmo_format::{BrickOctree, PackedOctree};

/// The four mixed differences of a voxel's codes (`4x + 2y + z`).
fn mixed(c: [i16; 8]) -> [i32; 4] {
    let c = c.map(i32::from);
    [
        c[6] - c[4] - c[2] + c[0],
        c[5] - c[4] - c[1] + c[0],
        c[3] - c[2] - c[1] + c[0],
        c[7] - c[6] - c[5] - c[3] + c[4] + c[2] + c[1] - c[0],
    ]
}

/// Whether every difference fits a signed field of `bits` bits.
fn fits(d: [i32; 4], bits: u32) -> bool {
    let lo = -(1 << (bits - 1));
    let hi = (1 << (bits - 1)) - 1;
    d.iter().all(|&x| (lo..=hi).contains(&x))
}

fn round8(x: usize) -> usize {
    x.div_ceil(8) * 8
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "file,voxels,v3_bytes,v3_bpv,private_leaves,private_voxels,fit_voxels,narrow_leaf_voxels,\
         per_leaf_bytes,per_leaf_bpv,per_voxel_bytes,per_voxel_bpv,per_leaf_g16_bytes,\
         per_leaf_g16_bpv,first_from_points_leaves,max_leaf_voxels"
    );
    for path in std::env::args().skip(1) {
        let octree = PackedOctree::from_vec(std::fs::read(&path)?)?;
        let brick = BrickOctree::encode_minor(&octree, 0)?;
        let b = octree.meta().bits.bytes();
        let half = 4 * b as u32;
        let v3 = brick.as_bytes().len();
        let voxels = octree.voxel_count();
        // Points of the shared leaves, by global grid point.
        let mut points: HashMap<[u32; 3], i16> = HashMap::new();
        for (coord, leaf) in brick.leaves() {
            if leaf.is_shared() {
                let codes = brick.voxel_codes(&leaf, 0);
                for (k, &c) in codes.iter().enumerate() {
                    let k = k as u32;
                    points.insert(
                        [
                            coord[0] + (k >> 2),
                            coord[1] + (k >> 1 & 1),
                            coord[2] + (k & 1),
                        ],
                        c,
                    );
                }
            }
        }
        let (mut p, mut w, mut fit, mut narrow_leaf) = (0, 0, 0, 0);
        let (mut first_from_points, mut max_count) = (0, 0);
        for (coord, leaf) in brick.leaves() {
            if leaf.is_shared() {
                continue;
            }
            let n = leaf.voxel_count();
            max_count = max_count.max(n);
            p += 1;
            w += n as usize;
            let codes: Vec<[i16; 8]> = (0..n).map(|k| brick.voxel_codes(&leaf, k)).collect();
            let f = codes.iter().filter(|c| fits(mixed(**c), half)).count();
            fit += f;
            if f == n as usize {
                narrow_leaf += f;
            }
            if n > 1
                && (0..8u32).all(|k| {
                    let g = [
                        coord[0] + (k >> 2),
                        coord[1] + (k >> 1 & 1),
                        coord[2] + (k & 1),
                    ];
                    points.get(&g) == Some(&codes[0][k as usize])
                })
            {
                first_from_points += 1;
            }
        }
        let groups = (p as usize).div_ceil(8);
        let v3_rest = v3 - round8(12 * groups) - round8(8 * b * w);
        let group16 = round8(16 * groups);
        let per_leaf = v3_rest + group16 + round8(8 * b * w - 2 * b * narrow_leaf);
        let per_voxel = v3_rest + group16 + round8(8 * b * w - 2 * b * fit) + 8 * w.div_ceil(64);
        // Per leaf with groups of 16 private leaves in 24 bytes (two u32 bases, 16 count bytes):
        // the 3.0 group's 1.5 bytes per private leaf.
        let per_leaf_g16 = per_leaf - group16 + round8(24 * (p as usize).div_ceil(16));
        let name = std::path::Path::new(&path)
            .file_name()
            .map_or(path.clone(), |n| n.to_string_lossy().into_owned());
        let bpv = |x: usize| x as f64 / voxels as f64;
        println!(
            "{name},{voxels},{v3},{:.3},{p},{w},{fit},{narrow_leaf},{per_leaf},{:.3},{per_voxel},{:.3},{per_leaf_g16},{:.3},{first_from_points},{max_count}",
            bpv(v3),
            bpv(per_leaf),
            bpv(per_voxel),
            bpv(per_leaf_g16),
        );
    }
    Ok(())
}
