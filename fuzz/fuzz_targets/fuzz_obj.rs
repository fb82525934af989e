//! Fuzzes the OBJ loader (one validating pass, `src/load/obj.rs`): any bytes must give a `MeshError` or a valid mesh, never a panic, an
//! out-of-bounds read or an allocation sized by an unchecked count.
//!
//! Properties checked on every accepted input: the mesh satisfies `TriMesh::new`'s
//! invariants; cleaning it again changes nothing (welding and cleaning are idempotent); its
//! topology is consistent; and written as binary STL and read back it gives the same triangles.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sdfmo_mesh::{load_mesh_from_bytes_with_limits, write, LoadLimits, MeshFormat, TriMesh};

/// Small limits keep the fuzzer's memory bounded (instancing and polygons amplify).
const LIMITS: LoadLimits = LoadLimits {
    max_triangles: 1 << 18,
    max_vertices: 1 << 18,
    max_node_visits: 1 << 12,
    max_file_bytes: 1 << 24,
};

fn check(m: &TriMesh) {
    TriMesh::new(m.positions.clone(), m.triangles.clone(), m.parts.clone()).expect("invariants");
    let (again, report) = m.cleaned().expect("a clean mesh cleans");
    assert_eq!(again.triangle_count(), m.triangle_count());
    assert_eq!(again.vertex_count(), m.vertex_count());
    assert_eq!(report.welded_vertices + report.degenerate_triangles + report.duplicate_triangles, 0);
    let t = m.topology();
    assert_eq!(t.component_of_triangle.len(), m.triangle_count());
    assert!(t.component_count >= 1 && t.component_count <= m.triangle_count());
    assert_eq!(t.watertight, t.boundary_edges == 0 && t.non_manifold_edges == 0);
    let stl = write::to_stl_binary(m);
    let back = load_mesh_from_bytes_with_limits(&stl, "roundtrip.stl", Some(MeshFormat::Stl), &LIMITS)
        .expect("binary STL of a clean mesh loads");
    assert_eq!(back.mesh.triangle_count(), m.triangle_count());
    for i in 0..m.triangle_count() {
        assert!(back.mesh.triangle(i) == m.triangle(i), "triangle {i} changed in the round trip");
    }
}

fuzz_target!(|data: &[u8]| {
    if let Ok(l) = load_mesh_from_bytes_with_limits(data, "fuzz.obj", Some(MeshFormat::Obj), &LIMITS) {
        check(&l.mesh);
    }
});
