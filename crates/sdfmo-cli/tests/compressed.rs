//! `sdfmo build --compress`: the compressed container written by the CLI, read back by `info`
//! and `render` as the same octree (same image, byte for byte), and its level checked.

mod common;

use common::{ok, refused, sdfmo};

fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text).unwrap()
}

#[test]
fn a_compressed_build_loads_and_renders_as_the_plain_one() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let (plain_smo, packed_smo) = (p("plain.smo"), p("packed.smo"));
    for lod in [false, true] {
        let extra: &[&str] = if lod {
            &["--lod", "--coarsest", "4"]
        } else {
            &[]
        };
        let plain = [&["build", "-d", "6", "-o", &plain_smo, "--json"], extra].concat();
        let packed = [
            &[
                "build",
                "-d",
                "6",
                "-o",
                &packed_smo,
                "--json",
                "--compress",
            ],
            extra,
        ]
        .concat();
        let a = json(&ok(&plain));
        let b = json(&ok(&packed));
        assert_eq!(a["bytes"], b["bytes"], "lod {lod}");
        assert_eq!(b["compress_level"], 9);
        let (traced, stored) = (
            b["bytes"].as_u64().unwrap(),
            b["stored_bytes"].as_u64().unwrap(),
        );
        assert_eq!(stored, std::fs::metadata(p("packed.smo")).unwrap().len());
        assert!(stored * 4 < traced, "lod {lod}: {stored} of {traced} bytes");

        let info = json(&ok(&["info", &p("packed.smo"), "--json"]));
        assert_eq!(info["compressed"], true);
        assert_eq!(info["stored_bytes"].as_u64(), Some(stored));
        assert_eq!(info["file_size"].as_u64(), Some(traced));
        assert_eq!(
            json(&ok(&["info", &p("plain.smo"), "--json"]))["compressed"],
            false
        );

        for (src, out) in [("plain.smo", "plain.png"), ("packed.smo", "packed.png")] {
            ok(&["render", &p(src), "-o", &p(out), "--size", "96"]);
        }
        assert_eq!(
            std::fs::read(p("plain.png")).unwrap(),
            std::fs::read(p("packed.png")).unwrap(),
            "lod {lod}"
        );
    }
}

#[test]
fn a_level_outside_zstd_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.smo");
    for level in ["--compress=0", "--compress=23", "--compress=fast"] {
        let o = sdfmo(&["build", "-d", "3", "-o", out.to_str().unwrap(), level]);
        assert_eq!(o.status.code(), Some(2), "{level}");
        assert!(!out.exists(), "{level}");
    }
}

#[test]
fn a_format_3_build_renders_as_the_1x_one() {
    // A 3.0 file (plain or compressed) is traced in place by the CPU tracer (`run_bricks`):
    // the image of the 1.x octree it encodes byte for byte, and `info` names its bricks.
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let v1 = json(&ok(&["build", "-d", "6", "-o", &p("v1.smo"), "--json"]));
    assert_eq!(v1["format"], "1.x");
    for (name, extra) in [("v3.smo", &[][..]), ("v3z.smo", &["--compress"][..])] {
        let out = p(name);
        let args = [
            &["build", "-d", "6", "--format", "3", "-o", &out, "--json"][..],
            extra,
        ]
        .concat();
        let v3 = json(&ok(&args));
        assert_eq!(v3["format"], "3.1", "{name}");
        assert_eq!(v3["voxels"], v1["voxels"], "{name}");
        let file = v3["file_bytes"].as_u64().unwrap();
        assert!(file < v1["bytes"].as_u64().unwrap(), "{name}: {file}");
        let info = json(&ok(&["info", &p(name), "--json"]));
        assert_eq!(info["version"], "3.1 (bricks)", "{name}");
        assert_eq!(info["file_size"].as_u64(), Some(file), "{name}");
        assert_eq!(info["compressed"], !extra.is_empty(), "{name}");
        assert!(info["bricks"].as_u64().unwrap() > 0, "{name}");
        ok(&[
            "render",
            &p(name),
            "-o",
            &p(&format!("{name}.png")),
            "--size",
            "96",
        ]);
    }
    ok(&["render", &p("v1.smo"), "-o", &p("v1.png"), "--size", "96"]);
    let png = |n: &str| std::fs::read(p(n)).unwrap();
    assert_eq!(png("v3.smo.png"), png("v1.png"));
    assert_eq!(png("v3z.smo.png"), png("v1.png"));
}

#[test]
fn format_3_below_depth_2_or_with_levels_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.smo");
    let out_arg = out.to_str().unwrap();
    for (depth, lod, needle) in [
        ("1", None, "--format 3 needs a depth of at least 2"),
        ("4", Some("--lod"), ""),
    ] {
        let mut args = vec!["build", "-d", depth, "--format", "3", "-o", out_arg];
        args.extend(lod);
        refused(&sdfmo(&args), needle, &format!("{args:?}"));
        assert!(!out.exists());
    }
}
