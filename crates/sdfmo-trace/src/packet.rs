//! Coherent packets of rays that share their origin (the primary rays of a pinhole camera):
//! one walk of the octree for [`PACKET_SIZE`] rays, with exactly the hits of [`intersect`] on
//! each ray.
//!
//! Why: on the paper views three quarters of the inner nodes a single ray visits lie in the top
//! six levels (abc1, depth 9: 1.0 M of 1.37 M inner visits per 1024² frame), and neighbouring
//! pixels visit the same ones. A packet reads each node once and does the per-ray arithmetic
//! for all its rays side by side (arrays of lanes the compiler vectorises).
//!
//! Why the hits are those of [`intersect`], bit for bit:
//! * every lane computes the same quantities with the same f32 operations as the single-ray
//!   step (`tm = (mid − o)·inv`, the entry octant, the crossings inside `(t_enter, t_exit)`
//!   sorted by the same stable comparator network), so a child is in a lane's mask exactly when
//!   the single-ray traversal of that ray visits it, and with the same span;
//! * children are visited in one order for the whole packet: by the number of octant bits that
//!   differ from the octant holding the common origin. Along any ray from that origin with
//!   `t ≥ 0` a mid-plane is crossed at most once and only away from the origin's side, so the
//!   children one ray visits differ from that octant in strictly growing sets of bits: this
//!   order restricted to any ray's children is that ray's own order;
//! * leaves run the same per-ray leaf test on each lane's span, and a lane stops at its first
//!   hit, as the single ray does.
//!
//! The unit test `packets_hit_exactly_like_single_rays` checks it against [`intersect`] on many
//! cameras (eyes on and off the root's mid-planes, axis-parallel rays, partial packets).
//!
//! [`intersect`]: crate::intersect

use glam::Vec3;
use sdfmo_format::{TracedOctree, MAX_DEPTH};

use crate::ray_voxel::{intersect_prepared, prepare_voxel, PreparedVoxel};
use crate::traversal::{child_at, le, root_span, split_span, CellStack, Hit};

/// Rays per packet (lanes).
pub const PACKET_SIZE: usize = 8;

/// Stack capacity: a node pushes at most seven children and continues with the eighth, so a
/// descent to depth `d` holds at most `7d + 1` entries; [`MAX_DEPTH`] bounds `d`.
const PACKET_STACK: usize = 7 * MAX_DEPTH as usize + 2;

/// The cells a packet has still to visit.
type PacketStack<N> = CellStack<PacketCell<N>, PACKET_STACK>;

/// Children in order of the number of bits that differ from the near octant (0, then the three
/// one-bit flips, the three two-bit flips, the far octant).
const NEAR_TO_FAR: [u32; 8] = [0, 1, 2, 4, 3, 5, 6, 7];

/// A cell and the lanes that visit it, with each lane's span.
#[derive(Clone, Copy)]
struct PacketCell<N> {
    node: N,
    min: Vec3,
    size: f32,
    lanes: u32,
    t_enter: [f32; PACKET_SIZE],
    t_exit: [f32; PACKET_SIZE],
}

/// The per-ray constants of a packet: the inverse directions lane by lane and the axes along
/// which each ray moves towards − (octant bits).
struct Lanes {
    inv: [[f32; PACKET_SIZE]; 3],
    negative: [u32; PACKET_SIZE],
}

/// Up to [`PACKET_SIZE`] rays `origin + t·dirs[i]`, `t ∈ [0, t_max]`, that share their origin
/// (the primary rays of neighbouring pixels): lane `i` is traced when bit `i` of `lanes` is set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayPacket {
    /// The origin of every ray (the eye).
    pub origin: Vec3,
    /// One direction per lane (any length; the hit's `t` is in units of it).
    pub dirs: [Vec3; PACKET_SIZE],
    /// Bit `i` set: lane `i` is traced; the others are ignored.
    pub lanes: u32,
    /// The far end of every ray's span.
    pub t_max: f32,
}

/// The first hit of each lane of `rays` (lanes not traced: `None`): for every traced ray
/// exactly what [`intersect`]`(octree, ray, 0.0, t_max)` returns, found in one walk of the
/// octree for the whole packet. Fastest when the rays are close together (neighbouring pixels).
///
/// [`intersect`]: crate::intersect
pub fn intersect_packet<O: TracedOctree>(
    octree: &O,
    rays: &RayPacket,
) -> [Option<Hit<O::Voxel>>; PACKET_SIZE] {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_walk() {
        // SAFETY: the CPU has AVX2, POPCNT, LZCNT, BMI1 and BMI2.
        return unsafe { packet_avx2(octree, rays) };
    }
    packet::<
        O,
        {
            if cfg!(target_arch = "x86_64") {
                SSE2
            } else {
                SCALAR
            }
        },
    >(octree, rays)
}

// Why the inner-node step is written three times, two of them in `core::arch` intrinsics
// rather than left to the compiler or a portable-SIMD crate (measured, docs/results/render.md,
// "Render time" history; CPU per frame, abc1 / abc5 depth 9, 1024², one thread, A/B rounds
// against the commit before): the plain-Rust lane loop written for autovectorisation was
// slower than the scalar step (33.4 against 30.5 ms on abc1: the compiler did not vectorise
// the sort network and child masks); the SSE2 step (f2eaf38) took abc1 32.1 → 29.9 ms and abc5
// 39.2 → 36.1 ms; the AVX2 step, eight lanes in one register, detected at run time (86263cd),
// 29.3 → 24.5 ms and 33.2 → 28.6 ms (instructions per two frames 529 M → 419 M on abc1).
// Compiling the scalar step for AVX2 alone changed nothing. All three steps give the same
// bits (tests below). A portable-SIMD crate was not measured.

/// Inner-node steps of [`packet`]: lane by lane.
const SCALAR: u8 = 0;
/// Inner-node steps of [`packet`]: SSE2, two registers of four lanes (x86-64 only).
const SSE2: u8 = 1;
/// Inner-node steps of [`packet`]: AVX2, one register of eight lanes (x86-64 CPUs with AVX2).
const AVX2: u8 = 2;

/// Whether the CPU runs [`packet_avx2`]: AVX2 and the bit instructions every AVX2 CPU has
/// (POPCNT, LZCNT, BMI1, BMI2; Intel since Haswell, AMD since Excavator).
#[cfg(target_arch = "x86_64")]
#[inline]
fn has_avx2_walk() -> bool {
    std::is_x86_feature_detected!("avx2")
        && std::is_x86_feature_detected!("popcnt")
        && std::is_x86_feature_detected!("lzcnt")
        && std::is_x86_feature_detected!("bmi1")
        && std::is_x86_feature_detected!("bmi2")
}

/// [`packet`] with the AVX2 step, compiled for AVX2 CPUs (the rest in three-operand VEX form;
/// Rust never fuses a multiply and an add by itself, so the same bits). With POPCNT, LZCNT and
/// BMI: without them a popcount (child indices, a 3.x voxel's point ranks) was some 15
/// instructions in software; with them 5 % fewer instructions per 1.x frame and 3 % per 3.1
/// frame (abc1 depth 9 multi, paper view 0, callgrind: 180.7 → 171.9 M, 219.5 → 212.8 M).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,lzcnt,bmi1,bmi2")]
unsafe fn packet_avx2<O: TracedOctree>(
    octree: &O,
    rays: &RayPacket,
) -> [Option<Hit<O::Voxel>>; PACKET_SIZE] {
    packet::<O, AVX2>(octree, rays)
}

/// The packet walk; `STEP` ([`SCALAR`], [`SSE2`], [`AVX2`]) picks the inner-node step (all give
/// the same bits; [`AVX2`] only from [`packet_avx2`], SSE2 only on x86-64).
#[inline(always)]
fn packet<O: TracedOctree, const STEP: u8>(
    octree: &O,
    rays: &RayPacket,
) -> [Option<Hit<O::Voxel>>; PACKET_SIZE] {
    let RayPacket {
        origin,
        ref dirs,
        lanes,
        t_max,
    } = *rays;
    let mut out = [None; PACKET_SIZE];
    let Some(root) = octree.root() else {
        return out;
    };
    if !le(0.0, t_max) {
        return out;
    }
    let o = origin;
    let mut consts = Lanes {
        inv: [[0.0; PACKET_SIZE]; 3],
        negative: [0; PACKET_SIZE],
    };
    let mut t_enter = [0.0f32; PACKET_SIZE];
    let mut t_exit = [0.0f32; PACKET_SIZE];
    let mut alive = 0u32;
    for (l, d) in dirs.iter().enumerate() {
        // The single-ray set-up, lane by lane.
        let (inv, te, tx) = root_span(o, *d, 0.0, t_max);
        consts.inv[0][l] = inv.x;
        consts.inv[1][l] = inv.y;
        consts.inv[2][l] = inv.z;
        consts.negative[l] =
            u32::from(inv.x < 0.0) << 2 | u32::from(inv.y < 0.0) << 1 | u32::from(inv.z < 0.0);
        t_enter[l] = te;
        t_exit[l] = tx;
        if lanes >> l & 1 != 0 && le(te, tx) {
            alive |= 1 << l;
        }
    }
    if alive == 0 {
        return out;
    }

    let mut stack = PacketStack::<O::Node>::new();
    let mut leaf = LeafLanes::<O>::new();
    let mut cell = PacketCell {
        node: root,
        min: Vec3::splat(-1.0),
        size: 2.0,
        lanes: alive,
        t_enter,
        t_exit,
    };
    loop {
        let lanes = cell.lanes & alive;
        if lanes != 0 {
            if octree.is_leaf(cell.node) {
                packet_leaf(octree, &cell, lanes, rays, &mut leaf, &mut out, &mut alive);
                if alive == 0 {
                    return out;
                }
            } else {
                let mut children = Children::new(octree, &cell, lanes, o, &consts, &mut stack);
                match STEP {
                    // SAFETY: STEP = AVX2 only in `packet_avx2`, called once AVX2 is detected.
                    #[cfg(target_arch = "x86_64")]
                    AVX2 => unsafe { packet_step_avx2(&mut children) },
                    // SAFETY: SSE2 is part of the x86-64 baseline.
                    #[cfg(target_arch = "x86_64")]
                    SSE2 => unsafe { packet_step_wide::<Sse2, O>(&mut children) },
                    _ => packet_step(&mut children),
                }
                if let Some(next) = children.pending {
                    cell = next;
                    continue;
                }
            }
        }
        match stack.pop() {
            Some(next) => cell = next,
            None => return out,
        }
    }
}

/// A lane's nearest voxel so far in a leaf: the voxel, its surface flag and its corners (for
/// the hit, see [`Hit::corners`]).
type LaneBest<V> = (V, bool, [f32; 8]);

/// Each lane's ray in a leaf's frame and its nearest voxel so far, and the octree's
/// [`TracedOctree::LeafCache`] for the packet's leaves: made once per packet and set for a
/// leaf's lanes only (zeroing all eight lanes at every leaf visit cost ~ 0.4 % of a frame:
/// callgrind, abc1 depth 9 multi, paper view 0).
struct LeafLanes<O: TracedOctree> {
    local_o: [Vec3; PACKET_SIZE],
    local_d: [Vec3; PACKET_SIZE],
    best_s: [f32; PACKET_SIZE],
    best: [Option<LaneBest<O::Voxel>>; PACKET_SIZE],
    cache: O::LeafCache,
}

impl<O: TracedOctree> LeafLanes<O> {
    #[inline(always)]
    fn new() -> Self {
        LeafLanes {
            local_o: [Vec3::ZERO; PACKET_SIZE],
            local_d: [Vec3::ZERO; PACKET_SIZE],
            best_s: [0.0; PACKET_SIZE],
            best: [None; PACKET_SIZE],
            cache: O::LeafCache::default(),
        }
    }
}

/// A leaf for the lanes `lanes`: for each, exactly the single-ray leaf test (the nearest voxel
/// hit in its span, voxels in storage order), with each voxel's corners read and prepared once
/// for all lanes (of `rays`, those in `lanes`). Lanes that hit get their hit in `out` and leave
/// `alive`.
#[inline(always)]
fn packet_leaf<O: TracedOctree>(
    octree: &O,
    cell: &PacketCell<O::Node>,
    lanes: u32,
    rays: &RayPacket,
    leaf: &mut LeafLanes<O>,
    out: &mut [Option<Hit<O::Voxel>>; PACKET_SIZE],
    alive: &mut u32,
) {
    let (o, dirs) = (rays.origin, &rays.dirs);
    // As in the single-ray leaf test: the local frame [0,1]³ from each lane's entry point.
    let inv_size = 1.0 / cell.size;
    let mut rest = lanes;
    while rest != 0 {
        let l = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        leaf.local_o[l] = (o + dirs[l] * cell.t_enter[l] - cell.min) * inv_size;
        leaf.local_d[l] = dirs[l] * inv_size;
        leaf.best_s[l] = cell.t_exit[l] - cell.t_enter[l];
        leaf.best[l] = None;
    }
    let voxels = octree.leaf_voxels(cell.node);
    if octree.any_clip_voxel(&voxels) {
        // A leaf with clip voxels takes the clip rule, lane by lane (as the single-ray test).
        let mut rest = lanes;
        while rest != 0 {
            let l = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let hit = crate::clip::leaf_hit::<O, false>(
                octree,
                voxels.clone(),
                leaf.local_o[l],
                leaf.local_d[l],
                leaf.best_s[l],
            );
            if let Some((s, voxel, surface)) = hit {
                leaf.best_s[l] = s;
                leaf.best[l] = Some((voxel, surface, octree.voxel_corners(voxel)));
            }
        }
    } else {
        packet_leaf_voxels(octree, voxels, lanes, leaf);
    }
    let mut rest = lanes;
    while rest != 0 {
        let l = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        if let Some((voxel, surface, corners)) = leaf.best[l] {
            out[l] = Some(Hit {
                t: (cell.t_enter[l] + leaf.best_s[l]).min(cell.t_exit[l]),
                voxel,
                cell_min: cell.min,
                cell_size: cell.size,
                surface,
                corners,
            });
            *alive &= !(1 << l);
        }
    }
}

/// The plain leaf rule (no clip voxels) for the packet's `lanes`: each voxel prepared once, the
/// nearest hit per lane (as the single-ray leaf test).
#[inline(always)]
fn packet_leaf_voxels<O: TracedOctree>(
    octree: &O,
    voxels: O::Voxels,
    lanes: u32,
    leaf: &mut LeafLanes<O>,
) {
    let LeafLanes {
        local_o,
        local_d,
        best_s,
        best,
        cache,
    } = leaf;
    for voxel in voxels {
        let corners = octree.voxel_corners_with(voxel, cache);
        let prepared = prepare_voxel(&corners);
        if let PreparedVoxel::Miss = prepared {
            continue; // no lane can hit it
        }
        let surface = octree.voxel_is_surface(voxel);
        let mut rest = lanes;
        while rest != 0 {
            let l = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            if let Some(s) = intersect_prepared(
                &prepared,
                local_o[l],
                local_d[l],
                (0.0, best_s[l]),
                surface,
                |_, _| true,
            ) {
                if best[l].is_none() || s < best_s[l] {
                    best_s[l] = s;
                    best[l] = Some((voxel, surface, corners));
                }
            }
        }
    }
}

/// One inner node being split for a packet's `lanes`, and its children as a step emits them,
/// farthest first (in the reverse of [`NEAR_TO_FAR`] from the octant `near` holding the common
/// origin; either side where it lies on a mid-plane: no ray with t ≥ 0 then crosses that plane
/// inside a span): each present child with the lanes that visit it and their spans. The
/// nearest is kept back in `pending` for the walk to take, the others go on the stack.
struct Children<'a, O: TracedOctree> {
    octree: &'a O,
    cell: &'a PacketCell<O::Node>,
    lanes: u32,
    consts: &'a Lanes,
    stack: &'a mut PacketStack<O::Node>,
    half: f32,
    mid: Vec3,
    /// From the common origin to `mid`.
    d: Vec3,
    mask: u32,
    near: u32,
    first: Option<O::Children>,
    pending: Option<PacketCell<O::Node>>,
}

impl<'a, O: TracedOctree> Children<'a, O> {
    #[inline(always)]
    fn new(
        octree: &'a O,
        cell: &'a PacketCell<O::Node>,
        lanes: u32,
        o: Vec3,
        consts: &'a Lanes,
        stack: &'a mut PacketStack<O::Node>,
    ) -> Self {
        let half = 0.5 * cell.size;
        let mid = cell.min + Vec3::splat(half);
        let near =
            u32::from(o.x >= mid.x) << 2 | u32::from(o.y >= mid.y) << 1 | u32::from(o.z >= mid.z);
        Children {
            octree,
            cell,
            lanes,
            consts,
            stack,
            half,
            mid,
            d: mid - o,
            mask: u32::from(octree.child_mask(cell.node)),
            near,
            first: None,
            pending: None,
        }
    }

    /// The present children among `candidates` (a mask of octants), farthest first (the
    /// reverse of [`NEAR_TO_FAR`] from `near`).
    #[inline(always)]
    fn present_far_to_near(&self, candidates: u32) -> FarToNear {
        FarToNear::new(self.mask & candidates, self.near)
    }

    /// The present child `c`, visited by `lanes` over their spans.
    #[inline(always)]
    fn add(&mut self, c: u32, lanes: u32, t_enter: [f32; PACKET_SIZE], t_exit: [f32; PACKET_SIZE]) {
        let (octree, node) = (self.octree, self.cell.node);
        let first = *self.first.get_or_insert_with(|| octree.children(node));
        // Exact, as in the single-ray step.
        let (node, min) = child_at(octree, first, self.mask, c, self.cell.min, self.mid);
        let child = PacketCell {
            node,
            min,
            size: self.half,
            lanes,
            t_enter,
            t_exit,
        };
        self.stack.defer(&mut self.pending, child);
    }
}

/// One inner node for a packet, lane by lane: each present child with the lanes that visit it
/// and their spans (those of the single-ray step, see [`crate::traversal`]).
#[inline(always)]
fn packet_step<O: TracedOctree>(children: &mut Children<'_, O>) {
    let (cell, consts, d) = (children.cell, children.consts, children.d);

    // Each lane walks its own child sequence with the single-ray split of its span (entry
    // octant, the crossings inside (t_enter, t_exit) sorted by the same stable network, each
    // flipping its bit) and marks the children it visits with its span. Only the packet's live
    // lanes run.
    let mut visit = [0u32; 8];
    let mut t_enter = [[0.0f32; PACKET_SIZE]; 8];
    let mut t_exit = [[0.0f32; PACKET_SIZE]; 8];
    let mut rest = children.lanes;
    while rest != 0 {
        let l = rest.trailing_zeros() as usize;
        let bit = rest & rest.wrapping_neg();
        rest &= rest - 1;
        let (te, tx) = (cell.t_enter[l], cell.t_exit[l]);
        let tm = Vec3::new(
            d.x * consts.inv[0][l],
            d.y * consts.inv[1][l],
            d.z * consts.inv[2][l],
        );
        let (behind, [k0, k1, k2], [b0, b1, b2]) = split_span(tm, te, tx);
        let mut c = (u32::from(behind) ^ consts.negative[l]) as usize;
        visit[c] |= bit;
        t_enter[c][l] = te;
        t_exit[c][l] = k0;
        // (An uncrossed key is `tx`, so `k_i` ends the child after `i` crossings.)
        for (b, a, z) in [(b0, k0, k1), (b1, k1, k2), (b2, k2, tx)] {
            if b == 0 {
                break;
            }
            c ^= b as usize;
            visit[c] |= bit;
            t_enter[c][l] = a;
            t_exit[c][l] = z;
        }
    }

    let visited = (0..8).fold(0, |m, c| m | u32::from(visit[c] != 0) << c);
    for c in children.present_far_to_near(visited) {
        let i = c as usize;
        children.add(c, visit[i], t_enter[i], t_exit[i]);
    }
}

/// The set bits `c` of a child mask in the reverse of [`NEAR_TO_FAR`] from the octant `near`,
/// by `leading_zeros` over the mask reordered by one table load ([`FAR_TO_NEAR_BITS`]), so
/// that absent children cost nothing.
///
/// Why: testing all eight octants of [`NEAR_TO_FAR`] for presence, then for lanes, was the
/// hottest loop of a frame (per 1024² frame of abc1 depth 9: 1.9 M octants tested, 1.0 M
/// present, 0.34 M with lanes; callgrind). Skipping the absent ones and, with the octants the
/// live lanes visit, the unvisited ones: 5 % fewer instructions per frame (190.6 → 180.7 M).
struct FarToNear {
    /// Bit `i` set when the child `near ^ NEAR_TO_FAR[i]` is in the mask.
    rest: u32,
    near: u32,
}

/// `FAR_TO_NEAR_BITS[near][mask]`: bit `i` set when bit `near ^ NEAR_TO_FAR[i]` of `mask` is.
const FAR_TO_NEAR_BITS: [[u8; 256]; 8] = {
    let mut t = [[0u8; 256]; 8];
    let mut k = 0;
    while k < 8 * 256 {
        let (near, mask) = (k / 256, k % 256);
        let mut i = 0;
        while i < 8 {
            t[near][mask] |= (((mask >> (near as u32 ^ NEAR_TO_FAR[i])) & 1) << i) as u8;
            i += 1;
        }
        k += 1;
    }
    t
};

impl FarToNear {
    #[inline(always)]
    fn new(mask: u32, near: u32) -> Self {
        FarToNear {
            rest: u32::from(FAR_TO_NEAR_BITS[near as usize & 7][mask as usize & 0xff]),
            near,
        }
    }
}

impl Iterator for FarToNear {
    type Item = u32;

    #[inline(always)]
    fn next(&mut self) -> Option<u32> {
        if self.rest == 0 {
            return None;
        }
        let i = 31 - self.rest.leading_zeros();
        self.rest ^= 1 << i;
        Some(self.near ^ NEAR_TO_FAR[i as usize & 7])
    }
}

/// Declares [`Lanes8`], the operations of the vector step on the packet's eight lanes, and
/// implements it for [`Sse2`] and [`Avx2`] from one table: a row per operation, its SSE2 form
/// (two registers of four lanes, `pair` applying a form to each) and its AVX2 form; then the
/// binary integer operations, a row each naming the two instructions (`int_op!`).
#[cfg(target_arch = "x86_64")]
macro_rules! lanes8 {
    (
        $(fn $op:ident($($arg:ident: $ty:ty),*) -> $ret:ty { sse2: $sse2:expr, avx2: $avx2:expr })*
        integer { $($int_op:ident: $int_sse2:ident, $int_avx2:ident;)* }
    ) => {
        lanes8! {
            @rows
            $(fn $op($($arg: $ty),*) -> $ret { sse2: $sse2, avx2: $avx2 })*
            $(fn $int_op(a: Self, b: Self) -> Self {
                sse2: int_op!($int_sse2, a, b, h),
                avx2: int_op!($int_avx2, a, b)
            })*
        }
    };
    (@rows $(fn $op:ident($($arg:ident: $ty:ty),*) -> $ret:ty { sse2: $sse2:expr, avx2: $avx2:expr })*) => {
        /// The packet's eight f32 lanes (or u32 lanes in the same bits) in SIMD registers, for
        /// [`packet_step_wide`]. Comparisons give all-ones or all-zero lanes and are false on
        /// NaN (ordered predicates), like Rust's; arithmetic is IEEE, like the scalar code.
        ///
        /// # Safety
        /// Every operation needs the type's instruction set on the running CPU.
        trait Lanes8: Copy {
            $(unsafe fn $op($($arg: $ty),*) -> $ret;)*
        }
        impl Lanes8 for Sse2 {
            $(
                #[inline(always)]
                unsafe fn $op($($arg: $ty),*) -> $ret {
                    // SAFETY: the caller guarantees SSE2 (loads and stores: eight f32/u32 of
                    // a PACKET_SIZE array, unaligned).
                    unsafe { $sse2 }
                }
            )*
        }
        impl Lanes8 for Avx2 {
            $(
                #[inline(always)]
                unsafe fn $op($($arg: $ty),*) -> $ret {
                    // SAFETY: the caller guarantees AVX2 (loads and stores as above).
                    unsafe { $avx2 }
                }
            )*
        }
    };
}

/// Eight lanes as two SSE2 registers (part of every x86-64 CPU).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Sse2([core::arch::x86_64::__m128; 2]);

/// Eight lanes as one AVX register (CPUs with AVX2).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx2(core::arch::x86_64::__m256);

/// `f` on each half of an [`Sse2`].
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn pair(f: impl Fn(usize) -> core::arch::x86_64::__m128) -> Sse2 {
    Sse2([f(0), f(1)])
}

#[cfg(target_arch = "x86_64")]
use core::arch::x86_64::*;

#[cfg(target_arch = "x86_64")]
const _: () = assert!(
    PACKET_SIZE == 8,
    "two SSE registers or one AVX register of lanes"
);

/// The OR of the four u32 lanes of `x` (SSE2).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn or_across_128(x: __m128i) -> u32 {
    // SAFETY: SSE2 is part of the x86-64 baseline.
    unsafe {
        let x = _mm_or_si128(x, _mm_shuffle_epi32(x, 0b01_00_11_10));
        let x = _mm_or_si128(x, _mm_shuffle_epi32(x, 0b10_11_00_01));
        _mm_cvtsi128_si32(x) as u32
    }
}

/// An integer instruction on the lanes' bits: `int_op!(op, a, b, h)` applies an SSE2 `op` to
/// each half of two [`Sse2`], `int_op!(op, a, b)` an AVX2 `op` to two [`Avx2`] (the casts
/// reinterpret the bits; they emit no instruction).
#[cfg(target_arch = "x86_64")]
macro_rules! int_op {
    ($op:ident, $a:ident, $b:ident, $h:ident) => {
        pair(|$h| _mm_castsi128_ps($op(_mm_castps_si128($a.0[$h]), _mm_castps_si128($b.0[$h]))))
    };
    ($op:ident, $a:ident, $b:ident) => {
        Avx2(_mm256_castsi256_ps($op(
            _mm256_castps_si256($a.0),
            _mm256_castps_si256($b.0),
        )))
    };
}

#[cfg(target_arch = "x86_64")]
lanes8! {
    fn splat(x: f32) -> Self { sse2: pair(|_| _mm_set1_ps(x)), avx2: Avx2(_mm256_set1_ps(x)) }
    fn splat_u(x: u32) -> Self {
        sse2: pair(|_| _mm_castsi128_ps(_mm_set1_epi32(x as i32))),
        avx2: Avx2(_mm256_castsi256_ps(_mm256_set1_epi32(x as i32)))
    }
    fn load(a: &[f32; PACKET_SIZE]) -> Self {
        sse2: pair(|h| _mm_loadu_ps(a.as_ptr().add(4 * h))),
        avx2: Avx2(_mm256_loadu_ps(a.as_ptr()))
    }
    fn load_u(a: &[u32; PACKET_SIZE]) -> Self {
        sse2: pair(|h| _mm_castsi128_ps(_mm_loadu_si128(a.as_ptr().add(4 * h).cast()))),
        avx2: Avx2(_mm256_castsi256_ps(_mm256_loadu_si256(a.as_ptr().cast())))
    }
    fn store(v: Self, a: &mut [f32; PACKET_SIZE]) -> () {
        sse2: (0..2).for_each(|h| _mm_storeu_ps(a.as_mut_ptr().add(4 * h), v.0[h])),
        avx2: _mm256_storeu_ps(a.as_mut_ptr(), v.0)
    }
    fn mul(a: Self, b: Self) -> Self {
        sse2: pair(|h| _mm_mul_ps(a.0[h], b.0[h])),
        avx2: Avx2(_mm256_mul_ps(a.0, b.0))
    }
    fn le(a: Self, b: Self) -> Self {
        sse2: pair(|h| _mm_cmple_ps(a.0[h], b.0[h])),
        avx2: Avx2(_mm256_cmp_ps::<_CMP_LE_OQ>(a.0, b.0))
    }
    fn lt(a: Self, b: Self) -> Self {
        sse2: pair(|h| _mm_cmplt_ps(a.0[h], b.0[h])),
        avx2: Avx2(_mm256_cmp_ps::<_CMP_LT_OQ>(a.0, b.0))
    }
    fn gt(a: Self, b: Self) -> Self {
        sse2: pair(|h| _mm_cmpgt_ps(a.0[h], b.0[h])),
        avx2: Avx2(_mm256_cmp_ps::<_CMP_GT_OQ>(a.0, b.0))
    }
    fn and(a: Self, b: Self) -> Self {
        sse2: pair(|h| _mm_and_ps(a.0[h], b.0[h])),
        avx2: Avx2(_mm256_and_ps(a.0, b.0))
    }
    fn or(a: Self, b: Self) -> Self {
        sse2: pair(|h| _mm_or_ps(a.0[h], b.0[h])),
        avx2: Avx2(_mm256_or_ps(a.0, b.0))
    }
    fn sel(m: Self, a: Self, b: Self) -> Self {
        sse2: pair(|h| _mm_or_ps(_mm_and_ps(m.0[h], a.0[h]), _mm_andnot_ps(m.0[h], b.0[h]))),
        avx2: Avx2(_mm256_blendv_ps(b.0, a.0, m.0))
    }
    fn movemask(a: Self) -> u32 {
        sse2: (_mm_movemask_ps(a.0[0]) | _mm_movemask_ps(a.0[1]) << 4) as u32,
        avx2: _mm256_movemask_ps(a.0) as u32
    }
    // `1 << a` of lanes `a` in 0..=8 (SSE2 has no variable shift: 2^a built as an f32's
    // exponent and converted, exact).
    fn octant_bit(a: Self) -> Self {
        sse2: pair(|h| _mm_castsi128_ps(_mm_cvttps_epi32(_mm_castsi128_ps(_mm_slli_epi32(
            _mm_add_epi32(_mm_castps_si128(a.0[h]), _mm_set1_epi32(127)),
            23,
        ))))),
        avx2: Avx2(_mm256_castsi256_ps(_mm256_sllv_epi32(
            _mm256_set1_epi32(1),
            _mm256_castps_si256(a.0),
        )))
    }
    // The OR of the eight lanes' bits.
    fn or_across(a: Self) -> u32 {
        sse2: or_across_128(_mm_or_si128(_mm_castps_si128(a.0[0]), _mm_castps_si128(a.0[1]))),
        avx2: or_across_128(_mm_or_si128(
            _mm256_castsi256_si128(_mm256_castps_si256(a.0)),
            _mm256_extracti128_si256(_mm256_castps_si256(a.0), 1),
        ))
    }
    // Operations on the lanes' bits as u32 (`int_op!`): the SSE2 and the AVX2 instruction.
    integer {
        and_u: _mm_and_si128, _mm256_and_si256;
        or_u: _mm_or_si128, _mm256_or_si256;
        xor_u: _mm_xor_si128, _mm256_xor_si256;
        eq_u: _mm_cmpeq_epi32, _mm256_cmpeq_epi32;
    }
}

/// [`packet_step`] with SIMD ([`Sse2`] or [`Avx2`] lanes), all eight lanes at once: the same
/// comparisons and the same f32 products lane by lane, so the same children, spans and bits.
/// Lanes outside `lanes` are computed too and masked off.
///
/// Each lane's child sequence is kept as four octants (`seq[p]`: after p crossings; 8 where
/// there is no p-th crossing) and five bounds (`t_enter`, the three sorted keys, `t_exit`); a
/// child is visited by the lanes whose sequence holds it, over `[bound p, bound p + 1]`.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn packet_step_wide<V: Lanes8, O: TracedOctree>(children: &mut Children<'_, O>) {
    let (cell, consts, d) = (children.cell, children.consts, children.d);
    // SAFETY: the caller guarantees V's instruction set.
    unsafe {
        let te = V::load(&cell.t_enter);
        let tx = V::load(&cell.t_exit);
        let tmx = V::mul(V::splat(d.x), V::load(&consts.inv[0]));
        let tmy = V::mul(V::splat(d.y), V::load(&consts.inv[1]));
        let tmz = V::mul(V::splat(d.z), V::load(&consts.inv[2]));
        let bits = |m: V, b: u32| V::and_u(m, V::splat_u(b));
        // Entry octant: `tm ≤ te` (behind), xor the negative axes.
        let behind = V::or_u(
            V::or_u(bits(V::le(tmx, te), 4), bits(V::le(tmy, te), 2)),
            bits(V::le(tmz, te), 1),
        );
        let o0 = V::xor_u(behind, V::load_u(&consts.negative));
        // Crossings inside (te, tx): key tm and the axis bit, else key tx and bit 0.
        let crossed = |t: V| V::and(V::gt(t, te), V::lt(t, tx));
        let (cx, cy, cz) = (crossed(tmx), crossed(tmy), crossed(tmz));
        let (mut k0, mut k1, mut k2) = (
            V::sel(cx, tmx, tx),
            V::sel(cy, tmy, tx),
            V::sel(cz, tmz, tx),
        );
        let (mut b0, mut b1, mut b2) = (bits(cx, 4), bits(cy, 2), bits(cz, 1));
        // The stable network: swap where the later key is strictly smaller.
        let sort = |ka: V, kb: V, ba: V, bb: V| {
            let s = V::lt(kb, ka);
            (
                V::sel(s, kb, ka),
                V::sel(s, ka, kb),
                V::sel(s, bb, ba),
                V::sel(s, ba, bb),
            )
        };
        (k0, k1, b0, b1) = sort(k0, k1, b0, b1);
        (k1, k2, b1, b2) = sort(k1, k2, b1, b2);
        (k0, k1, b0, b1) = sort(k0, k1, b0, b1);
        let o1 = V::xor_u(o0, b0);
        let o2 = V::xor_u(o1, b1);
        let o3 = V::xor_u(o2, b2);
        let (zero, none) = (V::splat_u(0), V::splat_u(8));
        let seq = [
            o0,
            V::sel(V::eq_u(b0, zero), none, o1),
            V::sel(V::eq_u(b1, zero), none, o2),
            V::sel(V::eq_u(b2, zero), none, o3),
        ];
        let b = [te, k0, k1, k2, tx];
        // The octants some live lane visits (an absent p-th crossing, octant 8, falls outside
        // the byte).
        let lane_bit = V::load_u(&[1, 2, 4, 8, 16, 32, 64, 128]);
        let live = V::eq_u(V::and_u(V::splat_u(children.lanes), lane_bit), lane_bit);
        let octants = V::or_u(
            V::or_u(V::octant_bit(seq[0]), V::octant_bit(seq[1])),
            V::or_u(V::octant_bit(seq[2]), V::octant_bit(seq[3])),
        );
        let visited = V::or_across(V::and_u(live, octants));

        for c in children.present_far_to_near(visited) {
            let cv = V::splat_u(c);
            let h = seq.map(|s| V::eq_u(s, cv));
            let visit = V::movemask(V::or(V::or(h[0], h[1]), V::or(h[2], h[3]))) & children.lanes;
            if visit == 0 {
                continue;
            }
            let mut t_enter = [0.0f32; PACKET_SIZE];
            let mut t_exit = [0.0f32; PACKET_SIZE];
            let t_a = V::sel(h[0], b[0], V::sel(h[1], b[1], V::sel(h[2], b[2], b[3])));
            let t_b = V::sel(h[0], b[1], V::sel(h[1], b[2], V::sel(h[2], b[3], b[4])));
            V::store(t_a, &mut t_enter);
            V::store(t_b, &mut t_exit);
            children.add(c, visit, t_enter, t_exit);
        }
    }
}

/// [`packet_step_wide`] with AVX2 lanes, compiled for AVX2 CPUs (the AVX comparison predicates
/// used are the ordered ones, false on NaN like SSE's).
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn packet_step_avx2<O: TracedOctree>(children: &mut Children<'_, O>) {
    // SAFETY: the CPU has AVX2 (this function's contract).
    unsafe { packet_step_wide::<Avx2, O>(children) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn far_to_near_lists_the_present_children_in_reverse_near_to_far_order() {
        for mask in 0..256u32 {
            for near in 0..8u32 {
                let expected: Vec<u32> = NEAR_TO_FAR
                    .iter()
                    .rev()
                    .map(|&flip| near ^ flip)
                    .filter(|&c| mask >> c & 1 != 0)
                    .collect();
                let got: Vec<u32> = FarToNear::new(mask, near).collect();
                assert_eq!(got, expected, "mask {mask:#010b}, near {near}");
            }
        }
    }
    use crate::traversal::intersect;
    use crate::traversal::tests::{
        octree_from_sdfs, same_hit, same_hit_in, sphere_a, spheres_and_sheet, tilted_sheet,
    };
    use crate::Ray;
    use sdfmo_format::BrickOctree;

    #[test]
    fn packets_hit_exactly_like_single_rays() {
        // A gyroid: many surfaces along every ray, so visiting leaves out of order changes hits.
        let gyroid = |p: Vec3| {
            let q = p * 5.0;
            0.1 * (q.x.sin() * q.y.cos() + q.y.sin() * q.z.cos() + q.z.sin() * q.x.cos())
        };
        // Clip voxels (format 1.1): a slab as two intersected planes, and the sheet clipped
        // by a clip-only plane.
        let top = |p: Vec3| p.y - 0.3;
        let bottom = |p: Vec3| -0.2 - p.y;
        let rim = |p: Vec3| p.x - 0.1;
        let octrees = [
            octree_from_sdfs(5, &[(&sphere_a, false, false)]),
            spheres_and_sheet(),
            octree_from_sdfs(5, &[(&gyroid, true, false)]),
            octree_from_sdfs(5, &[(&gyroid, false, false)]),
            octree_from_sdfs(
                5,
                &[
                    (&top, false, true),
                    (&bottom, false, true),
                    (&sphere_a, false, false),
                ],
            ),
            octree_from_sdfs(5, &[(&tilted_sheet, true, false), (&rim, true, true)]),
        ];
        // Eyes on two and one root mid-planes (the paper views), off them, inside the root
        // cube, on a cell corner, and looking along an axis.
        let eyes = [
            (Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO),
            (Vec3::new(3.0, 0.0, 0.0), Vec3::new(0.0, 0.1, 0.0)),
            (Vec3::new(1.3, -0.7, 2.6), Vec3::new(0.1, 0.0, -0.1)),
            (Vec3::new(0.05, 0.3, 0.2), Vec3::new(-0.5, -0.2, 0.1)),
            (Vec3::new(0.5, 0.5, -2.0), Vec3::new(0.5, 0.5, 0.0)),
            (Vec3::new(0.0, 2.5, 0.0), Vec3::ZERO),
        ];
        let mut hits = 0;
        for octree in &octrees {
            // The same octree in 3.0: the packets' hits are the 1.x hits, bit for bit.
            let bricks = BrickOctree::encode(octree).unwrap();
            for &(eye, target) in &eyes {
                let fwd = (target - eye).normalize();
                let hint = if fwd.cross(Vec3::Y).length() < 1e-6 {
                    Vec3::Z
                } else {
                    Vec3::Y
                };
                let right = fwd.cross(hint).normalize();
                let up = right.cross(fwd);
                let size = 48;
                for t_max in [f32::INFINITY, 2.9] {
                    for py in (0..size).step_by(2) {
                        for px in (0..size).step_by(4) {
                            let mut dirs = [Vec3::ZERO; PACKET_SIZE];
                            for (l, dir) in dirs.iter_mut().enumerate() {
                                let (x, y) = (px + l % 4, py + l / 4);
                                let u = (x as f32 + 0.5) / (size as f32 / 2.0) - 1.0;
                                let v = 1.0 - (y as f32 + 0.5) / (size as f32 / 2.0);
                                *dir = (fwd + 0.7 * (u * right + v * up)).normalize();
                            }
                            // The central column and row are exactly axis-parallel for the
                            // axis-aligned views.
                            if px == size / 2 {
                                dirs[0] = fwd;
                            }
                            // Every packet whole, and a partial one.
                            for lanes in [(1u32 << PACKET_SIZE) - 1, 0b1010_0110] {
                                let rays = RayPacket {
                                    origin: eye,
                                    dirs,
                                    lanes,
                                    t_max,
                                };
                                let got = intersect_packet(octree, &rays);
                                let got3 = intersect_packet(&bricks, &rays);
                                let scalar = packet::<_, SCALAR>(octree, &rays);
                                // The SSE2 step without AVX2 (x86-64; elsewhere scalar again).
                                let sse2 = packet::<_, SSE2>(octree, &rays);
                                for l in 0..PACKET_SIZE {
                                    let ray = Ray {
                                        origin: eye,
                                        dir: dirs[l],
                                    };
                                    let want = if lanes >> l & 1 != 0 {
                                        intersect(octree, &ray, 0.0, t_max)
                                    } else {
                                        None
                                    };
                                    assert!(
                                        same_hit(got[l], want),
                                        "eye {eye} lane {l} {ray:?}: {:?} vs {want:?}",
                                        got[l]
                                    );
                                    assert!(same_hit(scalar[l], want), "scalar step, lane {l}");
                                    assert!(same_hit(sse2[l], want), "SSE2 step, lane {l}");
                                    assert!(
                                        same_hit_in(octree, want, &bricks, got3[l]),
                                        "3.0, lane {l}"
                                    );
                                    hits += usize::from(want.is_some());
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(hits > 5000, "{hits} hits");
    }
}
