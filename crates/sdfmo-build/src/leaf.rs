//! Per-leaf voxel construction: the SVO's single voxel and the multi-octree's component voxels,
//! volume or surface, reduced to the cap, and kept only where they earn their place.
//!
//! # The multi-octree decision, leaf by leaf
//!
//! 1. *Samples.* Every gathered triangle is clipped to the leaf cell; the clipped polygon's
//!    vertices, centroid and centroid–vertex midpoints are points of the true surface inside the
//!    leaf (signed distance 0).
//! 2. *Does the SVO voxel already do?* The single voxel from the global signed distance (shared
//!    corners, quantised as the file stores them) is evaluated at the samples. If the largest
//!    distance from a sample to the voxel's zero set (`|f| / |∇f|`, not `|f|`: a collapsed
//!    gradient hides a missing zero set) is below [`Params::accept`] of the cell size, the leaf
//!    gets that voxel, exactly as the SVO (most leaves: smooth surfaces, sharp edges of one
//!    component). The thin test of step 3 measures the same distance.
//! 3. *Components.* The gathered triangles split into connected components through shared edges
//!    of vertices welded by position (never at a sharp edge: a sharp edge shares its vertices;
//!    part ids pre-split). Pieces of the same *global* component are merged back (a piece cut
//!    out of a closed surface by the leaf is not closed: its own signed distance is a
//!    half-space, see the `components` module). One voxel per component, corners = exact
//!    signed distance to that whole component alone. A component with boundary edges (open)
//!    gets a *surface* voxel. A component its own voxel does not reproduce (error above
//!    [`Params::thin`] at its samples: a plate thinner than a voxel whose corners all come out
//!    positive) whose triangles form two nearly opposite groups of normals (the plate's two
//!    faces, never the two faces of a sharp edge) is split into two surface voxels, one per face.
//!    The groups are canonical (reference normal oriented towards a fixed direction, side faces
//!    in neither group), so a one-ulp change of the input does not regroup the faces.
//! 4. *Reduction.* Voxels whose quantised corners do not change sign cannot be hit and go;
//!    voxels whose surface samples all lie inside another volume voxel are hidden and go; above
//!    the cap, the most similar volume voxels merge (min = union), then the most nearly coplanar
//!    surface voxels merge (average, oriented alike); a cap hit is counted.
//! 5. *Earn its place.* The voxel set and the SVO voxel are scored on the same samples: the
//!    mean error `max(min_v |f_v(p)|, buried depth inside a volume voxel)` plus a false-surface
//!    term (on a 3×3×3 grid in the cell, how much closer some voxel's zero set is than the
//!    true surface) plus a small cost per extra voxel. The multi set is kept only when it
//!    scores better by [`Params::earn`] *and* its visible zero set reaches no farther from the
//!    mesh than the SVO voxel's (plus [`Params::reach_tol`]): the zero crossings of every voxel
//!    on 4×4 axis-parallel lines per axis (exact, the interpolant is linear along them), minus
//!    those buried in another volume voxel, are measured against the true unsigned distance.
//!    Otherwise the leaf gets the SVO voxel.

use glam::Vec3;
use sdfmo_format::{quant, ValueBits, Voxel};
use sdfmo_mesh::UnionFind;

use crate::components::Components;
use crate::geom::{clip_triangle, corner_offset, trilinear, zero_set_gap, MAX_CLIP};
use crate::local::LocalMesh;

/// Tuning of the per-leaf decision (fractions of the cell edge `h`).
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
    /// The SVO voxel is accepted outright when its largest sample error is below this.
    pub accept: f32,
    /// A component voxel with a larger sample error is considered thin (split into surfaces).
    pub thin: f32,
    /// The multi set must beat the SVO voxel's score by this much.
    pub earn: f32,
    /// Score cost of every voxel beyond the first.
    pub voxel_cost: f32,
    /// A multi set whose visible zero set reaches farther from the true surface than the SVO
    /// voxel's by more than this is never chosen.
    pub reach_tol: f32,
}

impl Params {
    /// Defaults for a depth and quantisation.
    pub fn new(depth: u8, bits: ValueBits, max_voxels: usize) -> Params {
        Params {
            h: 2.0 / (1u64 << depth) as f32,
            dmax: quant::voxel_diagonal(depth),
            bits,
            max_voxels,
            accept: 0.08,
            thin: 0.2,
            earn: 0.03,
            voxel_cost: 0.01,
            reach_tol: 0.05,
        }
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

/// A fixed direction in no symmetry plane of a grid: orients the thin split's reference normal.
const CANONICAL: Vec3 = Vec3::new(0.534_522_5, 0.617_213_4, 0.577_350_3);

/// Faces whose normal makes `|cos| <` this with the thin split's reference normal are side faces.
const RIM_DOT: f32 = 0.3;

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
struct Cand {
    c: [f32; 8],
    q: [f32; 8],
    surface: bool,
    comp: u32,
}

/// Reusable buffers of one worker (no allocation per leaf after warm-up).
#[derive(Default)]
pub struct Scratch {
    samples: Vec<Vec3>,
    sample_tri: Vec<u32>,
    sets: UnionFind,
    edges: Vec<(u64, u32)>,
    comp_of: Vec<u32>,
    comp_tris: Vec<Vec<u32>>,
    group_a: Vec<u32>,
    group_b: Vec<u32>,
    cands: Vec<Cand>,
    qs: Vec<[f32; 8]>,
    surf: Vec<bool>,
    zeros: Vec<Vec3>,
}

/// The SVO leaf: the global-distance voxel if its quantised corners change sign.
#[inline]
pub fn svo_leaf(p: &Params, g: &[f32; 8]) -> LeafResult {
    if p.crosses(g) {
        LeafResult {
            voxels: vec![Voxel {
                corners: *g,
                surface: false,
            }],
            cap_hit: false,
        }
    } else {
        LeafResult::default()
    }
}

/// The multi-octree leaf at cell `coord` with gathered triangles `tris` and global corners `g`.
pub fn multi_leaf(
    p: &Params,
    mesh: &LocalMesh,
    global: &Components,
    coord: [u32; 3],
    tris: &[u32],
    g: &[f32; 8],
    s: &mut Scratch,
) -> LeafResult {
    let h = p.h;
    let lo = Vec3::new(coord[0] as f32, coord[1] as f32, coord[2] as f32) * h - Vec3::ONE;
    let hi = lo + Vec3::splat(h);
    let inv_h = 1.0 / h;

    // 1. Samples of the true surface inside the cell, in local coordinates.
    s.samples.clear();
    s.sample_tri.clear();
    let rich = tris.len() <= 16;
    let mut poly = [Vec3::ZERO; MAX_CLIP + 1];
    for (li, &t) in tris.iter().enumerate() {
        let (blo, bhi) = mesh.bbox[t as usize];
        let n = if blo.cmpge(lo).all() && bhi.cmple(hi).all() {
            poly[..3].copy_from_slice(&mesh.tris[t as usize]);
            3
        } else if blo.cmpgt(hi).any() || bhi.cmplt(lo).any() {
            0
        } else {
            clip_triangle(mesh.tris[t as usize], lo, hi, &mut poly)
        };
        if n == 0 {
            continue;
        }
        let mut centroid = Vec3::ZERO;
        for v in &poly[..n] {
            centroid += *v;
        }
        centroid /= n as f32;
        let cl = (centroid - lo) * inv_h;
        s.samples.push(cl);
        s.sample_tri.push(li as u32);
        for v in &poly[..n] {
            let vl = (*v - lo) * inv_h;
            s.samples.push(vl);
            s.sample_tri.push(li as u32);
            if rich {
                s.samples.push((vl + cl) * 0.5);
                s.sample_tri.push(li as u32);
            }
        }
    }
    if s.samples.is_empty() {
        return svo_leaf(p, g);
    }

    // 2. The SVO voxel.
    let gq = p.q8(g);
    let mut svo_max = 0.0f32;
    let mut svo_sum = 0.0f32;
    for l in &s.samples {
        let e = (trilinear(&gq, *l).abs() * inv_h).min(1.0);
        // Acceptance by the distance to the zero set, not |f|: a collapsed gradient (a plate
        // thinner than the cell) has small |f| on the faces and no zero set through them.
        svo_max = svo_max.max(zero_set_gap(&gq, *l, h));
        svo_sum += e;
    }
    let open_near = tris.iter().any(|&t| mesh.boundary[t as usize] != 0);
    if svo_max <= p.accept && !open_near {
        return svo_leaf(p, g);
    }
    let svo_mean = svo_sum / s.samples.len() as f32;

    // 3. Components through shared welded edges (same part only).
    let n = tris.len();
    s.sets.reset(n);
    s.edges.clear();
    for (li, &t) in tris.iter().enumerate() {
        let v = mesh.vids[t as usize];
        for k in 0..3 {
            let a = v[k];
            let b = v[(k + 1) % 3];
            if a != b {
                s.edges
                    .push((((a.min(b) as u64) << 32) | a.max(b) as u64, li as u32));
            }
        }
    }
    s.edges.sort_unstable();
    for w in 0..s.edges.len().saturating_sub(1) {
        let (ka, ta) = s.edges[w];
        let (kb, tb) = s.edges[w + 1];
        if ka == kb
            && mesh.parts[tris[ta as usize] as usize] == mesh.parts[tris[tb as usize] as usize]
        {
            // The smaller root wins (UnionFind's rule): deterministic.
            s.sets.union(ta, tb);
        }
    }
    // Pieces of one global component are merged back: a piece of a closed surface cut out by
    // the leaf (one face of a plate thinner than the cell, the two arms of a bend) is not a
    // closed surface, and its own signed distance is a half-space that swallows its sibling
    // piece (measured on abc5 at depth 8: false hits along the panel's silhouette, −1.6 dB).
    // Thin elements are split again below, by opposing normals, into surface voxels.
    s.edges.clear();
    for (li, &t) in tris.iter().enumerate() {
        s.edges
            .push((global.of_triangle[t as usize] as u64, li as u32));
    }
    s.edges.sort_unstable();
    for w in 0..s.edges.len().saturating_sub(1) {
        let (ga, ta) = s.edges[w];
        let (gb, tb) = s.edges[w + 1];
        if ga == gb {
            s.sets.union(ta, tb);
        }
    }
    // Component ids in order of first triangle.
    let k = s.sets.labels_into(&mut s.comp_of);
    while s.comp_tris.len() < k {
        s.comp_tris.push(Vec::new());
    }
    for c in s.comp_tris.iter_mut().take(k) {
        c.clear();
    }
    for (li, &t) in tris.iter().enumerate() {
        s.comp_tris[s.comp_of[li] as usize].push(t);
    }

    // One (or two) voxels per component.
    s.cands.clear();
    let corner_pos: [Vec3; 8] = std::array::from_fn(|i| lo + corner_offset(i) * h);
    for ci in 0..k {
        let ctris = &s.comp_tris[ci];
        // Does this component reach into the cell at all?
        if !s
            .sample_tri
            .iter()
            .any(|&li| s.comp_of[li as usize] == ci as u32)
        {
            continue;
        }
        // An open component signs by its own pseudo-normals (a boundary edge's is its face's):
        // the global sign (winding number near borders) jumps there.
        let open = ctris.iter().any(|&t| mesh.boundary[t as usize] != 0);
        let c: [f32; 8] = if k == 1 && !open {
            *g
        } else {
            // Exact distance to the whole global component.
            let gid = global.of_triangle[ctris[0] as usize];
            corner_pos.map(|x| global.signed_distance(mesh, gid, x, ctris[0]))
        };
        let q = p.q8(&c);
        let mut err = 0.0f32;
        for (l, &li) in s.samples.iter().zip(&s.sample_tri) {
            if s.comp_of[li as usize] == ci as u32 {
                err = err.max(zero_set_gap(&q, *l, h));
            }
        }
        if err > p.thin && ctris.len() >= 2 {
            // Split by opposing normals: reference = the largest triangle's normal.
            let mut best = ctris[0];
            for &t in ctris.iter() {
                if mesh.area2[t as usize] > mesh.area2[best as usize] {
                    best = t;
                }
            }
            // Oriented canonically (towards a fixed generic direction), so that which face is
            // group A does not depend on which of equally large triangles came first.
            let nref = mesh.face_normal[best as usize];
            let nref = if nref.dot(CANONICAL) < 0.0 {
                -nref
            } else {
                nref
            };
            s.group_a.clear();
            s.group_b.clear();
            for &t in ctris.iter() {
                let d = mesh.face_normal[t as usize].dot(nref);
                // Side faces (the rim, normal about perpendicular) belong to neither face: their
                // side would flip with a rounding of the normal.
                if d >= RIM_DOT {
                    s.group_a.push(t);
                } else if d <= -RIM_DOT {
                    s.group_b.push(t);
                }
            }
            // Only a genuinely thin element: the two faces must be nearly opposite (a sharp
            // edge has its faces at an angle and must never be split: fins).
            let mean = |g: &[u32]| {
                g.iter()
                    .map(|&t| mesh.face_normal[t as usize] * mesh.area2[t as usize])
                    .sum::<Vec3>()
                    .normalize_or_zero()
            };
            let opposite = mean(&s.group_a).dot(mean(&s.group_b)) < -0.8;
            if opposite && !s.group_a.is_empty() && !s.group_b.is_empty() {
                let ca = corner_pos.map(|x| mesh.signed_distance_subset(&s.group_a, x));
                let cb = corner_pos.map(|x| mesh.signed_distance_subset(&s.group_b, x));
                let qa = p.q8(&ca);
                let qb = p.q8(&cb);
                let mut err2 = 0.0f32;
                for (l, &li) in s.samples.iter().zip(&s.sample_tri) {
                    if s.comp_of[li as usize] == ci as u32 {
                        let e = zero_set_gap(&qa, *l, h).min(zero_set_gap(&qb, *l, h));
                        err2 = err2.max(e);
                    }
                }
                // Faces that coincide to within the file's rounding (the two voxels are exact
                // negatives: a zero-thickness fin or double wall) are one surface: the split adds
                // nothing but the fin's normal where it meets a wall (abc1: −0.13 dB at depth 8).
                let coincident = (0..8).all(|i| qa[i] == -qb[i]);
                if err2 < 0.5 * err && !coincident {
                    s.cands.push(Cand {
                        c: ca,
                        q: qa,
                        surface: true,
                        comp: ci as u32,
                    });
                    s.cands.push(Cand {
                        c: cb,
                        q: qb,
                        surface: true,
                        comp: ci as u32,
                    });
                    continue;
                }
            }
        }
        s.cands.push(Cand {
            c,
            q,
            surface: open,
            comp: ci as u32,
        });
    }
    if k == 1 && s.cands.len() == 1 && !s.cands[0].surface {
        // One component, one volume voxel: that is the SVO voxel.
        return svo_leaf(p, g);
    }

    // 4. Reduction: voxels that cannot be hit, hidden voxels, then the cap.
    s.cands.retain(|c| p.crosses(&c.q));
    let bury = 0.05 * h;
    let mut i = 0;
    while i < s.cands.len() {
        let me = s.cands[i];
        let mut any = false;
        let mut hidden = true;
        for (l, &li) in s.samples.iter().zip(&s.sample_tri) {
            if s.comp_of[li as usize] != me.comp {
                continue;
            }
            any = true;
            let inside = s.cands.iter().enumerate().any(|(j, o)| {
                j != i && !o.surface && o.comp != me.comp && trilinear(&o.q, *l) < -bury
            });
            if !inside {
                hidden = false;
                break;
            }
        }
        if any && hidden {
            s.cands.remove(i);
        } else {
            i += 1;
        }
    }
    let mut cap_hit = false;
    if s.cands.len() > p.max_voxels {
        cap_hit = true;
        reduce(p, &mut s.cands);
    }
    if s.cands.is_empty() {
        return svo_leaf(p, g);
    }

    // 5. Earn its place: score both on the same samples and grid.
    let mut m_sum = 0.0f32;
    for l in &s.samples {
        let mut near = f32::INFINITY;
        let mut deepest = 0.0f32;
        for c in &s.cands {
            let f = trilinear(&c.q, *l);
            near = near.min(f.abs());
            if !c.surface {
                deepest = deepest.max(-f);
            }
        }
        m_sum += (near.max(deepest) * inv_h).min(1.0);
    }
    let multi_mean = m_sum / s.samples.len() as f32;
    let svo_crosses = p.crosses(g);
    let mut false_m = 0.0f32;
    let mut false_s = 0.0f32;
    let cap = h;
    for gi in 0..27 {
        let l = Vec3::new((gi / 9) as f32, ((gi / 3) % 3) as f32, (gi % 3) as f32) * 0.25
            + Vec3::splat(0.25);
        let x = lo + l * h;
        let u = mesh.unsigned_distance_subset(tris, x, cap);
        let rm = s
            .cands
            .iter()
            .map(|c| trilinear(&c.q, l).abs())
            .fold(f32::INFINITY, f32::min);
        false_m += ((u - rm - 0.1 * h).max(0.0) * inv_h).min(1.0);
        if svo_crosses {
            let rs = trilinear(&gq, l).abs();
            false_s += ((u - rs - 0.1 * h).max(0.0) * inv_h).min(1.0);
        }
    }
    false_m /= 27.0;
    false_s /= 27.0;
    let svo_score = if svo_crosses { svo_mean + false_s } else { 1.0 };
    let multi_score = multi_mean + false_m + p.voxel_cost * (s.cands.len() as f32 - 1.0);
    // The zero sets themselves: how far from the true surface does each set's visible zero set
    // reach inside the cell? A multi set reaching farther than the SVO voxel (the plane of a
    // plate's face voxel running past the plate's rim) renders false hits the SVO does not.
    let keep = multi_score + p.earn < svo_score && {
        let reach_s = if svo_crosses {
            zero_reach(mesh, tris, lo, h, std::slice::from_ref(&gq), &[false], s)
        } else {
            0.0
        };
        s.qs.clear();
        s.surf.clear();
        for c in &s.cands {
            s.qs.push(c.q);
            s.surf.push(c.surface);
        }
        let qs = std::mem::take(&mut s.qs);
        let surf = std::mem::take(&mut s.surf);
        let reach_m = zero_reach(mesh, tris, lo, h, &qs, &surf, s);
        s.qs = qs;
        s.surf = surf;
        reach_m <= reach_s + p.reach_tol * h
    };
    if keep {
        LeafResult {
            voxels: s
                .cands
                .iter()
                .map(|c| Voxel {
                    corners: c.c,
                    surface: c.surface,
                })
                .collect(),
            cap_hit,
        }
    } else {
        let mut r = svo_leaf(p, g);
        r.cap_hit = cap_hit;
        r
    }
}

/// Lines per axis (per direction of the cell face) on which [`zero_reach`] finds the zero sets.
const REACH_LINES: usize = 4;

/// The largest true unsigned distance (world units, capped at `h`) from the visible zero set
/// of the voxels `qs` (quantised corners; `surf` = surface flags) to the gathered triangles
/// `tris`, over the zero crossings on `REACH_LINES`² axis-parallel lines per axis through the
/// cell at `lo`. Along such a line the trilinear interpolant is linear, so each voxel crosses
/// zero at most once there, exactly where the file's interpolant does. A crossing buried inside
/// another volume voxel (negative there) is hidden and does not count.
fn zero_reach(
    mesh: &LocalMesh,
    tris: &[u32],
    lo: Vec3,
    h: f32,
    qs: &[[f32; 8]],
    surf: &[bool],
    s: &mut Scratch,
) -> f32 {
    s.zeros.clear();
    let step = 1.0 / REACH_LINES as f32;
    for axis in 0..3 {
        for i in 0..REACH_LINES {
            for j in 0..REACH_LINES {
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
                    let hidden = qs
                        .iter()
                        .zip(surf)
                        .enumerate()
                        .any(|(wi, (o, &os))| wi != vi && !os && trilinear(o, l) < -0.02 * h);
                    if !hidden {
                        s.zeros.push(l);
                    }
                }
            }
        }
    }
    let mut reach = 0.0f32;
    for &l in &s.zeros {
        reach = reach.max(mesh.unsigned_distance_subset(tris, lo + l * h, h));
    }
    reach
}

/// Reduces `cands` to `p.max_voxels`: merge the most similar volume voxels (min = union), then
/// the most nearly coplanar surface voxels (average of the two, oriented alike), then drop the
/// last ones.
fn reduce(p: &Params, cands: &mut Vec<Cand>) {
    let diff = |a: &[f32; 8], b: &[f32; 8], s: f32| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - s * y).abs())
            .fold(0.0f32, f32::max)
    };
    while cands.len() > p.max_voxels {
        // Most similar pair of the same kind, volume pairs first.
        let mut best: Option<(usize, usize, f32, f32)> = None;
        for surface in [false, true] {
            for i in 0..cands.len() {
                if cands[i].surface != surface {
                    continue;
                }
                for j in i + 1..cands.len() {
                    if cands[j].surface != surface {
                        continue;
                    }
                    let (d, sg) = if surface {
                        let dp = diff(&cands[i].c, &cands[j].c, 1.0);
                        let dn = diff(&cands[i].c, &cands[j].c, -1.0);
                        if dn < dp {
                            (dn, -1.0)
                        } else {
                            (dp, 1.0)
                        }
                    } else {
                        (diff(&cands[i].c, &cands[j].c, 1.0), 1.0)
                    };
                    if best.is_none_or(|b| d < b.2) {
                        best = Some((i, j, d, sg));
                    }
                }
            }
            if best.is_some() {
                break;
            }
        }
        let Some((i, j, _, sg)) = best else {
            cands.truncate(p.max_voxels);
            break;
        };
        let b = cands.remove(j);
        let a = &mut cands[i];
        for k in 0..8 {
            a.c[k] = if a.surface {
                0.5 * (a.c[k] + sg * b.c[k])
            } else {
                a.c[k].min(b.c[k])
            };
        }
        a.q = p.q8(&a.c);
    }
}

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
    fn reduce_merges_volume_then_surface() {
        let p = Params::new(4, ValueBits::Eight, 2);
        let mk = |v: f32, surface: bool| Cand {
            c: [v; 8],
            q: [v; 8],
            surface,
            comp: 0,
        };
        let mut c = vec![
            mk(0.1, false),
            mk(0.2, false),
            mk(0.5, true),
            mk(-0.5, true),
        ];
        reduce(&p, &mut c);
        assert_eq!(c.len(), 2);
        assert!(!c[0].surface && c[0].c[0] == 0.1);
        // The two surface voxels are F and −F: they merge with orientation into one.
        assert!(c[1].surface && (c[1].c[0].abs() - 0.5).abs() < 1e-6);
    }
}
