//! What the instruction-count examples share: their arguments (`MESH POINTS [OUT]`), the mesh
//! normalised as the builder does and its distance structure, and the query mix (half within
//! 0.02 of the surface, half uniform in the root cube), queried on a pool of one thread.

use glam::Vec3;
use sdfmo_distance::sample::{near_surface_points, uniform_points};
use sdfmo_distance::{MeshDistance, SignMode};

/// A run's inputs.
pub struct Queries {
    /// The mesh's distance structure (`SignMode::Auto`), freshly made.
    pub md: MeshDistance,
    /// The query mix.
    pub points: Vec<Vec3>,
    /// Where to write the answers' bits, if asked.
    pub out: Option<String>,
    /// One thread, so that callgrind counts one query after the other.
    pub pool: rayon::ThreadPool,
}

/// Reads `MESH POINTS [OUT]` from the command line (`usage` names the example on error).
pub fn queries(usage: &str) -> Result<Queries, Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(path), Some(n)) = (args.get(1), args.get(2)) else {
        eprintln!("usage: {usage} MESH POINTS [OUT]");
        std::process::exit(2);
    };
    let n: usize = n.parse()?;
    let loaded = sdfmo_mesh::load_mesh(std::path::Path::new(path))?;
    let (mesh, _) = loaded.mesh.normalized(0.05);
    let md = MeshDistance::new(&mesh, SignMode::Auto)?;
    let mut points = near_surface_points(&mesh, n / 2, 0.02, 1);
    points.extend(uniform_points(n - n / 2, 2));
    Ok(Queries {
        md,
        points,
        out: args.get(3).cloned(),
        pool: rayon::ThreadPoolBuilder::new().num_threads(1).build()?,
    })
}
