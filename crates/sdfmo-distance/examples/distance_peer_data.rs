//! Writes a normalised mesh, benchmark query points and our signed distances to raw files, and
//! times our queries, for `benches/peers/libigl_distance.py` (the libigl comparison).
//!
//! ```text
//! cargo run --release -p sdfmo-distance --example distance_peer_data -- MESH OUT_DIR [N] [REPEATS]
//! ```
//!
//! Files in OUT_DIR (little-endian, no header): `vertices.f32` (V×3), `faces.u32` (F×3),
//! `near.f32` / `uniform.f32` (N×3 points) and `near.ours.f32` / `uniform.ours.f32` (N signed
//! distances). The last line on stdout is a JSON object with the sign mode, the build time and,
//! per point set, the median time over REPEATS runs of the batch query (rayon, all cores) and
//! of a single-threaded loop of `signed_distance`.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use sdfmo_distance::sample::{near_surface_points, uniform_points};
use sdfmo_distance::{MeshDistance, SignMode};

fn write_f32(path: &PathBuf, data: impl Iterator<Item = f32>) -> Result<(), sdfmo_io::IoError> {
    let bytes: Vec<u8> = data.flat_map(f32::to_le_bytes).collect();
    sdfmo_io::write_atomic(path, bytes)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: distance_peer_data MESH OUT_DIR [N] [REPEATS]");
        std::process::exit(2);
    }
    let out = PathBuf::from(&args[2]);
    let n: usize = args
        .get(3)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(100_000);
    let repeats: usize = args
        .get(4)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(5)
        .max(1);
    std::fs::create_dir_all(&out)?;
    let loaded = sdfmo_mesh::load_mesh(std::path::Path::new(&args[1]))?;
    let (mesh, _) = loaded.mesh.normalized(0.05);
    write_f32(
        &out.join("vertices.f32"),
        mesh.positions().iter().flat_map(|p| p.to_array()),
    )?;
    let faces: Vec<u8> = mesh
        .triangles()
        .iter()
        .flatten()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    sdfmo_io::write_atomic(out.join("faces.u32"), faces)?;

    let t0 = Instant::now();
    let md = MeshDistance::new(&mesh, SignMode::Auto)?;
    // Included in the build time: the one-time data the first signed query computes (the
    // clean-neighbourhood radii of the winding-number sign).
    md.prepare_sign();
    let build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let sets: [(&str, Vec<Vec3>); 2] = [
        ("near", near_surface_points(&mesh, n, 0.02, 1)),
        ("uniform", uniform_points(n, 2)),
    ];
    let mut json = format!(
        "{{\"triangles\": {}, \"sign\": \"{:?}\", \"build_ms\": {build_ms:.3}, \"threads\": {}",
        mesh.triangle_count(),
        md.sign_mode(),
        rayon::current_num_threads()
    );
    for (name, pts) in &sets {
        write_f32(
            &out.join(format!("{name}.f32")),
            pts.iter().flat_map(|p| p.to_array()),
        )?;
        let mut batch = Vec::new();
        let mut single = Vec::new();
        let mut result = Vec::new();
        for _ in 0..repeats {
            let t = Instant::now();
            result = md.signed_distances(pts);
            batch.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            let s: Vec<f32> = pts.iter().map(|&p| md.signed_distance(p)).collect();
            single.push(t.elapsed().as_secs_f64());
            assert_eq!(s, result, "single and batch queries agree");
        }
        write_f32(
            &out.join(format!("{name}.ours.f32")),
            result.iter().copied(),
        )?;
        // Sign checks (winding mode): the two-stage sign against the full hierarchical winding
        // number (β = 2) on every point, and against the exact winding number on every 100th.
        let (mut vs_full, mut vs_exact, mut exact_n) = (0usize, 0usize, 0usize);
        if md.sign_mode() == SignMode::Winding {
            for (i, (&p, &d)) in pts.iter().zip(&result).enumerate() {
                let inside = d < 0.0;
                vs_full += usize::from((md.winding_number(p) > 0.5) != inside);
                if i % 100 == 0 {
                    exact_n += 1;
                    vs_exact += usize::from((md.winding_number_exact(p) > 0.5) != inside);
                }
            }
        }
        let (b, s) = (median(batch), median(single));
        json += &format!(
            ", \"{name}\": {{\"points\": {}, \"batch_s\": {b:.6}, \"single_s\": {s:.6}, \"batch_pts_per_s\": {:.0}, \"single_pts_per_s\": {:.0}, \"sign_vs_full_winding\": {vs_full}, \"sign_vs_exact_winding\": {vs_exact}, \"exact_checked\": {exact_n}}}",
            pts.len(),
            pts.len() as f64 / b,
            pts.len() as f64 / s
        );
    }
    json += "}";
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{json}")?;
    Ok(())
}
