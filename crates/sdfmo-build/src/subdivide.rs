//! Top-down subdivision: the cells at the target depth that touch the surface, each with the
//! triangles near it.
//!
//! A node keeps the triangles that overlap its box inflated by the *gathering margin* (exact SAT
//! test, the `tribox` module); its children filter that list. Since the margin is an absolute
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
use sdfmo_format::cell_size;

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
    /// The first (lowest-index) triangle touching the cell within the *candidate* margin: the
    /// seed of the corners' closest-point queries. It does not depend on the gather margin, so
    /// the SVO and the multi-octree break exact distance ties alike (same corners, same signs).
    pub hint: u32,
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
        let s = cell_size(level);
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

    /// Distributes `tris` (the triangles of node `(level, coord)`) over its eight children in
    /// one pass and recurses into them in octant order. `bufs[l]` holds the eight child lists
    /// of level `l` (reused: no allocation once warm).
    fn recurse(
        &self,
        level: u8,
        coord: [u32; 3],
        tris: &[u32],
        bufs: &mut [[Vec<u32>; 8]],
        out: &mut Subdivision,
    ) {
        if level == self.depth {
            let (center, half) = self.cell(level, coord);
            let first = tris
                .iter()
                .find(|&&t| self.overlaps(t, center, half + self.candidate));
            if let Some(&hint) = first {
                let s = out.tris.len() as u32;
                out.tris.extend_from_slice(tris);
                out.cells.push(Candidate {
                    coord,
                    start: s,
                    len: tris.len() as u32,
                    hint,
                });
            }
            return;
        }
        out.inner_nodes += 1;
        let (center, half) = self.cell(level, coord);
        let ch = 0.5 * half; // child half size
        let g = self.gather;
        let (mine, rest) = bufs.split_first_mut().expect("one buffer set per level");
        for b in mine.iter_mut() {
            b.clear();
        }
        for &t in tris {
            let (lo, hi) = self.mesh.bbox[t as usize];
            // Which halves of each axis the (inflated) children may share with the bbox.
            let lo_side = lo.cmple(center + Vec3::splat(g)).bitmask(); // touches the low child
            let hi_side = hi.cmpge(center - Vec3::splat(g)).bitmask(); // touches the high child
            for (octant, list) in mine.iter_mut().enumerate() {
                // octant bits: x = 4, y = 2, z = 1; bitmask bits: x = 1, y = 2, z = 4.
                let bx = (octant >> 2) & 1;
                let by = (octant >> 1) & 1;
                let bz = octant & 1;
                let ok = |bit: usize, high: usize| {
                    if high == 1 {
                        hi_side & (1 << bit) != 0
                    } else {
                        lo_side & (1 << bit) != 0
                    }
                };
                if !(ok(0, bx) && ok(1, by) && ok(2, bz)) {
                    continue;
                }
                let cc = center
                    + Vec3::new(
                        bx as f32 * 2.0 - 1.0,
                        by as f32 * 2.0 - 1.0,
                        bz as f32 * 2.0 - 1.0,
                    ) * ch;
                if self.overlaps(t, cc, ch + g) {
                    list.push(t);
                }
            }
        }
        for octant in 0..8u32 {
            if mine[octant as usize].is_empty() {
                continue;
            }
            let list = std::mem::take(&mut mine[octant as usize]);
            self.recurse(level + 1, child(coord, octant), &list, rest, out);
            mine[octant as usize] = list;
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
            let mut bufs: Vec<[Vec<u32>; 8]> = (split..depth).map(|_| Default::default()).collect();
            ctx.recurse(split, coord, &tris, &mut bufs, &mut out);
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

#[cfg(test)]
mod tests {
    use super::*;
    use sdfmo_mesh::procedural;

    /// The cells and their closest-point seeds do not depend on the gather margin: the SVO and
    /// the multi-octree compute the same corners (exact distance ties broken alike).
    #[test]
    fn cells_and_hints_do_not_depend_on_the_gather_margin() {
        let (m, _) = procedural::demo_part().normalized(0.05);
        let local = LocalMesh::new(&m);
        let depth = 5;
        let h = cell_size(depth);
        let candidate = 0.02 * h;
        let svo = subdivide(&local, depth, candidate, candidate);
        let multi = subdivide(&local, depth, 0.3 * h, candidate);
        assert!(!svo.cells.is_empty());
        assert_eq!(svo.cells.len(), multi.cells.len());
        let mut wider = 0;
        for (a, b) in svo.cells.iter().zip(&multi.cells) {
            assert_eq!(a.coord, b.coord);
            assert_eq!(a.hint, b.hint, "cell {:?}", a.coord);
            // The seed touches the cell and is the lowest such triangle of the SVO's list.
            assert_eq!(a.hint, svo.tris_of(a)[0]);
            assert!(multi.tris_of(b).contains(&b.hint));
            wider += (b.len > a.len) as usize;
        }
        // The wider gather does change the lists (else the test would not test anything).
        assert!(wider > 0);
    }
}
