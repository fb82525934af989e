//! The builder's memory budget: its peak memory estimated from the mesh's surface area before
//! anything large is allocated, so that a depth the machine cannot hold is refused in
//! milliseconds instead of aborting after minutes.
//!
//! A plane of area `A` with unit normal `n` crosses about `A·(|nx| + |ny| + |nz|) / h²` cells
//! of edge `h`; summed over the triangles of the normalised mesh this predicts the candidate
//! leaves of a depth. The peak bytes per candidate and per triangle are measured (peak RSS of
//! `sdfmo build` on the shared ABC models, depths 8–11, docs/results/build.md) and rounded up.

use sdfmo_mesh::TriMesh;

use crate::{BuildError, BuildSettings, Method, Result};

/// Peak bytes per predicted candidate leaf of an SVO build (measured 167–182 at depth 11 on
/// abc1, abc3, abc5; rounded up by a fifth).
const BYTES_PER_CELL_SVO: f64 = 220.0;
/// Peak bytes per predicted candidate leaf of a multi-octree build (gathered triangles, a
/// component split per leaf; measured 171–184 at depth 11).
const BYTES_PER_CELL_MULTI: f64 = 230.0;
/// Peak bytes per predicted candidate leaf that [`BuildSettings::fit_corners`] adds (each
/// fitted leaf's normal equations, point and slot tables, the solver's vectors, and the shared
/// points kept until the fit: measured 208–338 at depth 10 on abc1, abc3, abc5 and abc8, multi,
/// peak RSS with the fit less the estimate without it, the solver's vectors freed before the
/// brick pass; rounded up by a fifth). Without it abc3 depth 10 with the fit was predicted
/// 0.96 GB and took 2.2 GB.
const BYTES_PER_CELL_FIT: f64 = 400.0;
/// Bytes per triangle of the mesh copies and distance structures (BVH, packets, topology).
const BYTES_PER_TRIANGLE: f64 = 600.0;
/// Fixed cost: the process, the thread pool, the progress bar.
const BASE_BYTES: f64 = 64.0 * 1024.0 * 1024.0;

/// What [`estimate_memory`] predicts for one build.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MemoryEstimate {
    /// Predicted candidate leaves (cells crossed by the surface) at the requested depth.
    pub candidate_cells: f64,
    /// Predicted peak memory of the build in bytes.
    pub bytes: u64,
}

/// Predicts the peak memory of [`build`](crate::build) for `mesh` and `settings` in time
/// linear in the triangles, without building anything.
pub fn estimate_memory(mesh: &TriMesh, settings: &BuildSettings) -> MemoryEstimate {
    let norm = sdfmo_mesh::Normalization::for_bounds(&mesh.bounds(), settings.margin);
    let scale = f64::from(norm.scale);
    // Σ area · (|nx| + |ny| + |nz|) = Σ (|cx| + |cy| + |cz|) / 2 with c the cross product.
    let crossed: f64 = mesh
        .triangles()
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions()[v as usize].as_dvec3() * scale);
            let cr = (b - a).cross(c - a);
            0.5 * (cr.x.abs() + cr.y.abs() + cr.z.abs())
        })
        .sum();
    let cells_per_edge = (1u64 << settings.depth.min(62)) as f64;
    let h = 2.0 / cells_per_edge;
    // Never more than every cell of the grid.
    let candidate_cells = (crossed / (h * h)).min(cells_per_edge.powi(3));
    let per_cell = match settings.method {
        Method::Svo => BYTES_PER_CELL_SVO,
        Method::Multi { .. } => BYTES_PER_CELL_MULTI,
    } + if settings.fit_corners {
        BYTES_PER_CELL_FIT
    } else {
        0.0
    };
    let bytes = BASE_BYTES
        + candidate_cells * per_cell
        + mesh.triangles().len() as f64 * BYTES_PER_TRIANGLE;
    MemoryEstimate {
        candidate_cells,
        bytes: bytes.min(u64::MAX as f64) as u64,
    }
}

/// The prediction of [`estimate_memory`], or [`BuildError::MemoryBudget`] when it exceeds
/// `budget` (`None`: no limit). [`BuildRequest`](crate::BuildRequest) calls it before
/// any work; a caller that runs several builds (a sweep) can call it for all of them first.
pub fn check_memory(
    mesh: &TriMesh,
    settings: &BuildSettings,
    budget: Option<u64>,
) -> Result<MemoryEstimate> {
    let estimate = estimate_memory(mesh, settings);
    match budget {
        Some(budget) if estimate.bytes > budget => Err(BuildError::MemoryBudget {
            depth: settings.depth,
            estimate: estimate.bytes,
            budget,
        }),
        _ => Ok(estimate),
    }
}

/// Physical memory of the machine in bytes, where the platform says (Linux: `MemTotal` of
/// `/proc/meminfo`); `None` elsewhere.
pub fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The budget [`build`](crate::build) applies: half the physical memory, or no limit where the
/// platform does not say how much there is.
pub fn default_memory_budget() -> Option<u64> {
    physical_memory().map(|b| b / 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_fit_is_counted_per_candidate_leaf() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let mesh = TriMesh::new(p, vec![[0, 1, 2]], vec![0]).unwrap();
        for method in [Method::Svo, BuildSettings::default().method] {
            let exact = BuildSettings::default().with_depth(9).with_method(method);
            let fitted = exact.with_fit_corners(true);
            let (a, b) = (
                estimate_memory(&mesh, &exact),
                estimate_memory(&mesh, &fitted),
            );
            assert_eq!(a.candidate_cells, b.candidate_cells);
            let extra = (b.bytes - a.bytes) as f64 / a.candidate_cells;
            assert!(
                (extra - BYTES_PER_CELL_FIT).abs() < 1.0,
                "{extra} bytes per cell"
            );
        }
    }
}
