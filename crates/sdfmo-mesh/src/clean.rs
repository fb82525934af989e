//! Welding of bit-identical vertices and removal of degenerate and duplicate triangles.

use std::collections::{HashMap, HashSet};

use glam::Vec3;

use crate::error::{MeshError, Result};
use crate::mesh::{cross_f64, validate, TriMesh};

/// What cleaning changed (all counts refer to the input as loaded).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CleanReport {
    /// Vertices in the input (STL: three per triangle).
    pub input_vertices: usize,
    /// Triangles in the input (after triangulating polygons).
    pub input_triangles: usize,
    /// Referenced input vertices merged into an earlier vertex with bit-identical coordinates
    /// (−0.0 and +0.0 count as identical).
    pub welded_vertices: usize,
    /// Vertices dropped because no kept triangle uses them.
    pub unreferenced_vertices: usize,
    /// Triangles removed because their area is zero (a repeated welded vertex, or collinear
    /// corners: the f64 cross product of two edges is exactly zero).
    pub degenerate_triangles: usize,
    /// Triangles removed because an earlier triangle has the same three welded vertices (in any
    /// order or orientation, whatever their parts).
    pub duplicate_triangles: usize,
}

#[inline]
fn key(p: Vec3) -> [u32; 3] {
    // +0.0 for −0.0, so the two zeros weld; NaN never reaches here (validated first).
    p.to_array().map(|c| (c + 0.0).to_bits())
}

/// Welds bit-identical vertices, drops degenerate and duplicate triangles and unreferenced
/// vertices, and returns the clean mesh with a report. `file` names the source in errors.
///
/// Vertices of the result are numbered in order of first use by the kept triangles; triangles
/// keep their order and part ids.
///
/// # Errors
/// [`MeshError::NonFinite`], [`MeshError::IndexOutOfRange`], [`MeshError::InvalidMesh`] for
/// invalid input; [`MeshError::NoTriangles`] if nothing is left.
pub fn clean(
    file: &str,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    parts: &[u32],
) -> Result<(TriMesh, CleanReport)> {
    validate(file, positions, triangles)?;
    if parts.len() != triangles.len() {
        return Err(MeshError::InvalidMesh {
            file: file.into(),
            reason: format!("{} part ids for {} triangles", parts.len(), triangles.len()),
        });
    }
    clean_valid(file, positions, triangles, parts)
}

/// [`clean`] of arrays already known to be valid (those of a [`TriMesh`]).
fn clean_valid(
    file: &str,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    parts: &[u32],
) -> Result<(TriMesh, CleanReport)> {
    let mut report = CleanReport {
        input_vertices: positions.len(),
        input_triangles: triangles.len(),
        ..CleanReport::default()
    };

    // 1. Weld: map each referenced input vertex to the first vertex with the same bits.
    let mut weld = vec![u32::MAX; positions.len()];
    let mut first_of_key: HashMap<[u32; 3], u32> =
        HashMap::with_capacity(positions.len().min(1 << 20));
    let mut referenced = 0usize;
    for t in triangles {
        for &v in t {
            if weld[v as usize] == u32::MAX {
                referenced += 1;
                weld[v as usize] = *first_of_key.entry(key(positions[v as usize])).or_insert(v);
            }
        }
    }
    report.welded_vertices = referenced - first_of_key.len();

    // 2. Drop degenerate and duplicate triangles.
    let mut seen: HashSet<[u32; 3]> = HashSet::with_capacity(triangles.len().min(1 << 22));
    let mut kept = Vec::with_capacity(triangles.len());
    let mut kept_parts = Vec::with_capacity(triangles.len());
    for (t, &part) in triangles.iter().zip(parts) {
        let w = t.map(|v| weld[v as usize]);
        if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] {
            report.degenerate_triangles += 1;
            continue;
        }
        let n = cross_f64(
            positions[w[0] as usize],
            positions[w[1] as usize],
            positions[w[2] as usize],
        );
        if n == [0.0; 3] {
            report.degenerate_triangles += 1;
            continue;
        }
        let mut sorted = w;
        sorted.sort_unstable();
        if !seen.insert(sorted) {
            report.duplicate_triangles += 1;
            continue;
        }
        kept.push(w);
        kept_parts.push(part);
    }
    if kept.is_empty() {
        return Err(MeshError::NoTriangles {
            file: file.into(),
            reason: format!(
                "all {} triangles are degenerate or duplicates",
                triangles.len()
            ),
        });
    }

    // 3. Compact the vertices in order of first use.
    let mut compact = vec![u32::MAX; positions.len()];
    let mut out_positions = Vec::with_capacity(first_of_key.len());
    for t in kept.iter_mut() {
        for v in t.iter_mut() {
            let c = &mut compact[*v as usize];
            if *c == u32::MAX {
                *c = out_positions.len() as u32;
                out_positions.push(positions[*v as usize]);
            }
            *v = *c;
        }
    }
    report.unreferenced_vertices = positions.len() - out_positions.len() - report.welded_vertices;
    Ok((TriMesh::from_valid(out_positions, kept, kept_parts), report))
}

impl TriMesh {
    /// The triangles in vertex ids welded by exact position (bit-identical, `+0.0` = `−0.0`),
    /// with the welded positions numbered in order of first occurrence among `positions`: the
    /// ids topology needs where a loader repeats a position across parts (OBJ objects, glTF
    /// primitives). Unlike [`TriMesh::cleaned`], no triangle is dropped and parts stay apart.
    pub fn welded_by_position(&self) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(self.vertex_count());
        let mut welded = Vec::with_capacity(self.vertex_count());
        let remap: Vec<u32> = self
            .positions()
            .iter()
            .map(|&p| {
                *first.entry(key(p)).or_insert_with(|| {
                    welded.push(p);
                    (welded.len() - 1) as u32
                })
            })
            .collect();
        let triangles = self
            .triangles()
            .iter()
            .map(|t| t.map(|v| remap[v as usize]))
            .collect();
        (welded, triangles)
    }
}

impl TriMesh {
    /// This mesh welded and cleaned (see [`clean`]).
    ///
    /// # Errors
    /// [`MeshError::NoTriangles`] if every triangle is degenerate or a duplicate.
    pub fn cleaned(&self) -> Result<(TriMesh, CleanReport)> {
        clean_valid(
            crate::mesh::MEMORY,
            self.positions(),
            self.triangles(),
            self.parts(),
        )
    }
}

/// Merges vertices closer than `tolerance` (Euclidean, transitively: chains of close vertices
/// become one vertex, at the position of the chain's lowest-index vertex), then cleans as
/// [`clean`]. For CAD seams whose two sides were written with slightly different coordinates;
/// `tolerance <= 0` is the exact (bit-identical) weld. The report's `welded_vertices` counts
/// both kinds of merge.
///
/// # Errors
/// As [`clean`].
pub fn weld_within(mesh: &TriMesh, tolerance: f32) -> Result<(TriMesh, CleanReport)> {
    if tolerance.is_nan() || tolerance <= 0.0 || tolerance.is_infinite() {
        return mesh.cleaned();
    }
    let n = mesh.positions().len();
    let cell = |p: Vec3| (p / tolerance).floor().as_i64vec3().to_array();
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::with_capacity(n.min(1 << 22));
    for (i, &p) in mesh.positions().iter().enumerate() {
        grid.entry(cell(p)).or_default().push(i as u32);
    }
    // Union–find over vertices; the root is always the lowest index of its set.
    let mut sets = crate::UnionFind::new(n);
    let tol2 = tolerance * tolerance;
    for (i, &p) in mesh.positions().iter().enumerate() {
        let c = cell(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(others) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                        continue;
                    };
                    for &j in others {
                        if (j as usize) < i
                            && p.distance_squared(mesh.positions()[j as usize]) <= tol2
                        {
                            sets.union(i as u32, j);
                        }
                    }
                }
            }
        }
    }
    let positions: Vec<Vec3> = (0..n as u32)
        .map(|i| mesh.positions()[sets.find(i) as usize])
        .collect();
    // Every welded position is one of the mesh's own: still valid.
    clean_valid(
        crate::mesh::MEMORY,
        &positions,
        mesh.triangles(),
        mesh.parts(),
    )
}

impl TriMesh {
    /// This mesh with vertices closer than `tolerance` merged, then cleaned (see
    /// [`weld_within`]).
    ///
    /// # Errors
    /// [`MeshError::NoTriangles`] if every triangle collapses.
    pub fn welded_within(&self, tolerance: f32) -> Result<(TriMesh, CleanReport)> {
        weld_within(self, tolerance)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welds_drops_and_counts() {
        // A quad as a triangle soup (6 vertices), plus a duplicate with flipped orientation,
        // a degenerate (collinear) triangle, a repeated-vertex one and an unused vertex.
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-0.0, 0.0, 0.0), // welds with vertex 0 (signed zero)
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(9.0, 9.0, 9.0), // unused
        ];
        let t = vec![[0, 1, 2], [3, 4, 5], [2, 1, 0], [0, 1, 6], [0, 3, 2]];
        let (m, r) = clean("x", &p, &t, &[0, 1, 2, 3, 4]).unwrap();
        assert_eq!(m.triangles(), vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.parts(), vec![0, 1]);
        assert_eq!(m.positions().len(), 4);
        assert_eq!(
            r,
            CleanReport {
                input_vertices: 8,
                input_triangles: 5,
                welded_vertices: 2,
                unreferenced_vertices: 2,
                degenerate_triangles: 2,
                duplicate_triangles: 1,
            }
        );
        assert!(m.topology().component_count == 1);
    }

    #[test]
    fn all_degenerate_is_an_error() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        let e = clean("f.stl", &p, &[[0, 1, 2]], &[0]).unwrap_err();
        assert!(matches!(e, MeshError::NoTriangles { .. }));
        assert!(e.to_string().starts_with("f.stl: "));
    }

    #[test]
    fn tolerance_weld_closes_jittered_seams() {
        // A box as a triangle soup whose copies of each corner differ by up to 2e-6.
        let b = crate::procedural::box_mesh(Vec3::ZERO, Vec3::ONE);
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for (t, tri) in b.triangles().iter().enumerate() {
            let base = positions.len() as u32;
            for (k, &v) in tri.iter().enumerate() {
                let jitter = ((t * 3 + k) % 5) as f32 * 5e-7;
                positions.push(b.positions()[v as usize] + Vec3::splat(jitter));
            }
            triangles.push([base, base + 1, base + 2]);
        }
        let soup = TriMesh::new(positions, triangles, vec![0; 12]).unwrap();
        let (exact, _) = soup.cleaned().unwrap();
        assert!(!exact.topology().watertight);
        let (welded, r) = soup.welded_within(1e-5).unwrap();
        assert_eq!((welded.vertex_count(), welded.triangle_count()), (8, 12));
        assert_eq!(r.welded_vertices, 28);
        assert!(welded.topology().watertight);
        // A tolerance below the jitter leaves the seams open.
        let (tight, _) = soup.welded_within(1e-7).unwrap();
        assert!(tight.vertex_count() > 8);
        // Zero tolerance is the exact weld.
        assert_eq!(soup.welded_within(0.0).unwrap().0, exact);
    }
}
