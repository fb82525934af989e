//! The constants every ray-tracing kernel of this format shares: the CPU tracer (`sdfmo-trace`)
//! uses them as they are, and the WGSL kernel (`sdfmo-gpu`) receives them as `const`
//! declarations generated from these values when its pipeline is created, so the two kernels
//! cannot drift apart (issue 20: they used to be written once in Rust and again in WGSL). They
//! live here, beside [`MAX_CLIP_VOXELS_PER_LEAF`](crate::MAX_CLIP_VOXELS_PER_LEAF), because
//! `sdfmo-gpu` depends on this crate only.
//!
//! Changing one changes images (on both devices alike).

use crate::MAX_DEPTH;

/// Traversal stack capacity of the CPU kernel: a node pushes at most four children and pops
/// one, so a descent to depth `d` holds at most `3d + 1` entries; [`MAX_DEPTH`] bounds `d` (50
/// entries). The WGSL kernel visits the same cells with one entry per level instead (its
/// `SMO_MAX_DEPTH`, see `sdfmo-gpu`'s `sdfmo.wgsl`).
pub const TRAVERSAL_STACK_SIZE: usize = 3 * MAX_DEPTH as usize + 2;

/// Replacement for a zero (or tinier) ray direction component in the plane crossing times, with
/// the component's sign.
pub const TINY_DIR: f32 = 1e-30;

/// Newton/bisection steps at most when a root is polished; bisection alone reaches
/// [`ROOT_REL_TOLERANCE`] in 20.
pub const MAX_POLISH_STEPS: u32 = 32;

/// Tolerance of a polished root, as a fraction of the segment length `t1 − t0` (the segment is
/// at most √3 voxel edges long, so this is below 2e-6 voxel units).
pub const ROOT_REL_TOLERANCE: f32 = 1e-6;

/// Slack of the clip test at a crossing, relative to the clip voxel's largest |corner|: a
/// candidate that is a polished root is accepted where `f_j ≤ CLIP_TOLERANCE · max|corner_j|`
/// (`FORMAT.md`, the clip rule).
///
/// Roots are polished to `1e-6` of the segment (below `2e-6` voxel edges), where a trilinear
/// interpolant bounded by `m` changes by at most about `2√3 · m` per edge, i.e. `7e-6 · m`.
/// Without slack, a ray through a convex edge of two intersect voxels could see both entries
/// rejected by rounding (each voxel a hair outside the other) and pass through the edge; with
/// it the solid grows by at most `1e-5` of the leaf diagonal there.
///
/// The span-start candidate (the ray enters the leaf inside a volume voxel) has no slack: it is
/// exact (no root to polish), and with slack a ray entering a leaf just before it crosses a
/// clip voxel's face would be accepted at the leaf boundary with the wrong voxel active (the
/// wrong normal); without it that candidate is rejected and the clip voxel's own crossing a
/// hair later is the hit.
pub const CLIP_TOLERANCE: f32 = 1e-5;
