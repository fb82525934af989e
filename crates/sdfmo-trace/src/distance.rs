//! The stored signed distance at a point and its gradient, for collision and proximity queries.
//!
//! [`distance_at`] finds the leaf cell that holds the point (one descent from the root, a
//! child lookup per level, no allocation) and evaluates the trilinear interpolant of its
//! voxels — the same field the tracer intersects — and the analytic gradient of it.

use glam::Vec3;
use sdfmo_format::{trilinear, trilinear_gradient, TracedOctree};

use crate::clip::LeafClips;

/// The stored field at a point: see [`distance_at`]. `V` is the octree's voxel
/// ([`TracedOctree::Voxel`]: the voxel index in a 1.x octree).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceSample<V = u32> {
    /// Signed distance in normalised units (negative inside; multiply by `1 / meta.scale` for
    /// model units). For a surface (thin) voxel it is unsigned: `|F| ≥ 0`, no inside.
    pub distance: f32,
    /// Gradient of [`distance`](Self::distance) with respect to the normalised position (of
    /// the chosen voxel's interpolant; about unit length where the field is a distance, and
    /// pointing away from the surface; zero at a saddle). The same direction in model units.
    pub gradient: Vec3,
    /// The voxel that gave the value (for [`TracedOctree::voxel_corners`]).
    pub voxel: V,
    /// Whether that voxel is a surface (thin) voxel.
    pub surface: bool,
    /// Minimum corner of the leaf cell holding the point, normalised coordinates.
    pub cell_min: Vec3,
    /// Edge length of that leaf cell.
    pub cell_size: f32,
}

impl<V: Copy> DistanceSample<V> {
    /// Puts `self` in `best` unless `best` already holds a sample at most as far (the union of
    /// a leaf's voxels: the minimum, the first of equal ones).
    #[inline]
    pub(crate) fn keep_if_nearer(self, best: &mut Option<DistanceSample<V>>) {
        if best.is_none_or(|b| self.distance < b.distance) {
            *best = Some(self);
        }
    }
}

/// Voxel `v`'s own value and gradient at the local coordinates `local` of the leaf cell at
/// `cell_min` of edge `cell_size`: unsigned for a surface voxel (`|f|`, the gradient flipped
/// with it) unless `keep_sign` (a clip voxel's term in the clip rule is always signed).
#[inline]
pub(crate) fn voxel_sample<O: TracedOctree>(
    octree: &O,
    v: O::Voxel,
    local: Vec3,
    cell_min: Vec3,
    cell_size: f32,
    keep_sign: bool,
) -> DistanceSample<O::Voxel> {
    let corners = octree.voxel_corners(v);
    let surface = octree.voxel_is_surface(v);
    let value = trilinear(&corners, local);
    let gradient = trilinear_gradient(&corners, local) / cell_size;
    let (distance, gradient) = if surface && !keep_sign && value < 0.0 {
        (-value, -gradient)
    } else {
        (value, gradient)
    };
    DistanceSample {
        distance,
        gradient,
        voxel: v,
        surface,
        cell_min,
        cell_size,
    }
}

/// The stored signed distance and its gradient at `p`, in the octree's normalised frame (the
/// root cube is `[-1, 1]³`; a model-space point maps to `(p − meta.center) · meta.scale`).
///
/// In a leaf with several voxels the value is the minimum over them (the union of the
/// components), surface voxels counting as `|F|`; the gradient is that voxel's, flipped with
/// the sign for a surface voxel so that it points away from the surface.
///
/// In a leaf with clip voxels (format 1.1) the value follows the clip rule of the hits: each
/// voxel that is hit itself contributes its value (`|F|` for a surface voxel) raised to the
/// largest value of the *other* clip voxels of the leaf (their intersection, `max`), and the
/// result is the minimum of these (the union): `max(f_A, f_B)` for two intersect voxels (a
/// sharp convex edge), `max(|f_S|, f_K)` for a sheet `S` cut by a clip-only voxel `K`.
/// Clip-only voxels contribute only through that `max`. The sample's voxel and gradient are
/// those of the voxel whose value it is (a clip voxel's where the clip dominates, signed even
/// for a clip-only voxel). Like a `max` of distances, this is exact on the faces and a lower
/// bound of the true distance near the edges.
///
/// Returns `None` when `p` is not finite or lies outside the root cube, and when the leaf cell
/// holding `p` is not stored: the builder stores only the cells the surface passes through, so
/// `None` means the stored field has no zero in that cell (no contact there). Its sign and
/// magnitude are then unknown; `occupied_bounds` and the ray functions answer coarser
/// questions.
///
/// # Accuracy
///
/// For an SVO leaf (one volumetric voxel whose corners are the exact signed distance `f` of a
/// closed mesh, quantised), the value differs from `f(p)` by at most
///
/// ```text
/// |distance_at(p) − f(p)| ≤ δ + h · √(u(1−u) + v(1−v) + w(1−w))       (≤ δ + h·√3/2)
/// ```
///
/// where `h` is the leaf edge, `(u, v, w)` the point's local coordinates in the leaf, and
/// `δ = dmax / (2Q)` the quantisation half step (`dmax` = leaf diagonal, `Q` = 127 or 32767, see
/// [`sdfmo_format::quant`]). Derivation: the interpolant is a convex combination
/// `Σ wᵢ·qᵢ` of the stored corners with tensor-product weights `wᵢ ≥ 0`, `Σ wᵢ = 1`, so
/// quantisation adds at most `δ`; and since a signed distance is 1-Lipschitz,
/// `|Σ wᵢ f(cᵢ) − f(p)| ≤ Σ wᵢ |cᵢ − p| ≤ √(Σ wᵢ |cᵢ − p|²)` (Jensen), where
/// `Σ wᵢ |cᵢ − p|² = h²·(u(1−u) + v(1−v) + w(1−w))` (per axis, the variance of a Bernoulli
/// corner choice). Where `f` is linear over the whole cell (near the middle of a planar face)
/// the interpolation term vanishes and only `δ` remains. The gradient there differs from the
/// face normal by at most `2δ/h` per component. Near a smooth surface the interpolation term is
/// second order instead: for a mesh within `s` of a sphere of radius `R`,
/// `δ + 2s + (h²/2)·(u(1−u) + v(1−v) + w(1−w)) / r` with `r ≈ R` the cell's distance from the
/// centre (`tests/distance.rs` checks both bounds against `sdfmo-distance`; on an icosphere at
/// depths 5–7 the worst error uses 2–3 % of the first and 32–57 % of the second).
///
/// In a multi-octree leaf each voxel stores the distance to one connected component; the value
/// returned is their union (the minimum), so the bound holds per component.
pub fn distance_at<O: TracedOctree>(octree: &O, p: Vec3) -> Option<DistanceSample<O::Voxel>> {
    if !p.is_finite() || p.abs().max_element() > 1.0 {
        return None;
    }
    let mut node = octree.root()?;
    let mut min = Vec3::splat(-1.0);
    let mut size = 2.0f32;
    for _ in 0..octree.meta().depth {
        if octree.is_leaf(node) {
            break;
        }
        let half = size * 0.5;
        let mid = min + Vec3::splat(half);
        let (x, y, z) = (p.x >= mid.x, p.y >= mid.y, p.z >= mid.z);
        let octant = (u8::from(x) << 2) | (u8::from(y) << 1) | u8::from(z);
        node = octree.child(node, octant)?;
        min += Vec3::new(
            f32::from(u8::from(x)),
            f32::from(u8::from(y)),
            f32::from(u8::from(z)),
        ) * half;
        size = half;
    }
    if !octree.is_leaf(node) {
        return None;
    }
    let local = ((p - min) / size).clamp(Vec3::ZERO, Vec3::ONE);
    let voxels = octree.leaf_voxels(node);
    if octree.any_clip_voxel(&voxels) {
        return distance_in_leaf(octree, voxels, local, min, size);
    }
    let mut best: Option<DistanceSample<O::Voxel>> = None;
    for voxel in voxels {
        voxel_sample(octree, voxel, local, min, size, false).keep_if_nearer(&mut best);
    }
    best
}

/// The stored field of a leaf with clip voxels at `local` (the leaf's frame), the counterpart
/// of the hit rule: for every voxel `i` that is hit itself, its value `g_i` (`f_i`, or `|f_i|`
/// for a surface voxel) raised to the largest `f_j` of the other clip voxels `j`
/// (`max(g_i, max_j f_j)`, the intersection), then the minimum over those `i` (the union). For
/// two intersect voxels this is `max(f_A, f_B)`; for a sheet with a clip-only voxel it is
/// `max(|f_S|, f_K)`. The sample's voxel is the *active* one (the one whose value it is, a clip
/// voxel where the clip dominates, whose value is then signed even if it is a clip-only
/// voxel), its gradient that voxel's (flipped with the sign for `|f_i|`).
fn distance_in_leaf<O: TracedOctree>(
    octree: &O,
    voxels: O::Voxels,
    local: Vec3,
    cell_min: Vec3,
    cell_size: f32,
) -> Option<DistanceSample<O::Voxel>> {
    let clips = LeafClips::gather(octree, voxels.clone())?;
    let mut best: Option<DistanceSample<O::Voxel>> = None;
    for i in voxels {
        if octree.voxel_is_surface(i) && octree.voxel_is_clip(i) {
            continue;
        }
        let mut active = voxel_sample(octree, i, local, cell_min, cell_size, false);
        for &(j, _) in clips.as_slice() {
            if j != i {
                let clip = voxel_sample(octree, j, local, cell_min, cell_size, true);
                if clip.distance > active.distance {
                    active = clip;
                }
            }
        }
        active.keep_if_nearer(&mut best);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use sdfmo_format::{LeafInput, OctreeMeta, PackedOctree, ValueBits, Voxel};

    /// One leaf at depth 1 (cell `[0,1]³`) holding `corners`.
    fn one_leaf(voxels: Vec<Voxel>) -> PackedOctree {
        let leaf = LeafInput {
            coord: [1, 1, 1],
            voxels,
        };
        PackedOctree::from_leaves(OctreeMeta::unit(1, ValueBits::Sixteen), vec![leaf]).unwrap()
    }

    /// The plane x = 0.5, inside x > 0.5 (distance 0.5 − x).
    fn plane() -> Voxel {
        Voxel {
            corners: core::array::from_fn(|i| 0.5 - (i >> 2) as f32),
            surface: false,
            clip: false,
        }
    }

    #[test]
    fn linear_field_is_reproduced_with_its_gradient() {
        let o = one_leaf(vec![plane()]);
        for p in [
            Vec3::new(0.25, 0.5, 0.5),
            Vec3::new(0.9, 0.1, 0.7),
            Vec3::ONE,
            Vec3::ZERO,
        ] {
            let s = distance_at(&o, p).unwrap();
            assert!((s.distance - (0.5 - p.x)).abs() < 1e-4, "{p}: {s:?}");
            assert!((s.gradient - -Vec3::X).length() < 1e-4, "{p}: {s:?}");
            assert_eq!((s.cell_min, s.cell_size), (Vec3::ZERO, 1.0));
        }
    }

    #[test]
    fn absent_cells_and_points_outside_the_root_are_none() {
        let o = one_leaf(vec![plane()]);
        assert_eq!(distance_at(&o, Vec3::new(-0.5, 0.5, 0.5)), None); // the empty octant
        assert_eq!(distance_at(&o, Vec3::new(0.5, -0.01, 0.5)), None);
        assert_eq!(distance_at(&o, Vec3::new(1.01, 0.5, 0.5)), None);
        assert_eq!(distance_at(&o, Vec3::new(f32::NAN, 0.5, 0.5)), None);
    }

    #[test]
    fn several_voxels_give_their_union_and_surface_voxels_are_unsigned() {
        // The plane x = 0.5 (volumetric) and the sheet z = 0.25 stored negated (surface).
        let sheet = Voxel {
            corners: core::array::from_fn(|i| 0.25 - (i & 1) as f32),
            surface: true,
            clip: false,
        };
        let o = one_leaf(vec![plane(), sheet]);
        // Near the sheet, above it: |F| = z − 0.25 < 0.5 − x.
        let s = distance_at(&o, Vec3::new(0.1, 0.5, 0.3)).unwrap();
        assert!(s.surface && (s.distance - 0.05).abs() < 1e-4, "{s:?}");
        assert!(
            (s.gradient - Vec3::Z).length() < 1e-4,
            "points away from the sheet: {s:?}"
        );
        // Inside the volume, far from the sheet: the plane's negative distance wins.
        let s = distance_at(&o, Vec3::new(0.9, 0.5, 0.9)).unwrap();
        assert!(!s.surface && (s.distance + 0.4).abs() < 1e-4, "{s:?}");
    }
}
