//! `sdfmo build --compress`: the compressed container written by the CLI, read back by `info`
//! and `render` as the same octree (same image, byte for byte), and its level checked.

use std::process::{Command, Output};

const SDFMO: &str = env!("CARGO_BIN_EXE_sdfmo");

fn sdfmo(args: &[&str]) -> Output {
    Command::new(SDFMO).args(args).output().unwrap()
}

fn ok(args: &[&str]) -> String {
    let o = sdfmo(args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

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
