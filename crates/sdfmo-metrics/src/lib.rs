//! Image metrics for sdf-multioctree: PSNR and LDR-FLIP.
//!
//! Both compare a *reference* image (the source mesh rendered by the same renderer) with a *test*
//! image (the octree rendered with the same camera), as 8-bit RGB ([`image::RgbImage`]):
//!
//! - [`psnr`]: peak signal-to-noise ratio over **all** pixels, background included, on the 8-bit
//!   values; the mean squared error is averaged over the three channels and
//!   PSNR = 10·log10(255² / MSE), `+inf` for identical images.
//! - [`flip`]: NVIDIA's LDR-FLIP (v1.7) through the pure-Rust port [`flip_rs`], at the reference
//!   tool's default of about 67 pixels per degree ([`DEFAULT_PPD`]), with the 8-bit values read
//!   as sRGB exactly as NVIDIA's tool reads a PNG. The result holds the per-pixel error map and
//!   its mean, pooled as the tool does; [`flip_heatmap`] colours the map with the tool's magma
//!   colour map.
//!
//! Both functions check their inputs and return a [`MetricsError`] (sizes differ, empty image)
//! rather than panicking. [`load_rgb8`] and [`save_png`] read and (atomically) write PNG files
//! for the CLI's `compare` command.
//!
//! All of it is checked against the outputs of NVIDIA's `flip-evaluator` 1.7 on the pairs in
//! `shared/golden/flip` (see `tests/golden.rs` and `docs/results/metrics.md`).
//!
//! ```
//! use image::{Rgb, RgbImage};
//! use sdfmo_metrics::{flip, flip_heatmap, psnr};
//!
//! let reference = RgbImage::from_fn(32, 24, |x, y| Rgb([(x * 8) as u8, (y * 10) as u8, 64]));
//! let mut test = reference.clone();
//! test.put_pixel(5, 7, Rgb([255, 255, 255]));
//!
//! assert_eq!(psnr(&reference, &reference)?, f64::INFINITY);
//! let db = psnr(&reference, &test)?;
//! assert!(db > 30.0 && db < 60.0);
//!
//! let result = flip(&reference, &test)?;
//! assert_eq!(result.map.len(), 32 * 24);
//! assert!(result.mean > 0.0 && result.max() <= 1.0);
//! let heatmap = flip_heatmap(&result);
//! assert_eq!(heatmap.dimensions(), (32, 24));
//! # Ok::<(), sdfmo_metrics::MetricsError>(())
//! ```
#![deny(missing_docs)]

mod flip;
mod io;
mod psnr;
mod window;

use std::fmt;
use std::path::PathBuf;

pub use flip::{flip, flip_heatmap, flip_with_ppd, FlipResult, DEFAULT_PPD};
pub use io::{load_rgb8, save_png, MAX_IMAGE_FILE_SIZE};
pub use psnr::{mse, psnr};
pub use window::{hottest_window, median, most_different_window, Window};

/// Which of the two compared images an error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageRole {
    /// The reference image (first argument).
    Reference,
    /// The test image (second argument).
    Test,
}

impl fmt::Display for ImageRole {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ImageRole::Reference => "reference",
            ImageRole::Test => "test",
        })
    }
}

/// Everything that can go wrong in this crate.
///
/// Messages name what was wrong; the underlying error, when there is one, is the
/// [`source`](std::error::Error::source) (print the chain, e.g. with anyhow's `{:#}`).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MetricsError {
    /// The two images do not have the same width and height.
    #[error(
        "image sizes differ: reference is {reference_width}×{reference_height}, \
         test is {test_width}×{test_height}"
    )]
    SizeMismatch {
        /// Width of the reference image.
        reference_width: u32,
        /// Height of the reference image.
        reference_height: u32,
        /// Width of the test image.
        test_width: u32,
        /// Height of the test image.
        test_height: u32,
    },
    /// An image has no pixels (zero width or height).
    #[error("the {role} image is empty ({width}×{height})")]
    EmptyImage {
        /// Which image is empty.
        role: ImageRole,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
    },
    /// The pixels per degree given to [`flip_with_ppd`] are not finite and positive.
    #[error("pixels per degree must be finite and positive, got {0}")]
    InvalidPpd(f32),
    /// `flip-rs` rejected the evaluation (e.g. filter work limits, failed allocation).
    #[error("FLIP evaluation failed")]
    Flip(#[source] flip_rs::FlipError),
    /// An image file could not be read: missing, not a regular file, larger than
    /// [`MAX_IMAGE_FILE_SIZE`], unreadable.
    #[error(transparent)]
    Read(sdfmo_io::IoError),
    /// An image file's content is not a format this crate decodes (PNG).
    #[error("{}: not a PNG image (unrecognised content)", path.display())]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
    },
    /// An image file could not be decoded (corrupt, truncated, unsupported variant, too large).
    #[error("cannot decode image {}", path.display())]
    Decode {
        /// The file.
        path: PathBuf,
        /// The decoder's error.
        #[source]
        source: image::ImageError,
    },
    /// An image could not be encoded as PNG.
    #[error("cannot encode PNG for {}", path.display())]
    Encode {
        /// The file that was to be written.
        path: PathBuf,
        /// The encoder's error.
        #[source]
        source: image::ImageError,
    },
    /// An image file could not be written: a refused destination (directory, device, FIFO),
    /// a missing folder that cannot be created, a full disk.
    #[error(transparent)]
    Write(sdfmo_io::IoError),
}

/// Result alias of this crate.
pub type Result<T, E = MetricsError> = std::result::Result<T, E>;

/// Checks that both images are non-empty and have the same size; returns that size.
pub(crate) fn check_pair(
    reference: &image::RgbImage,
    test: &image::RgbImage,
) -> Result<(u32, u32)> {
    let (rw, rh) = reference.dimensions();
    let (tw, th) = test.dimensions();
    if (rw, rh) != (tw, th) {
        return Err(MetricsError::SizeMismatch {
            reference_width: rw,
            reference_height: rh,
            test_width: tw,
            test_height: th,
        });
    }
    for (role, (w, h)) in [
        (ImageRole::Reference, (rw, rh)),
        (ImageRole::Test, (tw, th)),
    ] {
        if w == 0 || h == 0 {
            return Err(MetricsError::EmptyImage {
                role,
                width: w,
                height: h,
            });
        }
    }
    Ok((rw, rh))
}

/// The interleaved RGB bytes of exactly `width × height` pixels (an [`image::ImageBuffer`] may
/// own a longer container).
pub(crate) fn rgb_bytes(image: &image::RgbImage) -> &[u8] {
    let n = image.width() as usize * image.height() as usize * 3;
    let raw = image.as_raw();
    raw.get(..n).unwrap_or(raw)
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::RgbImage;

    /// Each refused pair (reference then test width and height) is named by its error's
    /// variant and fields (its `Debug` form) and message: both sizes on a mismatch, which image
    /// is empty.
    #[test]
    fn check_pair_names_the_sizes_of_a_refused_pair() {
        for ([rw, rh, tw, th], fields, message) in [
            (
                [4, 3, 3, 4],
                "SizeMismatch { reference_width: 4, reference_height: 3, test_width: 3, test_height: 4 }",
                "image sizes differ: reference is 4×3, test is 3×4",
            ),
            (
                [0, 5, 0, 5],
                "EmptyImage { role: Reference, width: 0, height: 5 }",
                "the reference image is empty (0×5)",
            ),
        ] {
            let err = check_pair(&RgbImage::new(rw, rh), &RgbImage::new(tw, th)).unwrap_err();
            assert_eq!(format!("{err:?}"), fields);
            assert_eq!(err.to_string(), message);
        }
        assert_eq!(
            check_pair(&RgbImage::new(2, 7), &RgbImage::new(2, 7)).unwrap(),
            (2, 7)
        );
    }

    #[test]
    fn rgb_bytes_ignores_a_longer_container() {
        let image = RgbImage::from_raw(1, 1, vec![1, 2, 3, 9, 9, 9]).unwrap();
        assert_eq!(rgb_bytes(&image), &[1, 2, 3]);
    }
}
