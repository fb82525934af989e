//! The octree builder of sdf-multioctree: triangle mesh → sparse octree of trilinear
//! signed-distance voxels, as the classic single-voxel SVO (the paper's baseline) or as the
//! SDFMultiOctree (several voxels per leaf, one per connected component; *surface* voxels for
//! open and thin elements).
//!
//! ```no_run
//! use sdfmo_build::{build, BuildRequest, BuildSettings, Method};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let mesh = sdfmo_mesh::procedural::demo_part();
//! let settings = BuildSettings::new(7, Method::Multi { max_voxels: 8 });
//! let (octree, stats) = build(&mesh, &settings)?;
//! println!("{} leaves, {} voxels, {} bytes", stats.leaves, stats.voxels, octree.byte_size());
//!
//! // Options on a request: a memory budget, progress, cancellation, levels of detail.
//! let (levels, _) = BuildRequest::new(&mesh, settings)
//!     .memory_budget(Some(1 << 30))
//!     .progress(&|f| eprint!("\r{:3.0} %", 100.0 * f))
//!     .levels(5)?;
//! assert_eq!((levels.coarsest(), levels.depth()), (5, 7));
//! # Ok(()) }
//! ```
//!
//! Every build runs on the caller's rayon pool (the global one, or one the caller `install`s:
//! the front-ends own their pools).
//!
//! # Pipeline ([`build`])
//!
//! 1. **normalise**: bounding-box centre to the origin, longest extent to `2·(1 − margin)`; the
//!    transform goes into the file.
//! 2. **distance**: the exact signed distance structure of `sdfmo-distance` (BVH, pseudo-normal
//!    or winding-number sign, chosen by [`BuildSettings::sign`]).
//! 3. **subdivide**: top-down, the cells touching the surface (exact triangle–box SAT test on
//!    boxes inflated by one quantisation step, so that no leaf whose quantised interpolant may
//!    reach zero is missed), subtrees in parallel ([`subdivide`](mod@subdivide)).
//! 4. **corners**: the global signed distance at every distinct corner of the candidate leaves,
//!    computed once and shared by the up to eight leaves around it.
//! 5. **leaves**: the SVO keeps a leaf's single voxel where its *quantised* corners change sign
//!    (exactly what the tracer can hit); the multi-octree decides per leaf as described in
//!    `leaf`. With [`BuildSettings::fit_corners`], the shared corner values of the leaves that
//!    keep the global-distance voxel are then fitted to the surface (module `cornerfit`).
//! 6. **pack**: [`PackedOctree::from_leaves`].
//!
//! Every step is a pure function of the input and runs in a fixed order of leaves, so the bytes
//! are identical for any number of threads.

#![deny(missing_docs)]

mod budget;
mod components;
mod cornerfit;
mod error;
mod geom;
mod leaf;
mod local;
pub mod subdivide;
mod tribox;

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use sdfmo_distance::{sign_by_pseudo_normal, Feature, MeshDistance, SignMode};
use sdfmo_format::{
    cell_size, quant, LeafInput, LodOctree, OctreeMeta, PackedOctree, ValueBits, MAX_DEPTH,
};
use sdfmo_mesh::TriMesh;

pub use budget::{
    check_memory, default_memory_budget, estimate_memory, physical_memory, MemoryEstimate,
};
pub use error::{BuildError, Result};
pub use leaf::LeafParams;
use local::LocalMesh;
pub use tribox::tri_box_overlap;

/// Which octree to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The classic sparse voxel octree: one voxel per leaf from the global signed distance.
    Svo,
    /// The SDFMultiOctree: up to `max_voxels` voxels per leaf (default 8).
    Multi {
        /// Cap on voxels per leaf (1..=255).
        max_voxels: u8,
    },
}

impl Default for Method {
    fn default() -> Self {
        Method::Multi { max_voxels: 8 }
    }
}

/// What [`build`] builds.
///
/// `#[non_exhaustive]`: made by [`BuildSettings::new`] (or `default()`) and the `with_*`
/// setters, so that a setting added later breaks no caller; the fields are public for reading.
///
/// ```
/// use sdfmo_build::{BuildSettings, LeafParams, Method};
/// use sdfmo_format::ValueBits;
/// let s = BuildSettings::new(9, Method::Svo).with_bits(ValueBits::Sixteen).with_leaf(LeafParams::PAPER);
/// assert_eq!((s.depth, s.bits, s.margin), (9, ValueBits::Sixteen, 0.05));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct BuildSettings {
    /// Leaves at this level (edge `2 / 2^depth`); 1..=16 ([`MIN_DEPTH`]..=[`MAX_DEPTH`]).
    pub depth: u8,
    /// SVO or multi-octree.
    pub method: Method,
    /// Corner quantisation of the file.
    pub bits: ValueBits,
    /// Normalisation margin (0.05): the longest extent is scaled to `2·(1 − margin)`.
    pub margin: f32,
    /// How the global signed distance is signed. `Auto`: pseudo-normals on watertight meshes; on
    /// others, pseudo-normals where the closest feature is a clean manifold feature and the
    /// generalised winding number elsewhere (see [`build`]). `Winding` / `PseudoNormal` force
    /// one method everywhere.
    pub sign: SignMode,
    /// The thresholds of the multi-octree's per-leaf decision ([`LeafParams::OURS`] by
    /// default, or [`LeafParams::PAPER`]); the SVO ignores them.
    pub leaf: LeafParams,
    /// Corners fitted to the surface (off by default): the shared corner values of the leaves
    /// that keep the global-distance voxel (every SVO leaf, most multi-octree leaves) are a
    /// least-squares fit of the trilinear interpolant's zero set to the mesh inside those
    /// leaves, each within six quantisation steps of the exact distance (an inside value at
    /// most one step deeper), instead of the exact distance itself: depth-9 multi-octree on the
    /// five shared models +0.83 to +1.17 dB (median +1.03), 49 of the 50 cells of the paper
    /// sweep gain and none loses more than 0.01 dB (`docs/results/sweep.md`). Off by default:
    /// it costs 1.5–3.5× the build time at depth 9 (multi, the five models). Each grid point keeps
    /// one value for every voxel around it; private corners (component, surface, plane and
    /// clip voxels), the corners of dropped cells and the points format 3.x needs as they are
    /// (a brick whose residuals would widen) keep their exact values. The leaf decisions are
    /// those of the exact corners, so the octree's leaves and voxels, and its size, are the
    /// same as without the fit, and its format 3.1 file 0.997–1.001× the exact one's.
    pub fit_corners: bool,
}

/// Builder methods `name(field: Type)` that return the same value with that one field replaced
/// (each with the doc comment written above it).
macro_rules! with_setters {
    ($($(#[$doc:meta])* $name:ident($field:ident: $ty:ty);)*) => {
        $(
            $(#[$doc])*
            pub fn $name(self, $field: $ty) -> Self {
                Self { $field, ..self }
            }
        )*
    };
}

impl BuildSettings {
    /// The settings of a build at `depth` with `method`, defaults otherwise.
    pub fn new(depth: u8, method: Method) -> BuildSettings {
        BuildSettings {
            depth,
            method,
            ..BuildSettings::default()
        }
    }

    with_setters! {
        /// The same settings at `depth`.
        with_depth(depth: u8);
        /// The same settings with `method`.
        with_method(method: Method);
        /// The same settings with corners of `bits`.
        with_bits(bits: ValueBits);
        /// The same settings with the normalisation `margin`.
        with_margin(margin: f32);
        /// The same settings signed by `sign`.
        with_sign(sign: SignMode);
        /// The same settings with the leaf decision's thresholds `leaf`.
        with_leaf(leaf: LeafParams);
        /// The same settings with corners fitted to the surface or not
        /// ([`BuildSettings::fit_corners`]).
        with_fit_corners(fit_corners: bool);
    }
}

impl Default for BuildSettings {
    fn default() -> Self {
        BuildSettings {
            depth: 8,
            method: Method::default(),
            bits: ValueBits::Eight,
            margin: 0.05,
            sign: SignMode::Auto,
            leaf: LeafParams::OURS,
            fit_corners: false,
        }
    }
}

/// Statistics of one build.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Nodes of the packed octree (inner nodes and leaves).
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Voxels.
    pub voxels: usize,
    /// Surface (thin) voxels.
    pub surface_voxels: usize,
    /// Histogram of voxels per leaf: `voxels_per_leaf[n]` leaves hold `n` voxels.
    pub voxels_per_leaf: Vec<usize>,
    /// Leaves whose component split produced more voxels than the cap (reduced by merging).
    pub cap_hits: usize,
    /// Milliseconds per phase, in order: normalize, distance, subdivide, corners, leaves, fit
    /// (only with [`BuildSettings::fit_corners`]), pack.
    pub phases: Vec<(String, f64)>,
    /// Total milliseconds.
    pub build_ms: f64,
    /// Bytes of the saved file.
    pub bytes: usize,
}

/// Absolute margins used by the subdivision for a depth and method (normalised units):
/// `(gather, candidate)`. The candidate margin is one quantisation step of the corner values; the
/// multi-octree gathers the triangles within 0.3 of a cell edge for its components' distances.
pub fn margins(depth: u8, bits: ValueBits, method: Method) -> (f32, f32) {
    let h = cell_size(depth);
    let step = quant::voxel_diagonal(depth) / quant::max_code(bits) as f32;
    let candidate = step + 1e-6 * h;
    match method {
        Method::Svo => (candidate, candidate),
        Method::Multi { .. } => ((0.3 * h).max(candidate), candidate),
    }
}

/// The normalised vertex `p` rounded to a grid of `2^-(depth + 10)` for 8-bit corners (a
/// 2048th of a leaf edge, against a quantisation half-step of a 147th) or `2^-(depth + 18)` for
/// 16-bit ones (against a 37,800th); not at all where that grid would be finer than `2^-22`
/// (four f32 ulps at 1: the snap would round nothing away). The multi-octree's decisions are
/// discrete (a component reaches a cell or not, a corner lies on one side of a sheet's plane or
/// the other), and CAD parts put faces, rims and corners exactly on cell faces, where one ulp
/// of input rounding (a scaled, translated or re-exported copy of the same part) would decide
/// them. Cell faces lie on this grid, so such features snap back onto them exactly; the
/// vertices move by at most half a step, well below the corner quantisation.
fn snap_to_grid(p: Vec3, depth: u8, bits: ValueBits) -> Vec3 {
    let below_quantisation = match bits {
        ValueBits::Eight => 10,
        ValueBits::Sixteen => 18,
    };
    let exponent = i32::from(depth) + below_quantisation;
    if exponent > 22 {
        return p;
    }
    let scale = 2f32.powi(exponent);
    // Exact: |p| <= 1 keeps p * 2^22 below 2^24.
    (p * scale).round() / scale
}

/// Shallowest depth [`build`] accepts: depth 0 would be one leaf for the whole root cube.
pub const MIN_DEPTH: u8 = 1;

fn validate(mesh: &TriMesh, settings: &BuildSettings) -> Result<()> {
    if !(MIN_DEPTH..=MAX_DEPTH).contains(&settings.depth) {
        return Err(BuildError::InvalidDepth {
            depth: settings.depth,
            max: MAX_DEPTH,
        });
    }
    if let Method::Multi { max_voxels: 0 } = settings.method {
        return Err(BuildError::InvalidMaxVoxels(0));
    }
    if !(0.0..0.5).contains(&settings.margin) {
        return Err(BuildError::InvalidMargin(settings.margin));
    }
    check_mesh(mesh)
}

/// Refuses a mesh no octree can be built of, nor an SDF asked of: one whose bounding box has
/// no extent (every vertex the same point) or whose every triangle has zero area (points and
/// lines: no surface, no inside). [`build`] checks it first; the front-ends check it where a
/// mesh is made (Python's `Mesh`), so that no query answers with the distance to a point.
///
/// # Errors
/// [`BuildError::DegenerateMesh`], naming which.
pub fn check_mesh(mesh: &TriMesh) -> Result<()> {
    let b = mesh.bounds();
    let ext = (b.max - b.min).max_element();
    if ext.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !ext.is_finite() {
        return Err(BuildError::DegenerateMesh(format!(
            "the bounding box has extent {ext}"
        )));
    }
    // In f64: a valid part of 5e-12 m has f32 cross products that underflow to zero.
    let any_area = (0..mesh.triangle_count()).any(|i| {
        let [x, y, z] = mesh.triangle_normal_f64(i);
        x != 0.0 || y != 0.0 || z != 0.0
    });
    if !any_area {
        return Err(BuildError::DegenerateMesh(
            "every triangle has zero area".into(),
        ));
    }
    Ok(())
}

/// Builds the octree of `mesh` (model units; normalised here, the transform is stored in the
/// octree) on the caller's rayon pool: [`BuildRequest::octree`] with the default memory budget
/// and neither progress nor cancellation.
///
/// # Errors
/// [`BuildError::InvalidDepth`], [`BuildError::InvalidMaxVoxels`], [`BuildError::InvalidMargin`],
/// [`BuildError::DegenerateMesh`], [`BuildError::MemoryBudget`], and the distance structure's or
/// the packing's error.
pub fn build(mesh: &TriMesh, settings: &BuildSettings) -> Result<(PackedOctree, BuildStats)> {
    BuildRequest::new(mesh, *settings).octree()
}

/// A build with its options, [`build`] when none is set (image-rs's `ImageReader` + `Limits`
/// is the model: options on the request, then one terminal call): the memory budget,
/// a progress callback, a cancellation test, and whether one octree ([`BuildRequest::octree`])
/// or levels of detail ([`BuildRequest::levels`]) are built.
///
/// The build runs on the caller's rayon pool; every step is a pure function of the input in
/// a fixed order of leaves, so the bytes are the same for any number of threads, and with or
/// without progress and cancellation.
///
/// ```
/// use sdfmo_build::{build, BuildError, BuildRequest, BuildSettings, Method};
/// let mesh = sdfmo_mesh::procedural::demo_part();
/// let settings = BuildSettings::new(4, Method::default());
/// let (octree, _) = BuildRequest::new(&mesh, settings).memory_budget(None).cancel(&|| false).octree()?;
/// assert_eq!(octree.as_bytes(), build(&mesh, &settings)?.0.as_bytes());
/// let refused = BuildRequest::new(&mesh, settings).memory_budget(Some(1 << 20)).octree();
/// assert!(matches!(refused, Err(BuildError::MemoryBudget { .. })));
/// # Ok::<(), BuildError>(())
/// ```
#[must_use = "a request builds nothing until `octree` or `levels` is called"]
pub struct BuildRequest<'a> {
    mesh: &'a TriMesh,
    settings: BuildSettings,
    budget: Option<u64>,
    progress: Option<&'a (dyn Fn(f32) + Sync)>,
    cancel: &'a (dyn Fn() -> bool + Sync),
}

impl<'a> BuildRequest<'a> {
    /// The build of `mesh` (model units) with `settings`, under [`default_memory_budget`].
    pub fn new(mesh: &'a TriMesh, settings: BuildSettings) -> BuildRequest<'a> {
        BuildRequest {
            mesh,
            settings,
            budget: default_memory_budget(),
            progress: None,
            cancel: &|| false,
        }
    }

    /// Refuses the build before it starts when its predicted peak memory ([`estimate_memory`])
    /// exceeds `budget` bytes (`None`: no limit; default [`default_memory_budget`], half the
    /// physical memory).
    pub fn memory_budget(mut self, budget: Option<u64>) -> BuildRequest<'a> {
        self.budget = budget;
        self
    }

    /// Calls `progress` with fractions in `0..=1`, increasing, from the calling thread (for
    /// levels, over the whole build: each level weighted by 4^level, the growth of a
    /// surface's cells per level).
    pub fn progress(mut self, progress: &'a (dyn Fn(f32) + Sync)) -> BuildRequest<'a> {
        self.progress = Some(progress);
        self
    }

    /// Stops early, with [`BuildError::Cancelled`], when `cancel` returns true. `cancel` is
    /// asked from the calling thread between the phases, between chunks of 65 536 corner
    /// points and between chunks of 16 384 leaves, so a caller can offer Ctrl-C (the Python
    /// package does). The subdivision phase is not split (about 1.2 s at depth 9 on one thread
    /// of the sphere of the Python tests, four times that per extra level).
    pub fn cancel(mut self, cancel: &'a (dyn Fn() -> bool + Sync)) -> BuildRequest<'a> {
        self.cancel = cancel;
        self
    }

    /// Builds one octree, its leaves at the settings' depth.
    ///
    /// # Errors
    /// Those of [`build`], and [`BuildError::Cancelled`].
    pub fn octree(&self) -> Result<(PackedOctree, BuildStats)> {
        let (mesh, settings) = (self.mesh, &self.settings);
        validate(mesh, settings)?;
        check_memory(mesh, settings, self.budget)?;
        let normalised = Normalised::new(mesh, settings.margin);
        build_level(
            &normalised,
            normalised.ms,
            settings,
            self.progress,
            self.cancel,
        )
    }

    /// Builds the levels of detail `coarsest..=depth` (the settings' depth): level `k` is
    /// exactly the octree [`build`] makes at depth `k` with the same settings, so it renders as
    /// that build does. The levels share the normalisation transform (it depends on the mesh's
    /// bounds and the margin only). Returns the levels and each level's statistics, coarsest
    /// first.
    ///
    /// The levels share the reshaped, normalised mesh (made once); from the per-depth vertex
    /// snap on ([`build`]'s step 1: the grid is `2^-(depth + 10)` for 8-bit corners)
    /// everything is the level's own: the snapped mesh differs per depth, so its welding,
    /// distance structure, winding data, subdivision, corners and leaf decisions do too, and
    /// reusing any of them across levels would change the level's bytes. The memory check is
    /// the finest level's (the levels are built one after the other; the coarser ones held
    /// meanwhile are at most a third of the finest one's size).
    ///
    /// # Errors
    /// [`BuildError::InvalidLevels`] when `coarsest` is below [`MIN_DEPTH`] or above the
    /// depth, and every error of [`BuildRequest::octree`].
    pub fn levels(&self, coarsest: u8) -> Result<(LodOctree, Vec<BuildStats>)> {
        build_levels(
            self.mesh,
            &self.settings,
            coarsest,
            self.budget,
            self.progress,
            self.cancel,
        )
    }
}

/// [`BuildRequest::levels`].
fn build_levels(
    mesh: &TriMesh,
    settings: &BuildSettings,
    coarsest: u8,
    budget: Option<u64>,
    progress: Option<&(dyn Fn(f32) + Sync)>,
    cancel: &(dyn Fn() -> bool + Sync),
) -> Result<(LodOctree, Vec<BuildStats>)> {
    let depth = settings.depth;
    if coarsest < MIN_DEPTH || coarsest > depth {
        return Err(BuildError::InvalidLevels {
            coarsest,
            depth,
            why: "the coarsest level must be in 1..=depth",
        });
    }
    validate(mesh, settings)?;
    check_memory(mesh, settings, budget)?;
    let weight = |k: u8| 4f64.powi(i32::from(k));
    let total: f64 = (coarsest..=depth).map(weight).sum();
    // The reshaped, normalised mesh depends on the mesh and the margin only: made once.
    // Everything after the per-depth snap (welding, the distance structure, the winding
    // sign's data) depends on the depth and is each level's own.
    let normalised = Normalised::new(mesh, settings.margin);
    let mut levels = Vec::new();
    let mut stats = Vec::new();
    let mut done = 0.0;
    for k in coarsest..=depth {
        let level_settings = settings.with_depth(k);
        let w = weight(k);
        let scaled = |f: f32| {
            if let Some(p) = progress {
                p((((done + w * f64::from(f)) / total) as f32).clamp(0.0, 1.0));
            }
        };
        let shared_ms = if k == coarsest { normalised.ms } else { 0.0 };
        let (octree, st) = build_level(
            &normalised,
            shared_ms,
            &level_settings,
            Some(&scaled),
            cancel,
        )?;
        done += w;
        levels.push(octree);
        stats.push(st);
    }
    Ok((LodOctree::from_levels(levels)?, stats))
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The distinct grid points of the candidates' corners, each once, in key order: their
/// positions, the closest-point hint of the first cell that has them, and for every slot
/// `cell · 8 + k` the index of its point.
///
/// The slots are sorted by corner key. Where the key (`depth + 1` bits per axis: a corner
/// coordinate reaches `2^depth`) and the slot index fit in 64 bits together, one packed `u64`
/// per slot is sorted (half the memory of a `(key, slot)` pair and of its sort: this array is
/// the build's peak); otherwise the pairs. Both orders are the same (slots are unique), so the
/// points and the octree are too.
fn shared_corners(sub: &subdivide::Subdivision, depth: u8) -> (Vec<Vec3>, Vec<u32>, Vec<u32>) {
    let slot_bits = u64::BITS - ((sub.cells.len() as u64) * 8).leading_zeros();
    let packs = 3 * (u32::from(depth) + 1) + slot_bits <= u64::BITS;
    shared_corners_sorted(sub, depth, packs)
}

/// [`shared_corners`] with the sort chosen by the caller: packed `u64` keys (`packs`, only when
/// key and slot fit) or `(key, slot)` pairs.
fn shared_corners_sorted(
    sub: &subdivide::Subdivision,
    depth: u8,
    packs: bool,
) -> (Vec<Vec3>, Vec<u32>, Vec<u32>) {
    let n = sub.cells.len();
    let axis_bits = u32::from(depth) + 1;
    let slot_bits = u64::BITS - ((n as u64) * 8).leading_zeros();
    let key_of = |c: &subdivide::Candidate, k: u32| -> u64 {
        let g = [
            c.coord[0] + ((k >> 2) & 1),
            c.coord[1] + ((k >> 1) & 1),
            c.coord[2] + (k & 1),
        ];
        ((g[0] as u64) << (2 * axis_bits)) | ((g[1] as u64) << axis_bits) | g[2] as u64
    };
    let mut out = SharedCorners::new(sub, depth, axis_bits);
    if packs {
        let mut packed: Vec<u64> = Vec::with_capacity(n * 8);
        for (i, c) in sub.cells.iter().enumerate() {
            for k in 0..8u32 {
                packed.push((key_of(c, k) << slot_bits) | u64::from(i as u32 * 8 + k));
            }
        }
        packed.par_sort_unstable();
        let slot_mask = (1u64 << slot_bits) - 1;
        for &p in &packed {
            out.visit(p >> slot_bits, (p & slot_mask) as u32);
        }
    } else {
        let mut slots: Vec<(u64, u32)> = Vec::with_capacity(n * 8);
        for (i, c) in sub.cells.iter().enumerate() {
            for k in 0..8u32 {
                slots.push((key_of(c, k), i as u32 * 8 + k));
            }
        }
        slots.par_sort_unstable();
        for &(key, slot) in &slots {
            out.visit(key, slot);
        }
    }
    (out.points, out.hints, out.point_of_slot)
}

/// What [`shared_corners`] accumulates while walking the sorted slots.
struct SharedCorners<'a> {
    sub: &'a subdivide::Subdivision,
    /// Cell edge in the normalised frame.
    h: f32,
    axis_bits: u32,
    points: Vec<Vec3>,
    hints: Vec<u32>,
    point_of_slot: Vec<u32>,
    last: u64,
}

impl<'a> SharedCorners<'a> {
    fn new(sub: &'a subdivide::Subdivision, depth: u8, axis_bits: u32) -> SharedCorners<'a> {
        let cells = sub.cells.len();
        SharedCorners {
            sub,
            h: cell_size(depth),
            axis_bits,
            points: Vec::with_capacity(cells * 2),
            hints: Vec::with_capacity(cells * 2),
            point_of_slot: vec![0u32; cells * 8],
            last: u64::MAX,
        }
    }

    /// One sorted slot: a new key starts a new point.
    #[inline]
    fn visit(&mut self, key: u64, slot: u32) {
        if key != self.last {
            let (b, mask) = (self.axis_bits, (1u64 << self.axis_bits) - 1);
            let g = [(key >> (2 * b)) & mask, (key >> b) & mask, key & mask];
            self.points
                .push(Vec3::new(g[0] as f32, g[1] as f32, g[2] as f32) * self.h - Vec3::ONE);
            self.hints.push(self.sub.cells[(slot / 8) as usize].hint);
            self.last = key;
        }
        self.point_of_slot[slot as usize] = (self.points.len() - 1) as u32;
    }
}

/// The global signed distance at a corner. With `hybrid` (sign mode `Auto` on a mesh that is
/// not watertight), the sign comes from the pseudo-normal of the closest feature when that
/// feature is clean (face interior, manifold consistently oriented edge, vertex with only such
/// edges) and from the generalised winding number otherwise: the same answer as the winding
/// number wherever the surface is locally a closed manifold, but ~5× cheaper on abc1 and
/// correct on both sides of open sheets away from their borders (where the winding number,
/// about ±0.5 on either side, reports *outside* twice and the sheet would vanish).
#[inline]
fn global_signed_distance(
    dist: &MeshDistance,
    local: &LocalMesh,
    hybrid: bool,
    p: Vec3,
    hint: u32,
) -> f32 {
    let c = if hint != u32::MAX {
        dist.closest_point_with_hint(p, hint)
    } else {
        dist.closest_point(p)
    };
    if hybrid && (c.triangle as usize) < local.len() {
        // The search's closest point carries its feature: no second closest-point test.
        let t = c.triangle as usize;
        // A face interior signs by its normal where that normal is known to point out of the
        // solid the winding number sees; elsewhere the winding number decides where it is
        // decisive. On abc1, corners half a voxel inside took the outside sign from nearby
        // faces whose normals point in (dark grooves along shallow creases in both methods:
        // −0.1 to −0.5 dB at depths 6–10); beside an open sheet the winding number is near ½
        // and the face's own orientation still decides.
        if c.feature == Feature::Face && !dist.face_normal_agrees_with_winding(c.triangle) {
            if let Some(inside) = dist.decisive_winding_inside(p) {
                return if inside { -c.distance } else { c.distance };
            }
        }
        if local.feature_is_clean(t, c.feature) {
            return sign_by_pseudo_normal(p, &c, local.pseudo_normal(t, c.feature));
        }
    }
    dist.sign_closest(p, &c)
}

/// The mesh after flat fans are re-triangulated and the result normalised: the part of step 1
/// that does not depend on the depth (shared by the levels of [`BuildRequest::levels`]).
struct Normalised {
    mesh: TriMesh,
    norm: sdfmo_mesh::Normalization,
    /// Milliseconds it took.
    ms: f64,
}

impl Normalised {
    fn new(mesh: &TriMesh, margin: f32) -> Normalised {
        let t = Instant::now();
        // Same surface; the fans' wedges would make every query and cell list near them O(n).
        let reshaped = sdfmo_distance::reshape_fans(mesh);
        let mesh = reshaped.as_ref().map_or(mesh, |r| &r.mesh);
        let (mesh, norm) = mesh.normalized(margin);
        Normalised {
            mesh,
            norm,
            ms: ms(t),
        }
    }
}

/// Steps 1 (the snap) to 6 of one depth, from the normalised mesh; `normalised_ms` (the time
/// of making it, or 0 where an earlier level counted it) is added to the normalize phase.
fn build_level(
    normalised: &Normalised,
    normalised_ms: f64,
    settings: &BuildSettings,
    progress: Option<&(dyn Fn(f32) + Sync)>,
    cancel: &(dyn Fn() -> bool + Sync),
) -> Result<(PackedOctree, BuildStats)> {
    // Progress and cancellation share their points: after each phase, after each chunk.
    let report = |f: f32| -> Result<()> {
        if let Some(p) = progress {
            p(f.clamp(0.0, 1.0));
        }
        if cancel() {
            return Err(BuildError::Cancelled);
        }
        Ok(())
    };
    let t_all = Instant::now();
    let mut phases = Vec::new();
    let depth = settings.depth;
    report(0.0)?;

    // 1. Normalise (the depth-independent part done by the caller), snap to this depth's grid.
    let t = Instant::now();
    let norm = normalised.norm;
    // Both methods: where the multi-octree has nothing to add it must equal the SVO.
    let norm_mesh = normalised
        .mesh
        .transformed(|p| snap_to_grid(p, depth, settings.bits));
    let local = LocalMesh::new(&norm_mesh);
    phases.push(("normalize".to_string(), normalised_ms + ms(t)));
    report(0.03)?;

    // 2. Distance structure.
    let t = Instant::now();
    // The winding mode's per-leaf data is made by the corners that need it: a coarse level
    // needs few of the leaves.
    let dist = MeshDistance::new(&norm_mesh, settings.sign)?;
    phases.push(("distance".to_string(), ms(t)));
    report(0.08)?;

    // 3. Subdivide.
    let t = Instant::now();
    let (gather, candidate) = margins(depth, settings.bits, settings.method);
    let sub = subdivide::subdivide(&local, depth, gather, candidate);
    phases.push(("subdivide".to_string(), ms(t)));
    report(0.2)?;

    // 4. Shared corners: every distinct grid point of the candidates, once.
    let t = Instant::now();
    let n = sub.cells.len();
    let (points, hints, point_of_slot) = shared_corners(&sub, depth);
    let hybrid = settings.sign == SignMode::Auto && dist.sign_mode() == SignMode::Winding;
    // In chunks, so that progress moves through this phase (a third of a deep build's time)
    // and a cancellation is seen within one chunk, both from this thread (the values do not
    // depend on the chunking: each is a function of its point and hint).
    const CORNER_CHUNK: usize = 1 << 16;
    let mut values: Vec<f32> = Vec::with_capacity(points.len());
    for (pc, hc) in points.chunks(CORNER_CHUNK).zip(hints.chunks(CORNER_CHUNK)) {
        values.par_extend(
            pc.par_iter()
                .zip(hc.par_iter())
                .with_min_len(256)
                .map(|(&p, &hint)| global_signed_distance(&dist, &local, hybrid, p, hint)),
        );
        report(0.2 + 0.25 * values.len() as f32 / points.len() as f32)?;
    }
    drop((points, hints));
    let corners: Vec<[f32; 8]> = (0..n)
        .map(|i| std::array::from_fn(|k| values[point_of_slot[i * 8 + k] as usize]))
        .collect();
    // The fit after the leaves needs the shared points; without it they go now.
    let shared = settings.fit_corners.then_some((point_of_slot, values));
    phases.push(("corners".to_string(), ms(t)));
    report(0.45)?;

    // 5. Leaves, in chunks so that progress is reported from this thread.
    let t = Instant::now();
    let cap = match settings.method {
        Method::Svo => 1,
        Method::Multi { max_voxels } => max_voxels,
    };
    let max_voxels = usize::from(cap);
    let params = leaf::Params::with(depth, settings.bits, cap, settings.leaf);
    let global = match settings.method {
        Method::Svo => None,
        Method::Multi { .. } => Some(components::Components::new(&local)),
    };
    let mut leaves: Vec<LeafInput> = Vec::with_capacity(n);
    let mut cap_hits = 0usize;
    let mut histogram = vec![0usize; max_voxels + 1];
    // For the fit: the cells whose one voxel is the shared one (with its index in `leaves`),
    // and the cells whose points keep their exact values (dropped cells, and others below).
    let mut fitted: Vec<(u32, usize)> = Vec::new();
    let mut frozen: Vec<u32> = Vec::new();
    // With `keep_brick_widths`, what format 3.x would store otherwise also stays as it is.
    let keep_3x_bytes = cornerfit::FitParams::DEFAULT.keep_brick_widths;
    const CHUNK: usize = 1 << 14;
    let mut start = 0;
    while start < n {
        let end = (start + CHUNK).min(n);
        let results: Vec<leaf::LeafResult> = match settings.method {
            Method::Svo => corners[start..end]
                .par_iter()
                .map(|g| leaf::svo_leaf(&params, g))
                .collect(),
            Method::Multi { .. } => (start..end)
                .into_par_iter()
                .map_init(leaf::Scratch::default, |s, i| {
                    let c = &sub.cells[i];
                    let global = global.as_ref().expect("components of a multi build");
                    let ctx = leaf::LeafCtx::new(
                        &params,
                        &local,
                        global,
                        c.coord,
                        sub.tris_of(c),
                        &corners[i],
                    );
                    leaf::multi_leaf(&ctx, s)
                })
                .collect(),
        };
        for (i, r) in (start..end).zip(results) {
            cap_hits += r.cap_hit as usize;
            if shared.is_some() {
                match r.voxels.as_slice() {
                    [] => frozen.push(i as u32),
                    // A surface voxel is private in format 3.x, stored narrow where its codes
                    // vary little: fitted values widen some (teapot depth 8: 184 bytes).
                    [v] if !v.clip && v.corners == corners[i] && !(keep_3x_bytes && v.surface) => {
                        fitted.push((i as u32, leaves.len()));
                    }
                    // A volume voxel of its own (a component's) is stored by format 3.x as a
                    // shared leaf where its codes agree with its neighbours': moving its points
                    // made 2,207 more leaves private on abc5 depth 9 (+1.3 % bytes).
                    [v] if keep_3x_bytes && !v.clip && !v.surface => frozen.push(i as u32),
                    _ => {}
                }
            }
            if !r.voxels.is_empty() {
                histogram[r.voxels.len().min(max_voxels)] += 1;
                leaves.push(LeafInput {
                    coord: sub.cells[i].coord,
                    voxels: r.voxels,
                });
            }
        }
        start = end;
        report(0.45 + 0.5 * end as f32 / n as f32)?;
    }
    phases.push(("leaves".to_string(), ms(t)));

    // 5b. Corners fitted to the surface.
    if let Some((point_of_slot, values)) = shared {
        let t = Instant::now();
        let cells: Vec<u32> = fitted.iter().map(|&(c, _)| c).collect();
        let fit = cornerfit::fit_values(
            &params,
            &cornerfit::FitParams::DEFAULT,
            &local,
            &sub,
            cornerfit::SharedPoints {
                values: &values,
                point_of_slot: &point_of_slot,
            },
            &cells,
            &frozen,
        );
        for &(c, at) in &fitted {
            leaves[at].voxels[0].corners =
                std::array::from_fn(|k| fit[point_of_slot[c as usize * 8 + k] as usize]);
        }
        phases.push(("fit".to_string(), ms(t)));
        report(0.97)?;
    }

    // 6. Pack.
    let t = Instant::now();
    let meta = OctreeMeta {
        depth,
        bits: settings.bits,
        center: norm.center,
        scale: norm.scale,
    };
    let octree = PackedOctree::from_leaves(meta, leaves)?;
    phases.push(("pack".to_string(), ms(t)));
    report(1.0)?;

    let stats = BuildStats {
        nodes: octree.node_count(),
        leaves: octree.leaf_count(),
        voxels: octree.voxel_count(),
        surface_voxels: octree.surface_voxel_count(),
        voxels_per_leaf: histogram,
        cap_hits,
        phases,
        build_ms: ms(t_all),
        bytes: octree.byte_size(),
    };
    Ok((octree, stats))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cancelled_build_stops_with_cancelled_and_an_uncancelled_one_is_unchanged() {
        let mesh = sdfmo_mesh::procedural::demo_part();
        let settings = BuildSettings::new(5, Method::default());
        let asked = std::sync::atomic::AtomicUsize::new(0);
        let after_two = || asked.fetch_add(1, std::sync::atomic::Ordering::Relaxed) >= 2;
        let r = BuildRequest::new(&mesh, settings)
            .cancel(&after_two)
            .octree();
        assert!(matches!(r, Err(BuildError::Cancelled)), "{r:?}");
        assert_eq!(asked.load(std::sync::atomic::Ordering::Relaxed), 3);
        let (a, _) = BuildRequest::new(&mesh, settings)
            .cancel(&|| false)
            .octree()
            .unwrap();
        let (b, _) = build(&mesh, &settings).unwrap();
        assert_eq!(a.as_bytes(), b.as_bytes());
    }

    /// The packed sort (used up to about depth 11) and the pair sort (deeper) give the same
    /// points, hints and slot map, so the octree does not depend on which one ran.
    #[test]
    fn both_corner_sorts_agree() {
        let mesh = sdfmo_mesh::procedural::demo_part();
        let (norm, _) = mesh.normalized(0.05);
        let local = LocalMesh::new(&norm);
        for depth in [4u8, 6] {
            let (gather, candidate) = margins(depth, ValueBits::Eight, Method::default());
            let sub = subdivide::subdivide(&local, depth, gather, candidate);
            assert!(!sub.cells.is_empty());
            let packed = shared_corners_sorted(&sub, depth, true);
            let pairs = shared_corners_sorted(&sub, depth, false);
            assert_eq!(packed, pairs, "depth {depth}");
            assert_eq!(shared_corners(&sub, depth), pairs);
            // Every slot of a cell points at that corner's grid position.
            let h = cell_size(depth);
            for (slot, &pt) in pairs.2.iter().enumerate() {
                let c = sub.cells[slot / 8].coord;
                let o = sdfmo_format::corner_offset(slot % 8);
                let want = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * h + o * h - Vec3::ONE;
                assert!((pairs.0[pt as usize] - want).length() < 1e-6);
            }
        }
    }
}
