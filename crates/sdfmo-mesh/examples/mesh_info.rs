//! Loads meshes and prints what `sdfmo info` reports, with timings, as a Markdown table:
//! `cargo run --release -p sdfmo-mesh --example mesh_info -- ../shared/data/*.stl`.
//! Without arguments it reports the built-in demo part. `--weld TOL` (first) additionally
//! merges vertices closer than TOL model units (`TriMesh::welded_within`) before reporting;
//! the cleaning columns then describe that second weld.

use std::time::Instant;

use sdfmo_mesh::{load_mesh, procedural, CleanReport, TriMesh};

fn row(name: &str, mesh: &TriMesh, report: Option<&CleanReport>, load_ms: f64) {
    let t = Instant::now();
    let info = mesh.info();
    let topo_ms = t.elapsed().as_secs_f64() * 1e3;
    let (input, welded, degenerate, duplicate) =
        report.map_or((mesh.triangle_count(), 0, 0, 0), |r| {
            (
                r.input_triangles,
                r.welded_vertices,
                r.degenerate_triangles,
                r.duplicate_triangles,
            )
        });
    println!(
        "| {name} | {input} | {} | {} | {welded} | {degenerate} | {duplicate} | {} | {} | {} | {} | {} | {load_ms:.1} | {topo_ms:.1} |",
        info.triangles,
        info.vertices,
        info.parts,
        info.components,
        info.boundary_edges,
        info.non_manifold_edges,
        info.watertight,
    );
}

fn main() {
    println!("| file | input tris | triangles | vertices | welded | degenerate | duplicate | parts | components | boundary | non-manifold | watertight | load ms | topology ms |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut paths: Vec<String> = std::env::args().skip(1).collect();
    let mut weld = None;
    if paths.first().map(String::as_str) == Some("--weld") && paths.len() >= 2 {
        weld = Some(paths[1].parse::<f32>().expect("--weld needs a number"));
        paths.drain(..2);
    }
    if paths.is_empty() {
        row("demo_part()", &procedural::demo_part(), None, 0.0);
    }
    for p in paths {
        let t = Instant::now();
        match load_mesh(std::path::Path::new(&p)) {
            Ok(mut l) => {
                if let Some(tol) = weld {
                    match l.mesh.welded_within(tol) {
                        Ok((m, r)) => (l.mesh, l.report) = (m, r),
                        Err(e) => eprintln!("error: {e}"),
                    }
                }
                let ms = t.elapsed().as_secs_f64() * 1e3;
                let name = std::path::Path::new(&p)
                    .file_name()
                    .map_or(p.clone(), |n| n.to_string_lossy().into());
                row(&name, &l.mesh, Some(&l.report), ms);
            }
            Err(e) => eprintln!("error: {e}"),
        }
    }
}
