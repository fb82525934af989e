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
//! | `gpu` | `sdfmo-gpu` | the same kernel in WGSL, rendering on a GPU (a backend of [`render`]; feature `gpu`) |
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
//! One entry per step, with the paper's defaults (load → build → save/load → render →
//! compare): [`load_mesh`], [`build_octree`] (every setting, progress, cancellation and levels
//! of detail on [`BuildRequest`]), [`save_octree`], [`load_octree`] (a file of either kind),
//! and [`Renderer`] (CPU or GPU, octree files or the mesh reference, on [`RenderSettings`]).
//! The libraries run on the caller's rayon pool: `install` one to choose the thread count.
//!
//! ```
//! use sdf_multioctree::{build_octree, compare, demo_mesh, load_octree, paper_views, save_octree};
//! use sdf_multioctree::{octree_distance, save_png, Device, LevelRequest, Renderer};
//! use sdf_multioctree::{Method, Mode, RenderSettings, Vec3}; // Vec3 is glam's (`sdf_multioctree::glam`)
//!
//! let mesh = demo_mesh(); // or sdf_multioctree::load_mesh("part.stl")?
//! let (octree, stats) = build_octree(&mesh, 5, Method::Multi { max_voxels: 8 })?;
//! let path = std::env::temp_dir().join(format!("sdfmo-doc-{}.smo", std::process::id()));
//! save_octree(&octree, &path)?;
//! let file = load_octree(&path)?.file; // one octree, or levels of detail
//! assert_eq!(file.finest().byte_size(), stats.bytes);
//!
//! let camera = &paper_views(64)[0];
//! let lambert = RenderSettings::new(Mode::Lambert);
//! let mut renderer = Renderer::new(Device::Cpu)?;
//! let reference = renderer.prepare_mesh(&mesh)?.render(camera, &lambert)?; // same camera and shading
//! let image = renderer.prepare(&file, LevelRequest::Finest)?.render(camera, &lambert)?;
//! let quality = compare(&reference, &image)?;
//! assert!(quality.psnr > 10.0 && quality.flip < 0.5);
//!
//! // Only hit or miss: no normals.
//! let mask = renderer.prepare(&file, LevelRequest::Finest)?.render(camera, &RenderSettings::new(Mode::Mask))?;
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
/// Crate `sdfmo-gpu`: the tracing kernel in WGSL and wgpu renders, a backend of [`render`]
/// (its camera, settings and image); [`Renderer`] chooses the device. Feature `gpu`.
#[cfg(feature = "gpu")]
pub mod gpu {
    #[doc(inline)]
    pub use sdfmo_gpu::*;
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

use distance::{MeshDistance, SignMode};
use render::MeshScene;

// The types and functions the high-level API takes and returns, at the root so that a caller
// of these functions (and the examples) needs no layer path.
pub use build::{BuildRequest, BuildSettings, BuildStats, Method};
pub use format::{PackedOctree, SmoFile, SmoPrefix};
pub use mesh::TriMesh;
pub use render::{save_png, Camera, LevelRequest, Mode, RenderSettings, Rendered};

/// Declares [`Error`], one variant per layer with the prefix its message gets, with its
/// `Display`, `source` (the layer error's own source: the layer's message is already shown)
/// and a `From` per layer error.
macro_rules! layer_errors {
    ($($(#[doc = $doc:literal])* $(#[cfg($cfg:meta)])* $variant:ident($ty:ty) => $prefix:literal,)*) => {
        /// An error of the high-level API: the layer's own error, one variant per layer.
        #[derive(Debug)]
        #[non_exhaustive]
        pub enum Error {
            $($(#[doc = $doc])* $(#[cfg($cfg)])* $variant($ty),)*
        }

        impl fmt::Display for Error {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                match self {
                    $($(#[cfg($cfg)])* Error::$variant(e) => write!(f, concat!($prefix, ": {}"), e),)*
                }
            }
        }

        impl std::error::Error for Error {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                match self {
                    $($(#[cfg($cfg)])* Error::$variant(e) => e.source(),)*
                }
            }
        }

        $($(#[cfg($cfg)])* impl From<$ty> for Error {
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
    /// Opening a GPU or rendering on it ([`Device::Gpu`]): no adapter, a file over the
    /// adapter's limits, a device error. Feature `gpu`.
    #[cfg(feature = "gpu")]
    Gpu(gpu::GpuError) => "GPU",
    /// Comparing images.
    Metrics(metrics::MetricsError) => "metrics",
);

/// Result of the high-level API.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The message of an error and its sources on one line, joined with `: `, a source whose text
/// the line already holds left out: what the front-ends show (Python's exception messages, the
/// harness's recorded failures) when they do not print the chain themselves.
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(inner) = source {
        let text = inner.to_string();
        if !s.contains(&text) {
            s.push_str(": ");
            s.push_str(&text);
        }
        source = inner.source();
    }
    s
}

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
/// [`DEFAULT_MARGIN`]) at `depth` with `method`, 8-bit corners and automatic sign, on the
/// caller's rayon pool. [`BuildRequest`] takes every setting ([`BuildSettings`]), a memory
/// budget, progress, cancellation, and builds levels of detail:
///
/// ```
/// use sdf_multioctree::{demo_mesh, BuildRequest, BuildSettings, Method};
/// let settings = BuildSettings::new(5, Method::Multi { max_voxels: 8 });
/// let (levels, stats) = BuildRequest::new(&demo_mesh(), settings).levels(3)?;
/// assert_eq!((levels.coarsest(), levels.depth(), stats.len()), (3, 5, 3));
/// # Ok::<(), sdf_multioctree::Error>(())
/// ```
///
/// # Errors
/// [`Error::Build`] for an invalid depth or voxel cap, or a mesh the builder cannot use.
pub fn build_octree(
    mesh: &TriMesh,
    depth: u8,
    method: Method,
) -> Result<(PackedOctree, BuildStats)> {
    let settings = BuildSettings::new(depth, method).with_margin(DEFAULT_MARGIN);
    Ok(build::build(mesh, &settings)?)
}

/// Loads a `.smo` file of either kind, chosen by its header: one octree (version 1.x) or
/// levels of detail (version 2.0, `sdfmo build --lod`, [`BuildRequest::levels`]), validating
/// it: the whole file, or a file with levels cut where a level ends (a download in progress,
/// `head -c`). Returns the levels it holds ([`SmoPrefix::file`], to draw with a [`Renderer`])
/// and those of the whole file ([`SmoPrefix::declared`]; [`SmoPrefix::is_complete`] says
/// whether all are held).
///
/// ```
/// use sdf_multioctree::{demo_mesh, load_octree, paper_views, BuildRequest, BuildSettings};
/// use sdf_multioctree::{Device, Error, LevelRequest, Method, Mode, Renderer, RenderSettings, SmoFile};
///
/// // Levels 3 to 5 of the demo part in one file, cut where level 4 ends.
/// let settings = BuildSettings::new(5, Method::default());
/// let (lod, _) = BuildRequest::new(&demo_mesh(), settings).levels(3)?;
/// let cut = lod.entries()[1].end() as usize;
/// let path = std::env::temp_dir().join(format!("sdfmo-doc-levels-{}.smo", std::process::id()));
/// std::fs::write(&path, &lod.to_bytes()[..cut]).unwrap();
///
/// let data = load_octree(&path)?;
/// assert_eq!((data.held(), data.declared), ((3, 4), (3, 5)));
/// let camera = &paper_views(32)[0];
/// let (depth, mask) = (RenderSettings::new(Mode::Depth), RenderSettings::new(Mode::Mask));
/// let mut renderer = Renderer::new(Device::Cpu)?;
/// // A level is that level's octree; the default is the finest held.
/// let level_3 = renderer.prepare(&data.file, LevelRequest::Level(3))?.render(camera, &depth)?;
/// let alone = SmoFile::Octree(lod.levels()[0].clone());
/// let alone = renderer.prepare(&alone, LevelRequest::Finest)?.render(camera, &depth)?;
/// assert_eq!(level_3.rgb, alone.rgb);
/// let finest = renderer.prepare(&data.file, LevelRequest::Finest)?.render(camera, &mask)?;
/// // Each ray at the coarsest level held whose voxels stay under 2 pixels.
/// let by_error = renderer.prepare(&data.file, LevelRequest::PixelError(2.0))?.render(camera, &mask)?;
/// assert!(finest.counters.hits > 0 && by_error.counters.hits > 0);
/// // Level 5 is not in the prefix: the error names the levels held.
/// let e = renderer.prepare(&data.file, LevelRequest::Level(5)).unwrap_err();
/// assert!(matches!(e, Error::Render(_)) && e.to_string().contains("levels 3..=4"), "{e}");
/// # std::fs::remove_file(&path).ok();
/// # Ok::<(), sdf_multioctree::Error>(())
/// ```
///
/// # Errors
/// [`Error::Format`] for an unreadable, truncated, corrupt or hostile file, and for one cut
/// anywhere but where a level ends ([`format::FormatError::CutInsideLevel`], or `Truncated`
/// before the coarsest level's end or in a file without levels).
pub fn load_octree(path: impl AsRef<Path>) -> Result<SmoPrefix> {
    Ok(SmoFile::load_prefix(path.as_ref(), format::MAX_FILE_SIZE)?)
}

/// Where a [`Renderer`] traces its rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Device {
    /// The CPU kernel (`sdfmo-trace`) on the caller's rayon pool: every mode, shadows and
    /// occlusion, the source mesh too ([`Renderer::prepare_mesh`]).
    #[default]
    Cpu,
    /// The WGSL kernel (crate `sdfmo-gpu`, feature `gpu`) on the first GPU adapter wgpu finds
    /// (`WGPU_ADAPTER_NAME` picks one): primary rays of octree files only (shadows, occlusion
    /// and the mesh reference are refused). Its images agree with the CPU's to a few ulps of the hit distance,
    /// not bit for bit (`crates/sdfmo-gpu/tests/match_cpu.rs` states the tolerances).
    Gpu,
}

impl Device {
    /// `"cpu"` or `"gpu"`.
    pub fn name(self) -> &'static str {
        match self {
            Device::Cpu => "cpu",
            Device::Gpu => "gpu",
        }
    }
}

/// The render entry of `.smo` files on either device: the CPU renderer, or a GPU opened once
/// (adapter and compiled kernel) for any number of files and views. The same camera, settings,
/// level request and image type ([`render`]'s) on both; the command line's `sdfmo render
/// --device` and Python's `Octree.render(device=...)` go through it.
///
/// ```
/// use sdf_multioctree::{build_octree, demo_mesh, paper_views, Device, LevelRequest};
/// use sdf_multioctree::{Method, Mode, Renderer, SmoFile};
/// use sdf_multioctree::render::RenderSettings;
///
/// let (octree, _) = build_octree(&demo_mesh(), 5, Method::Multi { max_voxels: 8 })?;
/// let file = SmoFile::Octree(octree);
/// let camera = &paper_views(32)[0];
/// let settings = RenderSettings::new(Mode::Depth);
/// let cpu = Renderer::new(Device::Cpu)?.prepare(&file, LevelRequest::Finest)?.render(camera, &settings)?;
/// // A typed error, never a panic, without an adapter (or without the `gpu` feature).
/// match Renderer::new(Device::Gpu) {
///     Ok(mut gpu) => {
///         let image = gpu.prepare(&file, LevelRequest::Finest)?.render(camera, &settings)?;
///         assert!(image.kernel_ms.is_some() && image.counters.rays == cpu.counters.rays);
///     }
///     Err(e) => eprintln!("no GPU: {e}"),
/// }
/// # Ok::<(), sdf_multioctree::Error>(())
/// ```
#[derive(Debug)]
pub struct Renderer {
    /// The GPU, for [`Device::Gpu`].
    #[cfg(feature = "gpu")]
    gpu: Option<gpu::GpuRenderer>,
}

impl Renderer {
    /// A renderer on `device`: for [`Device::Gpu`] opens the adapter and compiles the kernel.
    ///
    /// # Errors
    /// For [`Device::Gpu`]: `Error::Gpu` (`GpuError::NoAdapter`) when there is no GPU adapter
    /// or it refuses a device; [`Error::Render`] when this build has no GPU backend (the
    /// `gpu` feature is off).
    pub fn new(device: Device) -> Result<Renderer> {
        #[cfg(feature = "gpu")]
        let gpu = match device {
            Device::Cpu => None,
            Device::Gpu => Some(gpu::GpuRenderer::new()?),
        };
        #[cfg(not(feature = "gpu"))]
        if device == Device::Gpu {
            return Err(Error::Render(render::RenderError::InvalidSettings(
                "no GPU backend: sdf-multioctree was built without its `gpu` feature".into(),
            )));
        }
        Ok(Renderer {
            #[cfg(feature = "gpu")]
            gpu,
        })
    }

    /// The device it renders on.
    pub fn device(&self) -> Device {
        #[cfg(feature = "gpu")]
        if self.gpu.is_some() {
            return Device::Gpu;
        }
        Device::Cpu
    }

    /// `"cpu"`, or the GPU adapter's name.
    pub fn device_name(&self) -> &str {
        #[cfg(feature = "gpu")]
        if let Some(g) = &self.gpu {
            return g.adapter_name();
        }
        "cpu"
    }

    /// The GPU, for [`Device::Gpu`]: its adapter, timing ([`gpu::GpuRenderer::timing`]),
    /// limits.
    #[cfg(feature = "gpu")]
    pub fn gpu(&self) -> Option<&gpu::GpuRenderer> {
        self.gpu.as_ref()
    }

    /// The longest `.smo` file this device renders: [`format::MAX_FILE_SIZE`] on the CPU, the
    /// adapter's limit on a GPU (`GpuRenderer::max_file_bytes`). Check a file's length against
    /// it before reading it.
    pub fn max_file_bytes(&self) -> u64 {
        #[cfg(feature = "gpu")]
        if let Some(g) = &self.gpu {
            return g.max_file_bytes();
        }
        format::MAX_FILE_SIZE
    }

    /// Prepares `file` drawn as `level` asks ([`LevelRequest`]) for renders: checks the
    /// request, and on a GPU uploads what it draws (the level's octree, every level for a
    /// pixel error, or a 3.0 file's bytes as they are) once for every view. A 3.0 file
    /// ([`SmoFile::Bricks`]) is traced in place on either device: nothing is expanded to 1.x.
    ///
    /// # Errors
    /// [`Error::Render`] for a level the file does not hold or a pixel error it cannot draw
    /// ([`LevelRequest::scene`]); on a GPU, `Error::Gpu` when the upload fails (a file over
    /// the adapter's limits).
    pub fn prepare<'a>(
        &'a mut self,
        file: &'a SmoFile,
        level: LevelRequest,
    ) -> Result<Prepared<'a>> {
        // Which level is drawn does not depend on the camera (only a pixel's angle does).
        let _scene = level.scene(file, &Camera::default())?;
        #[cfg(feature = "gpu")]
        let gpu = match self.gpu.as_mut() {
            None => None,
            Some(g) => {
                let upload = match _scene {
                    render::LevelScene::Level(s) => Upload::Octree(g.upload(s.0)?),
                    // A 3.0 file's bytes as they are: the kernel traces the bricks.
                    render::LevelScene::Bricks(s) => Upload::Octree(g.upload_bricks(s.0)?),
                    render::LevelScene::PixelError(s) => Upload::Levels(g.upload_lod(s.lod)?),
                };
                Some((g, upload))
            }
        };
        Ok(Prepared {
            source: Source::File { file, level },
            #[cfg(feature = "gpu")]
            gpu,
            _renderer: std::marker::PhantomData,
        })
    }

    /// Prepares the source mesh (model units) as the reference image: normalised exactly as
    /// the builder does ([`DEFAULT_MARGIN`], [`mesh_frame`]), the same cameras and shading as
    /// its octrees, face normals. On the CPU only (the GPU kernel traces octrees).
    ///
    /// # Errors
    /// [`Error::Distance`] if the ray queries cannot be prepared; [`Error::Render`] on a GPU.
    pub fn prepare_mesh(&mut self, mesh: &TriMesh) -> Result<Prepared<'_>> {
        if self.device() == Device::Gpu {
            return Err(Error::Render(render::RenderError::InvalidSettings(
                "the mesh reference renders on the CPU (Device::Cpu); the GPU kernel traces octrees"
                    .into(),
            )));
        }
        let (normalized, _) = mesh.normalized(DEFAULT_MARGIN);
        let dist = MeshDistance::new(&normalized, SignMode::Auto)?;
        Ok(Prepared {
            source: Source::Mesh(Box::new(dist)),
            #[cfg(feature = "gpu")]
            gpu: None,
            _renderer: std::marker::PhantomData,
        })
    }
}

/// What a GPU holds of a prepared file.
#[cfg(feature = "gpu")]
#[derive(Debug)]
enum Upload {
    /// The level drawn.
    Octree(gpu::GpuOctree),
    /// Every level, for a pixel error.
    Levels(gpu::GpuLodOctree),
}

/// What a [`Prepared`] draws.
enum Source<'a> {
    /// A `.smo` file, drawn as the request asks.
    File {
        file: &'a SmoFile,
        level: LevelRequest,
    },
    /// The source mesh's ray queries, in the normalised frame.
    Mesh(Box<MeshDistance>),
}

impl fmt::Debug for Source<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Source::File { level, .. } => write!(f, "File({level:?})"),
            Source::Mesh(_) => f.write_str("Mesh"),
        }
    }
}

/// A file or mesh prepared for renders on a [`Renderer`]'s device ([`Renderer::prepare`],
/// [`Renderer::prepare_mesh`]).
#[derive(Debug)]
pub struct Prepared<'a> {
    source: Source<'a>,
    /// The GPU and what it holds of the file (`None` on the CPU).
    #[cfg(feature = "gpu")]
    gpu: Option<(&'a mut gpu::GpuRenderer, Upload)>,
    /// Borrows the renderer with or without the `gpu` feature.
    _renderer: std::marker::PhantomData<&'a mut Renderer>,
}

impl Prepared<'_> {
    /// Renders what was prepared seen by `camera` with `settings` ([`render::render`]'s
    /// camera, settings and image, on either device; on the CPU on the caller's rayon pool).
    ///
    /// # Errors
    /// [`Error::Render`] for an invalid camera or settings; on a GPU, `Error::Gpu` for
    /// settings it does not render (shadows, occlusion), a device error or a time-out.
    pub fn render(&mut self, camera: &Camera, settings: &RenderSettings) -> Result<Rendered> {
        self.render_with(camera, settings, None, None)
    }

    /// [`Prepared::render`] reporting its progress (the fraction of tiles done, from the
    /// worker threads; see [`render::RenderRequest::progress`]) and stopping with
    /// [`render::RenderError::Cancelled`] when `cancel` returns true (asked before each tile).
    /// A GPU frame is one dispatch: neither is called there.
    ///
    /// # Errors
    /// Those of [`Prepared::render`], and [`render::RenderError::Cancelled`].
    pub fn render_with(
        &mut self,
        camera: &Camera,
        settings: &RenderSettings,
        progress: Option<&(dyn Fn(f32) + Sync)>,
        cancel: Option<&(dyn Fn() -> bool + Sync)>,
    ) -> Result<Rendered> {
        let (file, level) = match &self.source {
            Source::File { file, level } => (*file, *level),
            Source::Mesh(dist) => {
                return on_cpu(&MeshScene(dist), camera, settings, progress, cancel)
            }
        };
        let scene = level.scene(file, camera)?;
        #[cfg(feature = "gpu")]
        if let Some((g, upload)) = self.gpu.as_mut() {
            return Ok(match upload {
                Upload::Octree(o) => g.render(o, camera, settings)?,
                Upload::Levels(l) => {
                    // `prepare` uploaded every level for a pixel error: this camera's choice.
                    let render::LevelScene::PixelError(s) = scene else {
                        return Err(render::RenderError::InvalidSettings(
                            "a pixel-error request drew one level".into(),
                        )
                        .into());
                    };
                    g.render_lod(l, s.choice, camera, settings)?
                }
            });
        }
        match scene {
            render::LevelScene::Level(s) => on_cpu(&s, camera, settings, progress, cancel),
            render::LevelScene::Bricks(s) => on_cpu(&s, camera, settings, progress, cancel),
            render::LevelScene::PixelError(s) => on_cpu(&s, camera, settings, progress, cancel),
        }
    }
}

/// `scene` rendered on the CPU with the optional progress and cancellation.
fn on_cpu<T: render::Traceable>(
    scene: &T,
    camera: &Camera,
    settings: &RenderSettings,
    progress: Option<&(dyn Fn(f32) + Sync)>,
    cancel: Option<&(dyn Fn() -> bool + Sync)>,
) -> Result<Rendered> {
    let mut request = render::RenderRequest::new(scene, camera, settings);
    if let Some(progress) = progress {
        request = request.progress(progress);
    }
    if let Some(cancel) = cancel {
        request = request.cancel(cancel);
    }
    Ok(request.render()?)
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
pub fn octree_distance<O: OctreeRef>(octree: O, point: Vec3) -> f32 {
    let frame = octree_frame(octree);
    match octree.stored_distance(frame.point_to_normalized(point.as_dvec3())) {
        Some(d) => frame.length_to_model(d),
        None => f32::NAN,
    }
}

/// The octree's frame: model units (the mesh's own) ↔ the normalised root cube `[-1, 1]³` the
/// octree and the renderer work in, from the normalisation stored in the file
/// ([`format::OctreeMeta`]), of any layout ([`OctreeRef`]).
pub fn octree_frame<O: OctreeRef>(octree: O) -> mesh::Normalization {
    let meta = octree.meta();
    mesh::Normalization {
        center: meta.center,
        scale: meta.scale,
    }
}

/// The frame of a loaded `.smo` file of any kind ([`octree_frame`] of its finest level: every
/// level of a file shares one normalisation).
pub fn file_frame(file: &SmoFile) -> mesh::Normalization {
    octree_frame(file.finest())
}

/// One octree as [`octree_frame`] and [`octree_distance`] take it, in any layout: a 1.x
/// octree (`&`[`PackedOctree`], or any `&`[`format::Octree`]), a 3.0 one
/// (`&`[`format::BrickOctree`]), or a level of a loaded file ([`format::SmoLevel`], what
/// [`SmoFile::finest`] and [`SmoFile::level`] give).
///
/// ```
/// use sdf_multioctree::format::BrickOctree;
/// use sdf_multioctree::{build_octree, demo_mesh, octree_distance, Method, SmoFile};
///
/// let mesh = demo_mesh();
/// let (octree, _) = build_octree(&mesh, 6, Method::Multi { max_voxels: 8 })?;
/// let bricks = BrickOctree::encode(&octree)?;
/// let file = SmoFile::from_bytes(bricks.as_bytes())?; // a 3.0 file stays 3.0
/// for p in mesh.positions().iter().step_by(50) {
///     let d = octree_distance(&octree, *p);
///     assert_eq!(d.to_bits(), octree_distance(&bricks, *p).to_bits());
///     assert_eq!(d.to_bits(), octree_distance(file.finest(), *p).to_bits());
/// }
/// # Ok::<(), sdf_multioctree::Error>(())
/// ```
pub trait OctreeRef: Copy {
    /// Depth, quantisation and normalisation transform.
    fn meta(&self) -> &format::OctreeMeta;
    /// The stored signed distance at `p` (normalised frame; [`trace::distance_at`]), `None`
    /// where no voxel holds `p`.
    fn stored_distance(&self, p: Vec3) -> Option<f32>;
}

/// Both layouts the tracers read ([`format::TracedOctree`]: the 1.x `Octree`, the 3.0
/// `BrickOctree`).
impl<O: format::TracedOctree> OctreeRef for &O {
    fn meta(&self) -> &format::OctreeMeta {
        format::TracedOctree::meta(*self)
    }

    fn stored_distance(&self, p: Vec3) -> Option<f32> {
        trace::distance_at(*self, p).map(|s| s.distance)
    }
}

impl OctreeRef for format::SmoLevel<'_> {
    fn meta(&self) -> &format::OctreeMeta {
        format::SmoLevel::meta(self)
    }

    fn stored_distance(&self, p: Vec3) -> Option<f32> {
        match *self {
            format::SmoLevel::Octree(o) => o.stored_distance(p),
            format::SmoLevel::Bricks(b) => b.stored_distance(p),
        }
    }
}

/// The mesh's frame: model units ↔ the normalised root cube, exactly as [`build_octree`],
/// [`Renderer::prepare_mesh`] and the command line normalise it ([`DEFAULT_MARGIN`]); the frame of every
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
/// use sdf_multioctree::{paper_views, Device, LevelRequest, Method, Mode, Renderer};
/// use sdf_multioctree::{RenderSettings, SmoFile, Vec3};
///
/// let mesh = demo_mesh();
/// let (octree, _) = build_octree(&mesh, 5, Method::Multi { max_voxels: 8 })?;
/// let mut camera = paper_views(32)[0];
/// camera.eye = Vec3::new(0.0, 0.0, 40.0); // model units: 40 units in front of the part
/// camera.target = mesh.bounds().center();
/// let camera = camera_from_model(&octree_frame(&octree), &camera);
/// let file = SmoFile::Octree(octree);
/// let image = Renderer::new(Device::Cpu)?
///     .prepare(&file, LevelRequest::Finest)?
///     .render(&camera, &RenderSettings::new(Mode::Mask))?;
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

/// `camera` (a paper view, say) with the parts given replaced: `eye` and `target` in model units
/// mapped through `frame` (as [`camera_from_model`] maps them), or in the normalised frame
/// where `frame` is `None`, and the vertical field of view `fov_y_deg`. The command line's
/// `--eye`, `--target`, `--fov` (`--normalized`) and Python's `RenderOptions` make their one
/// camera with it, so that one eye gives one image in every front-end.
///
/// ```
/// use sdf_multioctree::{demo_mesh, mesh_frame, paper_views, placed_camera, Vec3};
///
/// let frame = mesh_frame(&demo_mesh());
/// let view = paper_views(32)[0];
/// let far = placed_camera(view, Some([0.0, 0.0, 40.0]), None, Some(30.0), Some(&frame));
/// assert_eq!(far.eye, frame.point_to_normalized(Vec3::new(0.0, 0.0, 40.0).as_dvec3()));
/// assert_eq!((far.target, far.fov_y_deg), (view.target, 30.0));
/// let near = placed_camera(view, Some([0.0, 0.0, 2.0]), None, None, None);
/// assert_eq!((near.eye, near.fov_y_deg), (Vec3::new(0.0, 0.0, 2.0), view.fov_y_deg));
/// ```
pub fn placed_camera(
    camera: Camera,
    eye: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    fov_y_deg: Option<f32>,
    frame: Option<&mesh::Normalization>,
) -> Camera {
    let place = |p: [f32; 3]| match frame {
        None => Vec3::from_array(p),
        Some(f) => f.point_to_normalized(Vec3::from_array(p).as_dvec3()),
    };
    Camera {
        eye: eye.map_or(camera.eye, place),
        target: target.map_or(camera.target, place),
        fov_y_deg: fov_y_deg.unwrap_or(camera.fov_y_deg),
        ..camera
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

    /// A [`Renderer`] draws each level of a file with levels as that level's octree alone (the
    /// CLI's `render --lod` path), from the whole file and from each prefix cut where a level
    /// ends; a cut inside a level is refused.
    #[test]
    fn each_level_of_every_level_boundary_prefix_renders_as_that_level_alone() {
        let settings = BuildSettings::new(5, Method::default());
        let (lod, _) = BuildRequest::new(&demo_mesh(), settings).levels(3).unwrap();
        let bytes = lod.to_bytes();
        let camera = paper_views(24)[1];
        let mut renderer = Renderer::new(Device::Cpu).unwrap();
        let mut draw = |file: &SmoFile, level, mode| {
            renderer
                .prepare(file, level)
                .and_then(|mut p| p.render(&camera, &RenderSettings::new(mode)))
        };
        let alone = |k: u8| SmoFile::Octree(lod.level(k).unwrap().clone());
        let dir = std::env::temp_dir().join(format!("sdfmo-facade-levels-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (i, e) in lod.entries().iter().enumerate() {
            let path = dir.join(format!("cut{i}.smo"));
            std::fs::write(&path, &bytes[..e.end() as usize]).unwrap();
            let data = load_octree(&path).unwrap();
            assert_eq!((data.held(), data.declared), ((3, e.level), (3, 5)));
            assert_eq!(data.is_complete(), e.level == 5);
            for k in 3..=e.level {
                let a = draw(&data.file, LevelRequest::Level(k), Mode::Normal);
                let b = draw(&alone(k), LevelRequest::Finest, Mode::Normal);
                assert_eq!(
                    a.unwrap().rgb,
                    b.unwrap().rgb,
                    "prefix to level {}, level {k}",
                    e.level
                );
            }
            let finest = draw(&data.file, LevelRequest::Finest, Mode::Depth);
            let b = draw(&alone(e.level), LevelRequest::Finest, Mode::Depth);
            assert_eq!(finest.unwrap().rgb, b.unwrap().rgb);
            let missing = draw(&data.file, LevelRequest::Level(6), Mode::Mask);
            assert!(matches!(missing, Err(Error::Render(_))));
            if e.level < 5 {
                std::fs::write(&path, &bytes[..e.end() as usize + 9]).unwrap();
                let cut = load_octree(&path).unwrap_err();
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

    /// The mesh reference is the source mesh normalised as the builder does: its image and
    /// the octree's agree closely, and the GPU refuses it with a typed error (no panic).
    #[test]
    fn the_mesh_reference_renders_beside_its_octree() {
        let mesh = demo_mesh();
        let (octree, _) = build_octree(&mesh, 6, Method::default()).unwrap();
        let file = SmoFile::Octree(octree);
        let camera = paper_views(48)[2];
        let settings = RenderSettings::new(Mode::Lambert);
        let mut renderer = Renderer::new(Device::Cpu).unwrap();
        let reference = renderer
            .prepare_mesh(&mesh)
            .unwrap()
            .render(&camera, &settings)
            .unwrap();
        let image = renderer
            .prepare(&file, LevelRequest::Finest)
            .unwrap()
            .render(&camera, &settings)
            .unwrap();
        assert!(reference.counters.hits > 0);
        assert!(compare(&reference, &image).unwrap().psnr > 15.0);
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
