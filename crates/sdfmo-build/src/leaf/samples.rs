//! Phase 1: points of the true surface inside the leaf, and how well the SVO voxel fits them.

use glam::Vec3;

use super::{Cell, LeafCtx, Params, Scratch};
use crate::geom::{clip_triangle, trilinear, zero_set_gap, MAX_CLIP};
use crate::local::LocalMesh;

/// Points of the true surface inside a leaf, in the cell's local coordinates (`[0, 1]³`), each
/// with the index (into the leaf's gathered triangles) of the triangle it lies on.
#[derive(Clone, Debug, Default)]
pub(crate) struct Samples {
    /// Local coordinates.
    pub points: Vec<Vec3>,
    /// Gathered-triangle index of each point.
    pub triangle: Vec<u32>,
}

impl Samples {
    /// Replaces the samples with those of the gathered triangles `tris` in `cell`: every
    /// triangle clipped to the cell gives its polygon's centroid and vertices and, while there
    /// are at most [`LeafParams::rich_samples_below`] triangles, the centroid–vertex midpoints.
    pub fn collect(&mut self, p: &Params, mesh: &LocalMesh, cell: &Cell, tris: &[u32]) {
        self.points.clear();
        self.triangle.clear();
        let rich = tris.len() <= p.rich_samples_below;
        let (lo, hi) = (cell.lo, cell.hi);
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
            let cl = (centroid - lo) * cell.inv_h;
            self.push(cl, li);
            for v in &poly[..n] {
                let vl = (*v - lo) * cell.inv_h;
                self.push(vl, li);
                if rich {
                    self.push((vl + cl) * 0.5, li);
                }
            }
        }
    }

    fn push(&mut self, l: Vec3, triangle: usize) {
        self.points.push(l);
        self.triangle.push(triangle as u32);
    }

    /// No triangle reaches into the cell.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// The samples with the gathered-triangle index of each.
    pub fn iter(&self) -> impl Iterator<Item = (Vec3, u32)> + '_ {
        self.points
            .iter()
            .copied()
            .zip(self.triangle.iter().copied())
    }
}

/// Phase 1: the leaf's samples into `s.samples` and, where there are some, the SVO voxel's fit
/// to them into `s.svo`.
pub(crate) fn collect(ctx: &LeafCtx, s: &mut Scratch) {
    s.samples.collect(ctx.p, ctx.mesh, &ctx.cell, ctx.tris);
    if !s.samples.is_empty() {
        s.svo = svo_fit(&ctx.gq, &s.samples, &ctx.cell);
    }
}

/// How well one voxel (quantised corners) fits the samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct SvoFit {
    /// Largest distance (cell edges, ≤ 1) from a sample to the voxel's zero set.
    pub max_gap: f32,
    /// Mean `|f|` at the samples (cell edges, each capped at 1).
    pub mean_error: f32,
}

/// The fit of the voxel `gq` to `samples`. Acceptance uses the distance to the zero set, not
/// `|f|`: a collapsed gradient (a plate thinner than the cell) has small `|f|` on the faces and
/// no zero set through them.
pub(crate) fn svo_fit(gq: &[f32; 8], samples: &Samples, cell: &Cell) -> SvoFit {
    let mut max_gap = 0.0f32;
    let mut sum = 0.0f32;
    for &l in &samples.points {
        sum += (trilinear(gq, l).abs() * cell.inv_h).min(1.0);
        max_gap = max_gap.max(zero_set_gap(gq, l, cell.h));
    }
    SvoFit {
        max_gap,
        mean_error: sum / samples.len() as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::leaf::test_meshes::{Fixture, Leaf};
    use sdfmo_format::ValueBits;
    use sdfmo_mesh::procedural;

    /// A box of half-edge 0.3 and its depth-3 leaf containing `point`.
    fn box_leaf(point: Vec3) -> (Fixture, Params, Leaf) {
        let f = Fixture::new(procedural::box_mesh(Vec3::splat(-0.3), Vec3::splat(0.3)));
        let p = Params::new(3, ValueBits::Eight, 8);
        let leaf = f.leaf(&p, point);
        (f, p, leaf)
    }

    #[test]
    fn samples_lie_on_the_clipped_surface() {
        // A box face crossing the cell: every sample is on the face plane, inside the cell.
        let (f, p, leaf) = box_leaf(Vec3::new(0.3, 0.1, 0.1));
        let s = leaf.samples(&f, &p);
        assert!(s.len() >= 4);
        for (l, t) in s.iter() {
            assert!(l.cmpge(Vec3::splat(-1e-5)).all() && l.cmple(Vec3::splat(1.0 + 1e-5)).all());
            let x = leaf.cell.at(l);
            assert!((x.x - 0.3).abs() < 1e-5, "{x}");
            assert!((t as usize) < leaf.tris.len());
        }
    }

    #[test]
    fn midpoints_only_for_few_triangles() {
        let (f, mut p, leaf) = box_leaf(Vec3::new(0.3, 0.1, 0.1));
        let rich = leaf.samples(&f, &p);
        p.t.rich_samples_below = 0;
        let plain = leaf.samples(&f, &p);
        // Per polygon of n vertices: 1 + n samples, plus n midpoints when rich.
        let polygons = rich.len() - plain.len();
        assert!(polygons > 0);
        assert_eq!(plain.len() + polygons, rich.len());
        assert!(plain.points.iter().all(|p| rich.points.contains(p)));
    }

    #[test]
    fn a_cell_off_the_surface_has_no_samples() {
        let (f, p, leaf) = box_leaf(Vec3::new(0.8, 0.8, 0.8));
        let mut s = Samples::default();
        s.collect(&p, &f.mesh, &leaf.cell, &f.all_triangles());
        assert!(s.is_empty());
    }

    #[test]
    fn a_plane_fits_exactly_and_a_shifted_one_does_not() {
        let cell = Cell::new([0, 0, 0], 1.0);
        let mut s = Samples::default();
        for i in 0..5 {
            s.push(Vec3::new(0.5, 0.2 * i as f32, 0.3), 0);
        }
        let plane: [f32; 8] = std::array::from_fn(|i| crate::geom::corner_offset(i).x - 0.5);
        let fit = svo_fit(&plane, &s, &cell);
        assert!(fit.max_gap < 1e-6 && fit.mean_error < 1e-6);
        let shifted = plane.map(|v| v + 0.25);
        let fit = svo_fit(&shifted, &s, &cell);
        assert!((fit.max_gap - 0.25).abs() < 1e-5, "{fit:?}");
        assert!((fit.mean_error - 0.25).abs() < 1e-5, "{fit:?}");
    }
}
