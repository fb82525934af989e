//! The triangle mesh, its bounding box and the normalisation into the octree's root cube.

use glam::{DVec3, Vec3};

use crate::error::{MeshError, Result};

/// File name used in errors about meshes built in memory.
pub(crate) const MEMORY: &str = "<memory>";

/// An indexed triangle mesh in f32 with a part id per triangle.
///
/// Invariants: every position is finite, every index is in range,
/// `parts().len() == triangles().len()`, and there is at least one triangle. The fields are
/// private and every way to make a mesh keeps them ([`TriMesh::new`] and [`crate::clean`]
/// check their input; the loaders, [`TriMesh::transformed`], [`TriMesh::merge`] and the
/// [`crate::procedural`] parts keep them), so no layer above checks a `TriMesh` again.
#[derive(Clone, Debug, PartialEq)]
pub struct TriMesh {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    parts: Vec<u32>,
}

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (min = +inf, max = −inf), the identity of [`Aabb::grow`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The smallest box holding all `points` ([`Aabb::EMPTY`] for none).
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grow(p))
    }

    /// This box grown to hold `p`.
    #[must_use]
    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// Edge lengths (`max − min`).
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// Centre of the box.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// The longest edge length.
    pub fn longest_extent(&self) -> f32 {
        self.size().max_element()
    }

    /// Whether `p` lies inside or on the box.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
}

/// The similarity transform from model units into the normalised frame.
///
/// normalized = (model − center) · scale;  model = normalized / scale + center.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalization {
    /// Model-space point mapped to the origin (the bounding-box centre).
    pub center: Vec3,
    /// Uniform scale from model units to normalised units.
    pub scale: f32,
}

impl Normalization {
    /// The identity transform.
    pub const IDENTITY: Normalization = Normalization {
        center: Vec3::ZERO,
        scale: 1.0,
    };

    /// The transform that puts the centre of `bounds` at the origin and scales its longest
    /// extent to `2·(1 − margin)`. A box of zero extent gets scale 1.
    ///
    /// For a finite box the transform maps every point of the box to a finite point: where
    /// `min + max` overflows f32 the centre is taken as `min / 2 + max / 2`, and where the scale
    /// would overflow (a subnormal extent) it is 1. Neither happens for a box that fits f32
    /// comfortably, so ordinary meshes get the plain formula.
    pub fn for_bounds(bounds: &Aabb, margin: f32) -> Normalization {
        let longest = bounds.longest_extent();
        let target = 2.0 * (1.0 - margin);
        let scale = if longest > 0.0 && longest.is_finite() {
            target / longest
        } else {
            1.0
        };
        let center = bounds.center();
        Normalization {
            center: if center.is_finite() {
                center
            } else {
                bounds.min * 0.5 + bounds.max * 0.5
            },
            scale: if scale.is_finite() { scale } else { 1.0 },
        }
    }

    /// Model units → normalised frame.
    #[inline]
    pub fn to_normalized(&self, p: Vec3) -> Vec3 {
        (p - self.center) * self.scale
    }

    /// Normalised frame → model units.
    #[inline]
    pub fn to_model(&self, p: Vec3) -> Vec3 {
        p / self.scale + self.center
    }

    /// A model-unit point given in f64 (text, float64 arrays, a camera) → the normalised frame,
    /// computed in f64 and rounded once: the one conversion every front-end uses, so that the
    /// command line, Python and the facade query the same normalised point for the same input.
    /// Non-finite where the image overflows f32.
    #[inline]
    pub fn point_to_normalized(&self, p: DVec3) -> Vec3 {
        ((p - self.center.as_dvec3()) * f64::from(self.scale)).as_vec3()
    }

    /// A normalised-frame point → model units, in f64 and rounded once (the inverse of
    /// [`point_to_normalized`](Self::point_to_normalized) up to rounding).
    #[inline]
    pub fn point_to_model(&self, p: Vec3) -> Vec3 {
        (p.as_dvec3() / f64::from(self.scale) + self.center.as_dvec3()).as_vec3()
    }

    /// A length (a distance) of the normalised frame in model units, in f64 and rounded once.
    #[inline]
    pub fn length_to_model(&self, d: f32) -> f32 {
        (f64::from(d) / f64::from(self.scale)) as f32
    }
}

impl TriMesh {
    /// Builds a mesh after validating it: finite positions, indices in range,
    /// `parts.len() == triangles.len()`, at least one triangle. Does not weld or clean
    /// (see [`crate::clean`] for that).
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, parts: Vec<u32>) -> Result<TriMesh> {
        validate(MEMORY, &positions, &triangles)?;
        if parts.len() != triangles.len() {
            return Err(MeshError::InvalidMesh {
                file: MEMORY.into(),
                reason: format!("{} part ids for {} triangles", parts.len(), triangles.len()),
            });
        }
        Ok(TriMesh::from_valid(positions, triangles, parts))
    }

    /// A mesh from arrays the caller has already validated (inside this crate only): checked
    /// again in debug builds.
    pub(crate) fn from_valid(
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        parts: Vec<u32>,
    ) -> TriMesh {
        debug_assert!(validate(MEMORY, &positions, &triangles).is_ok());
        debug_assert_eq!(parts.len(), triangles.len());
        TriMesh {
            positions,
            triangles,
            parts,
        }
    }

    /// Vertex positions (all finite).
    #[inline]
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Triangles as three vertex indices (each below [`TriMesh::vertex_count`]),
    /// counter-clockwise seen from outside.
    #[inline]
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Part id per triangle (OBJ object/group, glTF primitive, ASCII STL solid);
    /// `0..part_count()`.
    #[inline]
    pub fn parts(&self) -> &[u32] {
        &self.parts
    }

    /// The positions, triangles and part ids, moved out.
    pub fn into_arrays(self) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<u32>) {
        (self.positions, self.triangles, self.parts)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of parts: the largest part id + 1 (0 for a mesh without triangles).
    pub fn part_count(&self) -> usize {
        self.parts.iter().max().map_or(0, |&m| m as usize + 1)
    }

    /// The three corners of triangle `i`.
    ///
    /// # Panics
    /// If `i` is out of range (like slice indexing).
    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[i];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Bounding box of the vertices referenced by triangles.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for t in &self.triangles {
            for &v in t {
                b = b.grow(self.positions[v as usize]);
            }
        }
        b
    }

    /// The mesh moved into the normalised frame: centre of the bounding box to the origin,
    /// longest extent to `2·(1 − margin)`; returns the transform too.
    ///
    /// # Panics
    /// Only if a vertex that no triangle references lies so far outside the triangles' box that
    /// its image overflows f32 (the referenced ones always map to finite points, see
    /// [`Normalization::for_bounds`]; loaded and cleaned meshes have no unreferenced vertices).
    pub fn normalized(&self, margin: f32) -> (TriMesh, Normalization) {
        let n = Normalization::for_bounds(&self.bounds(), margin);
        (self.transformed(|p| n.to_normalized(p)), n)
    }

    /// A copy with every position mapped by `f` (triangles and parts unchanged).
    ///
    /// # Panics
    /// If `f` maps a position to a non-finite one (the mesh would break its invariant); use
    /// [`TriMesh::try_transformed`] where the map can overflow.
    pub fn transformed(&self, f: impl Fn(Vec3) -> Vec3) -> TriMesh {
        match self.try_transformed(f) {
            Ok(m) => m,
            Err(e) => panic!("TriMesh::transformed: {e}"),
        }
    }

    /// A copy with every position mapped by `f` (triangles and parts unchanged).
    ///
    /// # Errors
    /// [`MeshError::NonFinite`] if `f` maps a position to a non-finite one.
    pub fn try_transformed(&self, f: impl Fn(Vec3) -> Vec3) -> Result<TriMesh> {
        let positions: Vec<Vec3> = self.positions.iter().map(|&p| f(p)).collect();
        validate(MEMORY, &positions, &self.triangles)?;
        Ok(TriMesh::from_valid(
            positions,
            self.triangles.clone(),
            self.parts.clone(),
        ))
    }

    /// Concatenates meshes; the part ids of each input are offset by the part counts of the
    /// inputs before it, so parts stay distinct.
    ///
    /// # Panics
    /// If `meshes` is empty (a mesh has at least one triangle).
    pub fn merge(meshes: &[TriMesh]) -> TriMesh {
        assert!(!meshes.is_empty(), "TriMesh::merge of no meshes");
        let mut out = TriMesh {
            positions: Vec::new(),
            triangles: Vec::new(),
            parts: Vec::new(),
        };
        let mut part_base = 0u32;
        for m in meshes {
            let base = out.positions.len() as u32;
            out.positions.extend_from_slice(&m.positions);
            out.triangles
                .extend(m.triangles.iter().map(|t| t.map(|v| v + base)));
            out.parts.extend(m.parts.iter().map(|p| p + part_base));
            part_base += m.part_count() as u32;
        }
        out
    }

    /// Twice the area vector (cross product of two edges) of triangle `i`, in f64.
    pub fn triangle_normal_f64(&self, i: usize) -> [f64; 3] {
        let [a, b, c] = self.triangle(i);
        cross_f64(a, b, c)
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        (0..self.triangle_count())
            .map(|i| {
                let n = self.triangle_normal_f64(i);
                0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
            })
            .sum()
    }
}

/// (b − a) × (c − a) in f64.
pub(crate) fn cross_f64(a: Vec3, b: Vec3, c: Vec3) -> [f64; 3] {
    let e1 = [
        b.x as f64 - a.x as f64,
        b.y as f64 - a.y as f64,
        b.z as f64 - a.z as f64,
    ];
    let e2 = [
        c.x as f64 - a.x as f64,
        c.y as f64 - a.y as f64,
        c.z as f64 - a.z as f64,
    ];
    [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ]
}

/// Checks that every index of `triangles` is below `vertex_count`; the error names the element
/// as `{prefix}triangle {i}`.
pub(crate) fn check_indices(
    file: &str,
    prefix: &str,
    triangles: &[[u32; 3]],
    vertex_count: usize,
) -> Result<()> {
    for (i, t) in triangles.iter().enumerate() {
        if let Some(&v) = t.iter().find(|&&v| v as usize >= vertex_count) {
            return Err(MeshError::IndexOutOfRange {
                file: file.into(),
                element: format!("{prefix}triangle {i}"),
                index: v as i64,
                vertex_count,
            });
        }
    }
    Ok(())
}

/// Checks finite positions, indices in range and at least one triangle.
pub(crate) fn validate(file: &str, positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<()> {
    for (i, p) in positions.iter().enumerate() {
        if !p.is_finite() {
            let bad = p.to_array().into_iter().find(|c| !c.is_finite());
            return Err(MeshError::NonFinite {
                file: file.into(),
                element: format!("vertex {i}"),
                value: format!("{}", bad.unwrap_or(f32::NAN)),
            });
        }
    }
    check_indices(file, "", triangles, positions.len())?;
    if triangles.is_empty() {
        return Err(MeshError::NoTriangles {
            file: file.into(),
            reason: "the triangle list is empty".into(),
        });
    }
    check_extent(file, positions, triangles)
}

/// Refuses a mesh that cannot be normalised: the extent of its triangles' bounding box
/// overflows f32 (vertices near ±3.4e38 on both sides), or is so small that the scale to the
/// normalised frame overflows. Both used to give a normalisation of scale 1 and wrong
/// distances without an error.
pub(crate) fn check_extent(file: &str, positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<()> {
    let b = Aabb::from_points(triangles.iter().flatten().map(|&v| positions[v as usize]));
    let extent = b.max - b.min;
    let longest = extent.max_element();
    let reason = if !extent.is_finite() {
        format!(
            "the bounding box {:?}..{:?} is wider than f32 can represent (extent {:?}): the \
             mesh cannot be normalised",
            b.min.to_array(),
            b.max.to_array(),
            extent.to_array()
        )
    } else if longest > 0.0 && !(2.0 / longest).is_finite() {
        format!("the bounding box's extent {longest:e} is too small to normalise in f32")
    } else {
        return Ok(());
    };
    Err(MeshError::InvalidMesh {
        file: file.into(),
        reason,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> TriMesh {
        TriMesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 4.0, 2.0)],
            vec![[0, 1, 2]],
            vec![0],
        )
        .unwrap()
    }

    #[test]
    fn a_mesh_wider_than_f32_is_refused() {
        // Issue 32: vertices near ±3e38 made the extent overflow; the normalisation fell back
        // to scale 1 and every distance was wrong, without an error.
        let p = vec![
            Vec3::new(-3e38, 0.0, 0.0),
            Vec3::new(3e38, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let e = TriMesh::new(p, vec![[0, 1, 2]], vec![0]).unwrap_err();
        assert!(matches!(e, MeshError::InvalidMesh { .. }), "{e}");
        assert!(e.to_string().contains("wider than f32"), "{e}");
        // Far from the origin but narrow enough is fine.
        let p = vec![
            Vec3::new(1e38, 0.0, 0.0),
            Vec3::new(3e38, 0.0, 0.0),
            Vec3::new(2e38, 1e38, 0.0),
        ];
        TriMesh::new(p, vec![[0, 1, 2]], vec![0]).unwrap();
        let tiny = vec![
            Vec3::ZERO,
            Vec3::new(1e-44, 0.0, 0.0),
            Vec3::new(0.0, 1e-44, 0.0),
        ];
        let e = TriMesh::new(tiny, vec![[0, 1, 2]], vec![0]).unwrap_err();
        assert!(e.to_string().contains("too small"), "{e}");
    }

    #[test]
    fn new_rejects_bad_input() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(matches!(
            TriMesh::new(p.clone(), vec![[0, 1, 3]], vec![0]),
            Err(MeshError::IndexOutOfRange {
                index: 3,
                vertex_count: 3,
                ..
            })
        ));
        assert!(matches!(
            TriMesh::new(p.clone(), vec![], vec![]),
            Err(MeshError::NoTriangles { .. })
        ));
        assert!(matches!(
            TriMesh::new(p.clone(), vec![[0, 1, 2]], vec![]),
            Err(MeshError::InvalidMesh { .. })
        ));
        let mut q = p;
        q[1].y = f32::NAN;
        let e = TriMesh::new(q, vec![[0, 1, 2]], vec![0]).unwrap_err();
        assert!(matches!(e, MeshError::NonFinite { ref element, .. } if element == "vertex 1"));
        assert!(e.to_string().contains("<memory>"), "{e}");
    }

    #[test]
    fn counts_bounds_and_normalisation() {
        let m = tri();
        assert_eq!(
            (m.triangle_count(), m.vertex_count(), m.part_count()),
            (1, 3, 1)
        );
        let b = m.bounds();
        assert_eq!(b.min, Vec3::ZERO);
        assert_eq!(b.max, Vec3::new(1.0, 4.0, 2.0));
        let (n, t) = m.normalized(0.05);
        let nb = n.bounds();
        assert!((nb.longest_extent() - 1.9).abs() < 1e-6);
        assert!((nb.center()).length() < 1e-6);
        assert!((t.scale - 1.9 / 4.0).abs() < 1e-7);
        for (p, q) in m.positions.iter().zip(&n.positions) {
            assert!((t.to_model(*q) - *p).length() < 1e-6);
            assert_eq!(t.to_normalized(*p), *q);
        }
        assert!((m.area() - 0.5 * (16.0f64 + 4.0).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn merge_offsets_indices_and_parts() {
        let m = TriMesh::merge(&[tri(), tri()]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(m.parts, vec![0, 1]);
        assert_eq!(m.part_count(), 2);
    }
}
