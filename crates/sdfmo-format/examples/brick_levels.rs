//! Sizes of files with levels in format 4.1 (levels of bricks) against the leaf-only files of
//! their finest level, from existing 2.0 files (`sdfmo build --lod`).
//!
//! ```text
//! cargo run --release -p sdfmo-format --example brick_levels -- FILE.smo…
//! ```
//! For each 2.0 file: the 4.1 file [`encode_levels`] writes, checked to decode to the same
//! levels byte for byte; the leaf-only 3.1 and 1.x files of its finest level; the ratios; then
//! per level the block's bytes against that level's own 3.1 file, and how its bricks were
//! coded. `--decode` also measures decoding in process CPU time (`/proc/self/stat`: CPU
//! seconds, not wall time, so a loaded machine slows it less), as MB/s of the 4.1 file and of
//! the 1.x octrees it decodes to.

use std::path::PathBuf;

use sdfmo_format::{decode_levels_stats, encode_levels, BrickOctree, LodOctree};

/// CPU seconds (user + system) this process has used.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").expect("/proc/self/stat");
    // Fields after the command's closing parenthesis; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')').expect("a stat line") + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap();
    ticks / 100.0 // USER_HZ is 100 on Linux
}

fn main() {
    let mut decode = false;
    let mut files = Vec::new();
    for a in std::env::args().skip(1) {
        match a.as_str() {
            "--decode" => decode = true,
            _ => files.push(PathBuf::from(a)),
        }
    }
    println!(
        "| file | levels | leaf-only 1.x | leaf-only 3.1 | leaf-only 4.1 | levels 2.0 | levels 4.1 | \
         levels 4.1 / leaf-only 3.1 | / leaf-only 1.x | / leaf-only 4.1 |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut details = Vec::new();
    for path in files {
        let v2 = std::fs::read(&path).expect("read");
        let lod = LodOctree::from_bytes(&v2).expect("a 2.0 file");
        let v4 = encode_levels(&lod).expect("encode");
        let (p, stats) = decode_levels_stats(&v4).expect("decode");
        assert_eq!(p.octree, lod, "{}: the levels decode alike", path.display());
        let leaf_1x = lod.finest().as_bytes().len() as f64;
        let leaf_3 = BrickOctree::encode(lod.finest())
            .expect("3.1")
            .as_bytes()
            .len() as f64;
        // The finest level alone in the same coding: what the levels cost in 4.1 itself.
        let finest = LodOctree::from_levels(vec![lod.finest().clone()]).expect("one level");
        let leaf_4 = encode_levels(&finest).expect("encode").len() as f64;
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        println!(
            "| {name} | {}–{} | {} | {} | {} | {} | {} | **{:.3}** | {:.3} | {:.3} |",
            lod.coarsest(),
            lod.depth(),
            leaf_1x,
            leaf_3,
            leaf_4,
            v2.len(),
            v4.len(),
            v4.len() as f64 / leaf_3,
            v4.len() as f64 / leaf_1x,
            v4.len() as f64 / leaf_4
        );
        for (s, o) in stats.iter().zip(lod.levels()) {
            let own = BrickOctree::encode(o).expect("3.1").as_bytes().len();
            details.push(format!(
                "{name},{},{},{own},{:.3},{},{},{},{},{},{},{}",
                s.level,
                s.bytes,
                s.bytes as f64 / own as f64,
                s.bricks,
                s.relative_bricks,
                s.coarse_bricks,
                s.upper_bytes,
                s.record_bytes,
                s.residual_bytes,
                s.private_bytes
            ));
        }
        if decode {
            let traced: usize = lod.levels().iter().map(|l| l.as_bytes().len()).sum();
            let (mut runs, t0) = (0u32, cpu_seconds());
            while cpu_seconds() - t0 < 2.0 || runs < 3 {
                std::hint::black_box(decode_levels_stats(&v4).expect("decode"));
                runs += 1;
            }
            let per = (cpu_seconds() - t0) / f64::from(runs);
            details.push(format!(
                "{name},decode,{runs} runs,{:.1} ms CPU,{:.0} MB/s of the 4.1 file,{:.0} MB/s of 1.x octrees",
                per * 1e3,
                v4.len() as f64 / per / 1e6,
                traced as f64 / per / 1e6
            ));
        }
    }
    println!();
    println!("file,level,block_bytes,own_v3_bytes,block/own,bricks,relative_occupancy,coarse_points,upper,records,residuals,private");
    for d in details {
        println!("{d}");
    }
}
