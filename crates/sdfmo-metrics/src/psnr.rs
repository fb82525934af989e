//! PSNR on 8-bit RGB images: over all pixels, background included, the squared error averaged
//! over the three channels.

use crate::{check_pair, rgb_bytes, Result};
use image::RgbImage;

/// Mean squared error over all pixels and the three channels, on the 8-bit values (0–255).
///
/// The sum of squared differences is accumulated exactly in integers, so the result does not
/// depend on image size or summation order beyond the final division.
///
/// # Errors
///
/// [`MetricsError::SizeMismatch`](crate::MetricsError::SizeMismatch) if the sizes differ,
/// [`MetricsError::EmptyImage`](crate::MetricsError::EmptyImage) if either has no pixels.
pub fn mse(reference: &RgbImage, test: &RgbImage) -> Result<f64> {
    let (w, h) = check_pair(reference, test)?;
    let samples = u64::from(w) * u64::from(h) * 3;
    let sse: u64 = rgb_bytes(reference)
        .iter()
        .zip(rgb_bytes(test))
        .map(|(&a, &b)| {
            let d = u64::from(a.abs_diff(b));
            d * d
        })
        .sum();
    Ok(sse as f64 / samples as f64)
}

/// Peak signal-to-noise ratio in dB: 10·log10(255² / MSE) with the [`mse`] over all pixels
/// (background included) and the three channels; `f64::INFINITY` for identical images.
///
/// # Errors
///
/// [`MetricsError::SizeMismatch`](crate::MetricsError::SizeMismatch) if the sizes differ,
/// [`MetricsError::EmptyImage`](crate::MetricsError::EmptyImage) if either has no pixels.
pub fn psnr(reference: &RgbImage, test: &RgbImage) -> Result<f64> {
    let mse = mse(reference, test)?;
    if mse == 0.0 {
        return Ok(f64::INFINITY);
    }
    Ok(10.0 * (255.0 * 255.0 / mse).log10())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ImageRole, MetricsError};
    use image::Rgb;

    fn pattern(w: u32, h: u32) -> RgbImage {
        RgbImage::from_fn(w, h, |x, y| {
            Rgb([(x * 37 + y) as u8, (y * 11) as u8, (x ^ y) as u8])
        })
    }

    /// A black `w` × `h` image and a copy whose pixel (x, y) is `rgb`.
    fn black_and_one_pixel(
        w: u32,
        h: u32,
        (x, y): (u32, u32),
        rgb: [u8; 3],
    ) -> (RgbImage, RgbImage) {
        let a = RgbImage::new(w, h);
        let mut b = a.clone();
        b.put_pixel(x, y, Rgb(rgb));
        (a, b)
    }

    #[test]
    fn identical_images_are_infinite() {
        let a = pattern(7, 5);
        assert_eq!(psnr(&a, &a.clone()).unwrap(), f64::INFINITY);
        assert_eq!(mse(&a, &a).unwrap(), 0.0);
    }

    #[test]
    fn one_channel_of_one_pixel_by_one_level() {
        // 2×2 image, 12 samples, one differs by 1: MSE = 1/12.
        let (a, b) = black_and_one_pixel(2, 2, (1, 0), [0, 1, 0]);
        assert_eq!(mse(&a, &b).unwrap(), 1.0 / 12.0);
        let expected = 10.0 * (255.0f64 * 255.0 * 12.0).log10();
        assert!((psnr(&a, &b).unwrap() - expected).abs() < 1e-12);
    }

    #[test]
    fn black_against_white_is_zero_db() {
        let black = RgbImage::new(3, 2);
        let white = RgbImage::from_pixel(3, 2, Rgb([255, 255, 255]));
        assert_eq!(mse(&black, &white).unwrap(), 65025.0);
        assert_eq!(psnr(&black, &white).unwrap(), 0.0);
        // Symmetric.
        assert_eq!(psnr(&white, &black).unwrap(), 0.0);
    }

    #[test]
    fn background_pixels_count() {
        // The same single wrong pixel in a larger (mostly equal, "background") image raises PSNR
        // by 10·log10(area ratio): every pixel counts.
        let (small_a, small_b) = black_and_one_pixel(2, 2, (0, 0), [40, 0, 0]);
        let (big_a, big_b) = black_and_one_pixel(8, 8, (0, 0), [40, 0, 0]);
        let gain = psnr(&big_a, &big_b).unwrap() - psnr(&small_a, &small_b).unwrap();
        assert!((gain - 10.0 * 16f64.log10()).abs() < 1e-9, "gain {gain}");
    }

    #[test]
    fn size_mismatch_and_empty_are_errors() {
        let a = pattern(4, 4);
        assert!(matches!(
            psnr(&a, &pattern(4, 5)),
            Err(MetricsError::SizeMismatch { .. })
        ));
        assert!(matches!(
            psnr(&RgbImage::new(3, 0), &RgbImage::new(3, 0)),
            Err(MetricsError::EmptyImage {
                role: ImageRole::Reference,
                ..
            })
        ));
    }
}
