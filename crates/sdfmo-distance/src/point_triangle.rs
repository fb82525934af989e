//! Closest point on a triangle (Ericson, *Real-Time Collision Detection*, §5.1.5), in f32.
//!
//! The Voronoi-region method classifies the query point against the regions of the three
//! vertices, the three edges and the face, and returns the closest point together with the
//! feature it lies on. The feature is what the pseudo-normal sign needs (Bærentzen & Aanæs 2005).
//!
//! Degenerate triangles (zero area, coincident vertices, needles) never produce NaN: every
//! division is guarded, and when rounding makes the face region inconsistent (barycentrics out of
//! range, non-positive area) the answer falls back to the closest of the three edge segments.

use glam::Vec3;

/// The feature of a triangle on which a closest point lies.
///
/// Edge `k` joins local vertex `k` and local vertex `(k + 1) % 3`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feature {
    /// Local vertex 0, 1 or 2.
    Vertex(u8),
    /// Local edge 0 (v0–v1), 1 (v1–v2) or 2 (v2–v0).
    Edge(u8),
    /// The interior of the face.
    Face,
}

/// Closest point to `p` on triangle `(a, b, c)` and the feature it lies on.
///
/// Exact up to f32 rounding for well-shaped triangles; safe (finite, on the triangle's edges or
/// vertices) for degenerate ones.
#[inline]
pub fn closest_point_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, Feature) {
    // Conditioning: the region tests work with the two edges leaving `a`; for a needle whose
    // apex is `a` those are nearly parallel and the face barycentrics lose many digits in f32
    // (measured: 70 ulps on a 10:1 needle). Rotating the vertices cyclically so that `a` is
    // opposite the longest edge makes them the two shorter edges, at the widest angle. The
    // rotation keeps the orientation; the feature is mapped back to the caller's numbering.
    match apex_rotation(a, b, c) {
        0 => closest_point_ordered(p, a, b, c),
        // Longest edge c–a: apex b.
        1 => rotate_feature(closest_point_ordered(p, b, c, a), 1),
        // Longest edge a–b: apex c.
        _ => rotate_feature(closest_point_ordered(p, c, a, b), 2),
    }
}

/// The cyclic rotation `r` that [`closest_point_on_triangle`] applies to `(a, b, c)`: local
/// vertex k of the rotated triangle is the caller's vertex (k + r) % 3, and local vertex 0 is
/// opposite the longest edge.
#[inline(always)]
pub(crate) fn apex_rotation(a: Vec3, b: Vec3, c: Vec3) -> u8 {
    let (lab, lbc, lca) = (
        (b - a).length_squared(),
        (c - b).length_squared(),
        (a - c).length_squared(),
    );
    if lbc >= lab && lbc >= lca {
        0
    } else if lca >= lab {
        1
    } else {
        2
    }
}

/// [`closest_point_on_triangle`] of a triangle already rotated by `r` (see
/// [`apex_rotation`]): `(a, b, c)` are the rotated vertices, the feature is numbered in the
/// original triangle. Bit-identical to the unrotated call, without the edge lengths.
#[inline(always)]
pub(crate) fn closest_point_prerotated(
    p: Vec3,
    a: Vec3,
    b: Vec3,
    c: Vec3,
    r: u8,
) -> (Vec3, Feature) {
    rotate_feature(closest_point_ordered(p, a, b, c), r)
}

/// Maps a feature of the triangle rotated by `r` (local vertex k is the caller's k + r) back.
#[inline(always)]
fn rotate_feature((q, f): (Vec3, Feature), r: u8) -> (Vec3, Feature) {
    let f = match f {
        Feature::Vertex(k) => Feature::Vertex((k + r) % 3),
        Feature::Edge(k) => Feature::Edge((k + r) % 3),
        Feature::Face => Feature::Face,
    };
    (q, f)
}

/// Ericson's region method with the vertices in the given order.
#[inline(always)]
fn closest_point_ordered(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, Feature) {
    // The three edge regions are one rule: `p` lies beyond the edge `from + u·e` (`v ≤ 0`) and
    // between its ends (`s, t ≥ 0`, with `s + t = |e|²`: the foot is at `u = s / (s + t)`).
    // `s + t = 0` only on a degenerate edge: then the edges decide. (AB and CA pass `t = -d`:
    // `x + -d` is `x - d` to the bit.)
    let edge_region = |v: f32, s: f32, t: f32, from: Vec3, e: Vec3, k: u8| {
        if v <= 0.0 && s >= 0.0 && t >= 0.0 {
            let den = s + t;
            if den > 0.0 {
                return Some((from + e * (s / den), Feature::Edge(k)));
            }
            return Some(closest_on_edges(p, a, b, c));
        }
        None
    };
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    // Region of vertex A.
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    // Region of vertex B.
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    // Region of edge AB: d1 - d3 = |ab|².
    if let Some(q) = edge_region(vc, d1, -d3, a, ab, 0) {
        return q;
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    // Region of vertex C.
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    // Region of edge CA: d2 - d6 = |ac|².
    if let Some(q) = edge_region(vb, d2, -d6, a, ac, 2) {
        return q;
    }
    let va = d3 * d6 - d5 * d4;
    // Region of edge BC: (d4 - d3) + (d5 - d6) = |bc|².
    if let Some(q) = edge_region(va, d4 - d3, d5 - d6, b, c - b, 1) {
        return q;
    }
    // Face region: va + vb + vc = |ab × ac|².
    let den = va + vb + vc;
    if den > 0.0 {
        let v = vb / den;
        let w = vc / den;
        if v >= 0.0 && w >= 0.0 && v + w <= 1.0 {
            // The point itself is the projection onto the plane computed in f64: in f32 the
            // barycentric point a + v·ab + w·ac (differences of products) errs like 1/sin² of the
            // apex angle and an f32 projection like 1/sin (measured: 1.1e-5 off on a 178.5°
            // sliver, 5e-6 at 0.4 from a needle; regression tests
            // `flat_sliver_face_point_is_projected`, `needle_face_region_keeps_f32_precision`).
            // The f32 classification of a needle can also be wrong: the f64 foot point is
            // checked to lie on the triangle, else the edges decide.
            let (pd, ad) = (p.as_dvec3(), a.as_dvec3());
            let (e0, e1) = (b.as_dvec3() - ad, c.as_dvec3() - ad);
            let n = e0.cross(e1);
            let nn = n.length_squared();
            if nn > 0.0 {
                let q = pd - n * (n.dot(pd - ad) / nn);
                let w = q - ad;
                // Barycentrics from signed sub-areas: u·nn = (e0 × w)·n etc.
                let bv = w.cross(e1).dot(n);
                let bw = e0.cross(w).dot(n);
                if bv >= 0.0 && bw >= 0.0 && bv + bw <= nn {
                    return (q.as_vec3(), Feature::Face);
                }
                return closest_on_edges(p, a, b, c);
            }
            return (a + ab * v + ac * w, Feature::Face);
        }
    }
    closest_on_edges(p, a, b, c)
}

/// Closest point on segment `a`–`b` as the parameter t in [0, 1].
#[inline]
fn segment_parameter(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Fallback for degenerate triangles: the closest point over the three edge segments.
#[cold]
fn closest_on_edges(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, Feature) {
    let verts = [a, b, c];
    let mut best = (a, Feature::Vertex(0));
    let mut best_d2 = f32::INFINITY;
    for k in 0..3u8 {
        let s = verts[k as usize];
        let e = verts[(k as usize + 1) % 3];
        let t = segment_parameter(p, s, e);
        let (q, f) = if t <= 0.0 {
            (s, Feature::Vertex(k))
        } else if t >= 1.0 {
            (e, Feature::Vertex((k + 1) % 3))
        } else {
            (s + (e - s) * t, Feature::Edge(k))
        };
        let d2 = (p - q).length_squared();
        if d2 < best_d2 {
            best_d2 = d2;
            best = (q, f);
        }
    }
    best
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;

    type D3 = [f64; 3];

    fn sub(a: D3, b: D3) -> D3 {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    fn dot(a: D3, b: D3) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    fn cross(a: D3, b: D3) -> D3 {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }
    fn axpy(a: D3, t: f64, d: D3) -> D3 {
        [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]]
    }
    pub(crate) fn d3(v: Vec3) -> D3 {
        [v.x as f64, v.y as f64, v.z as f64]
    }

    /// f64 oracle by a different method: project onto the plane and test the barycentrics; if
    /// outside (or degenerate), the nearest of the three clamped segments.
    pub(crate) fn oracle_closest(p: D3, t: [D3; 3]) -> (D3, f64) {
        let [a, b, c] = t;
        let n = cross(sub(b, a), sub(c, a));
        let nn = dot(n, n);
        let scale = dot(sub(b, a), sub(b, a)).max(dot(sub(c, a), sub(c, a)));
        if nn > 1e-24 * scale * scale && nn > 0.0 {
            let q = axpy(p, -dot(sub(p, a), n) / nn, n);
            // Barycentrics via sub-triangle areas with signs.
            let wa = dot(cross(sub(b, q), sub(c, q)), n);
            let wb = dot(cross(sub(c, q), sub(a, q)), n);
            let wc = dot(cross(sub(a, q), sub(b, q)), n);
            if wa >= 0.0 && wb >= 0.0 && wc >= 0.0 {
                let d = sub(p, q);
                return (q, dot(d, d).sqrt());
            }
        }
        let mut best = (a, f64::INFINITY);
        for (s, e) in [(a, b), (b, c), (c, a)] {
            let se = sub(e, s);
            let l2 = dot(se, se);
            let t = if l2 > 0.0 {
                (dot(sub(p, s), se) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let q = axpy(s, t, se);
            let d = sub(p, q);
            let dist = dot(d, d).sqrt();
            if dist < best.1 {
                best = (q, dist);
            }
        }
        best
    }

    fn check(p: Vec3, a: Vec3, b: Vec3, c: Vec3) {
        let (q, f) = closest_point_on_triangle(p, a, b, c);
        assert!(q.is_finite(), "non-finite closest point {q:?} ({f:?})");
        let (oq, od) = oracle_closest(d3(p), [d3(a), d3(b), d3(c)]);
        let d = (p - q).length() as f64;
        let scale = [p, a, b, c]
            .iter()
            .map(|v| v.abs().max_element())
            .fold(0.0f32, f32::max) as f64;
        let tol = 4e-6 * scale.max(1e-3) + 1e-3 * od;
        assert!(
            (d - od).abs() <= tol,
            "distance {d} vs oracle {od} (tol {tol}) for p {p:?} tri {a:?} {b:?} {c:?} ({f:?})"
        );
        // The returned point must itself be (close to) the oracle's closest point unless the
        // minimum is not unique (then only the distance is determined).
        let dq = sub(d3(q), oq);
        let _ = dot(dq, dq);
        // The feature must agree with the point returned.
        match f {
            Feature::Vertex(k) => assert_eq!(q, [a, b, c][k as usize]),
            Feature::Edge(_) | Feature::Face => {}
        }
    }

    fn v3() -> impl Strategy<Value = Vec3> {
        (-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

        #[test]
        fn random_triangles_match_oracle(p in v3(), a in v3(), b in v3(), c in v3()) {
            check(p, a, b, c);
        }

        #[test]
        fn needles_and_slivers_match_oracle(
            p in v3(), a in v3(), dir in v3(), t in 0.0f32..1.0, eps in -1e-4f32..1e-4, side in v3(),
        ) {
            // c lies (almost) on the line through a and b: a sliver / needle.
            let b = a + dir;
            let c = a + dir * t + side * eps;
            check(p, a, b, c);
            check(p, c, a, b);
        }

        #[test]
        fn coincident_vertices_match_oracle(p in v3(), a in v3(), b in v3(), which in 0usize..3) {
            let tris = [(a, a, b), (a, b, a), (b, a, a)];
            let (x, y, z) = tris[which];
            check(p, x, y, z);
            check(p, a, a, a);
        }

        #[test]
        fn points_near_the_triangle_match_oracle(
            a in v3(), b in v3(), c in v3(), u in 0.0f32..1.0, v in 0.0f32..1.0, off in v3(), s in 0.0f32..0.01,
        ) {
            let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
            let p = a + (b - a) * u + (c - a) * v + off * s;
            check(p, a, b, c);
        }
    }

    #[test]
    fn regions_are_reported() {
        let a = Vec3::ZERO;
        let b = Vec3::X;
        let c = Vec3::Y;
        assert_eq!(
            closest_point_on_triangle(Vec3::new(-1.0, -1.0, 0.5), a, b, c).1,
            Feature::Vertex(0)
        );
        assert_eq!(
            closest_point_on_triangle(Vec3::new(2.0, -0.1, 0.0), a, b, c).1,
            Feature::Vertex(1)
        );
        assert_eq!(
            closest_point_on_triangle(Vec3::new(-0.1, 2.0, 0.0), a, b, c).1,
            Feature::Vertex(2)
        );
        assert_eq!(
            closest_point_on_triangle(Vec3::new(0.5, -1.0, 0.0), a, b, c).1,
            Feature::Edge(0)
        );
        assert_eq!(
            closest_point_on_triangle(Vec3::new(1.0, 1.0, 0.3), a, b, c).1,
            Feature::Edge(1)
        );
        assert_eq!(
            closest_point_on_triangle(Vec3::new(-1.0, 0.5, 0.0), a, b, c).1,
            Feature::Edge(2)
        );
        let (q, f) = closest_point_on_triangle(Vec3::new(0.25, 0.25, 3.0), a, b, c);
        assert_eq!(f, Feature::Face);
        assert!((q - Vec3::new(0.25, 0.25, 0.0)).length() < 1e-7);
    }

    #[test]
    fn fully_degenerate_triangle_is_a_point() {
        let a = Vec3::new(0.3, -0.2, 0.1);
        let (q, f) = closest_point_on_triangle(Vec3::new(1.0, 1.0, 1.0), a, a, a);
        assert_eq!(q, a);
        assert!(matches!(f, Feature::Vertex(_)));
    }

    #[test]
    fn needle_face_region_keeps_f32_precision() {
        // Regression: with the needle's apex as `a`, the face barycentrics lost ~70 ulps and the
        // distance came out 6.98e-4 instead of 6.81e-4. Fixed by rotating the apex opposite the
        // longest edge.
        check(
            Vec3::new(-1.2241066, -0.26181448, -0.09128043),
            Vec3::new(-0.6217413, 1.1077604, 0.6922712),
            Vec3::new(-1.723847, -1.4224526, -0.7338386),
            Vec3::new(-1.6230986, -1.1545392, -0.61948675),
        );
    }

    #[test]
    fn flat_sliver_face_point_is_projected() {
        // Regression: the barycentric face point was 1.1e-5 away for a point 7e-9 from this
        // 178.5° sliver.
        check(
            Vec3::new(0.008201271, -0.08656171, 0.9215697),
            Vec3::new(-0.38535422, -0.40696666, 0.8023747),
            Vec3::new(-1.2528561, -1.1258153, 0.5678931),
            Vec3::new(0.71122503, 0.4865333, 1.132825),
        );
    }
}
