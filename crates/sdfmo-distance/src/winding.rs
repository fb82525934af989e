//! Generalised winding number (Jacobson, Kavan & Sorkine-Hornung 2013) with the fast
//! hierarchical approximation of Barill, Dickson, Schmidt, Levin & Jacobson 2018.
//!
//! The winding number of a point q is the sum of the signed solid angles of all triangles seen
//! from q, divided by 4π: 1 inside a closed, outward-oriented surface, 0 outside, and a smooth
//! "inside-ness" in between for open or non-manifold meshes; the sign of a signed distance is
//! negative where it exceeds ½.
//!
//! Every BVH node stores a Taylor expansion of its triangles' solid angle about the area-weighted
//! centre p̃ (Barill et al. §3, up to their second order): the area-weighted normal
//! N = Σ ½ (b − a) × (c − a) (the dipole), the first moment M = Σ N_t ⊗ (c_t − p̃) (c_t the
//! centroid of triangle t; exact, since a triangle's first moment is its centroid's), and a radius
//! r bounding every vertex from p̃. With r⃗ = p̃ − q, when |r⃗| > β·r the node contributes
//!
//! Ω ≈ N·r⃗ / |r⃗|³ + tr(M) / |r⃗|³ − 3 r⃗ᵀ M r⃗ / |r⃗|⁵
//!
//! instead of descending; otherwise the traversal descends, and leaves are summed exactly (Van
//! Oosterom & Strackee 1983). β = [`WINDING_BETA`] = 2 as Barill et al. recommend; the far-field
//! error of a node falls like (r / |r⃗|)³ asymptotically (libigl's `fast_winding_number` uses the
//! same order and β by default). Node radii are bounded by the smaller of the children's spheres
//! and the farthest box corner; inside a leaf that is not far, each triangle is still taken as a
//! dipole when the query is farther than β times its own radius ([`TriangleDipole`]). Measured
//! against the exact sum (tests): max |error| 0.009 on an open sheet, 0.047 on the teapot and
//! 0.054 inside a sphere (where every node's error has the same sign), far from the ½ threshold
//! that decides the sign except right at the rim of an open surface.

use glam::{Mat3, Vec3, Vec4};
use obvhs::bvh2::node::Bvh2Node;

use crate::triangle_packet::TrianglePacket;

/// Accuracy parameter β of the hierarchical winding number: a node is approximated by its dipole
/// when the query is farther than β times its radius from its centre.
pub const WINDING_BETA: f32 = 2.0;

/// One node of the winding-number tree: the BVH's topology with the expansion data, packed in
/// one 64-byte cache line so a traversal step touches one line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(crate) struct WindingNode {
    /// Area-weighted centre p̃.
    pub center: Vec3,
    /// (β · r)²: the squared distance beyond which the expansion is used.
    pub far2: f32,
    /// Area-weighted normal N = Σ ½ (b − a) × (c − a).
    pub normal: Vec3,
    /// tr(M).
    pub trace: f32,
    /// Symmetric part of the first moment M = Σ N_t ⊗ (c_t − p̃) (only it enters r⃗ᵀ M r⃗):
    /// xx, yy, zz, xy, xz, yz.
    pub sym: [f32; 6],
    /// Inner node: index of the first child (the second follows). Leaf: its first
    /// [`WindingPacket`].
    pub first: u32,
    /// 0 for an inner node, else the number of triangles of the leaf.
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<WindingNode>() == 64);

impl WindingNode {
    /// Far-field solid angle of the node seen from `q`, given r⃗ = p̃ − q and |r⃗|².
    #[inline(always)]
    pub fn far_field(&self, r: Vec3, r2: f32) -> f32 {
        let inv3 = 1.0 / (r2 * r2.sqrt());
        let [xx, yy, zz, xy, xz, yz] = self.sym;
        let rr = r * r;
        let rmr = xx * rr.x
            + yy * rr.y
            + zz * rr.z
            + 2.0 * (xy * r.x * r.y + xz * r.x * r.z + yz * r.y * r.z);
        (self.normal.dot(r) + self.trace - 3.0 * rmr / r2) * inv3
    }
}

/// One triangle's far field: seen from farther than β times its radius from its centroid, its
/// solid angle is N·r⃗ / |r⃗|³ (for a single flat triangle the second-order term about the
/// centroid vanishes, so the error is third order, as for the nodes).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct TriangleDipole {
    /// Centroid.
    pub center: Vec3,
    /// (β · r)², r the largest distance from the centroid to a vertex.
    pub far2: f32,
    /// Area normal ½ (b − a) × (c − a).
    pub normal: Vec3,
}

impl TriangleDipole {
    /// The far-field data of triangle `t`.
    pub fn new(t: &[Vec3; 3]) -> TriangleDipole {
        let center = (t[0] + t[1] + t[2]) / 3.0;
        let r = t
            .iter()
            .map(|v| (*v - center).length())
            .fold(0.0f32, f32::max);
        let far = WINDING_BETA * r * 1.0001;
        TriangleDipole {
            center,
            far2: far * far,
            normal: (t[1] - t[0]).cross(t[2] - t[0]) * 0.5,
        }
    }
}

/// Four triangles of one BVH leaf as the winding number's near field sees them, structure of
/// arrays: corners in the mesh's order (not the closest-point search's rotated ones, which
/// would change the solid angles' rounding) and each triangle's [`TriangleDipole`]. A leaf of n
/// triangles fills ⌈n/4⌉ packets; unused lanes repeat its last triangle and are not summed.
///
/// Why: near points of the open band abc1.stl spent most of their signed query in the leaves'
/// exact solid angles (111,296 for 2,000 points within 0.02 of the surface, one scalar
/// `solid_angle` each); four lanes at once give every lane's bits unchanged (the same f32
/// operations in the same order, no FMA) and cut abc1's signed query from 24,050 to 20,890
/// instructions per point (`examples/query_icount.rs`, 4,000 points, half near).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct WindingPacket {
    /// The corners, in the mesh's order.
    corners: TrianglePacket,
    /// x, y, z of the dipoles' centres ([`TriangleDipole::center`]).
    center: [Vec4; 3],
    /// [`TriangleDipole::far2`] per lane.
    far2: Vec4,
    /// x, y, z of the dipoles' area normals ([`TriangleDipole::normal`]).
    normal: [Vec4; 3],
}

impl WindingPacket {
    /// Packs up to four triangles of one leaf (missing lanes repeat the last).
    pub fn new(tris: &[[Vec3; 3]]) -> WindingPacket {
        assert!(!tris.is_empty() && tris.len() <= 4);
        let tri = |lane: usize| &tris[lane.min(tris.len() - 1)];
        let dipoles: [TriangleDipole; 4] = std::array::from_fn(|l| TriangleDipole::new(tri(l)));
        let soa = |v: [Vec3; 4]| {
            [
                Vec4::new(v[0].x, v[1].x, v[2].x, v[3].x),
                Vec4::new(v[0].y, v[1].y, v[2].y, v[3].y),
                Vec4::new(v[0].z, v[1].z, v[2].z, v[3].z),
            ]
        };
        WindingPacket {
            corners: TrianglePacket::new(tris),
            center: soa(dipoles.map(|d| d.center)),
            far2: Vec4::from(dipoles.map(|d| d.far2)),
            normal: soa(dipoles.map(|d| d.normal)),
        }
    }

    /// Per lane, the triangle's solid angle seen from `q` as the scalar traversal takes it,
    /// bit for bit: the dipole `N·r⃗ / |r⃗|³` when `q` is farther than its far-field radius
    /// (squared, times `scale`), else the exact [`solid_angle`].
    #[inline(always)]
    pub fn solid_angles(&self, q: Vec3, scale: f32) -> Vec4 {
        let (qx, qy, qz) = (Vec4::splat(q.x), Vec4::splat(q.y), Vec4::splat(q.z));
        // glam's scalar Vec3::dot: (x·x' + y·y') + z·z', left to right.
        let dot = |x: Vec4, y: Vec4, z: Vec4, u: Vec4, v: Vec4, w: Vec4| x * u + y * v + z * w;
        // The dipole: d = centre − q, N·d / (|d|² · |d|).
        let [cx, cy, cz] = self.center;
        let (dx, dy, dz) = (cx - qx, cy - qy, cz - qz);
        let d2 = dot(dx, dy, dz, dx, dy, dz);
        let far = d2.cmpgt(self.far2 * Vec4::splat(scale));
        let [nx, ny, nz] = self.normal;
        let dipole = dot(nx, ny, nz, dx, dy, dz) / (d2 * Vec4::sqrt(d2));
        if far.all() {
            return dipole;
        }
        // solid_angle, lane-wise.
        let TrianglePacket { a, b, c } = &self.corners;
        let (ax, ay, az) = (a[0] - qx, a[1] - qy, a[2] - qz);
        let (bx, by, bz) = (b[0] - qx, b[1] - qy, b[2] - qz);
        let (cx, cy, cz) = (c[0] - qx, c[1] - qy, c[2] - qz);
        let la = Vec4::sqrt(dot(ax, ay, az, ax, ay, az));
        let lb = Vec4::sqrt(dot(bx, by, bz, bx, by, bz));
        let lc = Vec4::sqrt(dot(cx, cy, cz, cx, cy, cz));
        // glam's scalar Vec3::cross of b and c.
        let (kx, ky, kz) = (by * cz - cy * bz, bz * cx - cz * bx, bx * cy - cx * by);
        let det = dot(ax, ay, az, kx, ky, kz);
        let den = la * lb * lc
            + dot(ax, ay, az, bx, by, bz) * lc
            + dot(bx, by, bz, cx, cy, cz) * la
            + dot(cx, cy, cz, ax, ay, az) * lb;
        let exact = Vec4::splat(2.0) * fast_atan2_4(det, den);
        Vec4::select(far, dipole, exact)
    }
}

/// [`fast_atan2`] in four lanes, bit for bit (its branches as selects).
#[inline(always)]
fn fast_atan2_4(y: Vec4, x: Vec4) -> Vec4 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let ax = x.abs();
    let ay = y.abs();
    let hi = ax.max(ay);
    let t = ax.min(ay) / hi;
    let t2 = t * t;
    let k = Vec4::splat;
    let mut h = k(ATAN_POLY[6]);
    for &c in ATAN_POLY[..6].iter().rev() {
        h = k(c) + t2 * h;
    }
    let mut r = t * h;
    r = Vec4::select(ay.cmpgt(ax), k(FRAC_PI_2) - r, r);
    r = Vec4::select(x.cmplt(Vec4::ZERO), k(PI) - r, r);
    r = Vec4::select(y.cmplt(Vec4::ZERO), -r, r);
    r = Vec4::select(hi.cmpeq(Vec4::ZERO), Vec4::ZERO, r);
    Vec4::select(x.is_nan_mask() | y.is_nan_mask(), k(f32::NAN), r)
}

/// Two packets at once in 256-bit AVX lanes (a leaf of five to eight triangles): the same
/// operations in the same order as [`WindingPacket::solid_angles`], so every lane's bits are
/// those of the 4-wide code (IEEE add, multiply, divide, square root, min, max and ordered
/// compares round alike at any width; no FMA). Called only where
/// `is_x86_feature_detected!("avx")` said yes. One pass instead of two cut abc1's signed query
/// from 17,564 to 17,271 instructions per point (`examples/query_icount.rs`; the teapot and
/// the bunny within 0.3 % either way).
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx {
    use std::arch::x86_64::*;

    use glam::{Vec3, Vec4};

    use super::{WindingPacket, ATAN_POLY};

    /// [`WindingPacket::solid_angles`] of `lo` in lanes 0–3 and `hi` in lanes 4–7.
    #[inline]
    #[target_feature(enable = "avx")]
    pub(crate) fn solid_angles(
        lo: &WindingPacket,
        hi: &WindingPacket,
        q: Vec3,
        scale: f32,
    ) -> [f32; 8] {
        let join = |x: Vec4, y: Vec4| _mm256_set_m128(y.into(), x.into());
        let both =
            |x: &[Vec4; 3], y: &[Vec4; 3]| [join(x[0], y[0]), join(x[1], y[1]), join(x[2], y[2])];
        let add = |x, y| _mm256_add_ps(x, y);
        let sub = |x, y| _mm256_sub_ps(x, y);
        let mul = |x, y| _mm256_mul_ps(x, y);
        let div = |x, y| _mm256_div_ps(x, y);
        let sqrt = |x| _mm256_sqrt_ps(x);
        let k = |x| _mm256_set1_ps(x);
        let (qx, qy, qz) = (k(q.x), k(q.y), k(q.z));
        // glam's scalar Vec3::dot: (x·x' + y·y') + z·z', left to right.
        let dot = |x, y, z, u, v, w| add(add(mul(x, u), mul(y, v)), mul(z, w));
        // The dipole.
        let [cx, cy, cz] = both(&lo.center, &hi.center);
        let (dx, dy, dz) = (sub(cx, qx), sub(cy, qy), sub(cz, qz));
        let d2 = dot(dx, dy, dz, dx, dy, dz);
        let far2 = mul(join(lo.far2, hi.far2), k(scale));
        let far = _mm256_cmp_ps::<_CMP_GT_OQ>(d2, far2);
        let [nx, ny, nz] = both(&lo.normal, &hi.normal);
        let dipole = div(dot(nx, ny, nz, dx, dy, dz), mul(d2, sqrt(d2)));
        let mut out = [0.0f32; 8];
        if _mm256_movemask_ps(far) == 0xFF {
            // SAFETY: `out` is 8 writable f32s; the store is unaligned.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), dipole) };
            return out;
        }
        // solid_angle, lane-wise.
        let [ax, ay, az] = both(&lo.corners.a, &hi.corners.a);
        let (ax, ay, az) = (sub(ax, qx), sub(ay, qy), sub(az, qz));
        let [bx, by, bz] = both(&lo.corners.b, &hi.corners.b);
        let (bx, by, bz) = (sub(bx, qx), sub(by, qy), sub(bz, qz));
        let [cx, cy, cz] = both(&lo.corners.c, &hi.corners.c);
        let (cx, cy, cz) = (sub(cx, qx), sub(cy, qy), sub(cz, qz));
        let la = sqrt(dot(ax, ay, az, ax, ay, az));
        let lb = sqrt(dot(bx, by, bz, bx, by, bz));
        let lc = sqrt(dot(cx, cy, cz, cx, cy, cz));
        let (kx, ky, kz) = (
            sub(mul(by, cz), mul(cy, bz)),
            sub(mul(bz, cx), mul(cz, bx)),
            sub(mul(bx, cy), mul(cx, by)),
        );
        let det = dot(ax, ay, az, kx, ky, kz);
        let den = add(
            add(
                add(mul(mul(la, lb), lc), mul(dot(ax, ay, az, bx, by, bz), lc)),
                mul(dot(bx, by, bz, cx, cy, cz), la),
            ),
            mul(dot(cx, cy, cz, ax, ay, az), lb),
        );
        // fast_atan2(det, den), its branches as selects.
        let (y, x) = (det, den);
        let select = |mask, t, f| _mm256_blendv_ps(f, t, mask);
        let abs = |v| _mm256_andnot_ps(k(-0.0), v);
        let (abs_x, abs_y) = (abs(x), abs(y));
        let hi_ = _mm256_max_ps(abs_x, abs_y);
        let t = div(_mm256_min_ps(abs_x, abs_y), hi_);
        let t2 = mul(t, t);
        let mut h = k(ATAN_POLY[6]);
        for &c in ATAN_POLY[..6].iter().rev() {
            h = add(k(c), mul(t2, h));
        }
        let mut r = mul(t, h);
        let zero = _mm256_setzero_ps();
        use std::f32::consts::{FRAC_PI_2, PI};
        r = select(
            _mm256_cmp_ps::<_CMP_GT_OQ>(abs_y, abs_x),
            sub(k(FRAC_PI_2), r),
            r,
        );
        r = select(_mm256_cmp_ps::<_CMP_LT_OQ>(x, zero), sub(k(PI), r), r);
        r = select(
            _mm256_cmp_ps::<_CMP_LT_OQ>(y, zero),
            _mm256_xor_ps(k(-0.0), r),
            r,
        );
        r = select(_mm256_cmp_ps::<_CMP_EQ_OQ>(hi_, zero), zero, r);
        let nan = _mm256_or_ps(
            _mm256_cmp_ps::<_CMP_UNORD_Q>(x, x),
            _mm256_cmp_ps::<_CMP_UNORD_Q>(y, y),
        );
        r = select(nan, k(f32::NAN), r);
        let exact = mul(k(2.0), r);
        // SAFETY: as above.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), select(far, dipole, exact)) };
        out
    }
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
    2.0 * fast_atan2(det, den)
}

/// The coefficients of t, t³, …, t¹³ in [`fast_atan2`]'s polynomial for atan on [0, 1],
/// evaluated by Horner's rule in t² from the last (every implementation in this order).
const ATAN_POLY: [f32; 7] = [
    0.999_996_1,
    -0.333_173_84,
    0.198_079_66,
    -0.132_339_2,
    0.079_634_32,
    -0.033_613_537,
    0.006_814_898,
];

/// atan2 by octant reduction and a degree-13 odd polynomial for atan on [0, 1] (coefficients
/// fitted for minimax error; 3.4e-7 rad in f32); absolute error below 1e-6 rad over all angles
/// (tested against `f32::atan2`), cheaper than the libm call. One triangle's solid angle then errs
/// by < 2e-6 sr, i.e. < 2e-7 in the winding number. `atan2(0, 0)` is 0.
#[inline(always)]
pub(crate) fn fast_atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    if x.is_nan() || y.is_nan() {
        return f32::NAN;
    }
    let ax = x.abs();
    let ay = y.abs();
    let hi = ax.max(ay);
    if hi == 0.0 {
        return 0.0;
    }
    let t = ax.min(ay) / hi;
    let t2 = t * t;
    let mut h = ATAN_POLY[6];
    for &c in ATAN_POLY[..6].iter().rev() {
        h = c + t2 * h;
    }
    let mut r = t * h;
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// Builds the dipole data for every node, bottom-up, and the leaves' [`WindingPacket`]s (each
/// leaf's contiguous, from the one its node's `first` names). `leaf_tris` are the triangles in
/// BVH leaf order; `order` lists the nodes parents-before-children.
pub(crate) fn build_winding_nodes(
    nodes: &[Bvh2Node],
    leaf_tris: &[[Vec3; 3]],
    order: &[u32],
) -> (Vec<WindingNode>, Vec<WindingPacket>) {
    /// Full expansion data during the bottom-up pass.
    #[derive(Clone, Copy)]
    struct Full {
        center: Vec3,
        normal: Vec3,
        moment: Mat3,
    }
    let empty = Full {
        center: Vec3::ZERO,
        normal: Vec3::ZERO,
        moment: Mat3::ZERO,
    };
    let mut out = vec![empty; nodes.len()];
    let mut area = vec![0.0f32; nodes.len()];
    let mut radius = vec![0.0f32; nodes.len()];
    let outer = |n: Vec3, d: Vec3| Mat3::from_cols(n * d.x, n * d.y, n * d.z);
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
            let mut moment = Mat3::ZERO;
            for t in tris {
                let cr = (t[1] - t[0]).cross(t[2] - t[0]) * 0.5;
                let centroid = (t[0] + t[1] + t[2]) / 3.0;
                moment += outer(cr, centroid - center);
            }
            let r = tris
                .iter()
                .flat_map(|t| t.iter())
                .map(|v| (*v - center).length())
                .fold(0.0f32, f32::max);
            out[ni] = Full {
                center,
                normal: n,
                moment,
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
            // Two upper bounds on the distance from p̃ to any vertex below: the children's
            // spheres (loose high up the tree, it grows with every level) and the farthest corner
            // of the node's box; the smaller one keeps more nodes in the far field.
            let spheres = ((out[l].center - center).length() + radius[l])
                .max((out[r].center - center).length() + radius[r]);
            let b = node.aabb();
            let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
            let corner = (center - lo).abs().max((hi - center).abs()).length();
            let rad = spheres.min(corner);
            let moment = out[l].moment
                + outer(out[l].normal, out[l].center - center)
                + out[r].moment
                + outer(out[r].normal, out[r].center - center);
            out[ni] = Full {
                center,
                normal: out[l].normal + out[r].normal,
                moment,
            };
            area[ni] = a_sum;
            radius[ni] = rad;
        }
    }
    let mut packets = Vec::with_capacity(leaf_tris.len() / 3 + 1);
    let tree = out
        .iter()
        .zip(&radius)
        .zip(nodes)
        .map(|((f, r), node)| {
            // Slightly inflated so rounding never admits a point inside the bounding sphere.
            let far = WINDING_BETA * r * 1.0001;
            let m = f.moment;
            let sym = [
                m.x_axis.x,
                m.y_axis.y,
                m.z_axis.z,
                0.5 * (m.y_axis.x + m.x_axis.y),
                0.5 * (m.z_axis.x + m.x_axis.z),
                0.5 * (m.z_axis.y + m.y_axis.z),
            ];
            WindingNode {
                center: f.center,
                far2: far * far,
                normal: f.normal,
                trace: m.x_axis.x + m.y_axis.y + m.z_axis.z,
                sym,
                first: if node.prim_count > 0 {
                    let first = packets.len() as u32;
                    let start = node.first_index as usize;
                    let tris = &leaf_tris[start..start + node.prim_count as usize];
                    packets.extend(tris.chunks(4).map(WindingPacket::new));
                    first
                } else {
                    node.first_index
                },
                count: node.prim_count,
            }
        })
        .collect();
    (tree, packets)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_points::{avx_pair_proptest, lanes_match_4_wide, packet_triangles, point};
    use proptest::prelude::*;

    /// A BVH node over `prim_count` primitives from `first_index` (with `prim_count` 0, an inner
    /// node whose children are nodes `first_index` and `first_index + 1`).
    fn node(first_index: u32, prim_count: u32) -> Bvh2Node {
        Bvh2Node {
            prim_count,
            first_index,
            ..Default::default()
        }
    }

    /// A triangle from its vertices' coordinates.
    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [Vec3; 3] {
        [a, b, c].map(Vec3::from)
    }

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

    #[test]
    fn far_field_error_falls_with_the_cube_of_the_distance() {
        // A curved patch of 4 triangles, one leaf.
        let v = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.2, 0.0, 0.03),
            Vec3::new(0.2, 0.2, 0.0),
            Vec3::new(0.0, 0.2, 0.04),
            Vec3::new(0.1, 0.1, 0.08),
        ];
        let tris = vec![
            [v[0], v[1], v[4]],
            [v[1], v[2], v[4]],
            [v[2], v[3], v[4]],
            [v[3], v[0], v[4]],
        ];
        let w = build_winding_nodes(&[node(0, 4)], &tris, &[0]).0[0];
        let dir = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut errs = Vec::new();
        for dist in [1.0f32, 2.0, 4.0] {
            let q = w.center + dir * dist;
            let exact: f32 = tris.iter().map(|t| solid_angle(q, t[0], t[1], t[2])).sum();
            let r = w.center - q;
            let approx = w.far_field(r, r.length_squared());
            errs.push(((approx - exact) / exact).abs());
        }
        // Second order: relative error shrinks ≈ 4× per doubling of the distance (order 1: 2×).
        assert!(
            errs[1] < errs[0] / 3.0 && errs[2] < errs[1] / 3.0,
            "{errs:?}"
        );
    }

    #[test]
    fn merged_moments_equal_the_moments_of_the_union() {
        let tris = vec![
            tri([0.0, 0.0, 0.0], [0.3, 0.0, 0.1], [0.0, 0.2, 0.05]),
            tri([0.5, 0.1, 0.0], [0.6, 0.4, 0.2], [0.4, 0.3, -0.1]),
            tri([0.1, 0.5, 0.3], [0.2, 0.7, 0.1], [-0.1, 0.6, 0.0]),
        ];
        let whole = build_winding_nodes(&[node(0, 3)], &tris, &[0]).0[0];
        // The root over leaves of triangle 0 and of triangles 1 and 2.
        let nodes = [node(1, 0), node(0, 1), node(1, 2)];
        let tree = build_winding_nodes(&nodes, &tris, &[0, 1, 2]).0[0];
        assert!((tree.center - whole.center).length() < 1e-6);
        assert!((tree.normal - whole.normal).length() < 1e-6);
        assert!((tree.trace - whole.trace).abs() < 1e-6);
        for k in 0..6 {
            assert!(
                (tree.sym[k] - whole.sym[k]).abs() < 1e-6,
                "{:?} vs {:?}",
                tree.sym,
                whole.sym
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Every lane of a packet is, to the bit, what the scalar sum took for its triangle:
        /// the triangle's dipole where the query is beyond its far-field radius, else the
        /// exact `solid_angle` (both NaN where the scalar value is NaN).
        #[test]
        fn packet_lanes_match_the_scalar_solid_angles(
            tris in packet_triangles(),
            q in point(),
            scale in prop_oneof![Just(1.0f32), Just(crate::COARSE_FAR_SCALE), 0.0f32..4.0],
        ) {
            let lanes = WindingPacket::new(&tris).solid_angles(q, scale).to_array();
            for (lane, t) in tris.iter().enumerate() {
                let dp = TriangleDipole::new(t);
                let d = dp.center - q;
                let d2 = d.length_squared();
                let want = if d2 > dp.far2 * scale {
                    dp.normal.dot(d) / (d2 * d2.sqrt())
                } else {
                    solid_angle(q, t[0], t[1], t[2])
                };
                let got = lanes[lane];
                prop_assert!(
                    got.to_bits() == want.to_bits() || got.is_nan() && want.is_nan(),
                    "lane {}: {} vs {}", lane, got, want
                );
            }
        }
    }

    avx_pair_proptest! {
        /// The 8-wide AVX pass gives each packet's lanes to the bit (on a CPU without AVX the
        /// winding number never calls it).
        fn avx_pairs_match_the_4_wide_code(
            lo,
            hi,
            q in point(),
            scale in prop_oneof![Just(1.0f32), Just(crate::COARSE_FAR_SCALE), 0.0f32..4.0],
        ) {
            let (lo, hi) = (WindingPacket::new(&lo), WindingPacket::new(&hi));
            // SAFETY: `avx_pair_proptest!` returns before the body without AVX.
            let lanes = unsafe { avx::solid_angles(&lo, &hi, q, scale) };
            let four = |packet: &WindingPacket| packet.solid_angles(q, scale).to_array();
            lanes_match_4_wide(&lanes, four(&lo), four(&hi))?;
        }
    }

    #[test]
    fn fast_atan2_matches_libm() {
        let mut max_err = 0.0f32;
        for i in 0..200_000u32 {
            let a = i as f32 / 200_000.0 * std::f32::consts::TAU;
            for r in [1e-6f32, 0.3, 1.0, 7.0e3] {
                let (y, x) = (a.sin() * r, a.cos() * r);
                max_err = max_err.max((fast_atan2(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(max_err < 1e-6, "{max_err}");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
        assert!((fast_atan2(0.0, -1.0) - std::f32::consts::PI).abs() < 1e-6);
        assert!(fast_atan2(f32::NAN, 1.0).is_nan());
    }
}
