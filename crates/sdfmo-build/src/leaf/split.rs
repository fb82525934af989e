//! Phases 2 and 5: the leaf's connected components, and one voxel (or two surface voxels) each.

use glam::Vec3;

use super::samples::Samples;
use super::{Cand, Cell, LeafCtx, Params, Scratch};
use crate::components::Components;
use crate::geom::zero_set_gap;
use crate::local::LocalMesh;

/// A fixed direction in no symmetry plane of a grid: orients the thin split's reference normal.
const CANONICAL: Vec3 = Vec3::new(0.534_522_5, 0.617_213_4, 0.577_350_3);

/// The connected components of a leaf's gathered triangles (reusable buffers).
#[derive(Clone, Debug, Default)]
pub(crate) struct LeafComponents {
    /// Global component of each leaf component, in order of first triangle.
    pub(super) global_ids: Vec<u32>,
    /// Component id per gathered triangle, numbered in order of first triangle.
    pub of: Vec<u32>,
    /// Global triangle ids of each component (the first `count` entries are live).
    pub members: Vec<Vec<u32>>,
    /// Number of components.
    pub count: usize,
    pub(super) group_a: Vec<u32>,
    pub(super) group_b: Vec<u32>,
}

impl LeafComponents {
    /// Groups `tris` (global triangle ids) by *global* component (connected through shared
    /// welded edges of one part over the whole mesh, see the `components` module): triangles
    /// connected inside the leaf are connected globally, and pieces of one global component are
    /// one leaf component. A piece of a closed surface cut out by the leaf (one face of a plate
    /// thinner than the cell, the two arms of a bend) is not closed, and its own signed
    /// distance would be a half-space that swallows its sibling piece (measured on abc5 at
    /// depth 8: false hits along the panel's silhouette, −1.6 dB). Thin elements are split
    /// again later, by opposing normals, into surface voxels. Components are numbered in order
    /// of first triangle. Returns their number.
    pub fn find(&mut self, global: &Components, tris: &[u32]) -> usize {
        self.global_ids.clear();
        self.of.clear();
        for &t in tris {
            let g = global.of_triangle[t as usize];
            // A leaf holds a handful of components: a linear scan beats a map.
            let c = match self.global_ids.iter().position(|&x| x == g) {
                Some(c) => c,
                None => {
                    self.global_ids.push(g);
                    self.global_ids.len() - 1
                }
            };
            self.of.push(c as u32);
        }
        let k = self.global_ids.len();
        while self.members.len() < k {
            self.members.push(Vec::new());
        }
        for c in self.members.iter_mut().take(k) {
            c.clear();
        }
        for (li, &t) in tris.iter().enumerate() {
            self.members[self.of[li] as usize].push(t);
        }
        self.count = k;
        k
    }

    /// Whether some sample lies on a triangle of component `c`.
    fn reaches_cell(&self, samples: &Samples, c: u32) -> bool {
        samples.triangle.iter().any(|&li| self.of[li as usize] == c)
    }

    /// Largest distance (cell edges) from a sample of component `c` to the zero set of the
    /// voxel `q` (quantised corners).
    fn error(&self, samples: &Samples, c: u32, q: &[f32; 8], h: f32) -> f32 {
        let mut err = 0.0f32;
        for (l, li) in samples.iter() {
            if self.of[li as usize] == c {
                err = err.max(zero_set_gap(q, l, h));
            }
        }
        err
    }
}

/// One voxel per component that reaches into the cell: the exact signed distance to its whole
/// global component (the SVO corners `g` when the leaf holds one closed component). An open
/// component gets a *surface* voxel signed by its own pseudo-normals (the global sign, a
/// winding number near borders, jumps there). A component its voxel does not reproduce (error
/// above [`LeafParams::thin`]) may be split into two surface voxels, see [`thin_split`].
/// Phase 5: reads `s.samples` and `s.components`, writes `s.cands`.
pub(crate) fn candidate_voxels(ctx: &LeafCtx, s: &mut Scratch) {
    let LeafCtx {
        p,
        mesh,
        global,
        cell,
        g,
        ..
    } = *ctx;
    let cell = &cell;
    let Scratch {
        samples,
        components: comps,
        cands: out,
        ..
    } = s;
    out.clear();
    let corner_pos = cell.corners();
    let k = comps.count;
    for ci in 0..k as u32 {
        if !comps.reaches_cell(samples, ci) {
            continue;
        }
        let ctris = &comps.members[ci as usize];
        let open = ctris.iter().any(|&t| mesh.boundary[t as usize] != 0);
        let c: [f32; 8] = if k == 1 && !open {
            *g
        } else {
            let gid = global.of_triangle[ctris[0] as usize];
            corner_pos.map(|x| global.signed_distance(mesh, gid, x, ctris[0]))
        };
        let q = p.q8(&c);
        let err = comps.error(samples, ci, &q, cell.h);
        if err > p.thin && ctris.len() >= 2 {
            if let Some([a, b]) = thin_split(p, mesh, cell, samples, comps, ci, err) {
                out.extend([a, b]);
                continue;
            }
        }
        out.push(Cand {
            c,
            q,
            surface: open,
            comp: ci,
        });
    }
}

/// A thin element as two surface voxels, one per face, or `None` when component `ci` is not
/// one. Its triangles are grouped by the sign of their normal against the largest triangle's
/// (oriented canonically, so a one-ulp change of the input does not regroup the faces; side
/// faces, within [`LeafParams::rim_cos`] of perpendicular, in neither group). The split is a thin
/// element only when the groups' mean normals are nearly opposite ([`LeafParams::opposite_cos`]:
/// the faces of a sharp edge are never split), it beats the one voxel's error `err` by
/// [`LeafParams::split_gain`], and the two faces do not coincide to within the file's rounding (a
/// zero-thickness fin or double wall, where the split adds nothing but the fin's normal where
/// it meets a wall: abc1 −0.13 dB at depth 8).
fn thin_split(
    p: &Params,
    mesh: &LocalMesh,
    cell: &Cell,
    samples: &Samples,
    comps: &mut LeafComponents,
    ci: u32,
    err: f32,
) -> Option<[Cand; 2]> {
    let ctris = &comps.members[ci as usize];
    let mut best = ctris[0];
    for &t in ctris.iter() {
        if mesh.area2[t as usize] > mesh.area2[best as usize] {
            best = t;
        }
    }
    let nref = mesh.face_normal[best as usize];
    let nref = if nref.dot(CANONICAL) < 0.0 {
        -nref
    } else {
        nref
    };
    comps.group_a.clear();
    comps.group_b.clear();
    for &t in ctris.iter() {
        let d = mesh.face_normal[t as usize].dot(nref);
        if d >= p.rim_cos {
            comps.group_a.push(t);
        } else if d <= -p.rim_cos {
            comps.group_b.push(t);
        }
    }
    let (group_a, group_b) = (&comps.group_a, &comps.group_b);
    let mean = |g: &[u32]| {
        g.iter()
            .map(|&t| mesh.face_normal[t as usize] * mesh.area2[t as usize])
            .sum::<Vec3>()
            .normalize_or_zero()
    };
    let opposite = mean(group_a).dot(mean(group_b)) < -p.opposite_cos;
    if !opposite || group_a.is_empty() || group_b.is_empty() {
        return None;
    }
    let corner_pos = cell.corners();
    let ca = corner_pos.map(|x| mesh.signed_distance_subset(group_a, x));
    let cb = corner_pos.map(|x| mesh.signed_distance_subset(group_b, x));
    let (qa, qb) = (p.q8(&ca), p.q8(&cb));
    let mut err2 = 0.0f32;
    for (l, li) in samples.iter() {
        if comps.of[li as usize] == ci {
            let e = zero_set_gap(&qa, l, cell.h).min(zero_set_gap(&qb, l, cell.h));
            err2 = err2.max(e);
        }
    }
    let coincident = (0..8).all(|i| qa[i] == -qb[i]);
    if err2 < p.split_gain * err && !coincident {
        let surface = |c, q| Cand {
            c,
            q,
            surface: true,
            comp: ci,
        };
        Some([surface(ca, qa), surface(cb, qb)])
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::leaf::test_meshes::{two_boxes, Fixture, Leaf};
    use sdfmo_format::ValueBits;
    use sdfmo_mesh::procedural;

    /// A plate thinner than the depth-3 cell y ∈ [0, 0.25], inside it, and that leaf.
    fn thin_plate() -> (Fixture, Params, Leaf) {
        let f = Fixture::new(procedural::box_mesh(
            Vec3::new(-0.9, 0.1, -0.9),
            Vec3::new(0.9, 0.15, 0.9),
        ));
        let p = Params::new(3, ValueBits::Eight, 8);
        let leaf = f.leaf(&p, Vec3::new(0.1, 0.12, 0.1));
        (f, p, leaf)
    }

    #[test]
    fn separate_boxes_are_separate_components() {
        for parts in [false, true] {
            let f = two_boxes(parts);
            let p = Params::new(3, ValueBits::Eight, 8);
            let leaf = f.leaf(&p, Vec3::new(0.1, 0.1, 0.1));
            let mut c = LeafComponents::default();
            assert_eq!(c.find(&f.global, &leaf.tris), 2);
            // Each component's triangles are one box's.
            for m in &c.members[..2] {
                let x = f.mesh.tris[m[0] as usize][0].x;
                assert!(m
                    .iter()
                    .all(|&t| (f.mesh.tris[t as usize][0].x < 0.1) == (x < 0.1)));
            }
        }
    }

    #[test]
    fn pieces_of_one_global_component_are_one() {
        // The leaf sees the plate's two faces as separate pieces (the rim is far outside); they
        // are one global component.
        let (f, _, leaf) = thin_plate();
        let mut c = LeafComponents::default();
        assert_eq!(c.find(&f.global, &leaf.tris), 1);
        assert_eq!(c.members[0].len(), leaf.tris.len());
        assert!(c.of.iter().all(|&k| k == 0));
    }

    #[test]
    fn a_plate_thinner_than_the_cell_splits_into_two_surface_voxels() {
        let (f, p, leaf) = thin_plate();
        let cands = leaf.candidates(&f, &p);
        assert_eq!(cands.len(), 2, "{cands:?}");
        assert!(cands.iter().all(|c| c.surface && c.comp == 0));
        // The two faces: one voxel's zero set at y = 0.1, the other's at 0.15.
        let mut planes: Vec<f32> = cands
            .iter()
            .map(|c| {
                let mid = leaf.cell.corners();
                // Zero of the interpolant along y at the cell's centre column (linear in y).
                let (a, b) = (
                    (c.c[0] + c.c[1] + c.c[4] + c.c[5]) / 4.0,
                    (c.c[2] + c.c[3] + c.c[6] + c.c[7]) / 4.0,
                );
                mid[0].y + p.h * a / (a - b)
            })
            .collect();
        planes.sort_by(f32::total_cmp);
        assert!(
            (planes[0] - 0.1).abs() < 2e-3 && (planes[1] - 0.15).abs() < 2e-3,
            "{planes:?}"
        );
        // Without the split (a gain no split can reach) it stays one volume voxel.
        let strict = Params {
            t: crate::LeafParams {
                split_gain: 0.0,
                ..p.t
            },
            ..p
        };
        let cands = leaf.candidates(&f, &strict);
        assert_eq!(cands.len(), 1);
        assert!(!cands[0].surface);
    }

    #[test]
    fn a_sharp_edge_is_never_split() {
        // The corner of a cube: faces at right angles, not opposite.
        let f = Fixture::new(procedural::box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5)));
        let mut p = Params::new(3, ValueBits::Eight, 8);
        p.t.thin = 0.0; // every voxel counts as thin: only the normals' test decides
        let leaf = f.leaf(&p, Vec3::new(0.49, 0.49, 0.1));
        let cands = leaf.candidates(&f, &p);
        assert_eq!(cands.len(), 1);
        assert!(!cands[0].surface);
    }

    #[test]
    fn an_open_sheet_gets_a_surface_voxel() {
        let f = Fixture::new(procedural::open_sheet(1.6, 1.6, 4));
        let p = Params::new(3, ValueBits::Eight, 8);
        let at = f.mesh.tris[0][0] * 0.5 + f.mesh.tris[0][1] * 0.25 + f.mesh.tris[0][2] * 0.25;
        let leaf = f.leaf(&p, at);
        let cands = leaf.candidates(&f, &p);
        assert_eq!(cands.len(), 1);
        assert!(cands[0].surface);
    }
}
