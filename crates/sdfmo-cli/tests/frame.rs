//! One coordinate frame in every front-end: the command line takes points and cameras in model
//! units, as the library (the facade) and Python do, and gives the same numbers and images.
//! (Python's side is `crates/sdfmo-py/tests/test_frame.py`, against this binary.)

mod common;

use std::path::{Path, PathBuf};

use sdf_multioctree::distance::{MeshDistance, SignMode};
use sdf_multioctree::glam::{DVec3, Vec3};
use sdf_multioctree::mesh::{procedural::box_mesh, write::to_obj};
use sdf_multioctree::DEFAULT_MARGIN;
use sdf_multioctree::{camera_from_model, file_frame, load_mesh, load_octree, mesh_frame};
use sdf_multioctree::{Camera, Device, LevelRequest, Mode, RenderSettings, Renderer};

use common::ok as run;
use common::temp_dir;

/// A box far from the origin with a non-trivial scale (model units [10, 14] × [−3, −1] × [5, 6]),
/// so that a front-end that skipped the conversion would answer differently.
fn box_obj(dir: &Path) -> PathBuf {
    let obj = to_obj(&box_mesh(
        Vec3::new(10.0, -3.0, 5.0),
        Vec3::new(14.0, -1.0, 6.0),
    ));
    let p = dir.join("box.obj");
    std::fs::write(&p, obj).unwrap();
    p
}

macro_rules! os {
    ($($arg:expr),* $(,)?) => {
        &[$(std::ffi::OsStr::new(&$arg)),*]
    };
}

#[test]
fn distance_in_model_units_is_the_librarys() {
    let dir = temp_dir("frame-distance");
    let obj = box_obj(dir.path());
    let points = [
        [12.0, -2.0, 5.5],
        [12.0, 0.25, 5.5],
        [9.1, -2.5, 5.25],
        [13.99, -1.01, 5.999],
        [30.0, 10.0, -7.5],
    ];
    let text: String = points
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect();
    std::fs::write(dir.path().join("p.xyz"), text).unwrap();
    let out = run(os!["distance", obj, "--points", dir.path().join("p.xyz")]);
    let cli: Vec<f32> = out.split_whitespace().map(|x| x.parse().unwrap()).collect();

    // The library: the mesh's frame, the queries in the normalised frame, lengths back.
    let mesh = load_mesh(&obj).unwrap();
    let frame = mesh_frame(&mesh);
    let dist = MeshDistance::new(&mesh.normalized(DEFAULT_MARGIN).0, SignMode::Auto).unwrap();
    let q: Vec<Vec3> = points
        .iter()
        .map(|p| frame.point_to_normalized(DVec3::from_array(*p)))
        .collect();
    let lib: Vec<f32> = dist
        .signed_distances(&q)
        .iter()
        .map(|&d| frame.length_to_model(d))
        .collect();
    assert_eq!(cli, lib);
    // And the numbers are model units: the centre is 0.5 inside (the box is 1 unit thick in z),
    // the point above the top face 1.25 outside.
    assert!((cli[0] + 0.5).abs() < 1e-5, "{cli:?}");
    assert!((cli[1] - 1.25).abs() < 1e-5, "{cli:?}");
}

/// The RGB bytes of a PNG the CLI wrote.
fn png_rgb(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().to_rgb8().into_raw()
}

#[test]
fn an_eye_in_model_units_gives_the_librarys_image() {
    let dir = temp_dir("frame-render");
    let obj = box_obj(dir.path());
    let smo = dir.path().join("box.smo");
    run(os!["build", obj, "-d", "5", "-o", smo]);
    let (eye, target) = ([19.0f32, 2.0, 12.0], [12.0f32, -2.0, 5.5]);
    let cam_args = [
        format!("--eye={},{},{}", eye[0], eye[1], eye[2]),
        format!("--target={},{},{}", target[0], target[1], target[2]),
    ];
    let octree_png = dir.path().join("octree.png");
    let mesh_png = dir.path().join("mesh.png");
    for (cmd, input, png) in [
        ("render", &smo, &octree_png),
        ("render-mesh", &obj, &mesh_png),
    ] {
        run(os![
            cmd,
            input,
            cam_args[0],
            cam_args[1],
            "--size=48x32",
            "-o",
            png
        ]);
    }

    let mut camera = Camera::paper_view(0, 48, 32);
    camera.eye = Vec3::from_array(eye);
    camera.target = Vec3::from_array(target);
    let file = load_octree(&smo).unwrap().file;
    let lambert = RenderSettings::new(Mode::Lambert);
    let mut renderer = Renderer::new(Device::Cpu).unwrap();
    let image = renderer
        .prepare(&file, LevelRequest::Finest)
        .and_then(|mut p| p.render(&camera_from_model(&file_frame(&file), &camera), &lambert))
        .unwrap();
    assert!(
        image.counters.hits > 30,
        "the box is in view: {:?}",
        image.counters
    );
    assert_eq!(png_rgb(&octree_png), image.rgb);
    let mesh = load_mesh(&obj).unwrap();
    let image = renderer
        .prepare_mesh(&mesh)
        .and_then(|mut p| p.render(&camera_from_model(&mesh_frame(&mesh), &camera), &lambert))
        .unwrap();
    assert_eq!(png_rgb(&mesh_png), image.rgb);

    // The same camera given in the normalised frame draws the same image.
    let frame = file_frame(&file);
    let n = |p: [f32; 3]| frame.point_to_normalized(Vec3::from_array(p).as_dvec3());
    let (ne, nt) = (n(eye), n(target));
    let normalized_png = dir.path().join("normalized.png");
    run(os![
        "render",
        smo,
        format!("--eye={},{},{}", ne.x, ne.y, ne.z),
        format!("--target={},{},{}", nt.x, nt.y, nt.z),
        "--normalized",
        "--size=48x32",
        "-o",
        normalized_png
    ]);
    assert_eq!(png_rgb(&normalized_png), png_rgb(&octree_png));
}
