//! # sdf-multioctree
//!
//! Triangle meshes to a compact sparse octree of trilinear signed-distance voxels, and a ray
//! tracer for it, following "SDFMultiOctree: implicit representation of surfaces based on signed
//! distance functions" (Mayorov, Garifullin, Voloboy, Frolov).
//!
//! This crate is a facade: each layer is its own crate, re-exported here as a module named after
//! the crate without its `sdfmo-` prefix (module [`mesh`] is crate `sdfmo-mesh`, [`distance`] is
//! `sdfmo-distance`, and so on, as bevy's `app` is `bevy_app`). Depend on one layer alone when
//! that is all you need: an engine that only loads and ray traces octrees needs
//! [`format`](mod@format) and [`trace`].
//!
//! | module | crate | what it does |
//! |---|---|---|
//! | [`mesh`] | `sdfmo-mesh` | load OBJ / glTF / STL, clean, normalise, topology, procedural parts |
//! | [`distance`] | `sdfmo-distance` | exact signed distance, closest points, ray hits on a mesh |
//! | [`build`] | `sdfmo-build` | the SVO baseline and the multi-octree builder |
//! | [`format`](mod@format) | `sdfmo-format` | the packed octree and its `.smo` file |
//! | [`trace`] | `sdfmo-trace` | ray vs packed octree |
//! | [`render`] | `sdfmo-render` | cameras, render modes, PNG/EXR, mesh reference images |
//! | [`metrics`] | `sdfmo-metrics` | PSNR and FLIP |
//!
//! ## Debug builds
//!
//! The builder and the renderer are numeric loops: a debug build of a crate that depends on
//! this one renders about 14× slower than a release build. Optimise the dependencies in dev
//! builds (or build in release):
//!
//! ```toml
//! [profile.dev.package."*"]
//! opt-level = 3
//! ```
//!
//! ## The pipeline in a few calls
//!
//! The functions at the root of this crate cover the common path with the paper's defaults
//! (load → build → save/load → render → compare); each layer offers every setting.
//!
//! ```
//! use sdf_multioctree::{build_octree, compare, demo_mesh, load_octree, paper_views};
//! use sdf_multioctree::{render_mesh, render_octree, save_octree, save_png, Method, Mode};
//!
//! let mesh = demo_mesh(); // or sdf_multioctree::load_mesh("part.stl")?
//! let (octree, stats) = build_octree(&mesh, 5, Method::Multi { max_voxels: 8 })?;
//! let path = std::env::temp_dir().join(format!("sdfmo-doc-{}.smo", std::process::id()));
//! save_octree(&octree, &path)?;
//! let octree = load_octree(&path)?;
//! assert_eq!(octree.byte_size(), stats.bytes);
//!
//! let camera = &paper_views(64)[0];
//! let reference = render_mesh(&mesh, camera, Mode::Lambert)?; // same camera and shading
//! let image = render_octree(&octree, camera, Mode::Lambert)?;
//! let quality = compare(&reference, &image)?;
//! assert!(quality.psnr > 10.0 && quality.flip < 0.5);
//!
//! let mask = render_octree(&octree, camera, Mode::Mask)?; // only hit or miss: no normals
//! assert_eq!(mask.counters.normal_evals, 0);
//! let png = path.with_extension("png");
//! save_png(&mask, &png)?;
//! # std::fs::remove_file(&path).ok();
//! # std::fs::remove_file(&png).ok();
//! # Ok::<(), sdf_multioctree::Error>(())
//! ```
#![deny(missing_docs)]

pub use sdfmo_build as build;
pub use sdfmo_distance as distance;
pub use sdfmo_format as format;
pub use sdfmo_io as io;
pub use sdfmo_mesh as mesh;
pub use sdfmo_metrics as metrics;
pub use sdfmo_render as render;
pub use sdfmo_trace as trace;

/// Margin of the normalisation into the root cube [-1, 1]³ (the repository's `docs/architecture.md`, Conventions): the longest extent of a
/// mesh becomes 2·(1 − margin). The builder's default; the CLI normalises meshes with it for
/// `distance` and `render-mesh` so that their frame is the octree's.
pub const DEFAULT_MARGIN: f32 = 0.05;

use std::fmt;
use std::path::Path;

use build::BuildSettings;
use distance::{MeshDistance, SignMode};
use render::{MeshScene, OctreeScene, RenderSettings};

// The types and functions the high-level API takes and returns, at the root so that a caller
// of these functions (and the examples) needs no layer path.
pub use build::{BuildStats, Method};
pub use format::PackedOctree;
pub use mesh::TriMesh;
pub use render::{save_png, Camera, Mode, Rendered};

/// Declares [`Error`], one variant per layer with the prefix its message gets, with its
/// `Display`, `source` (the layer error's own source: the layer's message is already shown)
/// and a `From` per layer error.
macro_rules! layer_errors {
    ($($(#[doc = $doc:literal])* $variant:ident($ty:ty) => $prefix:literal,)*) => {
        /// An error of the high-level API: the layer's own error, one variant per layer.
        #[derive(Debug)]
        #[non_exhaustive]
        pub enum Error {
            $($(#[doc = $doc])* $variant($ty),)*
        }

        impl fmt::Display for Error {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                match self {
                    $(Error::$variant(e) => write!(f, concat!($prefix, ": {}"), e),)*
                }
            }
        }

        impl std::error::Error for Error {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                match self {
                    $(Error::$variant(e) => e.source(),)*
                }
            }
        }

        $(impl From<$ty> for Error {
            fn from(e: $ty) -> Error {
                Error::$variant(e)
            }
        })*
    };
}
layer_errors!(
    /// Loading or validating a mesh.
    Mesh(mesh::MeshError) => "mesh",
    /// Preparing distance or ray queries on a mesh.
    Distance(distance::DistanceError) => "distance",
    /// Building an octree.
    Build(build::BuildError) => "build",
    /// Saving, loading or validating an octree file.
    Format(format::FormatError) => "octree file",
    /// Rendering or writing an image.
    Render(render::RenderError) => "render",
    /// Comparing images.
    Metrics(metrics::MetricsError) => "metrics",
);

/// Result of the high-level API.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Loads a mesh file (OBJ, glTF/GLB, STL), welded and cleaned, in model units.
///
/// # Errors
/// [`Error::Mesh`] naming the file and what is wrong with it.
pub fn load_mesh(path: impl AsRef<Path>) -> Result<TriMesh> {
    Ok(mesh::load_mesh(path.as_ref())?.mesh)
}

/// The built-in demo part: boxes, a plate thinner than a voxel, an open sheet and two parts
/// separated by a sub-voxel gap, where the multi-octree's advantage shows at a glance.
pub fn demo_mesh() -> TriMesh {
    mesh::procedural::demo_part()
}

/// Builds an octree of `mesh` (model units; normalised by the builder with
/// [`DEFAULT_MARGIN`]) at `depth` with `method`, 8-bit corners, automatic sign and all cores.
/// Use [`build::build`] for every setting and a progress callback.
///
/// # Errors
/// [`Error::Build`] for an invalid depth or voxel cap, or a mesh the builder cannot use.
pub fn build_octree(
    mesh: &TriMesh,
    depth: u8,
    method: Method,
) -> Result<(PackedOctree, BuildStats)> {
    let settings = BuildSettings {
        depth,
        method,
        margin: DEFAULT_MARGIN,
        ..BuildSettings::default()
    };
    Ok(build::build(mesh, &settings, None)?)
}

/// Loads a `.smo` octree file, validating it.
///
/// # Errors
/// [`Error::Format`] for an unreadable, truncated, corrupt or hostile file.
pub fn load_octree(path: impl AsRef<Path>) -> Result<PackedOctree> {
    Ok(PackedOctree::load(path.as_ref())?)
}

/// Saves an octree as a `.smo` file, atomically.
///
/// # Errors
/// [`Error::Format`] when the file cannot be written.
pub fn save_octree(octree: &PackedOctree, path: impl AsRef<Path>) -> Result<()> {
    Ok(octree.save(path.as_ref())?)
}

/// The paper's four cameras at `size`×`size` pixels (radius 3 in the y = 0 plane, looking at
/// the origin, vertical field of view 60°).
pub fn paper_views(size: u32) -> Vec<Camera> {
    Camera::paper_views(size, size)
}

/// Ray traces an octree in `mode` on all cores: [`Mode::Lambert`] is the paper's shading (no
/// shadows), [`Mode::Mask`], [`Mode::Depth`] and [`Mode::Normal`] compute only what they show.
/// Use [`render::render`] with [`render::RenderSettings`] for shadows, occlusion and threads.
///
/// # Errors
/// [`Error::Render`] for an invalid camera.
pub fn render_octree(octree: &PackedOctree, camera: &Camera, mode: Mode) -> Result<Rendered> {
    Ok(render::render(
        &OctreeScene(octree),
        camera,
        &RenderSettings::new(mode),
    )?)
}

/// Ray traces the source mesh (model units) in `mode` as the reference image: normalised
/// exactly as the builder does, the same camera and shading as [`render_octree`], face normals.
///
/// # Errors
/// [`Error::Distance`] if the ray queries cannot be prepared, [`Error::Render`] for an invalid
/// camera. (A [`TriMesh`] is valid by construction, so there is no mesh error here.)
pub fn render_mesh(mesh: &TriMesh, camera: &Camera, mode: Mode) -> Result<Rendered> {
    let (normalized, _) = mesh.normalized(DEFAULT_MARGIN);
    let dist = MeshDistance::new(&normalized, SignMode::Auto)?;
    Ok(render::render(
        &MeshScene(&dist),
        camera,
        &RenderSettings::new(mode),
    )?)
}

/// Image quality of a test image against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// PSNR in dB over all pixels and channels (`f64::INFINITY` for identical images).
    pub psnr: f64,
    /// Mean LDR-FLIP (0 = identical; lower is better).
    pub flip: f32,
}

/// Compares a test image with a reference (PSNR on the 8-bit RGB values, LDR-FLIP
/// at 67 pixels per degree).
///
/// # Errors
/// [`Error::Metrics`] when the sizes differ or an image is empty.
pub fn compare(reference: &Rendered, test: &Rendered) -> Result<Comparison> {
    let (a, b) = (reference.to_image(), test.to_image());
    Ok(Comparison {
        psnr: metrics::psnr(&a, &b)?,
        flip: metrics::flip(&a, &b)?.mean,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_margin_is_the_builders() {
        assert_eq!(DEFAULT_MARGIN, BuildSettings::default().margin);
    }

    #[test]
    fn layer_errors_convert_and_keep_their_message() {
        let e: Error = load_mesh("/nonexistent/sdfmo/x.obj").unwrap_err();
        assert!(matches!(e, Error::Mesh(_)));
        assert!(e.to_string().contains("x.obj"), "{e}");
        let e = load_octree("/nonexistent/sdfmo/x.smo").unwrap_err();
        assert!(matches!(e, Error::Format(_)));
    }
}
