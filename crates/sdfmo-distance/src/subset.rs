//! Distance to a subset of the triangles (brute force, no allocation): the builder's
//! per-component queries.

use super::*;

impl MeshDistance {
    /// Closest point to `p` on the triangles listed in `triangles` (brute force; no allocation).
    /// Indices out of range are ignored; an empty list gives a result with
    /// `distance == f32::INFINITY`.
    pub fn closest_point_in_subset(&self, triangles: &[u32], p: Vec3) -> ClosestPoint {
        let mut best = ClosestPoint::NONE;
        let mut best_d2 = f32::INFINITY;
        for &ti in triangles {
            let Some(t) = self.tris.get(ti as usize) else {
                continue;
            };
            let (q, f) = closest_point_on_triangle(p, t[0], t[1], t[2]);
            let d2 = (p - q).length_squared();
            if d2 < best_d2 {
                best_d2 = d2;
                best = ClosestPoint {
                    point: q,
                    distance: d2,
                    triangle: ti,
                    feature: f,
                };
            }
        }
        if best.triangle != u32::MAX {
            best.distance = best_d2.sqrt();
        }
        best
    }

    /// Signed distance from `p` to the triangles listed in `triangles`, the sign from the
    /// angle-weighted pseudo-normal of the closest feature computed with the adjacency of the
    /// whole mesh (whatever [`sign_mode`](Self::sign_mode) is). `f32::INFINITY` for an empty
    /// list.
    pub fn signed_distance_in_subset(&self, triangles: &[u32], p: Vec3) -> f32 {
        let c = self.closest_point_in_subset(triangles, p);
        self.pseudo_normal_sign(p, &c)
    }

    /// [`signed_distance_in_subset`](Self::signed_distance_in_subset) for several points at
    /// once (for instance the 8 corners of a voxel): `out[i]` receives the signed distance of
    /// `points[i]`; extra entries of the longer slice are left alone.
    pub fn signed_distances_in_subset(&self, triangles: &[u32], points: &[Vec3], out: &mut [f32]) {
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.signed_distance_in_subset(triangles, p);
        }
    }
}
