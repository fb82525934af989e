//! Builds one mesh with both methods at some depths and prints the statistics and a
//! renderer-free quality estimate: points sampled uniformly on the (normalised) mesh surface,
//! and at each the smallest `|f|` over the voxels of its leaf, in cell units (a leaf that is
//! missing counts as error 1). Also the distance from voxel zero sets to the mesh ("false
//! surface") measured at points on the voxels' zero sets.
//!
//! `cargo run --release -p sdfmo-build --example probe -- MESH [DEPTH...]`

use std::collections::HashMap;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_format::trilinear;
use sdfmo_format::{cell_size, PackedOctree, Voxel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Two workers, as the tables were measured (the builder runs on the caller's pool).
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global()?;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().ok_or("usage: probe MESH [DEPTH...]")?;
    let depths: Vec<u8> = if args.len() > 1 {
        args[1..]
            .iter()
            .map(|a| a.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![7, 9]
    };
    let mesh = sdfmo_mesh::load_mesh(std::path::Path::new(path))?.mesh;
    let (norm, _) = mesh.normalized(0.05);
    let dist = MeshDistance::new(&norm, SignMode::Auto)?;
    // Uniform surface samples.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let areas: Vec<f32> = (0..norm.triangle_count())
        .map(|i| {
            let [a, b, c] = norm.triangle(i);
            (b - a).cross(c - a).length()
        })
        .collect();
    let total: f32 = areas.iter().sum();
    let mut samples = Vec::new();
    let want = 200_000.0;
    for (i, &a) in areas.iter().enumerate() {
        let k = a / total * want;
        let mut n = k.floor() as usize;
        if rng.random::<f32>() < k - n as f32 {
            n += 1;
        }
        let [p0, p1, p2] = norm.triangle(i);
        for _ in 0..n {
            let (mut u, mut v): (f32, f32) = (rng.random(), rng.random());
            if u + v > 1.0 {
                u = 1.0 - u;
                v = 1.0 - v;
            }
            samples.push(p0 + (p1 - p0) * u + (p2 - p0) * v);
        }
    }
    println!(
        "{path}: {} triangles, {} samples",
        norm.triangle_count(),
        samples.len()
    );
    // The builder's edge flags: the mesh layer's, over vertices welded by position.
    let (welded, vids) = norm.welded_by_position();
    let flags = sdfmo_mesh::EdgeAdjacency::of_triangles(&vids).edge_flags(&vids, welded.len());
    let clean: u32 = flags.clean.iter().map(|b| b.count_ones()).sum();
    let bnd: u32 = flags.boundary.iter().map(|b| b.count_ones()).sum();
    let vc = flags.vertex_clean.iter().filter(|&&b| b).count();
    println!("edges (per triangle side): clean {clean}, boundary {bnd}, of {}; clean vertices {vc} of {}; sign {:?}",
        3 * vids.len(), welded.len(), dist.sign_mode());
    for &d in &depths {
        for method in methods() {
            let sign = match std::env::var("SIGN").as_deref() {
                Ok("pn") => SignMode::PseudoNormal,
                Ok("w") => SignMode::Winding,
                _ => SignMode::Auto,
            };
            let s = BuildSettings::new(d, method).with_sign(sign);
            let (oct, st) = build(&mesh, &s)?;
            let (err, missing, p95) = surface_error(&oct, &samples);
            let fs = false_surface(&oct, &dist, &mut rng);
            println!(
                "d{d} {:>5}: {:8.1} ms  {:9} B  leaves {:8} voxels {:8} surf {:7} caps {:5} | err mean {:.4} p95 {:.3} missing {:.4} | false {:.4}",
                if method == Method::Svo { "svo" } else { "multi" },
                st.build_ms, st.bytes, st.leaves, st.voxels, st.surface_voxels, st.cap_hits, err, p95, missing, fs
            );
            let ph: Vec<String> = st
                .phases
                .iter()
                .map(|(n, t)| format!("{n} {t:.0}"))
                .collect();
            println!(
                "         phases: {}  hist {:?}",
                ph.join(", "),
                st.voxels_per_leaf
            );
        }
    }
    Ok(())
}

fn leaf_map(oct: &PackedOctree) -> HashMap<[u32; 3], Vec<Voxel>> {
    oct.leaves().collect()
}

fn surface_error(oct: &PackedOctree, samples: &[Vec3]) -> (f64, f64, f64) {
    let map = leaf_map(oct);
    let h = cell_size(oct.depth());
    let mut errs = Vec::with_capacity(samples.len());
    let mut missing = 0;
    for p in samples {
        let c = ((*p + Vec3::ONE) / h).floor();
        let key = [c.x as u32, c.y as u32, c.z as u32];
        let l = (*p + Vec3::ONE) / h - c;
        match map.get(&key) {
            Some(vs) => {
                let e = vs
                    .iter()
                    .map(|v| trilinear(&v.corners, l).abs())
                    .fold(f32::INFINITY, f32::min)
                    / h;
                errs.push(e.min(1.0));
            }
            None => {
                missing += 1;
                errs.push(1.0);
            }
        }
    }
    let mean = errs.iter().map(|&e| e as f64).sum::<f64>() / errs.len() as f64;
    errs.sort_by(|a, b| a.total_cmp(b));
    (
        mean,
        missing as f64 / samples.len() as f64,
        errs[errs.len() * 95 / 100] as f64,
    )
}

/// Random points on voxel zero sets (along random segments in each leaf), and the mean of their
/// true unsigned distance to the mesh, in cell units, clamped at 1.
fn false_surface(oct: &PackedOctree, dist: &MeshDistance, rng: &mut impl Rng) -> f64 {
    let h = cell_size(oct.depth());
    let mut sum = 0.0;
    let mut n = 0usize;
    let leaves: Vec<_> = oct.leaves().collect();
    let step = (leaves.len() / 20_000).max(1);
    for (coord, vs) in leaves.iter().step_by(step) {
        let lo = Vec3::new(coord[0] as f32, coord[1] as f32, coord[2] as f32) * h - Vec3::ONE;
        for v in vs {
            for _ in 0..4 {
                let a = Vec3::new(rng.random(), rng.random(), rng.random());
                let b = Vec3::new(rng.random(), rng.random(), rng.random());
                let fa = trilinear(&v.corners, a);
                let fb = trilinear(&v.corners, b);
                if fa * fb < 0.0 {
                    let t = fa / (fa - fb);
                    let mut l = a + (b - a) * t;
                    // Polish with a few secant steps along the segment.
                    let (mut x0, mut f0, mut x1, mut f1) = (a, fa, b, fb);
                    for _ in 0..8 {
                        let fl = trilinear(&v.corners, l);
                        if fl * f0 < 0.0 {
                            x1 = l;
                            f1 = fl;
                        } else {
                            x0 = l;
                            f0 = fl;
                        }
                        l = x0 + (x1 - x0) * (f0 / (f0 - f1));
                    }
                    let d = dist.unsigned_distance(lo + l * h) / h;
                    sum += d.min(1.0) as f64;
                    n += 1;
                }
            }
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

fn methods() -> Vec<Method> {
    match std::env::var("METHOD").as_deref() {
        Ok("svo") => vec![Method::Svo],
        Ok("multi") => vec![Method::Multi { max_voxels: 8 }],
        _ => vec![Method::Svo, Method::Multi { max_voxels: 8 }],
    }
}
