//! Mesh ingestion for sdf-multioctree: loading OBJ, glTF/GLB and STL files into a welded,
//! cleaned, validated [`TriMesh`]; normalisation into the octree's root cube; edge adjacency,
//! connected components and watertightness ([`Topology`]); procedural test parts
//! ([`procedural`]).
//!
//! ```
//! use sdfmo_mesh::procedural;
//! let mesh = procedural::demo_part();
//! let topo = mesh.topology();
//! assert_eq!(topo.component_count, 6);
//! let (normalized, transform) = mesh.normalized(0.05);
//! assert!((normalized.bounds().longest_extent() - 1.9).abs() < 1e-5);
//! assert!((transform.scale - 1.0).abs() < 1e-5);
//! ```
//!
//! Loading never panics on malformed input: every problem is a [`MeshError`] naming the file
//! and the reason, and no allocation is sized by a count that was not checked against the bytes
//! present (and against [`LoadLimits`]).
#![deny(missing_docs)]

mod clean;
mod error;
mod flat;
mod load;
mod mesh;
pub mod procedural;
mod topology;
mod union_find;
pub mod write;

pub use clean::{clean, weld_within, CleanReport};
pub use error::{MeshError, Result};
pub use flat::{retriangulate_flat_regions, FlatRegionSettings, Retriangulated};
pub use load::{
    detect_format, load_mesh, load_mesh_from_bytes, load_mesh_from_bytes_with_limits,
    load_mesh_with_limits, mesh_name, LoadLimits, LoadedMesh, MeshFormat,
};
pub use mesh::{Aabb, Normalization, TriMesh};
pub use topology::{EdgeAdjacency, EdgeFlags, Topology};
pub use union_find::UnionFind;

/// The numbers `sdfmo info` reports for a mesh, in one place.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshInfo {
    /// Triangles (after welding and cleaning, for loaded meshes).
    pub triangles: usize,
    /// Vertices.
    pub vertices: usize,
    /// Parts (largest part id + 1).
    pub parts: usize,
    /// Connected components through shared edges.
    pub components: usize,
    /// Edges with one incident triangle.
    pub boundary_edges: usize,
    /// Edges with more than two incident triangles.
    pub non_manifold_edges: usize,
    /// No boundary and no non-manifold edges.
    pub watertight: bool,
    /// Bounding box in model units.
    pub bounds: Aabb,
}

impl TriMesh {
    /// The summary `sdfmo info` prints (computes the topology).
    pub fn info(&self) -> MeshInfo {
        let t = self.topology();
        MeshInfo {
            triangles: self.triangle_count(),
            vertices: self.vertex_count(),
            parts: self.part_count(),
            components: t.component_count,
            boundary_edges: t.boundary_edges,
            non_manifold_edges: t.non_manifold_edges,
            watertight: t.watertight,
            bounds: self.bounds(),
        }
    }
}
