//! Phase 4 of the leaf decision (see the parent module).
//!
//! Free space between a leaf's components: points that lie outside every component, between two
//! of them, where the one voxel for both says *inside* (a gap narrower than a voxel, closed).
//!
//! The surface samples cannot see a closed gap: the single voxel's zero set may pass near every
//! one of them and still fill the space between two parts, so a ray along the gap stops in this
//! leaf. The gap points are taken between the parts, not on them: for a surface sample of one
//! component, the midpoint to its closest point on another component of the leaf, kept when it
//! lies in the cell, clear of both surfaces by [`LeafParams::gap_min`] of the cell edge, and outside
//! every closed component of the leaf (true sign from the components' exact signed distances).
//! Only closed components are paired: an open one has no inside, so whether the space next to
//! it is free is not known (the inside of an open teapot body is not a gap).
//! Whatever the grid's alignment, a gap crossing the cell has such points in it.

use glam::Vec3;

use super::samples::Samples;
use super::split::LeafComponents;
use super::{Cand, LeafCtx, Params, Scratch};
use crate::components::Components;
use crate::geom::trilinear;
use crate::local::LocalMesh;

/// Phase 4: the gap points of the leaf into `s.gaps`: none where the SVO voxel does not cross
/// zero (the leaf would be dropped: it closes nothing).
pub(crate) fn collect(ctx: &LeafCtx, s: &mut Scratch) {
    if ctx.p.crosses(ctx.g) {
        s.gaps.collect(ctx, &s.samples, &s.components);
    } else {
        s.gaps.points.clear();
    }
}

/// Points of the free space between a leaf's components, local coordinates (`[0, 1]³`).
#[derive(Clone, Debug, Default)]
pub(crate) struct GapPoints {
    /// Local coordinates.
    pub points: Vec<Vec3>,
}

impl GapPoints {
    /// Replaces the points with those between the components `comps` of the leaf that its SVO
    /// voxel (quantised corners `ctx.gq`) calls inside: the gap it closes (at most
    /// [`LeafParams::gap_samples`] surface samples per component are paired). Empty when the leaf
    /// holds fewer than two closed components. The cheap test (the voxel's sign) comes first,
    /// the exact one (free space) only where the voxel says inside.
    pub fn collect(&mut self, ctx: &LeafCtx, samples: &Samples, comps: &LeafComponents) {
        let LeafCtx {
            p,
            mesh,
            global,
            cell,
            gq: svo,
            ..
        } = *ctx;
        let (cell, svo) = (&cell, &svo);
        self.points.clear();
        let k = comps.count;
        if k < 2 {
            return;
        }
        let min_gap = p.gap_min * cell.h;
        let closed = |c: u32| !global.open[comps.global_ids[c as usize] as usize];
        for a in (0..k as u32).filter(|&a| closed(a)) {
            let of_a = || {
                samples
                    .iter()
                    .filter(move |&(_, li)| comps.of[li as usize] == a)
            };
            // A fixed stride over the component's samples: deterministic, bounded work.
            let stride = of_a().count().div_ceil(p.gap_samples.max(1)).max(1);
            for (l, _) in of_a().step_by(stride) {
                let x = cell.at(l);
                for b in (0..k as u32).filter(|&b| closed(b)) {
                    if b == a {
                        continue;
                    }
                    // Gaps up to twice the gather margin: their midpoints lie within the
                    // margin of both sides, where the gathered triangles give exact distances.
                    let members = &comps.members[b as usize];
                    let Some(c) = mesh.closest_point_subset(members, x, 2.0 * p.gather) else {
                        continue;
                    };
                    if (c - x).length() < 2.0 * min_gap {
                        continue;
                    }
                    let m = (x + c) * 0.5;
                    let lm = (m - cell.lo) * cell.inv_h;
                    if lm.cmplt(Vec3::ZERO).any() || lm.cmpgt(Vec3::ONE).any() {
                        continue;
                    }
                    if trilinear(svo, lm) < 0.0 && is_free(p, mesh, global, comps, m, min_gap) {
                        self.points.push(lm);
                    }
                }
            }
        }
    }

    /// How many gap points some volume voxel of `cands` (quantised corners) calls inside.
    pub fn closed_by_set(&self, cands: &[Cand]) -> usize {
        self.points
            .iter()
            .filter(|&&l| cands.iter().any(|c| !c.surface && trilinear(&c.q, l) < 0.0))
            .count()
    }
}

/// Whether `m` (a point of the cell) lies at least `min_gap` from every component of the leaf
/// and outside each closed one (open components have no inside). Within the gather margin the
/// leaf's own triangles give the exact signed distance; farther, or at a feature whose
/// pseudo-normal does not sign reliably, the component's distance structure does.
fn is_free(
    p: &Params,
    mesh: &LocalMesh,
    global: &Components,
    comps: &LeafComponents,
    m: Vec3,
    min_gap: f32,
) -> bool {
    (0..comps.count).all(|c| {
        let members = &comps.members[c];
        let gid = comps.global_ids[c];
        if global.open[gid as usize] {
            mesh.unsigned_distance_subset(members, m, min_gap) >= min_gap
        } else {
            let d = mesh
                .signed_distance_near(members, m, p.gather)
                .unwrap_or_else(|| global.signed_distance(mesh, gid, m, members[0]));
            d >= min_gap
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::leaf::test_meshes::{two_boxes, Fixture};
    use sdfmo_format::ValueBits;
    use sdfmo_mesh::{procedural, TriMesh};

    fn gaps_of(f: &Fixture, p: &Params, at: Vec3) -> (GapPoints, crate::leaf::test_meshes::Leaf) {
        let leaf = f.leaf(p, at);
        let samples = leaf.samples(f, p);
        let mut comps = LeafComponents::default();
        comps.find(&f.global, &leaf.tris);
        let mut g = GapPoints::default();
        g.collect(&leaf.ctx(f, p), &samples, &comps);
        (g, leaf)
    }

    #[test]
    fn gap_points_lie_in_the_gap_the_svo_voxel_closes() {
        let f = two_boxes(true);
        let p = Params::new(3, ValueBits::Eight, 8);
        let (g, leaf) = gaps_of(&f, &p, Vec3::new(0.1, 0.1, 0.1));
        assert!(!g.points.is_empty());
        for &l in &g.points {
            let x = leaf.cell.at(l).x;
            assert!((x - 0.1).abs() < 1e-5, "gap point at x = {x}");
        }
        // Every corner of the cell lies inside a box: the SVO voxel is negative everywhere.
        assert!(p.q8(&leaf.g).iter().all(|&v| v < 0.0));
        // The two boxes' own voxels keep every gap point outside.
        let cands = leaf.candidates(&f, &p);
        assert_eq!(cands.len(), 2);
        assert_eq!(g.closed_by_set(&cands), 0);
    }

    #[test]
    fn one_component_or_touching_parts_have_no_gap_points() {
        let p = Params::new(3, ValueBits::Eight, 8);
        let one = Fixture::new(procedural::box_mesh(Vec3::splat(-0.6), Vec3::splat(0.4)));
        assert!(gaps_of(&one, &p, Vec3::new(0.3, 0.1, 0.1))
            .0
            .points
            .is_empty());
        // Two boxes sharing the face x = 0.1: no free space between them.
        let a = procedural::box_mesh(Vec3::new(-0.5, -0.5, -0.5), Vec3::new(0.1, 0.5, 0.5));
        let b = procedural::box_mesh(Vec3::new(0.1, -0.5, -0.5), Vec3::new(0.6, 0.5, 0.5));
        let touching = Fixture::new(TriMesh::merge(&[a, b]));
        assert!(gaps_of(&touching, &p, Vec3::new(0.1, 0.1, 0.1))
            .0
            .points
            .is_empty());
    }
}
