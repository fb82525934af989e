//! Writing images: 8-bit PNG and f32 OpenEXR, both atomically (temporary file, then rename).

use std::fs;
use std::path::{Path, PathBuf};

use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes};
use exr::prelude::{SmallVec, WritableImage};
use image::ImageEncoder;

use crate::{RenderError, Rendered};

/// A temporary sibling of `path` (same directory, so the rename is atomic).
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "image".into(), |n| n.to_string_lossy());
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// Moves `tmp` over `path`, removing `tmp` on failure.
fn commit(tmp: &Path, path: &Path) -> Result<(), RenderError> {
    fs::rename(tmp, path).map_err(|source| {
        let _ = fs::remove_file(tmp);
        RenderError::Io {
            path: path.to_path_buf(),
            source,
        }
    })
}

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

/// Writes the 8-bit RGB image as PNG, atomically (a temporary file in the same directory, then
/// a rename), so a crash never leaves half a file.
pub fn save_png(r: &Rendered, path: &Path) -> Result<(), RenderError> {
    check_len(r, "rgb", r.rgb.len(), 3)?;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(&r.rgb, r.width, r.height, image::ExtendedColorType::Rgb8)
        .map_err(|source| RenderError::Png {
            path: path.to_path_buf(),
            source,
        })?;
    let tmp = temp_path(path);
    fs::write(&tmp, &bytes).map_err(|source| {
        let _ = fs::remove_file(&tmp);
        RenderError::Io {
            path: tmp.clone(),
            source,
        }
    })?;
    commit(&tmp, path)
}

/// Writes an OpenEXR file (one layer, f32 samples, ZIP compression), atomically: channels `R`,
/// `G`, `B` hold the 8-bit image divided by 255; `Z` the ray distance when
/// [`Rendered::depth`] is present (+∞ for background); `N.X`, `N.Y`, `N.Z` the viewer-facing
/// normal when [`Rendered::normals`] is present (zero for background).
pub fn save_exr(r: &Rendered, path: &Path) -> Result<(), RenderError> {
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
    let tmp = temp_path(path);
    Image::from_layer(layer)
        .write()
        .to_file(&tmp)
        .map_err(|source| {
            let _ = fs::remove_file(&tmp);
            RenderError::Exr {
                path: path.to_path_buf(),
                source,
            }
        })?;
    commit(&tmp, path)
}
