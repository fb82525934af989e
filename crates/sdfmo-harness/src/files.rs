//! Writing the files of an output folder: atomically, at names the harness derived.

use std::path::Path;

use sdf_multioctree::io::Naming;

use crate::error::{HarnessError, Result};

/// Writes `bytes` atomically at a name the command derived (inside an output folder): a
/// symbolic link there is replaced, never followed ([`Naming::Derived`]).
///
/// # Errors
///
/// The [`sdf_multioctree::io::IoError`] of the write (the path named in it).
pub fn write_derived(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(sdf_multioctree::io::write_atomic_as(
        path,
        bytes,
        Naming::Derived,
    )?)
}

/// Encodes an RGB image as PNG and writes it atomically at a derived name ([`write_derived`]).
///
/// # Errors
///
/// [`HarnessError::Png`] when the image cannot be encoded (an empty image), or the write's.
pub fn write_derived_png(path: &Path, img: &image::RgbImage) -> Result<()> {
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png)
        .map_err(|source| HarnessError::Png {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
    write_derived(path, &buf.into_inner())
}
