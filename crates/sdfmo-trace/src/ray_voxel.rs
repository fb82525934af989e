//! Ray vs one trilinear voxel: the first root of a cubic along the ray.
//!
//! In its local frame `[0,1]³` a voxel interpolates its 8 corner values (corner `i = 4x + 2y + z`)
//! trilinearly. Along a ray `p(t) = origin + t·dir` that interpolant is a cubic in `t`. The kernel
//! re-parametrises it around the start of the segment (`s = t − t0`, so the coefficients are
//! computed from a point inside the cube and stay well conditioned however far the ray origin
//! is), splits `[0, t1 − t0]` at the roots of the derivative (Marmitt et al. 2004) into at most
//! three pieces on which the cubic is monotone, walks them front to back and polishes the first
//! bracketed root with Newton's method safeguarded by bisection.
//!
//! Which root counts:
//! * **Volume voxel** (negative inside): the hit is `inf { t ∈ [t0, t1] : f(t) < 0 }`, the first
//!   point where the ray is inside. A ray whose segment *starts* inside (`f(t0) < 0`) hits at
//!   `t0`: a shadow or occlusion ray that starts inside a solid is blocked, and a primary ray
//!   that enters a leaf already inside (a neighbour leaf that was not stored, or whose values do
//!   not match across the shared face) hits that face instead of leaking through it, which is
//!   what keeps silhouettes free of pinholes. A tangent touch from outside (`f ≥ 0` on both
//!   sides) is not a hit; a segment along which `f` is identically zero (it runs in the zero
//!   set, e.g. in the plane of an internal face of touching shells) is, where it starts. A
//!   voxel whose corners are all zero (all codes 0 in a file) is never hit: it has no inside,
//!   no surface and no gradient (`FORMAT.md`, surface section, issue 19).
//! * **Surface voxel** (no inside): the first `t` where `f` reaches zero, from either side,
//!   including `t0` itself when `f(t0) = 0`. An interpolant that is zero everywhere has no
//!   crossing and no hit.
//!
//! Decisions use only signs, and tolerances are relative to the segment, so the kernel is
//! scale-invariant: corner values of 1e6 or 1e-6 give the same roots. It never returns NaN.

use glam::Vec3;

use sdfmo_format::trilinear;

// Newton/bisection steps at most, and the tolerance of a polished root as a fraction of the
// segment length: shared with the WGSL kernel (`sdfmo_format::kernel`).
use sdfmo_format::kernel::MAX_POLISH_STEPS;
pub(crate) use sdfmo_format::kernel::ROOT_REL_TOLERANCE as REL_TOLERANCE;

/// A cubic `a s³ + b s² + c s + d` in the segment parameter `s = t − t0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RayCubic {
    /// Coefficient of `s³`.
    pub a: f32,
    /// Coefficient of `s²`.
    pub b: f32,
    /// Coefficient of `s`.
    pub c: f32,
    /// Constant term: the interpolant at the segment start.
    pub d: f32,
}

impl RayCubic {
    /// The interpolant of `corners` along `p + s·dir`, with `p` the segment start in the voxel's
    /// local frame (any point works; one inside `[0,1]³` keeps the coefficients accurate).
    #[inline]
    pub fn new(corners: &[f32; 8], p: Vec3, dir: Vec3) -> RayCubic {
        let [c000, c001, c010, c011, c100, c101, c110, c111] = *corners;
        // Monomial form f = k0 + kx x + ky y + kz z + kxy xy + kxz xz + kyz yz + kxyz xyz.
        let kx = c100 - c000;
        let ky = c010 - c000;
        let kz = c001 - c000;
        let kxy = (c110 - c100) - (c010 - c000);
        let kxz = (c101 - c100) - (c001 - c000);
        let kyz = (c011 - c010) - (c001 - c000);
        let kxyz = ((c111 - c110) - (c101 - c100)) - ((c011 - c010) - (c001 - c000));
        // Taylor expansion around p: value, gradient·dir, half the second directional
        // derivative, and the cubic term.
        let gx = kx + kxy * p.y + kxz * p.z + kxyz * p.y * p.z;
        let gy = ky + kxy * p.x + kyz * p.z + kxyz * p.x * p.z;
        let gz = kz + kxz * p.x + kyz * p.y + kxyz * p.x * p.y;
        let b = kxy * dir.x * dir.y
            + kxz * dir.x * dir.z
            + kyz * dir.y * dir.z
            + kxyz * (p.x * dir.y * dir.z + p.y * dir.x * dir.z + p.z * dir.x * dir.y);
        RayCubic {
            a: kxyz * dir.x * dir.y * dir.z,
            b,
            c: gx * dir.x + gy * dir.y + gz * dir.z,
            d: trilinear(corners, p),
        }
    }

    /// The cubic at `s`.
    #[inline]
    pub fn eval(&self, s: f32) -> f32 {
        ((self.a * s + self.b) * s + self.c) * s + self.d
    }

    /// Its derivative at `s`.
    #[inline]
    pub fn derivative(&self, s: f32) -> f32 {
        (3.0 * self.a * s + 2.0 * self.b) * s + self.c
    }

    /// Roots of the derivative strictly inside `(0, len)`, ascending, and how many there are.
    ///
    /// `3a s² + 2b s + c = 0` solved with the cancellation-free form (`q = −(B + sign(B)√Δ)/2`,
    /// roots `q/A` and `C/q`); a vanishing `a` (a quadratic or linear cubic, e.g. an
    /// axis-parallel ray) gives an infinite or NaN root, which the range test drops.
    #[inline]
    pub fn critical_points(&self, len: f32) -> ([f32; 2], usize) {
        let qa = 3.0 * self.a;
        let qb = 2.0 * self.b;
        let qc = self.c;
        let disc = qb * qb - 4.0 * qa * qc;
        let mut out = [0.0f32; 2];
        let mut n = 0;
        if disc >= 0.0 {
            let q = -0.5 * (qb + disc.sqrt().copysign(qb));
            let (mut r0, mut r1) = (q / qa, qc / q);
            if r1 < r0 {
                core::mem::swap(&mut r0, &mut r1);
            }
            // NaN fails both comparisons and is dropped.
            if r0 > 0.0 && r0 < len {
                out[n] = r0;
                n += 1;
            }
            if r1 > 0.0 && r1 < len && (n == 0 || r1 > out[0]) {
                out[n] = r1;
                n += 1;
            }
        }
        (out, n)
    }
}

/// The parameter span `[t_enter, t_exit]` of the ray `origin + t·dir` inside the unit cube
/// `[0,1]³`, or `None` when it misses. Zero direction components are handled (the ray is inside
/// that slab for all `t` or for none). The span is not clipped to `t ≥ 0`.
#[inline]
pub fn unit_cube_span(origin: Vec3, dir: Vec3) -> Option<(f32, f32)> {
    let mut t_enter = f32::NEG_INFINITY;
    let mut t_exit = f32::INFINITY;
    for k in 0..3 {
        let (o, d) = (origin[k], dir[k]);
        if d == 0.0 {
            if !(0.0..=1.0).contains(&o) {
                return None;
            }
        } else {
            let inv = 1.0 / d;
            let (ta, tb) = (-o * inv, (1.0 - o) * inv);
            t_enter = t_enter.max(ta.min(tb));
            t_exit = t_exit.min(ta.max(tb));
        }
    }
    (t_enter <= t_exit).then_some((t_enter, t_exit))
}

/// The kernel on one voxel, in its local frame `[0,1]³`: the first root in `[t0, t1]`
/// (volume voxels: the first point inside, `f < 0`, which is `t0` when the segment starts
/// inside; surface voxels: the first zero from either side). See the module docs.
///
/// The segment `[t0, t1]` is expected to lie in the unit cube (the traversal passes a leaf's
/// span; [`unit_cube_span`] computes it): outside the cube the interpolant is a polynomial
/// extrapolation, and the early-out for voxels whose corners all share one sign, exact inside the
/// cube, may skip roots there. `None` for an empty or NaN segment.
#[inline]
pub fn intersect_voxel(
    corners: &[f32; 8],
    origin: Vec3,
    dir: Vec3,
    t0: f32,
    t1: f32,
    surface: bool,
) -> Option<f32> {
    intersect_voxel_where(corners, origin, dir, (t0, t1), surface, |_, _| true)
}

/// The first candidate hit of one voxel in `span = (t0, t1)` that `accept` accepts (it gets the
/// candidate's `t` and whether it is a polished root, `false` for the span start `t0` of a
/// segment that starts inside a volume voxel or on a surface voxel), in the voxel's local
/// frame `[0,1]³`, the candidates taken front to back (those of the clip rule, `FORMAT.md` in
/// sdfmo-format, section `clip`): for a volume voxel every crossing from `f ≥ 0` to `f < 0`
/// and `t0` when `f(t0) < 0` (or `f` is zero along the whole segment); for a surface voxel
/// every sign change and `t0` when `f(t0) = 0`.
///
/// [`intersect_voxel`] is this with an `accept` that takes every candidate. `None` for an
/// empty or NaN segment.
#[inline]
pub fn intersect_voxel_where(
    corners: &[f32; 8],
    origin: Vec3,
    dir: Vec3,
    span: (f32, f32),
    surface: bool,
    accept: impl FnMut(f32, bool) -> bool,
) -> Option<f32> {
    // The plain kernel's early-outs, normalisation and polish, `accept` choosing the candidate.
    intersect_prepared(&prepare_voxel(corners), origin, dir, span, surface, accept)
}

/// What [`intersect_voxel`] learns from a voxel's corners alone, the same for every ray: a
/// packet of rays through one leaf computes it once per voxel ([`crate::intersect_packet`]).
#[derive(Clone, Copy, Debug)]
pub(crate) enum PreparedVoxel {
    /// No zero inside the cube (all corners positive, or all (near) zero or NaN).
    Miss,
    /// All corners negative: inside everywhere.
    Inside,
    /// The corners divided by their largest magnitude.
    Scaled([f32; 8]),
}

/// The corner-only part of [`intersect_voxel`].
#[inline]
pub(crate) fn prepare_voxel(corners: &[f32; 8]) -> PreparedVoxel {
    let (lo, hi) = min_max(corners);
    // Exact early-outs: a trilinear interpolant is a convex combination of its corners inside
    // the cube, so it can only reach zero if min ≤ 0 ≤ max.
    if lo > 0.0 {
        return PreparedVoxel::Miss;
    }
    if hi < 0.0 {
        return PreparedVoxel::Inside;
    }
    // Normalise values by the largest magnitude and the parameter to u = (t − t0)/len ∈ [0, 1]:
    // the coefficients of a cubic bounded by 1 on [0, 1] are O(1), so nothing overflows or
    // underflows whatever the corner magnitudes and the ray speed. Corners all below the
    // smallest normal f32 (or NaN) count as zero: no crossing.
    let m = hi.max(-lo);
    if m.is_nan() || m < f32::MIN_POSITIVE {
        return PreparedVoxel::Miss;
    }
    let inv = 1.0 / m;
    PreparedVoxel::Scaled(corners.map(|c| c * inv))
}

/// The per-ray part of [`intersect_voxel`] on the span `(t0, t1)`, the candidates filtered by
/// `accept` as [`intersect_voxel_where`](crate::clip::intersect_voxel_where) filters them: one
/// body for both kernels, so with `accept` always true the result is [`intersect_voxel`]'s, bit
/// for bit (`accept` is inlined away).
// Always inlined: with `#[inline]` alone the one body for both kernels cost the plain render
// 2.9 % more instructions (callgrind, abc1 depth 8 multi, paper view 0 at 1024²: 178.7 M before
// the merge, 183.9 M after, 171.0 M inlined).
#[inline(always)]
pub(crate) fn intersect_prepared(
    voxel: &PreparedVoxel,
    origin: Vec3,
    dir: Vec3,
    (t0, t1): (f32, f32),
    surface: bool,
    mut accept: impl FnMut(f32, bool) -> bool,
) -> Option<f32> {
    let len = t1 - t0;
    // Also rejects NaN and infinite segments.
    if !(0.0..f32::INFINITY).contains(&len) {
        return None;
    }
    match voxel {
        PreparedVoxel::Miss => None,
        // Everything inside: a volume voxel's only candidate is where the segment starts; a
        // surface voxel has no zero at all.
        PreparedVoxel::Inside => (!surface && accept(t0, false)).then_some(t0),
        PreparedVoxel::Scaled(scaled) => {
            let cubic = RayCubic::new(scaled, origin + dir * t0, dir * len);
            let to_t = |u: f32| (t0 + u * len).min(t1);
            roots_where(&cubic, 1.0, surface, |u, root| accept(to_t(u), root)).map(to_t)
        }
    }
}

/// The candidates of a cubic on `[0, len]` in order, the first one `accept` takes (it gets the
/// candidate's parameter and whether it is a polished root, `false` for the segment start):
/// for a volume voxel the segment start when it starts inside (or the cubic is zero along the
/// whole segment, a ray in the zero set of touching shells: on the surface, not a leak), then
/// every crossing from `g ≥ 0` to `g < 0`; for a surface voxel the start when `g = 0` there,
/// then every sign change. Each monotone piece between the cubic's critical points holds one
/// root at most, polished to `1e-6 · len`. [`intersect_voxel`] accepts everything; the clip
/// rule (`crate::clip`) goes on past rejected candidates.
#[inline(always)]
pub(crate) fn roots_where(
    cubic: &RayCubic,
    len: f32,
    surface: bool,
    mut accept: impl FnMut(f32, bool) -> bool,
) -> Option<f32> {
    let g0 = cubic.d;
    // The segment start: inside a volume, or on a surface.
    if (g0 < 0.0 && !surface || g0 == 0.0 && surface) && accept(0.0, false) {
        return Some(0.0);
    }
    if g0 == 0.0 && cubic.a == 0.0 && cubic.b == 0.0 && cubic.c == 0.0 {
        // Zero along the whole segment: a volume voxel is hit where it starts (as the plain
        // kernel); a surface voxel had its one candidate at the start.
        return (!surface && accept(0.0, false)).then_some(0.0);
    }
    if len.is_nan() || len < 0.0 || g0.is_nan() {
        return None;
    }
    if keeps_sign(cubic, len) {
        // No candidate after the start: the loop below would find no crossing.
        return None;
    }
    let (crit, n) = cubic.critical_points(len);
    let mut sa = 0.0f32;
    let mut ga = g0;
    for sb in crit.into_iter().take(n).chain(core::iter::once(len)) {
        let gb = cubic.eval(sb);
        // One root at most on a monotone piece.
        let crosses = if surface {
            (ga > 0.0 && gb <= 0.0) || (ga < 0.0 && gb >= 0.0)
        } else {
            ga >= 0.0 && gb < 0.0
        };
        if crosses {
            let s = polish(cubic, sa, sb, ga, gb, len * REL_TOLERANCE);
            if accept(s, true) {
                return Some(s);
            }
        }
        sa = sb;
        ga = gb;
    }
    None
}

/// Whether every value of `cubic` that [`roots_where`] evaluates on `[0, len]` has the sign of
/// `g(0) = d`, strictly, so that it finds no crossing: `|d|` is beyond `|a| len³ + |b| len² +
/// |c| len`, which bounds how far the cubic moves from `d` on the segment, by a margin
/// (`1.001×`, plus `1e-30` against underflow) far above the rounding of an f32 evaluation
/// (Horner: under `4e-7 · (|a| s³ + |b| s² + |c| s + |d|)`). Exact, not a heuristic: the
/// kernel's result is the same bit for bit, without the critical points and the evaluations on
/// the many segments that pass near the surface but not through it (callgrind, abc1 depth 9
/// multi, paper view 0: see docs/results/render.md). NaN coefficients give `false`.
#[inline(always)]
fn keeps_sign(cubic: &RayCubic, len: f32) -> bool {
    let reach = ((cubic.a.abs() * len + cubic.b.abs()) * len + cubic.c.abs()) * len;
    cubic.d.abs() > reach * 1.001 + 1e-30
}

/// The root of `cubic` in `[lo, hi]`, on which it is monotone, `g(lo) = glo` and `g(hi) = ghi`
/// of opposite signs (either may be zero). Newton steps, replaced by bisection whenever they
/// leave the bracket; stops when a step or the bracket is below `tol`.
#[inline]
pub(crate) fn polish(
    cubic: &RayCubic,
    mut lo: f32,
    mut hi: f32,
    glo: f32,
    ghi: f32,
    tol: f32,
) -> f32 {
    if glo == 0.0 {
        return lo;
    }
    if ghi == 0.0 {
        return hi;
    }
    let lo_positive = glo > 0.0;
    // Regula falsi start.
    let mut s = lo + (hi - lo) * (glo / (glo - ghi));
    if !(s > lo && s < hi) {
        s = 0.5 * (lo + hi);
    }
    for _ in 0..MAX_POLISH_STEPS {
        let gs = cubic.eval(s);
        if gs == 0.0 {
            return s;
        }
        // Keep the sign change inside the bracket: `s` replaces the end whose sign it has.
        (lo, hi) = if (gs > 0.0) == lo_positive {
            (s, hi)
        } else {
            (lo, s)
        };
        let newton = s - gs / cubic.derivative(s);
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - s).abs() <= tol || hi - lo <= tol {
            return next;
        }
        s = next;
    }
    s
}

#[inline]
pub(crate) fn min_max(c: &[f32; 8]) -> (f32, f32) {
    let lo = c[0]
        .min(c[1])
        .min(c[2].min(c[3]))
        .min(c[4].min(c[5]).min(c[6].min(c[7])));
    let hi = c[0]
        .max(c[1])
        .max(c[2].max(c[3]))
        .max(c[4].max(c[5]).max(c[6].max(c[7])));
    (lo, hi)
}

#[cfg(test)]
pub(crate) mod tests {
    //! The kernel against an f64 oracle (dense sampling plus bisection), on random voxels and
    //! rays and on the hard families: tangent and double roots, axis-parallel rays, rays that
    //! start inside the cube or on a face, all-near-zero and exactly-zero values, degenerate
    //! cubics, and corner magnitudes from 1e-6 to 1e6.

    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::TestCaseError;

    /// Samples of the oracle along the segment.
    const SAMPLES: usize = 4000;
    /// Residual allowed at a reported hit, and the depth beyond which a sample counts as clearly
    /// on the other side, relative to the largest |corner|.
    const EPS: f64 = 3e-5;
    /// Hit position accuracy required at clear crossings, in voxel units.
    const POS_TOL: f64 = 1e-4;
    /// Slope (per voxel unit, relative to the largest |corner|) from which a crossing is clear.
    const CLEAR_SLOPE: f64 = 0.05;

    /// The trilinear interpolant of `c` at `o + t·d`, in f64: the oracles' reference.
    pub(crate) fn f64_at(c: &[f32; 8], o: Vec3, d: Vec3, t: f64) -> f64 {
        let p = [0, 1, 2].map(|k| o[k] as f64 + t * d[k] as f64);
        let c = c.map(|v| v as f64);
        let l = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let c00 = l(c[0], c[1], p[2]);
        let c01 = l(c[2], c[3], p[2]);
        let c10 = l(c[4], c[5], p[2]);
        let c11 = l(c[6], c[7], p[2]);
        l(l(c00, c01, p[1]), l(c10, c11, p[1]), p[0])
    }

    /// The oracles' root between two samples where `changed(f(a), f(b))`: 80 bisection steps
    /// from `(a, f(a))` and `b`, keeping `changed(f(a), f(m))` on the `b` side.
    pub(crate) fn bisect(
        f: impl Fn(f64) -> f64,
        changed: impl Fn(f64, f64) -> bool,
        (mut a, fa): (f64, f64),
        mut b: f64,
    ) -> f64 {
        for _ in 0..80 {
            let m = 0.5 * (a + b);
            if changed(fa, f(m)) {
                b = m;
            } else {
                a = m;
            }
        }
        b
    }

    #[derive(Clone, Debug)]
    struct Case {
        corners: [f32; 8],
        origin: Vec3,
        dir: Vec3,
        t0: f32,
        t1: f32,
        surface: bool,
    }

    /// First oracle root (sampling, then 80 bisection steps) and whether the kernel's answer is
    /// consistent with it. See the constants for the tolerances.
    fn check(case: &Case) -> Result<Option<f32>, TestCaseError> {
        let Case {
            corners: c,
            origin: o,
            dir: d,
            t0,
            t1,
            surface,
        } = *case;
        let got = intersect_voxel(&c, o, d, t0, t1, surface);
        let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs() as f64));
        let eps = EPS * scale;
        let dlen = d.length() as f64;
        let (t0, t1) = (t0 as f64, t1 as f64);
        let dt_tol = POS_TOL / dlen;
        if let Some(t) = got {
            prop_assert!(t.is_finite(), "NaN/inf hit {t}");
            prop_assert!(
                t as f64 >= t0 && t as f64 <= t1,
                "hit {t} outside [{t0}, {t1}]"
            );
        }
        if scale == 0.0 {
            prop_assert_eq!(got, None, "all-zero voxel");
            return Ok(got);
        }
        let f = |t: f64| f64_at(&c, o, d, t);
        let ts: Vec<f64> = (0..=SAMPLES)
            .map(|i| t0 + (t1 - t0) * i as f64 / SAMPLES as f64)
            .collect();
        let fs: Vec<f64> = ts.iter().map(|&t| f(t)).collect();
        // "Clearly on the far side" of the surface.
        let clear_inside = |v: f64| if surface { false } else { v < -eps };
        // Reference side for surface voxels: the first clearly non-zero sample.
        let ref_sign = fs.iter().find(|v| v.abs() > eps).map(|v| v.signum());
        let clear_other = |v: f64| match (surface, ref_sign) {
            (true, Some(s)) => v * s < -eps,
            (true, None) => false,
            (false, _) => clear_inside(v),
        };
        // Oracle: first sign change.
        let mut oracle: Option<f64> = None;
        let changed = |a: f64, b: f64| {
            if surface {
                (a > 0.0 && b <= 0.0) || (a < 0.0 && b >= 0.0)
            } else {
                b < 0.0
            }
        };
        let starts_hit = if surface {
            fs[0] == 0.0
        } else {
            // Inside at once, or running in the zero set.
            fs[0] < 0.0 || fs.iter().all(|&v| v == 0.0)
        };
        if starts_hit {
            oracle = Some(t0);
        } else {
            for i in 1..fs.len() {
                if changed(fs[i - 1], fs[i]) {
                    oracle = Some(bisect(f, changed, (ts[i - 1], fs[i - 1]), ts[i]));
                    break;
                }
            }
        }
        match got {
            None => {
                // No missed root: nothing clearly on the far side anywhere.
                if let Some(i) = fs.iter().position(|&v| clear_other(v)) {
                    return Err(TestCaseError::fail(format!(
                        "missed root: f({}) = {} (scale {scale}), oracle root {oracle:?}",
                        ts[i], fs[i]
                    )));
                }
            }
            Some(tk) => {
                let tk = tk as f64;
                let fk = f(tk);
                // No false hit: the reported point is on the surface (or inside a volume).
                let ok = if surface { fk.abs() <= eps } else { fk <= eps };
                prop_assert!(
                    ok,
                    "false hit at {tk}: f = {fk} (scale {scale}), oracle {oracle:?}"
                );
                // Nothing clearly beyond the surface was skipped before the hit.
                for (t, v) in ts.iter().zip(&fs) {
                    if *t < tk - dt_tol {
                        prop_assert!(
                            !clear_other(*v),
                            "skipped root: f({t}) = {v} before hit {tk}, oracle {oracle:?}"
                        );
                    }
                }
                // Accuracy at clear crossings.
                if let Some(to) = oracle {
                    let h = 1e-6 / dlen;
                    let slope = ((f(to + h) - f(to - h)) / (2.0 * h)).abs() / dlen;
                    if to > t0 && slope >= CLEAR_SLOPE * scale && tk >= to - dt_tol {
                        prop_assert!(
                            (tk - to).abs() <= dt_tol,
                            "hit {tk} vs oracle {to}: {} voxel units (slope {slope})",
                            (tk - to).abs() * dlen
                        );
                    }
                    if to == t0 && fs[0] < -eps && !surface {
                        prop_assert_eq!(tk, t0, "started inside");
                    }
                }
            }
        }
        Ok(got)
    }

    /// A unit vector from three numbers, or +x when they are all tiny.
    pub(crate) fn unit(v: [f32; 3]) -> Vec3 {
        Vec3::from(v).try_normalize().unwrap_or(Vec3::X)
    }

    /// The ray `origin + t·dir` through `target` (inside the cube) from `back` units before it:
    /// its origin and its span `[t0, t1]` in the cube with t ≥ 0 (`None`: it misses).
    pub(crate) fn span_through(target: Vec3, dir: Vec3, back: f32) -> Option<(Vec3, f32, f32)> {
        let origin = target - dir * back;
        let (a, b) = unit_cube_span(origin, dir)?;
        let t0 = a.max(0.0);
        (t0 <= b).then_some((origin, t0, b))
    }

    /// A case whose ray is [`span_through`]'s.
    fn case_through(
        corners: [f32; 8],
        target: Vec3,
        dir: Vec3,
        back: f32,
        surface: bool,
    ) -> Option<Case> {
        let (origin, t0, t1) = span_through(target, dir, back)?;
        Some(Case {
            corners,
            origin,
            dir,
            t0,
            t1,
            surface,
        })
    }

    fn scale_strategy() -> impl Strategy<Value = f32> {
        prop_oneof![
            3 => Just(1.0f32),
            1 => Just(1e6f32),
            1 => Just(1e-6f32),
            2 => (-6i32..=6).prop_map(|e| 10f32.powi(e)),
        ]
    }

    fn corners_strategy() -> impl Strategy<Value = [f32; 8]> {
        (proptest::array::uniform8(-1.0f32..1.0), scale_strategy())
            .prop_map(|(c, s)| c.map(|v| v * s))
    }

    fn dir_strategy() -> impl Strategy<Value = Vec3> {
        (
            proptest::array::uniform3(-1.0f32..1.0),
            prop_oneof![Just(1.0f32), 0.05f32..20.0, Just(512.0f32)],
        )
            .prop_map(|(v, len)| unit(v) * len)
    }

    pub(crate) fn point_strategy() -> impl Strategy<Value = Vec3> {
        proptest::array::uniform3(0.0f32..=1.0).prop_map(Vec3::from)
    }

    /// `cases` per suite, or `PROPTEST_CASES` from the environment for a longer run.
    pub(crate) fn config(cases: u32) -> ProptestConfig {
        let cases = std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(cases);
        ProptestConfig {
            cases,
            failure_persistence: None,
            ..ProptestConfig::default()
        }
    }

    proptest! {
        #![proptest_config(config(3000))]

        /// `keeps_sign` only skips segments on which every value the root search evaluates
        /// (the cubic at its critical points and at the end, and anywhere between) has the
        /// start's sign: there, the search finds no crossing. Cubics whose start value is
        /// near the bound are the ones that could break it.
        #[test]
        fn keeps_sign_only_when_no_value_changes_sign(
            a in -8.0f32..8.0,
            b in -8.0f32..8.0,
            c in -8.0f32..8.0,
            near in 0.999f32..1.01,
            negative in any::<bool>(),
            len in 0.01f32..1.0,
        ) {
            let reach = ((a.abs() * len + b.abs()) * len + c.abs()) * len;
            let d = if negative { -near * reach } else { near * reach };
            let cubic = RayCubic { a, b, c, d };
            if keeps_sign(&cubic, len) {
                let (crit, n) = cubic.critical_points(len);
                let samples = (0..=1000).map(|i| len * i as f32 / 1000.0);
                for s in samples.chain(crit.into_iter().take(n)).chain([len]) {
                    let g = cubic.eval(s);
                    prop_assert!(g * d > 0.0, "{cubic:?} at {s}: {g}");
                }
                // No crossing: a surface finds nothing, nor does a volume past its start.
                prop_assert_eq!(roots_where(&cubic, len, true, |_, _| true), None);
                prop_assert_eq!(roots_where(&cubic, len, false, |_, root| root), None);
            }
        }

        /// Random voxels, random rays through the cube, random scales and ray speeds.
        #[test]
        fn random_voxels_and_rays(
            corners in corners_strategy(),
            target in point_strategy(),
            dir in dir_strategy(),
            back in 0.0f32..3.0,
            surface in any::<bool>(),
        ) {
            if let Some(case) = case_through(corners, target, dir, back / dir.length(), surface) {
                check(&case)?;
            }
        }

        /// Tangent (double) roots: the corners are shifted so that the cubic's value at one of
        /// its critical points inside the segment is zero, then nudged by ±0, 1e-7, 1e-5, 1e-3
        /// of the scale (just missing, exactly touching, barely dipping).
        #[test]
        fn tangent_and_double_roots(
            corners in corners_strategy(),
            target in point_strategy(),
            dir in dir_strategy(),
            back in 0.0f32..3.0,
            nudge in prop_oneof![Just(0.0f64), Just(1e-7), Just(-1e-7), Just(1e-5), Just(-1e-5),
                                  Just(1e-3), Just(-1e-3)],
            surface in any::<bool>(),
        ) {
            let Some(case) = case_through(corners, target, dir, back / dir.length(), surface)
            else { return Ok(()) };
            // f64 critical points of the cubic along the segment.
            let f = |t: f64| f64_at(&corners, case.origin, case.dir, t);
            let (t0, t1) = (case.t0 as f64, case.t1 as f64);
            let n = 400;
            let mut crit = None;
            let df = |t: f64| { let h = (t1 - t0) * 1e-7; f(t + h) - f(t - h) };
            for i in 1..n {
                let a = t0 + (t1 - t0) * (i - 1) as f64 / n as f64;
                let b = t0 + (t1 - t0) * i as f64 / n as f64;
                if (df(a) > 0.0) != (df(b) > 0.0) {
                    let (mut lo, mut hi) = (a, b);
                    let slo = df(lo) > 0.0;
                    for _ in 0..60 {
                        let m = 0.5 * (lo + hi);
                        if (df(m) > 0.0) == slo { lo = m } else { hi = m }
                    }
                    crit = Some(0.5 * (lo + hi));
                    break;
                }
            }
            let Some(tc) = crit else { return Ok(()) };
            let scale = corners.iter().fold(0.0f64, |m, v| m.max(v.abs() as f64));
            let shift = f(tc) - nudge * scale;
            let shifted = corners.map(|v| (v as f64 - shift) as f32);
            check(&Case { corners: shifted, ..case })?;
        }

        /// Rays with one or two zero direction components (a vanishing cubic term).
        #[test]
        fn axis_parallel_rays(
            corners in corners_strategy(),
            target in point_strategy(),
            dir in dir_strategy(),
            zero_mask in 1u8..7,
            back in 0.0f32..3.0,
            surface in any::<bool>(),
        ) {
            let mut d = dir;
            for k in 0..3 { if zero_mask & (1 << k) != 0 { d[k] = 0.0; } }
            if d == Vec3::ZERO { d[(zero_mask.trailing_ones() % 3) as usize] = dir.length(); }
            if let Some(case) = case_through(corners, target, d, back / d.length(), surface) {
                check(&case)?;
            }
        }

        /// Rays starting inside the cube (t0 = 0) or exactly on one of its faces.
        #[test]
        fn rays_starting_inside_or_on_a_face(
            corners in corners_strategy(),
            start in point_strategy(),
            dir in dir_strategy(),
            face in 0usize..7,
            surface in any::<bool>(),
        ) {
            let mut origin = start;
            if face < 6 { origin[face / 2] = (face % 2) as f32; }
            if let Some((_, b)) = unit_cube_span(origin, dir) {
                if b >= 0.0 {
                    check(&Case { corners, origin, dir, t0: 0.0, t1: b, surface })?;
                }
            }
        }

        /// Values all near zero (a few ulps of 1e-7 or 1e-30, some exactly zero) and the
        /// all-zero voxel, which has no crossing.
        #[test]
        fn values_all_near_zero(
            raw in proptest::array::uniform8(-4i32..=4),
            tiny in prop_oneof![Just(1e-7f32), Just(1e-30f32), Just(0.0f32)],
            target in point_strategy(),
            dir in dir_strategy(),
            back in 0.0f32..3.0,
            surface in any::<bool>(),
        ) {
            let corners = raw.map(|v| v as f32 * tiny);
            if let Some(case) = case_through(corners, target, dir, back / dir.length(), surface) {
                let got = check(&case)?;
                if tiny == 0.0 || raw == [0; 8] {
                    prop_assert_eq!(got, None);
                }
            }
        }

        /// Degenerate cubics: corners sampled from a plane (linear along any ray) or from a
        /// bilinear function (no xyz term: quadratic), at random scales.
        #[test]
        fn degenerate_cubics(
            n in proptest::array::uniform3(-1.0f32..1.0),
            offset in -1.0f32..1.0,
            bilinear in -1.0f32..1.0,
            use_bilinear in any::<bool>(),
            scale in scale_strategy(),
            target in point_strategy(),
            dir in dir_strategy(),
            back in 0.0f32..3.0,
            surface in any::<bool>(),
        ) {
            let corners: [f32; 8] = core::array::from_fn(|i| {
                let (x, y, z) = ((i >> 2) as f32, ((i >> 1) & 1) as f32, (i & 1) as f32);
                let k = if use_bilinear { bilinear * x * y } else { 0.0 };
                (n[0] * x + n[1] * y + n[2] * z + offset + k) * scale
            });
            if let Some(case) = case_through(corners, target, dir, back / dir.length(), surface) {
                check(&case)?;
            }
        }
    }

    #[test]
    fn tiny_corner_values_do_not_underflow_the_derivative() {
        // Found by `values_all_near_zero`: with corners of order 1e-30 the derivative's
        // discriminant (≈ b²) underflowed to 0, the critical points came out wrong and the root
        // at t ≈ 0.3798 was missed. Fixed by normalising values and parameter before solving.
        let raw = [0.0f32, 3.0, 0.0, 0.0, -3.0, 1.0, 0.0, 2.0];
        let corners = raw.map(|v| v * 1e-30);
        let target = Vec3::new(0.6637985, 0.39154395, 0.34931996);
        let dir = Vec3::new(0.5053114, 0.8124989, -0.29069895);
        let case = case_through(corners, target, dir, 0.6379345, false).unwrap();
        let got = check(&case).unwrap();
        assert!(got.is_some_and(|t| (t - 0.37976).abs() < 1e-3), "{got:?}");
    }

    #[test]
    fn all_zero_surface_voxel_has_no_hit() {
        // Found by `values_all_near_zero`: a surface voxel with all corners 0 reported a hit at
        // t0 (f(t0) = 0 counted as a crossing); an interpolant that is zero everywhere has none.
        let case = case_through([0.0; 8], Vec3::ZERO, Vec3::X, 0.0, true).unwrap();
        assert_eq!(check(&case).unwrap(), None);
    }

    #[test]
    fn plane_hit_is_exact() {
        // f = 0.25 − x (inside x > 0.25) along +x from x = −1: root at t = 1.25.
        let c: [f32; 8] = core::array::from_fn(|i| 0.25 - (i >> 2) as f32);
        let o = Vec3::new(-1.0, 0.5, 0.5);
        let (a, b) = unit_cube_span(o, Vec3::X).unwrap();
        assert_eq!((a, b), (1.0, 2.0));
        let t = intersect_voxel(&c, o, Vec3::X, a, b, false).unwrap();
        assert!((t - 1.25).abs() < 1e-6, "{t}");
        // Starting inside (x = 0.5), going either way: hit at t0.
        let inside = Vec3::new(0.5, 0.5, 0.5);
        assert_eq!(
            intersect_voxel(&c, inside, Vec3::X, 0.0, 0.5, false),
            Some(0.0)
        );
        assert_eq!(
            intersect_voxel(&c, inside, -Vec3::X, 0.0, 0.5, false),
            Some(0.0)
        );
        // A surface voxel from the negative side: the crossing at x = 0.25.
        let t = intersect_voxel(&c, inside, -Vec3::X, 0.0, 0.5, true).unwrap();
        assert!((t - 0.25).abs() < 1e-6, "{t}");
    }

    #[test]
    fn volume_tangent_touch_from_outside_is_not_a_hit() {
        // f = (x − 0.5)² is not trilinear; use f = x·(1 − x)-like saddle instead: corners of
        // f(x, y) = (2x − 1)(2y − 1) + 1 ≥ 0 touch zero only at corners (0,1) and (1,0).
        let c: [f32; 8] = core::array::from_fn(|i| {
            let (x, y) = ((i >> 2) as f32, ((i >> 1) & 1) as f32);
            (2.0 * x - 1.0) * (2.0 * y - 1.0) + 1.0
        });
        // Along the diagonal y = 1 − x the value is 1 − (2x − 1)² ≥ 0, zero at both ends only.
        let o = Vec3::new(0.0, 1.0, 0.5);
        let d = Vec3::new(1.0, -1.0, 0.0);
        assert_eq!(intersect_voxel(&c, o, d, 0.0, 1.0, false), None);
        // A surface voxel touches zero at the start.
        assert_eq!(intersect_voxel(&c, o, d, 0.0, 1.0, true), Some(0.0));
    }

    #[test]
    fn volume_ray_in_the_zero_set_is_a_hit() {
        // Zero on the face y = 0, −1 on y = 1: the distance field beside an internal face of
        // touching shells (zero on the face, inside on both sides).
        let c: [f32; 8] = core::array::from_fn(|i| if (i >> 1) & 1 == 1 { -1.0 } else { 0.0 });
        let o = Vec3::new(0.0, 0.0, 0.3);
        assert_eq!(intersect_voxel(&c, o, Vec3::X, 0.0, 1.0, false), Some(0.0));
        // Slightly above the face the ray is inside at once.
        let above = Vec3::new(0.0, 1e-3, 0.3);
        assert_eq!(
            intersect_voxel(&c, above, Vec3::X, 0.0, 1.0, false),
            Some(0.0)
        );
        // Outside a zero face (values rising away from it), just off the plane: no hit.
        let positive = c.map(|v| -v);
        assert_eq!(
            intersect_voxel(&positive, above, Vec3::X, 0.0, 1.0, false),
            None
        );
    }

    #[test]
    fn never_nan_on_nan_or_empty_input() {
        let c = [1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0];
        let o = Vec3::new(0.5, 0.5, -1.0);
        assert_eq!(intersect_voxel(&c, o, Vec3::Z, f32::NAN, 2.0, false), None);
        assert_eq!(intersect_voxel(&c, o, Vec3::Z, 2.0, 1.0, false), None);
        assert_eq!(
            intersect_voxel(&c, Vec3::NAN, Vec3::Z, 1.0, 2.0, true),
            None
        );
        assert_eq!(intersect_voxel(&c, o, Vec3::NAN, 1.0, 2.0, true), None);
        let nan_corners = [f32::NAN; 8];
        assert_eq!(
            intersect_voxel(&nan_corners, o, Vec3::Z, 1.0, 2.0, true),
            None
        );
    }

    #[test]
    fn scale_invariant_roots() {
        let base = [0.3f32, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2, -0.7];
        let o = Vec3::new(-0.5, 0.2, 0.3);
        let d = Vec3::new(1.0, 0.3, 0.2).normalize();
        let (a, b) = unit_cube_span(o, d).unwrap();
        let reference = intersect_voxel(&base, o, d, a, b, false).unwrap();
        for s in [1e-30f32, 1e-6, 1e-3, 1e3, 1e6, 1e12] {
            let c = base.map(|v| v * s);
            let t = intersect_voxel(&c, o, d, a, b, false).unwrap();
            assert!(
                (t - reference).abs() < 1e-5,
                "scale {s}: {t} vs {reference}"
            );
        }
    }

    #[test]
    fn unit_cube_span_handles_zero_components() {
        assert_eq!(
            unit_cube_span(Vec3::new(0.5, 0.5, -1.0), Vec3::Z),
            Some((1.0, 2.0))
        );
        assert_eq!(unit_cube_span(Vec3::new(1.5, 0.5, -1.0), Vec3::Z), None);
        // On a face, parallel to it: inside (closed cube).
        assert_eq!(
            unit_cube_span(Vec3::new(1.0, 0.5, -1.0), Vec3::Z),
            Some((1.0, 2.0))
        );
        assert_eq!(
            unit_cube_span(Vec3::new(2.0, 0.5, 0.5), -Vec3::X),
            Some((1.0, 2.0))
        );
    }
}
