//! Closest point on the mesh: the 4-wide BVH search nearest first, with the SIMD triangle filter
//! (`closest_point`, `closest_point_within`, `closest_point_with_hint`, `unsigned_distance`).

use super::*;
use bvh4::LeafPair;
use triangle_packet::TrianglePacket;

/// Depth of the 4-wide tree up to which the search uses a small stack (a 4-wide level spans
/// about two BVH2 levels, and PLOC trees over real meshes are 30–40 levels deep).
const SHALLOW_BVH4: usize = 32;

/// What the closest-point search reads of one leaf slot, in one 64-byte cache line (the
/// sphere, the corners and the id were three arrays, so up to three cache misses per triangle).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct LeafRecord {
    /// Bounding sphere (centre, radius): skips the closest-point test of triangles that cannot
    /// beat the best distance so far.
    pub(crate) sphere: Vec4,
    /// The triangle rotated so that its vertex 0 is opposite the longest edge (see
    /// `point_triangle::apex_rotation`): the search skips the edge lengths and the three-way
    /// branch of each test.
    pub(crate) corners: [Vec3; 3],
    /// Original triangle index.
    pub(crate) id: u32,
    /// The rotation applied to `corners`.
    pub(crate) rotation: u8,
}

/// State of one closest-point search: the query and the best triangle so far.
struct Search {
    p: Vec3,
    /// Squared distance of the best triangle so far (or the caller's bound).
    best_d2: f32,
    best_d: f32,
    /// A packet whose four triangles' boxes are all farther than this (squared) is skipped:
    /// `best_d` plus a margin that covers the rounding of both distances (see
    /// [`Search::set_best`]).
    cull_d2: f32,
    /// `CULL_SLACK` × (the mesh's and the query's largest coordinate): the absolute part of
    /// the margin.
    cull_abs: f32,
    /// Leaf slot of the best triangle when the SIMD filter's distance was taken without the
    /// exact test (its closest point is computed once, at the end), else `u32::MAX` and the
    /// best is in `best`.
    best_slot: u32,
    /// The best closest point found by an exact test (or the caller's seed), `distance`
    /// squared.
    best: ClosestPoint,
}

/// Relative rounding slack of the packet box test: 16 ε is several times the error of the
/// computed box distance (≤ 2 ε relative) plus that of a triangle's computed distance (≤ 4 ε
/// of the largest coordinate involved plus 3 ε relative, Ericson's edge and face points).
const CULL_SLACK: f32 = 16.0 * f32::EPSILON;

impl Search {
    fn new(p: Vec3, best_d2: f32, best: ClosestPoint, extent: f32) -> Search {
        let mut search = Search {
            p,
            best_d2,
            best_d: 0.0,
            cull_d2: f32::INFINITY,
            cull_abs: CULL_SLACK * (extent + p.abs().max_element()),
            best_slot: u32::MAX,
            best,
        };
        search.set_best(best_d2);
        search
    }

    /// Records a new best squared distance and the packet bound that follows from it.
    #[inline(always)]
    fn set_best(&mut self, d2: f32) {
        self.best_d2 = d2;
        self.best_d = d2.sqrt();
        let cull = self.best_d * (1.0 + CULL_SLACK) + self.cull_abs;
        // (+∞ when there is no bound yet, or when squaring overflows: nothing is culled.)
        self.cull_d2 = cull * cull;
    }

    /// The result: the best closest point with its distance (no longer squared). A best taken
    /// from the SIMD filter gets its closest point from the exact test now; the filter's
    /// distance is bit-identical to that test's (see `TrianglePacket::dist2_or_zero`).
    fn finish(self, records: &[LeafRecord]) -> ClosestPoint {
        let mut best = self.best;
        if let Some(rec) = records.get(self.best_slot as usize) {
            let t = &rec.corners;
            let (q, feature) =
                point_triangle::closest_point_prerotated(self.p, t[0], t[1], t[2], rec.rotation);
            let d2 = (self.p - q).length_squared();
            debug_assert_eq!(d2.to_bits(), self.best_d2.to_bits());
            best = ClosestPoint {
                point: q,
                distance: d2,
                triangle: rec.id,
                feature,
            };
        }
        if best.triangle != u32::MAX {
            best.distance = best.distance.sqrt();
        }
        best
    }
}

impl MeshDistance {
    /// Closest point on the mesh to `p`.
    pub fn closest_point(&self, p: Vec3) -> ClosestPoint {
        self.closest_bounded(p, f32::INFINITY, ClosestPoint::NONE)
    }

    /// Closest point on the mesh to `p` if it lies strictly within `max_distance`, else a
    /// result with `distance == f32::INFINITY` ([`ClosestPoint::is_found`] is false). Much faster
    /// than [`closest_point`](Self::closest_point) when the bound is tight (the traversal prunes
    /// every box farther than the bound from the start).
    pub fn closest_point_within(&self, p: Vec3, max_distance: f32) -> ClosestPoint {
        let bound = if max_distance.is_finite() {
            max_distance * max_distance
        } else {
            f32::INFINITY
        };
        self.closest_bounded(p, bound, ClosestPoint::NONE)
    }

    /// Closest point on the mesh to `p`, with triangle `hint` (for instance the closest triangle
    /// of a neighbouring query point) tested first to start the traversal with a tight bound.
    /// Same answer as [`closest_point`](Self::closest_point) up to ties; an out-of-range hint
    /// is ignored.
    pub fn closest_point_with_hint(&self, p: Vec3, hint: u32) -> ClosestPoint {
        let Some(t) = self.tris.get(hint as usize) else {
            return self.closest_point(p);
        };
        let (q, feature) = closest_point_on_triangle(p, t[0], t[1], t[2]);
        let d2 = (p - q).length_squared();
        let seed = ClosestPoint {
            point: q,
            distance: d2,
            triangle: hint,
            feature,
        };
        // Slightly above d2 so that a tie (the hint itself) keeps the hint.
        self.closest_bounded(p, d2, seed)
    }

    /// Best-first traversal. `best_d2` is the squared bound; `best.distance` holds a squared
    /// distance during the search and is converted on return. (Tightening the bound with the
    /// children's MINMAXDIST, Roussopoulos et al. 1995, was measured: it saved no node visits on
    /// abc1 or the bunny, since the nearer-first descent finds a close leaf at once.)
    pub(crate) fn closest_bounded(
        &self,
        p: Vec3,
        best_d2: f32,
        best: ClosestPoint,
    ) -> ClosestPoint {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (detected just above).
            return unsafe { self.closest_bounded_avx(p, best_d2, best) };
        }
        self.closest_bounded_any(p, best_d2, best)
    }

    /// [`closest_bounded`](Self::closest_bounded) compiled with AVX enabled: the same code, in
    /// VEX three-operand forms (no register copy before each SSE operation), which cut abc1's
    /// signed query from 20,890 to 20,053 instructions per point (`examples/query_icount.rs`).
    /// The same IEEE operations in the same order (no FMA: Rust never fuses a multiply and an
    /// add of its own accord), so the same bits; `avx_builds_answer_like_the_generic_code`
    /// compares the two.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn closest_bounded_avx(&self, p: Vec3, best_d2: f32, best: ClosestPoint) -> ClosestPoint {
        self.closest_bounded_any(p, best_d2, best)
    }

    /// [`closest_bounded`](Self::closest_bounded) for any CPU.
    #[inline(always)]
    pub(crate) fn closest_bounded_any(
        &self,
        p: Vec3,
        best_d2: f32,
        best: ClosestPoint,
    ) -> ClosestPoint {
        // The stack holds at most three entries per level. Zeroing the one for the deepest
        // supported tree (385 entries, 4.6 kB) cost as much as the rest of a query on abc5 in
        // instruction counts, so trees of ordinary depth get a small one.
        if self.bvh4.depth <= SHALLOW_BVH4 {
            self.closest_with_stack::<{ 3 * SHALLOW_BVH4 + 1 }>(p, best_d2, best)
        } else {
            self.closest_with_stack::<{ 3 * MAX_BVH_DEPTH + 1 }>(p, best_d2, best)
        }
    }

    /// [`closest_bounded`](Self::closest_bounded) with a stack of `STACK` entries (at least
    /// three per level of the 4-wide tree, plus one).
    #[inline(always)]
    fn closest_with_stack<const STACK: usize>(
        &self,
        p: Vec3,
        best_d2: f32,
        best: ClosestPoint,
    ) -> ClosestPoint {
        let mut search = Search::new(p, best_d2, best, self.bvh4.extent);
        if !p.is_finite() {
            // NaN would make every box distance (even the empty lanes', min +∞ max −∞) 0.
            return search.finish(&self.leaf_records);
        }
        let pa = Vec3A::from(p);
        let nodes = &self.bvh4.nodes[..];
        // Each level pushes at most three siblings: (child, leaf packet count or 0, d²).
        let mut stack = [(0u32, 0u32, 0.0f32); STACK];
        let mut sp = 0usize;
        let mut ni = 0usize;
        'descend: loop {
            let node = &nodes[ni];
            let d2 = node.box_dist2(pa).to_array();
            // The lanes to enter, nearest first (insertion sort of at most four).
            let mut order = [(0.0f32, 0usize); 4];
            let mut n = 0;
            for (lane, &d) in d2.iter().enumerate() {
                if d < search.best_d2 {
                    let mut i = n;
                    while i > 0 && order[i - 1].0 > d {
                        order[i] = order[i - 1];
                        i -= 1;
                    }
                    order[i] = (d, lane);
                    n += 1;
                }
            }
            if n > 0 {
                // Farther children wait on the stack; the nearest is taken now.
                for &(d, lane) in order[1..n].iter().rev() {
                    stack[sp] = (node.child[lane], node.count[lane], d);
                    sp += 1;
                }
                let lane = order[0].1;
                if node.count[lane] == 0 {
                    ni = node.child[lane] as usize;
                    continue;
                }
                self.search_leaf(&mut search, node.child[lane], node.count[lane]);
            }
            while sp > 0 {
                sp -= 1;
                let (child, count, d) = stack[sp];
                if d >= search.best_d2 {
                    continue;
                }
                if count == 0 {
                    ni = child as usize;
                    continue 'descend;
                }
                self.search_leaf(&mut search, child, count);
            }
            break;
        }
        search.finish(&self.leaf_records)
    }

    /// Tests the triangles of a leaf (`count` packets from packet `first`; two packets: pair
    /// `first`) against the search's best so far: four at a time, first their boxes, then the
    /// SIMD filter, then the exact test where the filter leaves the distance open (face
    /// interior, degenerate triangle). A leaf of two packets (five to eight triangles) takes
    /// both in one pass of 8-wide AVX where the CPU has it: the same lanes to the bit, in the
    /// same order, so the same answer.
    #[inline(always)]
    fn search_leaf(&self, search: &mut Search, first: u32, count: u32) {
        let p = search.p;
        if count == 2 {
            let pair = &self.bvh4.pairs[first as usize];
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx") {
                let t = &pair.triangles;
                // SAFETY: the CPU has AVX (detected just above).
                let boxes = unsafe { triangle_packet::avx::boxes_within(t, p, search.cull_d2) };
                match (boxes & 0xF != 0, boxes & 0xF0 != 0) {
                    (true, true) => {
                        // SAFETY: as above.
                        let (lanes, below) = unsafe {
                            let lanes = triangle_packet::avx::dist2_or_zero(t, p);
                            (
                                lanes,
                                triangle_packet::avx::lanes_below(&lanes, search.best_d2),
                            )
                        };
                        self.take_lanes(search, &lanes[..4], &pair.slots[0], below & 0xF);
                        self.take_lanes(search, &lanes[4..], &pair.slots[1], below >> 4);
                    }
                    (true, false) => self.test_packet(search, &t.half(0), &pair.slots[0]),
                    (false, true) => self.test_packet(search, &t.half(1), &pair.slots[1]),
                    (false, false) => {}
                }
                return;
            }
            self.search_pair_4wide(search, pair);
            return;
        }
        let first = first as usize;
        for packet in &self.bvh4.packets[first..first + count as usize] {
            if packet.triangles.any_box_within(p, search.cull_d2) {
                self.test_packet(search, &packet.triangles, &packet.slots);
            }
        }
    }

    /// A leaf of two packets on any CPU: each half as a 4-wide packet, the first first.
    #[inline(always)]
    fn search_pair_4wide(&self, search: &mut Search, pair: &LeafPair) {
        for (h, slots) in pair.slots.iter().enumerate() {
            let half = pair.triangles.half(h);
            if half.any_box_within(search.p, search.cull_d2) {
                self.test_packet(search, &half, slots);
            }
        }
    }

    /// The SIMD filter and the exact tests of one packet (`triangles`, leaf slots `slots`)
    /// whose boxes were not all culled.
    #[inline(always)]
    fn test_packet(&self, search: &mut Search, triangles: &TrianglePacket, slots: &[u32; 4]) {
        let lanes = triangles.dist2_or_zero(search.p);
        let below = lanes.cmplt(Vec4::splat(search.best_d2)).bitmask();
        self.take_lanes(search, &lanes.to_array(), slots, below);
    }

    /// Takes each lane of the filter (`lanes`, the leaf slots `slots`) that beats the best so
    /// far: a vertex or edge distance as it is, a face interior or degenerate triangle (0)
    /// through its bounding sphere and the exact test. Only the lanes of `below` are looked at
    /// (bit i: lane i was below the best when the filter ran, NaN lanes not; a lane above it
    /// cannot win, as the best only falls), in lane order. On abc1's uniform points most lanes
    /// lose; skipping them in one SIMD comparison instead of one by one cut its signed query
    /// from 19,377 to 18,378 instructions per point (`examples/query_icount.rs`).
    #[inline(always)]
    fn take_lanes(&self, search: &mut Search, lanes: &[f32], slots: &[u32; 4], mut below: u32) {
        let p = search.p;
        while below != 0 {
            let lane = below.trailing_zeros() as usize;
            below &= below - 1;
            let (d2, slot) = (lanes[lane], slots[lane]);
            if d2.partial_cmp(&search.best_d2) != Some(std::cmp::Ordering::Less) {
                continue;
            }
            if d2 != 0.0 {
                // Vertex or edge: the filter's distance is the exact test's, to the bit.
                search.set_best(d2);
                search.best_slot = slot;
                continue;
            }
            let rec = &self.leaf_records[slot as usize];
            // Face interior or degenerate: the filter gave no bound; the sphere may.
            let sphere = rec.sphere;
            let lim = search.best_d + sphere.w;
            if (p - sphere.truncate()).length_squared() > lim * lim {
                continue;
            }
            let t = &rec.corners;
            let (q, f) =
                point_triangle::closest_point_prerotated(p, t[0], t[1], t[2], rec.rotation);
            let d2 = (p - q).length_squared();
            if d2 < search.best_d2 {
                search.set_best(d2);
                search.best_slot = u32::MAX;
                search.best = ClosestPoint {
                    point: q,
                    distance: d2,
                    triangle: rec.id,
                    feature: f,
                };
            }
        }
    }

    /// Unsigned distance from `p` to the mesh.
    pub fn unsigned_distance(&self, p: Vec3) -> f32 {
        self.closest_point(p).distance
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::uniform_stream;

    /// Every two-packet leaf leaves the search in the same state through its 4-wide halves
    /// (the code of CPUs without AVX, which the searches on the test machines never take) as
    /// through the AVX pass (`search_leaf` here), from bounds that cull nothing, some or most
    /// of the lanes.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn pair_leaves_search_alike_in_both_widths() {
        if !std::is_x86_feature_detected!("avx") {
            return;
        }
        for mesh in [
            sdfmo_mesh::procedural::open_sheet(1.0, 0.8, 24),
            sdfmo_mesh::procedural::sphere(Vec3::ZERO, 0.5, 3),
        ] {
            let md = MeshDistance::new(&mesh, SignMode::Winding).unwrap();
            assert!(md.bvh4.pairs.len() > 10, "{}", md.bvh4.pairs.len());
            let mut next = uniform_stream(3, 2.4, 1.2);
            for i in 0..100 {
                let p = Vec3::new(next(), next(), next()) * if i % 2 == 0 { 1.0 } else { 0.3 };
                let d = md.closest_point(p).distance;
                for bound in [f32::INFINITY, (d * 3.0).powi(2), (d * 1.2).powi(2)] {
                    for (k, pair) in md.bvh4.pairs.iter().enumerate() {
                        let start = || Search::new(p, bound, ClosestPoint::NONE, md.bvh4.extent);
                        let (mut avx, mut four) = (start(), start());
                        md.search_leaf(&mut avx, k as u32, 2);
                        md.search_pair_4wide(&mut four, pair);
                        assert_eq!(
                            (avx.best_d2.to_bits(), avx.best_slot, avx.best),
                            (four.best_d2.to_bits(), four.best_slot, four.best),
                            "{p:?}"
                        );
                    }
                }
            }
        }
    }
}
