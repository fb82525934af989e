//! Top-down subdivision: the cells at the target depth that touch the surface, each with the
//! triangles near it.
//!
//! A node keeps the triangles that overlap its box inflated by the *gathering margin* (exact SAT
//! test, [`crate::tribox`]); its children filter that list. Since the margin is an absolute
//! distance, a child's inflated box lies inside its parent's, so filtering level by level is
//! exact. A leaf is a *candidate* when some triangle overlaps it inflated by the (smaller)
//! *candidate margin*: one quantisation step, so that every leaf whose quantised interpolant may
//! reach zero is examined (a leaf farther than that from every triangle has all its corner
//! values at least one step away from zero and of one sign).
//!
//! The top levels are expanded sequentially into up to 8^3 tasks, which rayon runs in parallel;
//! the tasks' outputs are concatenated in octant order, so the result does not depend on the
//! number of threads.

use glam::Vec3;
use rayon::prelude::*;

use crate::local::LocalMesh;
use crate::tribox::tri_box_overlap;

/// A cell at the target depth that touches the surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Candidate {
    /// Integer cell coordinates in `[0, 2^depth)³`.
    pub coord: [u32; 3],
    /// Range of the cell's gathered triangles in [`Subdivision::tris`].
    pub start: u32,
    /// Number of gathered triangles.
    pub len: u32,
}

/// The candidates and their gathered triangles.
#[derive(Clone, Debug, Default)]
pub struct Subdivision {
    /// Candidates in octant (Morton) order.
    pub cells: Vec<Candidate>,
    /// Triangle indices, `cells[i].start .. start + len`.
    pub tris: Vec<u32>,
    /// Inner nodes visited (levels below the target depth that touch the surface).
    pub inner_nodes: usize,
}

impl Subdivision {
    /// The gathered triangles of candidate `i`.
    #[inline]
    pub fn tris_of(&self, c: &Candidate) -> &[u32] {
        &self.tris[c.start as usize..(c.start + c.len) as usize]
    }
}

struct Ctx<'a> {
    mesh: &'a LocalMesh,
    depth: u8,
    gather: f32,
    candidate: f32,
}

impl Ctx<'_> {
    #[inline]
    fn cell(&self, level: u8, coord: [u32; 3]) -> (Vec3, f32) {
        let s = 2.0 / (1u64 << level) as f32;
        let lo = Vec3::new(coord[0] as f32, coord[1] as f32, coord[2] as f32) * s - Vec3::ONE;
        (lo + Vec3::splat(0.5 * s), 0.5 * s)
    }

    #[inline]
    fn overlaps(&self, t: u32, center: Vec3, half: f32) -> bool {
        let (lo, hi) = self.mesh.bbox[t as usize];
        let bl = center - Vec3::splat(half);
        let bh = center + Vec3::splat(half);
        if lo.cmpgt(bh).any() || hi.cmplt(bl).any() {
            return false;
        }
        if lo.cmpge(bl).all() && hi.cmple(bh).all() {
            return true; // the triangle lies inside the box
        }
        let [a, b, c] = self.mesh.tris[t as usize];
        tri_box_overlap(center, Vec3::splat(half), a, b, c)
    }

    /// Filters `scratch[start..end]` into the children of `(level, coord)` and recurses.
    fn recurse(
        &self,
        level: u8,
        coord: [u32; 3],
        scratch: &mut Vec<u32>,
        start: usize,
        end: usize,
        out: &mut Subdivision,
    ) {
        if level == self.depth {
            let (center, half) = self.cell(level, coord);
            let touches =
                (start..end).any(|i| self.overlaps(scratch[i], center, half + self.candidate));
            if touches {
                let s = out.tris.len() as u32;
                out.tris.extend_from_slice(&scratch[start..end]);
                out.cells.push(Candidate {
                    coord,
                    start: s,
                    len: (end - start) as u32,
                });
            }
            return;
        }
        out.inner_nodes += 1;
        for octant in 0..8u32 {
            let cc = child(coord, octant);
            let (center, half) = self.cell(level + 1, cc);
            let cs = scratch.len();
            for i in start..end {
                let t = scratch[i];
                if self.overlaps(t, center, half + self.gather) {
                    scratch.push(t);
                }
            }
            let ce = scratch.len();
            if ce > cs {
                self.recurse(level + 1, cc, scratch, cs, ce, out);
            }
            scratch.truncate(cs);
        }
    }
}

#[inline]
fn child(coord: [u32; 3], octant: u32) -> [u32; 3] {
    [
        coord[0] * 2 + ((octant >> 2) & 1),
        coord[1] * 2 + ((octant >> 1) & 1),
        coord[2] * 2 + (octant & 1),
    ]
}

/// Subdivides the root `[-1, 1]³` down to `depth`; `gather` and `candidate` are absolute margins
/// (normalised units) with `candidate ≤ gather`.
pub fn subdivide(mesh: &LocalMesh, depth: u8, gather: f32, candidate: f32) -> Subdivision {
    let ctx = Ctx {
        mesh,
        depth,
        gather,
        candidate: candidate.min(gather),
    };
    // Sequential expansion of the top levels into tasks (level, coord, triangles).
    let root: Vec<u32> = (0..mesh.len() as u32)
        .filter(|&t| ctx.overlaps(t, Vec3::ZERO, 1.0 + gather))
        .collect();
    let split = depth.min(3);
    let mut tasks: Vec<([u32; 3], Vec<u32>)> = vec![([0, 0, 0], root)];
    let mut inner_top = 0usize;
    for level in 0..split {
        let mut next = Vec::with_capacity(tasks.len() * 8);
        for (coord, tris) in tasks {
            if tris.is_empty() {
                continue;
            }
            inner_top += 1;
            for octant in 0..8 {
                let cc = child(coord, octant);
                let (center, half) = ctx.cell(level + 1, cc);
                let ct: Vec<u32> = tris
                    .iter()
                    .copied()
                    .filter(|&t| ctx.overlaps(t, center, half + gather))
                    .collect();
                if !ct.is_empty() {
                    next.push((cc, ct));
                }
            }
        }
        tasks = next;
    }
    let parts: Vec<Subdivision> = tasks
        .into_par_iter()
        .map(|(coord, tris)| {
            let mut out = Subdivision::default();
            let n = tris.len();
            let mut scratch = tris;
            ctx.recurse(split, coord, &mut scratch, 0, n, &mut out);
            out
        })
        .collect();
    let mut all = Subdivision {
        cells: Vec::with_capacity(parts.iter().map(|p| p.cells.len()).sum()),
        tris: Vec::with_capacity(parts.iter().map(|p| p.tris.len()).sum()),
        inner_nodes: inner_top,
    };
    for p in parts {
        let off = all.tris.len() as u32;
        all.cells.extend(p.cells.iter().map(|c| Candidate {
            start: c.start + off,
            ..*c
        }));
        all.tris.extend_from_slice(&p.tris);
        all.inner_nodes += p.inner_nodes;
    }
    all
}
