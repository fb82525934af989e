//! The GPU image against the CPU image (`sdfmo-render` over `sdfmo-trace`), on any adapter,
//! Mesa's software Vulkan (lavapipe) included.
//!
//! Without an adapter these tests print why and pass without checking, unless
//! `SDFMO_REQUIRE_GPU=1` (CI sets it): then they fail. The comparison, per paper view:
//!
//! - **mask** identical, except on pixels whose hit (the CPU's, or the GPU's where only it
//!   hits) lies within [`BOUNDARY_VOXELS`] of a voxel boundary: there the two kernels, whose
//!   f32 arithmetic differs by a few ulps (fused multiply-adds, WGSL's division), may enter a
//!   different leaf first;
//! - **depth** within [`DEPTH_VOXELS`] of the voxel size wherever both hit (the same boundary
//!   pixels excepted), or within [`DEPTH_ULPS`] ulps of t where that is larger: the issue asks
//!   for 1e-4 voxel, but at depth 9 the paper views' hits lie at t ≈ 2.5–3.8, where one ulp of
//!   an f32 t is 2.4e-7 = 0.6e-4 voxel, and two evaluation orders of the same f32 formulas
//!   (the CPU's, and the GPU's with fused multiply-adds) differ by a few ulps. The pixels
//!   that need the ulp allowance are counted (`ulp_allowance`);
//! - **lambert** PSNR ≥ [`MIN_PSNR`] dB against the CPU's lambert image.
//!
//! One more class of pixel is excused, and counted: where the CPU's own answer is
//! **ill-conditioned**, i.e. changing one component of the ray direction by one ulp changes the
//! CPU's mask or moves its hit by more than the depth tolerance (a ray nearly tangent to the
//! surface, where the cubic's root moves like √ε). There the GPU must still agree to within
//! the tolerance plus twice that one-ulp spread, and such pixels must stay rare
//! ([`MAX_ILL_CONDITIONED`] of the hits). Measured on lavapipe: depth-6 demo part, view 0, pixel
//! (169, 35): one ulp of dir.y moves the CPU's own t by 3.3e-6 (1.07e-4 voxel); the GPU's t
//! differs by 3.4e-6.
//!
//! A last class of **lambert** pixel is excused, and counted (`edge_excused`, at most
//! [`MAX_EDGE_EXCUSED`] of the hits): where the CPU's own hit changes voxel under a one-ulp
//! change of the ray. Those are hits on a sharp edge or corner built from intersect voxels
//! (issue 11), where two faces meet and either face's normal is right; the kernels' few-ulp
//! differences pick either. Measured on lavapipe, four 256² views: the demo part's
//! multi-octree 99 of 31,037 hits at depth 6 (0.32 %; lambert PSNR 37.3 dB without the excuse),
//! 60 at depth 7, 18 at depth 8 (8- and 16-bit), 4 at depth 9; abc5 and the teapot 0; the
//! SVOs 0–1.
//!
//! Resolution [`SIZE`]² (lavapipe runs the kernel on the CPU; a 256² paper view is 65k rays),
//! each octree built once and rendered in both modes on all four views.
//!
//! Levels of detail by pixel error ([`pixel_error_matches_cpu`]) are compared the same way,
//! each pixel's voxel size (depth tolerance, boundary distance) being that of the level the
//! CPU's hit lies in, and the one-ulp checks going through `intersect_lod`: a ray whose level
//! choice itself changes under a one-ulp change of direction counts as ill-conditioned.
//!
//! Clip voxels (format 1.1) are checked on a procedural octree built by hand
//! ([`clip_octree`]): a rotated cube whose leaves hold the face planes that cut them as
//! intersect voxels (sharp edges and corners), and a tilted open sheet whose leaves at its
//! oblique rim hold a clip-only voxel.

mod common;

use std::path::PathBuf;

use common::gpu;
use glam::Vec3;
use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_format::testing::{convex_cell_voxels, cube_planes, leaves_by_cell};
use sdfmo_format::{
    cell_corners, cell_size, BrickOctree, LodOctree, OctreeMeta, PackedOctree, ValueBits, Voxel,
};
use sdfmo_gpu::GpuRenderer;
use sdfmo_mesh::TriMesh;
use sdfmo_render::{render, Camera, LodScene, Mode, OctreeScene, RenderSettings, Rendered};
use sdfmo_trace::{intersect, intersect_lod, pixel_angle, LevelChoice, Ray};

/// Image side of the comparisons.
const SIZE: u32 = 256;
/// Pixels whose hit is this close to a voxel boundary (in voxel edges) may differ in the mask.
const BOUNDARY_VOXELS: f32 = 1e-4;
/// Depth agreement, in voxel edges.
const DEPTH_VOXELS: f32 = 1e-4;
/// ... or in ulps of t, whichever is larger (see the module docs: at depth 9 and t ≈ 3,
/// 1e-4 voxel is 1.6 ulps of t).
const DEPTH_ULPS: f32 = 4.0;
/// Lambert PSNR floor, dB.
const MIN_PSNR: f64 = 45.0;
/// Ill-conditioned pixels (see the module docs) allowed, as a fraction of the hits.
const MAX_ILL_CONDITIONED: f64 = 0.002;
/// Lambert pixels excused on sharp edges (see the module docs), as a fraction of the hits.
const MAX_EDGE_EXCUSED: f64 = 0.005;

fn cpu(octree: &PackedOctree, cam: &Camera, mode: Mode) -> Rendered {
    let settings = RenderSettings::new(mode);
    render(&OctreeScene(octree), cam, &settings).expect("CPU render")
}

/// Distance of `p` (normalised coordinates) to the nearest voxel boundary plane, in voxel edges.
fn boundary_distance(p: Vec3, depth: u8) -> f32 {
    let q = (p + Vec3::ONE) * (f32::from(1u16 << depth) * 0.5);
    (q - q.round()).abs().min_element()
}

/// The CPU side of a comparison: its images, and its own first hit of a ray.
trait CpuSide {
    /// The CPU renderer's image.
    fn render(&self, cam: &Camera, mode: Mode) -> Rendered;
    /// The CPU's first hit of the ray (`t_min` 0, unbounded).
    fn first_hit(&self, o: Vec3, d: Vec3) -> Option<CpuHit>;
    /// The depth of the finest octree (the voxel size of a pixel the CPU does not hit).
    fn depth(&self) -> u8;
    /// The depth of the octree the CPU's first hit of the ray lies in.
    fn hit_depth(&self, o: Vec3, d: Vec3) -> u8 {
        self.first_hit(o, d).map_or(self.depth(), |h| h.depth)
    }
}

/// A first hit of a [`CpuSide`]: `t`, the voxel (its level and index) and the depth of the
/// octree that holds it (its voxel size is the tolerance's unit).
#[derive(Clone, Copy, Debug, PartialEq)]
struct CpuHit {
    t: f32,
    voxel: (u8, u32),
    depth: u8,
}

impl CpuSide for PackedOctree {
    fn render(&self, cam: &Camera, mode: Mode) -> Rendered {
        cpu(self, cam, mode)
    }

    fn first_hit(&self, o: Vec3, d: Vec3) -> Option<CpuHit> {
        let depth = self.depth();
        intersect(self, &Ray { origin: o, dir: d }, 0.0, f32::INFINITY).map(|h| CpuHit {
            t: h.t,
            voxel: (depth, h.voxel),
            depth,
        })
    }

    fn depth(&self) -> u8 {
        PackedOctree::depth(self)
    }

    /// One octree: no trace needed.
    fn hit_depth(&self, _: Vec3, _: Vec3) -> u8 {
        PackedOctree::depth(self)
    }
}

/// A file with levels rendered by pixel error (`LodScene`, `intersect_lod`).
struct PixelErrorCpu<'a> {
    lod: &'a LodOctree,
    pixels: f32,
}

impl PixelErrorCpu<'_> {
    fn choice(&self, cam: &Camera) -> LevelChoice {
        LevelChoice::PixelError {
            pixels: self.pixels,
            pixel_angle: pixel_angle(cam.fov_y_deg, cam.height),
        }
    }
}

impl CpuSide for PixelErrorCpu<'_> {
    fn render(&self, cam: &Camera, mode: Mode) -> Rendered {
        let scene = LodScene {
            lod: self.lod,
            choice: self.choice(cam),
        };
        let settings = RenderSettings::new(mode);
        render(&scene, cam, &settings).expect("CPU render")
    }

    /// Every comparison of this file renders at [`SIZE`]² with a 60° field of view.
    fn first_hit(&self, o: Vec3, d: Vec3) -> Option<CpuHit> {
        let cam = Camera::paper_view(0, SIZE, SIZE);
        let ray = Ray { origin: o, dir: d };
        intersect_lod(self.lod, &ray, 0.0, f32::INFINITY, self.choice(&cam)).map(|h| CpuHit {
            t: h.hit.t,
            voxel: (h.level, h.hit.voxel),
            depth: h.level,
        })
    }

    fn depth(&self) -> u8 {
        self.lod.depth()
    }
}

/// How much the CPU's own first hit (`t`, +∞ for a miss) changes when one component of the
/// ray direction moves by one ulp: (whether hit/miss flips, the largest |Δt|).
fn one_ulp_spread(cpu: &dyn CpuSide, o: Vec3, d: Vec3, t: f32) -> (bool, f32) {
    let mut flips = false;
    let mut spread = 0.0f32;
    for k in 0..3 {
        for step in [-1i32, 1] {
            let mut dir = d.to_array();
            dir[k] = f32::from_bits(dir[k].to_bits().wrapping_add_signed(step));
            match cpu.first_hit(o, Vec3::from_array(dir)) {
                Some(h) if t.is_finite() => spread = spread.max((h.t - t).abs()),
                Some(_) => flips = true,
                None => flips |= t.is_finite(),
            }
        }
    }
    (flips, spread)
}

/// Whether the CPU's hit voxel (or level) changes when one component of the ray direction
/// moves by one ulp.
fn active_voxel_flips(cpu: &dyn CpuSide, o: Vec3, d: Vec3) -> bool {
    let voxel = |dir: Vec3| cpu.first_hit(o, dir).map(|h| h.voxel);
    let here = voxel(d);
    (0..3).any(|k| {
        [-1i32, 1].into_iter().any(|step| {
            let mut dir = d.to_array();
            dir[k] = f32::from_bits(dir[k].to_bits().wrapping_add_signed(step));
            voxel(Vec3::from_array(dir)) != here
        })
    })
}

fn psnr(a: &[u8], b: &[u8], size: u32) -> f64 {
    let img = |v: &[u8]| image::RgbImage::from_raw(size, size, v.to_vec()).expect("size");
    sdfmo_metrics::psnr(&img(a), &img(b)).expect("same size")
}

/// What one octree's comparison found, over its four views.
#[derive(Debug, Default)]
struct Stats {
    hits: u64,
    mask_diffs: u64,
    depth_diffs: u64,
    ulp_allowance: u64,
    boundary_excused: u64,
    ill_conditioned: u64,
    /// Lambert pixels whose CPU voxel is not stable under a one-ulp ray change.
    edge_excused: u64,
    max_depth_err_voxels: f32,
    min_psnr: f64,
}

/// An octree's GPU image against its CPU image on the paper views ([`compare_views`]).
fn compare(gpu: &mut GpuRenderer, octree: &PackedOctree, label: &str) -> Stats {
    let on_gpu = gpu.upload(octree).expect("upload");
    let mut draw = |gpu: &mut GpuRenderer, cam: &Camera, mode: Mode| {
        gpu.render(&on_gpu, cam, &RenderSettings::new(mode))
            .expect("GPU render")
    };
    compare_views(
        gpu,
        &mut draw,
        octree,
        &Camera::paper_views(SIZE, SIZE),
        label,
    )
}

/// The GPU's images (`draw`) against the CPU's, depth and lambert, on each of `cams` (all
/// [`SIZE`]²), with the tolerances of the module docs; the voxel size of a pixel is that of the
/// octree (the level) the CPU's hit lies in.
fn compare_views(
    gpu: &mut GpuRenderer,
    draw: &mut dyn FnMut(&mut GpuRenderer, &Camera, Mode) -> Rendered,
    cpu_side: &dyn CpuSide,
    cams: &[Camera],
    label: &str,
) -> Stats {
    let mut stats = Stats {
        min_psnr: f64::INFINITY,
        ..Stats::default()
    };
    let mut failures = Vec::new();
    for (view, cam) in cams.iter().enumerate() {
        assert_eq!((cam.width, cam.height), (SIZE, SIZE));
        let c: Rendered = cpu_side.render(cam, Mode::Depth);
        let g: Rendered = draw(gpu, cam, Mode::Depth);
        let cd = c.depth.as_ref().expect("depth mode keeps depth");
        let gd = g.depth.as_ref().expect("depth mode keeps depth");
        for (i, (&tc, &tg)) in cd.iter().zip(gd).enumerate() {
            let (px, py) = (i as u32 % SIZE, i as u32 / SIZE);
            let (o, d) = cam.primary_ray(px, py);
            stats.hits += u64::from(tc.is_finite());
            // The voxel size and boundaries of the CPU hit's octree (the finest where the
            // CPU misses: its boundaries include every coarser level's).
            let depth = if tc.is_finite() {
                cpu_side.hit_depth(o, d)
            } else {
                cpu_side.depth()
            };
            let voxel = cell_size(depth);
            let mask_differs = tc.is_finite() != tg.is_finite();
            let err = if mask_differs || !tc.is_finite() {
                0.0
            } else {
                (tc - tg).abs() / voxel
            };
            if !mask_differs && err <= DEPTH_VOXELS {
                stats.max_depth_err_voxels = stats.max_depth_err_voxels.max(err);
                continue;
            }
            let ulp = f32::from_bits(tc.to_bits() + 1) - tc;
            if !mask_differs && (tc - tg).abs() <= DEPTH_ULPS * ulp {
                stats.ulp_allowance += 1;
                continue;
            }
            if mask_differs {
                stats.mask_diffs += 1;
            } else {
                stats.depth_diffs += 1;
            }
            let t = if tc.is_finite() { tc } else { tg };
            if boundary_distance(o + d * t, depth) < BOUNDARY_VOXELS {
                stats.boundary_excused += 1;
                continue;
            }
            let (flips, spread) = one_ulp_spread(cpu_side, o, d, tc);
            let conditioned = if mask_differs {
                flips
            } else {
                flips || err <= DEPTH_VOXELS + 2.0 * spread / voxel
            };
            if (flips || spread / voxel > DEPTH_VOXELS) && conditioned {
                stats.ill_conditioned += 1;
            } else {
                failures.push(format!(
                    "{label} view {view} pixel ({px}, {py}): CPU t {tc}, GPU t {tg} ({err} voxel; \
                     a one-ulp ray change moves the CPU by {} voxel, flips: {flips})",
                    spread / voxel
                ));
            }
        }
        assert_eq!(c.rgb.len(), g.rgb.len());
        let cl = cpu_side.render(cam, Mode::Lambert);
        let gl = draw(gpu, cam, Mode::Lambert);
        // Lambert pixels whose CPU hit changes voxel under a one-ulp change of the ray (a hit on
        // a sharp edge of intersect voxels, where either face's normal is right) are excused:
        // compared as the CPU's.
        let mut g_rgb = gl.rgb.clone();
        for (i, (cp, gp)) in cl
            .rgb
            .chunks_exact(3)
            .zip(gl.rgb.chunks_exact(3))
            .enumerate()
        {
            if cp == gp {
                continue;
            }
            let (px, py) = (i as u32 % SIZE, i as u32 / SIZE);
            let (o, d) = cam.primary_ray(px, py);
            if active_voxel_flips(cpu_side, o, d) {
                stats.edge_excused += 1;
                g_rgb[3 * i..3 * i + 3].copy_from_slice(cp);
            }
        }
        let p = psnr(&cl.rgb, &g_rgb, SIZE);
        stats.min_psnr = stats.min_psnr.min(p);
        if p < MIN_PSNR {
            failures.push(format!(
                "{label} view {view}: lambert PSNR {p:.1} dB < {MIN_PSNR}"
            ));
        }
    }
    eprintln!("{label}: {stats:?}");
    assert!(
        stats.hits > 0,
        "{label}: nothing hit, the comparison is empty"
    );
    assert!(
        stats.edge_excused as f64 <= MAX_EDGE_EXCUSED * stats.hits as f64,
        "{label}: {} lambert pixels excused at edges of {} hits",
        stats.edge_excused,
        stats.hits
    );
    assert!(
        stats.ill_conditioned as f64 <= MAX_ILL_CONDITIONED * stats.hits as f64,
        "{label}: {} ill-conditioned pixels of {} hits",
        stats.ill_conditioned,
        stats.hits
    );
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures[..failures.len().min(20)].join("\n")
    );
    stats
}

fn build_octree(mesh: &TriMesh, depth: u8, method: Method, bits: ValueBits) -> PackedOctree {
    let settings = BuildSettings::new(depth, method).with_bits(bits);
    build(mesh, &settings).expect("build").0
}

fn methods() -> [(Method, &'static str); 2] {
    [
        (Method::Svo, "svo"),
        (Method::Multi { max_voxels: 8 }, "multi"),
    ]
}

fn match_model(name: &str, mesh: &TriMesh, depths: &[u8]) {
    let Some(mut gpu) = gpu() else { return };
    eprintln!("adapter: {}", gpu.adapter_name());
    for &depth in depths {
        for (method, m) in methods() {
            let octree = build_octree(mesh, depth, method, ValueBits::Eight);
            compare(&mut gpu, &octree, &format!("{name} {m} d{depth}"));
        }
    }
}

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("SDFMO_TEST_DATA_DIR")).join(name)
}

fn load(name: &str) -> TriMesh {
    sdfmo_mesh::load_mesh(&data(name)).expect("test mesh").mesh
}

/// Levels of detail: every level of one file with levels (`BuildRequest::levels`, written and read back as
/// a viewer would), drawn by the GPU as `render --lod K --device gpu` does, matches the CPU.
/// Levels 6…8, the depths the other models' tests cover: a depth-5 multi-octree of the demo
/// part (a level or a build alike) has 178 lambert pixels excused at sharp edges of 30,968 hits,
/// over this file's bound, which is a property of depth 5, not of levels (2026-12-03).
/// The demo part with levels 6..=8 as a reader sees it (written and read back).
fn demo_levels(demo: &TriMesh, method: Method) -> LodOctree {
    let (lod, _) = sdfmo_build::BuildRequest::new(demo, BuildSettings::new(8, method))
        .levels(6)
        .expect("levels");
    LodOctree::from_bytes(&lod.to_bytes()).expect("read back")
}

#[test]
fn levels_of_one_file_match_cpu() {
    let Some(mut gpu) = gpu() else { return };
    let demo = sdfmo_mesh::procedural::demo_part();
    for (method, m) in methods() {
        let back = demo_levels(&demo, method);
        for level in back.levels() {
            compare(
                &mut gpu,
                level,
                &format!("demo {m} level {} of 6..=8", level.depth()),
            );
        }
    }
}

/// Levels of detail by pixel error: the GPU's `render_lod` (`smo_intersect_lod`, one
/// dispatch over the whole 2.0 file) matches the CPU's `intersect_lod` on the file of
/// [`levels_of_one_file_match_cpu`], with the tolerances above in the voxel size of the level
/// the CPU's hit lies in. Paper views (hits at t ≈ 2.5–3.8: levels 7 and 8 in one image) and a
/// camera at (0, 0, 12) (level 6), at 1 and 2 pixels; the CPU's per-ray levels are counted to
/// show that every level is used.
#[test]
fn pixel_error_matches_cpu() {
    let Some(mut gpu) = gpu() else { return };
    let demo = sdfmo_mesh::procedural::demo_part();
    let mut cams = Camera::paper_views(SIZE, SIZE);
    let mut far = cams[0];
    far.eye = Vec3::new(0.0, 0.0, 12.0);
    cams.push(far);
    for (method, m) in methods() {
        let lod = demo_levels(&demo, method);
        let on_gpu = gpu.upload_lod(&lod).expect("upload_lod");
        for pixels in [1.0, 2.0] {
            let cpu_side = PixelErrorCpu { lod: &lod, pixels };
            // Hits per level, the paper views and the far view apart.
            let mut levels = [[0u64; 9]; 2];
            for (v, cam) in cams.iter().enumerate() {
                for py in 0..SIZE {
                    for px in 0..SIZE {
                        let (o, d) = cam.primary_ray(px, py);
                        if let Some(h) = cpu_side.first_hit(o, d) {
                            levels[usize::from(v == 4)][usize::from(h.depth)] += 1;
                        }
                    }
                }
            }
            eprintln!(
                "demo {m} pixel error {pixels}: hits per level 0..=8, paper views {:?}, far {:?}",
                levels[0], levels[1]
            );
            // Far away every hit is at the coarsest level; the paper views mix two levels
            // (7 and 8 at one pixel, 6 and 7 at two), so one pixel uses all three.
            let used = |l: &[u64; 9]| l.iter().filter(|&&n| n > 0).count();
            assert!(
                levels[1][6] > 200 && used(&levels[1]) == 1,
                "far: {levels:?}"
            );
            assert!(used(&levels[0]) == 2, "paper views: {levels:?}");
            if pixels == 1.0 {
                assert!(
                    levels[0][7] > 0 && levels[0][8] > 0,
                    "paper views: {levels:?}"
                );
            }
            // The tracer's level choice, the CPU side's own for this camera.
            let mut draw = |gpu: &mut GpuRenderer, cam: &Camera, mode: Mode| {
                let choice = cpu_side.choice(cam);
                gpu.render_lod(&on_gpu, choice, cam, &RenderSettings::new(mode))
                    .expect("GPU render")
            };
            compare_views(
                &mut gpu,
                &mut draw,
                &cpu_side,
                &cams,
                &format!("demo {m} 6..=8 pixel error {pixels}"),
            );
        }
    }
}

#[test]
fn demo_part_matches_cpu() {
    let demo = sdfmo_mesh::procedural::demo_part();
    match_model("demo", &demo, &[6, 7, 8, 9]);
    // The 16-bit corner decoding (the other tests use the default 8 bits).
    let Some(mut gpu) = gpu() else { return };
    for (method, m) in methods() {
        let octree = build_octree(&demo, 8, method, ValueBits::Sixteen);
        compare(&mut gpu, &octree, &format!("demo {m} d8 16-bit"));
    }
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn abc5_matches_cpu() {
    match_model("abc5", &load("abc5.stl"), &[6, 7, 8, 9]);
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn teapot_matches_cpu() {
    match_model("teapot", &load("teapot.obj"), &[6, 7, 8, 9]);
}

/// A procedural octree with clip voxels: the cube of half-edge 0.3 rotated about a skew axis
/// (in each leaf the face planes that cut it, as intersect voxels: the cube is their `max`),
/// and the sheet `n·p = −0.78` (normal near +z, |y| ≤ 0.5) kept where the oblique rim plane
/// `m·p ≤ 0.3` keeps it (a clip-only voxel in the leaves the rim crosses).
fn clip_octree(depth: u8, bits: ValueBits) -> PackedOctree {
    let rot = glam::Mat3::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.6);
    let centre = Vec3::new(0.021, 0.013, 0.037);
    let faces = cube_planes(rot, centre, 0.3);
    let sheet_n = Vec3::new(0.1, 0.15, 1.0).normalize();
    let rim_n = Vec3::new(1.0, 0.4, 0.1).normalize();
    let h = cell_size(depth);
    let mixed = |c: &[f32; 8]| c.iter().any(|&v| v > 0.0) && c.iter().any(|&v| v <= 0.0);
    let leaves = leaves_by_cell(depth, |c| {
        let mut voxels = convex_cell_voxels(depth, c, &faces);
        let y_lo = c[1] as f32 * h - 1.0;
        let sheet = cell_corners(depth, c, |p| sheet_n.dot(p) + 0.78);
        let rim = cell_corners(depth, c, |p| rim_n.dot(p) - 0.3);
        if mixed(&sheet) && (-0.5..0.5).contains(&y_lo) && !rim.iter().all(|&v| v > 0.0) {
            assert!(voxels.is_empty(), "the sheet and the cube share no leaf");
            voxels.push(Voxel {
                corners: sheet,
                surface: true,
                clip: false,
            });
            if mixed(&rim) {
                voxels.push(Voxel {
                    corners: rim,
                    surface: true,
                    clip: true,
                });
            }
        }
        voxels
    });
    PackedOctree::from_leaves(OctreeMeta::unit(depth, bits), leaves).expect("clip octree")
}

#[test]
fn clip_voxels_match_cpu() {
    let Some(mut gpu) = gpu() else { return };
    eprintln!("adapter: {}", gpu.adapter_name());
    for (depth, bits) in [
        (5, ValueBits::Sixteen),
        (6, ValueBits::Eight),
        (7, ValueBits::Sixteen),
    ] {
        let octree = clip_octree(depth, bits);
        assert!(octree.has_clip_voxels());
        let multi = (0..octree.node_count() as u32)
            .map(sdfmo_format::NodeRef::from_index)
            .filter(|&n| octree.is_leaf(n) && octree.leaf_voxels(n).len() > 1)
            .count();
        assert!(multi > 50, "{multi} leaves combine voxels");
        let stats = compare(
            &mut gpu,
            &octree,
            &format!("clip d{depth} {}-bit", bits.bits()),
        );
        assert!(stats.hits > 10_000, "{stats:?}");
    }
}

/// Issue 19 item 8: voxels whose corners are all 0 are never hit, on the GPU as on the CPU
/// (`FORMAT.md`, surface section). The sphere's SVO with such a voxel added to every leaf (and
/// leaves of one alone in empty cells), as a volume, surface, intersect or clip-only voxel,
/// renders exactly as the sphere alone on each device, and the devices agree on it.
#[test]
fn all_zero_voxels_are_never_hit() {
    use sdfmo_format::testing::with_all_zero_voxels;
    let Some(mut gpu) = gpu() else { return };
    let depth = 5;
    let sphere = || sdfmo_format::testing::sphere_leaves(depth, 0.6);
    let meta = OctreeMeta::unit(depth, ValueBits::Eight);
    let plain = PackedOctree::from_leaves(meta, sphere()).unwrap();
    let views = Camera::paper_views(128, 128);
    let render_both = |gpu: &mut GpuRenderer, o: &PackedOctree| {
        let on_gpu = gpu.upload(o).expect("upload");
        views
            .iter()
            .map(|cam| {
                let g = gpu
                    .render(&on_gpu, cam, &RenderSettings::new(Mode::Lambert))
                    .expect("GPU render");
                let g_depth = gpu
                    .render(&on_gpu, cam, &RenderSettings::new(Mode::Depth))
                    .expect("GPU render")
                    .depth
                    .expect("depth mode keeps depth");
                let c = cpu(o, cam, Mode::Lambert);
                (c.rgb, g.rgb, g_depth)
            })
            .collect::<Vec<_>>()
    };
    let reference = render_both(&mut gpu, &plain);
    assert!(reference[0].2.iter().filter(|t| t.is_finite()).count() > 1000);
    // The devices agree on the sphere (to the tolerances of this file); each device renders
    // every variant below exactly as it renders the sphere.
    compare(&mut gpu, &plain, "sphere d5");
    for (surface, clip, kind) in [
        (false, false, "volume"),
        (true, false, "surface"),
        (false, true, "intersect"),
        (true, true, "clip-only"),
    ] {
        let leaves = with_all_zero_voxels(depth, sphere(), surface, clip);
        let o = PackedOctree::from_leaves(meta, leaves).unwrap();
        let got = render_both(&mut gpu, &o);
        for (view, (a, b)) in got.iter().zip(&reference).enumerate() {
            assert!(a.0 == b.0, "{kind}: CPU view {view} differs");
            assert!(a.1 == b.1, "{kind}: GPU view {view} differs");
            let bits = |d: &[f32]| d.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
            assert!(
                bits(&a.2) == bits(&b.2),
                "{kind}: GPU depth of view {view} differs"
            );
        }
    }
}

/// Format 3.0 (issue 34): `octree`'s brick file ([`BrickOctree::encode`]), uploaded as it is
/// (`upload_bytes`: no expansion to 1.x; `compressed`: the compressed container, decoded to the
/// 3.0 bytes on upload) and traced by the kernel's brick path, renders on the GPU exactly as
/// the 1.x file does (lambert, normal and depth on the paper views: the colours byte for byte,
/// depths and normals bit for bit), and so matches the CPU's images of the 1.x file with this
/// file's tolerances ([`compare_views`]). Returns the brick file.
fn bricks_match(
    gpu: &mut GpuRenderer,
    octree: &PackedOctree,
    compressed: bool,
    label: &str,
) -> BrickOctree {
    bricks_match_minor(gpu, octree, compressed, label, None)
}

/// [`bricks_match`] of the file [`BrickOctree::encode_minor`] writes at `minor` (`None`: what
/// `encode` writes, 3.1).
fn bricks_match_minor(
    gpu: &mut GpuRenderer,
    octree: &PackedOctree,
    compressed: bool,
    label: &str,
    minor: Option<u16>,
) -> BrickOctree {
    let bricks = match minor {
        Some(m) => BrickOctree::encode_minor(octree, m),
        None => BrickOctree::encode(octree),
    }
    .expect("encode 3.x");
    let bytes = if compressed {
        sdfmo_format::compressed::compress(bricks.as_bytes()).expect("compress")
    } else {
        bricks.as_bytes().to_vec()
    };
    let plain = gpu.upload(octree).expect("upload 1.x");
    let on_gpu = gpu.upload_bytes(&bytes).expect("upload 3.0");
    // The buffer is the 3.0 file (not its 1.x expansion).
    assert_eq!(on_gpu.byte_size(), bricks.as_bytes().len() as u64);
    let bits = |v: &Option<Vec<f32>>| {
        v.as_ref()
            .map(|d| d.iter().map(|t| t.to_bits()).collect::<Vec<_>>())
    };
    let normal_bits = |v: &Option<Vec<Vec3>>| {
        v.as_ref().map(|n| {
            n.iter()
                .flat_map(|n| n.to_array().map(f32::to_bits))
                .collect::<Vec<_>>()
        })
    };
    let cams = Camera::paper_views(SIZE, SIZE);
    for (view, cam) in cams.iter().enumerate() {
        for mode in [Mode::Lambert, Mode::Normal, Mode::Depth] {
            let settings = RenderSettings::new(mode);
            let a = gpu.render(&plain, cam, &settings).expect("GPU 1.x");
            let b = gpu.render(&on_gpu, cam, &settings).expect("GPU 3.0");
            let what = format!("{label} view {view} {mode:?}");
            assert!(a.counters.hits > 0, "{what}: nothing hit");
            assert!(a.rgb == b.rgb, "{what}: colours differ");
            assert!(bits(&a.depth) == bits(&b.depth), "{what}: depths differ");
            assert!(
                normal_bits(&a.normals) == normal_bits(&b.normals),
                "{what}: normals differ"
            );
        }
    }
    let mut draw = |gpu: &mut GpuRenderer, cam: &Camera, mode: Mode| {
        gpu.render(&on_gpu, cam, &RenderSettings::new(mode))
            .expect("GPU render")
    };
    compare_views(gpu, &mut draw, octree, &cams, &format!("{label} 3.0"));
    eprintln!(
        "{label}: {} bricks, {} of {} leaves private, {} surface and {} clip voxels; {} bytes \
         on the GPU (1.x {})",
        bricks.brick_count(),
        bricks.private_leaf_count(),
        bricks.leaf_count(),
        bricks.surface_voxel_count(),
        bricks.clip_voxel_count(),
        on_gpu.byte_size(),
        plain.byte_size()
    );
    bricks
}

/// [`bricks_match`] on octrees whose brick files use every part of the layout: shared and
/// private leaves, several residual widths, 8- and 16-bit codes, surface voxels (the
/// multi-octree's thin walls) and clip voxels ([`clip_octree`]), plain and compressed.
#[test]
fn bricks_match_their_octree() {
    let Some(mut gpu) = gpu() else { return };
    eprintln!("adapter: {}", gpu.adapter_name());
    let demo = sdfmo_mesh::procedural::demo_part();
    for (depth, (method, m), bits) in [
        (6, methods()[0], ValueBits::Eight),
        (7, methods()[1], ValueBits::Eight),
        (7, methods()[1], ValueBits::Sixteen),
    ] {
        let octree = build_octree(&demo, depth, method, bits);
        let label = format!("demo {m} d{depth} {}-bit", bits.bits());
        let b = bricks_match(&mut gpu, &octree, depth == 6, &label);
        // 3.1's narrow private voxels (most of a multi-octree's), beside wide ones.
        if m == "multi" {
            assert!(
                b.wide_voxel_count() < b.private_voxel_count(),
                "{label}: narrow voxels"
            );
            // And the 3.0 layout of the same octree (every private voxel wide).
            let label = format!("{label} as 3.0");
            bricks_match_minor(&mut gpu, &octree, depth == 7, &label, Some(0));
        }
        // The SVO's leaves are all shared; the multi-octree's thin walls make private ones.
        assert!(
            b.private_leaf_count() < b.leaf_count(),
            "{label}: shared leaves"
        );
        assert_eq!(
            b.private_leaf_count() > 0,
            m == "multi",
            "{label}: private leaves"
        );
    }
    for (depth, bits) in [(5, ValueBits::Sixteen), (6, ValueBits::Eight)] {
        let octree = clip_octree(depth, bits);
        let b = bricks_match(
            &mut gpu,
            &octree,
            false,
            &format!("clip d{depth} {}-bit", bits.bits()),
        );
        assert!(b.clip_voxel_count() > 0 && b.surface_voxel_count() > 0);
    }
}

/// [`bricks_match`] on the open teapot (surface voxels) and abc5 (thin walls: many private
/// leaves), depth 7, both methods.
#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn bricks_of_models_match_their_octree() {
    let Some(mut gpu) = gpu() else { return };
    for name in ["teapot.obj", "abc5.stl"] {
        let mesh = load(name);
        for (method, m) in methods() {
            let octree = build_octree(&mesh, 7, method, ValueBits::Eight);
            let b = bricks_match(&mut gpu, &octree, false, &format!("{name} {m} d7"));
            if name == "teapot.obj" && m == "multi" {
                assert!(
                    b.surface_voxel_count() > 0,
                    "the open teapot has surface voxels"
                );
            }
        }
    }
}
