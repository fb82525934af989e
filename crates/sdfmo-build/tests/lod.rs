//! Levels of detail end to end: `BuildRequest::levels` against separate builds, the file's prefixes
//! against the whole file, and the per-ray level choice against fixed levels (images).

use sdfmo_build::{build, BuildError, BuildRequest, BuildSettings, BuildStats, Method};
use sdfmo_format::{LodOctree, PackedOctree, SmoFile};
use sdfmo_render::{render, Camera, LodScene, OctreeScene, RenderSettings};
use sdfmo_trace::{pixel_angle, LevelChoice};

const MULTI: Method = Method::Multi { max_voxels: 8 };

/// Levels `coarsest..=depth` of `mesh`.
fn levels(
    mesh: &sdfmo_mesh::TriMesh,
    depth: u8,
    coarsest: u8,
    method: Method,
) -> Result<(LodOctree, Vec<BuildStats>), BuildError> {
    BuildRequest::new(mesh, BuildSettings::new(depth, method)).levels(coarsest)
}

/// Asserts that every level of `lod` is, byte for byte, the octree a build of `mesh` to that
/// depth alone writes; the separate builds' statistics, coarsest level first.
fn assert_levels_are_builds(
    mesh: &sdfmo_mesh::TriMesh,
    lod: &LodOctree,
    method: Method,
) -> Vec<BuildStats> {
    (lod.coarsest()..=lod.depth())
        .map(|k| {
            let (alone, stats) = build(mesh, &BuildSettings::new(k, method)).expect("build");
            let level = lod.level(k).unwrap();
            assert_eq!(level.as_bytes(), alone.as_bytes(), "level {k}");
            stats
        })
        .collect()
}

/// Level k of a file with levels is, byte for byte, the file a build of depth k writes (so it
/// renders exactly as that build does), for both methods.
#[test]
fn every_level_is_the_build_of_its_depth() {
    let mesh = sdfmo_mesh::procedural::demo_part();
    for method in [Method::Svo, MULTI] {
        let (lod, stats) = levels(&mesh, 6, 3, method).expect("lod");
        assert_eq!((lod.coarsest(), lod.depth()), (3, 6));
        let alone = assert_levels_are_builds(&mesh, &lod, method);
        let voxels = |s: &[BuildStats]| s.iter().map(|s| s.voxels).collect::<Vec<_>>();
        assert_eq!(voxels(&stats), voxels(&alone));
    }
}

/// The same on a shared CAD part that is not watertight (abc1: the hybrid pseudo-normal /
/// winding-number sign, whose per-triangle data each level makes for its own snapped mesh),
/// with the levels sharing one normalised mesh; progress moves through every level and ends at
/// 1, and a cancellation asked during a later level stops the whole build.
#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn every_level_is_the_build_of_its_depth_on_abc1() {
    let path = std::path::PathBuf::from(env!("SDFMO_TEST_DATA_DIR")).join("abc1.stl");
    let mesh = sdfmo_mesh::load_mesh(&path).expect("abc1").mesh;
    let request = || BuildRequest::new(&mesh, BuildSettings::new(6, MULTI));
    let seen = std::sync::Mutex::new(Vec::new());
    let record = |f: f32| seen.lock().unwrap().push(f);
    let (lod, _) = request().progress(&record).levels(4).expect("lod");
    assert_eq!((lod.coarsest(), lod.depth()), (4, 6));
    assert_levels_are_builds(&mesh, &lod, MULTI);
    let seen = seen.into_inner().unwrap();
    assert!(seen.windows(2).all(|w| w[0] <= w[1]), "{seen:?}");
    assert_eq!(seen.last(), Some(&1.0));
    // Level 4 weighs 1/21 of the whole, level 5 4/21: values inside each level's span.
    for (lo, hi) in [
        (0.0, 1.0 / 21.0),
        (1.0 / 21.0, 5.0 / 21.0),
        (5.0 / 21.0, 1.0),
    ] {
        let inside = seen.iter().filter(|&&f| f > lo && f < hi).count();
        assert!(inside >= 3, "{inside} reports in ({lo}, {hi}): {seen:?}");
    }
    // Cancelled once progress has passed the first level: the build stops, nothing returned.
    let last = std::sync::atomic::AtomicU32::new(0);
    let store = |f: f32| last.store(f.to_bits(), std::sync::atomic::Ordering::Relaxed);
    let past_first = || f32::from_bits(last.load(std::sync::atomic::Ordering::Relaxed)) > 0.1;
    let r = request().progress(&store).cancel(&past_first).levels(4);
    assert!(matches!(r, Err(BuildError::Cancelled)), "{r:?}");
    assert!(f32::from_bits(last.load(std::sync::atomic::Ordering::Relaxed)) < 0.5);
}

#[test]
fn level_settings_are_checked() {
    let mesh = sdfmo_mesh::procedural::demo_part();
    for (depth, coarsest) in [(5, 6), (5, 0)] {
        let r = levels(&mesh, depth, coarsest, MULTI);
        assert!(
            matches!(r, Err(BuildError::InvalidLevels { .. })),
            "{depth} {coarsest}"
        );
    }
    // The leaf level alone is a file of one level.
    let (one, _) = levels(&mesh, 5, 5, MULTI).unwrap();
    assert_eq!(one.levels().len(), 1);
}

/// Every level-boundary prefix of the file loads and renders the image of that level of the
/// whole file; a cut inside a level renders the level before.
#[test]
fn prefixes_render_their_levels() {
    let mesh = sdfmo_mesh::procedural::demo_part();
    let (lod, _) = levels(&mesh, 6, 3, MULTI).unwrap();
    let bytes = lod.to_bytes();
    let SmoFile::Levels(whole) = SmoFile::from_bytes(&bytes).unwrap() else {
        panic!("read as 1.x")
    };
    assert_eq!(whole, lod);
    let cam = Camera::paper_view(1, 96, 96);
    let settings = RenderSettings::default();
    let image = |o: &PackedOctree| render(&OctreeScene(o), &cam, &settings).unwrap().rgb;
    for (i, e) in lod.entries().iter().enumerate() {
        let p = LodOctree::from_prefix(&bytes[..e.end() as usize]).unwrap();
        assert_eq!(p.octree.levels().len(), i + 1);
        let loaded = p.octree.level(e.level).unwrap();
        assert_eq!(
            image(loaded),
            image(lod.level(e.level).unwrap()),
            "level {}",
            e.level
        );
        if i > 0 {
            let cut = LodOctree::from_prefix(&bytes[..(e.offset + e.size / 2) as usize]).unwrap();
            assert_eq!(cut.octree.depth(), e.level - 1);
        }
    }
}

/// The screen-space choice: an error budget no voxel meets draws the finest level everywhere,
/// one every voxel meets draws the coarsest, and a budget in between mixes levels by distance.
#[test]
fn pixel_error_picks_levels_by_distance() {
    let mesh = sdfmo_mesh::procedural::demo_part();
    let (lod, _) = levels(&mesh, 6, 3, MULTI).unwrap();
    let cam = Camera::paper_view(0, 96, 96);
    let settings = RenderSettings::default();
    let pa = pixel_angle(cam.fov_y_deg, cam.height);
    let with = |pixels: f32| {
        let scene = LodScene {
            lod: &lod,
            choice: LevelChoice::PixelError {
                pixels,
                pixel_angle: pa,
            },
        };
        render(&scene, &cam, &settings).unwrap().rgb
    };
    let fixed = |k: u8| {
        render(&OctreeScene(lod.level(k).unwrap()), &cam, &settings)
            .unwrap()
            .rgb
    };
    assert_eq!(with(1e-6), fixed(6));
    assert_eq!(with(1e6), fixed(3));
    let mid = with(2.0);
    assert_ne!(mid, fixed(3));
}
