//! Four triangles at once: a SIMD filter in front of the exact closest-point test.
//!
//! The closest-point search tests every triangle whose leaf box is nearer than the best
//! distance so far; far from the surface that is ≈ 100 triangles per query, and each scalar
//! test is a chain of unpredictable branches (Ericson's region method). Most of them lose. This
//! module runs the same region method on four triangles in SIMD lanes, without branches, and
//! returns per lane the squared distance the scalar test would return: bit for bit the same
//! where the closest point is a vertex or on an edge (the same f32 operations in the same
//! order), and 0 ("test it exactly") where it is in the face interior (the scalar test projects
//! in f64 there) or the triangle is degenerate (the scalar test falls back to its edges). So the
//! search runs the scalar test only on lanes that can win, and its answer does not change.

use glam::{BVec4A, Vec3, Vec4};

/// Four triangles, structure of arrays: for the closest-point search with corners already
/// rotated as in the leaf records, for the winding number in the mesh's order.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct TrianglePacket {
    /// x, y, z of the first corners.
    pub(crate) a: [Vec4; 3],
    /// x, y, z of the second corners.
    pub(crate) b: [Vec4; 3],
    /// x, y, z of the third corners.
    pub(crate) c: [Vec4; 3],
}

impl TrianglePacket {
    /// Packs up to four triangles; missing lanes repeat the last triangle (any lane outside the
    /// caller's range is ignored by the caller).
    pub(crate) fn new(tris: &[[Vec3; 3]]) -> TrianglePacket {
        assert!(!tris.is_empty() && tris.len() <= 4);
        let mut packet = TrianglePacket {
            a: [Vec4::ZERO; 3],
            b: [Vec4::ZERO; 3],
            c: [Vec4::ZERO; 3],
        };
        for lane in 0..4 {
            let t = tris[lane.min(tris.len() - 1)];
            for (axis, ((a, b), c)) in packet
                .a
                .iter_mut()
                .zip(&mut packet.b)
                .zip(&mut packet.c)
                .enumerate()
            {
                a[lane] = t[0][axis];
                b[lane] = t[1][axis];
                c[lane] = t[2][axis];
            }
        }
        packet
    }

    /// Whether the bounding box of any of the four triangles is within squared distance
    /// `bound` of `p` (computed from the corners: a lower bound on each triangle's distance
    /// that costs a third of [`dist2_or_zero`](Self::dist2_or_zero)).
    #[inline(always)]
    pub(crate) fn any_box_within(&self, p: Vec3, bound: f32) -> bool {
        let axis = |k: usize, v: f32| {
            let lo = self.a[k].min(self.b[k]).min(self.c[k]);
            let hi = self.a[k].max(self.b[k]).max(self.c[k]);
            let v = Vec4::splat(v);
            let d = (lo - v).max(v - hi).max(Vec4::ZERO);
            d * d
        };
        let d2 = axis(0, p.x) + axis(1, p.y) + axis(2, p.z);
        d2.cmple(Vec4::splat(bound)).any()
    }

    /// Per lane: the squared distance from `p` to the triangle when its closest point is a
    /// vertex or on an edge (bit-identical to `(p - q).length_squared()` of the scalar
    /// `closest_point_ordered`), 0 when it is in the face interior or the triangle is degenerate
    /// (the caller must run the exact test), NaN when `p` is not finite.
    #[inline(always)]
    pub(crate) fn dist2_or_zero(&self, p: Vec3) -> Vec4 {
        let [ax, ay, az] = self.a;
        let [bx, by, bz] = self.b;
        let [cx, cy, cz] = self.c;
        let (px, py, pz) = (Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z));
        // glam's scalar Vec3::dot: (x·x' + y·y') + z·z', left to right.
        let dot = |x: Vec4, y: Vec4, z: Vec4, u: Vec4, v: Vec4, w: Vec4| x * u + y * v + z * w;
        let (abx, aby, abz) = (bx - ax, by - ay, bz - az);
        let (acx, acy, acz) = (cx - ax, cy - ay, cz - az);
        let (apx, apy, apz) = (px - ax, py - ay, pz - az);
        let d1 = dot(abx, aby, abz, apx, apy, apz);
        let d2 = dot(acx, acy, acz, apx, apy, apz);
        let to_a = dot(apx, apy, apz, apx, apy, apz);
        let (bpx, bpy, bpz) = (px - bx, py - by, pz - bz);
        let d3 = dot(abx, aby, abz, bpx, bpy, bpz);
        let d4 = dot(acx, acy, acz, bpx, bpy, bpz);
        let to_b = dot(bpx, bpy, bpz, bpx, bpy, bpz);
        let (cpx, cpy, cpz) = (px - cx, py - cy, pz - cz);
        let d5 = dot(abx, aby, abz, cpx, cpy, cpz);
        let d6 = dot(acx, acy, acz, cpx, cpy, cpz);
        let to_c = dot(cpx, cpy, cpz, cpx, cpy, cpz);
        let zero = Vec4::ZERO;
        let all = |m: [BVec4A; 3]| m[0] & m[1] & m[2];
        // On an edge region, the squared distance to o + e·(num/den), the way the scalar test
        // computes it, or 0 (exact test) when the edge is degenerate (den ≤ 0).
        let on_edge = |o: [Vec4; 3], e: [Vec4; 3], num, den: Vec4| {
            let t = num / den;
            let (dx, dy, dz) = (
                px - (o[0] + e[0] * t),
                py - (o[1] + e[1] * t),
                pz - (o[2] + e[2] * t),
            );
            Vec4::select(den.cmpgt(zero), dot(dx, dy, dz, dx, dy, dz), zero)
        };
        // Each vertex's and edge's distance as soon as its inputs are known, the regions'
        // verdicts last: the differences and edge vectors die sooner, so fewer registers are
        // spilled (abc1's signed query 18,378 → 18,102 instructions per point with the same
        // order in the AVX pass; the values are computed as before, so the bits are the same).
        let to_ab = on_edge(self.a, [abx, aby, abz], d1, d1 - d3);
        let to_ca = on_edge(self.a, [acx, acy, acz], d2, d2 - d6);
        let e4 = d4 - d3;
        let e5 = d5 - d6;
        let to_bc = on_edge(self.b, [cx - bx, cy - by, cz - bz], e4, e4 + e5);
        let vc = d1 * d4 - d3 * d2;
        let vb = d5 * d2 - d1 * d6;
        let va = d3 * d6 - d5 * d4;
        // Regions from last to first, so the first that applies wins (the scalar test's order).
        // Face interior and the degenerate fallbacks: 0.
        let in_bc = all([va.cmple(zero), e4.cmpge(zero), e5.cmpge(zero)]);
        let mut out = Vec4::select(in_bc, to_bc, zero);
        let in_ca = all([vb.cmple(zero), d2.cmpge(zero), d6.cmple(zero)]);
        out = Vec4::select(in_ca, to_ca, out);
        let in_c = d6.cmpge(zero) & d5.cmple(d6);
        out = Vec4::select(in_c, to_c, out);
        let in_ab = all([vc.cmple(zero), d1.cmpge(zero), d3.cmple(zero)]);
        out = Vec4::select(in_ab, to_ab, out);
        let in_b = d3.cmpge(zero) & d4.cmple(d3);
        out = Vec4::select(in_b, to_b, out);
        // Vertex A.
        let in_a = d1.cmple(zero) & d2.cmple(zero);
        Vec4::select(in_a, to_a, out)
    }
}

/// Two packets' triangles (a leaf of five to eight), each coordinate's eight lanes contiguous
/// (lanes 0–3 the first packet's, 4–7 the second's) and 32-byte aligned: the AVX passes load
/// each whole instead of joining two packets' halves (ten `vinsertf128` per filter pass, nine
/// per box test): abc1's signed query 18,102 → 17,564 instructions per point, the bunny's
/// 10,551 → 10,371. The 4-wide code reads either half.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct TrianglePair {
    /// x, y, z of the first corners.
    a: [[f32; 8]; 3],
    /// x, y, z of the second corners.
    b: [[f32; 8]; 3],
    /// x, y, z of the third corners.
    c: [[f32; 8]; 3],
}

impl TrianglePair {
    /// `lo` in lanes 0–3, `hi` in lanes 4–7.
    pub(crate) fn new(lo: &TrianglePacket, hi: &TrianglePacket) -> TrianglePair {
        let join = |x: &[Vec4; 3], y: &[Vec4; 3]| {
            std::array::from_fn(|k| {
                let mut lanes = [0.0f32; 8];
                x[k].write_to_slice(&mut lanes[..4]);
                y[k].write_to_slice(&mut lanes[4..]);
                lanes
            })
        };
        TrianglePair {
            a: join(&lo.a, &hi.a),
            b: join(&lo.b, &hi.b),
            c: join(&lo.c, &hi.c),
        }
    }

    /// Half `h` (0: lanes 0–3, 1: lanes 4–7) as a 4-wide packet.
    #[inline(always)]
    pub(crate) fn half(&self, h: usize) -> TrianglePacket {
        TrianglePacket {
            a: half_lanes(&self.a, h),
            b: half_lanes(&self.b, h),
            c: half_lanes(&self.c, h),
        }
    }
}

/// Lanes `4h .. 4h + 4` of each coordinate. (A function, not a closure: the closure was left
/// out of line in the AVX search, 143k instructions of the bunny's 36.9M.)
#[inline(always)]
fn half_lanes(x: &[[f32; 8]; 3], h: usize) -> [Vec4; 3] {
    let lanes = 4 * h..4 * h + 4;
    [
        Vec4::from_slice(&x[0][lanes.clone()]),
        Vec4::from_slice(&x[1][lanes.clone()]),
        Vec4::from_slice(&x[2][lanes]),
    ]
}

/// Two packets at once in 256-bit AVX lanes (a leaf holds up to eight triangles, two packets):
/// the same operations in the same order as [`TrianglePacket::any_box_within`] and
/// [`TrianglePacket::dist2_or_zero`], so every lane's bits are those of the 4-wide code (IEEE
/// add, multiply, divide, min, max and ordered compares round alike at any width; no FMA).
/// Called only where `is_x86_feature_detected!("avx")` said yes.
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx {
    use std::arch::x86_64::*;

    use glam::Vec3;

    use super::TrianglePair;

    /// The pair's corners, eight lanes per coordinate.
    struct Pair {
        a: [__m256; 3],
        b: [__m256; 3],
        c: [__m256; 3],
    }

    impl Pair {
        #[inline]
        #[target_feature(enable = "avx")]
        fn new(t: &TrianglePair) -> Pair {
            // SAFETY: each `[f32; 8]` is 8 readable f32s, 32-byte aligned (the struct's
            // alignment and the arrays' 32-byte size).
            let lanes = |x: &[f32; 8]| unsafe { _mm256_load_ps(x.as_ptr()) };
            let load = |x: &[[f32; 8]; 3]| [lanes(&x[0]), lanes(&x[1]), lanes(&x[2])];
            Pair {
                a: load(&t.a),
                b: load(&t.b),
                c: load(&t.c),
            }
        }
    }

    /// Bit `i` set: lane `i`'s triangle box lies within squared distance `bound` of `p`
    /// ([`TrianglePacket::any_box_within`](super::TrianglePacket::any_box_within) per lane).
    #[inline]
    #[target_feature(enable = "avx")]
    pub(crate) fn boxes_within(pair: &TrianglePair, p: Vec3, bound: f32) -> u32 {
        let t = Pair::new(pair);
        let axis = |k: usize, v: f32| {
            let lo = _mm256_min_ps(_mm256_min_ps(t.a[k], t.b[k]), t.c[k]);
            let hi = _mm256_max_ps(_mm256_max_ps(t.a[k], t.b[k]), t.c[k]);
            let v = _mm256_set1_ps(v);
            let d = _mm256_max_ps(
                _mm256_max_ps(_mm256_sub_ps(lo, v), _mm256_sub_ps(v, hi)),
                _mm256_setzero_ps(),
            );
            _mm256_mul_ps(d, d)
        };
        let d2 = _mm256_add_ps(_mm256_add_ps(axis(0, p.x), axis(1, p.y)), axis(2, p.z));
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(d2, _mm256_set1_ps(bound))) as u32
    }

    /// Bit `i` set: `lanes[i] < bound` (ordered: a NaN lane is not below).
    #[inline]
    #[target_feature(enable = "avx")]
    pub(crate) fn lanes_below(lanes: &[f32; 8], bound: f32) -> u32 {
        // SAFETY: `lanes` is 8 readable f32s; the load is unaligned.
        let v = unsafe { _mm256_loadu_ps(lanes.as_ptr()) };
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(v, _mm256_set1_ps(bound))) as u32
    }

    /// [`TrianglePacket::dist2_or_zero`](super::TrianglePacket::dist2_or_zero) of all eight
    /// lanes.
    #[inline]
    #[target_feature(enable = "avx")]
    pub(crate) fn dist2_or_zero(pair: &TrianglePair, p: Vec3) -> [f32; 8] {
        let t = Pair::new(pair);
        let [ax, ay, az] = t.a;
        let [bx, by, bz] = t.b;
        let [cx, cy, cz] = t.c;
        let add = |x, y| _mm256_add_ps(x, y);
        let sub = |x, y| _mm256_sub_ps(x, y);
        let mul = |x, y| _mm256_mul_ps(x, y);
        let le = |x, y| _mm256_cmp_ps::<_CMP_LE_OQ>(x, y);
        let ge = |x, y| _mm256_cmp_ps::<_CMP_GE_OQ>(x, y);
        let and = |x, y| _mm256_and_ps(x, y);
        let select = |mask, x, y| _mm256_blendv_ps(y, x, mask);
        let (px, py, pz) = (
            _mm256_set1_ps(p.x),
            _mm256_set1_ps(p.y),
            _mm256_set1_ps(p.z),
        );
        // glam's scalar Vec3::dot: (x·x' + y·y') + z·z', left to right.
        let dot = |x, y, z, u, v, w| add(add(mul(x, u), mul(y, v)), mul(z, w));
        let (abx, aby, abz) = (sub(bx, ax), sub(by, ay), sub(bz, az));
        let (acx, acy, acz) = (sub(cx, ax), sub(cy, ay), sub(cz, az));
        let (apx, apy, apz) = (sub(px, ax), sub(py, ay), sub(pz, az));
        let d1 = dot(abx, aby, abz, apx, apy, apz);
        let d2 = dot(acx, acy, acz, apx, apy, apz);
        let to_a = dot(apx, apy, apz, apx, apy, apz);
        let (bpx, bpy, bpz) = (sub(px, bx), sub(py, by), sub(pz, bz));
        let d3 = dot(abx, aby, abz, bpx, bpy, bpz);
        let d4 = dot(acx, acy, acz, bpx, bpy, bpz);
        let to_b = dot(bpx, bpy, bpz, bpx, bpy, bpz);
        let (cpx, cpy, cpz) = (sub(px, cx), sub(py, cy), sub(pz, cz));
        let d5 = dot(abx, aby, abz, cpx, cpy, cpz);
        let d6 = dot(acx, acy, acz, cpx, cpy, cpz);
        let to_c = dot(cpx, cpy, cpz, cpx, cpy, cpz);
        let zero = _mm256_setzero_ps();
        let on_edge = |o: [__m256; 3], e: [__m256; 3], num, den| {
            let t = _mm256_div_ps(num, den);
            let (dx, dy, dz) = (
                sub(px, add(o[0], mul(e[0], t))),
                sub(py, add(o[1], mul(e[1], t))),
                sub(pz, add(o[2], mul(e[2], t))),
            );
            select(
                _mm256_cmp_ps::<_CMP_GT_OQ>(den, zero),
                dot(dx, dy, dz, dx, dy, dz),
                zero,
            )
        };
        // Distances first, the regions' verdicts last, as in the 4-wide code.
        let to_ab = on_edge(t.a, [abx, aby, abz], d1, sub(d1, d3));
        let to_ca = on_edge(t.a, [acx, acy, acz], d2, sub(d2, d6));
        let e4 = sub(d4, d3);
        let e5 = sub(d5, d6);
        let cb = [sub(cx, bx), sub(cy, by), sub(cz, bz)];
        let to_bc = on_edge(t.b, cb, e4, add(e4, e5));
        let vc = sub(mul(d1, d4), mul(d3, d2));
        let vb = sub(mul(d5, d2), mul(d1, d6));
        let va = sub(mul(d3, d6), mul(d5, d4));
        let in_bc = and(and(le(va, zero), ge(e4, zero)), ge(e5, zero));
        let mut out = select(in_bc, to_bc, zero);
        let in_ca = and(and(le(vb, zero), ge(d2, zero)), le(d6, zero));
        out = select(in_ca, to_ca, out);
        let in_c = and(ge(d6, zero), le(d5, d6));
        out = select(in_c, to_c, out);
        let in_ab = and(and(le(vc, zero), ge(d1, zero)), le(d3, zero));
        out = select(in_ab, to_ab, out);
        let in_b = and(ge(d3, zero), le(d4, d3));
        out = select(in_b, to_b, out);
        let in_a = and(le(d1, zero), le(d2, zero));
        out = select(in_a, to_a, out);
        let mut lanes = [0.0f32; 8];
        // SAFETY: `lanes` is 8 writable f32s; the store is unaligned.
        unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), out) };
        lanes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::point_triangle::{apex_rotation, closest_point_prerotated, Feature};
    use crate::test_points::{avx_pair_proptest, lanes_match_4_wide, packet_triangles, point};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Every lane equals the scalar test's squared distance exactly on vertices and edges,
        /// and is 0 exactly where the scalar test found a face point (so the filter never hides
        /// a triangle the scalar search would have taken).
        #[test]
        fn lanes_match_the_scalar_test(
            tris in packet_triangles(),
            p in point(),
        ) {
            let rotated: Vec<[Vec3; 3]> = tris
                .iter()
                .map(|&t| {
                    let k = apex_rotation(t[0], t[1], t[2]) as usize;
                    [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
                })
                .collect();
            let lanes = TrianglePacket::new(&rotated).dist2_or_zero(p).to_array();
            for (lane, t) in rotated.iter().enumerate() {
                let (q, feature) = closest_point_prerotated(p, t[0], t[1], t[2], 0);
                let exact = (p - q).length_squared();
                let got = lanes[lane];
                if got != 0.0 {
                    prop_assert_eq!(got.to_bits(), exact.to_bits(), "lane {} {:?}", lane, feature);
                }
                if feature == Feature::Face {
                    prop_assert_eq!(got, 0.0);
                }
            }
        }
    }

    avx_pair_proptest! {
        /// The 8-wide AVX pass gives each packet's lanes to the bit and the same box verdicts
        /// as the 4-wide code (on a CPU without AVX the search never calls it).
        fn avx_pairs_match_the_4_wide_code(
            lo,
            hi,
            p in point(),
            bound in prop_oneof![0.0f32..4.0, Just(f32::INFINITY)],
        ) {
            let (lo, hi) = (TrianglePacket::new(&lo), TrianglePacket::new(&hi));
            let pair = TrianglePair::new(&lo, &hi);
            for (h, packet) in [lo, hi].iter().enumerate() {
                let back = pair.half(h);
                prop_assert_eq!((back.a, back.b, back.c), (packet.a, packet.b, packet.c));
            }
            // SAFETY: `avx_pair_proptest!` returns before the body without AVX.
            let (lanes, boxes) = unsafe {
                (avx::dist2_or_zero(&pair, p), avx::boxes_within(&pair, p, bound))
            };
            // SAFETY: as above.
            let below = unsafe { avx::lanes_below(&lanes, bound) };
            for (lane, d2) in lanes.iter().enumerate() {
                prop_assert_eq!(below >> lane & 1 == 1, *d2 < bound, "lane {}", lane);
            }
            let four = |packet: &TrianglePacket| packet.dist2_or_zero(p).to_array();
            lanes_match_4_wide(&lanes, four(&lo), four(&hi))?;
            prop_assert_eq!(boxes & 0xF != 0, lo.any_box_within(p, bound));
            prop_assert_eq!(boxes & 0xF0 != 0, hi.any_box_within(p, bound));
        }
    }

    #[test]
    fn face_and_vertex_lanes() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let packet = TrianglePacket::new(&[t]);
        // Above the interior: the exact test must run.
        assert_eq!(packet.dist2_or_zero(Vec3::new(0.2, 0.2, 1.0)).x, 0.0);
        // Beyond vertex X: distance² to it.
        assert_eq!(packet.dist2_or_zero(Vec3::new(3.0, 0.0, 0.0)).x, 4.0);
        // Beside edge XY.
        let d = packet.dist2_or_zero(Vec3::new(1.0, 1.0, 0.0)).x;
        assert!((d - 0.5).abs() < 1e-6, "{d}");
    }
}
