//! Corners fitted to the surface ([`BuildSettings::fit_corners`](crate::BuildSettings)): the
//! shared corner values of the leaves that keep the global-distance voxel, chosen so that the
//! trilinear interpolant's zero set follows the mesh, instead of sampling the exact distance.
//!
//! Exact distances at the corners are not the best corners for a trilinear voxel: near a
//! feature or across a curved surface the interpolant of the exact distance bows off the
//! surface, and rounding each value to its code on its own adds up to half a step more. The fit
//! is one sparse least-squares problem over the *shared* grid points (every voxel around a
//! point reads the same value, so a layout that stores each grid point once stores the fitted
//! one once):
//!
//! ```text
//! minimise  Σ_leaves 1/N_L Σ_samples f_L(p)²  +  λ Σ_points (v − d)²
//! ```
//!
//! in units of the leaf edge `h`, where `f_L` is leaf `L`'s trilinear interpolant of the point
//! values `v`, the samples `p` are the leaf decision's points of the true surface in the cell
//! (`leaf::samples`, `N_L` of them) and `d` is the exact signed distance. It is solved for the
//! moves `v − d` by a fixed number of conjugate-gradient steps from zero, preconditioned by the
//! system's diagonal (Jacobi: 20 steps reach what 120 plain steps did); each value is rounded
//! to its code within [`FitParams::max_shift_steps`] of `d` (an inside value at most
//! [`FitParams::max_inside_drop_steps`] below), and then a few sweeps of greedy
//! descent move codes by one step where that lowers the same energy (the quantised values are
//! what the file stores).
//!
//! Which points move: those of leaves whose voxel is the shared global-distance voxel (every
//! SVO leaf; a multi-octree leaf the decision gave the SVO voxel). Private corners (a
//! multi-octree leaf's component, surface, plane or clip voxels) keep their own values. A point
//! that is also a corner of a candidate cell the build dropped keeps its exact value, and a
//! point farther than one quantisation step from the surface keeps its sign, so that no cell
//! outside the file (a dropped candidate, or a cell beyond the candidate margin, all of whose
//! corners are that far) gains a zero crossing. The leaf decisions are made on the exact
//! corners before the fit: the leaves and voxels, and so the bytes, are the same with or
//! without it.
//!
//! Format 3.x's bytes too ([`FitParams::keep_brick_widths`]): it stores a brick's shared points
//! as a plane and residuals of a width per brick, and fitted values lie less on a plane. So
//! the points of a brick whose residuals the fitted codes would widen keep their exact values,
//! as do the points of single-voxel leaves that format 3.x may store as shared (a component's
//! volume voxel) and the leaves of surface voxels (private there, and narrow where their codes
//! vary little): the 3.1 file of a fitted octree is 0.997–1.001× the exact one's.
//!
//! Deterministic: the per-leaf systems are functions of their leaf, the point sums run over
//! each point's leaves in leaf order, the dot products sum fixed chunks in a fixed order, and
//! the code descent moves one parity class of grid points at a time (points of one class share
//! no leaf), so the values do not depend on the number of threads.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use crate::geom::corner_offset;
use crate::leaf::samples::Samples;
use crate::leaf::{Cell, Params};
use crate::local::LocalMesh;
use crate::subdivide::Subdivision;

/// The weights and limits of the fit. Measured at depth 9, multi-octree, 1024² paper views, dB
/// over the exact corners for teapot / abc8 (/ abc1):
/// - `λ` (shift 2, 40 steps, no code descent): 0.2 → +0.78 / +0.43, 0.05 → +0.82 / +0.54,
///   0.01 → +1.12 / +0.49. A gradient term pulling `∇f` to the face normals at the samples
///   (weight 0.1 or 1 against the value term's 1) cost the teapot 0.40 or 1.31 dB: dropped.
/// - The code descent (shift 3, 40 steps): 0 → 4 sweeps −0.14 / +0.07 / +0.06.
/// - Steps and shift (plain conjugate gradients): 40 steps, shift 3 → +1.09 / +0.72 / +0.93;
///   120 steps, shift 4 → +1.22 / +1.15 / +1.21; 120 steps, shift 6 → +1.23 / +1.47 / +1.29.
/// - Jacobi-preconditioned steps (shift 6), against 120 plain steps over the 50 cells of the
///   paper sweep (five models, depths 6–10, SVO and multi): 20 steps within −0.01 to +0.03 dB of
///   every cell (the values below; a sixth of the solver's work); 10 steps within −0.1 dB at
///   depth 9 but −1.37 dB on abc5 SVO depth 6; no steps (rounding and code descent alone):
///   depth-9 multi median +0.96 dB.
///
/// Without a bound on the inside values 48 of the 50 cells of the paper sweep gained (+0.03 to
/// +2.64 dB, depth-9 multi median +1.29); abc5 lost 1.04 dB (SVO, depth 6) and 0.30 dB (multi,
/// depth 7): seen edge-on, a face's silhouette column flipped where lowered values moved the
/// zero set out by 0.01–0.03 of a cell (one or two codes). Against abc5 depths 6/7, SVO/multi,
/// dB over exact:
/// - every value at most one code below its exact code: within −0.05 dB, but a depth-9 multi
///   median of +0.71;
/// - only outside values (`d > 0`) bounded to one code below: −1.13 / +0.14 / +0.29 / −0.46;
/// - only inside values bounded, to 2 codes: −0.98 / +0.24 / +0.58 / +0.28; to 0: +0.25 / +0.14
///   / +0.56 / +0.23; **to 1** (`max_inside_drop_steps`): +0.25 / +0.21 / +0.47 / +0.30, and
///   SVO and multi gain in 49 of the 50 cells (abc5 SVO depth 9 −0.01), depth-9 multi median
///   +1.13 dB (`docs/results/sweep.md`);
/// - extra rows pinning `f` at points `δ` off the surface along the face normal to their exact
///   distance (outside only or both sides, `δ` 0.1–0.5 of a cell, weight 1–16 against the
///   surface samples' 1): abc5 SVO depth 6 stayed at −0.9 to −1.0 dB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FitParams {
    /// Weight `λ` of a value's squared move away from its exact distance.
    pub lambda: f32,
    /// Preconditioned conjugate-gradient steps.
    pub iterations: usize,
    /// Largest move of a value from its exact distance, in quantisation steps.
    pub max_shift_steps: f32,
    /// Sweeps of the greedy descent over the quantised codes (one code up or down per point
    /// and sweep where that lowers the energy).
    pub code_sweeps: usize,
    /// Largest move of an inside value (exact distance at or below zero) below its exact code,
    /// in codes.
    pub max_inside_drop_steps: i32,
    /// Keep exact the points of every brick whose residuals the fitted codes would widen, so
    /// that format 3.x stores the fitted octree in the bytes of the exact one: without it the
    /// 3.1 file grew by 8–9 % (abc1, abc5 depth 9 multi), with it 0.997–1.001× on the 30 cells
    /// of depths 8–10, for a depth-9 multi median of +1.03 dB instead of +1.13
    /// (`docs/results/sweep.md`).
    pub keep_brick_widths: bool,
}

impl FitParams {
    /// The values the builder uses.
    pub const DEFAULT: FitParams = FitParams {
        lambda: 0.01,
        iterations: 20,
        max_shift_steps: 6.0,
        code_sweeps: 4,
        max_inside_drop_steps: 1,
        keep_brick_widths: true,
    };
}

/// One fitted leaf's normal equations: its 8×8 matrix and its right-hand side, in units of
/// `h`, for the moves `v − d` of its corners.
#[derive(Clone, Copy, Debug)]
struct LeafSystem {
    m: LeafMatrix,
    b: [f32; 8],
}

/// A leaf's symmetric 8×8 matrix: its upper triangle, row-major (36 entries). Packed because
/// the solver's steps are bound by memory, each reading every leaf's matrix (abc1 depth 9:
/// 42 MB a step): the whole matrix by columns (64 entries, one load per column half) took
/// 11 % fewer instructions than this and no less time (abc1 depth 9, 2026-12-05).
#[derive(Clone, Copy, Debug)]
struct LeafMatrix([f32; 36]);

/// Index of `(i, j)`, `i ≤ j`, in the packed upper triangle of an 8×8 matrix.
#[inline]
fn upper(i: usize, j: usize) -> usize {
    debug_assert!(i <= j);
    i * 8 - i * (i + 1) / 2 + j
}

impl LeafMatrix {
    /// `M[i][k]`.
    #[inline]
    fn at(&self, i: usize, k: usize) -> f32 {
        self.0[upper(i.min(k), i.max(k))]
    }

    /// `M x`, as the sum of `M`'s columns scaled by `x[k]` for `k = 0, 1, …, 7` in turn: each
    /// `y[i]` adds the terms `M[i][k] x[k]` in the order of `k`, as a row-by-row product does
    /// (the same value to the bit), four lanes at a time (mul then add, no fused
    /// multiply-add, as the scalar `y += a * x`).
    #[inline]
    fn apply(&self, x: &[f32; 8]) -> [f32; 8] {
        let column = |k: usize, first_row: usize| {
            Vec4::from_array(std::array::from_fn(|r| self.at(first_row + r, k)))
        };
        let (mut lo, mut hi) = (Vec4::ZERO, Vec4::ZERO);
        for (k, &xk) in x.iter().enumerate() {
            let xk = Vec4::splat(xk);
            lo += column(k, 0) * xk;
            hi += column(k, 4) * xk;
        }
        let (lo, hi) = (lo.to_array(), hi.to_array());
        [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]]
    }
}

impl LeafSystem {
    fn zero() -> LeafSystem {
        LeafSystem {
            m: LeafMatrix([0.0; 36]),
            b: [0.0; 8],
        }
    }

    /// Adds the row `r · x = t` with weight `w`.
    #[inline]
    fn add_row(&mut self, r: &[f32; 8], t: f32, w: f32) {
        for i in 0..8 {
            if r[i] == 0.0 {
                continue;
            }
            let wi = w * r[i];
            for (j, rj) in r.iter().enumerate().skip(i) {
                self.m.0[upper(i, j)] += wi * rj;
            }
            self.b[i] += wi * t;
        }
    }
}

/// The trilinear weights of the eight corners at local coordinates `l`.
#[inline]
fn weights(l: Vec3) -> [f32; 8] {
    std::array::from_fn(|k| {
        let o = corner_offset(k);
        let f = |o: f32, t: f32| if o > 0.5 { t } else { 1.0 - t };
        f(o.x, l.x) * f(o.y, l.y) * f(o.z, l.z)
    })
}

/// The normal equations of one leaf with exact corners `d` (normalised units) and `samples`:
/// rows for the moves `x = (v − d) / h`.
fn leaf_system(cell: &Cell, d: &[f32; 8], samples: &Samples) -> LeafSystem {
    let mut sys = LeafSystem::zero();
    if samples.is_empty() {
        return sys;
    }
    let du: [f32; 8] = d.map(|v| v * cell.inv_h);
    let w = 1.0 / samples.len() as f32;
    for &l in &samples.points {
        // Value: f(p) = w·(d + x h) = 0  →  w·x = −w·d / h.
        let r = weights(l);
        let f0: f32 = r.iter().zip(&du).map(|(a, b)| a * b).sum();
        sys.add_row(&r, -f0, w);
    }
    sys
}

/// Sum of `f(i)` over `0..n` in fixed chunks summed in order (the same for any thread count).
fn ordered_sum(n: usize, f: impl Fn(usize) -> f64 + Sync) -> f64 {
    const CHUNK: usize = 4096;
    let parts: Vec<f64> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| (c * CHUNK..((c + 1) * CHUNK).min(n)).map(&f).sum())
        .collect();
    parts.iter().sum()
}

/// The shared grid points of a build: the exact distance of each (`values`) and the point of
/// each candidate cell's eight corners (`point_of_slot[cell * 8 + k]`).
#[derive(Clone, Copy)]
pub(crate) struct SharedPoints<'a> {
    /// Exact signed distance per point.
    pub values: &'a [f32],
    /// Point index per cell corner.
    pub point_of_slot: &'a [u32],
}

/// The fitted values of the shared grid points `pts`: `fitted` are the cells whose voxel is the
/// shared one (ascending), `frozen` the cells whose points keep their exact value (dropped
/// candidates, and the leaves the caller keeps as they are for format 3.x).
pub(crate) fn fit_values(
    p: &Params,
    fp: &FitParams,
    mesh: &LocalMesh,
    sub: &Subdivision,
    pts: SharedPoints,
    fitted: &[u32],
    frozen: &[u32],
) -> Vec<f32> {
    let SharedPoints {
        values,
        point_of_slot,
    } = pts;
    let h = p.h;
    let npts = values.len();
    let corners_of =
        |cell: u32| -> [u32; 8] { std::array::from_fn(|k| point_of_slot[cell as usize * 8 + k]) };

    // Which points may move.
    let mut free = vec![false; npts];
    for &c in fitted {
        for q in corners_of(c) {
            free[q as usize] = true;
        }
    }
    for &c in frozen {
        for q in corners_of(c) {
            free[q as usize] = false;
        }
    }

    // Per-leaf systems.
    let (matrices, rhs): (Vec<LeafMatrix>, Vec<[f32; 8]>) = fitted
        .par_iter()
        .map_init(Samples::default, |samples, &c| {
            let cand = &sub.cells[c as usize];
            let cell = Cell::new(cand.coord, h);
            samples.collect(p, mesh, &cell, sub.tris_of(cand));
            let d = corners_of(c).map(|q| values[q as usize]);
            let s = leaf_system(&cell, &d, samples);
            (s.m, s.b)
        })
        .unzip();

    // Each fitted leaf's eight points, once (every solver step reads them).
    let leaf_points: Vec<[u32; 8]> = fitted.iter().map(|&c| corners_of(c)).collect();

    // Each point's (leaf, corner) slots `8 · leaf + corner`, in leaf order: the scatter as a
    // gather.
    let mut start = vec![0u32; npts + 1];
    for pts in &leaf_points {
        for &q in pts {
            start[q as usize + 1] += 1;
        }
    }
    for i in 0..npts {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut slots = vec![0u32; start[npts] as usize];
    for (j, pts) in leaf_points.iter().enumerate() {
        for (k, &q) in pts.iter().enumerate() {
            let at = &mut fill[q as usize];
            slots[*at as usize] = (j * 8 + k) as u32;
            *at += 1;
        }
    }
    // `out[i] = diag · x[i] + Σ per_slot[slot]` over point `i`'s slots, 0 where it is not free.
    let gather = |per_slot: &[f32], out: &mut [f32], diag: f32, x: &[f32]| {
        out.par_iter_mut()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(i, o)| {
                if !free[i] {
                    *o = 0.0;
                    return;
                }
                let mut s = diag * x[i];
                for &sl in &slots[start[i] as usize..start[i + 1] as usize] {
                    s += per_slot[sl as usize];
                }
                *o = s;
            });
    };

    // Right-hand side: Σ_L b_L on the free points (the moves start at 0).
    let bs: Vec<f32> = rhs.iter().flatten().copied().collect();
    let mut r = vec![0.0f32; npts];
    gather(&bs, &mut r, 0.0, &vec![0.0; npts]);
    drop(bs);

    // Conjugate gradients on (Σ_L M_L + λ I) x = r over the free points, preconditioned by
    // the inverse of that matrix's diagonal (a point's weight varies with how many leaves and
    // samples it has: 20 steps with it reach what 120 without did, `FitParams`).
    let inv_diag: Vec<f32> = (0..npts)
        .into_par_iter()
        .with_min_len(1024)
        .map(|i| {
            if !free[i] {
                return 0.0;
            }
            let mut d = fp.lambda;
            for &sl in &slots[start[i] as usize..start[i + 1] as usize] {
                let (j, k) = ((sl / 8) as usize, (sl % 8) as usize);
                d += matrices[j].at(k, k);
            }
            1.0 / d
        })
        .collect();
    let precondition = |z: &mut [f32], r: &[f32]| {
        z.par_iter_mut()
            .zip(r.par_iter())
            .zip(inv_diag.par_iter())
            .for_each(|((z, r), d)| *z = r * d);
    };
    let mut x = vec![0.0f32; npts];
    let mut z = vec![0.0f32; npts];
    precondition(&mut z, &r);
    let mut dir = z.clone();
    let mut ad = vec![0.0f32; npts];
    // `M_L` times the leaf's moves, per slot; one buffer for every step.
    let mut per_slot = vec![0.0f32; leaf_points.len() * 8];
    let mut rz = ordered_sum(npts, |i| f64::from(r[i]) * f64::from(z[i]));
    for _ in 0..fp.iterations {
        if rz <= 0.0 {
            break;
        }
        per_slot
            .par_chunks_exact_mut(8)
            .zip(matrices.par_iter())
            .zip(leaf_points.par_iter())
            .with_min_len(256)
            .for_each(|((y, s), pts)| y.copy_from_slice(&s.apply(&pts.map(|q| dir[q as usize]))));
        gather(&per_slot, &mut ad, fp.lambda, &dir);
        let dad = ordered_sum(npts, |i| f64::from(dir[i]) * f64::from(ad[i]));
        if dad <= 0.0 {
            break;
        }
        let alpha = (rz / dad) as f32;
        x.par_iter_mut()
            .zip(dir.par_iter())
            .for_each(|(x, d)| *x += alpha * d);
        r.par_iter_mut()
            .zip(ad.par_iter())
            .for_each(|(r, a)| *r -= alpha * a);
        precondition(&mut z, &r);
        let rz_new = ordered_sum(npts, |i| f64::from(r[i]) * f64::from(z[i]));
        let beta = (rz_new / rz) as f32;
        dir.par_iter_mut()
            .zip(z.par_iter())
            .for_each(|(d, z)| *d = z + beta * *d);
        rz = rz_new;
    }
    // The solver's vectors go before the code descent and the brick pass (the fit's peak).
    drop((r, z, dir, ad, per_slot, inv_diag));

    // Quantisation: each free point's code, chosen within its range by greedy descent of the
    // same energy, starting from the rounded continuous fit.
    let step = p.dmax / sdfmo_format::quant::max_code(p.bits) as f32;
    let limit = fp.max_shift_steps * step;
    let code_of = |v: f32| sdfmo_format::quant::quantize(v, p.dmax, p.bits);
    let value_of = |c: i32| c as f32 * step;
    let range = |d: f32| -> (i32, i32) {
        let q = sdfmo_format::quant::max_code(p.bits);
        let mut lo = (((d - limit) / step).ceil() as i32).max(-q);
        let mut hi = (((d + limit) / step).floor() as i32).min(q);
        // A point farther than a step from the surface keeps its sign: no cell outside the
        // candidates (all of whose corners are) gains a zero crossing.
        if d > step {
            lo = lo.max(1);
        } else if d < -step {
            hi = hi.min(-1);
        }
        let exact = code_of(d);
        // An inside point's value goes at most `max_inside_drop_steps` codes deeper than its
        // exact code: deeper inside values push the zero set outward, past the surface, which
        // is where the fit lost (abc5's silhouettes seen edge-on; see `FitParams`).
        if d <= 0.0 {
            lo = lo.max(exact - fp.max_inside_drop_steps);
        }
        (lo.min(exact), hi.max(exact))
    };
    let mut codes: Vec<i32> = values
        .par_iter()
        .zip(x.par_iter())
        .zip(free.par_iter())
        .map(|((&d, &x), &free)| {
            if free && x.is_finite() {
                let (lo, hi) = range(d);
                code_of(d + x * h).clamp(lo, hi)
            } else {
                code_of(d)
            }
        })
        .collect();
    drop(x);
    if fp.code_sweeps > 0 {
        let inv_h = 1.0 / h;
        let mut xs: Vec<f32> = codes
            .par_iter()
            .zip(values.par_iter())
            .map(|(&c, &d)| (value_of(c) - d) * inv_h)
            .collect();
        // Points of one parity class (grid coordinates mod 2) share no leaf: a class moves at once.
        let mut classes: [Vec<u32>; 8] = Default::default();
        for i in 0..npts {
            if free[i] && start[i] < start[i + 1] {
                let sl = slots[start[i] as usize];
                let cand = &sub.cells[fitted[(sl / 8) as usize] as usize];
                let o = corner_offset((sl % 8) as usize);
                let g = [
                    cand.coord[0] + o.x as u32,
                    cand.coord[1] + o.y as u32,
                    cand.coord[2] + o.z as u32,
                ];
                classes[((g[0] & 1) * 4 + (g[1] & 1) * 2 + (g[2] & 1)) as usize].push(i as u32);
            }
        }
        let ds = step * inv_h;
        for _ in 0..fp.code_sweeps {
            let mut moved = 0usize;
            for class in &classes {
                let updates: Vec<(u32, i32)> = class
                    .par_iter()
                    .filter_map(|&i| {
                        let i = i as usize;
                        let (mut a, mut g) = (fp.lambda, fp.lambda * xs[i]);
                        for &sl in &slots[start[i] as usize..start[i + 1] as usize] {
                            let (j, k) = ((sl / 8) as usize, (sl % 8) as usize);
                            let (m, b) = (&matrices[j], &rhs[j]);
                            let pts = leaf_points[j];
                            a += m.at(k, k);
                            g -= b[k];
                            for (n, &q) in pts.iter().enumerate() {
                                let mk = m.at(n, k);
                                g += mk * xs[q as usize];
                            }
                        }
                        let (lo, hi) = range(values[i]);
                        let c = codes[i];
                        let mut best = (0.0f32, c);
                        for (dc, delta) in [(1, ds), (-1, -ds)] {
                            let e = delta * delta * a + 2.0 * delta * g;
                            if (lo..=hi).contains(&(c + dc)) && e < best.0 {
                                best = (e, c + dc);
                            }
                        }
                        (best.1 != c).then_some((i as u32, best.1))
                    })
                    .collect();
                moved += updates.len();
                for (i, c) in updates {
                    codes[i as usize] = c;
                    xs[i as usize] = (value_of(c) - values[i as usize]) * inv_h;
                }
            }
            if moved == 0 {
                break;
            }
        }
    }
    if fp.keep_brick_widths {
        let exact = |i: usize| code_of(values[i]);
        keep_brick_widths(&mut free, &codes, &exact, fitted, sub, &leaf_points, p.bits);
    }
    codes
        .par_iter()
        .zip(values.par_iter())
        .zip(free.par_iter())
        .map(|((&c, &d), &free)| if free { value_of(c) } else { d })
        .collect()
}

/// Unfrees every point of a brick (the 4³ leaves of a node at `depth − 2`: format 3.x's unit
/// of residual widths, [`sdfmo_format::brick_residual_bits`]) that the fitted codes would store
/// with wider residuals than the exact codes, so that such a brick's points keep their exact
/// values; round after round, all wide bricks at once (a point kept exact can widen a brick
/// beside it), until none widens. Returns how many points it kept exact.
fn keep_brick_widths(
    free: &mut [bool],
    codes: &[i32],
    exact: &(dyn Fn(usize) -> i32 + Sync),
    fitted: &[u32],
    sub: &Subdivision,
    leaf_points: &[[u32; 8]],
    bits: sdfmo_format::ValueBits,
) -> usize {
    const NONE: u32 = u32::MAX;
    // Each brick's grid points (index `25 x + 5 y + z`, as the encoder orders them), bricks in
    // key order.
    let mut by_key: std::collections::BTreeMap<[u32; 3], [u32; 125]> = Default::default();
    for (j, &c) in fitted.iter().enumerate() {
        let coord = sub.cells[c as usize].coord;
        let grid = by_key.entry(coord.map(|v| v >> 2)).or_insert([NONE; 125]);
        // The leaf's lowest corner in the brick's 5³ grid (`25x + 5y + z`).
        let low = 25 * (coord[0] & 3) + 5 * (coord[1] & 3) + (coord[2] & 3);
        for (&q, offset) in leaf_points[j]
            .iter()
            .zip(sdfmo_format::CORNER_POINT_OFFSETS)
        {
            grid[(low + offset) as usize] = q;
        }
    }
    let bricks: Vec<[u32; 125]> = by_key.into_values().collect();
    let width = |grid: &[u32; 125], code: &dyn Fn(usize) -> i32| -> u32 {
        let points = grid.map(|q| (q != NONE).then(|| code(q as usize)));
        sdfmo_format::brick_residual_bits(&points, bits)
    };
    let exact_width: Vec<u32> = bricks.par_iter().map(|b| width(b, exact)).collect();
    // Each point's bricks (a point on a brick's face or edge is in two to eight), as
    // `(point, brick)` pairs sorted by point: after a round only the bricks of the points it
    // kept exact are measured again.
    let mut pairs: Vec<(u32, u32)> = bricks
        .iter()
        .enumerate()
        .flat_map(|(b, grid)| {
            grid.iter()
                .filter(|&&q| q != NONE)
                .map(move |&q| (q, b as u32))
        })
        .collect();
    pairs.sort_unstable();
    let mut check: Vec<u32> = (0..bricks.len() as u32).collect();
    let mut kept = 0;
    while !check.is_empty() {
        let now = |i: usize| if free[i] { codes[i] } else { exact(i) };
        let wide: Vec<u32> = check
            .par_iter()
            .copied()
            .filter(|&b| width(&bricks[b as usize], &now) > exact_width[b as usize])
            .collect();
        let mut next = Vec::new();
        for b in wide {
            for &q in bricks[b as usize].iter().filter(|&&q| q != NONE) {
                if std::mem::replace(&mut free[q as usize], false) {
                    kept += 1;
                    let from = pairs.partition_point(|&(p, _)| p < q);
                    next.extend(
                        pairs[from..]
                            .iter()
                            .take_while(|&&(p, _)| p == q)
                            .map(|&(_, b)| b),
                    );
                }
            }
        }
        next.sort_unstable();
        next.dedup();
        check = next;
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::trilinear;

    #[test]
    fn weights_are_the_interpolant() {
        let c: [f32; 8] = [0.3, -0.2, 0.7, 0.1, -0.5, 0.4, 0.2, -0.9];
        for l in [Vec3::new(0.1, 0.7, 0.4), Vec3::ZERO, Vec3::ONE] {
            let w = weights(l);
            let v: f32 = w.iter().zip(&c).map(|(a, b)| a * b).sum();
            assert!((v - trilinear(&c, l)).abs() < 1e-6);
        }
    }

    #[test]
    fn the_packed_matrix_applies_as_the_full_one() {
        let mut s = LeafSystem::zero();
        let rows = [weights(Vec3::new(0.2, 0.5, 0.9)), weights(Vec3::splat(0.3))];
        for (i, r) in rows.iter().enumerate() {
            s.add_row(r, 0.5 + i as f32, 2.0);
        }
        let x: [f32; 8] = std::array::from_fn(|k| k as f32 - 3.5);
        let y = s.m.apply(&x);
        for i in 0..8 {
            let want: f32 = (0..8)
                .map(|j| rows.iter().map(|r| 2.0 * r[i] * r[j] * x[j]).sum::<f32>())
                .sum();
            assert!((y[i] - want).abs() < 1e-5, "{i}: {} vs {want}", y[i]);
        }
    }
}
