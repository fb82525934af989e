//! Diagnostic: pixels of one paper view where the multi-octree hits and the SVO does not (or
//! the reverse), with the hit leaf's voxels and the true distance at the hit.
//!
//! `cargo run --release -p sdfmo-build --example diag -- MESH DEPTH VIEW SIZE`

use std::collections::HashMap;
use std::path::Path;

use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_format::cell_size;
use sdfmo_render::{mesh_in_octree_frame, Camera};
use sdfmo_trace::{intersect, Ray};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let mesh = sdfmo_mesh::load_mesh(Path::new(&a[0]))?.mesh;
    let depth: u8 = a[1].parse()?;
    let view: usize = a[2].parse()?;
    let size: u32 = a[3].parse()?;
    let (svo, _) = build(&mesh, &BuildSettings::new(depth, Method::Svo))?;
    let (multi, _) = build(&mesh, &BuildSettings::new(depth, Method::default()))?;
    let m = mesh_in_octree_frame(&mesh, multi.meta());
    let d = MeshDistance::new(&m, SignMode::Auto)?;
    let leaves: HashMap<[u32; 3], Vec<sdfmo_format::Voxel>> = multi.leaves().collect();
    let svo_leaves: HashMap<[u32; 3], Vec<sdfmo_format::Voxel>> = svo.leaves().collect();
    let cam = &Camera::paper_views(size, size)[view];
    let h = cell_size(depth);
    // The leaf key of a hit and the voxels both octrees store there (corners in voxel units).
    let cell_key = |hit: &sdfmo_trace::Hit| {
        let c = ((hit.cell_min + glam::Vec3::ONE) / h).round();
        [c.x as u32, c.y as u32, c.z as u32]
    };
    let in_voxels = |x: f32| (x / h * 100.0).round() / 100.0;
    let print_multi = |key: &[u32; 3]| {
        for v in leaves.get(key).into_iter().flatten() {
            println!("   {:?} surf {}", v.corners.map(in_voxels), v.surface);
        }
    };
    let print_svo = |key: &[u32; 3]| {
        for v in svo_leaves.get(key).into_iter().flatten() {
            println!("   svo {:?}", v.corners.map(in_voxels));
        }
    };
    let mut shown = 0;
    let (mut worse, mut better, mut worse_shown) = (0usize, 0usize, 0usize);
    let (mut nworse, mut nbetter) = (0usize, 0usize);
    let mut count = [0usize; 4];
    let mut mism = [[0usize; 2]; 2];
    for py in 0..size {
        for px in 0..size {
            let (o, dir) = cam.primary_ray(px, py);
            let ray = Ray { origin: o, dir };
            let hs = intersect(&svo, &ray, 0.0, f32::INFINITY);
            let hm = intersect(&multi, &ray, 0.0, f32::INFINITY);
            let hr = d.ray_hit(o, dir, 0.0, f32::INFINITY);
            let k = (hs.is_some() as usize) * 2 + hm.is_some() as usize;
            count[k] += 1;
            if k == 1 || k == 2 {
                mism[k - 1][hr.is_some() as usize] += 1;
            }
            if let (Some(hs), Some(hm), Some(hr)) = (hs, hm, hr) {
                let nr = if hr.normal.dot(dir) > 0.0 {
                    -hr.normal
                } else {
                    hr.normal
                };
                let ns = sdfmo_trace::hit_normal(&ray, &hs);
                let nm = sdfmo_trace::hit_normal(&ray, &hm);
                let (as_, am) = (
                    ns.dot(nr).clamp(-1.0, 1.0).acos(),
                    nm.dot(nr).clamp(-1.0, 1.0).acos(),
                );
                if am > as_ + 0.2 {
                    nworse += 1;
                    if nworse <= 4 {
                        let key = cell_key(&hm);
                        println!("px ({px},{py}) normal error svo {as_:.2} multi {am:.2} rad, surface {} cell {key:?}", hm.surface);
                        print_multi(&key);
                        print_svo(&key);
                    }
                } else if as_ > am + 0.2 {
                    nbetter += 1;
                }
                let es = (hs.t - hr.t).abs() / h;
                let em = (hm.t - hr.t).abs() / h;
                if em > es + 0.1 {
                    worse += 1;
                    if worse_shown < 4 {
                        worse_shown += 1;
                        let key = cell_key(&hm);
                        println!(
                            "px ({px},{py}) depth error svo {es:.3} h multi {em:.3} h, multi voxel {} surface {} cell {key:?}",
                            hm.voxel, hm.surface
                        );
                        print_multi(&key);
                        print_svo(&key);
                    }
                } else if es > em + 0.1 {
                    better += 1;
                }
            }
            if let (None, Some(hm)) = (hs, hm) {
                if shown < 3 && hr.is_none() {
                    shown += 1;
                    let p = o + dir * hm.t;
                    let key = cell_key(&hm);
                    println!(
                        "px ({px},{py}) multi hit t {:.4} voxel {} surface {} true dist {:.3} h, ref hit {:?}",
                        hm.t,
                        hm.voxel,
                        hm.surface,
                        d.unsigned_distance(p) / h,
                        hr.map(|r| r.t)
                    );
                    print_svo(&key);
                    let lo = hm.cell_min;
                    let exact: Vec<f32> = (0..8)
                        .map(|i| {
                            let q = lo
                                + glam::Vec3::new(
                                    ((i >> 2) & 1) as f32,
                                    ((i >> 1) & 1) as f32,
                                    (i & 1) as f32,
                                ) * h;
                            in_voxels(d.signed_distance(q))
                        })
                        .collect();
                    println!("   exact global {exact:?} cell {key:?}");
                    print_multi(&key);
                }
            }
        }
    }
    println!("both hit: multi normal worse by > 0.2 rad at {nworse} px, better at {nbetter} px");
    println!("both hit: multi depth worse by > 0.1 h at {worse} px, better at {better} px");
    println!(
        "neither {} multi-only {} svo-only {} both {}",
        count[0], count[1], count[2], count[3]
    );
    println!(
        "multi-only: ref miss {} ref hit {}; svo-only: ref miss {} ref hit {}",
        mism[0][0], mism[0][1], mism[1][0], mism[1][1]
    );
    Ok(())
}
