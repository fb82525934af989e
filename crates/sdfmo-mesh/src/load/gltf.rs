//! glTF / GLB reader (in progress).

use std::path::Path;

use super::{LoadLimits, RawMesh};
use crate::error::{MeshError, Result};

pub(super) fn read(
    _bytes: &[u8],
    file: &str,
    _base: Option<&Path>,
    _limits: &LoadLimits,
) -> Result<RawMesh> {
    Err(MeshError::Unsupported {
        file: file.into(),
        reason: "glTF loading is not available in this build yet".into(),
    })
}
