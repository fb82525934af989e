//! Distance to a subset of the triangles (brute force over the listed triangles, pruned by
//! their bounding boxes, no allocation): the builder's per-component and per-leaf queries, and
//! [`MeshDistance`]'s subset API, share this one loop.

use super::*;

/// Triangle corners and bounding boxes, indexed alike: what a subset query reads.
#[derive(Clone, Copy, Debug)]
pub struct TriangleSlices<'a> {
    /// Corners per triangle.
    pub corners: &'a [[Vec3; 3]],
    /// Bounding box (min, max) per triangle.
    pub boxes: &'a [(Vec3, Vec3)],
}

/// Bounding box (min, max) of each triangle.
pub fn triangle_boxes(corners: &[[Vec3; 3]]) -> Vec<(Vec3, Vec3)> {
    corners
        .iter()
        .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
        .collect()
}

impl TriangleSlices<'_> {
    /// Closest point to `p` on the triangles listed in `subset` that lies nearer than
    /// `max_distance` (`f32::INFINITY`: any). Triangles whose bounding box is no nearer than
    /// the best so far are skipped (exactly: the first strictly nearest triangle wins, as
    /// without the pruning). Indices out of range are ignored; nothing found gives a result
    /// with `distance == f32::INFINITY` and `triangle == u32::MAX`.
    #[inline]
    pub fn closest_point_in_subset(
        &self,
        subset: &[u32],
        p: Vec3,
        max_distance: f32,
    ) -> ClosestPoint {
        let mut best = ClosestPoint::NONE;
        let mut best_d2 = max_distance * max_distance;
        for &ti in subset {
            let (Some(t), Some(&(lo, hi))) =
                (self.corners.get(ti as usize), self.boxes.get(ti as usize))
            else {
                continue;
            };
            // Cheap lower bound: distance to the triangle's bounding box.
            if (lo - p).max(p - hi).max(Vec3::ZERO).length_squared() >= best_d2 {
                continue;
            }
            let (q, f) = closest_point_on_triangle(p, t[0], t[1], t[2]);
            let d2 = (q - p).length_squared();
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

    /// Unsigned distance from `p` to `subset`, at most `cap`.
    #[inline]
    pub fn unsigned_distance_in_subset(&self, subset: &[u32], p: Vec3, cap: f32) -> f32 {
        let c = self.closest_point_in_subset(subset, p, cap);
        if c.is_found() {
            c.distance
        } else {
            cap
        }
    }
}

/// The signed distance of `p` to its closest point `c`, signed by the pseudo-normal `n` of the
/// closest feature: negative where `(p − c) · n < 0`.
#[inline]
pub fn sign_by_pseudo_normal(p: Vec3, c: &ClosestPoint, n: Vec3) -> f32 {
    if (p - c.point).dot(n) < 0.0 {
        -c.distance
    } else {
        c.distance
    }
}

impl MeshDistance {
    /// The triangles as subset queries read them.
    fn slices(&self) -> TriangleSlices<'_> {
        TriangleSlices {
            corners: &self.tris,
            boxes: &self.tri_boxes,
        }
    }

    /// Closest point to `p` on the triangles listed in `triangles` (brute force; no allocation).
    /// Indices out of range are ignored; an empty list gives a result with
    /// `distance == f32::INFINITY`.
    pub fn closest_point_in_subset(&self, triangles: &[u32], p: Vec3) -> ClosestPoint {
        self.slices()
            .closest_point_in_subset(triangles, p, f32::INFINITY)
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
