//! The reference renderer on real meshes: procedural parts through `sdfmo-distance`'s ray hits.

use glam::Vec3;
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_mesh::procedural;
use sdfmo_render::shading::light_dir;
use sdfmo_render::{apply_normalization, render, Camera, MeshScene, Mode, RenderSettings, Spheres};

fn settings(mode: Mode, shadows: bool, ao: u32) -> RenderSettings {
    RenderSettings {
        mode,
        shadows,
        ao_samples: ao,
        threads: Some(2),
    }
}

#[test]
fn icosphere_silhouette_matches_the_analytic_sphere() {
    let (mesh, _) = procedural::sphere(Vec3::new(3.0, -1.0, 2.0), 5.0, 4).normalized(0.05);
    let radius = mesh
        .positions()
        .iter()
        .map(|p| p.length())
        .fold(0.0f32, f32::max);
    let dist = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
    let camera = Camera::paper_view(1, 96, 96);
    let m = render(&MeshScene(&dist), &camera, &settings(Mode::Mask, false, 0)).unwrap();
    let s = render(
        &Spheres::one(Vec3::ZERO, radius),
        &camera,
        &settings(Mode::Mask, false, 0),
    )
    .unwrap();
    let both = m
        .rgb
        .iter()
        .zip(&s.rgb)
        .filter(|(a, b)| **a == 255 && **b == 255)
        .count();
    let either = m
        .rgb
        .iter()
        .zip(&s.rgb)
        .filter(|(a, b)| **a == 255 || **b == 255)
        .count();
    let iou = both as f64 / either as f64;
    assert!(iou > 0.97, "IoU {iou}");
    assert_eq!(m.counters.normal_evals, 0);
}

#[test]
fn mesh_lambert_is_two_sided_and_close_to_the_analytic_shading() {
    let (mesh, _) = procedural::sphere(Vec3::ZERO, 1.0, 5).normalized(0.05);
    let radius = mesh
        .positions()
        .iter()
        .map(|p| p.length())
        .fold(0.0f32, f32::max);
    let dist = MeshDistance::new(&mesh, SignMode::Auto).unwrap();
    let camera = Camera::paper_view(0, 65, 65);
    let m = render(
        &MeshScene(&dist),
        &camera,
        &settings(Mode::Lambert, false, 0),
    )
    .unwrap();
    let s = render(
        &Spheres::one(Vec3::ZERO, radius),
        &camera,
        &settings(Mode::Lambert, false, 0),
    )
    .unwrap();
    assert_eq!(m.counters.normal_evals, m.counters.hits);
    // centre pixel: the facet normal is within a few degrees of +Z
    let c = (32 * 65 + 32) * 3;
    assert!((i32::from(m.rgb[c]) - i32::from(s.rgb[c])).abs() <= 6);

    // From inside the sphere the inner faces are seen: flipped normals, still lit.
    let inside = Camera::new(Vec3::ZERO, -Vec3::ONE, 60.0, 9, 9);
    let r = render(
        &MeshScene(&dist),
        &inside,
        &settings(Mode::Lambert, false, 0),
    )
    .unwrap();
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
    let lit = render(
        &MeshScene(&dist),
        &camera,
        &settings(Mode::Lambert, false, 0),
    )
    .unwrap();
    let dark = render(
        &MeshScene(&dist),
        &camera,
        &settings(Mode::Lambert, true, 0),
    )
    .unwrap();
    assert_eq!(lit.counters.shadow_rays, 0);
    assert!(dark.counters.shadow_rays > 0);
    let shadowed = lit.rgb.iter().zip(&dark.rgb).filter(|(a, b)| b < a).count();
    assert!(shadowed > 100, "{shadowed}");
    // the shadow falls on the side away from the light
    let shadow_dir = -light_dir();
    assert!(shadow_dir.x < 0.0 && shadow_dir.z < 0.0);
    let ao = render(
        &MeshScene(&dist),
        &camera,
        &settings(Mode::Lambert, false, 8),
    )
    .unwrap();
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
