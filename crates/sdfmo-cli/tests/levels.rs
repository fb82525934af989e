//! Levels of detail in `sdfmo render` (issue 37): a file with levels, whole or cut where a
//! level ends, draws the levels it holds, with the facade's images (`load_octree`,
//! `Renderer`: the same `LevelRequest` rule); a cut inside a level, a level not held and a
//! pixel error without levels are one-line errors. (Python's side is
//! `crates/sdfmo-py/tests/test_levels.py`, against this binary.)

mod common;

use std::path::Path;

use sdf_multioctree::format::LodOctree;
use sdf_multioctree::render::encode_png;
use sdf_multioctree::{load_octree, Camera, Device, LevelRequest, Mode, Vec3};
use sdf_multioctree::{RenderSettings, Renderer};
use serde_json::Value;

use common::{refused, sdfmo, stderr, succeeded, temp_dir};

/// `sdfmo render FILE ARGS --size 40x32 -o PNG --json`: the JSON, stderr and the PNG's bytes.
fn render(file: &Path, png: &Path, args: &[&str]) -> (Value, String, Vec<u8>) {
    let (file, out) = (file.display().to_string(), png.display().to_string());
    let all = [
        &["render", &file, "--size", "40x32", "-o", &out, "--json"],
        args,
    ]
    .concat();
    let o = sdfmo(&all);
    succeeded(&o, &format!("{all:?}"));
    let json = serde_json::from_slice(&o.stdout).unwrap();
    (json, stderr(&o), std::fs::read(png).unwrap())
}

/// The facade's PNG of `file` for `camera` and `request` (what the CLI must write).
fn facade_png(file: &Path, camera: &Camera, mode: Mode, request: LevelRequest) -> Vec<u8> {
    let data = load_octree(file).unwrap();
    let image = Renderer::new(Device::Cpu)
        .unwrap()
        .prepare(&data.file, request)
        .unwrap()
        .render(camera, &RenderSettings::new(mode))
        .unwrap();
    encode_png(&image, Path::new("x.png")).unwrap()
}

fn list(levels: std::ops::RangeInclusive<u8>) -> Value {
    levels.collect::<Vec<_>>().into()
}

/// Levels 4..=6 of the demo part; each prefix cut where a level ends draws its finest level by
/// default, each level it holds with `--lod`, and by `--pixel-error` among them, every image
/// the facade's byte for byte; the note on stderr names the missing levels.
#[test]
fn every_level_boundary_prefix_renders_the_levels_it_holds() {
    let dir = temp_dir("levels");
    let whole = dir.path().join("lod.smo");
    let o = sdfmo(&[
        "build",
        "-d",
        "6",
        "--lod",
        "--coarsest",
        "4",
        "-o",
        &whole.display().to_string(),
    ]);
    succeeded(&o, "build --lod");
    let bytes = std::fs::read(&whole).unwrap();
    let entries = LodOctree::from_bytes(&bytes).unwrap().entries();
    assert_eq!(entries.len(), 3);
    let png = dir.path().join("out.png");
    let paper = Camera::paper_view(0, 40, 32);
    let near = Camera {
        eye: Vec3::new(0.0, 0.0, 5.0),
        ..paper
    };
    for e in &entries {
        let finest = e.level;
        let cut = dir.path().join(format!("cut{finest}.smo"));
        std::fs::write(&cut, &bytes[..e.end() as usize]).unwrap();
        let name = cut.display().to_string();

        let (json, err, image) = render(&cut, &png, &["--mode", "normal"]);
        let levels = json["levels"].clone();
        assert_eq!(levels["file"], list(4..=6), "{json}");
        assert_eq!(levels["held"], list(4..=finest));
        assert_eq!(levels["drawn"], list(finest..=finest));
        let note = match finest {
            6 => String::new(),
            4 => format!("note: {name} holds level 4 of 4-6 (a prefix); drawing level 4\n"),
            _ => format!(
                "note: {name} holds levels 4-{finest} of 4-6 (a prefix); drawing level {finest}\n"
            ),
        };
        assert_eq!(err, note);
        let want = facade_png(&cut, &paper, Mode::Normal, LevelRequest::Finest);
        assert_eq!(image, want, "prefix to level {finest}: default");

        for k in 4..=finest {
            let (json, _, image) = render(&cut, &png, &["--lod", &k.to_string()]);
            assert_eq!(json["levels"]["drawn"], list(k..=k));
            let want = facade_png(&cut, &paper, Mode::Lambert, LevelRequest::Level(k));
            assert_eq!(image, want, "prefix to level {finest}: --lod {k}");
        }

        let args = [
            "--pixel-error",
            "1",
            "--eye=0,0,5",
            "--normalized",
            "--mode",
            "depth",
        ];
        let (json, err, image) = render(&cut, &png, &args);
        let want = facade_png(&cut, &near, Mode::Depth, LevelRequest::PixelError(1.0));
        assert_eq!(image, want, "prefix to level {finest}: --pixel-error");
        let drawn: Vec<u64> = json["levels"]["drawn"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect();
        assert!(!drawn.is_empty() && drawn.iter().all(|&k| (4..=u64::from(finest)).contains(&k)));
        if finest < 6 {
            assert!(err.contains("by the pixel error"), "{err}");
            let missing = (finest + 1).to_string();
            refused(
                &sdfmo(&["render", &name, "--lod", &missing, "-o", "x.png"]),
                &format!("level {missing} is not in the data: it holds level"),
                "a level the prefix does not hold",
            );
            // Cut 9 bytes further: inside the next level (levels start 8-byte aligned).
            std::fs::write(&cut, &bytes[..e.end() as usize + 9]).unwrap();
            refused(
                &sdfmo(&["render", &name, "-o", "x.png"]),
                &format!("end inside level {missing}"),
                "a cut inside a level",
            );
        }
    }
}

/// A file without levels has one, its depth: `--lod` of it draws it, another level and a pixel
/// error are refused; `render-mesh` has no levels (`null`).
#[test]
fn a_file_without_levels_has_its_depth_only() {
    let dir = temp_dir("levels-flat");
    let smo = dir.path().join("flat.smo");
    let o = sdfmo(&["build", "-d", "5", "-o", &smo.display().to_string()]);
    succeeded(&o, "build");
    let png = dir.path().join("flat.png");
    let (json, err, image) = render(&smo, &png, &["--lod", "5"]);
    assert_eq!(err, "");
    assert_eq!(json["levels"]["held"], list(5..=5));
    assert_eq!(json["levels"]["file"], list(5..=5));
    assert_eq!(json["levels"]["drawn"], list(5..=5));
    let paper = Camera::paper_view(0, 40, 32);
    assert_eq!(
        image,
        facade_png(&smo, &paper, Mode::Lambert, LevelRequest::Level(5))
    );
    let name = smo.display().to_string();
    refused(
        &sdfmo(&["render", &name, "--lod", "4", "-o", "x.png"]),
        "level 4 is not in the data: it holds level 5 only",
        "--lod of another level",
    );
    refused(
        &sdfmo(&["render", &name, "--pixel-error", "1", "-o", "x.png"]),
        "has no levels of detail",
        "--pixel-error without levels",
    );
    let o = sdfmo(&[
        "render-mesh",
        "--size",
        "8",
        "-o",
        &png.display().to_string(),
        "--json",
    ]);
    succeeded(&o, "render-mesh");
    let json: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(json["levels"].is_null(), "{json}");
}

/// Levels 3..=5 of the demo part as format 4.0 (`--format 3`): each prefix cut where a level
/// ends renders that level as a separate build of its depth renders, byte for byte, on its own
/// and through `--lod`; `info` describes the blocks; a coarsest level below 2 is refused.
#[test]
fn brick_level_prefixes_render_their_levels() {
    let dir = temp_dir("levels4");
    let whole = dir.path().join("lod4.smo");
    let w = whole.display().to_string();
    let o = sdfmo(&[
        "build",
        "-d",
        "5",
        "--lod",
        "--coarsest",
        "3",
        "--format",
        "3",
        "-o",
        &w,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&whole).unwrap();
    assert!(sdf_multioctree::format::is_brick_levels(&bytes));
    let o = sdfmo(&["info", &w, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let info: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(info["version"], "4.1 (levels of bricks)");
    let levels = info["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 3);
    assert!(
        levels.iter().all(|l| l["bricks"].as_u64().unwrap() > 0),
        "{info}"
    );
    let png = dir.path().join("out.png");
    for l in levels {
        let k = l["level"].as_u64().unwrap().to_string();
        let end = (l["offset"].as_u64().unwrap() + l["bytes"].as_u64().unwrap()) as usize;
        let cut = dir.path().join(format!("cut{k}.smo"));
        std::fs::write(&cut, &bytes[..end]).unwrap();
        let single = dir.path().join(format!("d{k}.smo"));
        let s = single.display().to_string();
        assert!(sdfmo(&["build", "-d", &k, "-o", &s]).status.success());
        let (_, _, want) = render(&single, &png, &[]);
        let (json, _, image) = render(&cut, &png, &[]);
        assert_eq!(
            json["levels"]["drawn"],
            list(k.parse().unwrap()..=k.parse().unwrap())
        );
        assert_eq!(image, want, "prefix to level {k}");
        let (_, _, image) = render(&whole, &png, &["--lod", &k]);
        assert_eq!(image, want, "--lod {k} of the whole file");
    }
    refused(
        &sdfmo(&[
            "build",
            "-d",
            "4",
            "--lod",
            "--coarsest",
            "1",
            "--format",
            "3",
            "-o",
            &w,
        ]),
        "coarsest level of at least 2",
        "--lod --coarsest 1 --format 3",
    );
}
