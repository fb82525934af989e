//! Loading and saving 8-bit RGB PNG images for comparisons.

use crate::{MetricsError, Result};
use image::{DynamicImage, ImageEncoder, ImageFormat, ImageReader, RgbImage};
use std::io::Cursor;
use std::path::Path;

/// Largest image file [`load_rgb8`] reads (1 GiB), checked before reading.
pub const MAX_IMAGE_FILE_SIZE: u64 = 1 << 30;

/// Loads an image file as 8-bit RGB, ready for [`psnr`](crate::psnr) and [`flip`](crate::flip).
///
/// The format is detected from the content, not the extension; PNG is supported. The channels
/// are taken as they are stored (no colour-profile conversion), exactly as NVIDIA's FLIP tool
/// reads them through `stb_image`: alpha is dropped without compositing, grey is replicated to
/// RGB, and 16-bit channels keep their high byte. The `image` crate's default decoding limits
/// guard against huge images.
///
/// # Errors
///
/// [`MetricsError::Read`] if the file cannot be opened or read,
/// [`MetricsError::UnsupportedFormat`] if its content is not a recognised image format, and
/// [`MetricsError::Decode`] if decoding fails (corrupt, truncated, too large).
pub fn load_rgb8(path: impl AsRef<Path>) -> Result<RgbImage> {
    let path = path.as_ref();
    let read_error = |source| {
        MetricsError::Read(sdfmo_io::IoError::Os {
            action: "read",
            path: path.to_path_buf(),
            source,
        })
    };
    let bytes = sdfmo_io::read_regular(path, MAX_IMAGE_FILE_SIZE).map_err(MetricsError::Read)?;
    let reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(read_error)?;
    if reader.format() != Some(ImageFormat::Png) {
        return Err(MetricsError::UnsupportedFormat {
            path: path.to_path_buf(),
        });
    }
    let image = reader.decode().map_err(|source| match source {
        image::ImageError::IoError(source) => read_error(source),
        source => MetricsError::Decode {
            path: path.to_path_buf(),
            source,
        },
    })?;
    Ok(to_rgb8_like_stb(image))
}

/// 8-bit RGB as `stb_image` (which NVIDIA's tool loads PNGs with) produces it: 16-bit channels
/// keep their high byte (the `image` crate would round instead), alpha is dropped, grey is
/// replicated.
fn to_rgb8_like_stb(image: DynamicImage) -> RgbImage {
    use DynamicImage::{ImageLuma16, ImageLumaA16, ImageRgb16, ImageRgba16};
    match image {
        ImageLuma16(_) | ImageLumaA16(_) | ImageRgb16(_) | ImageRgba16(_) => {
            let wide = image.into_rgb16();
            let (w, h) = wide.dimensions();
            let narrow = wide
                .into_raw()
                .into_iter()
                .map(|v| (v >> 8) as u8)
                .collect();
            RgbImage::from_raw(w, h, narrow).unwrap_or_default()
        }
        image => image.into_rgb8(),
    }
}

/// Saves an 8-bit RGB image as PNG, atomically ([`sdfmo_io::write_atomic`]: a fresh temporary
/// file next to `path`, then a rename), so a crash never leaves half a file; a destination that
/// is a directory, device or FIFO is refused. Missing parent directories are created (as the
/// CLI's conventions ask).
///
/// # Errors
///
/// [`MetricsError::Encode`] if PNG encoding fails (e.g. an empty image),
/// [`MetricsError::Write`] if the directory or the temporary file cannot be created, written or
/// renamed (the temporary file is removed).
pub fn save_png(image: &RgbImage, path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(
            crate::rgb_bytes(image),
            image.width(),
            image.height(),
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|source| MetricsError::Encode {
            path: path.to_path_buf(),
            source,
        })?;
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|source| {
            MetricsError::Write(sdfmo_io::IoError::Os {
                action: "create the folder of",
                path: path.to_path_buf(),
                source,
            })
        })?;
    }
    sdfmo_io::write_atomic(path, &bytes).map_err(MetricsError::Write)
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;
    use std::fs;
    use std::path::PathBuf;

    /// A fresh directory under the system temp dir, removed on drop.
    struct TempDir(PathBuf);
    impl TempDir {
        fn new(tag: &str) -> TempDir {
            let dir = std::env::temp_dir().join(format!(
                "sdfmo-metrics-{tag}-{}-{:?}",
                std::process::id(),
                std::thread::current().id()
            ));
            let _ = fs::remove_dir_all(&dir);
            fs::create_dir_all(&dir).unwrap();
            TempDir(dir)
        }
    }
    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn png_round_trip_is_exact_and_leaves_no_temporary() {
        let dir = TempDir::new("roundtrip");
        let image = RgbImage::from_fn(13, 7, |x, y| Rgb([(x * 19) as u8, (y * 36) as u8, 200]));
        let path = dir.0.join("image.png");
        save_png(&image, &path).unwrap();
        // Overwriting an existing file works too.
        save_png(&image, &path).unwrap();
        assert_eq!(load_rgb8(&path).unwrap(), image);
        let names: Vec<_> = fs::read_dir(&dir.0)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("image.png")]);
    }

    #[test]
    fn rgba_and_grey_pngs_load_as_rgb() {
        let dir = TempDir::new("channels");
        let rgba = image::RgbaImage::from_pixel(2, 2, image::Rgba([10, 20, 30, 0]));
        let rgba_path = dir.0.join("rgba.png");
        rgba.save(&rgba_path).unwrap();
        assert_eq!(
            load_rgb8(&rgba_path).unwrap(),
            RgbImage::from_pixel(2, 2, Rgb([10, 20, 30]))
        );
        let grey = image::GrayImage::from_pixel(3, 1, image::Luma([77]));
        let grey_path = dir.0.join("grey.png");
        grey.save(&grey_path).unwrap();
        assert_eq!(
            load_rgb8(&grey_path).unwrap(),
            RgbImage::from_pixel(3, 1, Rgb([77, 77, 77]))
        );
    }

    #[test]
    fn sixteen_bit_pngs_keep_the_high_byte_as_stb_image_does() {
        let dir = TempDir::new("sixteen");
        // 0x80FF would round to 0x81 (129) with the image crate's conversion; stb gives 0x80.
        let wide = image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(
            2,
            1,
            vec![0x80FF, 0xFFFF, 0x0000, 0x00FF, 0x1234, 0xFF00],
        )
        .unwrap();
        let path = dir.0.join("wide.png");
        wide.save(&path).unwrap();
        assert_eq!(
            load_rgb8(&path).unwrap().into_raw(),
            vec![0x80, 0xFF, 0x00, 0x00, 0x12, 0xFF]
        );
    }

    #[test]
    fn missing_file_is_a_read_error_naming_it() {
        let err = load_rgb8("/nonexistent/sdfmo/metrics.png").unwrap_err();
        assert!(matches!(err, MetricsError::Read { .. }));
        assert_eq!(
            err.to_string(),
            "cannot read /nonexistent/sdfmo/metrics.png"
        );
        let dir = TempDir::new("dir");
        assert!(matches!(load_rgb8(&dir.0), Err(MetricsError::Read { .. })));
    }

    #[test]
    fn non_image_and_corrupt_png_are_typed_errors() {
        let dir = TempDir::new("corrupt");
        let text = dir.0.join("not-an-image.png");
        fs::write(&text, b"v 0 0 0\nv 1 0 0\n").unwrap();
        assert!(matches!(
            load_rgb8(&text),
            Err(MetricsError::UnsupportedFormat { .. })
        ));

        let good = dir.0.join("good.png");
        save_png(&RgbImage::from_pixel(64, 64, Rgb([1, 2, 3])), &good).unwrap();
        let bytes = fs::read(&good).unwrap();
        let truncated = dir.0.join("truncated.png");
        fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
        let err = load_rgb8(&truncated).unwrap_err();
        assert!(
            matches!(err, MetricsError::Decode { .. } | MetricsError::Read { .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("truncated.png"));
    }

    #[test]
    fn saving_creates_missing_directories() {
        let dir = TempDir::new("mkdir");
        let path = dir.0.join("a/b/heat.png");
        save_png(&RgbImage::from_pixel(2, 3, Rgb([9, 8, 7])), &path).unwrap();
        assert_eq!(load_rgb8(&path).unwrap().dimensions(), (2, 3));
    }

    #[test]
    fn unwritable_paths_and_empty_images_are_typed_errors() {
        let dir = TempDir::new("unwritable");
        let file = dir.0.join("a-file");
        fs::write(&file, b"x").unwrap();
        // A regular file where a directory is needed.
        let err = save_png(&RgbImage::new(1, 1), file.join("out.png")).unwrap_err();
        assert!(matches!(err, MetricsError::Write { .. }), "{err:?}");
        assert!(err.to_string().contains("out.png"));
        let err = save_png(&RgbImage::new(1, 1), "/").unwrap_err();
        assert!(matches!(err, MetricsError::Write { .. }), "{err:?}");
        let err = save_png(&RgbImage::new(0, 4), dir.0.join("empty.png")).unwrap_err();
        assert!(matches!(err, MetricsError::Encode { .. }), "{err:?}");
        assert!(!dir.0.join("empty.png").exists());
    }
}
