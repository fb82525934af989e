//! Runs the real `sdfmo` binary on generated files and on `../shared/data`: JSON shapes, exit
//! codes and messages of failures, file naming, and a tiny sweep writing every output.

mod common;

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use serde_json::Value;

use common::{refused, sdfmo, stderr, SDFMO};

/// Command-line arguments of mixed kinds (`&str`, paths) as one `[&OsStr; N]`.
macro_rules! os {
    ($($arg:expr),* $(,)?) => {
        [$(std::ffi::OsStr::new(&$arg)),*]
    };
}

/// A fresh directory for one test, removed when the test ends.
struct TestDir(PathBuf);

impl std::ops::Deref for TestDir {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn tmp(name: &str) -> TestDir {
    let d = std::env::temp_dir().join(format!("sdfmo-cli-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TestDir(d)
}

/// A fresh directory `name` holding [`cube_obj`]'s cube.
fn with_cube(name: &str) -> (TestDir, PathBuf) {
    let dir = tmp(name);
    let cube = cube_obj(&dir);
    (dir, cube)
}

/// Run with `--json` appended (every JSON test wants it last): succeeds and prints exactly one
/// JSON object on stdout.
fn json_ok<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Value {
    let mut args: Vec<&std::ffi::OsStr> = args.iter().map(AsRef::as_ref).collect();
    args.push("--json".as_ref());
    let o = sdfmo(&args);
    assert!(
        o.status.success(),
        "exit {:?}: {}",
        o.status.code(),
        stderr(&o)
    );
    let text = String::from_utf8(o.stdout).unwrap();
    assert_eq!(
        text.trim_end().lines().count(),
        1,
        "one JSON line expected: {text}"
    );
    let v: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"));
    assert!(v.is_object(), "{v}");
    v
}

/// Fails cleanly: [`refused`] naming `needle`, and nothing on stdout.
fn fails_cleanly<S: AsRef<std::ffi::OsStr> + std::fmt::Debug>(args: &[S], needle: &str) {
    let o = sdfmo(args);
    refused(&o, needle, &format!("{args:?}"));
    assert!(o.stdout.is_empty());
}

/// `sdfmo sweep ARGS -o OUT`, run by [`json_ok`]: its JSON line and the `results.json` it wrote.
fn sweep_ok(args: &[&std::ffi::OsStr], out: &Path) -> (Value, Value) {
    let sweep = std::ffi::OsStr::new("sweep");
    let args = [&[sweep], args, &["-o".as_ref(), out.as_os_str()]].concat();
    let j = json_ok(&args);
    let results = std::fs::read_to_string(out.join("results.json")).unwrap();
    (j, serde_json::from_str(&results).unwrap())
}

fn keys(v: &Value, names: &[&str]) {
    for k in names {
        assert!(v.get(k).is_some(), "missing key {k} in {v}");
    }
}

/// A closed unit cube as OBJ (12 triangles, 8 vertices, outward faces).
fn cube_obj(dir: &Path) -> PathBuf {
    let p = dir.join("cube.obj");
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
               f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n\
               f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
    std::fs::write(&p, obj).unwrap();
    p
}

#[test]
fn info_of_a_generated_cube_and_the_demo_part() {
    let (_dir, cube) = with_cube("info");
    let j = json_ok(&os!["info", cube]);
    keys(
        &j,
        &[
            "triangles",
            "vertices",
            "parts",
            "components",
            "boundary_edges",
            "non_manifold_edges",
            "watertight",
            "bounds",
        ],
    );
    assert_eq!(j["triangles"], 12);
    assert_eq!(j["vertices"], 8);
    assert_eq!(j["components"], 1);
    assert_eq!(j["boundary_edges"], 0);
    assert_eq!(j["watertight"], true);
    assert_eq!(j["bounds"]["min"], serde_json::json!([0.0, 0.0, 0.0]));
    assert_eq!(j["bounds"]["max"], serde_json::json!([1.0, 1.0, 1.0]));

    let demo = json_ok(&["info"]);
    assert!(demo["triangles"].as_u64().unwrap() > 12);
    assert!(demo["parts"].as_u64().unwrap() >= 1);

    let human = sdfmo(&os!["info", cube]);
    assert!(human.status.success());
    assert!(String::from_utf8_lossy(&human.stdout).contains("triangles"));
}

#[test]
fn missing_and_malformed_inputs_fail_cleanly() {
    let dir = tmp("errors");
    let missing = dir.join("no_such_file.obj");
    fails_cleanly(&os!["info", missing], "no_such_file.obj");
    let bad = dir.join("bad.stl");
    std::fs::write(
        &bad,
        b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nan\n",
    )
    .unwrap();
    fails_cleanly(&os!["info", bad], "bad.stl");
    fails_cleanly(
        &os!["build", missing, "-d", "4", "-o", dir.join("x.smo")],
        "no_such_file.obj",
    );
    let not_smo = dir.join("not.smo");
    std::fs::write(&not_smo, b"this is not an octree").unwrap();
    fails_cleanly(&os!["render", not_smo, "-o", dir.join("x.png")], "not.smo");
    fails_cleanly(&os!["compare", not_smo, not_smo], "not.smo");
    // Usage errors are clap's: exit 2 too, no panic.
    let o = sdfmo(&["render", "--size", "0x5", "a.smo", "-o", "x.png"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!stderr(&o).contains("panicked"));
}

#[test]
fn distance_signs_output_file_and_malformed_lines() {
    let (dir, cube) = with_cube("distance");
    let pts = dir.join("p.xyz");
    // Normalised frame: the cube spans [-0.95, 0.95]³.
    std::fs::write(
        &pts,
        "# centre, outside, near a face\n0 0 0\n0.5 1.5 0\n0.9 0 0\n",
    )
    .unwrap();
    let out = dir.join("d.txt");
    let j = json_ok(&os![
        "distance",
        cube,
        "--points",
        pts,
        "-o",
        out,
        "--normalized"
    ]);
    keys(&j, &["points", "query_ms"]);
    assert_eq!(j["frame"], "normalized");
    assert_eq!(j["points"], 3);
    let d: Vec<f32> = std::fs::read_to_string(&out)
        .unwrap()
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    assert_eq!(d.len(), 3);
    assert!((d[0] + 0.95).abs() < 1e-4, "centre: {}", d[0]);
    assert!((d[1] - 0.55).abs() < 1e-4, "outside: {}", d[1]);
    assert!((d[2] + 0.05).abs() < 1e-4, "near a face: {}", d[2]);
    // Without -o, --json carries the distances.
    let j = json_ok(&os!["distance", cube, "--points", pts, "--sign", "winding"]);
    assert_eq!(j["distances"].as_array().unwrap().len(), 3);
    assert_eq!(j["sign"], "winding");
    // By default the points are model units (the cube is [0, 1]³): its centre is 0.5 inside,
    // a point 0.5 above its top face 0.5 outside, in the cube's own units.
    std::fs::write(&pts, "0.5 0.5 0.5\n0.5 1.5 0.5\n").unwrap();
    let j = json_ok(&os!["distance", cube, "--points", pts]);
    assert_eq!(j["frame"], "model");
    let d: Vec<f64> = j["distances"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(
        (d[0] + 0.5).abs() < 1e-5 && (d[1] - 0.5).abs() < 1e-5,
        "{d:?}"
    );

    std::fs::write(&pts, "0 0 0\n0 0\n").unwrap();
    fails_cleanly(&os!["distance", cube, "--points", pts], "p.xyz:2");
}

#[test]
fn a_closed_stdout_is_not_an_error() {
    let (dir, cube) = with_cube("pipe");
    let pts = dir.join("many.xyz");
    let text: String = (0..40_000)
        .map(|i| format!("{} 0.1 0.2\n", (i % 200) as f32 / 100.0 - 1.0))
        .collect();
    std::fs::write(&pts, text).unwrap();
    let mut child = Command::new(SDFMO)
        .args([
            "distance".as_ref(),
            cube.as_os_str(),
            "--points".as_ref(),
            pts.as_os_str(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read one byte and close the pipe, as `| head -c1` would.
    let mut stdout = child.stdout.take().unwrap();
    let mut one = [0u8; 1];
    stdout.read_exact(&mut one).unwrap();
    drop(stdout);
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(status.success(), "exit {status:?}: {err}");
    assert!(err.is_empty(), "{err}");
}

#[test]
fn build_render_and_compare_the_demo_part() {
    let dir = tmp("pipeline");
    let mut smo = PathBuf::new();
    for method in ["svo", "multi"] {
        smo = dir.join(format!("demo.{method}.smo"));
        let j = json_ok(&os![
            "build",
            "-d",
            "5",
            "--method",
            method,
            "--threads",
            "2",
            "-o",
            smo,
        ]);
        keys(
            &j,
            &[
                "nodes",
                "leaves",
                "voxels",
                "surface_voxels",
                "bytes",
                "build_ms",
                "voxels_per_leaf",
                "cap_hits",
                "phases",
            ],
        );
        assert_eq!(
            std::fs::metadata(&smo).unwrap().len(),
            j["bytes"].as_u64().unwrap()
        );
        assert!(j["voxels"].as_u64().unwrap() >= j["leaves"].as_u64().unwrap());
    }

    // --views paper numbers the files before the extension.
    let views = dir.join("v.png");
    let j = json_ok(&os![
        "render", smo, "--views", "paper", "--size", "32x24", "-o", views,
    ]);
    assert_eq!(j["views"].as_array().unwrap().len(), 4);
    assert!(!views.exists());
    for k in 0..4 {
        let img = image::open(dir.join(format!("v_{k}.png"))).unwrap();
        assert_eq!((img.width(), img.height()), (32, 24));
    }
    assert_eq!(j["counters"]["rays"].as_u64().unwrap(), 4 * 32 * 24);

    // One camera; a mask needs no normals, lambert does; shadows cast shadow rays.
    let mask = json_ok(&os![
        "render",
        smo,
        "--mode",
        "mask",
        "--eye=2,1.5,2.5",
        "--target=0,0,0",
        "--normalized",
        "--fov=45",
        "--size=40x30",
        "-o",
        dir.join("mask.png"),
    ]);
    keys(&mask, &["render_ms", "counters"]);
    assert_eq!(mask["counters"]["normal_evals"], 0);
    assert_eq!(mask["counters"]["shadow_rays"], 0);
    let lit = json_ok(&os![
        "render",
        smo,
        "--shadows",
        "--eye=2,1.5,2.5",
        "--normalized",
        "--size=40x30",
        "-o",
        dir.join("lit.png"),
    ]);
    assert!(lit["counters"]["normal_evals"].as_u64().unwrap() > 0);
    assert!(lit["counters"]["shadow_rays"].as_u64().unwrap() > 0);

    // The mesh reference with the same camera lines up: compare them.
    let reference = dir.join("ref.png");
    let j = json_ok(&os![
        "render-mesh",
        "--eye=2,1.5,2.5",
        "--normalized",
        "--size=40x30",
        "-o",
        reference,
    ]);
    keys(&j, &["render_ms", "counters"]);
    let heat = dir.join("heat.png");
    let c = json_ok(&os![
        "compare",
        reference,
        dir.join("lit.png"),
        "--heatmap",
        heat,
    ]);
    assert!(c["psnr"].as_f64().unwrap() > 5.0, "{c}");
    let flip = c["flip"].as_f64().unwrap();
    assert!((0.0..1.0).contains(&flip), "{c}");
    assert_eq!(image::open(&heat).unwrap().width(), 40);
    // Identical images: infinite PSNR is written as null with a flag (JSON has no infinity).
    let same = json_ok(&os!["compare", reference, reference]);
    assert_eq!(same["psnr"], Value::Null);
    assert_eq!(same["identical"], true);
    assert_eq!(same["flip"], 0.0);
    // Different sizes are an error, not a panic.
    fails_cleanly(&os!["compare", reference, dir.join("v_0.png")], "");
}

#[test]
fn a_tiny_sweep_writes_every_output() {
    let dir = tmp("sweep");
    let out = dir.join("out");
    let (j, results) = sweep_ok(
        &os!["--depths", "4..5", "--size", "32", "--threads", "2"],
        &out,
    );
    assert_eq!(j["rows"].as_array().unwrap().len(), 4);
    let rows = results["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    for r in rows {
        keys(
            r,
            &[
                "model",
                "method",
                "depth",
                "psnr",
                "flip",
                "bytes",
                "build_ms",
                "render_ms",
            ],
        );
        assert_eq!(r["model"], "demo");
        assert!(r["bytes"].as_u64().unwrap() > 0);
        let (m, d) = (r["method"].as_str().unwrap(), r["depth"].as_u64().unwrap());
        for k in 0..4 {
            for f in [
                format!("{m}_d{d}_{k}.png"),
                format!("{m}_d{d}_{k}_flip.png"),
            ] {
                assert!(out.join("images/demo").join(&f).exists(), "{f}");
            }
        }
    }
    for k in 0..4 {
        assert!(out.join(format!("images/demo/reference_{k}.png")).exists());
    }
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5);
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        table.contains("## demo") && table.contains("ΔPSNR"),
        "{table}"
    );
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let plots: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.starts_with("plot") && f.ends_with(".png"))
        .collect();
    assert_eq!(plots.len(), 4, "{plots:?}");
    for p in &plots {
        assert!(
            html.contains(&format!("src=\"{p}\"")),
            "{p} not on the page"
        );
    }
    assert!(html.contains("images/demo/multi_d5_0_flip.png"));
    // No temporary file is left behind.
    let leftovers: Vec<_> = walk(&out)
        .into_iter()
        .filter(|p| p.to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// `sweep --levels`: one file with levels per method gives the rows separate builds give (a
/// level is that depth's build, byte for byte), each with the prefix that holds it, whose last
/// is the size of the file `build --lod` writes; the levels table and plot are written.
#[test]
fn a_sweep_of_levels_scores_every_level_of_one_file() {
    let dir = tmp("sweep-levels");
    let common = os!["--depths", "4..6", "--size", "32", "--frames", "1"];
    let (_, separate) = sweep_ok(&common, &dir.join("separate"));
    let levels_args = [&common[..], &os!["--levels"]].concat();
    let out = dir.join("levels");
    let (_, levels) = sweep_ok(&levels_args, &out);
    let (a, b) = (
        separate["rows"].as_array().unwrap(),
        levels["rows"].as_array().unwrap(),
    );
    assert_eq!(a.len(), 6);
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        for k in [
            "method",
            "depth",
            "psnr",
            "flip",
            "bytes",
            "voxels",
            "psnr_views",
        ] {
            assert_eq!(x[k], y[k], "{k}: {x} against {y}");
        }
        assert!(x.get("bytes_read").is_none());
    }
    for method in ["svo", "multi"] {
        let read: Vec<u64> = b
            .iter()
            .filter(|r| r["method"] == method)
            .map(|r| r["bytes_read"].as_u64().unwrap())
            .collect();
        assert!(read.windows(2).all(|w| w[0] < w[1]), "{read:?}");
        let file = dir.join(format!("{method}.smo"));
        json_ok(&os![
            "build",
            "--depth",
            "6",
            "--lod",
            "--coarsest",
            "4",
            "--method",
            method,
            "-o",
            &file
        ]);
        let size = std::fs::metadata(&file).unwrap().len();
        assert_eq!(read.last().copied(), Some(size), "{method}");
    }
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(table.contains("Levels of one file") && table.contains("file / leaf-only"));
    assert!(out.join("plot_psnr_vs_bytes_read.png").exists());
    assert!(!dir.join("separate/plot_psnr_vs_bytes_read.png").exists());
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(csv.lines().next().unwrap().ends_with(",bytes_read"));
}

#[test]
fn extra_rows_join_the_sweep_and_bad_files_fail_in_one_line() {
    let dir = tmp("extra-rows");
    let good = dir.join("nglod.json");
    std::fs::write(
        &good,
        r#"[{"model": "demo", "method": "nglod", "depth": 4, "lod": 1, "psnr": 21.5,
             "flip": 0.2, "bytes": 5000, "render_ms": 300.0}]"#,
    )
    .unwrap();
    // Refused before any work: a value out of range, a configuration the sweep makes itself.
    let text = std::fs::read_to_string(&good).unwrap();
    for (name, (from, to), needle) in [
        (
            "bad.json",
            ("0.2", "1.2"),
            "row 0 (demo nglod depth 4): flip 1.2 must be within 0..=1",
        ),
        (
            "again.json",
            ("nglod", "svo"),
            "which this sweep already has",
        ),
    ] {
        let file = dir.join(name);
        std::fs::write(&file, text.replace(from, to)).unwrap();
        let out = dir.join("x");
        let args = os![
            "sweep",
            "--depths",
            "4",
            "--size",
            "16",
            "--extra-rows",
            file,
            "-o",
            out
        ];
        fails_cleanly(&args, needle);
    }
    assert!(
        !dir.join("x").exists(),
        "nothing is written before the rows are checked"
    );
    let out = dir.join("out");
    let (j, results) = sweep_ok(
        &os![
            "--depths",
            "4",
            "--size",
            "16",
            "--frames",
            "2",
            "--extra-rows",
            good
        ],
        &out,
    );
    assert_eq!(j["rows"].as_array().unwrap().len(), 3);
    assert_eq!(results["provenance"]["frames"], 2);
    assert_eq!(results["extra_rows"][0]["rows"], 1);
    assert_eq!(results["rows"][2]["lod"], 1);
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        table.contains("PSNR dB nglod") && table.contains("21.50 (LOD 1)"),
        "{table}"
    );
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(csv.lines().next().unwrap().ends_with(",lod"), "{csv}");
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        html.contains("Rows of nglod from another producer"),
        "{html}"
    );
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]
fn shared_data_parts_and_sign() {
    // The shared test meshes, as `build.rs` resolved them (`sdfmo-testdata`).
    let data = PathBuf::from(env!("SDFMO_TEST_DATA_DIR"));
    let j = json_ok(&os!["info", data.join("abc5_parts.glb")]);
    assert_eq!(j["parts"], 10);
    let j = json_ok(&os!["info", data.join("teapot.obj")]);
    assert_eq!(j["watertight"], false);
    assert!(j["boundary_edges"].as_u64().unwrap() > 0);
}

/// `sweep --fit-corners`: every build of the sweep fitted (each row's octree the one
/// `build --fit-corners` writes), the setting recorded in `results.json` and in the settings
/// hash; rows of the same sizes as without, other PSNR.
#[test]
fn a_sweep_with_fitted_corners_records_them() {
    let dir = tmp("sweep-fit");
    let common = os![
        "--depths",
        "5",
        "--size",
        "48",
        "--methods",
        "svo",
        "--threads",
        "2"
    ];
    let (_, exact) = sweep_ok(&common, &dir.join("exact"));
    let fit = [&common[..], &os!["--fit-corners"][..]].concat();
    let (_, fitted) = sweep_ok(&fit, &dir.join("fitted"));
    assert_eq!(fitted["settings"]["fit_corners"], true);
    assert!(exact["settings"].get("fit_corners").is_none());
    let (a, b) = (&exact["rows"][0], &fitted["rows"][0]);
    assert_eq!(a["bytes"], b["bytes"]);
    assert_ne!(a["psnr"], b["psnr"]);
    let fitted_build = dir.join("fitted.smo");
    let depth5 = os!["-d", "5", "--method", "svo"];
    let args = [
        &os!["build"][..],
        &depth5,
        &os!["--fit-corners", "-o", fitted_build],
    ]
    .concat();
    let built = json_ok(&args);
    assert_eq!(built["bytes"], b["bytes"]);
    let table = std::fs::read_to_string(dir.join("fitted").join("table.md")).unwrap();
    assert!(table.contains("corners fitted to the surface"), "{table}");
}

/// `build --fit-corners`: the same leaves, voxels and bytes as without, other corner values,
/// and a `fit` phase before `pack`.
#[test]
fn build_with_fitted_corners_keeps_the_size() {
    let dir = tmp("fit-corners");
    let (exact, fitted) = (dir.join("exact.smo"), dir.join("fitted.smo"));
    let a = json_ok(&os!["build", "-d", "5", "-o", exact]);
    let b = json_ok(&os!["build", "-d", "5", "--fit-corners", "-o", fitted]);
    for key in ["leaves", "voxels", "surface_voxels", "bytes"] {
        assert_eq!(a[key], b[key], "{key}");
    }
    assert_ne!(
        std::fs::read(&exact).unwrap(),
        std::fs::read(&fitted).unwrap()
    );
    let names = |j: &Value| -> Vec<String> {
        j["phases"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["name"].as_str().unwrap().to_string())
            .collect()
    };
    assert!(!names(&a).contains(&"fit".to_string()));
    let with = names(&b);
    assert_eq!(with[with.len() - 2..], ["fit", "pack"]);
}
