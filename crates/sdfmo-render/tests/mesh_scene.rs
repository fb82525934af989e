//! The reference renderer on real meshes: procedural parts through `sdfmo-distance`'s ray hits.

mod common;
use common::shot;

use glam::Vec3;
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_mesh::procedural;
use sdfmo_render::shading::light_dir;
use sdfmo_render::{apply_normalization, Camera, MeshScene, Mode, Rendered, Spheres};

/// The mesh and the analytic sphere of `radius` at the origin, rendered alike.
fn mesh_and_sphere(
    dist: &MeshDistance,
    radius: f32,
    camera: &Camera,
    mode: Mode,
) -> (Rendered, Rendered) {
    let sphere = Spheres::one(Vec3::ZERO, radius);
    let mesh = shot(&MeshScene(dist), camera, mode, false, 0);
    (mesh, shot(&sphere, camera, mode, false, 0))
}

/// An icosphere normalised as the builder would: its ray queries and its radius in that frame.
fn normalized_sphere(center: Vec3, radius: f32, subdivisions: u32) -> (MeshDistance, f32) {
    let (mesh, _) = procedural::sphere(center, radius, subdivisions).normalized(0.05);
    let r = mesh
        .positions()
        .iter()
        .map(|p| p.length())
        .fold(0.0f32, f32::max);
    (MeshDistance::new(&mesh, SignMode::Auto).unwrap(), r)
}

#[test]
fn icosphere_silhouette_matches_the_analytic_sphere() {
    let (dist, radius) = normalized_sphere(Vec3::new(3.0, -1.0, 2.0), 5.0, 4);
    let camera = Camera::paper_view(1, 96, 96);
    let (m, s) = mesh_and_sphere(&dist, radius, &camera, Mode::Mask);
    let pixels = |f: fn(bool, bool) -> bool| {
        let masks = m.rgb.iter().zip(&s.rgb);
        masks.filter(|(a, b)| f(**a == 255, **b == 255)).count()
    };
    let (both, either) = (pixels(|a, b| a && b), pixels(|a, b| a || b));
    let iou = both as f64 / either as f64;
    assert!(iou > 0.97, "IoU {iou}");
    assert_eq!(m.counters.normal_evals, 0);
}

#[test]
fn mesh_lambert_is_two_sided_and_close_to_the_analytic_shading() {
    let (dist, radius) = normalized_sphere(Vec3::ZERO, 1.0, 5);
    let camera = Camera::paper_view(0, 65, 65);
    let (m, s) = mesh_and_sphere(&dist, radius, &camera, Mode::Lambert);
    assert_eq!(m.counters.normal_evals, m.counters.hits);
    // centre pixel: the facet normal is within a few degrees of +Z
    let c = (32 * 65 + 32) * 3;
    assert!((i32::from(m.rgb[c]) - i32::from(s.rgb[c])).abs() <= 6);

    // From inside the sphere the inner faces are seen: flipped normals, still lit.
    let inside = Camera::new(Vec3::ZERO, -Vec3::ONE, 60.0, 9, 9);
    let r = shot(&MeshScene(&dist), &inside, Mode::Lambert, false, 0);
    assert_eq!(r.counters.hits, 81);
    assert!(
        r.rgb[(4 * 9 + 4) * 3] > 220,
        "inner wall facing the light is bright"
    );
}

#[test]
fn mesh_shadows_and_occlusion_cast_rays_and_darken() {
    // a box floating above a wide plate: the plate gets the box's shadow
    let plate = procedural::box_mesh(Vec3::new(-1.0, -0.1, -1.0), Vec3::new(1.0, 0.0, 1.0));
    let block = procedural::box_mesh(Vec3::new(-0.2, 0.2, -0.2), Vec3::new(0.2, 0.6, 0.2));
    let mesh = sdfmo_mesh::TriMesh::merge(&[plate, block]);
    let dist = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
    let camera = Camera::new(Vec3::new(0.0, 3.0, 0.5), Vec3::ZERO, 60.0, 64, 64);
    let lit = shot(&MeshScene(&dist), &camera, Mode::Lambert, false, 0);
    let dark = shot(&MeshScene(&dist), &camera, Mode::Lambert, true, 0);
    assert_eq!(lit.counters.shadow_rays, 0);
    assert!(dark.counters.shadow_rays > 0);
    let shadowed = lit.rgb.iter().zip(&dark.rgb).filter(|(a, b)| b < a).count();
    assert!(shadowed > 100, "{shadowed}");
    // the shadow falls on the side away from the light
    let shadow_dir = -light_dir();
    assert!(shadow_dir.x < 0.0 && shadow_dir.z < 0.0);
    let ao = shot(&MeshScene(&dist), &camera, Mode::Lambert, false, 8);
    assert_eq!(ao.counters.ao_rays, 8 * ao.counters.hits);
    assert!(
        lit.rgb.iter().zip(&ao.rgb).any(|(a, b)| b < a),
        "the contact region darkens"
    );
}

#[test]
fn normalization_helpers_match_the_mesh_crate() {
    let mesh = procedural::demo_part();
    let (expect, n) = mesh.normalized(0.05);
    let got = apply_normalization(&mesh, n);
    assert_eq!(got.positions(), expect.positions());
    assert_eq!(got.triangles(), expect.triangles());
}
