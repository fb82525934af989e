//! Phase 8 of the leaf decision (see the parent module).
//!
//! Clean open rims: a surface voxel stops at the free edge it represents. The zero set of an
//! open sheet's surface voxel runs on past the sheet's boundary to the end of the cell (the
//! signed distance to an open sheet changes sign across the sheet's plane extended, not only
//! across the sheet); a *clip-only* voxel (the format's surface + clip bits) per rim line cuts it
//! there: the signed distance to the plane through the boundary edge, perpendicular to the sheet,
//! positive beyond the rim. A straight rim takes one; a convex corner of the sheet two (their
//! intersection).
//!
//! The clips are added only where the leaf's voxel set is one voxel of one open component (its
//! surface voxel, or the SVO voxel where that won), the boundary edges crossing the cell lie on
//! at most [`MAX_RIMS`] lines, and no surface sample lies beyond a clip (a concave corner, or a
//! rim that is not straight within the cell). Where the sheet is one flat face in the cell (the
//! `sharp` module's face groups), its own voxel becomes that plane.

use glam::Vec3;
use sdfmo_format::Voxel;

use super::sharp::flat_faces;
use super::{LeafCtx, Scratch};
use crate::geom::zero_set_gap;

/// Most rim lines (clip voxels) per leaf: a convex corner of a sheet.
pub(crate) const MAX_RIMS: usize = 2;

/// A rim plane: unit normal pointing away from the sheet, and a point of the boundary edge.
#[derive(Clone, Copy, Debug)]
struct RimPlane {
    normal: Vec3,
    point: Vec3,
}

/// Appends to `out` the clip-only voxels that cut the surface voxel of the open component
/// `tris` (gathered triangles) at its boundary edges in `cell`; returns how many (0 where the
/// rim is not clean, see the module docs).
pub(crate) fn rim_clips(ctx: &LeafCtx, s: &mut Scratch, out: &mut Vec<Voxel>) -> usize {
    let (p, mesh, cell, tris) = (ctx.p, ctx.mesh, &ctx.cell, ctx.tris);
    let (samples, scratch) = (&s.samples, &mut s.sharp);
    let flat = p.sharp_flat * cell.h;
    let unset = RimPlane {
        normal: Vec3::ZERO,
        point: Vec3::ZERO,
    };
    let mut planes = [unset; MAX_RIMS];
    let mut count = 0;
    for &t in tris {
        let t = t as usize;
        let bits = mesh.boundary[t];
        if bits == 0 {
            continue;
        }
        let n = mesh.face_normal[t];
        if n == Vec3::ZERO {
            return 0;
        }
        for k in 0..3 {
            if bits & (1 << k) == 0 {
                continue;
            }
            let (a, b) = (mesh.tris[t][k], mesh.tris[t][(k + 1) % 3]);
            if !segment_meets_box(a, b, cell.lo, cell.hi) {
                continue;
            }
            let normal = (b - a).cross(n).normalize_or_zero();
            if normal == Vec3::ZERO {
                continue;
            }
            let same = |q: &RimPlane| {
                q.normal.dot(normal) >= p.sharp_cos && q.normal.dot(a - q.point).abs() <= flat
            };
            if planes[..count].iter().any(same) {
                continue;
            }
            if count == MAX_RIMS {
                return 0;
            }
            planes[count] = RimPlane { normal, point: a };
            count += 1;
        }
    }
    let corners = cell.corners();
    let start = out.len();
    // The sheet's voxel (its surface voxel, or the SVO voxel where that won) becomes the sheet's
    // plane, or a curved sheet's continuation past the rim: near the rim the distance to the
    // sheet (and the global distance) bends around the boundary edge, and the interpolant's
    // zero set with it, which the clips cannot straighten (a silhouette a fraction of a voxel
    // out along the rim); the plane, cut by the clips, is exact.
    if let Some(sheet) = out.first_mut().filter(|v| !v.clip) {
        let plane =
            flat_faces(p, mesh, cell, tris, samples, scratch).and_then(|f| f.single_plane());
        let continued = match plane {
            Some((normal, point)) => Some(corners.map(|x| normal.dot(x - point))),
            // A curved sheet: its continuation past the rim, kept where it fits the samples
            // as well as the accepted SVO voxel must.
            None => {
                let c = corners.map(|x| mesh.sheet_continuation_distance(tris, x));
                let q = p.q8(&c);
                let fits = c.iter().all(|v| v.is_finite())
                    && samples
                        .points
                        .iter()
                        .all(|&l| zero_set_gap(&q, l, cell.h) <= p.accept);
                fits.then_some(c)
            }
        };
        if let Some(c) = continued {
            // Keep the orientation of the sheet's own voxel (either sign is the same surface).
            let same = c
                .iter()
                .zip(&sheet.corners)
                .map(|(a, b)| a * b)
                .sum::<f32>()
                >= 0.0;
            sheet.corners = if same { c } else { c.map(|v| -v) };
        }
        // An open sheet has no inside: as a volume voxel the SVO voxel's negative side would
        // stop a ray entering the leaf there (where the leaf beyond the rim is dropped, at the
        // leaf's face: a wall a voxel off the sheet).
        sheet.surface = true;
    }
    for plane in &planes[..count] {
        // The sheet lies on the inner side: no sample beyond the plane.
        if samples
            .points
            .iter()
            .any(|&l| plane.normal.dot(cell.at(l) - plane.point) > flat)
        {
            out.truncate(start);
            return 0;
        }
        let c = corners.map(|x| plane.normal.dot(x - plane.point));
        // A clip that cuts nothing in the cell is no use.
        if p.q8(&c).iter().all(|&v| v <= 0.0) {
            continue;
        }
        out.push(Voxel {
            corners: c,
            surface: true,
            clip: true,
        });
    }
    out.len() - start
}

/// Whether the segment `a`–`b` meets the box `[lo, hi]` (slab clipping).
fn segment_meets_box(a: Vec3, b: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let d = b - a;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for k in 0..3 {
        if d[k] == 0.0 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return false;
            }
        } else {
            let (ta, tb) = ((lo[k] - a[k]) / d[k], (hi[k] - a[k]) / d[k]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    t0 <= t1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::leaf::test_meshes::Fixture;
    use crate::leaf::Params;
    use sdfmo_format::ValueBits;
    use sdfmo_mesh::procedural;

    fn clips_at(f: &Fixture, p: &Params, at: Vec3) -> Vec<Voxel> {
        let leaf = f.leaf(p, at);
        let mut s = Scratch {
            samples: leaf.samples(f, p),
            ..Scratch::default()
        };
        let mut out = Vec::new();
        rim_clips(&leaf.ctx(f, p), &mut s, &mut out);
        out
    }

    #[test]
    fn a_sheet_is_clipped_at_its_rim_and_corner() {
        // The sheet y = 0.1, x and z in [-0.3, 0.3]: its rim x = 0.3 crosses the depth-3 cell
        // [0.25, 0.5] × [0, 0.25] × [0, 0.25], its corner (0.3, 0.1, 0.3) the cell above.
        let f = Fixture::new(
            procedural::open_sheet(0.6, 0.6, 3).transformed(|q| q + Vec3::new(0.0, 0.1, 0.0)),
        );
        let p = Params::new(3, ValueBits::Eight, 8);
        let v = clips_at(&f, &p, Vec3::new(0.3, 0.1, 0.1));
        assert_eq!(v.len(), 1);
        assert!(v[0].surface && v[0].clip);
        // Positive beyond the rim (x > 0.3), negative on the sheet: corner 0 is x = 0.25.
        assert!(v[0].corners[0] < 0.0 && v[0].corners[4] > 0.0, "{v:?}");
        assert_eq!(clips_at(&f, &p, Vec3::new(0.3, 0.1, 0.3)).len(), 2);
        // Inside the sheet: no rim.
        assert!(clips_at(&f, &p, Vec3::new(0.1, 0.1, 0.1)).is_empty());
    }

    #[test]
    fn segments_and_boxes() {
        let (lo, hi) = (Vec3::ZERO, Vec3::ONE);
        assert!(segment_meets_box(
            Vec3::splat(-1.0),
            Vec3::splat(0.5),
            lo,
            hi
        ));
        assert!(!segment_meets_box(
            Vec3::new(2.0, 0.5, 0.5),
            Vec3::new(3.0, 0.5, 0.5),
            lo,
            hi
        ));
        assert!(segment_meets_box(
            Vec3::new(0.5, 0.5, -1.0),
            Vec3::new(0.5, 0.5, 2.0),
            lo,
            hi
        ));
        assert!(!segment_meets_box(
            Vec3::new(1.5, 0.5, -1.0),
            Vec3::new(1.5, 0.5, 2.0),
            lo,
            hi
        ));
    }
}
