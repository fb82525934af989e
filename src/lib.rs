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
//! `glam`, whose types appear in the signatures, is re-exported as `sdf_multioctree::glam` (and [`Vec3`]
//! at the root): a dependent crate needs no `glam` dependency of its own.
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
//! use sdf_multioctree::{octree_distance, render_mesh, render_octree, save_octree, save_png};
//! use sdf_multioctree::{Method, Mode, Vec3}; // Vec3 is glam's (`sdf_multioctree::glam`)
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
//!
//! // The stored signed distance in model units: about 0 on the surface, NaN where the octree
//! // stores nothing (away from the surface).
//! let vertex: Vec3 = mesh.positions()[0];
//! assert!(octree_distance(&octree, vertex).abs() < 0.05);
//! assert!(octree_distance(&octree, vertex + Vec3::splat(100.0)).is_nan());
//! let png = path.with_extension("png");
//! save_png(&mask, &png)?;
//! # std::fs::remove_file(&path).ok();
//! # std::fs::remove_file(&png).ok();
//! # Ok::<(), sdf_multioctree::Error>(())
//! ```
#![deny(missing_docs)]

/// Crate `sdfmo-build`: the SVO baseline and the multi-octree builder.
pub mod build {
    #[doc(inline)]
    pub use sdfmo_build::*;
}
/// Crate `sdfmo-distance`: exact signed distance, closest points, ray hits on a mesh.
pub mod distance {
    #[doc(inline)]
    pub use sdfmo_distance::*;
}
/// Crate `sdfmo-format`: the packed octree and its `.smo` file.
pub mod format {
    #[doc(inline)]
    pub use sdfmo_format::*;
}
/// Crate `sdfmo-io`: atomic writes, bounded reads, the deterministic generator.
pub mod io {
    #[doc(inline)]
    pub use sdfmo_io::*;
}
/// Crate `sdfmo-mesh`: load OBJ / glTF / STL, clean, normalise, topology, procedural parts.
pub mod mesh {
    #[doc(inline)]
    pub use sdfmo_mesh::*;
}
/// Crate `sdfmo-metrics`: PSNR and FLIP.
pub mod metrics {
    #[doc(inline)]
    pub use sdfmo_metrics::*;
}
/// Crate `sdfmo-render`: cameras, render modes, PNG/EXR, mesh reference images.
pub mod render {
    #[doc(inline)]
    pub use sdfmo_render::*;
}
/// Crate `sdfmo-trace`: ray vs packed octree, distance queries.
pub mod trace {
    #[doc(inline)]
    pub use sdfmo_trace::*;
}

/// The vector maths in this crate's signatures ([`Camera::new`], [`octree_distance`],
/// [`trace::distance_at`]): the `glam` version the layers are built with, so a caller needs no
/// `glam` dependency of its own (`sdf_multioctree::glam::Vec3`).
pub use glam;
/// A point or direction (`glam::Vec3`, f32).
#[doc(no_inline)]
pub use glam::Vec3;

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
pub use format::{PackedOctree, SmoFile, SmoPrefix};
pub use mesh::TriMesh;
pub use render::{save_png, Camera, LevelRequest, Mode, Rendered};

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

/// Loads a `.smo` file of either kind, one octree or levels of detail (`sdfmo build --lod`,
/// [`build::build_lod`]), validating it: the whole file, or a file with levels cut where a
/// level ends (a download in progress, `head -c`). Returns the levels it holds
/// ([`SmoPrefix::file`], to draw with [`render_levels`]) and those of the whole file
/// ([`SmoPrefix::declared`]; [`SmoPrefix::is_complete`] says whether all are held).
///
/// ```
/// use sdf_multioctree::build::{build_lod, BuildSettings};
/// use sdf_multioctree::{demo_mesh, load_levels, paper_views, render_levels, render_octree};
/// use sdf_multioctree::{Error, LevelRequest, Method, Mode};
///
/// // Levels 3 to 5 of the demo part in one file, cut where level 4 ends.
/// let settings = BuildSettings { depth: 5, coarsest_level: Some(3), ..BuildSettings::default() };
/// let (lod, _) = build_lod(&demo_mesh(), &settings, None, None, &|| false)?;
/// let cut = lod.entries()[1].end() as usize;
/// let path = std::env::temp_dir().join(format!("sdfmo-doc-levels-{}.smo", std::process::id()));
/// std::fs::write(&path, &lod.to_bytes()[..cut]).unwrap();
///
/// let data = load_levels(&path)?;
/// assert_eq!((data.held(), data.declared), ((3, 4), (3, 5)));
/// let camera = &paper_views(32)[0];
/// // A level is that level's octree; the default is the finest held.
/// let level_3 = render_levels(&data.file, camera, Mode::Depth, LevelRequest::Level(3))?;
/// let alone = render_octree(&lod.levels()[0], camera, Mode::Depth)?;
/// assert_eq!(level_3.rgb, alone.rgb);
/// let finest = render_levels(&data.file, camera, Mode::Mask, LevelRequest::Finest)?;
/// // Each ray at the coarsest level held whose voxels stay under 2 pixels.
/// let by_error = render_levels(&data.file, camera, Mode::Mask, LevelRequest::PixelError(2.0))?;
/// assert!(finest.counters.hits > 0 && by_error.counters.hits > 0);
/// // Level 5 is not in the prefix: the error names the levels held.
/// let e = render_levels(&data.file, camera, Mode::Mask, LevelRequest::Level(5)).unwrap_err();
/// assert!(matches!(e, Error::Render(_)) && e.to_string().contains("levels 3..=4"), "{e}");
/// # std::fs::remove_file(&path).ok();
/// # Ok::<(), sdf_multioctree::Error>(())
/// ```
///
/// # Errors
/// [`Error::Format`] for an unreadable, corrupt or hostile file, and for one cut anywhere but
/// where a level ends ([`format::FormatError::CutInsideLevel`], or `Truncated` before the
/// coarsest level's end or in a file without levels).
pub fn load_levels(path: impl AsRef<Path>) -> Result<SmoPrefix> {
    Ok(SmoFile::load_prefix(path.as_ref(), format::MAX_FILE_SIZE)?)
}

/// Ray traces the levels of a `.smo` file ([`load_levels`]) in `mode` on all cores: `level`
/// picks what is drawn ([`LevelRequest`]: the finest level held, one level, or each ray's level
/// by pixel error), the rule `sdfmo render --lod`/`--pixel-error` and Python's `lod=` and
/// `pixel_error=` follow. The camera is in the normalised frame (see [`camera_from_model`]
/// with `octree_frame(file.finest())` for one in model units). Example: [`load_levels`].
///
/// # Errors
/// [`Error::Render`] for an invalid camera, a level the file does not hold (naming those it
/// holds), or a pixel error on a file without levels or not finite and > 0.
pub fn render_levels(
    file: &SmoFile,
    camera: &Camera,
    mode: Mode,
    level: LevelRequest,
) -> Result<Rendered> {
    let settings = RenderSettings::new(mode);
    Ok(match level.scene(file, camera)? {
        render::LevelScene::Level(s) => render::render(&s, camera, &settings)?,
        render::LevelScene::PixelError(s) => render::render(&s, camera, &settings)?,
    })
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

/// The signed distance the octree stores at `point`, both in model units (the units of the
/// mesh it was built from): negative inside, `|F| ≥ 0` in a surface (thin) voxel, which has no
/// inside. It is the field the renderer intersects: within a leaf cell of the surface it is
/// the trilinear interpolant of the leaf's voxels (their minimum in a multi-voxel leaf), whose
/// error against the mesh's exact distance is bounded in [`trace::distance_at`].
///
/// **Away from the surface it is `f32::NAN`**: outside the root cube, and in every cell the
/// builder stored no leaf for. The file holds no field there (only cells the surface passes
/// through are stored) and no inside/outside either, so neither a sign nor a value exists to
/// return; any finite number would be a guess that a collision or proximity test could take
/// for an answer, whereas NaN fails every comparison (`d < r` is false) and shows in any
/// arithmetic it enters. Test with `f32::is_nan`. (What the tree does know there is that the
/// stored surface is outside the empty cell: [`trace::distance_at`] and
/// [`trace::occupied_bounds`] give the cells and bounds for coarser questions.)
///
/// The point maps to the octree's frame as `(point − center) · scale` with the normalisation
/// stored in the file ([`format::OctreeMeta`]) and the distance back by `1 / scale`.
///
/// ```
/// use sdf_multioctree::{build_octree, demo_mesh, octree_distance, Method, Vec3};
///
/// let mesh = demo_mesh();
/// let (octree, _) = build_octree(&mesh, 6, Method::Multi { max_voxels: 8 })?;
/// // A vertex of the mesh lies on its surface: the stored distance there is about zero.
/// let on_surface = mesh.positions()[0];
/// let d = octree_distance(&octree, on_surface);
/// assert!(d.abs() < 0.05, "{d}");
/// // Far outside the mesh the octree stores nothing.
/// assert!(octree_distance(&octree, Vec3::splat(1e3)).is_nan());
/// # Ok::<(), sdf_multioctree::Error>(())
/// ```
pub fn octree_distance<B: AsRef<[u8]>>(octree: &format::Octree<B>, point: Vec3) -> f32 {
    let frame = octree_frame(octree);
    match trace::distance_at(octree, frame.point_to_normalized(point.as_dvec3())) {
        Some(sample) => frame.length_to_model(sample.distance),
        None => f32::NAN,
    }
}

/// The octree's frame: model units (the mesh's own) ↔ the normalised root cube `[-1, 1]³` the
/// octree and the renderer work in, from the normalisation stored in the file
/// ([`format::OctreeMeta`]).
pub fn octree_frame<B: AsRef<[u8]>>(octree: &format::Octree<B>) -> mesh::Normalization {
    let meta = octree.meta();
    mesh::Normalization {
        center: meta.center,
        scale: meta.scale,
    }
}

/// The mesh's frame: model units ↔ the normalised root cube, exactly as [`build_octree`],
/// [`render_mesh`] and the command line normalise it ([`DEFAULT_MARGIN`]); the frame of every
/// octree built from it.
pub fn mesh_frame(mesh: &TriMesh) -> mesh::Normalization {
    mesh::Normalization::for_bounds(&mesh.bounds(), DEFAULT_MARGIN)
}

/// `camera` with its eye and target given in model units, moved into `frame`'s normalised frame,
/// where the renderer works (field of view and image size unchanged). The command line's
/// `--eye`/`--target` and Python's `eye=`/`target=` go through this same conversion, so one
/// eye gives one image in every front-end. The paper's views ([`paper_views`]) are defined in
/// the normalised frame already.
///
/// ```
/// use sdf_multioctree::{build_octree, camera_from_model, demo_mesh, octree_frame};
/// use sdf_multioctree::{paper_views, render_octree, Method, Mode, Vec3};
///
/// let mesh = demo_mesh();
/// let (octree, _) = build_octree(&mesh, 5, Method::Multi { max_voxels: 8 })?;
/// let mut camera = paper_views(32)[0];
/// camera.eye = Vec3::new(0.0, 0.0, 40.0); // model units: 40 units in front of the part
/// camera.target = mesh.bounds().center();
/// let image = render_octree(&octree, &camera_from_model(&octree_frame(&octree), &camera), Mode::Mask)?;
/// assert!(image.counters.hits > 0);
/// # Ok::<(), sdf_multioctree::Error>(())
/// ```
pub fn camera_from_model(frame: &mesh::Normalization, camera: &Camera) -> Camera {
    Camera {
        eye: frame.point_to_normalized(camera.eye.as_dvec3()),
        target: frame.point_to_normalized(camera.target.as_dvec3()),
        ..*camera
    }
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

    /// `render_levels` of each level of a file with levels is `render_octree` of that level
    /// alone (the CLI's `render --lod` path), of the whole file and of each prefix cut where a
    /// level ends; a cut inside a level is refused.
    #[test]
    fn render_levels_draws_each_level_of_every_level_boundary_prefix() {
        let settings = BuildSettings {
            depth: 5,
            coarsest_level: Some(3),
            ..BuildSettings::default()
        };
        let (lod, _) = build::build_lod(&demo_mesh(), &settings, None, None, &|| false).unwrap();
        let bytes = lod.to_bytes();
        let camera = paper_views(24)[1];
        let dir = std::env::temp_dir().join(format!("sdfmo-facade-levels-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (i, e) in lod.entries().iter().enumerate() {
            let path = dir.join(format!("cut{i}.smo"));
            std::fs::write(&path, &bytes[..e.end() as usize]).unwrap();
            let data = load_levels(&path).unwrap();
            assert_eq!((data.held(), data.declared), ((3, e.level), (3, 5)));
            assert_eq!(data.is_complete(), e.level == 5);
            for k in 3..=e.level {
                let a = render_levels(&data.file, &camera, Mode::Normal, LevelRequest::Level(k));
                let b = render_octree(lod.level(k).unwrap(), &camera, Mode::Normal).unwrap();
                assert_eq!(
                    a.unwrap().rgb,
                    b.rgb,
                    "prefix to level {}, level {k}",
                    e.level
                );
            }
            let finest = render_levels(&data.file, &camera, Mode::Depth, LevelRequest::Finest);
            let b = render_octree(lod.level(e.level).unwrap(), &camera, Mode::Depth).unwrap();
            assert_eq!(finest.unwrap().rgb, b.rgb);
            let missing = render_levels(&data.file, &camera, Mode::Mask, LevelRequest::Level(6));
            assert!(matches!(missing, Err(Error::Render(_))));
            if e.level < 5 {
                std::fs::write(&path, &bytes[..e.end() as usize + 9]).unwrap();
                let cut = load_levels(&path).unwrap_err();
                assert!(
                    matches!(
                        cut,
                        Error::Format(format::FormatError::CutInsideLevel { level, .. })
                            if level == e.level + 1
                    ),
                    "{cut}"
                );
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn layer_errors_convert_and_keep_their_message() {
        let e: Error = load_mesh("/nonexistent/sdfmo/x.obj").unwrap_err();
        assert!(matches!(e, Error::Mesh(_)));
        assert!(e.to_string().contains("x.obj"), "{e}");
        let e = load_octree("/nonexistent/sdfmo/x.smo").unwrap_err();
        assert!(matches!(e, Error::Format(_)));
    }

    /// A 20-unit box away from the origin: the distance comes back in the box's units, signed,
    /// within the SVO bound of `trace::distance_at` (a plane: quantisation alone, under 1 % of
    /// the leaf edge of 20/0.95/32 units), and NaN where no leaf is stored.
    #[test]
    fn octree_distance_is_in_model_units_and_nan_away_from_the_surface() {
        let (lo, hi) = (Vec3::new(100.0, 0.0, 0.0), Vec3::new(120.0, 20.0, 20.0));
        let mesh = mesh::procedural::box_mesh(lo, hi);
        let (octree, _) = build_octree(&mesh, 5, Method::Svo).unwrap();
        let leaf_edge = 20.0 / (1.0 - DEFAULT_MARGIN) / 32.0;
        let face = Vec3::new(120.0, 10.0, 10.0);
        // The face's leaf cell spans x ∈ [119.87, 120.53] (normalised [0.9375, 1]).
        for offset in [-0.1, -0.05, 0.0, 0.05, 0.2, 0.4] {
            let d = octree_distance(&octree, face + Vec3::X * offset);
            assert!((d - offset).abs() < 0.01 * leaf_edge, "{offset}: {d}");
        }
        assert!(octree_distance(&octree, Vec3::new(110.0, 10.0, 10.0)).is_nan());
        assert!(octree_distance(&octree, Vec3::splat(1e6)).is_nan());
        assert!(octree_distance(&octree, Vec3::NAN).is_nan());
    }
}
