//! PSNR and FLIP against NVIDIA's reference outputs in `shared/golden/flip`.
//!
//! `golden.json` lists every pair (`NAME_ref.png`, `NAME_test.png`) with the mean and max FLIP and
//! the PSNR (`"inf"` for identical images) produced by `flip-evaluator` 1.7 (LDR, default PPD);
//! `NAME_flip.f32` is its per-pixel error map, raw little-endian `f32`, width × height row-major.
//!
//! The directory comes from `SDFMO_GOLDEN` (default: `../shared/golden/flip` beside the
//! workspace; a relative value is taken against the workspace root), resolved by `build.rs`
//! through `sdfmo-testdata`. When it has no `golden.json` the tests are reported as ignored,
//! unless `SDFMO_REQUIRE_TEST_DATA=1`, in which case they run and fail.

use sdfmo_metrics::{flip, flip_heatmap, load_rgb8, psnr, FlipResult};
use std::path::{Path, PathBuf};

/// flip-rs claims bit-exact agreement with NVIDIA's C++ code; the golden files were written by
/// NVIDIA's tool, so we hold every value to this.
const FLIP_TOLERANCE: f32 = 1e-6;
/// PSNR is computed exactly up to the final division and logarithm.
const PSNR_TOLERANCE: f64 = 1e-9;

/// The golden directory, as `build.rs` resolved it (`sdfmo-testdata`).
fn golden_dir() -> PathBuf {
    PathBuf::from(env!("SDFMO_GOLDEN_DIR"))
}

struct Pair {
    name: String,
    width: u32,
    height: u32,
    mean_flip: f32,
    max_flip: f32,
    /// `None` for "inf".
    psnr: Option<f64>,
}

fn pairs(dir: &Path) -> Vec<Pair> {
    let text = std::fs::read_to_string(dir.join("golden.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let pairs = json["pairs"]
        .as_object()
        .expect("golden.json has no \"pairs\" object");
    assert!(!pairs.is_empty(), "golden.json lists no pairs");
    let mut out: Vec<Pair> = pairs
        .iter()
        .map(|(name, p)| {
            let number = |key: &str| {
                p[key]
                    .as_f64()
                    .unwrap_or_else(|| panic!("{name}: {key} is not a number"))
            };
            let psnr = match &p["psnr_rgb8"] {
                serde_json::Value::String(s) if s == "inf" => None,
                v => Some(
                    v.as_f64()
                        .unwrap_or_else(|| panic!("{name}: psnr_rgb8 is {v}")),
                ),
            };
            Pair {
                name: name.clone(),
                width: number("width") as u32,
                height: number("height") as u32,
                mean_flip: number("mean_flip") as f32,
                max_flip: number("max_flip") as f32,
                psnr,
            }
        })
        .collect();
    out.sort_by(|a, b| a.name.cmp(&b.name));
    out
}

fn read_f32_map(path: &Path) -> Vec<f32> {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(bytes.len() % 4, 0, "{}: not whole f32s", path.display());
    bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

fn evaluate(dir: &Path, pair: &Pair) -> (f64, FlipResult) {
    let reference = load_rgb8(dir.join(format!("{}_ref.png", pair.name))).unwrap();
    let test = load_rgb8(dir.join(format!("{}_test.png", pair.name))).unwrap();
    assert_eq!(
        reference.dimensions(),
        (pair.width, pair.height),
        "{}",
        pair.name
    );
    (
        psnr(&reference, &test).unwrap(),
        flip(&reference, &test).unwrap(),
    )
}

/// Every golden pair with our PSNR and FLIP of it, computed once for all the tests here.
fn evaluated() -> &'static [(Pair, f64, FlipResult)] {
    static ALL: std::sync::OnceLock<Vec<(Pair, f64, FlipResult)>> = std::sync::OnceLock::new();
    ALL.get_or_init(|| {
        let dir = golden_dir();
        let pairs = pairs(&dir);
        let scores = pairs.iter().map(|pair| evaluate(&dir, pair));
        let scores: Vec<_> = scores.collect();
        pairs
            .into_iter()
            .zip(scores)
            .map(|(pair, (db, result))| (pair, db, result))
            .collect()
    })
}

fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
#[cfg_attr(sdfmo_no_golden_data, ignore = "no golden FLIP data: set SDFMO_GOLDEN")]
fn psnr_matches_golden_for_every_pair() {
    for (pair, db, _) in evaluated() {
        let db = *db;
        let diff = pair.psnr.map_or(0.0, |g| (db - g).abs());
        println!(
            "{:>15}: psnr {db:.15} golden {:?} |d| {diff:.1e}",
            pair.name, pair.psnr
        );
        match pair.psnr {
            None => assert_eq!(db, f64::INFINITY, "{}", pair.name),
            Some(expected) => assert!(
                (db - expected).abs() <= PSNR_TOLERANCE,
                "{}: psnr {db} vs golden {expected}",
                pair.name
            ),
        }
    }
}

#[test]
#[cfg_attr(sdfmo_no_golden_data, ignore = "no golden FLIP data: set SDFMO_GOLDEN")]
fn flip_matches_golden_mean_max_and_map_for_every_pair() {
    let dir = golden_dir();
    for (pair, _, result) in evaluated() {
        let golden_map = read_f32_map(&dir.join(format!("{}_flip.f32", pair.name)));
        assert_eq!(
            golden_map.len(),
            (pair.width * pair.height) as usize,
            "{}: map size",
            pair.name
        );
        assert_eq!((result.width, result.height), (pair.width, pair.height));
        let map_diff = max_abs_diff(&result.map, &golden_map);
        let mean_diff = (result.mean - pair.mean_flip).abs();
        let max_diff = (result.max() - pair.max_flip).abs();
        println!(
            "{:>15} {}x{}: mean {:.9} (golden {:.9}, |d| {:.2e}), max |d| {:.2e}, map max |d| {:.2e}",
            pair.name,
            pair.width,
            pair.height,
            result.mean,
            pair.mean_flip,
            mean_diff,
            max_diff,
            map_diff
        );
        assert!(mean_diff <= FLIP_TOLERANCE, "{}: mean", pair.name);
        assert!(max_diff <= FLIP_TOLERANCE, "{}: max", pair.name);
        assert!(map_diff <= FLIP_TOLERANCE, "{}: map", pair.name);
        // The golden mean is the mean of the golden map (same pooling).
        let golden_mean = golden_map.iter().fold(0.0_f32, |s, &v| s + v) / golden_map.len() as f32;
        assert!(
            (golden_mean - pair.mean_flip).abs() <= FLIP_TOLERANCE,
            "{}",
            pair.name
        );
    }
}

#[test]
#[cfg_attr(sdfmo_no_golden_data, ignore = "no golden FLIP data: set SDFMO_GOLDEN")]
fn golden_maps_are_row_major() {
    // Check the layout claim on the non-square pairs with a visible error: reading the golden
    // map as column-major (transposed) must disagree with ours, row-major must agree.
    let dir = golden_dir();
    let mut checked = 0;
    for (pair, _, result) in evaluated() {
        if pair.width == pair.height || pair.max_flip == 0.0 {
            continue;
        }
        let golden = read_f32_map(&dir.join(format!("{}_flip.f32", pair.name)));
        let (w, h) = (pair.width as usize, pair.height as usize);
        let transposed: Vec<f32> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| golden[x * h + y])
            .collect();
        assert!(max_abs_diff(&result.map, &golden) <= FLIP_TOLERANCE);
        assert!(
            max_abs_diff(&result.map, &transposed) > 0.01,
            "{}: layout ambiguous",
            pair.name
        );
        checked += 1;
    }
    assert!(
        checked > 0,
        "no non-square pair with errors to check the layout"
    );
}

#[test]
#[cfg_attr(sdfmo_no_golden_data, ignore = "no golden FLIP data: set SDFMO_GOLDEN")]
fn heatmap_of_golden_pairs_has_their_size_and_magma_extremes() {
    let magma0 = flip_rs_magma_byte(0);
    for (pair, _, result) in evaluated() {
        let heat = flip_heatmap(result);
        assert_eq!(heat.dimensions(), (pair.width, pair.height));
        if pair.max_flip == 0.0 {
            assert!(heat.pixels().all(|p| p.0 == magma0), "{}", pair.name);
        } else {
            assert!(heat.pixels().any(|p| p.0 != magma0), "{}", pair.name);
        }
    }
}

/// Entry `i` of the magma table as 8-bit sRGB, taken from a one-pixel heat map.
fn flip_rs_magma_byte(i: usize) -> [u8; 3] {
    let e = i as f32 / 255.0;
    flip_heatmap(&FlipResult {
        mean: e,
        width: 1,
        height: 1,
        map: vec![e],
    })
    .get_pixel(0, 0)
    .0
}
