//! Phase 7: does the multi set earn its place? Both it and the SVO voxel are scored on the
//! same samples and grid, and the multi set must not reach farther from the mesh.

use glam::Vec3;

use super::samples::{Samples, SvoFit};
use super::{Cand, Cell, LeafCtx, Params, Scratch};
use crate::geom::trilinear;
use crate::local::LocalMesh;

/// Reusable buffers of the reach test.
#[derive(Clone, Debug, Default)]
pub(crate) struct ReachScratch {
    qs: Vec<[f32; 8]>,
    surf: Vec<bool>,
    zeros: Vec<Vec3>,
}

/// The gap the SVO voxel closes (points of the free space between the leaf's components that
/// it calls *inside*, see the `gaps` module; 0 when it has no zero set in the cell and the leaf
/// would be dropped), and how many of those points the multi set's volume voxels close too.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct GapCounts {
    /// Gap points the SVO voxel closes.
    pub svo: usize,
    /// How many of them the multi set closes too.
    pub multi: usize,
}

impl GapCounts {
    /// Score term of the SVO voxel: [`LeafParams::gap_weight`] where it closes a gap.
    fn svo_term(&self, p: &Params) -> f32 {
        self.term(p, self.svo)
    }

    /// Score term of the multi set: the weight × the fraction of the gap it closes too.
    fn multi_term(&self, p: &Params) -> f32 {
        self.term(p, self.multi)
    }

    fn term(&self, p: &Params, closed: usize) -> f32 {
        if self.svo == 0 {
            0.0
        } else {
            p.gap_weight * closed as f32 / self.svo as f32
        }
    }
}

/// Whether the candidate set `cands` should replace the SVO voxel (global corners `g`,
/// quantised `gq`, its fit `svo`). The score of a set is its mean error at the samples
/// (`max(min_v |f_v|, buried depth inside a volume voxel)`), plus its false-surface term
/// ([`false_surface`]), plus [`LeafParams::voxel_cost`] per voxel beyond the first; the multi set
/// must score better by [`LeafParams::earn`] *and* its visible zero set must reach no farther
/// from the mesh than the SVO voxel's plus [`LeafParams::reach_tol`] ([`zero_reach`]).
///
/// Both scores count the inside/outside errors in the free space between components
/// ([`GapCounts`], weighted by [`LeafParams::gap_weight`]); a multi set that keeps open more of a
/// gap than the SVO voxel may reach up to [`LeafParams::gap_reach_tol`] instead.
pub(crate) fn multi_earns_its_place(ctx: &LeafCtx, s: &mut Scratch) -> bool {
    let gaps = GapCounts {
        svo: s.gaps.points.len(),
        multi: s.gaps.closed_by_set(&s.cands),
    };
    earns(ctx, &s.svo, &s.samples, gaps, &s.cands, &mut s.reach)
}

/// [`multi_earns_its_place`] for the SVO fit `svo`, the samples, the gap counts and the
/// candidate set `cands` given.
fn earns(
    ctx: &LeafCtx,
    svo: &SvoFit,
    samples: &Samples,
    gaps: GapCounts,
    cands: &[Cand],
    s: &mut ReachScratch,
) -> bool {
    let LeafCtx {
        p,
        mesh,
        tris,
        cell,
        g,
        ..
    } = *ctx;
    let (cell, gq) = (&cell, &ctx.gq);
    let svo_crosses = p.crosses(g);
    let (false_m, false_s) = false_surface(p, mesh, tris, cell, cands, svo_crosses.then_some(gq));
    let svo_score = if svo_crosses {
        svo.mean_error + false_s + gaps.svo_term(p)
    } else {
        1.0
    };
    let multi_score = sample_error(samples, cands, cell)
        + false_m
        + p.voxel_cost * (cands.len() as f32 - 1.0)
        + gaps.multi_term(p);
    // A NaN score (never expected) keeps the SVO voxel.
    let better = multi_score + p.earn < svo_score;
    if !better {
        return false;
    }

    let reach_s = if svo_crosses {
        zero_reach(
            p,
            mesh,
            tris,
            cell,
            std::slice::from_ref(gq),
            &[false],
            &mut s.zeros,
        )
    } else {
        0.0
    };
    s.qs.clear();
    s.surf.clear();
    for c in cands {
        s.qs.push(c.q);
        s.surf.push(c.surface);
    }
    let reach_m = zero_reach(p, mesh, tris, cell, &s.qs, &s.surf, &mut s.zeros);
    // Keeping open a gap that the SVO voxel closes is worth some reach: one closed leaf shuts
    // the gap for every ray along it, while the reach it costs is where each part's own voxel
    // rounds the part's sharp end.
    let tol = if gaps.multi < gaps.svo {
        p.gap_reach_tol
    } else {
        p.reach_tol
    };
    reach_m <= reach_s + tol * cell.h
}

/// Mean error of the set at the samples (cell edges, each capped at 1): the distance to the
/// nearest zero set, or the depth inside a volume voxel where that is larger (a sample of the
/// true surface buried inside a voxel is not seen).
pub(crate) fn sample_error(samples: &Samples, cands: &[Cand], cell: &Cell) -> f32 {
    let mut sum = 0.0f32;
    for &l in &samples.points {
        let mut near = f32::INFINITY;
        let mut deepest = 0.0f32;
        for c in cands {
            let f = trilinear(&c.q, l);
            near = near.min(f.abs());
            if !c.surface {
                deepest = deepest.max(-f);
            }
        }
        sum += (near.max(deepest) * cell.inv_h).min(1.0);
    }
    sum / samples.len() as f32
}

/// The false-surface terms of the multi set and of the SVO voxel `svo` (`None`: it has no
/// zero set, term 0): on a grid of [`LeafParams::score_grid`]³ points inside the cell, how much
/// closer the nearest zero set is than the true surface (beyond
/// [`LeafParams::false_surface_slack`]), in cell edges capped at 1, averaged.
pub(crate) fn false_surface(
    p: &Params,
    mesh: &LocalMesh,
    tris: &[u32],
    cell: &Cell,
    cands: &[Cand],
    svo: Option<&[f32; 8]>,
) -> (f32, f32) {
    let n = p.score_grid;
    let slack = p.false_surface_slack * cell.h;
    let mut false_m = 0.0f32;
    let mut false_s = 0.0f32;
    for gi in 0..n * n * n {
        let step = |i: usize| (i + 1) as f32 / (n + 1) as f32;
        let l = Vec3::new(step(gi / (n * n)), step((gi / n) % n), step(gi % n));
        let u = mesh.unsigned_distance_subset(tris, cell.at(l), cell.h);
        let rm = cands
            .iter()
            .map(|c| trilinear(&c.q, l).abs())
            .fold(f32::INFINITY, f32::min);
        false_m += ((u - rm - slack).max(0.0) * cell.inv_h).min(1.0);
        if let Some(gq) = svo {
            let rs = trilinear(gq, l).abs();
            false_s += ((u - rs - slack).max(0.0) * cell.inv_h).min(1.0);
        }
    }
    let count = (n * n * n) as f32;
    (false_m / count, false_s / count)
}

/// The largest true unsigned distance (world units, capped at `h`) from the visible zero set
/// of the voxels `qs` (quantised corners; `surf` = surface flags) to the gathered triangles
/// `tris`, over the zero crossings on [`LeafParams::reach_lines`]² axis-parallel lines per axis
/// through the cell. Along such a line the trilinear interpolant is linear, so each voxel
/// crosses zero at most once there, exactly where the file's interpolant does. A crossing
/// deeper than [`LeafParams::reach_bury`] inside another volume voxel is hidden and does not count.
pub(crate) fn zero_reach(
    p: &Params,
    mesh: &LocalMesh,
    tris: &[u32],
    cell: &Cell,
    qs: &[[f32; 8]],
    surf: &[bool],
    zeros: &mut Vec<Vec3>,
) -> f32 {
    zeros.clear();
    let lines = p.reach_lines;
    let step = 1.0 / lines as f32;
    let hidden_below = -p.reach_bury * cell.h;
    for axis in 0..3 {
        for i in 0..lines {
            for j in 0..lines {
                let u = (i as f32 + 0.5) * step;
                let v = (j as f32 + 0.5) * step;
                let at = |t: f32| match axis {
                    0 => Vec3::new(t, u, v),
                    1 => Vec3::new(u, t, v),
                    _ => Vec3::new(u, v, t),
                };
                for (vi, q) in qs.iter().enumerate() {
                    let a = trilinear(q, at(0.0));
                    let b = trilinear(q, at(1.0));
                    if (a > 0.0 && b > 0.0) || (a < 0.0 && b < 0.0) || a == b {
                        continue;
                    }
                    let l = at((a / (a - b)).clamp(0.0, 1.0));
                    let hidden =
                        qs.iter().zip(surf).enumerate().any(|(wi, (o, &os))| {
                            wi != vi && !os && trilinear(o, l) < hidden_below
                        });
                    if !hidden {
                        zeros.push(l);
                    }
                }
            }
        }
    }
    let mut reach = 0.0f32;
    for &l in zeros.iter() {
        reach = reach.max(mesh.unsigned_distance_subset(tris, cell.at(l), cell.h));
    }
    reach
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::leaf::test_meshes::Fixture;
    use sdfmo_format::ValueBits;
    use sdfmo_mesh::procedural;

    /// A box face through a cell, the cell's exact plane voxel and a copy shifted off the face.
    fn face_case() -> (
        Fixture,
        Params,
        crate::leaf::test_meshes::Leaf,
        [f32; 8],
        [f32; 8],
    ) {
        // The face x = 0.4 crosses the depth-3 cell [0.25, 0.5] × [0, 0.25]²; the shifted
        // voxel's zero set is the plane x = 0.3, 0.4 h off the face, inside the cell.
        let f = Fixture::new(procedural::box_mesh(Vec3::splat(-0.6), Vec3::splat(0.4)));
        let p = Params::new(3, ValueBits::Sixteen, 8);
        let leaf = f.leaf(&p, Vec3::new(0.3, 0.1, 0.1));
        let x0 = 0.4;
        let exact: [f32; 8] = leaf.cell.corners().map(|c| c.x - x0);
        let off = exact.map(|v| v + 0.4 * p.h);
        (f, p, leaf, p.q8(&exact), p.q8(&off))
    }

    fn cand(q: [f32; 8], surface: bool) -> Cand {
        Cand {
            c: q,
            q,
            surface,
            comp: 0,
        }
    }

    #[test]
    fn the_exact_voxel_scores_zero_and_a_shifted_one_does_not() {
        let (f, p, leaf, exact, off) = face_case();
        let samples = leaf.samples(&f, &p);
        assert!(sample_error(&samples, &[cand(exact, false)], &leaf.cell) < 1e-3);
        let e = sample_error(&samples, &[cand(off, false)], &leaf.cell);
        assert!((e - 0.4).abs() < 0.01, "{e}");
    }

    #[test]
    fn a_zero_set_off_the_surface_is_a_false_surface() {
        let (f, p, leaf, exact, off) = face_case();
        let (m, s) = false_surface(
            &p,
            &f.mesh,
            &leaf.tris,
            &leaf.cell,
            &[cand(exact, false)],
            Some(&off),
        );
        assert_eq!(m, 0.0);
        assert!(s > 0.05, "{s}");
        let (_, none) = false_surface(&p, &f.mesh, &leaf.tris, &leaf.cell, &[], None);
        assert_eq!(none, 0.0);
    }

    #[test]
    fn reach_measures_the_zero_set_against_the_mesh() {
        let (f, p, leaf, exact, off) = face_case();
        let mut zeros = Vec::new();
        let reach = |qs: &[[f32; 8]], surf: &[bool], zeros: &mut Vec<Vec3>| {
            zero_reach(&p, &f.mesh, &leaf.tris, &leaf.cell, qs, surf, zeros)
        };
        let r = reach(&[exact], &[false], &mut zeros);
        assert!(r < 1e-3 * p.h, "{r}");
        assert!(!zeros.is_empty());
        let r = reach(&[off], &[false], &mut zeros);
        assert!((r - 0.4 * p.h).abs() < 0.01 * p.h, "{r}");
        // The shifted zero set lies inside the exact volume voxel: hidden, it reaches nowhere.
        let both = [exact, off];
        let r = reach(&both, &[false, false], &mut zeros);
        assert!(r < 1e-3 * p.h, "{r}");
        // A surface voxel hides nothing.
        let r = reach(&both, &[true, false], &mut zeros);
        assert!((r - 0.4 * p.h).abs() < 0.01 * p.h, "{r}");
    }

    #[test]
    fn the_multi_set_must_beat_the_svo_voxel() {
        let (f, p, leaf, exact, off) = face_case();
        let samples = leaf.samples(&f, &p);
        let mut s = ReachScratch::default();
        // Does `multi` replace the SVO voxel `svo` (taken as exact: its own quantised corners)?
        let mut earns_with = |svo: [f32; 8], multi: &[Cand], gaps: GapCounts| {
            let fit = crate::leaf::samples::svo_fit(&svo, &samples, &leaf.cell);
            let ctx = LeafCtx {
                g: &svo,
                gq: svo,
                ..leaf.ctx(&f, &p)
            };
            earns(&ctx, &fit, &samples, gaps, multi, &mut s)
        };
        let none = GapCounts::default();
        // Exact multi set against a shifted SVO voxel: earns it; the other way round: does not.
        assert!(earns_with(off, &[cand(exact, false)], none));
        assert!(!earns_with(exact, &[cand(off, false)], none));
        // Equal sets: the voxel cost and `earn` keep the SVO voxel.
        assert!(!earns_with(
            exact,
            &[cand(exact, false), cand(exact, true)],
            none
        ));
        // Closed gap points between components weigh in the score: a worse multi set that
        // keeps open a gap the SVO voxel closes earns its place as long as it reaches no
        // farther than `gap_reach_tol` (the shifted voxel is 0.4 h off); when both close it,
        // the samples decide.
        let gaps = |svo, multi| GapCounts { svo, multi };
        let mut lenient = p;
        lenient.t.gap_reach_tol = 0.5;
        let fit = crate::leaf::samples::svo_fit(&exact, &samples, &leaf.cell);
        let multi = [cand(off, false)];
        for (q, expected) in [(&lenient, true), (&p, false)] {
            let ctx = LeafCtx {
                g: &exact,
                gq: exact,
                ..leaf.ctx(&f, q)
            };
            let r = earns(
                &ctx,
                &fit,
                &samples,
                gaps(4, 0),
                &multi,
                &mut ReachScratch::default(),
            );
            assert_eq!(r, expected, "gap_reach_tol {}", q.gap_reach_tol);
        }
        assert!(earns_with(off, &[cand(exact, false)], gaps(4, 4)));
        assert!(!earns_with(exact, &[cand(off, false)], gaps(4, 4)));
    }
}
