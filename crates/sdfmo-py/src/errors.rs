//! The exceptions of the package and the mapping of every layer error onto one of them.
//!
//! | raised | for |
//! |---|---|
//! | `ValueError` | bad arguments: shapes, dtypes, NaN or infinite coordinates, indices out of range, unknown option names, a depth or voxel cap out of range, a degenerate mesh (no extent or no area), images of different sizes, an image file that is not a PNG, an output path without its format's extension (`.png`, `.smo`) |
//! | `FileNotFoundError`, `PermissionError`, `IsADirectoryError`, `OSError` | files that cannot be read or written (the operating system's error, with `errno` and `filename`; a device, FIFO or a file over the size limit is a plain `OSError`) |
//! | `sdfmo.MeshError` (a `ValueError`) | a mesh file that is not a readable OBJ / glTF / STL: truncated, malformed, unknown format, no triangles |
//! | `sdfmo.FormatError` (a `ValueError`) | a `.smo` file that is truncated, corrupt (checksum), of an unknown version, or hostile |
//! | `MemoryError` | a build whose predicted memory exceeds the budget; any allocation sized by the input that fails (`sample_sdf`'s points, a mesh's or a file's arrays, e.g. under an address-space limit): allocated fallibly, never an abort |
//! | `KeyboardInterrupt` | Ctrl-C during a long call |
//! | `RuntimeError` | no GPU for `Octree.render(device="gpu")` (no adapter, a refused device, a device error or time-out); what should never happen (a thread pool that cannot start; an internal panic) |

use std::io::ErrorKind;

use pyo3::exceptions::{
    PyFileNotFoundError, PyIsADirectoryError, PyMemoryError, PyOSError, PyPermissionError,
    PyRuntimeError, PyValueError,
};
use pyo3::prelude::*;
use sdf_multioctree::build::BuildError;
use sdf_multioctree::distance::DistanceError;
use sdf_multioctree::format::FormatError as LayerFormatError;
use sdf_multioctree::io::{FileKind, IoError};
use sdf_multioctree::mesh::MeshError as LayerMeshError;
use sdf_multioctree::metrics::MetricsError;
use sdf_multioctree::render::RenderError;

pyo3::create_exception!(
    sdfmo,
    FormatError,
    PyValueError,
    "A `.smo` octree file that cannot be used: truncated, corrupt (checksum mismatch), an \
     unknown format version, or inconsistent sections. A subclass of ValueError; the message is \
     the format layer's and names what is wrong."
);

pyo3::create_exception!(
    sdfmo,
    MeshError,
    PyValueError,
    "A mesh file that is not a readable OBJ, glTF/GLB or STL file: unknown format, truncated, \
     malformed, non-finite coordinates, indices out of range, or no triangles. A subclass of \
     ValueError; the message names the file and the element."
);

/// The `ValueError` of an argument `what` given as `given`, which is none of `choices`:
/// `{what} must be "a", "b" or "c", got "given"`.
pub fn choice_error(what: &str, choices: &[&str], given: &str) -> PyErr {
    let quoted: Vec<String> = choices.iter().map(|c| format!("\"{c}\"")).collect();
    let listed = match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    };
    PyValueError::new_err(format!("{what} must be {listed}, got {given:?}"))
}

/// The value `choices` pairs with the name `given` of argument `what`, else its
/// [`choice_error`].
pub fn choice<T: Copy>(what: &str, given: &str, choices: &[(&str, T)]) -> PyResult<T> {
    match choices.iter().find(|(name, _)| *name == given) {
        Some(&(_, value)) => Ok(value),
        None => {
            let names: Vec<&str> = choices.iter().map(|&(name, _)| name).collect();
            Err(choice_error(what, &names, given))
        }
    }
}

/// The message of an error and its sources, joined with `: ` (each source once).
pub use sdf_multioctree::error_chain as chain;

/// `OSError(errno, message, filename)` as Python builds it: the subclass follows the errno.
fn os_error(errno: Option<i32>, message: String, filename: String) -> PyErr {
    match errno {
        Some(n) => PyOSError::new_err((n, message, filename)),
        None => PyOSError::new_err(message),
    }
}

/// An I/O error of the file layer as the matching `OSError` subclass.
pub fn io_error(e: &IoError) -> PyErr {
    io_error_with(e, chain(e))
}

/// `MemoryError` for `what` (its message names the bytes asked for).
pub fn memory_error(what: impl std::fmt::Display) -> PyErr {
    PyMemoryError::new_err(what.to_string())
}

/// [`io_error`] with another message (the caller's context added to the layer's).
fn io_error_with(e: &IoError, message: String) -> PyErr {
    let filename = e.path().display().to_string();
    match e {
        IoError::OutOfMemory { .. } => memory_error(message),
        IoError::Os { source, .. } if source.kind() == ErrorKind::OutOfMemory => {
            memory_error(message)
        }
        IoError::Os { source, .. } => match source.kind() {
            ErrorKind::NotFound => PyFileNotFoundError::new_err((
                source.raw_os_error().unwrap_or(2),
                message,
                filename,
            )),
            ErrorKind::PermissionDenied => {
                PyPermissionError::new_err((source.raw_os_error().unwrap_or(13), message, filename))
            }
            _ => os_error(source.raw_os_error(), message, filename),
        },
        IoError::NotRegularFile {
            kind: FileKind::Directory,
            ..
        } => PyIsADirectoryError::new_err((21, message, filename)),
        // ENOENT: outputs never create the folders they go into.
        IoError::MissingFolder { .. } => PyFileNotFoundError::new_err((2, message, filename)),
        // EFBIG: larger than the reader's limit.
        IoError::TooLarge { .. } => os_error(Some(27), message, filename),
        // A bad argument, not the file system's refusal.
        IoError::WrongExtension { .. } => PyValueError::new_err(message),
        _ => os_error(None, message, filename),
    }
}

/// A mesh error: the file's I/O errors as `OSError`s (an external glTF buffer that cannot be
/// read too, with the glTF named in the message), a buffer reference leaving the model's
/// folder and everything about the content as [`MeshError`].
pub fn mesh_error(e: &LayerMeshError) -> PyErr {
    match e {
        LayerMeshError::Io(io) => io_error(io),
        LayerMeshError::OutOfMemory { .. } => memory_error(chain(e)),
        LayerMeshError::ExternalBuffer { source, .. }
            if !matches!(source, IoError::OutsideFolder { .. }) =>
        {
            io_error_with(source, chain(e))
        }
        _ => MeshError::new_err(chain(e)),
    }
}

/// An error of the in-memory constructors (`Mesh(vertices, faces)`): a `ValueError`.
pub fn array_mesh_error(e: &LayerMeshError) -> PyErr {
    match e {
        LayerMeshError::OutOfMemory { .. } => memory_error(chain(e)),
        _ => PyValueError::new_err(chain(e)),
    }
}

/// A format error: I/O as `OSError`s, everything about the bytes as [`FormatError`].
pub fn format_error(e: &LayerFormatError) -> PyErr {
    match e {
        LayerFormatError::Io(io) => io_error(io),
        _ => FormatError::new_err(chain(e)),
    }
}

/// A build error: settings as `ValueError`, the memory budget as `MemoryError`.
pub fn build_error(e: &BuildError) -> PyErr {
    match e {
        BuildError::MemoryBudget { .. } => PyMemoryError::new_err(chain(e)),
        BuildError::Format(f) => format_error(f),
        _ => PyValueError::new_err(chain(e)),
    }
}

/// The distance structure refused the mesh (a BVH deeper than the traversal supports).
pub fn distance_error(e: &DistanceError) -> PyErr {
    PyValueError::new_err(chain(e))
}

/// A render error: cameras and settings as `ValueError`.
pub fn render_error(e: &RenderError) -> PyErr {
    match e {
        RenderError::Io(io) => io_error(io),
        _ => PyValueError::new_err(chain(e)),
    }
}

/// An error of the facade's `Renderer`: a render error as [`render_error`], a GPU that cannot
/// be opened or fails (no adapter, a refused device, a device error, a time-out) as
/// `RuntimeError`, an octree over the adapter's limits as `ValueError`.
pub fn facade_error(e: &sdf_multioctree::Error) -> PyErr {
    use sdf_multioctree::gpu::GpuError;
    match e {
        sdf_multioctree::Error::Render(r) | sdf_multioctree::Error::Gpu(GpuError::Render(r)) => {
            render_error(r)
        }
        sdf_multioctree::Error::Gpu(
            GpuError::TooLarge { .. } | GpuError::FileTooLarge { .. } | GpuError::Format(_),
        ) => PyValueError::new_err(chain(e)),
        _ => PyRuntimeError::new_err(chain(e)),
    }
}

/// A metrics error: an image file that cannot be read or written as the `OSError` subclass,
/// everything else (sizes differ, empty images, not a PNG, corrupt PNG) as `ValueError`. Sizes
/// are said as numpy shapes, `(height, width, 3)`: the layer's `width×height` reads as the
/// wrong shape to a numpy user.
pub fn metrics_error(e: &MetricsError) -> PyErr {
    match e {
        MetricsError::Read(io) | MetricsError::Write(io) => io_error(io),
        &MetricsError::SizeMismatch {
            reference_width,
            reference_height,
            test_width,
            test_height,
        } => PyValueError::new_err(format!(
            "image sizes differ: reference has shape ({reference_height}, {reference_width}, 3), \
             test ({test_height}, {test_width}, 3) (height, width, channels)"
        )),
        &MetricsError::EmptyImage {
            role,
            width,
            height,
        } => PyValueError::new_err(format!(
            "the {role} image is empty: shape ({height}, {width}, 3) (height, width, channels)"
        )),
        _ => PyValueError::new_err(chain(e)),
    }
}
