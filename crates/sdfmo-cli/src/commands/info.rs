//! `sdfmo info`: what a mesh is made of.

use serde_json::json;

use crate::args::InfoArgs;
use crate::commands::load_input;
use crate::output::{json_f32, print_json, print_text};

/// Prints the triangle, vertex, part and component counts, the open and non-manifold edges, the
/// watertight flag, the bounds and what loading cleaned up.
pub fn run(args: &InfoArgs) -> anyhow::Result<()> {
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
