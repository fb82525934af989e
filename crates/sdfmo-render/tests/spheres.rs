//! The renderer end to end on an analytic scene of spheres: planning through the counters,
//! thread-count independence, shading values, shadows, occlusion, depth, normals, file output.

mod common;
use common::{on_threads, settings, shot};

use std::path::PathBuf;

use glam::Vec3;
use sdfmo_render::shading::{light_dir, AMBIENT};
use sdfmo_render::{
    render, save_exr, save_png, Camera, Mode, RenderError, RenderPlan, RenderRequest,
    RenderSettings, Rendered, Spheres,
};

fn sphere() -> Spheres {
    Spheres::one(Vec3::ZERO, 0.8)
}

/// A small sphere between the light and a big one: the big one gets a shadow.
fn shadow_pair() -> Spheres {
    Spheres {
        spheres: vec![(Vec3::ZERO, 0.6), (light_dir() * 1.2, 0.25)],
    }
}

fn cam(size: u32) -> Camera {
    Camera::paper_view(0, size, size)
}

#[test]
fn every_mode_casts_one_primary_ray_per_pixel() {
    for mode in Mode::ALL {
        let r = shot(&sphere(), &cam(37), mode, false, 0);
        assert_eq!(r.counters.rays, 37 * 37);
        assert_eq!(r.rgb.len(), 37 * 37 * 3);
        assert!(r.counters.hits > 0 && r.counters.hits < r.counters.rays);
    }
}

#[test]
fn mask_and_depth_evaluate_no_normals_even_with_shadows_and_ao_asked() {
    for mode in [Mode::Mask, Mode::Depth] {
        let r = shot(&shadow_pair(), &cam(32), mode, true, 8);
        assert!(r.counters.hits > 0);
        assert_eq!(r.counters.normal_evals, 0, "{mode}");
        assert_eq!(r.counters.shadow_rays, 0, "{mode}");
        assert_eq!(r.counters.ao_rays, 0, "{mode}");
    }
}

#[test]
fn normal_mode_evaluates_one_normal_per_hit_and_nothing_else() {
    let r = shot(&shadow_pair(), &cam(32), Mode::Normal, true, 8);
    assert_eq!(r.counters.normal_evals, r.counters.hits);
    assert_eq!((r.counters.shadow_rays, r.counters.ao_rays), (0, 0));
}

#[test]
fn lambert_casts_secondary_rays_only_when_asked() {
    let scene = shadow_pair();
    let plain = shot(&scene, &cam(48), Mode::Lambert, false, 0);
    assert_eq!(plain.counters.normal_evals, plain.counters.hits);
    assert_eq!(plain.counters.shadow_rays, 0);
    assert_eq!(plain.counters.ao_rays, 0);

    let shadowed = shot(&scene, &cam(48), Mode::Lambert, true, 0);
    assert!(shadowed.counters.shadow_rays > 0);
    // only hits facing the light cast one
    assert!(shadowed.counters.shadow_rays < shadowed.counters.hits);
    assert_eq!(shadowed.counters.ao_rays, 0);

    let ao = shot(&scene, &cam(48), Mode::Lambert, false, 5);
    assert_eq!(ao.counters.ao_rays, 5 * ao.counters.hits);
    assert_eq!(ao.counters.shadow_rays, 0);
}

#[test]
fn image_and_counters_do_not_depend_on_the_thread_count() {
    let scene = shadow_pair();
    for mode in Mode::ALL {
        let s = settings(mode, true, 4);
        let one = on_threads(1, || render(&scene, &cam(70), &s).unwrap());
        for threads in [2, 4] {
            let other = on_threads(threads, || render(&scene, &cam(70), &s).unwrap());
            assert_eq!(one.rgb, other.rgb, "{mode} with {threads} threads");
            assert_eq!(one.depth, other.depth);
            assert_eq!(one.normals, other.normals);
            assert_eq!(one.counters, other.counters);
        }
        let global = render(&scene, &cam(70), &s).unwrap();
        assert_eq!(one.rgb, global.rgb);
    }
}

#[test]
fn tile_size_does_not_change_the_image() {
    let scene = shadow_pair();
    let s = settings(Mode::Lambert, true, 3);
    let plan = RenderPlan::new(&s).unwrap();
    let camera = cam(45);
    let a = RenderRequest::new(&scene, &camera, &s)
        .plan(plan)
        .render()
        .unwrap();
    let b = RenderRequest::new(&scene, &camera, &s)
        .plan(plan.with_tile_size(7))
        .render()
        .unwrap();
    assert_eq!(a.rgb, b.rgb);
    assert_eq!(a.counters, b.counters);
}

fn px(r: &Rendered, x: u32, y: u32) -> [u8; 3] {
    let i = ((y * r.width + x) * 3) as usize;
    [r.rgb[i], r.rgb[i + 1], r.rgb[i + 2]]
}

#[test]
fn lambert_centre_pixel_has_the_documented_value() {
    // Odd size: the centre ray points straight at the sphere centre, n = +Z,
    // value = 0.25 + 2/3 · (1/√3) = 0.6349 → 162.
    let r = render(&sphere(), &cam(33), &settings(Mode::Lambert, false, 0)).unwrap();
    assert_eq!(px(&r, 16, 16), [162; 3]);
    assert_eq!(px(&r, 0, 0), [0; 3], "background is black");
    // grey everywhere, at least ambient on the object
    for p in r.rgb.chunks(3) {
        assert!(p[0] == p[1] && p[1] == p[2]);
        assert!(p[0] == 0 || p[0] >= 64);
    }
}

#[test]
fn mask_is_white_on_black_and_matches_the_sphere_silhouette() {
    let r = shot(&sphere(), &cam(64), Mode::Mask, false, 0);
    let cam = cam(64);
    for y in 0..64 {
        for x in 0..64 {
            let (o, d) = cam.primary_ray(x, y);
            // distance of the ray's line from the centre vs the radius, away from the rim
            let dist = (o - d * o.dot(d)).length();
            let v = px(&r, x, y);
            if dist < 0.79 {
                assert_eq!(v, [255; 3]);
            } else if dist > 0.81 {
                assert_eq!(v, [0; 3]);
            }
        }
    }
}

#[test]
fn shadows_darken_to_ambient_where_the_small_sphere_blocks_the_light() {
    let scene = shadow_pair();
    let camera = Camera::new(light_dir() * 3.0, Vec3::ZERO, 40.0, 41, 41);
    let lit = shot(&scene, &camera, Mode::Lambert, false, 0);
    let dark = shot(&scene, &camera, Mode::Lambert, true, 0);
    // Seen from the light, the small sphere covers the centre; around it, the big sphere is in
    // its shadow: those pixels drop to the ambient value.
    let ambient = (AMBIENT * 255.0).round() as u8;
    let mut shadowed = 0;
    for i in 0..lit.rgb.len() {
        assert!(dark.rgb[i] <= lit.rgb[i], "shadows only darken");
        if dark.rgb[i] < lit.rgb[i] {
            assert_eq!(dark.rgb[i], ambient);
            shadowed += 1;
        }
    }
    // Viewed exactly from the light direction, the shadow hides behind the occluder: none.
    assert_eq!(shadowed, 0);
    // From the side, the shadow is visible.
    let side = Camera::new(Vec3::new(3.0, 0.5, 0.5), Vec3::ZERO, 50.0, 64, 64);
    let lit = shot(&scene, &side, Mode::Lambert, false, 0);
    let dark = shot(&scene, &side, Mode::Lambert, true, 0);
    let n = lit.rgb.iter().zip(&dark.rgb).filter(|(a, b)| b < a).count();
    assert!(n > 30, "only {n} shadowed channel values");
    for (a, b) in lit.rgb.iter().zip(&dark.rgb) {
        assert!(b <= a && (b == a || *b == ambient));
    }
}

#[test]
fn occlusion_leaves_a_convex_sphere_unchanged_and_darkens_a_contact() {
    let plain = shot(&sphere(), &cam(40), Mode::Lambert, false, 0);
    let ao = shot(&sphere(), &cam(40), Mode::Lambert, false, 8);
    assert!(ao.counters.ao_rays > 0);
    assert_eq!(plain.rgb, ao.rgb, "nothing occludes a lone convex sphere");

    // two touching spheres side by side: around the contact the ambient term drops
    let pair = Spheres {
        spheres: vec![
            (Vec3::new(-0.5, 0.0, 0.0), 0.5),
            (Vec3::new(0.5, 0.0, 0.0), 0.5),
        ],
    };
    let plain = shot(&pair, &cam(64), Mode::Lambert, false, 0);
    let ao = shot(&pair, &cam(64), Mode::Lambert, false, 16);
    let darker = plain.rgb.iter().zip(&ao.rgb).filter(|(a, b)| b < a).count();
    assert!(darker > 0);
    assert!(plain.rgb.iter().zip(&ao.rgb).all(|(a, b)| b <= a));
}

#[test]
fn depth_mode_keeps_distances_and_maps_them_to_grey() {
    let r = shot(&sphere(), &cam(33), Mode::Depth, false, 0);
    let depth = r.depth.as_ref().expect("depth kept in depth mode");
    assert!(r.normals.is_none());
    assert!(
        (depth[16 * 33 + 16] - 2.2).abs() < 1e-5,
        "{}",
        depth[16 * 33 + 16]
    );
    assert!(depth[0].is_infinite());
    // nearer is brighter; hits are never black
    let centre = px(&r, 16, 16)[0];
    let rim = px(&r, 16, 10)[0];
    assert!(depth[10 * 33 + 16] > 2.2 && rim < centre && rim > 0);
}

#[test]
fn normal_mode_keeps_unit_viewer_facing_normals() {
    let camera = cam(31);
    let r = shot(&sphere(), &camera, Mode::Normal, false, 0);
    let normals = r.normals.as_ref().expect("normals kept in normal mode");
    assert!(r.depth.is_none());
    for y in 0..31 {
        for x in 0..31 {
            let n = normals[(y * 31 + x) as usize];
            let (_, d) = camera.primary_ray(x, y);
            if px(&r, x, y) == [0; 3] {
                assert_eq!(n, Vec3::ZERO);
            } else {
                assert!((n.length() - 1.0).abs() < 1e-5 && n.dot(d) <= 0.0);
            }
        }
    }
    assert_eq!(px(&r, 15, 15), [128, 128, 255]);
}

#[test]
fn inside_a_sphere_normals_flip_toward_the_viewer() {
    // The camera inside a big sphere sees its inner side: two-sided shading lights it.
    let scene = Spheres::one(Vec3::ZERO, 10.0);
    let camera = Camera::new(Vec3::ZERO, -Vec3::ONE, 60.0, 9, 9);
    let r = render(&scene, &camera, &settings(Mode::Lambert, false, 0)).unwrap();
    assert_eq!(r.counters.hits, 81);
    // looking toward −(1,1,1): the inner wall's viewer-facing normal is +(1,1,1)/√3 = the light
    assert_eq!(px(&r, 4, 4), [234; 3]);
}

#[test]
fn invalid_input_is_an_error_not_a_panic() {
    let bad = Camera { width: 0, ..cam(8) };
    assert!(matches!(
        render(&sphere(), &bad, &RenderSettings::default()),
        Err(RenderError::InvalidCamera(_))
    ));
    assert!(matches!(
        render(&sphere(), &cam(8), &settings(Mode::Lambert, false, 2000)),
        Err(RenderError::InvalidSettings(_))
    ));
}

fn out_dir() -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("sdfmo-render-tests");
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn png_round_trips_exactly() {
    let r = shot(&shadow_pair(), &cam(29), Mode::Lambert, true, 2);
    // Its own folder: the leftover count below must not see another test's temporaries (the
    // EXR test writes beside out_dir() at the same time; this failed once in a workspace run).
    let dir = out_dir().join("png-round-trip");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("lambert.png");
    save_png(&r, &path).unwrap();
    let back = image::open(&path).unwrap().into_rgb8();
    assert_eq!(back.dimensions(), (29, 29));
    assert_eq!(back.into_raw(), r.rgb);
    assert_eq!(r.to_image().into_raw(), r.rgb);
    // no temporary file left behind
    let leftovers = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".tmp")
        })
        .count();
    assert_eq!(leftovers, 0);
    // a missing directory is an error
    assert!(save_png(&r, out_dir().join("missing/dir/x.png")).is_err());
    // a buffer that does not match the size is an error
    let broken = Rendered {
        rgb: vec![0; 5],
        ..r
    };
    assert!(matches!(
        save_png(&broken, &path),
        Err(RenderError::BufferSize { .. })
    ));
}

#[test]
fn exr_holds_f32_depth_and_normals() {
    use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};
    let camera = cam(17);
    for mode in [Mode::Depth, Mode::Normal] {
        let r = shot(&sphere(), &camera, mode, false, 0);
        let path = out_dir().join(format!("{mode}.exr"));
        save_exr(&r, &path).unwrap();
        let img = read_all_flat_layers_from_file(&path).unwrap();
        let layer = &img.layer_data[0];
        assert_eq!((layer.size.0, layer.size.1), (17, 17));
        let channel = |name: &str| -> Vec<f32> {
            let c = layer
                .channel_data
                .list
                .iter()
                .find(|c| c.name.to_string() == name)
                .unwrap_or_else(|| panic!("channel {name} missing in {mode}"));
            match &c.sample_data {
                FlatSamples::F32(v) => v.clone(),
                other => panic!("channel {name} is not f32: {other:?}"),
            }
        };
        let red = channel("R");
        assert_eq!(red[8 * 17 + 8], f32::from(r.rgb[(8 * 17 + 8) * 3]) / 255.0);
        if mode == Mode::Depth {
            assert_eq!(&channel("Z"), r.depth.as_ref().unwrap());
        } else {
            let n = r.normals.as_ref().unwrap();
            let (x, y, z) = (channel("N.X"), channel("N.Y"), channel("N.Z"));
            for i in 0..n.len() {
                assert_eq!(Vec3::new(x[i], y[i], z[i]), n[i]);
            }
        }
    }
}

#[test]
fn a_cancelled_render_stops_and_says_so() {
    // Issue 32: the Python package's `render` ignored Ctrl-C until the whole image was done;
    // `RenderRequest::cancel` asks before each tile.
    use sdfmo_render::plan::DEFAULT_TILE_SIZE;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let scene = Spheres::one(Vec3::ZERO, 0.5);
    let camera = Camera::paper_view(0, 256, 256);
    let settings = RenderSettings::new(Mode::Lambert);
    let whole = render(&scene, &camera, &settings).unwrap();
    let never = RenderRequest::new(&scene, &camera, &settings)
        .cancel(&|| false)
        .render()
        .unwrap();
    assert_eq!(never.rgb, whole.rgb);
    assert_eq!(never.counters, whole.counters);
    let asked = AtomicUsize::new(0);
    let after_three = || asked.fetch_add(1, Ordering::Relaxed) >= 3;
    let e = RenderRequest::new(&scene, &camera, &settings)
        .cancel(&after_three)
        .render()
        .unwrap_err();
    assert!(matches!(e, RenderError::Cancelled), "{e}");
    // Once it said stop, the other tiles are skipped without asking again.
    let tiles = 256usize.div_ceil(DEFAULT_TILE_SIZE as usize).pow(2);
    assert!(
        asked.load(Ordering::Relaxed) < tiles,
        "{}",
        asked.load(Ordering::Relaxed)
    );
}
