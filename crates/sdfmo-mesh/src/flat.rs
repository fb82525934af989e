//! Flat regions made of long thin triangles (fans, n-gon caps) re-triangulated into
//! well-shaped triangles that cover exactly the same surface.
//!
//! Why: a cap that a CAD exporter wrote as a fan from one rim vertex, or a disc of 50 000
//! wedges around one hub, has triangles whose boxes and bounding spheres span the whole cap. No
//! BVH box and no winding-number dipole separates them, so every query near the cap visits O(n)
//! of them (docs/hardening.md: a 50 000-wedge disc took 412 CPU-s to build at depth 8, 93 % of
//! it in the winding number). The same region re-triangulated by constrained Delaunay
//! refinement ([spade](https://docs.rs/spade)) has triangles whose size grows with their
//! distance from the rim, and both hierarchies work again.
//!
//! The surface does not change: a region is re-triangulated only when every one of its vertices
//! lies within [`FlatRegionSettings::flatness`] of its plane, the new vertices lie in that plane,
//! the rim edges are kept as they are (constraint edges that the refinement may not split, so a
//! closed mesh stays closed and no T-junction appears), every old vertex stays, and the new
//! triangles' area equals the region's; any region failing one of these is left as it was.
//! Triangle indices are not preserved: a caller that reports faces keeps the original mesh.

use crate::{EdgeAdjacency, TriMesh};
use glam::{DVec2, DVec3, Vec3};
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
};
use std::collections::HashSet;

/// Which flat regions [`retriangulate_flat_regions`] replaces, and how finely.
#[derive(Clone, Debug, PartialEq)]
pub struct FlatRegionSettings {
    /// A triangle is *thin* when its height over its longest edge (twice its area over the
    /// longest edge squared) is below this. A fan wedge of n around a hub scores about 2π/n; a
    /// well-shaped triangle 0.3 to 0.87.
    pub thin_ratio: f64,
    /// Least number of thin triangles that makes a region worth re-triangulating: small fans
    /// (a CAD part's hole caps) cost the hierarchies little and keep their triangles.
    pub min_thin_triangles: usize,
    /// Largest angle (degrees) between a triangle's normal and its region's area-weighted
    /// normal so far for the triangle to join the region (f32 rounding tilts a sliver's normal
    /// by up to its relative rounding over its aspect ratio: 0.06° for a 1 : 10 000 wedge).
    pub max_normal_angle_deg: f64,
    /// Largest distance of a region's vertex from the region's plane, as a fraction of the
    /// mesh's bounding-box diagonal (f32 coordinates round at about 6e-8 of their magnitude).
    pub flatness: f64,
    /// Smallest inner angle (degrees) the refinement aims for; spade guarantees termination up
    /// to about 30°.
    pub min_angle_deg: f64,
    /// Most vertices the refinement may add, per vertex of the region.
    pub max_added_per_vertex: usize,
}

impl Default for FlatRegionSettings {
    fn default() -> Self {
        FlatRegionSettings {
            thin_ratio: 0.01,
            min_thin_triangles: 32,
            max_normal_angle_deg: 1.0,
            flatness: 1e-6,
            min_angle_deg: 20.0,
            max_added_per_vertex: 4,
        }
    }
}

/// A mesh whose flat thin-triangle regions were re-triangulated, and what changed.
#[derive(Clone, Debug)]
pub struct Retriangulated {
    /// The new mesh: the untouched triangles first, in their order, then the regions' new ones;
    /// the old vertices first, in their order, then the added ones.
    pub mesh: TriMesh,
    /// Regions re-triangulated.
    pub regions: usize,
    /// Triangles those regions held.
    pub replaced_triangles: usize,
    /// Triangles that replaced them.
    pub new_triangles: usize,
    /// Vertices the refinement added inside the regions.
    pub added_vertices: usize,
}

/// Re-triangulates the flat regions of `mesh` that hold at least
/// [`FlatRegionSettings::min_thin_triangles`] thin triangles (module docs); `None` when there is
/// no such region or none passed the checks that keep the surface unchanged.
///
/// ```
/// use sdfmo_mesh::{procedural::fan_disc, retriangulate_flat_regions, FlatRegionSettings};
/// let disc = fan_disc(2_000);
/// let r = retriangulate_flat_regions(&disc, &FlatRegionSettings::default()).unwrap();
/// assert_eq!(r.regions, 1);
/// assert!((r.mesh.area() - disc.area()).abs() < 1e-9 * disc.area());
/// ```
pub fn retriangulate_flat_regions(
    mesh: &TriMesh,
    settings: &FlatRegionSettings,
) -> Option<Retriangulated> {
    let n = mesh.triangle_count();
    let normals: Vec<DVec3> = (0..n)
        .map(|t| DVec3::from(mesh.triangle_normal_f64(t)))
        .collect();
    let thin: Vec<bool> = (0..n)
        .map(|t| height_over_base(mesh, t) < settings.thin_ratio)
        .collect();
    if thin.iter().filter(|&&t| t).count() < settings.min_thin_triangles {
        return None;
    }
    let adjacency = EdgeAdjacency::of(mesh);
    let mut edge_of = vec![u32::MAX; 3 * n];
    for e in 0..adjacency.edge_count() {
        for (&t, &k) in adjacency.triangles_of(e).iter().zip(adjacency.slots_of(e)) {
            edge_of[3 * t as usize + usize::from(k)] = e as u32;
        }
    }
    let diagonal = f64::from(mesh.bounds().size().length());
    let ctx = Context {
        mesh,
        settings,
        normals: &normals,
        adjacency: &adjacency,
        edge_of: &edge_of,
        tolerance: settings.flatness * diagonal,
        cos_limit: settings.max_normal_angle_deg.to_radians().cos(),
    };

    let mut region_of = vec![u32::MAX; n];
    let mut replaced = vec![false; n];
    let mut positions = mesh.positions().to_vec();
    let mut new_triangles: Vec<([u32; 3], u32)> = Vec::new();
    let mut regions = 0;
    for seed in 0..n {
        if !thin[seed] || region_of[seed] != u32::MAX {
            continue;
        }
        let region = ctx.grow(seed, seed as u32, &mut region_of);
        if region.iter().filter(|&&t| thin[t as usize]).count() < settings.min_thin_triangles {
            continue;
        }
        if let Some(tris) = ctx.retriangulate(&region, seed as u32, &region_of, &mut positions) {
            let part = mesh.parts()[seed];
            for &t in &region {
                replaced[t as usize] = true;
            }
            new_triangles.extend(tris.into_iter().map(|t| (t, part)));
            regions += 1;
        }
    }
    if regions == 0 {
        return None;
    }
    let replaced_triangles = replaced.iter().filter(|&&r| r).count();
    let new_count = new_triangles.len();
    let added_vertices = positions.len() - mesh.vertex_count();
    let mut triangles = Vec::with_capacity(n - replaced_triangles + new_count);
    let mut parts = Vec::with_capacity(triangles.capacity());
    for t in (0..n).filter(|&t| !replaced[t]) {
        triangles.push(mesh.triangles()[t]);
        parts.push(mesh.parts()[t]);
    }
    for (t, part) in new_triangles {
        triangles.push(t);
        parts.push(part);
    }
    Some(Retriangulated {
        mesh: TriMesh::from_valid(positions, triangles, parts),
        regions,
        replaced_triangles,
        new_triangles: new_count,
        added_vertices,
    })
}

/// Triangle `t`'s height over its longest edge: twice its area over the longest edge squared
/// (0 for a degenerate triangle, √3/2 for an equilateral one).
fn height_over_base(mesh: &TriMesh, t: usize) -> f64 {
    let [a, b, c] = mesh.triangle(t).map(|p| p.as_dvec3());
    let longest2 = (b - a)
        .length_squared()
        .max((c - b).length_squared())
        .max((a - c).length_squared());
    if longest2 > 0.0 {
        DVec3::from(mesh.triangle_normal_f64(t)).length() / longest2
    } else {
        0.0
    }
}

/// What the region search shares.
struct Context<'a> {
    mesh: &'a TriMesh,
    settings: &'a FlatRegionSettings,
    /// Twice the area vector of each triangle.
    normals: &'a [DVec3],
    adjacency: &'a EdgeAdjacency,
    /// The adjacency's edge index of triangle `t`'s edge `k` at `3 t + k`.
    edge_of: &'a [u32],
    /// Largest distance of a vertex from its region's plane.
    tolerance: f64,
    /// Cosine of [`FlatRegionSettings::max_normal_angle_deg`].
    cos_limit: f64,
}

impl Context<'_> {
    /// The triangles reachable from `seed` across clean manifold edges (two triangles, opposite
    /// directions) of the same part whose normals stay within the angle limit of the region's
    /// normal so far; marks them `id` in `region_of`.
    fn grow(&self, seed: usize, id: u32, region_of: &mut [u32]) -> Vec<u32> {
        let parts = self.mesh.parts();
        let mut region = vec![seed as u32];
        region_of[seed] = id;
        let mut normal = self.normals[seed];
        let mut next = 0;
        while next < region.len() {
            let t = region[next] as usize;
            next += 1;
            for k in 0..3 {
                let e = self.edge_of[3 * t + k];
                if e == u32::MAX {
                    continue;
                }
                let tris = self.adjacency.triangles_of(e as usize);
                let slots = self.adjacency.slots_of(e as usize);
                if tris.len() != 2 {
                    continue;
                }
                let (o, ok) = if tris[0] as usize == t {
                    (tris[1] as usize, slots[1])
                } else {
                    (tris[0] as usize, slots[0])
                };
                let own = self.mesh.triangles()[t];
                let other = self.mesh.triangles()[o];
                let opposite = other[usize::from(ok)] == own[(k + 1) % 3];
                if !opposite || region_of[o] != u32::MAX || parts[o] != parts[t] {
                    continue;
                }
                let no = self.normals[o];
                let along = no.dot(normal);
                let len = no.length() * normal.length();
                // Degenerate triangles have no direction: the plane check decides for them.
                if len > 0.0 && along < self.cos_limit * len {
                    continue;
                }
                region_of[o] = id;
                normal += no;
                region.push(o as u32);
            }
        }
        region
    }

    /// The region re-triangulated in its plane (new vertices appended to `positions`), or
    /// `None` when it is not flat, not a simple oriented region, or the triangulation does not
    /// cover it exactly.
    fn retriangulate(
        &self,
        region: &[u32],
        id: u32,
        region_of: &[u32],
        positions: &mut Vec<Vec3>,
    ) -> Option<Vec<[u32; 3]>> {
        let tris = self.mesh.triangles();
        let pos = self.mesh.positions();
        let normal = region
            .iter()
            .map(|&t| self.normals[t as usize])
            .sum::<DVec3>()
            .try_normalize()?;
        let mut vertices: Vec<u32> = region.iter().flat_map(|&t| tris[t as usize]).collect();
        vertices.sort_unstable();
        vertices.dedup();
        let origin = pos[vertices[0] as usize].as_dvec3();
        if vertices
            .iter()
            .any(|&v| (pos[v as usize].as_dvec3() - origin).dot(normal).abs() > self.tolerance)
        {
            return None;
        }
        // u × v = normal, so counter-clockwise in (u, v) faces along the region's normal.
        let u = normal.any_orthonormal_vector();
        let v = normal.cross(u);
        let plane = |p: Vec3| {
            let d = p.as_dvec3() - origin;
            DVec2::new(d.dot(u), d.dot(v))
        };
        let signed_area = |a: DVec2, b: DVec2, c: DVec2| 0.5 * (b - a).perp_dot(c - a);

        // The region's area, and every triangle facing along the normal (a fold would make
        // the area test below meaningless).
        let mut area = 0.0;
        for &t in region {
            let [a, b, c] = tris[t as usize].map(|i| plane(pos[i as usize]));
            let s = signed_area(a, b, c);
            if s < 0.0 {
                return None;
            }
            area += s;
        }

        let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
        let mut handles = Vec::with_capacity(vertices.len());
        for (k, &vi) in vertices.iter().enumerate() {
            let p = plane(pos[vi as usize]);
            let h = cdt.insert(Point2::new(p.x, p.y)).ok()?;
            if h.index() != k {
                return None; // two vertices at one position: not a simple region
            }
            handles.push(h);
        }
        let local = |vi: u32| vertices.binary_search(&vi).ok();
        // Constraints: every edge that is not shared by exactly two triangles of the region,
        // i.e. the rim, and edges that other triangles also use.
        let mut constrained = HashSet::new();
        for &t in region {
            for k in 0..3 {
                let e = self.edge_of[3 * t as usize + k];
                if e == u32::MAX {
                    continue;
                }
                let inner = {
                    let around = self.adjacency.triangles_of(e as usize);
                    around.len() == 2 && around.iter().all(|&o| region_of[o as usize] == id)
                };
                if inner || !constrained.insert(e) {
                    continue;
                }
                let [a, b] = self.adjacency.edges[e as usize];
                let (a, b) = (local(a)?, local(b)?);
                if cdt.try_add_constraint(handles[a], handles[b]).len() != 1 {
                    return None; // crossing rims or a vertex on a rim edge
                }
            }
        }

        let budget = self.settings.max_added_per_vertex * vertices.len();
        let result = cdt.refine(
            RefinementParameters::<f64>::new()
                .exclude_outer_faces(true)
                .keep_constraint_edges()
                .with_angle_limit(AngleLimit::from_deg(self.settings.min_angle_deg))
                .with_max_additional_vertices(budget),
        );
        let excluded: HashSet<_> = result.excluded_faces.into_iter().collect();

        // The refinement's vertices follow the inserted ones in the CDT's order: lift them onto
        // the plane and append them in that order.
        let first_new = positions.len();
        positions.extend(cdt.vertices().skip(vertices.len()).map(|h| {
            let p = h.position();
            (origin + u * p.x + v * p.y).as_vec3()
        }));
        let index_of = |k: usize| -> u32 {
            match vertices.get(k) {
                Some(&old) => old,
                None => (first_new + k - vertices.len()) as u32,
            }
        };
        let mut out = Vec::new();
        let mut new_area = 0.0;
        for face in cdt.inner_faces() {
            if excluded.contains(&face.fix()) {
                continue;
            }
            let [(ka, pa), (kb, pb), (kc, pc)] =
                face.vertices().map(|h| (h.fix().index(), h.position()));
            let [da, db, dc] = [pa, pb, pc].map(|p| DVec2::new(p.x, p.y));
            let s = signed_area(da, db, dc);
            new_area += s.abs();
            let [ia, ib, ic] = [ka, kb, kc].map(index_of);
            out.push(if s >= 0.0 { [ia, ib, ic] } else { [ia, ic, ib] });
        }
        let exact = (new_area - area).abs() <= 1e-9 * area.max(f64::MIN_POSITIVE);
        if !exact || positions[first_new..].iter().any(|p| !p.is_finite()) {
            positions.truncate(first_new);
            return None;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::{box_mesh, fan_cylinder, fan_disc, sphere};

    fn worst_ratio(mesh: &TriMesh) -> f64 {
        (0..mesh.triangle_count())
            .map(|t| height_over_base(mesh, t))
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn a_fan_cylinder_stays_closed_with_the_same_area_and_rim() {
        let mesh = fan_cylinder(2_000, 1.0, 0.5);
        let r = retriangulate_flat_regions(&mesh, &FlatRegionSettings::default()).unwrap();
        assert_eq!(r.regions, 2, "both caps");
        assert_eq!(r.replaced_triangles, 2 * 1_998);
        let topo = r.mesh.topology();
        assert!(topo.watertight, "{topo:?}");
        assert_eq!(topo.component_count, 1);
        assert!((r.mesh.area() - mesh.area()).abs() < 1e-6 * mesh.area());
        assert_eq!(r.mesh.bounds(), mesh.bounds());
        // The old vertices are all kept, in place.
        assert_eq!(&r.mesh.positions()[..mesh.vertex_count()], mesh.positions());
        // The caps' triangles are no longer slivers; the sides (not flat) are untouched.
        let caps: Vec<usize> =
            (mesh.triangle_count() - r.replaced_triangles..r.mesh.triangle_count()).collect();
        assert_eq!(caps.len(), r.mesh.triangle_count() - 2 * 2_000);
        assert!(
            r.new_triangles < 10 * r.replaced_triangles,
            "{}",
            r.new_triangles
        );
        let side_ratio = worst_ratio(&mesh);
        assert!(worst_ratio(&r.mesh) >= side_ratio * 0.999);
    }

    #[test]
    fn a_wedge_disc_gets_well_shaped_triangles() {
        let disc = fan_disc(5_000);
        let r = retriangulate_flat_regions(&disc, &FlatRegionSettings::default()).unwrap();
        assert_eq!(r.regions, 1);
        assert!((r.mesh.area() - disc.area()).abs() < 1e-9 * disc.area());
        let topo = r.mesh.topology();
        assert_eq!(
            topo.boundary_edges,
            disc.topology().boundary_edges,
            "the same rim"
        );
        // Away from the rim the wedges (height / base ≈ 2π / 5 000) are gone.
        assert!(worst_ratio(&r.mesh) > 100.0 * worst_ratio(&disc));
    }

    #[test]
    fn meshes_without_flat_fans_are_left_alone() {
        let s = FlatRegionSettings::default();
        assert!(retriangulate_flat_regions(&sphere(Vec3::ZERO, 1.0, 3), &s).is_none());
        assert!(retriangulate_flat_regions(&box_mesh(Vec3::ZERO, Vec3::ONE), &s).is_none());
        // A fan of fewer wedges than the threshold.
        assert!(retriangulate_flat_regions(&fan_disc(20), &s).is_none());
    }

    #[test]
    fn a_fan_that_winds_twice_is_left_alone() {
        // Wedges around the hub through 4π: the region covers the disc twice, which no single
        // triangulation of it can (coincident rim vertices for an even count, crossing rim edges
        // for an odd one), so it must stay as it is.
        for n in [2_000u32, 2_001] {
            let mut positions = vec![Vec3::ZERO];
            positions.extend((0..n).map(|k| {
                let a = 2.0 * std::f32::consts::TAU * k as f32 / n as f32;
                Vec3::new(a.cos(), a.sin(), 0.0)
            }));
            let tris: Vec<[u32; 3]> = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
            let parts = vec![0; tris.len()];
            let twice = TriMesh::new(positions, tris, parts).unwrap();
            assert!(
                retriangulate_flat_regions(&twice, &FlatRegionSettings::default()).is_none(),
                "{n}"
            );
        }
    }

    #[test]
    fn a_bent_fan_is_not_flattened() {
        // Every other rim vertex lifted: the region is not flat, so nothing changes.
        let disc = fan_disc(2_000);
        let (mut p, t, parts) = disc.clone().into_arrays();
        for (k, v) in p.iter_mut().enumerate().skip(1) {
            v.z = if k % 2 == 0 { 1e-3 } else { 0.0 };
        }
        let bent = TriMesh::new(p, t, parts).unwrap();
        let s = FlatRegionSettings {
            max_normal_angle_deg: 90.0,
            ..FlatRegionSettings::default()
        };
        assert!(retriangulate_flat_regions(&bent, &s).is_none());
    }
}
