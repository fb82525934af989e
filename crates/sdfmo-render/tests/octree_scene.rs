//! The octree renderer against the mesh reference: procedural parts built by `sdfmo-build`,
//! traced by `sdfmo-trace`, compared with the same mesh through `sdfmo-distance`.

mod common;
use common::{on_threads, settings, shot};

use glam::Vec3;
use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_format::PackedOctree;
use sdfmo_mesh::{procedural, TriMesh};
use sdfmo_render::shading::PixelRng;
use sdfmo_render::{
    mesh_in_octree_frame, render, Camera, MeshScene, Mode, OctreeScene, RenderPlan, RenderRequest,
    RenderSettings, Rendered, Traceable,
};

fn octree(mesh: &TriMesh, depth: u8, method: Method) -> PackedOctree {
    build(mesh, &BuildSettings::new(depth, method))
        .expect("build")
        .0
}

fn reference(mesh: &TriMesh, octree: &PackedOctree) -> MeshDistance {
    MeshDistance::new(&mesh_in_octree_frame(mesh, octree.meta()), SignMode::Auto).unwrap()
}

fn hit(r: &Rendered, x: u32, y: u32) -> bool {
    r.rgb[((y * r.width + x) * 3) as usize] != 0
}

/// Pixels hit in the reference whose whole (2·erode+1)² neighbourhood is hit too, and which the
/// octree image misses: pinholes.
fn pinholes(reference: &Rendered, test: &Rendered, erode: i64) -> usize {
    let (w, h) = (reference.width as i64, reference.height as i64);
    let mut holes = 0;
    for y in 0..h {
        for x in 0..w {
            let interior = (-erode..=erode).all(|dy| {
                (-erode..=erode).all(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    xx >= 0 && yy >= 0 && xx < w && yy < h && hit(reference, xx as u32, yy as u32)
                })
            });
            if interior && !hit(test, x as u32, y as u32) {
                holes += 1;
            }
        }
    }
    holes
}

fn iou(a: &Rendered, b: &Rendered) -> f64 {
    let both = a
        .rgb
        .iter()
        .zip(&b.rgb)
        .filter(|(x, y)| **x != 0 && **y != 0)
        .count();
    let either = a
        .rgb
        .iter()
        .zip(&b.rgb)
        .filter(|(x, y)| **x != 0 || **y != 0)
        .count();
    both as f64 / either as f64
}

/// Mask IoU and lambert PSNR of the octree against the mesh reference on the paper views.
fn assert_agrees(mesh: &TriMesh, depth: u8, min_iou: f64, min_psnr: f64) {
    assert_agrees_with(
        mesh,
        depth,
        min_iou,
        min_psnr,
        &[Method::Svo, Method::Multi { max_voxels: 8 }],
    );
}

/// [`assert_agrees`] for the given build methods only.
fn assert_agrees_with(mesh: &TriMesh, depth: u8, min_iou: f64, min_psnr: f64, methods: &[Method]) {
    for &method in methods {
        let tree = octree(mesh, depth, method);
        let dist = reference(mesh, &tree);
        for camera in Camera::paper_views(64, 64) {
            let s = settings(Mode::Mask, false, 0);
            let o = render(&OctreeScene(&tree), &camera, &s).unwrap();
            let m = render(&MeshScene(&dist), &camera, &s).unwrap();
            let v = iou(&o, &m);
            assert!(
                v > min_iou,
                "{method:?} view {:?}: mask IoU {v}",
                camera.eye
            );
            let s = settings(Mode::Lambert, false, 0);
            let o = render(&OctreeScene(&tree), &camera, &s).unwrap();
            let m = render(&MeshScene(&dist), &camera, &s).unwrap();
            let mse = o
                .rgb
                .iter()
                .zip(&m.rgb)
                .map(|(a, b)| (f64::from(*a) - f64::from(*b)).powi(2))
                .sum::<f64>()
                / o.rgb.len() as f64;
            let psnr = 10.0 * (255.0f64 * 255.0 / mse).log10();
            assert!(
                psnr > min_psnr,
                "{method:?} view {:?}: PSNR {psnr:.1}",
                camera.eye
            );
        }
    }
}

#[test]
fn octree_and_mesh_reference_agree_on_closed_parts() {
    let mesh = TriMesh::merge(&[
        procedural::sphere(Vec3::new(-0.4, 0.3, 0.2), 0.5, 3),
        procedural::box_mesh(Vec3::new(0.1, -0.8, -0.6), Vec3::new(0.9, 0.0, 0.4)),
    ]);
    assert_agrees(&mesh, 7, 0.95, 20.0);
}

/// The demo part (thin plate, open sheet, sub-voxel gap) at depth 7, multi-octree. The stripes
/// seen on paper view 1 were the thin plate (0.4 voxel thick, its mid-plane on the diagonals of
/// the cells `gx + gz = 127`), not the open sheet: the global corners there form a saddle
/// (`+0.505, −0.205, −0.205, +0.505` cell edges) whose zero set hugs two cell edges only, and the
/// builder accepted it because `|f|` on the faces (0.18 of a cell) was under the thin-split
/// threshold. Fixed in the builder (the decision now uses the distance to the zero set,
/// `|f| / |∇f|`; regression `thin_plate_on_the_cell_diagonal_is_split_into_surface_voxels` in
/// sdfmo-build). The SVO keeps losing that sub-voxel plate by design (the paper's baseline:
/// IoU 0.897 on view 1), so only the multi-octree is held to the mesh here.
#[test]
fn octree_and_mesh_reference_agree_on_the_demo_part() {
    assert_agrees_with(
        &procedural::demo_part(),
        7,
        0.9,
        15.0,
        &[Method::Multi { max_voxels: 8 }],
    );
}

#[test]
fn octree_planning_through_the_counters() {
    let mesh = procedural::demo_part();
    let tree = octree(&mesh, 6, Method::Multi { max_voxels: 8 });
    let scene = OctreeScene(&tree);
    let camera = Camera::paper_view(1, 48, 48);
    for mode in [Mode::Mask, Mode::Depth] {
        let r = shot(&scene, &camera, mode, true, 4);
        assert!(r.counters.hits > 0);
        assert_eq!(r.counters.rays, 48 * 48);
        assert_eq!(
            (
                r.counters.normal_evals,
                r.counters.shadow_rays,
                r.counters.ao_rays
            ),
            (0, 0, 0)
        );
    }
    let plain = shot(&scene, &camera, Mode::Lambert, false, 0);
    assert_eq!(plain.counters.normal_evals, plain.counters.hits);
    assert_eq!((plain.counters.shadow_rays, plain.counters.ao_rays), (0, 0));
    let full = shot(&scene, &camera, Mode::Lambert, true, 3);
    assert!(full.counters.shadow_rays > 0 && full.counters.shadow_rays <= full.counters.hits);
    assert_eq!(full.counters.ao_rays, 3 * full.counters.hits);
}

#[test]
fn octree_image_does_not_depend_on_the_thread_count() {
    let mesh = procedural::demo_part();
    let tree = octree(&mesh, 6, Method::Multi { max_voxels: 8 });
    let camera = Camera::paper_view(3, 50, 40);
    let s = settings(Mode::Lambert, true, 2);
    let one = on_threads(1, || render(&OctreeScene(&tree), &camera, &s).unwrap());
    for threads in [2, 4] {
        let r = on_threads(threads, || {
            render(&OctreeScene(&tree), &camera, &s).unwrap()
        });
        assert_eq!(one.rgb, r.rgb);
        assert_eq!(one.counters, r.counters);
    }
}

#[test]
fn octree_shadows_fall_where_the_mesh_shadows_fall() {
    let plate = procedural::box_mesh(Vec3::new(-1.0, -0.1, -1.0), Vec3::new(1.0, 0.0, 1.0));
    let block = procedural::box_mesh(Vec3::new(-0.2, 0.2, -0.2), Vec3::new(0.2, 0.6, 0.2));
    let mesh = TriMesh::merge(&[plate, block]);
    let tree = octree(&mesh, 7, Method::Multi { max_voxels: 8 });
    let dist = reference(&mesh, &tree);
    let camera = Camera::new(Vec3::new(0.0, 3.0, 0.5), Vec3::ZERO, 60.0, 64, 64);
    let shadowed = |lit: &Rendered, dark: &Rendered| -> Vec<bool> {
        lit.rgb
            .iter()
            .zip(&dark.rgb)
            .step_by(3)
            .map(|(a, b)| b < a)
            .collect()
    };
    let o = shadowed(
        &shot(&OctreeScene(&tree), &camera, Mode::Lambert, false, 0),
        &shot(&OctreeScene(&tree), &camera, Mode::Lambert, true, 0),
    );
    let m = shadowed(
        &shot(&MeshScene(&dist), &camera, Mode::Lambert, false, 0),
        &shot(&MeshScene(&dist), &camera, Mode::Lambert, true, 0),
    );
    let (no, nm) = (
        o.iter().filter(|x| **x).count(),
        m.iter().filter(|x| **x).count(),
    );
    let both = o.iter().zip(&m).filter(|(a, b)| **a && **b).count();
    assert!(nm > 50, "reference shadow has {nm} pixels");
    // no self-shadowing acne: the octree shadow is about the reference one
    assert!(
        no < nm * 3 / 2 && both > nm * 3 / 4,
        "octree {no}, mesh {nm}, both {both}"
    );
}

/// Random views around the origin: eye at distance 2.5–4 in a random direction, target within
/// 0.3 of the origin, fov 40–70°.
fn random_views(seed: u32, count: u32, size: u32) -> Vec<Camera> {
    let mut rng = PixelRng::new(seed, 0xC0FFEE);
    (0..count)
        .map(|_| {
            let mut f = || rng.next_f32();
            let z: f32 = 2.0 * f() - 1.0;
            let phi = std::f32::consts::TAU * f();
            let r = (1.0 - z * z).sqrt();
            let dir = Vec3::new(r * phi.cos(), z, r * phi.sin());
            let eye = dir * (2.5 + 1.5 * f());
            let target = (Vec3::new(f(), f(), f()) * 2.0 - Vec3::ONE) * 0.3;
            Camera::new(eye, target, 40.0 + 30.0 * f(), size, size)
        })
        .collect()
}

/// No pinholes: every pixel inside the mesh silhouette eroded by 2 pixels is hit by the octree,
/// from `views` random views, for a closed sphere and the closed box.
fn assert_watertight(depths: &[u8], views: u32, size: u32) {
    let parts = [
        ("sphere", procedural::sphere(Vec3::ZERO, 1.0, 4)),
        (
            "box",
            procedural::box_mesh(Vec3::new(-1.0, -0.6, -0.8), Vec3::new(1.0, 0.6, 0.8)),
        ),
    ];
    for (name, mesh) in &parts {
        for &depth in depths {
            for method in [Method::Svo, Method::Multi { max_voxels: 8 }] {
                let tree = octree(mesh, depth, method);
                let dist = reference(mesh, &tree);
                let s = RenderSettings::new(Mode::Mask);
                for (i, camera) in random_views(u32::from(depth), views, size)
                    .iter()
                    .enumerate()
                {
                    let o = render(&OctreeScene(&tree), camera, &s).unwrap();
                    let m = render(&MeshScene(&dist), camera, &s).unwrap();
                    assert!(m.counters.hits > 0);
                    let holes = pinholes(&m, &o, 2);
                    assert_eq!(
                        holes, 0,
                        "{name} depth {depth} {method:?} view {i} {camera:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn closed_parts_have_no_pinholes_at_shallow_depths() {
    assert_watertight(&[6, 7], 100, 48);
}

/// Depths 8–10 (release build: `cargo test -p sdfmo-render --release --test octree_scene --
/// --ignored closed_parts_have_no_pinholes_at_deep_depths`).
#[test]
#[ignore = "slow in the dev profile: run with --release -- --ignored"]
fn closed_parts_have_no_pinholes_at_deep_depths() {
    assert_watertight(&[8, 9, 10], 100, 64);
}

/// The octree scene with the occupied-box rejection switched off: every ray is traced.
struct TraceEverything<'a>(OctreeScene<'a>);

impl Traceable for TraceEverything<'_> {
    type Hit = <OctreeScene<'static> as Traceable>::Hit;
    fn first_hit(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<Self::Hit> {
        self.0.first_hit(o, d, t_min, t_max)
    }
    fn hit_t(&self, hit: &Self::Hit) -> f32 {
        self.0.hit_t(hit)
    }
    fn normal(&self, o: Vec3, d: Vec3, hit: &Self::Hit) -> Vec3 {
        self.0.normal(o, d, hit)
    }
    fn occluded(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        self.0.occluded(o, d, t_min, t_max)
    }
    fn epsilon(&self) -> f32 {
        self.0.epsilon()
    }
}

#[test]
fn skipping_rays_outside_the_occupied_box_changes_no_pixel() {
    // A thin plate (its box is a slab of the root cube) and the demo part, from all four views.
    let plate = procedural::box_mesh(Vec3::new(-1.0, -0.05, -0.6), Vec3::new(1.0, 0.05, 0.6));
    for mesh in [plate, procedural::demo_part()] {
        let tree = octree(&mesh, 6, Method::Multi { max_voxels: 8 });
        let scene = OctreeScene(&tree);
        let (lo, hi) = scene.occupied_bounds().expect("non-empty octree");
        assert!((hi - lo).min_element() < 1.9, "{lo} {hi}");
        for view in 0..4 {
            let camera = Camera::paper_view(view, 48, 40);
            let s = settings(Mode::Lambert, true, 2);
            let fast = render(&scene, &camera, &s).unwrap();
            let full = render(&TraceEverything(scene), &camera, &s).unwrap();
            assert!(fast.counters.hits > 0);
            assert_eq!(fast.rgb, full.rgb, "view {view}");
            assert_eq!(fast.counters, full.counters, "view {view}");
            // Small tiles: many of them lie wholly outside the box and are skipped.
            let plan = RenderPlan::new(&s).unwrap().with_tile_size(4);
            let small = RenderRequest::new(&scene, &camera, &s)
                .plan(plan)
                .render()
                .unwrap();
            assert_eq!(small.rgb, full.rgb, "view {view}, 4-pixel tiles");
            assert_eq!(small.counters, full.counters, "view {view}, 4-pixel tiles");
        }
    }
}
