//! The facade's one render entry on both devices: `Renderer` on the GPU draws what it draws on
//! the CPU (the same camera, settings, level request and image type), for a whole file with
//! levels and for a prefix of it cut where a level ends, by level and by pixel error.
//!
//! The kernels agree to a few ulps of the hit distance, not bit for bit
//! (`crates/sdfmo-gpu/tests/match_cpu.rs` holds them to tight per-pixel tolerances); here the
//! images are held to what a user sees: masks identical but for a few pixels, depth greys
//! within one level, shaded pixels within 4 levels but for 5 % of the hits (a hit on a sharp
//! edge, where either face's normal is right, may take either). Without an adapter the test
//! prints why and passes, unless `SDFMO_REQUIRE_GPU=1`.
#![cfg(feature = "gpu")]

use sdf_multioctree::gpu::GpuError;
use sdf_multioctree::render::{RenderError, RenderSettings};
use sdf_multioctree::{
    demo_mesh, load_octree, paper_views, BuildRequest, BuildSettings, Device, Error, LevelRequest,
    Method, Mode, Rendered, Renderer,
};

/// The GPU renderer, or `None` (with a message) when there is no adapter and none is required.
fn gpu() -> Option<Renderer> {
    match Renderer::new(Device::Gpu) {
        Ok(r) => Some(r),
        Err(e) if std::env::var("SDFMO_REQUIRE_GPU").as_deref() == Ok("1") => {
            panic!("SDFMO_REQUIRE_GPU=1 but no GPU renderer: {e}")
        }
        Err(e) => {
            eprintln!("skipped: no GPU adapter ({e}); set SDFMO_REQUIRE_GPU=1 to fail instead");
            None
        }
    }
}

/// Holds the GPU's image of `mode` to the CPU's (see the module docs).
fn agree(cpu: &Rendered, gpu: &Rendered, mode: Mode, label: &str) {
    assert_eq!((cpu.width, cpu.height), (gpu.width, gpu.height), "{label}");
    assert_eq!(cpu.counters.rays, gpu.counters.rays, "{label}");
    assert!(
        cpu.kernel_ms.is_none() && gpu.kernel_ms.is_some(),
        "{label}"
    );
    let pixels = cpu.rgb.len() / 3;
    let hit = |rgb: &[u8]| rgb.iter().any(|&c| c != 0);
    let (mut mask_diffs, mut worst, mut shaded_off) = (0usize, 0u8, 0usize);
    for (c, g) in cpu.rgb.chunks_exact(3).zip(gpu.rgb.chunks_exact(3)) {
        if hit(c) != hit(g) {
            mask_diffs += 1;
            continue;
        }
        let off = c
            .iter()
            .zip(g)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        worst = worst.max(off);
        shaded_off += usize::from(off > 4);
    }
    assert!(
        mask_diffs * 500 <= pixels,
        "{label}: {mask_diffs} of {pixels} pixels hit on one device only"
    );
    let hits = cpu.counters.hits.abs_diff(gpu.counters.hits) as usize;
    assert!(hits <= mask_diffs, "{label}: hits {cpu:?} vs {gpu:?}");
    match mode {
        Mode::Mask => assert_eq!(worst, 0, "{label}"),
        Mode::Depth => assert!(worst <= 1, "{label}: a depth grey differs by {worst}"),
        _ => assert!(
            shaded_off as u64 * 20 <= cpu.counters.hits,
            "{label}: {shaded_off} pixels off by more than 4 of {} hits",
            cpu.counters.hits
        ),
    }
    assert!(cpu.counters.hits > 100, "{label}: the comparison is empty");
}

#[test]
fn gpu_renders_levels_and_prefixes_as_the_cpu_does() {
    let Some(mut gpu) = gpu() else { return };
    assert_eq!(gpu.device(), Device::Gpu);
    let settings = BuildSettings::new(6, Method::default());
    let (lod, _) = BuildRequest::new(&demo_mesh(), settings).levels(3).unwrap();
    let bytes = lod.to_bytes();
    let dir = std::env::temp_dir().join(format!("sdfmo-facade-gpu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut cpu = Renderer::new(Device::Cpu).unwrap();
    let cameras = &paper_views(96)[..2];
    // The whole file (levels 3..=6) and the prefix that ends with level 5.
    for end_level in [6, 5] {
        let entries = lod.entries();
        let entry = entries.iter().find(|e| e.level == end_level).unwrap();
        let path = dir.join(format!("to{end_level}.smo"));
        std::fs::write(&path, &bytes[..entry.end() as usize]).unwrap();
        let data = load_octree(&path).unwrap();
        assert_eq!(data.held(), (3, end_level));
        for request in [
            LevelRequest::Finest,
            LevelRequest::Level(4),
            LevelRequest::PixelError(1.0),
            LevelRequest::PixelError(3.0),
        ] {
            let mut on_cpu = cpu.prepare(&data.file, request).unwrap();
            let mut on_gpu = gpu.prepare(&data.file, request).unwrap();
            for (view, camera) in cameras.iter().enumerate() {
                for mode in Mode::ALL {
                    let s = RenderSettings::new(mode);
                    let c = on_cpu.render(camera, &s).unwrap();
                    let g = on_gpu.render(camera, &s).unwrap();
                    let label = format!("to level {end_level}, {request:?}, view {view}, {mode}");
                    agree(&c, &g, mode, &label);
                    // The image keeps what the plan keeps, on either device.
                    assert_eq!(g.depth.is_some(), mode == Mode::Depth, "{label}");
                    assert_eq!(g.normals.is_some(), mode == Mode::Normal, "{label}");
                }
            }
        }
        // What the data does not hold is refused on the GPU as on the CPU, naming the levels.
        for device in [&mut cpu, &mut gpu] {
            let e = device
                .prepare(&data.file, LevelRequest::Level(7))
                .unwrap_err();
            assert!(
                matches!(e, Error::Render(RenderError::LevelNotHeld { level: 7, .. })),
                "{e}"
            );
        }
    }
    // Shadows are a CPU setting: a typed error on the GPU.
    let data = load_octree(dir.join("to6.smo")).unwrap();
    let shadows = RenderSettings::new(Mode::Lambert).with_shadows(true);
    let e = gpu
        .prepare(&data.file, LevelRequest::Finest)
        .unwrap()
        .render(&cameras[0], &shadows)
        .unwrap_err();
    assert!(
        matches!(
            e,
            Error::Gpu(GpuError::Render(RenderError::InvalidSettings(_)))
        ),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 34: a 3.0 brick file (`SmoFile::Bricks`) prepared for renders draws on each device exactly what
/// its 1.x octree draws there, traced in place on both: on the GPU from the bytes as uploaded,
/// on the CPU from the same bytes in memory (the same colours and depths, bit for bit).
#[test]
fn bricks_render_as_their_octree_on_both_devices() {
    use sdf_multioctree::format::BrickOctree;
    use sdf_multioctree::SmoFile;
    let settings = BuildSettings::new(6, Method::Multi { max_voxels: 8 });
    let (octree, _) = BuildRequest::new(&demo_mesh(), settings)
        .octree()
        .expect("build");
    let bricks = SmoFile::Bricks(BrickOctree::encode(&octree).expect("encode 3.0"));
    let file = SmoFile::Octree(octree);
    let mut renderers = vec![Renderer::new(Device::Cpu).unwrap()];
    renderers.extend(gpu());
    for r in &mut renderers {
        let device = r.device();
        for (view, cam) in paper_views(64).iter().enumerate() {
            for mode in [Mode::Lambert, Mode::Depth] {
                let settings = RenderSettings::new(mode);
                let a = r
                    .prepare(&file, LevelRequest::Finest)
                    .and_then(|mut p| p.render(cam, &settings))
                    .expect("1.x");
                let b = r
                    .prepare(&bricks, LevelRequest::Finest)
                    .and_then(|mut p| p.render(cam, &settings))
                    .expect("3.0");
                let label = format!("{device:?} view {view} {mode:?}");
                assert!(a.counters.hits > 100, "{label}");
                assert!(a.rgb == b.rgb, "{label}: colours differ");
                let bits = |r: &Rendered| {
                    r.depth
                        .as_ref()
                        .map(|d| d.iter().map(|t| t.to_bits()).collect::<Vec<_>>())
                };
                assert!(bits(&a) == bits(&b), "{label}: depths differ");
            }
        }
    }
}
