//! What the mesh-loader fuzz targets share: bounded limits and the properties every accepted
//! mesh must have. Included by each target with `mod mesh_common;`.

use sdfmo_mesh::{load_mesh_from_bytes_with_limits, write, LoadLimits, MeshFormat, TriMesh};

/// Small limits keep the fuzzer's memory bounded (instancing and polygons amplify).
pub const LIMITS: LoadLimits = LoadLimits {
    max_triangles: 1 << 18,
    max_vertices: 1 << 18,
    max_node_visits: 1 << 12,
    max_file_bytes: 1 << 24,
};

/// The mesh satisfies `TriMesh::new`'s invariants; cleaning it again changes nothing; its
/// topology is consistent; written as binary STL and read back it gives the same triangles.
pub fn check(m: &TriMesh) {
    TriMesh::new(m.positions().to_vec(), m.triangles().to_vec(), m.parts().to_vec()).expect("invariants");
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

