//! `sdfmo render --device gpu`: the CPU's images and JSON keys plus `device` and `gpu_ms`, and
//! clear errors for what the GPU path does not do. Without an adapter the rendering test says so
//! and passes without checking, unless `SDFMO_REQUIRE_GPU=1` (CI).

use std::path::PathBuf;
use std::process::{Command, Output};

use serde_json::Value;

const SDFMO: &str = env!("CARGO_BIN_EXE_sdfmo");

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sdfmo-gpu-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn sdfmo(args: &[&str], env: &[(&str, &str)]) -> Output {
    Command::new(SDFMO)
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("cannot run sdfmo")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit 2, the message on one line, no panic, nothing on stdout.
fn fails_cleanly(o: &Output, needle: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected: {err}"
    );
    assert!(err.contains(needle), "{needle:?} not in {err:?}");
    assert!(o.stdout.is_empty());
}

/// Whether a GPU render failed for want of an adapter (the test is then skipped, unless
/// `SDFMO_REQUIRE_GPU=1`, where that fails it).
fn no_adapter(o: &Output) -> bool {
    if o.status.success() || !stderr(o).contains("no GPU adapter") {
        return false;
    }
    assert_ne!(
        std::env::var("SDFMO_REQUIRE_GPU").as_deref(),
        Ok("1"),
        "SDFMO_REQUIRE_GPU=1 but: {}",
        stderr(o)
    );
    eprintln!("skipped: {}", stderr(o).trim());
    true
}

/// A depth-6 SVO of the built-in demo part.
fn demo_octree(dir: &std::path::Path) -> String {
    let smo = dir.join("demo.smo").display().to_string();
    // The SVO: the multi-octree's sharp edges (intersect voxels, issue 11) may take either
    // face's normal on either device, which crates/sdfmo-gpu/tests/match_cpu.rs checks pixel by
    // pixel; here the CLI's plumbing must give the same image.
    let o = sdfmo(&["build", "-d", "6", "--method", "svo", "-o", &smo], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    smo
}

/// Renders with `render` (device → its output and image path) on the GPU and then the CPU, and
/// checks that the GPU took time, both hit the same pixels, and the images match (identical or
/// PSNR ≥ 45 dB). The GPU's and the CPU's JSON, or `None` when there is no adapter.
fn gpu_matches_cpu(render: impl Fn(&str) -> (Output, String)) -> Option<(Value, Value)> {
    let (o, gpu_png) = render("gpu");
    if no_adapter(&o) {
        return None;
    }
    assert!(o.status.success(), "{}", stderr(&o));
    let gpu: Value = serde_json::from_slice(&o.stdout).unwrap();
    let (o, cpu_png) = render("cpu");
    assert!(o.status.success(), "{}", stderr(&o));
    let cpu: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(gpu["gpu_ms"].as_f64().is_some_and(|ms| ms > 0.0), "{gpu}");
    assert_eq!(gpu["counters"]["hits"], cpu["counters"]["hits"]);
    assert!(gpu["counters"]["hits"].as_u64().unwrap() > 0);
    let o = sdfmo(&["compare", &cpu_png, &gpu_png, "--json"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cmp: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        cmp["identical"] == true || cmp["psnr"].as_f64().is_some_and(|p| p >= 45.0),
        "{cmp}"
    );
    Some((gpu, cpu))
}

#[test]
fn gpu_render_matches_cpu_and_adds_device_keys() {
    let dir = tmp("match");
    let smo = demo_octree(&dir);
    let render = |device: &str| {
        let png = dir.join(format!("{device}.png")).display().to_string();
        let o = sdfmo(
            &[
                "render", &smo, "--device", device, "--size", "96x64", "--mode", "lambert", "-o",
                &png, "--json",
            ],
            &[],
        );
        (o, png)
    };
    let Some((gpu, cpu)) = gpu_matches_cpu(render) else {
        return;
    };
    for key in [
        "source",
        "mode",
        "width",
        "height",
        "views",
        "render_ms",
        "counters",
        "device",
        "gpu_ms",
    ] {
        assert!(gpu.get(key).is_some(), "GPU JSON lacks {key}: {gpu}");
        assert!(cpu.get(key).is_some(), "CPU JSON lacks {key}: {cpu}");
    }
    assert_eq!(cpu["device"], "cpu");
    assert!(cpu["gpu_ms"].is_null());
    assert!(gpu["device"]
        .as_str()
        .is_some_and(|d| !d.is_empty() && d != "cpu"));
}

/// Extra `render` arguments, environment, and what the one-line error must contain.
type RefusalCase<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)], &'a str);

/// `sdfmo render` of a fresh demo octree (in the folder `name`) on the GPU with `extra`
/// arguments and `env`: fails with one line containing `needle` and writes no image.
fn gpu_render_fails(name: &str, cases: &[RefusalCase]) {
    let dir = tmp(name);
    let smo = demo_octree(&dir);
    let png = dir.join("x.png").display().to_string();
    for &(extra, env, needle) in cases {
        let mut args = vec!["render", smo.as_str(), "--device", "gpu"];
        args.extend_from_slice(extra);
        args.extend(["-o", png.as_str()]);
        fails_cleanly(&sdfmo(&args, env), needle);
        assert!(!std::path::Path::new(&png).exists(), "{extra:?}");
    }
}

#[test]
fn gpu_refuses_what_it_does_not_render() {
    gpu_render_fails(
        "refuse",
        &[
            (
                &["--shadows"],
                &[],
                "--shadows and --ao are not available with --device gpu",
            ),
            (&["--ao", "4"], &[], "--device gpu"),
            (
                &["--threads", "2"],
                &[],
                "--threads applies to --device cpu only",
            ),
        ],
    );
}

#[test]
fn no_adapter_is_one_line_error() {
    // wgpu is built without its GL backend: asking for it alone finds no adapter anywhere.
    gpu_render_fails(
        "none",
        &[(&[], &[("WGPU_BACKEND", "gl")], "no GPU adapter found")],
    );
}

/// Issue 23: `--pixel-error` on the GPU (it used to be refused) renders a file with levels as
/// the CPU does (the same hits, the images identical or PSNR ≥ 45 dB); a file without levels is
/// refused as on the CPU.
#[test]
fn gpu_pixel_error_matches_cpu() {
    let dir = tmp("pixel-error");
    let smo = dir.join("demo-lod.smo").display().to_string();
    let o = sdfmo(
        &["build", "-d", "7", "--lod", "--method", "svo", "-o", &smo],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let render = |device: &str| {
        let png = dir.join(format!("{device}.png")).display().to_string();
        let o = sdfmo(
            &[
                "render",
                &smo,
                "--pixel-error",
                "1",
                "--eye",
                "0,0,5",
                "--normalized",
                "--device",
                device,
                "--size",
                "96x64",
                "-o",
                &png,
                "--json",
            ],
            &[],
        );
        (o, png)
    };
    if gpu_matches_cpu(render).is_none() {
        return;
    }
    let flat = demo_octree(&dir);
    let png = dir.join("flat.png").display().to_string();
    fails_cleanly(
        &sdfmo(
            &[
                "render",
                &flat,
                "--pixel-error",
                "1",
                "--device",
                "gpu",
                "-o",
                &png,
            ],
            &[],
        ),
        "has no levels of detail",
    );
}

/// Issue 34: a 3.0 file (`build --format 3`, plain and `--compress`ed) renders on the GPU from
/// its bricks (no 1.x octree is made: `run_bricks`) exactly as the 1.x file of the same octree
/// renders on the GPU: the same PNG bytes, the same hits, `levels` its one depth; a level or a
/// pixel error it does not hold is refused in one line, as for a 1.x file.
#[test]
fn gpu_renders_a_v3_file_as_its_octree() {
    let dir = tmp("v3");
    let p = |name: &str| dir.join(name).display().to_string();
    let build = |out: &str, extra: &[&str]| {
        let mut args = vec!["build", "-d", "6", "--method", "multi", "-o", out];
        args.extend_from_slice(extra);
        let o = sdfmo(&args, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    build(&p("v1.smo"), &[]);
    build(&p("v3.smo"), &["--format", "3"]);
    build(&p("v3z.smo"), &["--format", "3", "--compress"]);
    let render = |smo: &str, png: &str, mode: &str| {
        sdfmo(
            &[
                "render", smo, "--device", "gpu", "--size", "96x64", "--views", "paper", "--mode",
                mode, "-o", png, "--json",
            ],
            &[],
        )
    };
    for mode in ["lambert", "normal", "depth"] {
        let o = render(&p("v1.smo"), &p(&format!("v1-{mode}.png")), mode);
        if no_adapter(&o) {
            return;
        }
        assert!(o.status.success(), "{}", stderr(&o));
        let v1: Value = serde_json::from_slice(&o.stdout).unwrap();
        for name in ["v3", "v3z"] {
            let o = render(
                &p(&format!("{name}.smo")),
                &p(&format!("{name}-{mode}.png")),
                mode,
            );
            assert!(o.status.success(), "{}", stderr(&o));
            let v3: Value = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(v3["counters"], v1["counters"], "{name} {mode}");
            assert!(v3["counters"]["hits"].as_u64().unwrap() > 0);
            assert_eq!(v3["levels"], json_levels(6), "{name}");
            assert_eq!(v3["device"], v1["device"]);
            for view in 0..4 {
                let png = |n: &str| std::fs::read(dir.join(format!("{n}-{mode}_{view}.png")));
                let (a, b) = (png("v1").unwrap(), png(name).unwrap());
                assert!(a == b, "{name} {mode} view {view}: the PNGs differ");
            }
        }
    }
    let (png, v3) = (p("x.png"), p("v3.smo"));
    for (extra, needle) in [
        (&["--lod", "5"][..], "level 5"),
        (&["--pixel-error", "1"][..], "has no levels of detail"),
    ] {
        let mut args = vec!["render", v3.as_str(), "--device", "gpu", "-o", png.as_str()];
        args.extend_from_slice(extra);
        fails_cleanly(&sdfmo(&args, &[]), needle);
    }
}

/// `--json`'s `levels` of a file of one level `d`.
fn json_levels(d: u8) -> Value {
    serde_json::json!({ "file": [d], "held": [d], "drawn": [d] })
}
