//! Per-leaf voxel construction: the SVO's single voxel and the multi-octree's component voxels,
//! volume or surface, reduced to the cap, and kept only where they earn their place.
//!
//! # The multi-octree decision, leaf by leaf
//!
//! [`multi_leaf`] runs these phases in this order, each a function of its own module with its
//! own tests, all of the shape `fn(&LeafCtx, &mut Scratch)`: [`LeafCtx`] holds what the leaf
//! reads (settings, mesh tables, cell, gathered triangles, the SVO voxel), [`Scratch`] what the
//! phases write for the ones after them. Every threshold is a documented field of [`Params`].
//!
//! 1. *Samples* ([`samples`]). Every gathered triangle is clipped to the leaf cell; the clipped
//!    polygon's vertices, centroid and centroid–vertex midpoints are points of the true surface
//!    inside the leaf (signed distance 0). A cell without samples near an open sheet is dropped
//!    (the sheet's extended plane is no surface there); elsewhere it gets the SVO voxel. The
//!    SVO voxel (global signed distance at the shared corners, quantised as the file stores
//!    them) is evaluated at the samples: the largest distance from a sample to its zero set
//!    (`|f| / |∇f|`, not `|f|`: a collapsed gradient hides a missing zero set).
//! 2. *Components* ([`split`]). The gathered triangles split into connected components through
//!    shared edges of vertices welded by position (never at a sharp edge: a sharp edge shares
//!    its vertices; part ids pre-split). Pieces of the same *global* component are merged back
//!    (a piece cut out of a closed surface by the leaf is not closed: its own signed distance
//!    is a half-space, see the `components` module).
//! 3. *Sharp features* ([`sharp`]). Where the samples all lie on one closed component and no
//!    open sheet is near, a sharp edge or corner takes one plane voxel per face.
//! 4. *Gaps, and does the SVO voxel already do?* ([`gaps`]). Points of the free space between
//!    the components that the SVO voxel calls inside (a gap it closes, which the samples on
//!    the surfaces cannot see). If the SVO voxel's sample error is below [`LeafParams::accept`] of
//!    the cell size, no sheet is open near it and it closes no gap, the leaf gets that voxel,
//!    exactly as the SVO (most leaves: smooth surfaces).
//! 5. *Candidate voxels* ([`split`]). One voxel per component, corners = exact signed distance
//!    to that whole component alone. A component with boundary edges (open) gets a *surface*
//!    voxel. A component its own voxel does not reproduce (error above [`LeafParams::thin`] at its
//!    samples: a plate thinner than a voxel whose corners all come out positive) whose
//!    triangles form two nearly opposite groups of normals (the plate's two faces, never the
//!    two faces of a sharp edge) is split into two surface voxels, one per face. The groups
//!    are canonical (reference normal oriented towards a fixed direction, side faces in
//!    neither group), so a one-ulp change of the input does not regroup the faces. One
//!    component with one volume voxel is the SVO voxel.
//! 6. *Reduction* ([`reduce`]). Voxels whose quantised corners do not change sign cannot be
//!    hit and go; voxels whose surface samples all lie inside another volume voxel are hidden
//!    and go; above the cap, the most similar volume voxels merge (min = union), then the most
//!    nearly coplanar surface voxels merge (average, oriented alike); a cap hit is counted.
//! 7. *Earn its place* ([`score`]). The voxel set and the SVO voxel are scored on the same
//!    samples: the mean error `max(min_v |f_v(p)|, buried depth inside a volume voxel)` plus a
//!    false-surface term (on a 3×3×3 grid in the cell, how much closer some voxel's zero set is
//!    than the true surface) plus a small cost per extra voxel. The multi set is kept only when
//!    it scores better by [`LeafParams::earn`] *and* its visible zero set reaches no farther from
//!    the mesh than the SVO voxel's (plus [`LeafParams::reach_tol`]): the zero crossings of every
//!    voxel on 4×4 axis-parallel lines per axis (exact, the interpolant is linear along them),
//!    minus those buried in another volume voxel, are measured against the true unsigned
//!    distance. Both scores count the gap points each choice closes. Otherwise the leaf gets
//!    the SVO voxel.
//! 8. *Rims* ([`rim`]). An open sheet's one voxel is clipped at the sheet's boundary.
//!
//! Wherever the leaf ends up with the SVO voxel and holds one open component, that voxel is a
//! surface voxel when its inside is not enclosed by the sheet (the back of an open sheet, see
//! `svo_voxel`).

use glam::Vec3;
use sdfmo_format::{cell_size, quant, ValueBits, Voxel};

use crate::components::Components;
use crate::geom::corner_offset;
use crate::local::LocalMesh;

pub(crate) mod gaps;
pub(crate) mod reduce;
pub(crate) mod rim;
pub(crate) mod samples;
pub(crate) mod score;
pub(crate) mod sharp;
pub(crate) mod split;

use samples::{Samples, SvoFit};
use split::LeafComponents;

/// The thresholds of the multi-octree's per-leaf decision (the phases of the `leaf` module of
/// this crate): a field of [`BuildSettings`](crate::BuildSettings), with two named presets,
/// [`LeafParams::OURS`] (the default) and [`LeafParams::PAPER`]. Lengths are fractions of the
/// leaf's cell edge `h`. Each field says the measurement that chose its value in
/// `OURS` (PSNR gains are multi-octree − SVO at 1024², the paper's protocol, from
/// `docs/results/build.md` and `docs/results/sweep.md` of the repository); where none is given
/// the value was set once and no alternative was measured.
///
/// The SVO ignores them. Any values build a valid octree; none of them changes the file format.
///
/// `#[non_exhaustive]`: start from a preset and assign the fields to change (a threshold added
/// later breaks no caller):
///
/// ```
/// use sdfmo_build::{BuildSettings, LeafParams, Method};
/// let mut leaf = LeafParams::OURS;
/// leaf.earn = 0.05;
/// let settings = BuildSettings::new(8, Method::default()).with_leaf(leaf);
/// assert_eq!(settings.leaf.earn, 0.05);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct LeafParams {
    /// The SVO voxel is accepted outright when its largest sample error (distance from a sample
    /// of the surface to its zero set) is below this (0.08): the many leaves of smooth surfaces
    /// keep the SVO's voxel without the component phases.
    pub accept: f32,
    /// A component voxel with a larger sample error is considered thin and may be split into
    /// two surface voxels (0.2, "thin split only for opposing faces").
    pub thin: f32,
    /// The multi set must beat the SVO voxel's score by this much (0.03). Measured on abc5 at
    /// depth 9, 1024²: 0.15 cost 0.42 dB, −0.03 cost 0.08 dB.
    pub earn: f32,
    /// Score cost of every voxel beyond the first (0.01).
    pub voxel_cost: f32,
    /// A multi set whose visible zero set reaches farther from the true surface than the SVO
    /// voxel's by more than this is never chosen (0.05). Measured on abc5 depth 9 / abc1 depth
    /// 8 at 512²: 0 → +0.10 / −0.01 dB (every split refused), 0.01 → +8.17 / −0.13 dB but abc5
    /// depth 8 +0.02 instead of +1.40 dB, 0.05 and 0.1 → +8.17 / −0.13 dB.
    pub reach_tol: f32,
    /// With at most this many gathered triangles, each clipped polygon also gives the midpoints
    /// between its centroid and its vertices as samples (16: more samples where they are cheap).
    pub rich_samples_below: usize,
    /// Thin split: faces whose normal makes `|cos|` below this with the reference normal are
    /// side faces (the rim) and belong to neither face group (0.3). Putting the rim's side
    /// faces into both groups instead cost 0.18 dB on abc5 at depth 9.
    pub rim_cos: f32,
    /// Thin split: the two face groups' mean normals must be nearly opposite, `cos < −this`
    /// (0.8; the two faces of a sharp edge are at an angle and are never split: splitting
    /// there made abc3 0.03 dB worse, with speckles, and cost the authors' code 2–5 dB).
    pub opposite_cos: f32,
    /// Thin split: kept when the two surface voxels' sample error is below this fraction of
    /// the one voxel's (0.5).
    pub split_gain: f32,
    /// A voxel is hidden (dropped) when all its samples lie deeper than this inside another
    /// component's volume voxel (0.05).
    pub bury: f32,
    /// False-surface term of the score: a voxel's zero set counts as false only where it is
    /// closer than the true surface by more than this (0.1).
    pub false_surface_slack: f32,
    /// Reach test: a zero crossing deeper than this inside another volume voxel is hidden (0.02).
    pub reach_bury: f32,
    /// Points per axis of the score's false-surface grid, at `(i + 1) / (n + 1)` of the cell
    /// (3). The grid alone missed the false hits at the ends of abc5's thin parts, which the
    /// reach test catches.
    pub score_grid: usize,
    /// Lines per axis direction of the reach test (`n²` lines per axis, at `(i + ½) / n`; 4).
    /// 8 × 8 lines instead of 4 × 4: no change at `reach_tol` 0.05.
    pub reach_lines: usize,
    /// Gap points: free space between two components counts only where it is at least this
    /// far from every component (0.025: narrower gaps are below what the corners represent).
    pub gap_min: f32,
    /// Gap points: at most this many surface samples per component are paired with the
    /// other components (24).
    pub gap_samples: usize,
    /// Score weight of the fraction of gap points a choice calls inside, a closed gap (1).
    pub gap_weight: f32,
    /// The reach allowed to a multi set that keeps open more gap points than the SVO voxel
    /// (instead of [`LeafParams::reach_tol`]). Measured on the gap suite
    /// (`tests/hard_cases/gaps.rs`) and abc5: 0.05 keeps 14.7 % of the gaps open, 0.15 33 %,
    /// 0.3 99 %; abc5 at depth 6 pays 0.78 dB for it (each plank's own voxel rounds its sharp
    /// ends), depths 7–9 none.
    pub gap_reach_tol: f32,
    /// Sharp features as plane voxels (the `sharp` phase).
    pub sharp: bool,
    /// Sharp features: triangles whose normals make a cosine of at least this with a face
    /// group's first triangle belong to that face (0.97, 14°). Measured at depth 9, multi − SVO
    /// dB for abc1 / teapot (abc3, abc5, abc8 do not change): 0.8 → +1.08 / +0.62, 0.9 → +1.08 /
    /// +1.55, 0.97 → +1.80 / +2.55, 0.99 → +1.43 / +3.53, 0.998 → +0.89 / +3.61 (abc5 −3.2).
    pub sharp_cos: f32,
    /// Sharp features: a face's samples must lie within this of its plane, and every sample
    /// within this of the combined voxels' zero set (0.02). Measured at depth 9, multi − SVO dB
    /// for abc1 / teapot: 0.02 → +1.80 / +2.55, 0.04 → +1.98 / +2.18, 0.08 → +1.07 / +1.28.
    /// Also the rims' flatness test.
    pub sharp_flat: f32,
    /// Sharp features: corners whose exact distance is beyond this must keep their sign (0.05).
    pub sharp_sign: f32,
    /// Clip-only voxels at the rims of open sheets (the `rim` phase).
    pub rims: bool,
}

impl LeafParams {
    /// This crate's decision, the default: every phase on, the values above.
    pub const OURS: LeafParams = LeafParams {
        accept: 0.08,
        thin: 0.2,
        earn: 0.03,
        voxel_cost: 0.01,
        reach_tol: 0.05,
        rich_samples_below: 16,
        rim_cos: 0.3,
        opposite_cos: 0.8,
        split_gain: 0.5,
        bury: 0.05,
        false_surface_slack: 0.1,
        reach_bury: 0.02,
        score_grid: 3,
        reach_lines: 4,
        gap_min: 0.025,
        gap_samples: 24,
        gap_weight: 1.0,
        gap_reach_tol: 0.3,
        sharp: true,
        sharp_cos: 0.97,
        sharp_flat: 0.02,
        sharp_sign: 0.05,
        rims: true,
    };

    /// The paper's decision as far as these thresholds reach: one voxel per component of the
    /// leaf (a surface voxel for an open one) wherever the leaf has surface samples, reduced to
    /// the cap; the SVO voxel only where it fits the samples exactly (`accept` 0), no score or
    /// reach test against it (`earn` −∞, `reach_tol` and `gap_reach_tol` +∞: the gap points
    /// are still found but decide nothing), no plane voxels at sharp features, no rim clips.
    /// The component split, the thin split and the reduction are this crate's. Not measured
    /// as a whole; the fields' measurements say what each addition earned.
    pub const PAPER: LeafParams = LeafParams {
        accept: 0.0,
        earn: f32::NEG_INFINITY,
        reach_tol: f32::INFINITY,
        gap_reach_tol: f32::INFINITY,
        sharp: false,
        rims: false,
        ..LeafParams::OURS
    };
}

impl Default for LeafParams {
    fn default() -> Self {
        LeafParams::OURS
    }
}

/// The decision's parameters for one build: the cell and quantisation of its depth, the cap,
/// and the thresholds ([`LeafParams`], reached through `Deref`: `p.accept`).
#[derive(Clone, Copy, Debug)]
pub struct Params {
    /// Cell edge.
    pub h: f32,
    /// Quantisation range (the cell diagonal).
    pub dmax: f32,
    /// Corner bits.
    pub bits: ValueBits,
    /// Voxel cap per leaf.
    pub max_voxels: usize,
    /// The subdivision's gather margin (absolute): a leaf's triangles are those within it of
    /// the cell, so below it the leaf's own triangles give exact distances.
    pub gather: f32,
    /// The thresholds.
    pub t: LeafParams,
}

impl std::ops::Deref for Params {
    type Target = LeafParams;
    fn deref(&self) -> &LeafParams {
        &self.t
    }
}

impl Params {
    /// The parameters of a multi-octree build at `depth` with `bits` and `max_voxels`.
    pub fn with(depth: u8, bits: ValueBits, max_voxels: u8, t: LeafParams) -> Params {
        Params {
            h: cell_size(depth),
            dmax: quant::voxel_diagonal(depth),
            bits,
            max_voxels: max_voxels.into(),
            gather: crate::margins(depth, bits, crate::Method::Multi { max_voxels }).0,
            t,
        }
    }

    /// [`Params::with`] the default thresholds ([`LeafParams::OURS`]).
    #[cfg(test)]
    pub fn new(depth: u8, bits: ValueBits, max_voxels: u8) -> Params {
        Params::with(depth, bits, max_voxels, LeafParams::OURS)
    }

    /// The value the file stores for `v` (quantised and read back).
    #[inline]
    pub fn q(&self, v: f32) -> f32 {
        let code = quant::quantize(v, self.dmax, self.bits);
        code as f32 * (self.dmax / quant::max_code(self.bits) as f32)
    }

    /// All eight corners quantised.
    #[inline]
    pub fn q8(&self, c: &[f32; 8]) -> [f32; 8] {
        c.map(|v| self.q(v))
    }

    /// Whether the quantised corners change sign (the interpolant reaches zero in the cell).
    #[inline]
    pub fn crosses(&self, c: &[f32; 8]) -> bool {
        let mut lo = i32::MAX;
        let mut hi = i32::MIN;
        for &v in c {
            let k = quant::quantize(v, self.dmax, self.bits);
            lo = lo.min(k);
            hi = hi.max(k);
        }
        lo <= 0 && hi >= 0 && lo != hi
    }
}

/// One leaf cell: its box in the normalised frame and its edge.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cell {
    /// Lowest corner.
    pub lo: Vec3,
    /// Highest corner.
    pub hi: Vec3,
    /// Edge.
    pub h: f32,
    /// `1 / h`.
    pub inv_h: f32,
}

impl Cell {
    /// The cell at integer coordinates `coord` of a grid of edge `h` over `[-1, 1]³`.
    pub fn new(coord: [u32; 3], h: f32) -> Cell {
        let lo = Vec3::new(coord[0] as f32, coord[1] as f32, coord[2] as f32) * h - Vec3::ONE;
        Cell {
            lo,
            hi: lo + Vec3::splat(h),
            h,
            inv_h: 1.0 / h,
        }
    }

    /// The eight corner positions, index `4x + 2y + z`.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| self.lo + corner_offset(i) * self.h)
    }

    /// The point at local coordinates `l` (`[0, 1]³`).
    #[inline]
    pub fn at(&self, l: Vec3) -> Vec3 {
        self.lo + l * self.h
    }
}

/// The outcome of one leaf.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LeafResult {
    /// The voxels (empty: the leaf is dropped).
    pub voxels: Vec<Voxel>,
    /// The component split produced more voxels than the cap.
    pub cap_hit: bool,
}

/// A voxel under construction: corners, quantised corners, surface flag, owning component.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cand {
    /// Corner signed distances.
    pub c: [f32; 8],
    /// The same, quantised as the file stores them.
    pub q: [f32; 8],
    /// Surface (thin) voxel.
    pub surface: bool,
    /// The leaf component it represents.
    pub comp: u32,
}

/// What every phase of one leaf reads: the settings, the mesh's tables, the cell, its gathered
/// triangles and the SVO voxel (the global signed distance at its corners, exact and as the
/// file stores it). Built once per leaf; the phases are functions of it and of [`Scratch`].
#[derive(Clone, Copy)]
pub(crate) struct LeafCtx<'a> {
    /// The decision's parameters.
    pub p: &'a Params,
    /// The builder's per-triangle tables.
    pub mesh: &'a LocalMesh,
    /// The mesh's global components (their distance structures and open flags).
    pub global: &'a Components,
    /// The leaf cell.
    pub cell: Cell,
    /// The gathered triangles (global ids).
    pub tris: &'a [u32],
    /// Global signed distance at the corners.
    pub g: &'a [f32; 8],
    /// The same, quantised as the file stores them.
    pub gq: [f32; 8],
    /// Some gathered triangle has a boundary edge (an open sheet is near).
    pub open_near: bool,
}

impl<'a> LeafCtx<'a> {
    /// The leaf at cell `coord` with gathered triangles `tris` and global corners `g`.
    pub fn new(
        p: &'a Params,
        mesh: &'a LocalMesh,
        global: &'a Components,
        coord: [u32; 3],
        tris: &'a [u32],
        g: &'a [f32; 8],
    ) -> LeafCtx<'a> {
        LeafCtx {
            p,
            mesh,
            global,
            cell: Cell::new(coord, p.h),
            tris,
            g,
            gq: p.q8(g),
            open_near: tris.iter().any(|&t| mesh.boundary[t as usize] != 0),
        }
    }
}

/// What the phases of one leaf write and read after them, in buffers reused from leaf to leaf
/// by one worker (no allocation per leaf after warm-up).
#[derive(Default)]
pub struct Scratch {
    /// Phase 1: samples of the true surface in the cell.
    samples: Samples,
    /// Phase 1: how well the SVO voxel fits them.
    svo: SvoFit,
    /// Phase 2: the leaf's components.
    components: LeafComponents,
    /// Phase 3 (and 8): the sharp feature's faces.
    sharp: sharp::SharpScratch,
    /// Phase 4: the free space between components the SVO voxel closes.
    gaps: gaps::GapPoints,
    /// Phases 5–6: the candidate voxels.
    cands: Vec<Cand>,
    /// Phase 7: the reach test's buffers.
    reach: score::ReachScratch,
}

/// The SVO leaf: the global-distance voxel if its quantised corners change sign.
#[inline]
pub fn svo_leaf(p: &Params, g: &[f32; 8]) -> LeafResult {
    if p.crosses(g) {
        LeafResult {
            voxels: vec![Voxel {
                corners: *g,
                surface: false,
                clip: false,
            }],
            cap_hit: false,
        }
    } else {
        LeafResult::default()
    }
}

/// The multi-octree leaf: the phases of the module docs, in order.
pub(crate) fn multi_leaf(ctx: &LeafCtx, s: &mut Scratch) -> LeafResult {
    let p = ctx.p;
    // 1. Samples of the true surface inside the cell.
    samples::collect(ctx, s);
    if s.samples.is_empty() {
        // No surface in the cell. Near an open sheet's rim the global distance still changes
        // sign across the sheet's plane extended past the rim: that zero set is false.
        if ctx.open_near && p.rims {
            return LeafResult::default();
        }
        return svo_leaf(p, ctx.g);
    }
    // 2. Components.
    let k = s.components.find(ctx.global, ctx.tris);
    // 3. A sharp edge or corner of one closed component: one plane voxel per face.
    if let Some(voxels) = sharp::sharp_leaf(ctx, s) {
        return LeafResult {
            voxels,
            cap_hit: false,
        };
    }
    // 4. The free space between components that the SVO voxel fills; does it already do?
    gaps::collect(ctx, s);
    if s.svo.max_gap <= p.accept && !ctx.open_near && s.gaps.points.is_empty() {
        return svo_voxel(ctx, s);
    }
    // 5. One (or two) voxels per component.
    split::candidate_voxels(ctx, s);
    if k == 1 && s.cands.len() == 1 && !s.cands[0].surface {
        // One component, one volume voxel: that is the SVO voxel.
        return svo_voxel(ctx, s);
    }
    // 6. Reduction: voxels that cannot be hit, hidden voxels, then the cap.
    let cap_hit = reduce::reduce(ctx, s);
    if s.cands.is_empty() {
        return svo_voxel(ctx, s);
    }
    // 7. Earn its place.
    let mut r = if score::multi_earns_its_place(ctx, s) {
        let voxels = s.cands.iter().map(|c| Voxel {
            corners: c.c,
            surface: c.surface,
            clip: false,
        });
        LeafResult {
            voxels: voxels.collect(),
            cap_hit,
        }
    } else {
        LeafResult {
            cap_hit,
            ..svo_voxel(ctx, s)
        }
    };
    // 8. One open sheet's voxel (its surface voxel, or the SVO voxel) stops at the sheet's rim.
    if p.rims && k == 1 && ctx.open_near && r.voxels.len() == 1 {
        rim::rim_clips(ctx, s, &mut r.voxels);
    }
    r
}

/// The SVO voxel as the multi-octree keeps it: a *surface* voxel on the back of an open sheet.
///
/// One open surface meets the cell and the SVO voxel's negative side is not enclosed by it (a
/// corner it calls inside where the surface's winding number says outside): the back of an open
/// sheet, which a ray can reach without crossing the sheet. As a volume voxel the SVO voxel
/// would stop such a ray where it enters the leaf from its empty neighbour, a wall up to a voxel
/// off the sheet (a curved sheet's silhouette). There the SVO voxel is a surface voxel (no
/// inside). Where the inside is enclosed (a nearly closed open surface: the teapot) it stays a
/// volume voxel, which keeps the surface watertight. Judged at the corner the voxel calls most
/// deeply inside (one winding number per leaf, and only where the SVO voxel is kept).
fn svo_voxel(ctx: &LeafCtx, s: &Scratch) -> LeafResult {
    let mut r = svo_leaf(ctx.p, ctx.g);
    if !r.voxels.is_empty() && back_of_open_sheet(ctx, &s.components) {
        r.voxels[0].surface = true;
    }
    r
}

/// Whether the cell holds one open component and the SVO voxel's deepest corner is outside it
/// by its winding number (see [`svo_voxel`]).
fn back_of_open_sheet(ctx: &LeafCtx, comps: &LeafComponents) -> bool {
    if comps.count != 1 {
        return false;
    }
    let comp = comps.global_ids[0];
    if !ctx.global.open[comp as usize] {
        return false;
    }
    let (deepest, &gv) = ctx
        .gq
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .expect("eight corners");
    gv < 0.0
        && ctx
            .global
            .winding_inside(ctx.mesh, comp, ctx.cell.at(corner_offset(deepest)))
            .is_some_and(|inside| !inside)
}

#[cfg(test)]
pub(crate) mod test_meshes;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_uses_quantised_values() {
        let p = Params::new(4, ValueBits::Eight, 8);
        let step = p.dmax / 127.0;
        let mut c = [p.h; 8];
        assert!(!p.crosses(&c));
        c[3] = 0.4 * step; // rounds to 0: touches zero
        assert!(p.crosses(&c));
        c[3] = 0.6 * step;
        assert!(!p.crosses(&c));
        c[3] = -0.6 * step;
        assert!(p.crosses(&c));
        assert!(!p.crosses(&[0.0; 8]));
    }

    #[test]
    fn cell_geometry() {
        let c = Cell::new([1, 0, 3], 0.5);
        assert_eq!(c.lo, Vec3::new(-0.5, -1.0, 0.5));
        assert_eq!(c.hi, Vec3::new(0.0, -0.5, 1.0));
        assert_eq!(c.corners()[0], c.lo);
        assert_eq!(c.corners()[7], c.hi);
        assert_eq!(c.corners()[4], Vec3::new(0.0, -1.0, 0.5));
        assert_eq!(c.at(Vec3::splat(0.5)), (c.lo + c.hi) * 0.5);
    }

    /// The whole pipeline: two boxes 0.4 of a cell apart, the gap inside one cell whose
    /// corners all lie inside a box (the SVO voxel has no zero set: the gap is closed), get one
    /// volume voxel each; a cell on one box's flat face gets the SVO voxel.
    #[test]
    fn separate_parts_closer_than_a_cell_keep_their_gap() {
        let f = test_meshes::two_boxes(true);
        let p = Params::new(3, ValueBits::Eight, 8);
        let mut s = Scratch::default();
        let leaf = f.leaf(&p, Vec3::new(0.1, 0.1, 0.1));
        assert!(!p.crosses(&leaf.g), "the SVO voxel closes the gap");
        let r = multi_leaf(&leaf.ctx(&f, &p), &mut s);
        assert_eq!(r.voxels.len(), 2, "{r:?}");
        assert!(r.voxels.iter().all(|v| !v.surface));
        assert!(!r.cap_hit);
        let face = f.leaf(&p, Vec3::new(-0.3, 0.5, 0.1));
        let r = multi_leaf(&face.ctx(&f, &p), &mut s);
        assert_eq!(r, svo_leaf(&p, &face.g));
        assert_eq!(r.voxels.len(), 1);
    }
}
