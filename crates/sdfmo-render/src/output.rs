//! Writing images: 8-bit PNG and f32 OpenEXR, encoded in memory, then written atomically with
//! [`sdfmo_io`] (one file, or several all-or-none with an [`sdfmo_io::OutputBatch`]).

use std::path::Path;

use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes};
use exr::prelude::{SmallVec, WritableImage};
use image::ImageEncoder;

use crate::{RenderError, Rendered};

fn check_len(r: &Rendered, what: &str, len: usize, per_pixel: usize) -> Result<(), RenderError> {
    let expect = r.width as usize * r.height as usize * per_pixel;
    if len == expect && r.width > 0 && r.height > 0 {
        Ok(())
    } else {
        Err(RenderError::BufferSize {
            what: what.to_string(),
            len,
            width: r.width,
            height: r.height,
        })
    }
}

/// Writes the 8-bit RGB image as PNG, atomically ([`sdfmo_io::write_atomic`]: a fresh
/// temporary file in the same directory, then a rename), so a crash never leaves half a file.
/// A destination that is a directory, device or FIFO is refused; a symbolic link is followed.
pub fn save_png(r: &Rendered, path: impl AsRef<Path>) -> Result<(), RenderError> {
    let path = path.as_ref();
    Ok(sdfmo_io::write_atomic(path, &encode_png(r, path)?)?)
}

/// Writes [`encode_exr`]'s file atomically, like [`save_png`].
pub fn save_exr(r: &Rendered, path: impl AsRef<Path>) -> Result<(), RenderError> {
    let path = path.as_ref();
    Ok(sdfmo_io::write_atomic(path, &encode_exr(r, path)?)?)
}

/// The 8-bit RGB image as PNG bytes; `path` only names the image in errors.
///
/// # Errors
/// [`RenderError::BufferSize`] for an inconsistent image, [`RenderError::Png`].
pub fn encode_png(r: &Rendered, path: &Path) -> Result<Vec<u8>, RenderError> {
    check_len(r, "rgb", r.rgb.len(), 3)?;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(&r.rgb, r.width, r.height, image::ExtendedColorType::Rgb8)
        .map_err(|source| RenderError::Png {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(bytes)
}

/// An OpenEXR file as bytes (one layer, f32 samples, ZIP compression); `path` only names the
/// image in errors. Channels `R`, `G`, `B` hold the 8-bit image divided by 255; `Z` the ray
/// distance when [`Rendered::depth`] is present (+∞ for background); `N.X`, `N.Y`, `N.Z` the
/// viewer-facing normal when [`Rendered::normals`] is present (zero for background).
///
/// # Errors
/// [`RenderError::BufferSize`] for an inconsistent image, [`RenderError::Exr`].
pub fn encode_exr(r: &Rendered, path: &Path) -> Result<Vec<u8>, RenderError> {
    check_len(r, "rgb", r.rgb.len(), 3)?;
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in ["R", "G", "B"].into_iter().enumerate() {
        let v = r
            .rgb
            .iter()
            .skip(c)
            .step_by(3)
            .map(|&x| f32::from(x) / 255.0)
            .collect();
        channels.push(AnyChannel::new(name, FlatSamples::F32(v)));
    }
    if let Some(depth) = &r.depth {
        check_len(r, "depth", depth.len(), 1)?;
        channels.push(AnyChannel::new("Z", FlatSamples::F32(depth.clone())));
    }
    if let Some(normals) = &r.normals {
        check_len(r, "normals", normals.len(), 1)?;
        for (c, name) in ["N.X", "N.Y", "N.Z"].into_iter().enumerate() {
            let v = normals.iter().map(|n| n[c]).collect();
            channels.push(AnyChannel::new(name, FlatSamples::F32(v)));
        }
    }
    let layer = Layer::new(
        (r.width as usize, r.height as usize),
        LayerAttributes::named("sdfmo"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|source| RenderError::Exr {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(bytes.into_inner())
}
