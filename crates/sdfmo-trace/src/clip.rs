//! The clip rule: ray hits in leaves with clip voxels (format 1.1), and the leaf's clip voxels
//! that the distance query (`distance.rs`) applies the same rule with.
//!
//! A voxel with the clip bit clips the other voxels of its leaf (`FORMAT.md` in sdfmo-format,
//! section `clip`, is the specification):
//!
//! * **intersect voxel** (volume + clip): hit like a volume voxel, and clips the others;
//! * **clip-only voxel** (surface + clip): never hit itself, only clips the others.
//!
//! A *candidate* hit of a voxel `i` that is hit itself is any of its crossings of the right
//! kind inside the leaf's span — every one, not only the first (volume: from `f ≥ 0` to
//! `f < 0`, and the span start when `f < 0` there; surface: a sign change either way, and the
//! span start when `f = 0` there). It is **accepted** when every *other* clip voxel `j` of the
//! leaf has `f_j ≤ 0` at the candidate's point (up to [`CLIP_TOLERANCE`]); the leaf's hit is
//! the nearest accepted candidate over its voxels, and the voxel of that candidate is the
//! *active* one whose gradient is the normal. So intersect voxels `A`, `B` make the solid
//! `max(f_A, f_B) ≤ 0` (a sharp convex edge, exact for two plane voxels) and a surface voxel
//! `S` with a clip-only voxel `K` the sheet `f_S = 0` restricted to `f_K ≤ 0` (an open rim).
//!
//! The traversal branches here (one test per leaf, [`Octree::any_clip_voxel`]) only for a leaf
//! that has a clip voxel; every other leaf keeps the plain nearest-hit kernel, so octrees
//! without clip voxels trace exactly as before.
//!
//! # Kernel
//!
//! [`intersect_voxel_where`] (in `ray_voxel.rs`) walks one voxel's candidates front to back:
//! the segment's cubic is split at its critical points
//! ([`RayCubic::critical_points`](crate::ray_voxel::RayCubic::critical_points)) into at most
//! three monotone pieces, each of which holds at most one root, polished with the plain
//! kernel's safeguarded Newton iteration; the first candidate the caller's predicate accepts is
//! the voxel's hit. With a predicate that accepts everything it is
//! [`intersect_voxel`](crate::intersect_voxel).

use glam::Vec3;
use sdfmo_format::{trilinear, TracedOctree};

use sdfmo_format::MAX_CLIP_VOXELS_PER_LEAF;

use crate::ray_voxel::{intersect_voxel_where, min_max};

// Slack of the clip test at a crossing, relative to the clip voxel's largest |corner| (the
// format's value, shared with the WGSL kernel; its documentation says why it is needed and why
// the span start has none).
use sdfmo_format::kernel::CLIP_TOLERANCE;

/// Whether the point `p` (local frame of the leaf) is on the kept side of the clip voxel
/// `corners`: `f ≤ CLIP_TOLERANCE · max|corner|` at a polished root (`slack`), `f ≤ 0` at the
/// span start.
#[inline]
pub fn inside_clip(corners: &[f32; 8], p: Vec3, slack: bool) -> bool {
    let f = trilinear(corners, p);
    if slack {
        let (lo, hi) = min_max(corners);
        f <= CLIP_TOLERANCE * hi.max(-lo)
    } else {
        f <= 0.0
    }
}

/// The clip voxels of one leaf (index and corners), gathered once per leaf so the clip test of
/// a candidate reads only them: at most [`MAX_CLIP_VOXELS_PER_LEAF`] (validation refuses a file
/// with more), which makes the clip rule's work linear in the leaf's voxels.
pub(crate) struct LeafClips<V> {
    voxels: [(V, [f32; 8]); MAX_CLIP_VOXELS_PER_LEAF],
    count: usize,
}

impl<V: Copy + PartialEq> LeafClips<V> {
    /// The clip voxels of `voxels` in order (a leaf's voxels in a validated octree); `None`
    /// for a leaf without voxels.
    #[inline]
    pub(crate) fn gather<O: TracedOctree<Voxel = V>>(
        octree: &O,
        voxels: O::Voxels,
    ) -> Option<LeafClips<V>> {
        // Unused slots hold the leaf's first voxel (never read: `count` bounds the slice).
        let filler = voxels.clone().next()?;
        let mut clips = LeafClips {
            voxels: [(filler, [0.0; 8]); MAX_CLIP_VOXELS_PER_LEAF],
            count: 0,
        };
        for j in voxels {
            if octree.voxel_is_clip(j) {
                // Validation bounds the count; were it exceeded, the extra voxels would be
                // ignored rather than indexed out of bounds.
                debug_assert!(clips.count < MAX_CLIP_VOXELS_PER_LEAF, "validated bound");
                if let Some(slot) = clips.voxels.get_mut(clips.count) {
                    *slot = (j, octree.voxel_corners(j));
                    clips.count += 1;
                }
            }
        }
        Some(clips)
    }

    /// The gathered `(voxel, corners)` pairs.
    #[inline]
    pub(crate) fn as_slice(&self) -> &[(V, [f32; 8])] {
        &self.voxels[..self.count]
    }

    /// Whether every clip voxel other than `voxel` keeps the local point `p` ([`inside_clip`]).
    #[inline]
    fn keep(&self, voxel: V, p: Vec3, slack: bool) -> bool {
        self.as_slice()
            .iter()
            .all(|(j, c)| *j == voxel || inside_clip(c, p, slack))
    }
}

/// The leaf rule on a leaf with clip voxels: the nearest accepted candidate over the voxels of
/// `voxels` on the segment `local_o + s·local_d`, `s ∈ [0, len]` (the leaf's local frame), as
/// `(s, voxel, surface)`; any accepted candidate when `ANY`. At most 4 candidates per voxel,
/// each tested against at most [`MAX_CLIP_VOXELS_PER_LEAF`] clip voxels.
pub(crate) fn leaf_hit<O: TracedOctree, const ANY: bool>(
    octree: &O,
    voxels: O::Voxels,
    local_o: Vec3,
    local_d: Vec3,
    len: f32,
) -> Option<(f32, O::Voxel, bool)> {
    let clips = LeafClips::gather(octree, voxels.clone())?;
    let mut best_s = len;
    let mut best: Option<(O::Voxel, bool)> = None;
    for voxel in voxels {
        let surface = octree.voxel_is_surface(voxel);
        let clip = octree.voxel_is_clip(voxel);
        if surface && clip {
            continue; // clip-only: never hit itself
        }
        let corners = octree.voxel_corners(voxel);
        let others_keep = |s: f32, root: bool| clips.keep(voxel, local_o + local_d * s, root);
        let found = intersect_voxel_where(
            &corners,
            local_o,
            local_d,
            (0.0, best_s),
            surface,
            others_keep,
        );
        if let Some(s) = found {
            if best.is_none() || s < best_s {
                best_s = s;
                best = Some((voxel, surface));
                if ANY {
                    break;
                }
            }
        }
    }
    best.map(|(voxel, surface)| (best_s, voxel, surface))
}

#[cfg(test)]
mod tests {
    //! The clip kernel against an f64 oracle of the combined rule: dense sampling along the
    //! segment and bisection, on random pairs and triples of voxels of every kind, on the max of
    //! two planes, on clipped surfaces and on clip boundaries through the hit (tangent cases).

    use super::*;
    use crate::ray_voxel::tests::{bisect, config, f64_at, point_strategy, span_through, unit};
    use crate::ray_voxel::{intersect_voxel, unit_cube_span};
    use proptest::prelude::*;
    use proptest::test_runner::TestCaseError;

    /// Samples of the oracle along the segment.
    const SAMPLES: usize = 3000;
    /// Residual allowed at a reported hit (relative to the voxel's largest |corner|), and the
    /// margin beyond which an oracle value counts as clearly on one side.
    const EPS: f64 = 3e-5;
    /// Positions: a hit may come this much (voxel units) before an oracle candidate.
    const POS_TOL: f64 = 1e-4;
    /// Slope (per voxel unit, relative to the largest |corner|) from which a crossing is clear.
    const CLEAR_SLOPE: f64 = 0.05;

    /// Voxel kinds: (surface, clip).
    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Kind {
        Volume,
        Surface,
        Intersect,
        ClipOnly,
    }

    impl Kind {
        fn surface(self) -> bool {
            matches!(self, Kind::Surface | Kind::ClipOnly)
        }
        fn clip(self) -> bool {
            matches!(self, Kind::Intersect | Kind::ClipOnly)
        }
    }

    #[derive(Clone, Debug)]
    struct Case {
        voxels: Vec<([f32; 8], Kind)>,
        origin: Vec3,
        dir: Vec3,
        t1: f32,
    }

    fn scale_of(c: &[f32; 8]) -> f64 {
        c.iter().fold(0.0f64, |m, v| m.max(v.abs() as f64))
    }

    /// The kernel's leaf rule on the case (the same code path as the traversal, over a slice).
    fn kernel(case: &Case) -> Option<(f32, usize)> {
        let mut best_s = case.t1;
        let mut best = None;
        for (i, (corners, kind)) in case.voxels.iter().enumerate() {
            if *kind == Kind::ClipOnly {
                continue;
            }
            let keep = |s: f32, root: bool| {
                let p = case.origin + case.dir * s;
                case.voxels
                    .iter()
                    .enumerate()
                    .all(|(j, (c, k))| j == i || !k.clip() || inside_clip(c, p, root))
            };
            let s = intersect_voxel_where(
                corners,
                case.origin,
                case.dir,
                (0.0, best_s),
                kind.surface(),
                keep,
            );
            if let Some(s) = s {
                if best.is_none() || s < best_s {
                    best_s = s;
                    best = Some(i);
                }
            }
        }
        best.map(|i| (best_s, i))
    }

    /// One oracle candidate: ray parameter, voxel, whether it is clear (a clear crossing or a
    /// clearly-inside start) and the largest relative clip value of the other clip voxels there.
    struct Candidate {
        t: f64,
        voxel: usize,
        clear: bool,
        clip_margin: f64,
    }

    /// Every candidate of every hittable voxel in f64: sign changes of the dense samples,
    /// bisected, plus the segment start.
    fn oracle(case: &Case) -> Vec<Candidate> {
        let (o, d) = (case.origin, case.dir);
        let t1 = case.t1 as f64;
        let dlen = d.length() as f64;
        let ts: Vec<f64> = (0..=SAMPLES)
            .map(|i| t1 * i as f64 / SAMPLES as f64)
            .collect();
        let margin = |i: usize, t: f64| {
            case.voxels
                .iter()
                .enumerate()
                .filter(|(j, (_, k))| *j != i && k.clip())
                .map(|(_, (c, _))| f64_at(c, o, d, t) / scale_of(c).max(1e-300))
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let mut out = Vec::new();
        for (i, (c, kind)) in case.voxels.iter().enumerate() {
            if *kind == Kind::ClipOnly {
                continue;
            }
            let scale = scale_of(c);
            if scale == 0.0 {
                continue;
            }
            let surface = kind.surface();
            let f = |t: f64| f64_at(c, o, d, t);
            let fs: Vec<f64> = ts.iter().map(|&t| f(t)).collect();
            let changed = |a: f64, b: f64| {
                if surface {
                    (a > 0.0 && b <= 0.0) || (a < 0.0 && b >= 0.0)
                } else {
                    a >= 0.0 && b < 0.0
                }
            };
            let starts = if surface { fs[0] == 0.0 } else { fs[0] < 0.0 };
            if starts {
                out.push(Candidate {
                    t: 0.0,
                    voxel: i,
                    clear: !surface && fs[0] < -EPS * scale,
                    clip_margin: margin(i, 0.0),
                });
            }
            for k in 1..fs.len() {
                if changed(fs[k - 1], fs[k]) {
                    let b = bisect(f, changed, (ts[k - 1], fs[k - 1]), ts[k]);
                    let h = 1e-6 / dlen;
                    let slope = ((f(b + h) - f(b - h)) / (2.0 * h)).abs() / dlen;
                    // Clear: steep, and not at the very start (where the start rule decides).
                    let clear = slope >= CLEAR_SLOPE * scale && b > 2.0 * POS_TOL / dlen;
                    out.push(Candidate {
                        t: b,
                        voxel: i,
                        clear,
                        clip_margin: margin(i, b),
                    });
                }
            }
        }
        out
    }

    /// The kernel's answer is consistent with the oracle: a reported hit is a true candidate of
    /// its voxel (residual) inside every other clip voxel (up to EPS), and no clear candidate
    /// that is clearly accepted comes before it (or exists at all, for a miss).
    fn check(case: &Case) -> Result<Option<(f32, usize)>, TestCaseError> {
        let got = kernel(case);
        let (o, d) = (case.origin, case.dir);
        let dlen = d.length() as f64;
        if let Some((s, i)) = got {
            prop_assert!(s.is_finite() && s >= 0.0 && s <= case.t1, "hit {s} outside");
            let (c, kind) = case.voxels[i];
            prop_assert!(kind != Kind::ClipOnly, "a clip-only voxel was hit");
            let fk = f64_at(&c, o, d, s as f64);
            let scale = scale_of(&c);
            let on = if kind.surface() {
                fk.abs() <= EPS * scale
            } else {
                fk <= EPS * scale
            };
            prop_assert!(on, "false hit at {s}: f = {fk} (scale {scale})");
            for (j, (cj, kj)) in case.voxels.iter().enumerate() {
                if j != i && kj.clip() {
                    let v = f64_at(cj, o, d, s as f64);
                    prop_assert!(
                        v <= EPS * scale_of(cj),
                        "hit {s} of voxel {i} outside clip voxel {j}: {v}"
                    );
                }
            }
        }
        let limit = got.map_or(f64::INFINITY, |(s, _)| s as f64 - POS_TOL / dlen);
        for cand in oracle(case) {
            if cand.clear && cand.clip_margin < -EPS && cand.t < limit {
                return Err(TestCaseError::fail(format!(
                    "skipped candidate t = {} of voxel {} (clip margin {}), kernel {got:?}",
                    cand.t, cand.voxel, cand.clip_margin
                )));
            }
        }
        Ok(got)
    }

    /// The case of the ray `(target, dir, back)` of [`ray_strategy`] ([`span_through`], `back`
    /// in units of `|dir|`), re-based at the entry point (as the traversal does: s = t − t_enter).
    fn case_through(
        voxels: Vec<([f32; 8], Kind)>,
        (target, dir, back): (Vec3, Vec3, f32),
    ) -> Option<Case> {
        let (origin, t0, t1) = span_through(target, dir, back / dir.length())?;
        Some(Case {
            voxels,
            origin: origin + dir * t0,
            dir,
            t1: t1 - t0,
        })
    }

    fn kind_strategy() -> impl Strategy<Value = Kind> {
        prop_oneof![
            Just(Kind::Volume),
            Just(Kind::Surface),
            Just(Kind::Intersect),
            Just(Kind::ClipOnly)
        ]
    }

    /// Corners of the plane `n·p = offset` (distance, for a unit `n`).
    fn plane(n: Vec3, offset: f32) -> [f32; 8] {
        core::array::from_fn(|i| {
            let p = Vec3::new((i >> 2) as f32, ((i >> 1) & 1) as f32, (i & 1) as f32);
            n.dot(p) - offset
        })
    }

    /// Pairs and triples of random voxels with random kinds, at least one clip voxel and one
    /// that is hit itself.
    fn voxels_strategy() -> impl Strategy<Value = Vec<([f32; 8], Kind)>> {
        prop::collection::vec(
            (proptest::array::uniform8(-1.0f32..1.0), kind_strategy()),
            2..=3,
        )
        .prop_map(|mut v| {
            if !v.iter().any(|(_, k)| k.clip()) {
                v[0].1 = Kind::Intersect;
            }
            if v.iter().all(|(_, k)| *k == Kind::ClipOnly) {
                v[0].1 = Kind::Volume;
            }
            v
        })
    }

    fn dir_strategy() -> impl Strategy<Value = Vec3> {
        (
            proptest::array::uniform3(-1.0f32..1.0),
            prop_oneof![Just(1.0f32), 0.05f32..20.0],
        )
            .prop_map(|(v, len)| unit(v) * len)
    }

    /// The corners of a random plane `n·p = offset` (unit `n`) near the cube.
    fn plane_strategy() -> impl Strategy<Value = [f32; 8]> {
        (proptest::array::uniform3(-1.0f32..1.0), -0.5f32..1.5)
            .prop_map(|(n, offset)| plane(unit(n), offset))
    }

    /// A ray through a point of the cube: (target, direction, distance back from the target in
    /// units of the direction's length).
    fn ray_strategy() -> impl Strategy<Value = (Vec3, Vec3, f32)> {
        (point_strategy(), dir_strategy(), 0.0f32..3.0)
    }

    /// An optional further voxel of any kind.
    fn extra_voxel_strategy() -> impl Strategy<Value = Option<([f32; 8], Kind)>> {
        proptest::option::of((proptest::array::uniform8(-1.0f32..1.0), kind_strategy()))
    }

    proptest! {
        #![proptest_config(config(1500))]

        /// Random pairs and triples of voxels of every kind, random rays.
        #[test]
        fn random_voxel_sets(
            voxels in voxels_strategy(),
            ray in ray_strategy(),
        ) {
            if let Some(case) = case_through(voxels, ray) {
                check(&case)?;
            }
        }

        /// The max of two planes (two intersect voxels: a convex edge), optionally with a third
        /// voxel of any kind; the hit must be on the solid max(a, b) ≤ 0 with the active plane.
        #[test]
        fn max_of_two_planes(
            a in plane_strategy(),
            b in plane_strategy(),
            third in extra_voxel_strategy(),
            ray in ray_strategy(),
        ) {
            let mut voxels = vec![(a, Kind::Intersect), (b, Kind::Intersect)];
            voxels.extend(third);
            let Some(case) = case_through(voxels, ray) else {
                return Ok(());
            };
            let got = check(&case)?;
            if case.voxels.len() == 2 {
                // Exact against the analytic solid: the ray's entry into max(a, b) ≤ 0.
                let (o, d) = (case.origin, case.dir);
                let g = |t: f64| f64_at(&a, o, d, t).max(f64_at(&b, o, d, t));
                let clear_inside = (0..=400).any(|k| g(case.t1 as f64 * k as f64 / 400.0) < -1e-3);
                if clear_inside {
                    prop_assert!(got.is_some(), "missed the solid max(a, b)");
                }
            }
        }

        /// A surface voxel clipped by a clip-only plane (an open rim), optionally with a second
        /// voxel; the hit is on the sheet where the clip plane keeps it.
        #[test]
        fn clipped_surfaces(
            sheet in proptest::array::uniform8(-1.0f32..1.0),
            clip in plane_strategy(),
            intersect_clip in any::<bool>(),
            other in extra_voxel_strategy(),
            ray in ray_strategy(),
        ) {
            let kind = if intersect_clip { Kind::Intersect } else { Kind::ClipOnly };
            let mut voxels = vec![(sheet, Kind::Surface), (clip, kind)];
            voxels.extend(other);
            if let Some(case) = case_through(voxels, ray) {
                check(&case)?;
            }
        }

        /// Tangent cases: the clip plane passes through the sheet's (or volume's) first root
        /// along the ray, nudged by 0, ±1e-7, ±1e-5, ±1e-3, so the candidate sits on the clip
        /// boundary; and through a critical point of the clip voxel's own cubic.
        #[test]
        fn clip_boundary_through_the_hit(
            corners in proptest::array::uniform8(-1.0f32..1.0),
            n in proptest::array::uniform3(-1.0f32..1.0),
            surface in any::<bool>(),
            clip_kind in prop_oneof![Just(Kind::Intersect), Just(Kind::ClipOnly)],
            nudge in prop_oneof![Just(0.0f32), Just(1e-7), Just(-1e-7), Just(1e-5), Just(-1e-5),
                                 Just(1e-3), Just(-1e-3)],
            ray in ray_strategy(),
        ) {
            let Some(case) = case_through(vec![], ray) else {
                return Ok(());
            };
            let Some(s) = intersect_voxel(&corners, case.origin, case.dir, 0.0, case.t1, surface)
            else {
                return Ok(());
            };
            let p = case.origin + case.dir * s;
            let nn = unit(n);
            let clip = plane(nn, nn.dot(p) + nudge);
            let kind = if surface { Kind::Surface } else { Kind::Volume };
            check(&Case { voxels: vec![(corners, kind), (clip, clip_kind)], ..case })?;
        }
    }

    #[test]
    fn accepting_everything_is_the_plain_kernel() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..20000 {
            let corners: [f32; 8] = core::array::from_fn(|_| rng.random_range(-1.0..1.0));
            let target = Vec3::new(rng.random(), rng.random(), rng.random());
            let dir = unit([
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ]);
            let origin = target - dir * rng.random_range(0.0..2.0);
            let Some((a, b)) = unit_cube_span(origin, dir) else {
                continue;
            };
            let t0 = a.max(0.0);
            for surface in [false, true] {
                assert_eq!(
                    intersect_voxel_where(&corners, origin, dir, (t0, b), surface, |_, _| true),
                    intersect_voxel(&corners, origin, dir, t0, b, surface)
                );
            }
        }
    }

    #[test]
    fn a_convex_edge_of_two_plane_voxels_is_sharp() {
        // a: x ≤ 0.5, b: y ≤ 0.5 (inside negative): the solid is the quarter x, y ≤ 0.5.
        let a = plane(Vec3::X, 0.5);
        let b = plane(Vec3::Y, 0.5);
        let voxels = vec![(a, Kind::Intersect), (b, Kind::Intersect)];
        // Down −y at x = 0.3: enters through the top face y = 0.5 (voxel b).
        let case = Case {
            voxels: voxels.clone(),
            origin: Vec3::new(0.3, 1.0, 0.5),
            dir: -Vec3::Y,
            t1: 1.0,
        };
        let (s, i) = check(&case).unwrap().unwrap();
        assert!((s - 0.5).abs() < 1e-6 && i == 1, "{s} {i}");
        // At x = 0.7 the top face is outside a: no hit at all (a plain union would hit b).
        let miss = Case {
            origin: Vec3::new(0.7, 1.0, 0.5),
            ..case.clone()
        };
        assert_eq!(check(&miss).unwrap(), None);
        // Diagonally at the edge from outside both: the entry is where the later plane is met.
        let diag = Case {
            voxels,
            origin: Vec3::new(1.0, 0.9, 0.5),
            dir: Vec3::new(-1.0, -1.0, 0.0).normalize(),
            t1: 0.9 * 2f32.sqrt(),
        };
        let (s, i) = check(&diag).unwrap().unwrap();
        let p = diag.origin + diag.dir * s;
        assert!((p.x - 0.5).abs() < 1e-5 && p.y <= 0.5 && i == 0, "{p} {i}");
    }

    #[test]
    fn a_clip_only_voxel_cuts_a_sheet_and_is_never_hit() {
        // The sheet z = 0.5 (surface), kept where x ≤ 0.4 (clip-only).
        let sheet = plane(Vec3::Z, 0.5);
        let rim = plane(Vec3::X, 0.4);
        let case = |x: f32| Case {
            voxels: vec![(sheet, Kind::Surface), (rim, Kind::ClipOnly)],
            origin: Vec3::new(x, 0.5, 1.0),
            dir: -Vec3::Z,
            t1: 1.0,
        };
        let (s, i) = check(&case(0.3)).unwrap().unwrap();
        assert!((s - 0.5).abs() < 1e-6 && i == 0);
        assert_eq!(check(&case(0.45)).unwrap(), None);
        // Along the sheet's normal through the rim plane: the rim itself is never a hit.
        let along = Case {
            voxels: vec![(sheet, Kind::Surface), (rim, Kind::ClipOnly)],
            origin: Vec3::new(0.0, 0.5, 0.7),
            dir: Vec3::X,
            t1: 1.0,
        };
        assert_eq!(check(&along).unwrap(), None);
    }

    #[test]
    fn a_rejected_first_crossing_is_followed_by_a_later_one() {
        // The saddle sheet f = (2x − 1)(2y − 1) − 0.25 has two zeros along x = y = t, at
        // (2t − 1)² = 0.25: t = 0.25 and t = 0.75.
        let c: [f32; 8] = core::array::from_fn(|i| {
            let (x, y) = ((i >> 2) as f32, ((i >> 1) & 1) as f32);
            (2.0 * x - 1.0) * (2.0 * y - 1.0) - 0.25
        });
        let dir = Vec3::new(1.0, 1.0, 0.0);
        let origin = Vec3::new(0.0, 0.0, 0.5);
        // Clip away x < 0.5: the first zero (t = 0.25) is rejected, the second (0.75) kept.
        let clip = plane(-Vec3::X, -0.5);
        for kind in [Kind::ClipOnly, Kind::Intersect] {
            let case = Case {
                voxels: vec![(c, Kind::Surface), (clip, kind)],
                origin,
                dir,
                t1: 1.0,
            };
            let (s, i) = check(&case).unwrap().unwrap();
            if kind == Kind::ClipOnly {
                assert!((s - 0.75).abs() < 1e-5 && i == 0, "{s}");
            } else {
                // The intersect plane x ≥ 0.5 is itself entered at t = 0.5 inside the sheet's
                // cell: a volume hit there (nearer than 0.75).
                assert!((s - 0.5).abs() < 1e-5 && i == 1, "{s} {i}");
            }
        }
    }
}
