//! Ray vs packed octree: front-to-back traversal with a fixed stack, stopping at the first leaf
//! with a hit.
//!
//! At an inner node the ray's span `[t_enter, t_exit]` is split at the three mid-planes (the
//! parametric scheme of Revelles et al. 2000): the child containing the entry point is found by
//! comparing each mid-plane's crossing time with `t_enter`, and every mid-plane crossed inside
//! the span flips that axis's bit of the octant, in crossing order. The present children among
//! those (at most four) are pushed farthest first, so the stack pops cells in ray order and the
//! first leaf that reports a hit holds the nearest hit. Every cell's span is computed from the
//! exact plane coordinates with the same formula, so neighbouring cells share their boundary
//! `t` bit for bit and nothing slips between them.
//!
//! Zero direction components are replaced, for the plane crossing times only, by ±1e-30 (the
//! sign kept), which puts their planes at ±1e30 or exactly at 0: a ray lying in a plane is
//! consistently on its `+` side (or `−` for a `−0.0` component). The voxel kernel sees the true
//! direction.

use core::mem::MaybeUninit;

use glam::Vec3;
use sdfmo_format::TracedOctree;

use crate::ray_voxel::intersect_voxel;

/// A ray `origin + t·dir`; `dir` should be unit length (then `t` is a distance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point, normalised octree coordinates (the root cube is `[-1, 1]³`).
    pub origin: Vec3,
    /// Direction, unit length.
    pub dir: Vec3,
}

/// The first hit of a ray in an octree; `V` is the octree's voxel
/// ([`TracedOctree::Voxel`]: the voxel index in a 1.x octree).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit<V = u32> {
    /// Ray parameter of the hit.
    pub t: f32,
    /// The voxel hit (for [`TracedOctree::voxel_corners`]).
    pub voxel: V,
    /// Minimum corner of the leaf cell, normalised coordinates.
    pub cell_min: Vec3,
    /// Edge length of the leaf cell.
    pub cell_size: f32,
    /// Whether the voxel is a surface (thin) voxel.
    pub surface: bool,
    /// The voxel's eight corner distances ([`TracedOctree::voxel_corners`]), carried from the
    /// leaf test that found the hit so that [`crate::hit_normal`] reads nothing again (in a
    /// 3.0 octree a second decode of the brick's corners cost about a fifth of a frame).
    pub corners: [f32; 8],
}

// Stack capacity, and the replacement for zero direction components in the plane crossing
// times: shared with the WGSL kernel (`sdfmo_format::kernel`).
use sdfmo_format::kernel::{TINY_DIR, TRAVERSAL_STACK_SIZE as STACK_SIZE};

/// A cell waiting on the stack: node, box and the ray's span in it.
#[derive(Clone, Copy, Debug)]
struct Cell<N> {
    node: N,
    min: Vec3,
    size: f32,
    t_enter: f32,
    t_exit: f32,
}

/// The ray's first hit in `[t_min, t_max]`: in the first leaf along the ray that has one, the
/// nearest hit among its voxels. `None` for an empty octree, a miss, or NaN input.
///
/// Generic over the octree ([`TracedOctree`]), so it traces a 1.x
/// [`PackedOctree`](sdfmo_format::PackedOctree) (owned bytes), a zero-copy
/// [`PackedOctreeView`](sdfmo_format::PackedOctreeView) or a 3.0
/// [`BrickOctree`](sdfmo_format::BrickOctree) alike (static dispatch, monomorphised per layout
/// and buffer type; the same octree in either layout gives the same hits, bit for bit).
pub fn intersect<O: TracedOctree>(
    octree: &O,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<Hit<O::Voxel>> {
    traverse::<O, false>(octree, ray, t_min, t_max, inner_step)
}

/// Whether anything is hit in `[t_min, t_max]` (stops at the first voxel hit, not the nearest).
pub fn occluded<O: TracedOctree>(octree: &O, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    traverse::<O, true>(octree, ray, t_min, t_max, inner_step).is_some()
}

/// A box containing every leaf of the octree, `(min, max)` in normalised coordinates: the union
/// of the occupied cells `levels` below the root (of the leaves, where they are shallower).
/// `None` for an empty octree. Costs one visit per occupied node down to `levels`; a ray that
/// misses this box hits nothing, so renderers reject it before [`intersect`].
pub fn occupied_bounds<O: TracedOctree>(octree: &O, levels: u8) -> Option<(Vec3, Vec3)> {
    let root = octree.root()?;
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut stack = vec![(root, Vec3::splat(-1.0), 2.0f32, 0u8)];
    while let Some((node, min, size, level)) = stack.pop() {
        if level >= levels || octree.is_leaf(node) {
            lo = lo.min(min);
            hi = hi.max(min + Vec3::splat(size));
            continue;
        }
        let mask = octree.child_mask(node);
        let children = octree.children(node);
        let half = 0.5 * size;
        for oct in 0..8u8 {
            if mask >> oct & 1 == 0 {
                continue;
            }
            let offset = Vec3::new(
                f32::from(oct >> 2),
                f32::from((oct >> 1) & 1),
                f32::from(oct & 1),
            );
            stack.push((
                octree.child_of(children, u32::from(mask), u32::from(oct)),
                min + offset * half,
                half,
                level + 1,
            ));
        }
    }
    le(lo.x, hi.x).then_some((lo, hi))
}

/// Whether the ray's span in the box `[lo, hi]`, clipped to `[t_min, t_max]`, is not empty
/// (true for NaN-free rays touching the box; zero direction components handled as in the
/// traversal). Conservative callers pad the box.
#[inline]
pub fn ray_meets_box(ray: &Ray, lo: Vec3, hi: Vec3, t_min: f32, t_max: f32) -> bool {
    let (t_enter, t_exit) = box_span(lo, hi, ray.origin, inv_dir(ray.dir), t_min, t_max);
    le(t_enter, t_exit)
}

/// `a ≤ b`, false when either is NaN.
#[inline]
pub(crate) fn le(a: f32, b: f32) -> bool {
    a <= b
}

/// `1/d`, with zero (and subnormal) components replaced by ±[`TINY_DIR`].
#[inline]
pub(crate) fn safe_inv(d: f32) -> f32 {
    if d.abs() < TINY_DIR {
        1.0 / TINY_DIR.copysign(d)
    } else {
        1.0 / d
    }
}

/// The inverse direction for the plane crossing times: [`safe_inv`] on each component.
#[inline]
pub(crate) fn inv_dir(d: Vec3) -> Vec3 {
    Vec3::new(safe_inv(d.x), safe_inv(d.y), safe_inv(d.z))
}

/// The ray's span in the box `[lo, hi]`, clipped to `[t_min, t_max]`.
#[inline]
pub(crate) fn box_span(
    lo: Vec3,
    hi: Vec3,
    origin: Vec3,
    inv: Vec3,
    t_min: f32,
    t_max: f32,
) -> (f32, f32) {
    let ta = (lo - origin) * inv;
    let tb = (hi - origin) * inv;
    let t_enter = ta.min(tb).max_element().max(t_min);
    let t_exit = ta.max(tb).min_element().min(t_max);
    (t_enter, t_exit)
}

/// The ray's span in the root cube `[-1, 1]³` clipped to `[t_min, t_max]`, with its inverse
/// direction: the set-up of every walk of the octree, one ray or a packet lane.
#[inline]
pub(crate) fn root_span(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> (Vec3, f32, f32) {
    let inv = inv_dir(dir);
    let (t_enter, t_exit) = box_span(Vec3::splat(-1.0), Vec3::ONE, origin, inv, t_min, t_max);
    (inv, t_enter, t_exit)
}

/// The root cell with the ray's span in it, and the ray's inverse direction; `None` for an
/// empty octree or span (NaN input included).
#[inline(always)]
fn root_cell<O: TracedOctree>(
    octree: &O,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(Cell<O::Node>, Vec3)> {
    let root = octree.root()?;
    // Also rejects a NaN bound (f32::max/min would ignore it).
    if !le(t_min, t_max) {
        return None;
    }
    let (inv, t_enter, t_exit) = root_span(ray.origin, ray.dir, t_min, t_max);
    // Also rejects NaN.
    if !le(t_enter, t_exit) {
        return None;
    }
    let cell = Cell {
        node: root,
        min: Vec3::splat(-1.0),
        size: 2.0,
        t_enter,
        t_exit,
    };
    Some((cell, inv))
}

/// The cells waiting for a walk of the octree (single rays and packets), nearest on top, in a
/// fixed array on the machine stack; a push beyond `N` is dropped (the callers' `N` bounds the
/// depth-first walk, so it never is).
pub(crate) struct CellStack<T, const N: usize> {
    cells: [MaybeUninit<T>; N],
    len: usize,
}

impl<T: Copy, const N: usize> CellStack<T, N> {
    /// An empty stack. Not initialised up front: zeroing the whole stack for every ray cost
    /// about a sixth of the traversal time (perf, abc1 depth 9, paper view).
    #[inline(always)]
    pub(crate) fn new() -> Self {
        CellStack {
            cells: [const { MaybeUninit::uninit() }; N],
            len: 0,
        }
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, cell: T) {
        if self.len < N {
            self.cells[self.len].write(cell);
            self.len += 1;
        }
    }

    /// A node's children come farthest first: each becomes `pending` and the one it replaces is
    /// pushed, so the nearest is left in `pending` for the walk to take without a round trip
    /// through the stack.
    #[inline(always)]
    pub(crate) fn defer(&mut self, pending: &mut Option<T>, cell: T) {
        if let Some(p) = pending.replace(cell) {
            self.push(p);
        }
    }

    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: `len < N` (it only grows by one, and only while below `N`) and `cells[len]`
        // was written (`len` grows right after writing `cells[len]`, so every entry below it
        // is initialised). Unchecked: the bounds check cost 0.4 % of a shadow-ray frame.
        Some(unsafe { self.cells.get_unchecked(self.len).assume_init() })
    }
}

/// Child `oct` (octant bits x = 4, y = 2, z = 1) of an inner node with child `mask` whose
/// children are `children` ([`TracedOctree::children`]): its node and the min corner of its
/// cell, for a node cell at `min` with centre `mid`.
#[inline(always)]
pub(crate) fn child_at<O: TracedOctree>(
    octree: &O,
    children: O::Children,
    mask: u32,
    oct: u32,
    min: Vec3,
    mid: Vec3,
) -> (O::Node, Vec3) {
    let node = octree.child_of(children, mask, oct);
    // Each coordinate is `mid`'s where the octant bit is set, else `min`'s, chosen by a bit mask:
    // the compiler made `if` selects branches, which the octant order (the ray's) mispredicts
    // a quarter of the time (callgrind's branch simulation: 184 k of the 1.24 M mispredictions
    // of an abc1 paper-view frame).
    let pick = |bit: u32, mid: f32, min: f32| {
        let take_mid = 0u32.wrapping_sub(u32::from(oct & bit != 0));
        f32::from_bits((mid.to_bits() & take_mid) | (min.to_bits() & !take_mid))
    };
    let min = Vec3::new(
        pick(4, mid.x, min.x),
        pick(2, mid.y, min.y),
        pick(1, mid.z, min.z),
    );
    (node, min)
}

/// A ray's span `(te, tx)` in a node split at the node's mid-planes, crossed at `tm`: the axes
/// whose plane lies behind the entry point (`tm ≤ te`, as octant bits), and the three sort keys
/// and axis bits in crossing order. A plane crossed inside `(te, tx)` has the key `tm`; the
/// others get the key `tx` and bit 0, which sort after every crossing (a crossing is < tx) and
/// end the sequence, so key `i` ends the child after `i` crossings. Equal times keep the axis
/// order x, y, z (a stable three-comparator network: strict comparisons).
#[inline(always)]
pub(crate) fn split_span(tm: Vec3, te: f32, tx: f32) -> (u8, [f32; 3], [u8; 3]) {
    let behind = u8::from(tm.x <= te) << 2 | u8::from(tm.y <= te) << 1 | u8::from(tm.z <= te);
    let crossed = |t: f32| t > te && t < tx;
    let (mut k0, mut b0) = if crossed(tm.x) { (tm.x, 4u8) } else { (tx, 0) };
    let (mut k1, mut b1) = if crossed(tm.y) { (tm.y, 2u8) } else { (tx, 0) };
    let (mut k2, mut b2) = if crossed(tm.z) { (tm.z, 1u8) } else { (tx, 0) };
    if k1 < k0 {
        (k0, k1, b0, b1) = (k1, k0, b1, b0);
    }
    if k2 < k1 {
        (k1, k2, b1, b2) = (k2, k1, b2, b1);
    }
    if k1 < k0 {
        (k0, k1, b0, b1) = (k1, k0, b1, b0);
    }
    (behind, [k0, k1, k2], [b0, b1, b2])
}

/// The single-ray walk, with the inner-node step `step` (a function item, called directly):
/// always [`inner_step`], except in the test that checks it against the step it replaced.
#[inline(always)]
fn traverse<O: TracedOctree, const ANY: bool>(
    octree: &O,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    step: impl Fn(&mut Walk<'_, O>, &Cell<O::Node>) -> Option<Cell<O::Node>>,
) -> Option<Hit<O::Voxel>> {
    let (mut cell, inv) = root_cell(octree, ray, t_min, t_max)?;
    let (o, d) = (ray.origin, ray.dir);
    let negative = u8::from(inv.x < 0.0) << 2 | u8::from(inv.y < 0.0) << 1 | u8::from(inv.z < 0.0);
    let mut walk = Walk {
        octree,
        o,
        d,
        inv,
        negative,
        stack: CellStack::new(),
    };
    loop {
        if octree.is_leaf(cell.node) {
            if let Some(hit) = leaf_hit::<O, ANY>(&walk, &cell) {
                return Some(hit);
            }
        } else if let Some(next) = step(&mut walk, &cell) {
            // The nearest child goes straight to `cell` (no round trip through the stack).
            cell = next;
            continue;
        }
        cell = walk.stack.pop()?;
    }
}

/// One ray's walk of the octree: what each inner-node step reads, and the cells still to
/// visit.
struct Walk<'a, O: TracedOctree> {
    octree: &'a O,
    /// The ray's origin.
    o: Vec3,
    /// Its direction.
    d: Vec3,
    /// Its inverse direction ([`inv_dir`]).
    inv: Vec3,
    /// Axes along which the ray moves towards − (bit 4 = x, 2 = y, 1 = z, as in octants): on
    /// those a mid-plane crossed at tm ≤ t puts the ray on the lower side at t, on the others
    /// on the upper side.
    negative: u8,
    stack: CellStack<Cell<O::Node>, STACK_SIZE>,
}

/// One inner node: its present children that the ray's span crosses, in ray order. The nearest
/// is returned, the others are pushed farthest first. `None` when the ray crosses no present
/// child.
///
/// Written out with scalars and selects rather than arrays of tuples and loops over axes: the
/// earlier form (same decisions, same arithmetic) executed about 2.5 times as many instructions
/// per inner node (callgrind, abc1 depth 9, paper view 0), and inner nodes are most of the
/// frame. Decisions, ties and spans are those of the original scheme bit for bit (the test
/// `lean_step_matches_the_reference_traversal_bit_for_bit` runs the walk with the original
/// step, `reference_step`, beside it):
/// * entry octant: on a `+` axis the upper side once `tm ≤ t_enter`, on a `−` axis while
///   `tm > t_enter`;
/// * the mid-planes crossed inside `(t_enter, t_exit)` flip their bit in order of `tm`, equal
///   times in axis order x, y, z (a stable sort);
/// * a child's span runs from the crossing that enters it (or `t_enter`) to the next crossing
///   (or `t_exit`).
#[inline(always)]
fn inner_step<O: TracedOctree>(
    walk: &mut Walk<'_, O>,
    cell: &Cell<O::Node>,
) -> Option<Cell<O::Node>> {
    let (octree, o, inv, negative) = (walk.octree, walk.o, walk.inv, walk.negative);
    let half = 0.5 * cell.size;
    let mid = cell.min + Vec3::splat(half);
    let (te, tx) = (cell.t_enter, cell.t_exit);
    let (behind, [k0, k1, k2], [b0, b1, b2]) = split_span((mid - o) * inv, te, tx);

    let mask = octree.child_mask(cell.node);
    // The octants along the ray (entry octant, then each flips the next crossed bit) and which
    // are present.
    let o0 = behind ^ negative;
    let o1 = o0 ^ b0;
    let o2 = o1 ^ b1;
    let o3 = o2 ^ b2;
    let present = |oct: u8, valid: bool| valid && mask >> oct & 1 != 0;
    let p0 = present(o0, true);
    let p1 = present(o1, b0 != 0);
    let p2 = present(o2, b1 != 0);
    let p3 = present(o3, b2 != 0);
    if !(p0 | p1 | p2 | p3) {
        return None;
    }
    // One read of the node's group.
    let children = octree.children(cell.node);
    let child = |oct: u8, t_a: f32, t_b: f32| {
        let (node, min) = child_at(
            octree,
            children,
            u32::from(mask),
            u32::from(oct),
            cell.min,
            mid,
        );
        Cell {
            node,
            min,
            size: half,
            t_enter: t_a,
            t_exit: t_b,
        }
    };
    // Farthest first; the nearest present child is kept back and returned.
    let mut pending: Option<Cell<O::Node>> = None;
    if p3 {
        walk.stack.defer(&mut pending, child(o3, k2, tx));
    }
    if p2 {
        walk.stack.defer(&mut pending, child(o2, k1, k2));
    }
    if p1 {
        walk.stack.defer(&mut pending, child(o1, k0, k1));
    }
    if p0 {
        walk.stack.defer(&mut pending, child(o0, te, k0));
    }
    pending
}

/// The nearest voxel hit inside a leaf's span (any hit when `ANY`); in a leaf with clip voxels
/// the nearest hit the clip rule accepts ([`crate::clip`]).
#[inline(always)]
fn leaf_hit<O: TracedOctree, const ANY: bool>(
    walk: &Walk<'_, O>,
    cell: &Cell<O::Node>,
) -> Option<Hit<O::Voxel>> {
    let (octree, o, d) = (walk.octree, walk.o, walk.d);
    let inv_size = 1.0 / cell.size;
    // The kernel works from the entry point, in the cell's local frame [0,1]³, with the same
    // parameter scale as the world ray (t_local = t − t_enter).
    let local_o = (o + d * cell.t_enter - cell.min) * inv_size;
    let local_d = d * inv_size;
    let mut best_s = cell.t_exit - cell.t_enter;
    let voxels = octree.leaf_voxels(cell.node);
    // A leaf with clip voxels takes the clip rule (crate::clip); the test is one compare for
    // an octree without clip voxels.
    if octree.any_clip_voxel(&voxels) {
        return crate::clip::leaf_hit::<O, ANY>(octree, voxels, local_o, local_d, best_s).map(
            |(s, voxel, surface)| Hit {
                t: (cell.t_enter + s).min(cell.t_exit),
                voxel,
                cell_min: cell.min,
                cell_size: cell.size,
                surface,
                corners: octree.voxel_corners(voxel),
            },
        );
    }
    let mut best: Option<(O::Voxel, bool, [f32; 8])> = None;
    for voxel in voxels {
        let corners = octree.voxel_corners(voxel);
        let surface = octree.voxel_is_surface(voxel);
        if let Some(s) = intersect_voxel(&corners, local_o, local_d, 0.0, best_s, surface) {
            if best.is_none() || s < best_s {
                best_s = s;
                best = Some((voxel, surface, corners));
                if ANY {
                    break;
                }
            }
        }
    }
    best.map(|(voxel, surface, corners)| Hit {
        t: (cell.t_enter + best_s).min(cell.t_exit),
        voxel,
        cell_min: cell.min,
        cell_size: cell.size,
        surface,
        corners,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    //! Traversal against brute force over every voxel of small octrees built from sampled
    //! analytic SDFs.

    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use sdfmo_format::testing::pinhole_dirs;
    use sdfmo_format::{
        cell_size, BrickOctree, BrickOctreeView, BrickVoxel, LeafInput, NodeRef, OctreeMeta,
        PackedOctree, PackedOctreeView, ValueBits, Voxel,
    };

    fn meta(depth: u8) -> OctreeMeta {
        OctreeMeta::unit(depth, ValueBits::Sixteen)
    }

    fn cell_min(coord: [u32; 3], depth: u8) -> (Vec3, f32) {
        let h = cell_size(depth);
        (
            Vec3::new(coord[0] as f32, coord[1] as f32, coord[2] as f32) * h - Vec3::ONE,
            h,
        )
    }

    /// The tests' first sphere (a shape of several tests).
    pub(crate) fn sphere_a(p: Vec3) -> f32 {
        (p - Vec3::new(-0.15, 0.0, 0.0)).length() - 0.5
    }

    /// The tests' second sphere, interpenetrating [`sphere_a`].
    pub(crate) fn sphere_b(p: Vec3) -> f32 {
        (p - Vec3::new(0.2, 0.1, 0.0)).length() - 0.45
    }

    /// The tests' tilted plane through both spheres (traced as a surface sheet).
    pub(crate) fn tilted_sheet(p: Vec3) -> f32 {
        p.dot(Vec3::new(0.3, 1.0, 0.2).normalize()) - 0.05
    }

    /// The two interpenetrating spheres as separate voxels of the same leaves, plus the tilted
    /// surface sheet, at depth 4: every leaf near their crossings holds two or three voxels.
    pub(crate) fn spheres_and_sheet() -> PackedOctree {
        octree_from_sdfs(
            4,
            &[
                (&sphere_a, false, false),
                (&sphere_b, false, false),
                (&tilted_sheet, true, false),
            ],
        )
    }

    /// A signed distance with the surface and clip bits of its voxels.
    pub(crate) type Field<'a> = (&'a dyn Fn(Vec3) -> f32, bool, bool);

    /// Leaves where `sdfs` come within a cell diagonal of zero, one voxel per SDF (with its
    /// surface and clip bits) sampled at the cell corners.
    pub(crate) fn octree_from_sdfs(depth: u8, sdfs: &[Field<'_>]) -> PackedOctree {
        let n = 1u32 << depth;
        let mut leaves = Vec::new();
        for x in 0..n {
            for y in 0..n {
                for z in 0..n {
                    let (min, h) = cell_min([x, y, z], depth);
                    let mut voxels = Vec::new();
                    for &(sdf, surface, clip) in sdfs {
                        if sdf(min + Vec3::splat(0.5 * h)).abs() > h * 0.87 {
                            continue;
                        }
                        let corners = core::array::from_fn(|i| {
                            let c =
                                Vec3::new((i >> 2) as f32, ((i >> 1) & 1) as f32, (i & 1) as f32);
                            sdf(min + c * h)
                        });
                        voxels.push(Voxel {
                            corners,
                            surface,
                            clip,
                        });
                    }
                    // A leaf of clip-only voxels alone is not a valid leaf.
                    if !voxels.iter().all(|v| v.surface && v.clip) {
                        leaves.push(LeafInput {
                            coord: [x, y, z],
                            voxels,
                        });
                    }
                }
            }
        }
        PackedOctree::from_leaves(meta(depth), leaves).unwrap()
    }

    /// The nearest hit over all voxels of all leaves (the kernel on each leaf's span).
    fn brute_force(octree: &PackedOctree, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let depth = octree.depth();
        let inv = inv_dir(ray.dir);
        let mut best: Option<f32> = None;
        let mut voxel = 0u32;
        for (coord, voxels) in octree.leaves() {
            let (min, h) = cell_min(coord, depth);
            let (te, tx) = box_span(min, min + Vec3::splat(h), ray.origin, inv, t_min, t_max);
            if !le(te, tx) {
                voxel += voxels.len() as u32;
                continue;
            }
            let lo = (ray.origin + ray.dir * te - min) / h;
            let ld = ray.dir / h;
            for v in voxels {
                let corners = octree.voxel_corners(voxel);
                voxel += 1;
                if let Some(s) = intersect_voxel(&corners, lo, ld, 0.0, tx - te, v.surface) {
                    let t = (te + s).min(tx);
                    if best.is_none_or(|b| t < b) {
                        best = Some(t);
                    }
                }
            }
        }
        best
    }

    /// The interval `(t_min, t_max)` a test ray is traced over: `[0.3, 2.5]` when `bounded`,
    /// else the whole ray `[0, ∞)`.
    fn test_interval(bounded: bool) -> (f32, f32) {
        if bounded {
            (0.3, 2.5)
        } else {
            (0.0, f32::INFINITY)
        }
    }

    fn random_ray(rng: &mut ChaCha8Rng) -> Ray {
        let mut dir = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        // A third of the rays have one or two zero components.
        match rng.random_range(0..9) {
            0 => dir.x = 0.0,
            1 => dir.y = 0.0,
            2 => {
                dir.x = 0.0;
                dir.z = 0.0;
            }
            _ => {}
        }
        let dir = dir.try_normalize().unwrap_or(Vec3::Y);
        // Origins outside the root cube (primary rays) and inside it (secondary rays).
        let target = Vec3::new(
            rng.random_range(-0.9..0.9),
            rng.random_range(-0.9..0.9),
            rng.random_range(-0.9..0.9),
        );
        let back = if rng.random_bool(0.5) {
            rng.random_range(2.0..4.0)
        } else {
            rng.random_range(0.0..0.5)
        };
        Ray {
            origin: target - dir * back,
            dir,
        }
    }

    fn compare_with_brute_force(octree: &PackedOctree, rays: usize, seed: u64) -> usize {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let h = cell_size(octree.depth());
        let mut hits = 0;
        for i in 0..rays {
            let ray = random_ray(&mut rng);
            let (t_min, t_max) = test_interval(i % 4 == 0);
            let got = intersect(octree, &ray, t_min, t_max);
            let expected = brute_force(octree, &ray, t_min, t_max);
            match (got, expected) {
                (Some(g), Some(e)) => {
                    assert!(
                        (g.t - e).abs() <= 1e-5 * h,
                        "ray {i} {ray:?}: {} vs {e}",
                        g.t
                    );
                    assert!(g.t >= t_min && g.t <= t_max);
                    assert!(occluded(octree, &ray, t_min, t_max));
                    let n = crate::hit_normal(&ray, &g);
                    assert!(
                        n.is_finite() && (n.length() - 1.0).abs() < 1e-4 && n.dot(ray.dir) <= 0.0
                    );
                    hits += 1;
                }
                (None, None) => assert!(!occluded(octree, &ray, t_min, t_max)),
                _ => panic!("ray {i} {ray:?}: traversal {got:?}, brute force {expected:?}"),
            }
        }
        hits
    }

    /// The inner-node step as it was before the lean one (commit f8eb665), kept verbatim as
    /// the reference the new one must match bit for bit (`walk.negative` unused: it reads the
    /// direction's signs from `inv`, as it did).
    fn reference_step<O: TracedOctree<Children = u32, Node = NodeRef>>(
        walk: &mut Walk<'_, O>,
        cell: &Cell<NodeRef>,
    ) -> Option<Cell<NodeRef>> {
        let (octree, o, inv) = (walk.octree, walk.o, walk.inv);
        // Whether the ray moves towards + along each axis (then a mid-plane crossed at tm ≤ t puts
        // the ray on the upper side at t).
        let positive = [inv.x > 0.0, inv.y > 0.0, inv.z > 0.0];
        // The next cell: the nearest child of an inner node goes straight to `cell` (no round
        // trip through the stack), the others are pushed farthest first.
        let mut next = None;
        let half = 0.5 * cell.size;
        let mid = cell.min + Vec3::splat(half);
        let tm = (mid - o) * inv;
        let (te, tx) = (cell.t_enter, cell.t_exit);

        // Octant of the entry point, and the mid-planes crossed inside (te, tx).
        let mut octant = 0u8;
        let mut planes = [(f32::INFINITY, 0u8); 3];
        for (k, bit) in [(0usize, 4u8), (1, 2), (2, 1)] {
            let t = tm[k];
            let upper = if positive[k] { t <= te } else { t > te };
            if upper {
                octant |= bit;
            }
            if t > te && t < tx {
                planes[k] = (t, bit);
            }
        }
        // Sort the three crossings (a three-comparator network).
        if planes[1].0 < planes[0].0 {
            planes.swap(0, 1);
        }
        if planes[2].0 < planes[1].0 {
            planes.swap(1, 2);
        }
        if planes[1].0 < planes[0].0 {
            planes.swap(0, 1);
        }

        // The present children in ray order with their spans.
        let mask = octree.child_mask(cell.node);
        let mut children = [(0u8, 0.0f32, 0.0f32); 4];
        let mut n = 0;
        let mut t_a = te;
        for &(t_b, bit) in &planes {
            if bit == 0 {
                break;
            }
            if mask >> octant & 1 != 0 {
                children[n] = (octant, t_a, t_b);
                n += 1;
            }
            octant ^= bit;
            t_a = t_b;
        }
        if mask >> octant & 1 != 0 {
            children[n] = (octant, t_a, tx);
            n += 1;
        }
        // Children are stored contiguously in octant order: one read of the node's group.
        let first = if n > 0 { octree.children(cell.node) } else { 0 };
        for (i, &(oct, t_a, t_b)) in children[..n].iter().enumerate().rev() {
            let below = u32::from(mask) & ((1u32 << oct) - 1);
            let child = NodeRef::from_index(first + below.count_ones());
            let offset = Vec3::new(
                f32::from(oct >> 2),
                f32::from((oct >> 1) & 1),
                f32::from(oct & 1),
            );
            let c = Cell {
                node: child,
                min: cell.min + offset * half,
                size: half,
                t_enter: t_a,
                t_exit: t_b,
            };
            if i == 0 {
                next = Some(c);
            } else {
                walk.stack.push(c);
            }
        }
        next
    }

    /// Bit-level equality of two optional hits (`t` and `cell_min` compared as bits, so `-0.0`
    /// and `0.0` differ).
    pub(crate) fn same_hit(a: Option<Hit>, b: Option<Hit>) -> bool {
        match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) => {
                a.t.to_bits() == b.t.to_bits()
                    && a.voxel == b.voxel
                    && a.cell_min.to_array().map(f32::to_bits)
                        == b.cell_min.to_array().map(f32::to_bits)
                    && a.cell_size.to_bits() == b.cell_size.to_bits()
                    && a.surface == b.surface
            }
            _ => false,
        }
    }

    /// Whether a hit in the 1.x octree `o` and one in another layout `b` of the same octree
    /// are the same bit for bit: `t` and the cell as bits, the surface flag, and the voxel's
    /// corners (the voxels are named differently by each layout).
    pub(crate) fn same_hit_in<P: TracedOctree>(
        o: &PackedOctree,
        a: Option<Hit>,
        b: &P,
        h: Option<Hit<P::Voxel>>,
    ) -> bool {
        match (a, h) {
            (None, None) => true,
            (Some(a), Some(h)) => {
                a.t.to_bits() == h.t.to_bits()
                    && a.cell_min.to_array().map(f32::to_bits)
                        == h.cell_min.to_array().map(f32::to_bits)
                    && a.cell_size.to_bits() == h.cell_size.to_bits()
                    && a.surface == h.surface
                    && o.voxel_corners(a.voxel).map(f32::to_bits)
                        == b.voxel_corners(h.voxel).map(f32::to_bits)
            }
            _ => false,
        }
    }

    #[test]
    fn bricks_trace_like_the_1x_octree_bit_for_bit() {
        // The same octree in 3.0 (BrickOctree::encode, lossless): every query the renderers
        // and Python make gives the 1.x answer bit for bit, on volume, surface, multi-voxel and
        // clip leaves (two intersected spheres; a sheet cut by a clip-only plane).
        let rim = |p: Vec3| p.x - 0.1;
        let octrees = [
            octree_from_sdfs(5, &[(&sphere_a, false, false)]),
            spheres_and_sheet(),
            octree_from_sdfs(4, &[(&sphere_a, false, true), (&sphere_b, false, true)]),
            octree_from_sdfs(5, &[(&tilted_sheet, true, false), (&rim, true, true)]),
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let (mut hits, mut shared_hits, mut samples) = (0, 0, 0);
        for octree in &octrees {
            let bricks = BrickOctree::encode(octree).unwrap();
            let view = BrickOctreeView::new(bricks.as_bytes()).unwrap();
            assert_eq!(
                occupied_bounds(&bricks, 3),
                occupied_bounds(octree, 3),
                "occupied bounds"
            );
            for i in 0..3000 {
                let ray = random_ray(&mut rng);
                let (t_min, t_max) = test_interval(i % 3 == 0);
                let want = intersect(octree, &ray, t_min, t_max);
                let got = intersect(&bricks, &ray, t_min, t_max);
                assert!(
                    same_hit_in(octree, want, &bricks, got),
                    "ray {i} {ray:?}: {got:?} vs {want:?}"
                );
                assert!(same_hit_in(
                    octree,
                    want,
                    &view,
                    intersect(&view, &ray, t_min, t_max)
                ));
                assert_eq!(
                    occluded(&bricks, &ray, t_min, t_max),
                    occluded(octree, &ray, t_min, t_max)
                );
                if let (Some(w), Some(g)) = (want, got) {
                    let (nw, ng) = (crate::hit_normal(&ray, &w), crate::hit_normal(&ray, &g));
                    assert_eq!(
                        nw.to_array().map(f32::to_bits),
                        ng.to_array().map(f32::to_bits)
                    );
                    hits += 1;
                    shared_hits += usize::from(matches!(g.voxel, BrickVoxel::Shared { .. }));
                }
                // The stored distance at points along the ray.
                let p = ray.origin + ray.dir * rng.random_range(0.0..4.0f32);
                let (a, b) = (
                    crate::distance_at(octree, p),
                    crate::distance_at(&bricks, p),
                );
                match (a, b) {
                    (None, None) => {}
                    (Some(a), Some(b)) => {
                        assert_eq!(a.distance.to_bits(), b.distance.to_bits(), "{p}");
                        assert_eq!(a.gradient.to_array(), b.gradient.to_array(), "{p}");
                        assert_eq!(
                            octree.voxel_corners(a.voxel),
                            TracedOctree::voxel_corners(&bricks, b.voxel)
                        );
                        assert_eq!(
                            (a.surface, a.cell_min, a.cell_size),
                            (b.surface, b.cell_min, b.cell_size)
                        );
                        samples += 1;
                    }
                    _ => panic!("distance at {p}: {a:?} vs {b:?}"),
                }
            }
        }
        assert!(
            hits > 2000 && shared_hits > 500,
            "{hits} hits, {shared_hits} shared"
        );
        assert!(samples > 500, "{samples} samples");
    }

    #[test]
    fn lean_step_matches_the_reference_traversal_bit_for_bit() {
        let octrees = [
            octree_from_sdfs(5, &[(&sphere_a, false, false)]),
            spheres_and_sheet(),
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut rays = Vec::new();
        // Random rays (a third with zero components, half starting inside the root).
        for _ in 0..4000 {
            rays.push(random_ray(&mut rng));
        }
        // Primary rays of a pinhole camera on a root mid-plane (x = y = 0, as the paper views),
        // and from a generic eye.
        for eye in [Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.3, -0.7, 2.6)] {
            let dirs = pinhole_dirs(eye, 64, 0.6);
            rays.extend(dirs.into_iter().map(|dir| Ray { origin: eye, dir }));
        }
        // Axis-aligned rays on and between cell planes, both directions, ±0 components.
        for i in -8..=8 {
            for j in -8..=8 {
                for (dir, zero) in [(Vec3::Z, 0.0f32), (-Vec3::Z, -0.0), (Vec3::X, 0.0)] {
                    let (x, y) = (i as f32 / 8.0, j as f32 / 8.0);
                    let origin = if dir.x != 0.0 {
                        Vec3::new(-3.0, x, y)
                    } else {
                        Vec3::new(x, y, -3.0 * dir.z)
                    };
                    let mut d = dir;
                    if d.x == 0.0 {
                        d.x = zero;
                    }
                    rays.push(Ray { origin, dir: d });
                }
            }
        }
        // Rays starting exactly on mid-planes, and a few odd inputs.
        for k in 0..3 {
            for sign in [1.0f32, -1.0] {
                let mut origin = Vec3::new(0.013, -0.021, 0.017);
                origin[k] = 0.0;
                let mut dir = Vec3::new(0.1, 0.2, 0.3);
                dir[k] = sign;
                rays.push(Ray {
                    origin,
                    dir: dir.normalize(),
                });
            }
        }
        rays.push(Ray {
            origin: Vec3::new(f32::INFINITY, 0.1, 0.1),
            dir: -Vec3::X,
        });
        rays.push(Ray {
            origin: Vec3::new(0.0, 0.0, -3.0),
            dir: Vec3::ZERO,
        });
        let ranges = [
            (0.0, f32::INFINITY),
            (0.3, 2.5),
            (2.9, 2.9),
            (f32::NAN, 1.0),
        ];
        let mut hits = 0;
        for octree in &octrees {
            for (i, ray) in rays.iter().enumerate() {
                let (t_min, t_max) = ranges[i % ranges.len()];
                let new = traverse::<_, false>(octree, ray, t_min, t_max, inner_step);
                let old = traverse::<_, false>(octree, ray, t_min, t_max, reference_step);
                assert!(same_hit(new, old), "ray {i} {ray:?}: {new:?} vs {old:?}");
                let new_any = traverse::<_, true>(octree, ray, t_min, t_max, inner_step);
                let old_any = traverse::<_, true>(octree, ray, t_min, t_max, reference_step);
                assert!(same_hit(new_any, old_any), "any, ray {i} {ray:?}");
                hits += usize::from(new.is_some());
            }
        }
        assert!(hits > 1500, "{hits} hits");
    }

    #[test]
    fn occupied_bounds_enclose_the_leaves_and_every_hit() {
        // An off-centre small sphere: its box is much smaller than the root cube.
        let c = Vec3::new(0.3, -0.2, 0.1);
        let sphere = move |p: Vec3| (p - c).length() - 0.25;
        let octree = octree_from_sdfs(5, &[(&sphere, false, false)]);
        let depth = octree.depth();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for (coord, _) in octree.leaves() {
            let (min, h) = cell_min(coord, depth);
            lo = lo.min(min);
            hi = hi.max(min + Vec3::splat(h));
        }
        // At the leaf level the box is exact; coarser levels give boxes around it.
        assert_eq!(occupied_bounds(&octree, depth), Some((lo, hi)));
        assert_eq!(occupied_bounds(&octree, 40), Some((lo, hi)));
        assert_eq!(
            occupied_bounds(&octree, 0),
            Some((Vec3::splat(-1.0), Vec3::ONE))
        );
        let (clo, chi) = occupied_bounds(&octree, 2).unwrap();
        assert!(clo.cmple(lo).all() && chi.cmpge(hi).all());
        assert!((chi - clo).max_element() < 2.0, "{clo} {chi}");
        // No hit outside the box: rays that miss it miss the octree.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut hits, mut rejected) = (0, 0);
        for _ in 0..3000 {
            let ray = random_ray(&mut rng);
            let hit = intersect(&octree, &ray, 0.0, f32::INFINITY);
            if !ray_meets_box(&ray, lo, hi, 0.0, f32::INFINITY) {
                assert!(hit.is_none(), "{ray:?}");
                rejected += 1;
            } else if hit.is_some() {
                hits += 1;
            }
        }
        assert!(
            hits > 100 && rejected > 1000,
            "{hits} hits, {rejected} rejected"
        );
        let empty = PackedOctree::from_leaves(meta(3), Vec::new()).unwrap();
        assert_eq!(occupied_bounds(&empty, 3), None);
    }

    #[test]
    fn sphere_matches_brute_force() {
        let sphere = |p: Vec3| p.length() - 0.7;
        let octree = octree_from_sdfs(5, &[(&sphere, false, false)]);
        let hits = compare_with_brute_force(&octree, 1500, 1);
        assert!(hits > 300, "{hits} hits");
    }

    #[test]
    fn zero_copy_view_traces_like_the_owned_octree() {
        let octree = octree_from_sdfs(
            4,
            &[(&sphere_a, false, false), (&tilted_sheet, true, false)],
        );
        let bytes = octree.to_bytes();
        let view = PackedOctreeView::new(&bytes).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut hits = 0;
        for _ in 0..500 {
            let ray = random_ray(&mut rng);
            let owned = intersect(&octree, &ray, 0.0, f32::INFINITY);
            assert_eq!(owned, intersect(&view, &ray, 0.0, f32::INFINITY));
            assert_eq!(owned.is_some(), occluded(&view, &ray, 0.0, f32::INFINITY));
            if let Some(h) = owned {
                assert_eq!(crate::hit_normal(&ray, &h), crate::hit_normal(&ray, &h));
                hits += 1;
            }
        }
        assert!(hits > 100, "{hits}");
    }

    #[test]
    fn multi_voxel_leaves_keep_the_nearest_hit() {
        let octree = spheres_and_sheet();
        assert!(octree.voxel_count() > octree.leaf_count() + 50);
        let hits = compare_with_brute_force(&octree, 1500, 2);
        assert!(hits > 300, "{hits} hits");
    }

    #[test]
    fn axis_aligned_rays_between_and_on_cell_planes() {
        let sphere = |p: Vec3| p.length() - 0.6;
        let octree = octree_from_sdfs(4, &[(&sphere, false, false)]);
        // Along ±z through a grid of points, including exactly on cell planes (multiples of
        // 1/8) where the ray runs inside the shared faces of neighbouring cells.
        for i in -8..=8 {
            for j in -8..=8 {
                for sign in [1.0f32, -1.0] {
                    let (x, y) = (i as f32 / 8.0, j as f32 / 8.0);
                    let ray = Ray {
                        origin: Vec3::new(x, y, -3.0 * sign),
                        dir: Vec3::Z * sign,
                    };
                    let got = intersect(&octree, &ray, 0.0, f32::INFINITY);
                    let expected = brute_force(&octree, &ray, 0.0, f32::INFINITY);
                    match (got, expected) {
                        (Some(g), Some(e)) => {
                            assert!((g.t - e).abs() < 1e-4, "{x} {y}: {} vs {e}", g.t)
                        }
                        (None, None) => {}
                        _ => panic!("{x} {y} {sign}: {got:?} vs {expected:?}"),
                    }
                    // The analytic sphere is hit where x² + y² < 0.6² − margin.
                    if x * x + y * y < 0.5 * 0.5 {
                        assert!(got.is_some(), "{x} {y}");
                    }
                }
            }
        }
    }

    #[test]
    fn rays_starting_inside_a_solid_hit_at_t_min() {
        let sphere = |p: Vec3| p.length() - 0.7;
        let octree = octree_from_sdfs(5, &[(&sphere, false, false)]);
        // From a point just inside the surface (its leaf is stored), any direction.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..200 {
            let n = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let origin = n * 0.69;
            let dir = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let hit = intersect(&octree, &Ray { origin, dir }, 0.0, 10.0).expect("inside");
            assert_eq!(hit.t, 0.0);
        }
    }

    #[test]
    fn rays_starting_on_a_mid_plane_enter_the_side_they_move_to() {
        // Origins exactly on the root's mid-planes (t_enter = 0 = the plane's crossing time):
        // the ray must start in the child it moves into, on every axis and in both directions.
        for axis in 0..3 {
            for sign in [1.0f32, -1.0] {
                let mut centre = Vec3::ZERO;
                centre[axis] = 0.5 * sign;
                let sphere = move |p: Vec3| (p - centre).length() - 0.3;
                let octree = octree_from_sdfs(4, &[(&sphere, false, false)]);
                let mut origin = Vec3::new(0.013, -0.021, 0.017);
                origin[axis] = 0.0;
                let mut dir = Vec3::ZERO;
                dir[axis] = sign;
                let hit = intersect(&octree, &Ray { origin, dir }, 0.0, 5.0).expect("hit");
                assert!(
                    (hit.t - 0.2).abs() < 0.01,
                    "axis {axis} sign {sign}: {}",
                    hit.t
                );
            }
        }
    }

    #[test]
    fn empty_and_nan_inputs() {
        let sphere = |p: Vec3| p.length() - 0.7;
        let octree = octree_from_sdfs(3, &[(&sphere, false, false)]);
        let ray = Ray {
            origin: Vec3::new(0.0, 0.0, -3.0),
            dir: Vec3::Z,
        };
        assert!(
            intersect(&octree, &ray, 0.0, 1.0).is_none(),
            "t_max before the sphere"
        );
        assert!(intersect(&octree, &ray, 2.0, 1.0).is_none(), "empty range");
        assert!(intersect(&octree, &ray, f32::NAN, 10.0).is_none());
        let nan = Ray {
            origin: Vec3::NAN,
            dir: Vec3::Z,
        };
        assert!(intersect(&octree, &nan, 0.0, 10.0).is_none());
        let zero = Ray {
            origin: Vec3::new(0.0, 0.0, -3.0),
            dir: Vec3::ZERO,
        };
        assert!(intersect(&octree, &zero, 0.0, 10.0).is_none());
        let miss = Ray {
            origin: Vec3::new(0.0, 3.0, -3.0),
            dir: Vec3::Z,
        };
        assert!(intersect(&octree, &miss, 0.0, 10.0).is_none());
        let hit = intersect(&octree, &ray, 0.0, 10.0).unwrap();
        assert!((hit.t - 2.3).abs() < 0.05, "{}", hit.t);
    }

    #[test]
    fn depth_zero_octree_is_a_single_leaf() {
        let corners = core::array::from_fn(|i| ((i >> 1) & 1) as f32 * 2.0 - 1.0); // f = y
        let leaf = LeafInput {
            coord: [0, 0, 0],
            voxels: vec![Voxel {
                corners,
                surface: true,
                clip: false,
            }],
        };
        let octree = PackedOctree::from_leaves(meta(0), vec![leaf]).unwrap();
        let ray = Ray {
            origin: Vec3::new(0.2, 2.0, 0.1),
            dir: -Vec3::Y,
        };
        let hit = intersect(&octree, &ray, 0.0, 10.0).unwrap();
        assert!((hit.t - 2.0).abs() < 1e-5);
        assert!(hit.surface);
        assert_eq!(hit.cell_size, 2.0);
    }
}
