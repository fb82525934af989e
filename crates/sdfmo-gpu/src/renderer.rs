//! The wgpu side: a device, the compute pipeline of `render.wgsl`, octree uploads, renders.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

use glam::{DVec3, Vec3};
use sdfmo_format::quant::dequant_scale;
use sdfmo_format::{BrickNode, BrickOctree, LodOctree, PackedOctree, PackedOctreeView};
use sdfmo_render::octree::OCCUPIED_LEVELS;
use sdfmo_render::scene::OCCUPIED_PAD;
use sdfmo_render::shading::{light_dir, DepthRange, AMBIENT, LIGHT_INTENSITY};
use sdfmo_render::{
    Camera, CameraFrame, Counters, LodScene, Mode, OctreeScene, RenderError, RenderPlan,
    RenderSettings, Rendered, Traceable,
};
use sdfmo_trace::LevelChoice;
use wgpu::util::DeviceExt;

use crate::shared_struct::shared_struct;
use crate::{
    shader_source, GpuError, Result, BACKGROUND_ENTRY_POINT, ENTRY_POINT, MAX_GPU_BRICKS, SMO_FAR,
    WORKGROUP_SIZE,
};

/// The `mode` code of `SmoRenderParams` in `render.wgsl` (the renderer's [`Mode`]s; shadows
/// and occlusion are CPU options).
fn mode_code(mode: Mode) -> u32 {
    match mode {
        Mode::Mask => 0,
        Mode::Depth => 1,
        Mode::Normal => 2,
        Mode::Lambert => 3,
    }
}

/// The `rays` binding of `render.wgsl` for a camera's frame: every column term
/// ([`CameraFrame::column`]), then every row term ([`CameraFrame::row`]), each as a
/// double-float pair of vec4 rows (hi.xyz, 0), (lo.xyz, 0). The kernel adds and normalises
/// them as [`CameraFrame::direction`] does: the CPU renderer's rays exactly.
fn ray_terms(frame: &CameraFrame) -> Vec<[f32; 4]> {
    let split = |v: DVec3| {
        let hi = v.as_vec3();
        let lo = (v - hi.as_dvec3()).as_vec3();
        [[hi.x, hi.y, hi.z, 0.0], [lo.x, lo.y, lo.z, 0.0]]
    };
    (0..frame.width)
        .flat_map(|px| split(frame.column(px)))
        .chain((0..frame.height).flat_map(|py| split(frame.row(py))))
        .collect()
}

/// The image's tiles of [`WORKGROUP_SIZE`]² pixels as `render.wgsl` lists them (tile (x, y)
/// as `x | y << 16`), row by row: (those to trace, those whose primary rays all miss the
/// `occupied` box, [`CameraFrame::tile_misses_box`], background without tracing). Every tile
/// is traced without a box.
fn tile_lists(frame: &CameraFrame, occupied: Option<(Vec3, Vec3)>) -> (Vec<u32>, Vec<u32>) {
    let (w, h) = (frame.width, frame.height);
    let mut traced = Vec::new();
    let mut culled = Vec::new();
    for ty in 0..h.div_ceil(WORKGROUP_SIZE) {
        for tx in 0..w.div_ceil(WORKGROUP_SIZE) {
            let (x0, y0) = (tx * WORKGROUP_SIZE, ty * WORKGROUP_SIZE);
            let (tw, th) = (WORKGROUP_SIZE.min(w - x0), WORKGROUP_SIZE.min(h - y0));
            let misses =
                occupied.is_some_and(|(lo, hi)| frame.tile_misses_box(x0, y0, tw, th, lo, hi));
            // At most 32768 / 8 tiles per side (sdfmo_render::MAX_IMAGE_SIDE): 16 bits each.
            let tile = tx | ty << 16;
            if misses {
                culled.push(tile);
            } else {
                traced.push(tile);
            }
        }
    }
    (traced, culled)
}

/// Workgroups `(x, y)` of a dispatch over `tiles` list entries: rows of at most `max` (the
/// adapter's limit per dimension); `None` when even `max` rows of `max` are too few.
fn grid(tiles: usize, max: u32) -> Option<(u32, u32)> {
    let n = u32::try_from(tiles).ok()?;
    let x = n.min(max).max(1);
    let y = n.div_ceil(x);
    (y <= max).then_some((x, y))
}

/// How the kernel time of a GPU render ([`sdfmo_render::Rendered::kernel_ms`]) is measured
/// ([`GpuRenderer::timing`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GpuTiming {
    /// Timestamp queries at the start and end of the compute pass: the kernel alone.
    Timestamps,
    /// The adapter has no timestamp queries: wall time from submission to completion.
    WallClock,
}

impl GpuTiming {
    /// `"timestamps"` or `"wall"`.
    pub fn name(self) -> &'static str {
        match self {
            GpuTiming::Timestamps => "timestamps",
            GpuTiming::WallClock => "wall",
        }
    }
}

/// An octree uploaded to the GPU: the `.smo` file's bytes (1.x, or 3.0 bricks), unchanged, in
/// one storage buffer.
#[derive(Debug)]
pub struct GpuOctree {
    buffer: wgpu::Buffer,
    bytes: u64,
    dequant: f32,
    /// The box every hit lies in, padded as the CPU renderer pads it (its occupied cells
    /// [`OCCUPIED_LEVELS`] below the root, grown by [`OCCUPIED_PAD`]): tiles whose rays all
    /// miss it are not traced. `None`: trace every tile.
    occupied: Option<(Vec3, Vec3)>,
    device_id: usize,
}

impl GpuOctree {
    /// Bytes on the GPU (the file's length).
    pub fn byte_size(&self) -> u64 {
        self.bytes
    }

    /// The storage buffer holding the file (binding 0 of `sdfmo.wgsl`), for a pipeline of
    /// your own.
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// The dequantisation factor to pass to `smo_info` (`diagonal / Q`).
    pub fn dequant(&self) -> f32 {
        self.dequant
    }
}

/// A file with levels of detail uploaded to the GPU: the `.smo` 2.0 file's bytes as saved
/// ([`LodOctree::to_bytes`]: the 2.0 header, its level table, every level's 1.x file), in one
/// storage buffer, so one dispatch can trace any level ([`GpuRenderer::render_lod`]).
#[derive(Debug)]
pub struct GpuLodOctree {
    octree: GpuOctree,
    coarsest: u8,
    depth: u8,
}

impl GpuLodOctree {
    /// Bytes on the GPU (the 2.0 file's length).
    pub fn byte_size(&self) -> u64 {
        self.octree.bytes
    }

    /// The storage buffer holding the 2.0 file (binding 0 of `sdfmo.wgsl`, read with `smo_lod`).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.octree.buffer
    }

    /// The finest level's dequantisation factor, to pass to `smo_lod`.
    pub fn dequant(&self) -> f32 {
        self.octree.dequant
    }

    /// The coarsest and the finest level (`coarsest..=depth`).
    pub fn levels(&self) -> (u8, u8) {
        (self.coarsest, self.depth)
    }
}

shared_struct! {
    /// The render's parameters (std140-compatible: 16-byte rows; 64 bytes).
    struct Params as "SmoRenderParams" {
        /// Eye position, normalised octree coordinates.
        eye: [f32; 3],
        /// The octree's dequantisation factor (sdfmo.wgsl).
        dequant: f32,
        /// Unit direction toward the light.
        light: [f32; 3],
        /// Intensity of the directional light.
        light_intensity: f32,
        /// Image width and height in pixels.
        width: u32,
        height: u32,
        /// 0 mask, 1 depth, 2 normal, 3 lambert.
        mode: u32,
        /// Ambient term of the lambert shading.
        ambient: f32,
        /// Depth mode: distances mapped to 255 and to the darkest grey.
        depth_near: f32,
        depth_far: f32,
        /// 0: the bound file is one octree (1.x, or 3.0 bricks), traced as it is. > 0: a 2.0
        /// file with levels, and each ray stops at the coarsest level whose voxel edge projects
        /// to at most this many pixels at its hit distance (`smo_intersect_lod`).
        pixel_error: f32,
        /// Radians one pixel subtends (with `pixel_error` > 0).
        pixel_angle: f32,
    }
}

/// The WGSL declaration of the uniform `SmoRenderParams` of `render.wgsl`, generated from
/// [`Params`].
pub(crate) fn params_wgsl() -> String {
    Params::wgsl()
}

const _: () = assert!(std::mem::size_of::<Params>() == 64);

/// Largest `.smo` file the kernel can address: it reads the low 32 bits of the header's 64-bit
/// section offsets (`sdfmo.wgsl`, `smo_info`), exact for every file shorter than 4 GiB (a
/// file's length is a multiple of 4, so this is the longest one whose offsets fit 32 bits).
pub const MAX_GPU_FILE_BYTES: u64 = (1 << 32) - 4;

/// How long [`GpuRenderer::render`] waits for the GPU by default before it gives up with
/// [`GpuError::Timeout`] ([`GpuRenderer::set_timeout`] changes it). A 1024² frame of the
/// shared meshes takes well under a second even on Mesa's software rasteriser (lavapipe).
pub const DEFAULT_GPU_TIMEOUT: Duration = Duration::from_secs(60);

/// Bytes per pixel of the `pixels` binding (`SmoPixel`: normal, t).
const PIXEL_BYTES: u64 = 16;
/// Bytes per pixel of the `colors` binding.
const COLOR_BYTES: u64 = 4;

/// Output buffers for one image size, kept between renders of the same size.
struct Targets {
    pixels: u64,
    pixel_buf: wgpu::Buffer,
    color_buf: wgpu::Buffer,
    pixel_read: wgpu::Buffer,
    color_read: wgpu::Buffer,
}

/// Timestamp queries, when the adapter has them.
struct Timer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    period_ns: f32,
}

/// A wgpu device with the octree kernel's compute pipeline.
///
/// ```no_run
/// # fn main() -> Result<(), sdfmo_gpu::GpuError> {
/// use sdfmo_gpu::GpuRenderer;
/// use sdfmo_render::{Camera, Mode, RenderSettings};
/// let octree = sdfmo_format::PackedOctree::load(std::path::Path::new("part.smo"))?;
/// let mut gpu = GpuRenderer::new()?; // a typed error without an adapter
/// let on_gpu = gpu.upload(&octree)?;
/// // The CPU renderer's camera, settings and image type.
/// let camera = Camera::paper_view(0, 256, 256);
/// let image = gpu.render(&on_gpu, &camera, &RenderSettings::new(Mode::Lambert))?;
/// println!(
///     "{}: {} hits in {:.2} ms",
///     gpu.adapter_name(),
///     image.counters.hits,
///     image.kernel_ms.unwrap_or_default()
/// );
/// # Ok(()) }
/// ```
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    layout: wgpu::BindGroupLayout,
    /// [`ENTRY_POINT`]: traces the listed tiles.
    pipeline: wgpu::ComputePipeline,
    /// [`BACKGROUND_ENTRY_POINT`]: fills the listed tiles with background.
    background: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    targets: Option<Targets>,
    timer: Option<Timer>,
    /// Errors wgpu reports outside an error scope (recorded instead of wgpu's default panic).
    uncaptured: Arc<Mutex<Option<String>>>,
    device_id: usize,
    timeout: Duration,
    /// Whether a wait timed out: the device may still be busy with that work.
    timed_out: AtomicBool,
}

impl Drop for GpuRenderer {
    fn drop(&mut self) {
        if self.timed_out.load(Ordering::Relaxed) {
            // wgpu's queue waits, when it is dropped, until the device is idle: after a time-out
            // that is as long as the runaway frame (minutes, on lavapipe, for the file of the
            // time-out test). Leak it instead (and the device with it): the work ends on its
            // own or with the process.
            std::mem::forget(self.queue.clone());
        }
    }
}

impl std::fmt::Debug for GpuRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuRenderer")
            .field("adapter", &self.info.name)
            .field("backend", &self.info.backend)
            .field("timestamps", &self.timer.is_some())
            .finish_non_exhaustive()
    }
}

fn next_device_id() -> usize {
    use std::sync::atomic::AtomicUsize;
    static NEXT: AtomicUsize = AtomicUsize::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

impl GpuRenderer {
    /// Opens the first suitable adapter (a high-performance one preferred; `WGPU_ADAPTER_NAME`
    /// and `WGPU_BACKEND` select one, as in wgpu's examples) and compiles the kernel.
    /// [`GpuError::NoAdapter`] when there is none.
    pub fn new() -> Result<GpuRenderer> {
        pollster::block_on(Self::new_async())
    }

    async fn new_async() -> Result<GpuRenderer> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            desc.backends = wgpu::Backends::PRIMARY;
        }
        let instance = wgpu::Instance::new(desc);
        let adapter = wgpu::util::initialize_adapter_from_env_or_default(&instance, None)
            .await
            .map_err(|e| GpuError::NoAdapter {
                reason: e.to_string(),
            })?;
        let info = adapter.get_info();
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let features = if timestamps {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        };
        // Everything the adapter offers: octrees and images beyond the WebGPU defaults (128 MiB
        // bindings) where the hardware allows.
        let limits = adapter.limits();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("sdfmo-gpu"),
                required_features: features,
                required_limits: limits.clone(),
                ..Default::default()
            })
            .await
            .map_err(|source| GpuError::RequestDevice {
                adapter: info.name.clone(),
                source,
            })?;
        let uncaptured = Arc::new(Mutex::new(None));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut slot) = sink.lock() {
                slot.get_or_insert_with(|| e.to_string());
            }
        }));

        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("sdfmo render.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader_source().into()),
        });
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sdfmo bindings"),
            entries: &[
                storage(0, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                storage(2, false),
                storage(3, false),
                storage(4, true),
                storage(5, true),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sdfmo pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let compile = |label, entry_point| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let pipeline = compile("sdfmo render", ENTRY_POINT);
        let background = compile("sdfmo background", BACKGROUND_ENTRY_POINT);
        if let Some(e) = scope.pop().await {
            return Err(GpuError::Device(e.to_string()));
        }
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sdfmo params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let timer = timestamps.then(|| Timer {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("sdfmo kernel time"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("sdfmo timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("sdfmo timestamps readback"),
                size: 16,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            period_ns: queue.get_timestamp_period(),
        });
        Ok(GpuRenderer {
            device,
            queue,
            info,
            limits,
            layout,
            pipeline,
            background,
            params,
            targets: None,
            timer,
            uncaptured,
            device_id: next_device_id(),
            timeout: DEFAULT_GPU_TIMEOUT,
            timed_out: AtomicBool::new(false),
        })
    }

    /// The adapter's name (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)" for Mesa's software Vulkan).
    pub fn adapter_name(&self) -> &str {
        &self.info.name
    }

    /// The adapter's description from wgpu (backend, driver, device type).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// How this adapter's kernel times ([`Rendered::kernel_ms`]) are measured: timestamp
    /// queries where the adapter has them, else the wall time of the frame.
    pub fn timing(&self) -> GpuTiming {
        if self.timer.is_some() {
            GpuTiming::Timestamps
        } else {
            GpuTiming::WallClock
        }
    }

    /// How long [`GpuRenderer::render`] waits for one frame (and each read-back) before it
    /// returns [`GpuError::Timeout`] ([`DEFAULT_GPU_TIMEOUT`] unless set). After a time-out the
    /// work may still be running on the device: open a new renderer. Dropping this one does not
    /// wait for that work (its queue and device are leaked instead).
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// The current wait limit ([`GpuRenderer::set_timeout`]).
    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    /// The largest `.smo` file [`GpuRenderer::upload_bytes`] accepts on this adapter: the
    /// adapter's storage-binding and buffer limits, and [`MAX_GPU_FILE_BYTES`] (the kernel's
    /// 32-bit offsets). Check a file's length against it before reading the file.
    pub fn max_file_bytes(&self) -> u64 {
        self.binding_limit().min(MAX_GPU_FILE_BYTES)
    }

    /// The device, to build pipelines of your own around `sdfmo.wgsl`.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// Uploads an octree: its `.smo` bytes ([`PackedOctree::as_bytes`]), unchanged and not
    /// copied on the host (the octree was validated when it was made). The size is checked
    /// first ([`GpuRenderer::max_file_bytes`]).
    pub fn upload(&self, octree: &PackedOctree) -> Result<GpuOctree> {
        self.check_file_size(octree.as_bytes().len() as u64)?;
        let occupied = OctreeScene(octree).occupied_bounds();
        self.upload_validated(octree.as_bytes(), octree.meta(), occupied)
    }

    /// Uploads a 3.0 brick file: its bytes ([`BrickOctree::as_bytes`]), unchanged and not
    /// copied on the host, traced as they are (the kernel reads bricks; nothing is expanded to
    /// 1.x). The size is checked first ([`GpuRenderer::max_file_bytes`]).
    ///
    /// # Errors
    /// Those of [`GpuRenderer::upload`], and [`GpuError::TooLarge`] for more than
    /// [`MAX_GPU_BRICKS`] bricks.
    pub fn upload_bricks<B: AsRef<[u8]>>(&self, bricks: &BrickOctree<B>) -> Result<GpuOctree> {
        let bytes = bricks.as_bytes();
        self.check_file_size(bytes.len() as u64)?;
        if bricks.brick_count() > MAX_GPU_BRICKS as usize {
            return Err(GpuError::TooLarge {
                what: "the brick records (the kernel numbers bricks in 25 bits)",
                needed: bricks.brick_count() as u64 * sdfmo_format::BRICK_RECORD_SIZE as u64,
                limit: u64::from(MAX_GPU_BRICKS) * sdfmo_format::BRICK_RECORD_SIZE as u64,
            });
        }
        let occupied = brick_occupied_bounds(bricks, OCCUPIED_LEVELS);
        self.upload_validated(bytes, bricks.meta(), occupied)
    }

    /// Validates `.smo` file bytes (the kernel trusts what it reads: [`PackedOctreeView::new`]
    /// for 1.x, [`BrickOctree::new`] for 3.0, which is traced as it is) and uploads them
    /// unchanged into one storage buffer; a compressed file
    /// ([`sdfmo_format::compressed`]) is decoded first, to at most
    /// [`GpuRenderer::max_file_bytes`]. The length is checked against
    /// [`GpuRenderer::max_file_bytes`] before anything is read.
    pub fn upload_bytes(&self, bytes: &[u8]) -> Result<GpuOctree> {
        if sdfmo_format::compressed::is_compressed(bytes) {
            let decoded = sdfmo_format::compressed::decompress(bytes, self.max_file_bytes())?;
            return self.upload_bytes(&decoded);
        }
        self.check_file_size(bytes.len() as u64)?;
        if sdfmo_format::is_v3(bytes) {
            return self.upload_bricks(&BrickOctree::new(bytes)?);
        }
        let view = PackedOctreeView::new(bytes)?;
        // OctreeScene's occupied bounds, of the borrowed bytes.
        let occupied = sdfmo_trace::occupied_bounds(&view, OCCUPIED_LEVELS);
        self.upload_validated(bytes, view.meta(), occupied)
    }

    /// Uploads a file with levels of detail: its `.smo` 2.0 bytes ([`LodOctree::to_bytes`],
    /// every level, coarsest first) into one storage buffer, for
    /// [`GpuRenderer::render_lod`]. The size is checked first
    /// ([`GpuRenderer::max_file_bytes`]).
    pub fn upload_lod(&self, lod: &LodOctree) -> Result<GpuLodOctree> {
        self.check_file_size(lod.byte_size())?;
        // The union of every level's occupied cells (the level choice does not enter it).
        let scene = LodScene {
            lod,
            choice: LevelChoice::Level(lod.depth()),
        };
        let octree =
            self.upload_validated(&lod.to_bytes(), &lod.meta(), scene.occupied_bounds())?;
        Ok(GpuLodOctree {
            octree,
            coarsest: lod.coarsest(),
            depth: lod.depth(),
        })
    }

    /// [`GpuError::TooLarge`] when a `.smo` file of `len` bytes cannot be bound on this adapter
    /// or addressed by the kernel ([`GpuRenderer::max_file_bytes`]). Costs nothing: call it with
    /// a file's length before loading it.
    pub fn check_file_size(&self, len: u64) -> Result<()> {
        let binding = self.binding_limit();
        if len > binding {
            return Err(GpuError::TooLarge {
                what: "the octree",
                needed: len,
                limit: binding,
            });
        }
        if len > MAX_GPU_FILE_BYTES {
            return Err(GpuError::FileTooLarge {
                needed: len,
                limit: MAX_GPU_FILE_BYTES,
            });
        }
        Ok(())
    }

    /// Uploads validated bytes (their length already checked), with their occupied bounds
    /// (`Traceable::occupied_bounds`).
    fn upload_validated(
        &self,
        bytes: &[u8],
        meta: &sdfmo_format::OctreeMeta,
        occupied: Option<(Vec3, Vec3)>,
    ) -> Result<GpuOctree> {
        let len = bytes.len() as u64;
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let buffer = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("sdfmo octree (.smo bytes)"),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Device(e.to_string()));
        }
        Ok(GpuOctree {
            buffer,
            bytes: len,
            dequant: dequant_scale(meta.depth, meta.bits),
            occupied: occupied.map(|(lo, hi)| {
                (
                    lo - Vec3::splat(OCCUPIED_PAD),
                    hi + Vec3::splat(OCCUPIED_PAD),
                )
            }),
            device_id: self.device_id,
        })
    }

    /// Renders one image of `octree` with the CPU renderer's camera, settings and shading
    /// ([`sdfmo_render::render`] of an [`sdfmo_render::OctreeScene`]), and reads it back as the
    /// CPU renderer returns it: [`Rendered::depth`] and [`Rendered::normals`] as the plan keeps
    /// them, the primary-ray [`Rendered::counters`], the kernel's time in
    /// [`Rendered::kernel_ms`].
    ///
    /// # Errors
    /// [`GpuError::Render`] for an invalid camera, or settings the kernel does not render
    /// (shadows, ambient occlusion, a thread count: it traces primary rays only); the
    /// adapter's errors and limits otherwise.
    pub fn render(
        &mut self,
        octree: &GpuOctree,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<Rendered> {
        self.render_file(octree, camera, settings, None)
    }

    /// Renders one image of a file with levels ([`GpuRenderer::upload_lod`]), each ray at the
    /// level `choice` picks: [`LevelChoice::PixelError`], the coarsest level whose voxels
    /// project to at most `pixels` pixels at its hit distance (the rule, the levels and the
    /// order of the re-traces of `sdfmo_trace::intersect_lod`; the choice of a
    /// [`sdfmo_render::LevelRequest::PixelError`] for this camera is in the
    /// [`sdfmo_render::LodScene`] that [`sdfmo_render::LevelRequest::scene`] returns). Reads the
    /// image back as [`GpuRenderer::render`] does.
    ///
    /// # Errors
    /// Those of [`GpuRenderer::render`], and [`GpuError::Render`] for a pixel error or pixel
    /// angle that is not finite and > 0, or a [`LevelChoice::Level`] (upload that level and
    /// [`GpuRenderer::render`] it).
    pub fn render_lod(
        &mut self,
        lod: &GpuLodOctree,
        choice: LevelChoice,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<Rendered> {
        let LevelChoice::PixelError {
            pixels,
            pixel_angle,
        } = choice
        else {
            return Err(invalid_settings(format!(
                "the GPU draws a fixed level of a file as that level's octree: upload it \
                 (GpuRenderer::upload) instead of choosing {choice:?}"
            )));
        };
        let valid = |v: f32| v.is_finite() && v > 0.0;
        if !valid(pixels) || !valid(pixel_angle) {
            return Err(invalid_settings(format!(
                "the pixel error and the pixel angle must be finite and > 0: {choice:?}"
            )));
        }
        self.render_file(&lod.octree, camera, settings, Some((pixels, pixel_angle)))
    }

    /// Renders the uploaded file: a 1.x octree (`error` `None`) or a 2.0 file by pixel error
    /// (pixels, pixel angle).
    fn render_file(
        &mut self,
        octree: &GpuOctree,
        camera: &Camera,
        settings: &RenderSettings,
        error: Option<(f32, f32)>,
    ) -> Result<Rendered> {
        if octree.device_id != self.device_id {
            return Err(GpuError::ForeignOctree);
        }
        let plan = RenderPlan::new(settings)?;
        if plan.shadow_rays || plan.ao_samples > 0 {
            return Err(invalid_settings(format!(
                "the GPU kernel traces primary rays only: shadows ({}) and ambient occlusion ({} \
                 rays) are CPU settings",
                settings.shadows, settings.ao_samples
            )));
        }
        let frame = camera.frame()?;
        let (w, h) = (frame.width, frame.height);
        let (traced, culled) = tile_lists(&frame, octree.occupied);
        let max_groups = self.limits.max_compute_workgroups_per_dimension;
        let [traced_groups, culled_groups] = [&traced, &culled].map(|l| grid(l.len(), max_groups));
        if traced_groups.is_none() || culled_groups.is_none() {
            return Err(GpuError::Render(RenderError::InvalidCamera(format!(
                "{w}x{h} needs {} workgroups, over the adapter's {max_groups}²",
                traced.len().max(culled.len())
            ))));
        }
        let pixels = u64::from(w) * u64::from(h);
        let limit = self.binding_limit();
        if pixels * PIXEL_BYTES > limit {
            return Err(GpuError::TooLarge {
                what: "the pixel buffer",
                needed: pixels * PIXEL_BYTES,
                limit,
            });
        }
        // The CPU renderer's shading (`sdfmo_render::shading`), with the depth range of the
        // octree's bounds, the root cube (`OctreeScene` and `LodScene` bounds).
        let range = DepthRange::new(camera.eye, Vec3::splat(-1.0), Vec3::ONE);
        let params = Params {
            eye: frame.eye.as_vec3().to_array(),
            dequant: octree.dequant,
            light: light_dir().to_array(),
            light_intensity: LIGHT_INTENSITY,
            width: w,
            height: h,
            mode: mode_code(plan.mode),
            ambient: AMBIENT,
            depth_near: range.near,
            depth_far: range.far,
            pixel_error: error.map_or(0.0, |e| e.0),
            pixel_angle: error.map_or(0.0, |e| e.1),
        };
        let terms = ray_terms(&frame);
        self.take_uncaptured()?;
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        self.ensure_targets(pixels);
        let t = self.targets.as_ref().expect("ensure_targets made them");
        self.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let rays = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("sdfmo ray terms"),
                contents: bytemuck::cast_slice(&terms),
                usage: wgpu::BufferUsages::STORAGE,
            });
        // One bind group per tile list (binding 5), the rest shared.
        let bind = |tiles: &wgpu::Buffer| {
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("sdfmo bind group"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: octree.buffer.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: self.params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: t.pixel_buf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: t.color_buf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: rays.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: tiles.as_entire_binding(),
                    },
                ],
            })
        };
        let dispatches = [
            (&self.pipeline, &traced, traced_groups),
            (&self.background, &culled, culled_groups),
        ]
        .into_iter()
        .filter(|(_, list, _)| !list.is_empty())
        .map(|(pipeline, list, groups)| {
            let tiles = self
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("sdfmo tiles"),
                    contents: bytemuck::cast_slice(list),
                    usage: wgpu::BufferUsages::STORAGE,
                });
            (pipeline, bind(&tiles), groups.expect("checked above"))
        })
        .collect::<Vec<_>>();
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sdfmo render"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("sdfmo kernel"),
                timestamp_writes: self.timer.as_ref().map(|timer| {
                    wgpu::ComputePassTimestampWrites {
                        query_set: &timer.queries,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }
                }),
            });
            for (pipeline, bind, (x, y)) in &dispatches {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, bind, &[]);
                pass.dispatch_workgroups(*x, *y, 1);
            }
        }
        if let Some(timer) = &self.timer {
            encoder.resolve_query_set(&timer.queries, 0..2, &timer.resolve, 0);
            encoder.copy_buffer_to_buffer(&timer.resolve, 0, &timer.read, 0, 16);
        }
        encoder.copy_buffer_to_buffer(&t.pixel_buf, 0, &t.pixel_read, 0, pixels * PIXEL_BYTES);
        encoder.copy_buffer_to_buffer(&t.color_buf, 0, &t.color_read, 0, pixels * COLOR_BYTES);
        let start = Instant::now();
        let submission = self.queue.submit([encoder.finish()]);
        self.wait(Some(submission))?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        if let Some(e) = pollster::block_on(oom.pop()) {
            drop(pollster::block_on(scope.pop()));
            return Err(GpuError::Device(e.to_string()));
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Device(e.to_string()));
        }
        self.take_uncaptured()?;

        let pixel_bytes = self.read_back(&t.pixel_read, pixels * PIXEL_BYTES)?;
        let color_bytes = self.read_back(&t.color_read, pixels * COLOR_BYTES)?;
        let kernel_ms = match &self.timer {
            Some(timer) => {
                let stamps = self.read_back(&timer.read, 16)?;
                let begin = u64::from_le_bytes(stamps[0..8].try_into().expect("8 bytes"));
                let end = u64::from_le_bytes(stamps[8..16].try_into().expect("8 bytes"));
                let ns = end.saturating_sub(begin) as f64 * f64::from(timer.period_ns);
                ns * 1e-6
            }
            None => wall_ms,
        };

        let n = pixels as usize;
        let mut rgb = Vec::with_capacity(n * 3);
        for c in color_bytes.chunks_exact(4) {
            rgb.extend_from_slice(&c[..3]);
        }
        let mut depth = Vec::with_capacity(if plan.keep_depth { n } else { 0 });
        let mut normals = Vec::with_capacity(if plan.keep_normals { n } else { 0 });
        let mut hits = 0;
        for p in pixel_bytes.chunks_exact(16) {
            let f = |k: usize| f32::from_le_bytes(p[4 * k..4 * k + 4].try_into().expect("4 bytes"));
            let t = f(3);
            let hit = t < SMO_FAR;
            hits += u64::from(hit);
            if plan.keep_depth {
                depth.push(if hit { t } else { f32::INFINITY });
            }
            if plan.keep_normals {
                normals.push(Vec3::new(f(0), f(1), f(2)));
            }
        }
        // What the CPU renderer counts for the same plan: a ray per pixel, a normal per hit
        // when the mode shades (the kernel evaluates it at every hit then).
        let counters = Counters {
            rays: pixels,
            hits,
            normal_evals: if plan.normals { hits } else { 0 },
            ..Counters::default()
        };
        Ok(Rendered {
            width: w,
            height: h,
            rgb,
            depth: plan.keep_depth.then_some(depth),
            normals: plan.keep_normals.then_some(normals),
            counters,
            render_ms: wall_ms,
            kernel_ms: Some(kernel_ms),
        })
    }

    /// The largest buffer the kernel can bind.
    fn binding_limit(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// The output buffers for `pixels` pixels (reused when the size is unchanged).
    fn ensure_targets(&mut self, pixels: u64) {
        if self.targets.as_ref().is_some_and(|t| t.pixels == pixels) {
            return;
        }
        let buf = |label, size, usage| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let read = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        self.targets = Some(Targets {
            pixels,
            pixel_buf: buf("sdfmo pixels", pixels * PIXEL_BYTES, storage),
            color_buf: buf("sdfmo colors", pixels * COLOR_BYTES, storage),
            pixel_read: buf("sdfmo pixels readback", pixels * PIXEL_BYTES, read),
            color_read: buf("sdfmo colors readback", pixels * COLOR_BYTES, read),
        });
    }

    /// Maps `buffer` (a MAP_READ copy target), copies its first `len` bytes out, unmaps it.
    fn read_back(&self, buffer: &wgpu::Buffer, len: u64) -> Result<Vec<u8>> {
        let slice = buffer.slice(..len);
        let (tx, rx) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait(None)?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(GpuError::Readback(e)),
            Err(_) => return Err(GpuError::Device("the mapping callback never ran".into())),
        }
        let bytes = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Device(e.to_string()))?
            .to_vec();
        buffer.unmap();
        Ok(bytes)
    }

    /// Waits for `submission` (the latest when `None`) at most [`GpuRenderer::timeout`].
    fn wait(&self, submission: Option<wgpu::SubmissionIndex>) -> Result<()> {
        match self.device.poll(wgpu::PollType::Wait {
            submission_index: submission,
            timeout: Some(self.timeout),
        }) {
            Ok(_) => Ok(()),
            Err(wgpu::PollError::Timeout) => {
                self.timed_out.store(true, Ordering::Relaxed);
                Err(GpuError::Timeout {
                    after: self.timeout,
                })
            }
            Err(e) => Err(GpuError::Poll(e)),
        }
    }

    /// An error wgpu reported outside any scope since the last call, as [`GpuError::Device`].
    fn take_uncaptured(&self) -> Result<()> {
        let taken = self.uncaptured.lock().ok().and_then(|mut slot| slot.take());
        match taken {
            Some(e) => Err(GpuError::Device(e)),
            None => Ok(()),
        }
    }
}

/// The union of the occupied cells `levels` below the root of a 3.0 file (`None` when it is
/// empty): the cells `sdfmo_trace::occupied_bounds` unions for the same octree in 1.x (the
/// same nodes, walked through [`BrickOctree::child`]), so tiles are culled as for that file.
fn brick_occupied_bounds<B: AsRef<[u8]>>(
    bricks: &BrickOctree<B>,
    levels: u8,
) -> Option<(Vec3, Vec3)> {
    let root = bricks.root()?;
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut stack: Vec<(BrickNode, Vec3, f32, u8)> = vec![(root, Vec3::splat(-1.0), 2.0, 0)];
    while let Some((node, min, size, level)) = stack.pop() {
        if level >= levels || bricks.is_leaf(node) {
            lo = lo.min(min);
            hi = hi.max(min + Vec3::splat(size));
            continue;
        }
        let half = 0.5 * size;
        for oct in 0..8u8 {
            if let Some(child) = bricks.child(node, oct) {
                let offset = Vec3::new(
                    f32::from(oct >> 2),
                    f32::from((oct >> 1) & 1),
                    f32::from(oct & 1),
                );
                stack.push((child, min + offset * half, half, level + 1));
            }
        }
    }
    Some((lo, hi))
}

/// [`GpuError::Render`] with [`RenderError::InvalidSettings`].
fn invalid_settings(what: String) -> GpuError {
    GpuError::Render(RenderError::InvalidSettings(what))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::size_of;

    /// (member, byte offset, struct size) of the WGSL struct `name` in the render module.
    fn wgsl_layout(name: &str) -> (Vec<(String, u32)>, u32) {
        let m = naga::front::wgsl::parse_str(&shader_source()).expect("the shader parses");
        let ty = m
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no struct {name}"))
            .1;
        match &ty.inner {
            naga::TypeInner::Struct { members, span } => (
                members
                    .iter()
                    .map(|mb| (mb.name.clone().unwrap_or_default(), mb.offset))
                    .collect(),
                *span,
            ),
            other => panic!("{name} is {other:?}"),
        }
    }

    /// Every tile is listed once, in one of the two lists; a camera looking away from the box
    /// traces none (the empty frame that cost a whole kernel per SIMD group on lavapipe), one
    /// looking at it traces the tiles around it only.
    #[test]
    fn tile_lists_cover_the_image_once_and_trace_only_near_the_box() {
        let unit = Some((Vec3::splat(-0.5), Vec3::splat(0.5)));
        let eye = Vec3::new(0.0, 0.0, 3.0);
        let tiles = |target: Vec3, occupied| {
            let frame = Camera::new(eye, target, 60.0, 100, 60).frame().unwrap();
            tile_lists(&frame, occupied)
        };
        let all: Vec<u32> = (0..8u32)
            .flat_map(|y| (0..13u32).map(move |x| x | y << 16))
            .collect();
        for (target, occupied) in [(Vec3::ZERO, unit), (Vec3::ZERO, None), (eye * 2.0, unit)] {
            let (traced, culled) = tiles(target, occupied);
            let mut both = [traced, culled].concat();
            both.sort_unstable();
            assert_eq!(both, all, "{target} {occupied:?}");
        }
        assert_eq!(tiles(Vec3::ZERO, None).0.len(), all.len());
        assert!(tiles(eye * 2.0, unit).0.is_empty());
        let (traced, culled) = tiles(Vec3::ZERO, unit);
        assert!(!traced.is_empty() && culled.len() > traced.len());
        assert_eq!(grid(0, 65535), Some((1, 0)));
        assert_eq!(grid(70_000, 65535), Some((65535, 2)));
        assert_eq!(grid(10, 3), None);
    }

    /// A 3.0 file's occupied box (the tiles the GPU culls) is its 1.x file's, at every number
    /// of levels below the root: the sphere's octree at depths 2 to 6, the empty one too.
    #[test]
    fn brick_bounds_are_the_octree_bounds() {
        use sdfmo_format::{testing::sphere_leaves, OctreeMeta, ValueBits};
        for depth in 2..=6u8 {
            for leaves in [sphere_leaves(depth, 0.6), Vec::new()] {
                let meta = OctreeMeta::unit(depth, ValueBits::Eight);
                let octree = PackedOctree::from_leaves(meta, leaves).unwrap();
                let bricks = BrickOctree::encode(&octree).unwrap();
                for levels in 0..=depth + 1 {
                    assert_eq!(
                        brick_occupied_bounds(&bricks, levels),
                        sdfmo_trace::occupied_bounds(&octree, levels),
                        "depth {depth}, {levels} levels, {} leaves",
                        octree.leaf_count()
                    );
                }
            }
        }
    }

    /// `smo_lod_level_info` (sdfmo.wgsl) derives level k's dequantisation factor from the
    /// finest level's as `ldexp(dequant, D − k)`: the same f32 the host would compute, for
    /// every depth, level and corner precision.
    #[test]
    fn level_dequant_is_the_finest_times_a_power_of_two() {
        use sdfmo_format::{ValueBits, MAX_DEPTH};
        for bits in [ValueBits::Eight, ValueBits::Sixteen] {
            for d in 0..=MAX_DEPTH {
                for k in 0..=d {
                    let derived = dequant_scale(d, bits) * 2f32.powi(i32::from(d - k));
                    assert_eq!(
                        derived.to_bits(),
                        dequant_scale(k, bits).to_bits(),
                        "{d} {k}"
                    );
                }
            }
        }
    }

    /// Issue 20: the uniform's layout was kept by hand in Rust and WGSL (only the size was
    /// asserted); `SmoRenderParams` is now generated from `Params`. naga's layout of it must
    /// place every member where `Params` has its field (WGSL's alignment rules are not Rust's),
    /// and `SmoPixel` must be `PIXEL_BYTES` long.
    #[test]
    fn the_uniform_layout_matches_the_wgsl() {
        let (members, span) = wgsl_layout("SmoRenderParams");
        let rust: Vec<(String, u32)> = Params::offsets()
            .into_iter()
            .map(|(n, o)| (n.to_owned(), o as u32))
            .collect();
        assert_eq!(rust.len(), 12);
        assert_eq!(members, rust);
        assert_eq!(span as usize, size_of::<Params>());
        let (_, pixel) = wgsl_layout("SmoPixel");
        assert_eq!(u64::from(pixel), PIXEL_BYTES);
    }
}
