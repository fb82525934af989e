//! Phase 3 of the leaf decision (see the parent module).
//!
//! Sharp features as several voxels: a leaf where one closed component shows two or three flat
//! faces meeting at a sharp edge or corner gets one *plane voxel* per face (the signed distance
//! to the face's plane, which a trilinear voxel reproduces exactly), combined by intersection
//! (the format's clip bit: `max`) across a convex feature and by union (plain volume voxels,
//! nearest hit: `min`) across a concave one. The edge comes out sharp and every hit gets its
//! face's exact normal, where one voxel of the exact distance rounds the edge over a whole cell
//! and blends the two normals across it.
//!
//! The faces are the groups of the leaf's triangles (those reaching into the cell) whose normals
//! lie within [`LeafParams::sharp_cos`] of the group's first; each group must be flat (its samples
//! within [`LeafParams::sharp_flat`] of its plane). The set is kept only where it reproduces the
//! leaf: every surface sample on its zero set (within [`LeafParams::sharp_flat`]), and every corner
//! whose exact distance is clearly signed (beyond [`LeafParams::sharp_sign`]) on the same side.

use glam::Vec3;
use sdfmo_format::Voxel;

use super::samples::Samples;
use super::{Cell, LeafCtx, Params, Scratch};
use crate::geom::trilinear;
use crate::local::LocalMesh;

/// Most faces a sharp feature may have (an edge: 2; a corner: 3).
const MAX_FACES: usize = 3;

/// One flat face group of a leaf: its plane and the gathered-triangle indices in it.
#[derive(Clone, Copy, Debug, Default)]
struct Face {
    /// Normal of the group's first triangle (the grouping reference).
    reference: Vec3,
    /// Area-weighted sum of normals, then the unit plane normal.
    normal: Vec3,
    /// Area-weighted sum of centroids, then a point of the plane.
    point: Vec3,
    /// Sum of the weights.
    area: f32,
}

/// How the plane voxels of a sharp feature combine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Combine {
    /// Convex: the solid is the intersection of the faces' half-spaces (clip bits).
    Intersect,
    /// Concave: the solid is their union (plain volume voxels).
    Union,
}

/// Reusable buffers: the face of each gathered triangle.
#[derive(Clone, Debug, Default)]
pub(crate) struct SharpScratch {
    face_of: Vec<u8>,
}

/// The flat faces of a leaf: the groups of the triangles reaching into the cell whose normals lie
/// within [`LeafParams::sharp_cos`] of the group's first, each with its plane (area-weighted normal
/// and centroid) and the mean of its samples.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FlatFaces {
    faces: [Face; MAX_FACES],
    centers: [Vec3; MAX_FACES],
    count: usize,
}

impl FlatFaces {
    /// The plane `(unit normal, point)` where the leaf holds exactly one flat face.
    pub fn single_plane(&self) -> Option<(Vec3, Vec3)> {
        (self.count == 1).then(|| (self.faces[0].normal, self.faces[0].point))
    }
}

/// The flat faces of the triangles `tris` in `cell` (see [`FlatFaces`]), or `None` where they
/// form more than [`MAX_FACES`] groups or some face's samples stray farther than
/// [`LeafParams::sharp_flat`] from its plane.
pub(crate) fn flat_faces(
    p: &Params,
    mesh: &LocalMesh,
    cell: &Cell,
    tris: &[u32],
    samples: &Samples,
    s: &mut SharpScratch,
) -> Option<FlatFaces> {
    const NONE: u8 = u8::MAX;
    s.face_of.clear();
    s.face_of.resize(tris.len(), NONE);
    let mut faces = [Face::default(); MAX_FACES];
    let mut count = 0;
    for &li in &samples.triangle {
        let li = li as usize;
        if s.face_of[li] != NONE {
            continue;
        }
        let t = tris[li] as usize;
        let n = mesh.face_normal[t];
        if n == Vec3::ZERO {
            continue;
        }
        let f = match faces[..count]
            .iter()
            .position(|f| f.reference.dot(n) >= p.sharp_cos)
        {
            Some(f) => f,
            None if count < MAX_FACES => {
                faces[count].reference = n;
                count += 1;
                count - 1
            }
            None => return None,
        };
        s.face_of[li] = f as u8;
        let w = mesh.area2[t];
        let [a, b, c] = mesh.tris[t];
        let face = &mut faces[f];
        face.normal += n * w;
        face.point += (a + b + c) * (w / 3.0);
        face.area += w;
    }
    for f in faces[..count].iter_mut() {
        f.normal = f.normal.normalize_or_zero();
        f.point /= f.area;
        if f.normal == Vec3::ZERO || !f.point.is_finite() {
            return None;
        }
    }
    // Each face flat; the mean of each face's samples.
    let flat = p.sharp_flat * cell.h;
    let mut centers = [Vec3::ZERO; MAX_FACES];
    let mut n_samples = [0u32; MAX_FACES];
    for (l, li) in samples.iter() {
        let f = s.face_of[li as usize];
        if f == NONE {
            continue;
        }
        let face = &faces[f as usize];
        let x = cell.at(l);
        if face.normal.dot(x - face.point).abs() > flat {
            return None;
        }
        centers[f as usize] += x;
        n_samples[f as usize] += 1;
    }
    for (c, n) in centers.iter_mut().zip(n_samples) {
        *c /= n.max(1) as f32;
    }
    Some(FlatFaces {
        faces,
        centers,
        count,
    })
}

/// Phase 3: the plane voxels of a sharp feature where the leaf's samples all lie on one
/// component and no open sheet is near (other gathered components that do not reach into the
/// cell do not count: their own leaves hold them); `None` elsewhere or when disabled
/// ([`LeafParams::sharp`]).
pub(crate) fn sharp_leaf(ctx: &LeafCtx, s: &mut Scratch) -> Option<Vec<Voxel>> {
    let of = &s.components.of;
    let mut sampled = s.samples.iter().map(|(_, li)| of[li as usize]);
    let first_sampled = sampled.next();
    let one_sampled = sampled.all(|c| Some(c) == first_sampled);
    if !(one_sampled && !ctx.open_near && ctx.p.sharp) {
        return None;
    }
    sharp_voxels(ctx, &s.samples, &mut s.sharp)
}

/// The plane voxels of the sharp feature in `cell` (gathered triangles `tris` of one closed
/// component, global corner distances `g`, surface samples `samples`), or `None` where the leaf
/// is smooth, curved, not one clean edge or corner, or not reproduced (see the module docs).
pub(crate) fn sharp_voxels(
    ctx: &LeafCtx,
    samples: &Samples,
    s: &mut SharpScratch,
) -> Option<Vec<Voxel>> {
    let LeafCtx {
        p,
        mesh,
        cell,
        tris,
        g,
        ..
    } = *ctx;
    let cell = &cell;
    // 1–2. Two or three flat faces.
    let flat_faces = flat_faces(p, mesh, cell, tris, samples, s)?;
    let count = flat_faces.count;
    if count < 2 {
        return None;
    }
    let faces = &flat_faces.faces[..count];
    let centers = &flat_faces.centers[..count];
    let flat = p.sharp_flat * cell.h;

    // 3. Convex (every face's samples behind every other face's plane) or concave (in front).
    let mut convex = 0;
    let mut concave = 0;
    for (i, fi) in faces.iter().enumerate() {
        for (j, &cj) in centers.iter().enumerate() {
            if i == j {
                continue;
            }
            let side = fi.normal.dot(cj - fi.point);
            if side < -flat {
                convex += 1;
            } else if side > flat {
                concave += 1;
            } else {
                return None;
            }
        }
    }
    let combine = match (convex, concave) {
        (_, 0) => Combine::Intersect,
        (0, _) => Combine::Union,
        _ => return None,
    };

    // 4. Plane voxels, quantised as stored, must reproduce the samples and the corners' signs.
    let corners = cell.corners();
    let mut voxels = Vec::with_capacity(count);
    let mut qs = [[0.0f32; 8]; MAX_FACES];
    for (i, f) in faces.iter().enumerate() {
        let c = corners.map(|x| f.normal.dot(x - f.point));
        qs[i] = p.q8(&c);
        voxels.push(Voxel {
            corners: c,
            surface: false,
            clip: combine == Combine::Intersect,
        });
    }
    let qs = &qs[..count];
    let combined = |l: Vec3| {
        let values = qs.iter().map(|q| trilinear(q, l));
        match combine {
            Combine::Intersect => values.fold(f32::NEG_INFINITY, f32::max),
            Combine::Union => values.fold(f32::INFINITY, f32::min),
        }
    };
    if samples.points.iter().any(|&l| combined(l).abs() > flat) {
        return None;
    }
    let sign_tol = p.sharp_sign * cell.h;
    for (k, &gk) in g.iter().enumerate() {
        let l = crate::geom::corner_offset(k);
        if gk.abs() > sign_tol && (combined(l) < 0.0) != (gk < 0.0) {
            return None;
        }
    }
    if !voxels.iter().any(|v| p.crosses(&v.corners)) {
        return None;
    }
    Some(voxels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::leaf::test_meshes::Fixture;
    use sdfmo_format::ValueBits;
    use sdfmo_mesh::{procedural, TriMesh};

    fn sharp_at(f: &Fixture, p: &Params, at: Vec3) -> Option<Vec<Voxel>> {
        let leaf = f.leaf(p, at);
        let samples = leaf.samples(f, p);
        sharp_voxels(&leaf.ctx(f, p), &samples, &mut SharpScratch::default())
    }

    #[test]
    fn a_box_edge_is_two_intersected_planes_and_a_corner_three() {
        let f = Fixture::new(procedural::box_mesh(Vec3::splat(-0.6), Vec3::splat(0.4)));
        let p = Params::new(3, ValueBits::Eight, 8);
        // The edge x = y = 0.4 runs through the cell [0.25, 0.5] × [0.25, 0.5] × [0, 0.25].
        // Intersected: every voxel is an intersect voxel (volume + clip).
        let v = sharp_at(&f, &p, Vec3::new(0.3, 0.3, 0.1)).expect("an edge");
        assert_eq!(v.len(), 2);
        assert!(v.iter().all(|v| v.clip && !v.surface));
        // The corner (0.4, 0.4, 0.4).
        let v = sharp_at(&f, &p, Vec3::splat(0.3)).expect("a corner");
        assert_eq!(v.len(), 3);
        assert!(v.iter().all(|v| v.clip && !v.surface));
        // A flat face: nothing sharp.
        assert!(sharp_at(&f, &p, Vec3::new(0.3, 0.1, 0.1)).is_none());
    }

    /// The closed prism of the counter-clockwise polygon `profile` (x, y), z in `[-0.6, 0.6]`;
    /// the caps are fans from the first vertex (which must see every other).
    fn prism(profile: &[[f32; 2]]) -> TriMesh {
        let n = profile.len() as u32;
        let mut positions = Vec::new();
        for z in [-0.6, 0.6] {
            positions.extend(profile.iter().map(|&[x, y]| Vec3::new(x, y, z)));
        }
        let mut triangles = Vec::new();
        for i in 1..n - 1 {
            triangles.push([0, i + 1, i]);
            triangles.push([n, n + i, n + i + 1]);
        }
        for i in 0..n {
            let j = (i + 1) % n;
            triangles.push([i, j, n + j]);
            triangles.push([i, n + j, n + i]);
        }
        let parts = vec![0; triangles.len()];
        TriMesh::new(positions, triangles, parts).expect("a valid prism")
    }

    #[test]
    fn an_inner_edge_is_a_union() {
        // An L-shaped prism: the inner edge x = 0, y = 0.3 (the fan starts at the reflex
        // vertex).
        let l_shape = prism(&[
            [0.0, 0.3],
            [0.0, 0.6],
            [-0.6, 0.6],
            [-0.6, -0.6],
            [0.6, -0.6],
            [0.6, 0.3],
        ]);
        let f = Fixture::new(l_shape);
        let p = Params::new(3, ValueBits::Eight, 8);
        // United: plain volume voxels.
        let v = sharp_at(&f, &p, Vec3::new(0.1, 0.4, 0.1)).expect("an inner edge");
        assert_eq!(v.len(), 2);
        assert!(v.iter().all(|v| !v.clip && !v.surface));
    }

    #[test]
    fn curved_surfaces_are_not_sharp() {
        let f = Fixture::new(procedural::sphere(Vec3::ZERO, 0.6, 2));
        let p = Params::new(4, ValueBits::Eight, 8);
        for at in [Vec3::new(0.6, 0.0, 0.0), Vec3::new(0.35, 0.35, 0.3)] {
            assert!(sharp_at(&f, &p, at).is_none(), "{at}");
        }
    }
}
