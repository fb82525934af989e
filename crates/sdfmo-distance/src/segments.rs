//! Distance from a point to the nearest of a set of segments (the winding sign's chain
//! boundary, see the `clean` module), through a small bounding-box tree.
//!
//! The answer is, bit for bit, the minimum of `point_segment_distance` (the scalar reference
//! the SIMD lanes of a leaf follow) over every segment: a subtree is skipped only when its box
//! is farther than the best distance so far by a margin far above f32 rounding, and the
//! minimum of a set does not depend on the order it is taken in.
//! Per query the tree visits O(log n) of the n segments where a scan visits all of them
//! (the Stanford bunny: 69 451 triangles against 223 boundary edges).

use glam::{Vec3, Vec4};

/// Most segments in a leaf of the tree.
const LEAF_SEGMENTS: usize = 4;

/// A subtree is skipped when its box lies farther than `best × (1 + RELATIVE_MARGIN) +
/// ABSOLUTE_MARGIN`: both far above the f32 rounding of a distance in the normalised frame
/// (coordinates within ±1, rounding ≈ 1e-7), so no skipped segment could have been nearer.
const RELATIVE_MARGIN: f32 = 1e-4;
const ABSOLUTE_MARGIN: f32 = 1e-5;

/// Distance from `p` to the segment `a`–`b` (to `a` when the segment has no length): the
/// reference the tree's lanes ([`SegmentQuad::distances`]) follow bit for bit.
#[cfg(test)]
pub(crate) fn point_segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let s = ((p - a).dot(ab) / ab.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
    (p - (a + ab * s)).length()
}

/// The segments of one leaf (at most [`LEAF_SEGMENTS`] = 4) as structure of arrays, for the
/// distance from a point to all of them in one SIMD pass: the same operations in the same
/// order as the scalar `point_segment_distance` (the tests' reference), lane by lane, so each
/// lane's distance is the scalar one to the bit. One by one, the leaves' distances were
/// 12.2 M of the bunny's first call of 50,000 points (859.5 -> 847.3 M instructions; 223
/// chain-boundary edges, ~2,000 instructions per search).
#[derive(Clone, Copy)]
struct SegmentQuad {
    /// Per axis, each lane's first end.
    a: [Vec4; 3],
    /// Per axis, each lane's `b − a`.
    ab: [Vec4; 3],
    /// Each lane's `ab.length_squared().max(f32::MIN_POSITIVE)`.
    den: Vec4,
}

impl SegmentQuad {
    /// The quad of up to four segments (the lanes beyond them repeat the first, and are not
    /// read).
    fn new(segments: &[(Vec3, Vec3)]) -> SegmentQuad {
        let mut q = SegmentQuad {
            a: [Vec4::ZERO; 3],
            ab: [Vec4::ZERO; 3],
            den: Vec4::ONE,
        };
        for lane in 0..4 {
            let (a, b) = segments[lane.min(segments.len() - 1)];
            let ab = b - a;
            for axis in 0..3 {
                q.a[axis][lane] = a[axis];
                q.ab[axis][lane] = ab[axis];
            }
            q.den[lane] = ab.length_squared().max(f32::MIN_POSITIVE);
        }
        q
    }

    /// The distance from `p` to each lane's segment, as `point_segment_distance`. glam's
    /// `Vec3` dot product adds left to right, `f32::max` returns the other operand for a NaN
    /// and `f32::clamp` keeps a NaN and a −0: the lanes do the same with compares and
    /// selects.
    #[inline]
    fn distances(&self, p: Vec3) -> [f32; 4] {
        let [ax, ay, az] = self.a;
        let [bx, by, bz] = self.ab;
        let (px, py, pz) = (Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z));
        let (dx, dy, dz) = (px - ax, py - ay, pz - az);
        let t = (dx * bx + dy * by + dz * bz) / self.den;
        let t = Vec4::select(t.cmplt(Vec4::ZERO), Vec4::ZERO, t);
        let s = Vec4::select(t.cmpgt(Vec4::ONE), Vec4::ONE, t);
        let (rx, ry, rz) = (px - (ax + bx * s), py - (ay + by * s), pz - (az + bz * s));
        (rx * rx + ry * ry + rz * rz).sqrt().to_array()
    }

    /// The minimum of the first `count` lanes' distances, folded left to right as the scalar
    /// search did (`f32::min`, which skips a NaN).
    #[inline]
    fn nearest(&self, p: Vec3, count: usize, best: f32) -> f32 {
        self.distances(p)[..count]
            .iter()
            .fold(best, |m, &d| m.min(d))
    }
}

/// A node: its box, and either two children (`count == 0`, children at `first` and `first +
/// 1`) or `count` segments, those of `quads[first]`.
struct Node {
    min: Vec3,
    max: Vec3,
    first: u32,
    count: u32,
}

impl Node {
    /// A node whose box and contents are still to be filled.
    const PENDING: Node = Node {
        min: Vec3::ZERO,
        max: Vec3::ZERO,
        first: 0,
        count: 0,
    };

    /// Distance from `p` to the box (0 inside).
    fn distance(&self, p: Vec3) -> f32 {
        (self.min - p).max(p - self.max).max(Vec3::ZERO).length()
    }
}

/// Segments in a bounding-box tree, for [`SegmentTree::nearest_distance`].
pub(crate) struct SegmentTree {
    nodes: Vec<Node>,
    /// Each leaf's segments.
    quads: Vec<SegmentQuad>,
}

impl SegmentTree {
    /// The tree of `segments` (median splits on the longest axis of their midpoints).
    pub(crate) fn new(mut segments: Vec<(Vec3, Vec3)>) -> SegmentTree {
        let mut nodes = vec![Node::PENDING];
        let mut quads = Vec::new();
        // (node, start, end) still to be filled.
        let mut pending = vec![(0usize, 0usize, segments.len())];
        while let Some((node, start, end)) = pending.pop() {
            let range = &mut segments[start..end];
            let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            let (mut mid_min, mut mid_max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for &(a, b) in range.iter() {
                min = min.min(a).min(b);
                max = max.max(a).max(b);
                let mid = (a + b) * 0.5;
                mid_min = mid_min.min(mid);
                mid_max = mid_max.max(mid);
            }
            nodes[node].min = min;
            nodes[node].max = max;
            if range.len() <= LEAF_SEGMENTS {
                if !range.is_empty() {
                    nodes[node].first = quads.len() as u32;
                    nodes[node].count = range.len() as u32;
                    quads.push(SegmentQuad::new(range));
                }
                continue;
            }
            let axis = (mid_max - mid_min).max_position();
            let half = range.len() / 2;
            range.select_nth_unstable_by(half, |x, y| {
                (x.0 + x.1)[axis].total_cmp(&(y.0 + y.1)[axis])
            });
            let first = nodes.len();
            nodes.extend([Node::PENDING, Node::PENDING]);
            nodes[node].first = first as u32;
            pending.push((first, start, start + half));
            pending.push((first + 1, start + half, end));
        }
        SegmentTree { nodes, quads }
    }

    /// An upper bound of [`nearest_distance`](Self::nearest_distance) at `p` (infinity when
    /// there are no segments), never below it in f32: the minimum of `point_segment_distance`
    /// over the segments of the one leaf reached by descending to the child whose box is
    /// nearer at every node (a subset of the segments the search takes the minimum of). A few
    /// hundred instructions where the search takes ~2,000 (the bunny).
    pub(crate) fn distance_bound(&self, p: Vec3) -> f32 {
        if self.quads.is_empty() {
            return f32::INFINITY;
        }
        let mut node = &self.nodes[0];
        while node.count == 0 {
            let (l, r) = (
                &self.nodes[node.first as usize],
                &self.nodes[node.first as usize + 1],
            );
            node = if l.distance(p) <= r.distance(p) { l } else { r };
        }
        self.quads[node.first as usize].nearest(p, node.count as usize, f32::INFINITY)
    }

    /// The distance from `p` to the nearest segment (infinity when there are none): exactly the
    /// minimum of `point_segment_distance` over all of them.
    pub(crate) fn nearest_distance(&self, p: Vec3) -> f32 {
        let mut best = f32::INFINITY;
        if self.quads.is_empty() {
            return best;
        }
        // Median splits keep the tree ⌈log₂(n / LEAF_SEGMENTS)⌉ + 1 ≤ 20 levels deep for the
        // 2^20 edges allowed, and the walk holds at most one sibling per level: no allocation
        // per query (one query per triangle).
        // Each entry carries its node's box distance, computed when its parent was opened (both
        // children's are needed there to order them): taking it again when the node is popped
        // was 15 % of the bunny's searches (223 edges; 87.8 M -> 74.2 M instructions in the
        // first call of 20,000 points).
        // The nearer child of an opened node is taken at once, the farther kept for after it
        // (the order pushing both gave): one push and pop fewer per node (bunny first call of
        // 50,000 points, 812.8 -> 810.4 M instructions).
        let mut stack = [(0u32, 0.0f32); 64];
        let mut len = 0;
        let mut next = (0, self.nodes[0].distance(p));
        loop {
            let (i, box_distance) = next;
            let node = &self.nodes[i as usize];
            // (Not `<=`: a NaN box distance is not skipped.)
            let skip = box_distance > best * (1.0 + RELATIVE_MARGIN) + ABSOLUTE_MARGIN;
            if !skip && node.count > 0 {
                best = self.quads[node.first as usize].nearest(p, node.count as usize, best);
            } else if !skip {
                let (l, r) = (node.first, node.first + 1);
                let (dl, dr) = (
                    self.nodes[l as usize].distance(p),
                    self.nodes[r as usize].distance(p),
                );
                let (far, near) = if dl <= dr {
                    ((r, dr), (l, dl))
                } else {
                    ((l, dl), (r, dr))
                };
                stack[len] = far;
                len += 1;
                next = near;
                continue;
            }
            if len == 0 {
                break;
            }
            len -= 1;
            next = stack[len];
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reproducible stream of values in [-1, 1) (the project's SplitMix64).
    fn stream(seed: u64) -> impl FnMut() -> f32 {
        let mut rng = sdfmo_io::SplitMix64::new(seed);
        move || rng.range(-1.0, 1.0)
    }

    #[test]
    fn nearest_distance_is_the_scans_minimum_bit_for_bit() {
        let mut next = stream(7);
        for n in [0usize, 1, 3, 4, 5, 17, 300] {
            // Short segments scattered in the cube, some of them points, a few long ones.
            let segments: Vec<(Vec3, Vec3)> = (0..n)
                .map(|i| {
                    let a = Vec3::new(next(), next(), next());
                    let len = match i % 7 {
                        0 => 0.0,
                        1 => 1.0,
                        _ => 0.05,
                    };
                    (a, a + Vec3::new(next(), next(), next()) * len)
                })
                .collect();
            let tree = SegmentTree::new(segments.clone());
            for _ in 0..500 {
                let p = Vec3::new(next(), next(), next()) * 1.5;
                let scan = segments
                    .iter()
                    .map(|&(a, b)| point_segment_distance(p, a, b))
                    .fold(f32::INFINITY, f32::min);
                assert_eq!(
                    tree.nearest_distance(p).to_bits(),
                    scan.to_bits(),
                    "{n} {p:?}"
                );
                assert!(tree.distance_bound(p) >= scan, "{n} {p:?}");
            }
        }
    }

    /// Each lane of a quad is `point_segment_distance` to the bit, in the special cases too: a
    /// point behind either end (the parameter clamped, a −0 kept), a segment of no length or
    /// of a denormal one, a NaN or infinite point (NaN on both sides).
    #[test]
    fn quad_lanes_are_the_scalar_distance() {
        let segments = [
            (Vec3::ZERO, Vec3::X),
            (Vec3::Y, Vec3::Y),
            (Vec3::new(-1.0, 2.0, 0.5), Vec3::new(3.0, -1.0, 0.25)),
            (Vec3::Z, Vec3::new(0.0, 0.0, 1.0 + 1e-38)),
        ];
        let quad = SegmentQuad::new(&segments);
        let mut next = stream(3);
        let mut points = vec![
            Vec3::ZERO,
            Vec3::new(-0.0, 1.0, -0.0),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::NAN,
            Vec3::new(f32::INFINITY, 0.0, 0.0),
            Vec3::new(0.0, f32::NEG_INFINITY, 1.0),
        ];
        points.extend((0..500).map(|_| Vec3::new(next(), next(), next()) * 3.0));
        for p in points {
            let lanes = quad.distances(p);
            for (lane, &(a, b)) in segments.iter().enumerate() {
                let scalar = point_segment_distance(p, a, b);
                assert!(
                    lanes[lane].to_bits() == scalar.to_bits()
                        || lanes[lane].is_nan() && scalar.is_nan(),
                    "{p:?} lane {lane}: {} against {scalar}",
                    lanes[lane]
                );
            }
        }
    }

    #[test]
    fn coincident_segments_and_points_on_them() {
        // Many copies of one edge and queries on it: distance 0, never a skipped copy.
        let (a, b) = (Vec3::new(-0.5, 0.1, 0.2), Vec3::new(0.5, 0.1, 0.2));
        let tree = SegmentTree::new(vec![(a, b); 40]);
        assert_eq!(tree.nearest_distance(a.lerp(b, 0.3)), 0.0);
        assert_eq!(
            tree.nearest_distance(Vec3::new(0.0, 0.1, 1.2)).to_bits(),
            point_segment_distance(Vec3::new(0.0, 0.1, 1.2), a, b).to_bits()
        );
    }
}
