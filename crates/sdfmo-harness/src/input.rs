//! The meshes a command reads: a file, or the built-in demo part.

use std::path::Path;

use sdf_multioctree::mesh::{self, CleanReport, TriMesh};

/// A mesh read from a file, or the built-in demo part.
pub struct InputMesh {
    /// The mesh in model units.
    pub mesh: TriMesh,
    /// What loading cleaned up (None for the demo part, which is generated clean).
    pub report: Option<CleanReport>,
    /// Where it came from: the path, or `demo`.
    pub source: String,
    /// Short name for tables and file names: the file stem, or `demo`.
    pub name: String,
    /// The format the file was read as (None for the demo part).
    pub format: Option<String>,
    /// Name of each part, where the file gives them.
    pub part_names: Vec<String>,
}

/// Loads `path`, or generates the built-in demo part when it is `None`.
///
/// # Errors
///
/// The mesh layer's error (it names the file) when the file cannot be read or parsed.
pub fn load_input(path: Option<&Path>) -> Result<InputMesh, mesh::MeshError> {
    match path {
        Some(p) => {
            // Every mesh error names the file already.
            let loaded = mesh::load_mesh(p)?;
            let name = mesh::mesh_name(p);
            Ok(InputMesh {
                mesh: loaded.mesh,
                report: Some(loaded.report),
                source: p.display().to_string(),
                name,
                format: Some(format!("{:?}", loaded.format).to_lowercase()),
                part_names: loaded.part_names,
            })
        }
        None => Ok(InputMesh {
            mesh: mesh::procedural::demo_part(),
            report: None,
            source: "demo".to_owned(),
            name: "demo".to_owned(),
            format: None,
            part_names: Vec::new(),
        }),
    }
}
