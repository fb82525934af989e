//! Generalised winding number (Jacobson, Kavan & Sorkine-Hornung 2013) with the fast
//! hierarchical approximation of Barill, Dickson, Schmidt, Levin & Jacobson 2018.
//!
//! The winding number of a point q is the sum of the signed solid angles of all triangles seen
//! from q, divided by 4π: 1 inside a closed, outward-oriented surface, 0 outside, and a smooth
//! "inside-ness" in between for open or non-manifold meshes; the sign of a signed distance is
//! negative where it exceeds ½.
//!
//! Every BVH node stores a first-order ("dipole") expansion of its triangles: the area-weighted
//! normal N = Σ ½ (b − a) × (c − a), the area-weighted centre p̃ and a radius r bounding every
//! vertex from p̃. When |q − p̃| > β·r the node contributes N·(p̃ − q) / |p̃ − q|³ (its solid
//! angle as one dipole) instead of descending; otherwise the traversal descends, and leaves are
//! summed exactly (Van Oosterom & Strackee 1983). β = [`WINDING_BETA`] = 2 as Barill et al.
//! recommend; the far-field error of a node falls like (r / |q − p̃|)², so β = 2 keeps it to a few
//! percent of that node's (already small) contribution. The tests measure the total error
//! against the exact sum.

use glam::Vec3;
use obvhs::bvh2::node::Bvh2Node;

/// Accuracy parameter β of the hierarchical winding number: a node is approximated by its dipole
/// when the query is farther than β times its radius from its centre.
pub const WINDING_BETA: f32 = 2.0;

/// Per-node dipole data, parallel to the BVH node array.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct WindingNode {
    /// Area-weighted centre p̃.
    pub center: Vec3,
    /// (β · r)²: the squared distance beyond which the dipole is used.
    pub far2: f32,
    /// Area-weighted normal Σ ½ (b − a) × (c − a).
    pub normal: Vec3,
}

/// Signed solid angle of triangle `(a, b, c)` seen from `q` (Van Oosterom & Strackee 1983).
/// Positive when q is behind the triangle (on the side opposite to `(b − a) × (c − a)`).
#[inline]
pub(crate) fn solid_angle(q: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let a = a - q;
    let b = b - q;
    let c = c - q;
    let la = a.length();
    let lb = b.length();
    let lc = c.length();
    let det = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * det.atan2(den)
}

/// Builds the dipole data for every node, bottom-up. `leaf_tris` are the triangles in BVH leaf
/// order; `order` lists the nodes parents-before-children.
pub(crate) fn build_winding_nodes(
    nodes: &[Bvh2Node],
    leaf_tris: &[[Vec3; 3]],
    order: &[u32],
) -> Vec<WindingNode> {
    let mut out = vec![WindingNode::default(); nodes.len()];
    let mut area = vec![0.0f32; nodes.len()];
    let mut radius = vec![0.0f32; nodes.len()];
    for &ni in order.iter().rev() {
        let ni = ni as usize;
        let node = &nodes[ni];
        if node.prim_count > 0 {
            let range = node.first_index as usize..(node.first_index + node.prim_count) as usize;
            let tris = &leaf_tris[range];
            let mut n = Vec3::ZERO;
            let mut a_sum = 0.0f32;
            let mut c_sum = Vec3::ZERO;
            let mut mean = Vec3::ZERO;
            for t in tris {
                let cr = (t[1] - t[0]).cross(t[2] - t[0]) * 0.5;
                let ar = cr.length();
                let centroid = (t[0] + t[1] + t[2]) / 3.0;
                n += cr;
                a_sum += ar;
                c_sum += centroid * ar;
                mean += centroid;
            }
            let center = if a_sum > 0.0 {
                c_sum / a_sum
            } else {
                mean / tris.len().max(1) as f32
            };
            let r = tris
                .iter()
                .flat_map(|t| t.iter())
                .map(|v| (*v - center).length())
                .fold(0.0f32, f32::max);
            out[ni] = WindingNode {
                center,
                far2: 0.0,
                normal: n,
            };
            area[ni] = a_sum;
            radius[ni] = r;
        } else {
            let l = node.first_index as usize;
            let r = l + 1;
            let a_sum = area[l] + area[r];
            let center = if a_sum > 0.0 {
                (out[l].center * area[l] + out[r].center * area[r]) / a_sum
            } else {
                0.5 * (out[l].center + out[r].center)
            };
            let rad = ((out[l].center - center).length() + radius[l])
                .max((out[r].center - center).length() + radius[r]);
            out[ni] = WindingNode {
                center,
                far2: 0.0,
                normal: out[l].normal + out[r].normal,
            };
            area[ni] = a_sum;
            radius[ni] = rad;
        }
    }
    for (w, r) in out.iter_mut().zip(&radius) {
        // Slightly inflated so rounding never admits a point inside the bounding sphere.
        let far = WINDING_BETA * r * 1.0001;
        w.far2 = far * far;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_angle_of_an_octant() {
        // The triangle (e_x, e_y, e_z) spans one octant of directions from the origin: 4π / 8.
        let s = solid_angle(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z);
        assert!((s - std::f32::consts::PI / 2.0).abs() < 1e-5, "{s}");
        // Seen from the other side, the sign flips.
        let s2 = solid_angle(Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::Y);
        assert!((s + s2).abs() < 1e-6);
    }

    #[test]
    fn solid_angle_of_a_degenerate_triangle_is_zero() {
        let s = solid_angle(Vec3::new(0.3, 0.1, -1.0), Vec3::X, Vec3::X, Vec3::Y);
        assert!(s.abs() < 1e-6, "{s}");
        assert!(solid_angle(Vec3::X, Vec3::X, Vec3::Y, Vec3::Z).is_finite());
    }
}
