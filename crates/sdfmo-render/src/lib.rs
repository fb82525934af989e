//! Rendering for sdf-multioctree: cameras, render modes, effect planning, tiles in parallel,
//! PNG/EXR output, for the packed octree and for the source mesh (the reference image).
//!
//! Conventions (the repository's `docs/architecture.md`): right-handed, +Y up, the octree root is [-1, 1]³ and meshes are
//! rendered in the same normalised frame. The camera is described in [`camera`], the exact
//! shading formulas in [`shading`], the planning in [`plan`].
//!
//! The reference renderer of the source mesh (`MeshScene`, module `mesh`) is behind the
//! default feature `mesh-reference`; with `default-features = false` the crate renders octrees
//! on `sdfmo-format` and `sdfmo-trace` alone and compiles no mesh loader or BVH.
//!
//! ```
//! use sdfmo_render::{render, Camera, Mode, RenderSettings, Spheres};
//! use glam::Vec3;
//!
//! let scene = Spheres::one(Vec3::ZERO, 0.5);
//! let camera = Camera::paper_view(0, 64, 64);
//! let img = render(&scene, &camera, &RenderSettings::new(Mode::Mask)).unwrap();
//! assert_eq!(img.counters.rays, 64 * 64);
//! assert_eq!(img.counters.normal_evals, 0); // a mask needs no normals
//! ```
#![deny(missing_docs)]

pub mod camera;
mod levels;
#[cfg(feature = "mesh-reference")]
pub mod mesh;
pub mod octree;
mod output;
pub mod plan;
#[cfg(feature = "mesh-reference")]
pub mod protocol;
mod render;
pub mod scene;
pub mod shading;

use std::path::PathBuf;

pub use camera::{check_image_size, Camera, CameraFrame, MAX_IMAGE_SIDE, MAX_PIXELS};
pub use levels::{LevelRequest, LevelScene};
#[cfg(feature = "mesh-reference")]
pub use mesh::{apply_normalization, mesh_in_octree_frame, octree_normalization, MeshScene};
pub use octree::{LodScene, OctreeScene};
pub use output::{encode_exr, encode_png, save_exr, save_png};
pub use plan::{Counters, Mode, RenderPlan, RenderSettings, MAX_AO_SAMPLES};
#[cfg(feature = "mesh-reference")]
pub use protocol::{PaperProtocol, ProtocolError, Score, ViewScore};
pub use render::{render, RenderRequest, Rendered};
pub use scene::{SphereHit, Spheres, Traceable};
/// The packet of primary rays [`Traceable::first_hits`] takes.
pub use sdfmo_trace::RayPacket;

/// Everything that can go wrong while rendering or writing images.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// The camera is degenerate (size, field of view, eye = target, non-finite values).
    #[error("invalid camera: {0}")]
    InvalidCamera(String),
    /// The settings or plan are inconsistent (unknown mode, too many occlusion rays, …).
    #[error("invalid render settings: {0}")]
    InvalidSettings(String),
    /// A [`Rendered`] buffer does not match its width and height.
    #[error("{what} buffer of {len} values does not match a {width}x{height} image")]
    BufferSize {
        /// Which buffer.
        what: String,
        /// Its length.
        len: usize,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// PNG encoding failed.
    #[error("cannot encode PNG {}", path.display())]
    Png {
        /// Destination.
        path: PathBuf,
        /// The image crate's error.
        #[source]
        source: image::ImageError,
    },
    /// EXR encoding failed.
    #[error("cannot encode EXR {}", path.display())]
    Exr {
        /// Destination.
        path: PathBuf,
        /// The exr crate's error.
        #[source]
        source: exr::error::Error,
    },
    /// A level the data does not hold was asked for ([`LevelRequest::Level`]).
    #[error("level {level} is not in the data: {}", levels::held_levels(*coarsest, *finest))]
    LevelNotHeld {
        /// The level asked for.
        level: u8,
        /// The coarsest level held.
        coarsest: u8,
        /// The finest level held.
        finest: u8,
    },
    /// A pixel error ([`LevelRequest::PixelError`]) for a file without levels of detail.
    #[error(
        "the file has no levels of detail (its one level is {depth}): a pixel error needs a \
         file built with levels (`sdfmo build --lod`)"
    )]
    NoLevels {
        /// The file's one level.
        depth: u8,
    },
    /// The render was cancelled by its caller ([`RenderRequest::cancel`]).
    #[error("the render was cancelled")]
    Cancelled,
    /// A file could not be written: a refused destination (directory, device, FIFO), a
    /// missing folder, a full disk (see [`sdfmo_io::IoError`]).
    #[error(transparent)]
    Io(#[from] sdfmo_io::IoError),
}
