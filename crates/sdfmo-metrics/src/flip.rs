//! LDR-FLIP through `flip-rs`, and its magma heat map.

use crate::{check_pair, rgb_bytes, MetricsError, Result};
use image::RgbImage;

/// The reference tool's default pixels per degree, about 67.02 (a 0.7 m wide, 3840-pixel
/// monitor viewed from 0.7 m): what "67 pixels per degree" means in the paper's protocol.
pub const DEFAULT_PPD: f32 = flip_rs::DEFAULT_PPD;

/// An LDR-FLIP evaluation: the per-pixel error map and its mean.
#[derive(Clone, Debug, PartialEq)]
pub struct FlipResult {
    /// Mean error over all pixels, pooled as NVIDIA's tool does (summed in `f32` in row-major
    /// order, divided by the pixel count).
    pub mean: f32,
    /// Width of the compared images in pixels.
    pub width: u32,
    /// Height of the compared images in pixels.
    pub height: u32,
    /// Error per pixel in 0..=1, row-major (index `y · width + x`, `y` from the top).
    pub map: Vec<f32>,
}

impl FlipResult {
    /// Largest per-pixel error (0 for an empty or error-free map; NaN values are ignored).
    pub fn max(&self) -> f32 {
        self.map.iter().copied().fold(0.0, f32::max)
    }

    /// Error at pixel (x, y), `None` outside the image.
    pub fn get(&self, x: u32, y: u32) -> Option<f32> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.map
            .get(y as usize * self.width as usize + x as usize)
            .copied()
    }
}

/// LDR-FLIP between two 8-bit images read as sRGB, at [`DEFAULT_PPD`], the 8-bit values read as sRGB.
///
/// # Errors
///
/// [`MetricsError::SizeMismatch`] if the sizes differ, [`MetricsError::EmptyImage`] if either
/// has no pixels, [`MetricsError::Flip`] if `flip-rs` refuses (its work limits are far above any
/// image we render) or cannot allocate.
pub fn flip(reference: &RgbImage, test: &RgbImage) -> Result<FlipResult> {
    flip_with_ppd(reference, test, DEFAULT_PPD)
}

/// LDR-FLIP as [`flip`] for another viewing distance, given in pixels per degree.
///
/// # Errors
///
/// As [`flip`], plus [`MetricsError::InvalidPpd`] if `ppd` is not finite and positive.
pub fn flip_with_ppd(reference: &RgbImage, test: &RgbImage, ppd: f32) -> Result<FlipResult> {
    let (width, height) = check_pair(reference, test)?;
    if !(ppd.is_finite() && ppd > 0.0) {
        return Err(MetricsError::InvalidPpd(ppd));
    }
    let to_flip = |image: &RgbImage| {
        flip_rs::RgbImage::new(width as usize, height as usize, rgb_bytes(image).to_vec())
            .map_err(MetricsError::Flip)
    };
    let errors = flip_rs::ldr_flip(&to_flip(reference)?, &to_flip(test)?, ppd)
        .map_err(MetricsError::Flip)?;
    let map = errors.into_pixels();
    Ok(FlipResult {
        mean: reference_mean(&map),
        width,
        height,
        map,
    })
}

/// The mean as `FLIPPooling::pooling<float>::getMean` computes it: a sequential `f32` sum in
/// row-major order divided by the count (what `flip-rs`'s `Statistics::mean` does too, without
/// its sort for the quartiles).
fn reference_mean(map: &[f32]) -> f32 {
    let sum = map.iter().fold(0.0_f32, |sum, &v| sum + v);
    sum / map.len() as f32
}

/// Colours a FLIP error map with the magma colour map of NVIDIA's tool, as its heat-map PNG:
/// error e ∈ [0, 1] picks entry round(255·e) of the 256-entry table
/// ([`flip_rs::MAGMA`][magma]), whose sRGB values are written as round(255·c).
///
/// The image is `width × height`. A `FlipResult` built by hand whose map is shorter than that
/// yields only the rows the map covers (never a panic or an allocation beyond the map's size);
/// NaN errors show as 0.
///
/// [magma]: https://docs.rs/flip-rs/0.1/flip_rs/constant.MAGMA.html
pub fn flip_heatmap(result: &FlipResult) -> RgbImage {
    let palette: [[u8; 3]; 256] =
        flip_rs::MAGMA.map(|rgb| rgb.map(|c| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8));
    let width = result.width;
    let rows = if width == 0 {
        0
    } else {
        (result.map.len() / width as usize).min(result.height as usize) as u32
    };
    let mut pixels = Vec::with_capacity(width as usize * rows as usize * 3);
    for &e in &result.map[..width as usize * rows as usize] {
        // `as usize` maps NaN to 0 and saturates; the clamp keeps 255.5 from indexing 256.
        let index = ((e.clamp(0.0, 1.0) * 255.0 + 0.5) as usize).min(255);
        pixels.extend_from_slice(&palette[index]);
    }
    RgbImage::from_raw(width, rows, pixels).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    /// A deterministic smooth gradient with a sharp-edged square.
    fn scene(w: u32, h: u32) -> RgbImage {
        RgbImage::from_fn(w, h, |x, y| {
            let inside = (w / 4..w / 2).contains(&x) && (h / 4..h / 2).contains(&y);
            if inside {
                Rgb([230, 200, 40])
            } else {
                Rgb([(x * 255 / w) as u8, (y * 255 / h) as u8, 90])
            }
        })
    }

    #[test]
    fn identical_images_have_zero_error_everywhere() {
        let a = scene(40, 30);
        let r = flip(&a, &a).unwrap();
        assert_eq!((r.width, r.height, r.map.len()), (40, 30, 1200));
        assert!(r.map.iter().all(|&e| e == 0.0));
        assert_eq!((r.mean, r.max()), (0.0, 0.0));
    }

    #[test]
    fn black_against_white_is_near_the_maximum_error() {
        let black = RgbImage::new(16, 16);
        let white = RgbImage::from_pixel(16, 16, Rgb([255, 255, 255]));
        let r = flip(&black, &white).unwrap();
        assert!(r.mean > 0.8 && r.max() <= 1.0, "mean {}", r.mean);
    }

    #[test]
    fn error_is_local_to_the_changed_region() {
        // A changed pixel block in one corner: the error map is row-major and peaks there,
        // far from the opposite corner.
        let a = scene(64, 48);
        let mut b = a.clone();
        for y in 40..44 {
            for x in 2..6 {
                b.put_pixel(x, y, Rgb([255, 0, 255]));
            }
        }
        let r = flip(&a, &b).unwrap();
        let peak = r.get(3, 41).unwrap();
        assert!(peak > 0.3, "peak {peak}");
        assert_eq!(r.get(3, 41), Some(r.map[41 * 64 + 3]));
        assert_eq!(r.get(60, 2), Some(0.0));
        assert!(r.max() >= peak && r.mean > 0.0 && r.mean < peak);
        assert_eq!(r.get(64, 0), None);
        assert_eq!(r.get(0, 48), None);
    }

    #[test]
    fn mean_is_the_row_major_f32_mean_of_flip_rs_statistics() {
        let a = scene(50, 37);
        let b = RgbImage::from_fn(50, 37, |x, y| {
            let p = a.get_pixel(x, y).0;
            Rgb([p[0].wrapping_add((x * y % 7) as u8), p[1], p[2] / 2])
        });
        let r = flip(&a, &b).unwrap();
        let stats = flip_rs::ErrorMap::new(50, 37, r.map.clone())
            .unwrap()
            .statistics();
        assert_eq!(r.mean, stats.mean);
        let f64_mean = r.map.iter().map(|&v| f64::from(v)).sum::<f64>() / r.map.len() as f64;
        assert!((f64::from(r.mean) - f64_mean).abs() < 1e-6);
    }

    #[test]
    fn lower_ppd_changes_the_result_and_bad_ppd_is_rejected() {
        let a = scene(32, 32);
        let b = RgbImage::from_fn(32, 32, |x, y| {
            if (x + y) % 2 == 0 {
                *a.get_pixel(x, y)
            } else {
                Rgb([0, 0, 0])
            }
        });
        let near = flip_with_ppd(&a, &b, 10.0).unwrap();
        assert_eq!(
            flip(&a, &b).unwrap(),
            flip_with_ppd(&a, &b, DEFAULT_PPD).unwrap()
        );
        assert_ne!(near.mean, flip(&a, &b).unwrap().mean);
        for ppd in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                flip_with_ppd(&a, &b, ppd),
                Err(MetricsError::InvalidPpd(_))
            ));
        }
    }

    #[test]
    fn size_mismatch_and_empty_are_errors() {
        assert!(matches!(
            flip(&scene(8, 8), &scene(8, 9)),
            Err(MetricsError::SizeMismatch { .. })
        ));
        assert!(matches!(
            flip(&RgbImage::new(0, 0), &RgbImage::new(0, 0)),
            Err(MetricsError::EmptyImage { .. })
        ));
    }

    #[test]
    fn heatmap_uses_the_magma_ends_and_rounds_to_the_nearest_entry() {
        let r = FlipResult {
            mean: 0.0,
            width: 4,
            height: 1,
            map: vec![0.0, 1.0, 0.5, 2.0],
        };
        let heat = flip_heatmap(&r);
        assert_eq!(heat.dimensions(), (4, 1));
        let byte = |c: f32| (c * 255.0 + 0.5) as u8;
        let entry = |i: usize| Rgb(flip_rs::MAGMA[i].map(byte));
        assert_eq!(*heat.get_pixel(0, 0), entry(0));
        assert_eq!(*heat.get_pixel(1, 0), entry(255));
        // 0.5·255 + 0.5 = 128.0 → entry 128.
        assert_eq!(*heat.get_pixel(2, 0), entry(128));
        // Clamped.
        assert_eq!(*heat.get_pixel(3, 0), entry(255));
        // Magma runs from near-black to a light yellow.
        assert_eq!(entry(0), Rgb([0, 0, 4]));
        assert!(entry(255).0.iter().all(|&c| c > 180));
    }

    #[test]
    fn heatmap_of_an_inconsistent_result_does_not_panic() {
        let short = FlipResult {
            mean: 0.0,
            width: 3,
            height: 1_000_000,
            map: vec![0.1, f32::NAN, 0.3, 0.4, 0.5],
        };
        let heat = flip_heatmap(&short);
        assert_eq!(heat.dimensions(), (3, 1));
        // NaN shows as zero error: magma entry 0, (0, 0, 4) in 8 bits.
        assert_eq!(heat.get_pixel(1, 0).0, [0, 0, 4]);
        let zero_width = FlipResult {
            mean: 0.0,
            width: 0,
            height: 5,
            map: vec![0.5],
        };
        assert_eq!(flip_heatmap(&zero_width).dimensions(), (0, 0));
    }

    #[test]
    fn heatmap_of_a_real_evaluation_matches_the_map() {
        let a = scene(20, 10);
        let b = RgbImage::from_fn(20, 10, |x, _| Rgb([(x * 12) as u8, 0, 0]));
        let r = flip(&a, &b).unwrap();
        let heat = flip_heatmap(&r);
        assert_eq!(heat.dimensions(), (20, 10));
        let colors = flip_rs::ErrorMap::new(20, 10, r.map.clone())
            .unwrap()
            .colorize()
            .unwrap();
        let expected: Vec<u8> = colors
            .pixels()
            .iter()
            .map(|&c| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
            .collect();
        assert_eq!(heat.as_raw(), &expected);
    }
}
