//! Times PSNR, FLIP and the heat map on a synthetic render-like pair (a lit sphere on black, and
//! the same sphere shifted by a fraction of a pixel with a little noise).
//!
//! ```sh
//! cargo run --release -p sdfmo-metrics --example flip_timing -- [SIZE=1024] [REPEATS=3]
//! ```
//! Threads: flip-rs processes rows in parallel with rayon (`RAYON_NUM_THREADS` to pin it).

use image::{Rgb, RgbImage};
use sdfmo_metrics::{flip, flip_heatmap, psnr};
use std::time::Instant;

/// A Lambert-shaded sphere of radius 0.6 (image half-width = 1), light from (1, 1, 1),
/// displaced by `shift` pixels, plus a deterministic ±`noise` level dither.
fn sphere(size: u32, shift: f32, noise: u32) -> RgbImage {
    let light = {
        let l = 1.0 / 3f32.sqrt();
        [l, l, l]
    };
    let mut state = 0x9E37_79B9_u32;
    RgbImage::from_fn(size, size, |px, py| {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        let x = (2.0 * (px as f32 + 0.5 + shift) / size as f32 - 1.0) / 0.6;
        let y = (1.0 - 2.0 * (py as f32 + 0.5) / size as f32) / 0.6;
        let r2 = x * x + y * y;
        if r2 >= 1.0 {
            return Rgb([0, 0, 0]);
        }
        let z = (1.0 - r2).sqrt();
        let lambert = (x * light[0] + y * light[1] + z * light[2]).max(0.0);
        let v = (0.25 + 2.0 / 3.0 * lambert).min(1.0) * 255.0;
        let dither = if noise == 0 {
            0.0
        } else {
            (state % (2 * noise + 1)) as f32 - noise as f32
        };
        let c = (v + dither).clamp(0.0, 255.0).round() as u8;
        Rgb([c, c, c])
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let size: u32 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(1024);
    let repeats: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(3);
    let reference = sphere(size, 0.0, 0);
    let test = sphere(size, 0.3, 2);
    println!(
        "{size}x{size}, {} hardware threads, RAYON_NUM_THREADS={}",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "unset".into())
    );
    for run in 1..=repeats {
        let t = Instant::now();
        let db = psnr(&reference, &test)?;
        let psnr_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let result = flip(&reference, &test)?;
        let flip_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let heat = flip_heatmap(&result);
        let heat_ms = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(heat.dimensions(), (size, size));
        println!(
            "run {run}: psnr {db:.3} dB in {psnr_ms:.2} ms, flip mean {:.6} in {flip_ms:.1} ms, \
             heat map in {heat_ms:.2} ms",
            result.mean
        );
    }
    Ok(())
}
