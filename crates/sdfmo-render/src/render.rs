//! The tiled renderer: plans, renders tiles in parallel, sums their counters.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::camera::{Camera, CameraFrame};
use crate::plan::{Counters, Mode, RenderPlan, RenderSettings};
use crate::scene::{Traceable, OCCUPIED_PAD, PACKET};
use crate::RayPacket;

/// Pixel columns and rows of a packet of primary rays ([`PACKET`] in all).
const PACKET_COLS: usize = 4;
const PACKET_ROWS: usize = PACKET / PACKET_COLS;
use crate::shading::{
    cosine_hemisphere, depth_grey, lambert_value, light_dir, normal_rgb, DepthRange, PixelRng,
    AO_DISTANCE,
};
use crate::RenderError;

/// A rendered image and what it cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// 8-bit RGB, row-major from the top, `width · height · 3` bytes.
    pub rgb: Vec<u8>,
    /// Distance along the unit primary ray per pixel (+∞ for background), when the plan keeps it
    /// (depth mode).
    pub depth: Option<Vec<f32>>,
    /// Viewer-facing unit normal per pixel (zero for background), when the plan keeps it
    /// (normal mode).
    pub normals: Option<Vec<Vec3>>,
    /// Work done.
    pub counters: Counters,
    /// Wall time of the rendering alone (tiles and their assembly; not the pool creation, not
    /// saving), milliseconds. On a GPU: from submission until the image is on the host.
    pub render_ms: f64,
    /// A GPU render's kernel time in milliseconds (`sdfmo-gpu`: from timestamp queries where
    /// the adapter has them, else the frame's wall time); `None` on the CPU.
    pub kernel_ms: Option<f64>,
}

impl Rendered {
    /// The image as an `image::RgbImage` (for metrics and saving); a black image of the same
    /// size if `rgb` does not hold `width · height · 3` bytes (only possible for a hand-made
    /// `Rendered`).
    pub fn to_image(&self) -> image::RgbImage {
        image::RgbImage::from_raw(self.width, self.height, self.rgb.clone())
            .unwrap_or_else(|| image::RgbImage::new(self.width, self.height))
    }

    /// Primary rays per second of this render (0 if it took no measurable time).
    pub fn rays_per_second(&self) -> f64 {
        if self.render_ms > 0.0 {
            self.counters.rays as f64 / (self.render_ms * 1e-3)
        } else {
            0.0
        }
    }
}

/// Renders `scene` seen by `camera` with the plan of `settings` (see [`RenderPlan::new`]), on
/// the caller's rayon pool. [`RenderRequest`] adds progress, cancellation and an explicit plan.
///
/// # Errors
/// [`RenderError::InvalidCamera`], [`RenderError::InvalidSettings`].
pub fn render<T: Traceable>(
    scene: &T,
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<Rendered, RenderError> {
    RenderRequest::new(scene, camera, settings).render()
}

/// A render with its options, [`render`] when none is set: a progress callback, a cancellation
/// test and an explicit plan (image-rs's `ImageReader` is the model: options on the request,
/// one terminal call).
///
/// Tiles of [`RenderPlan::tile_size`] pixels are rendered in parallel on the caller's rayon
/// pool (the global one, or the one the caller `install`s: the front-ends own the pools) and
/// every pixel depends only on its own coordinates, so the image and counters are identical
/// for any thread count, and with or without progress and cancellation.
///
/// ```
/// use std::sync::atomic::{AtomicU32, Ordering};
/// use sdfmo_render::{Camera, Mode, RenderPlan, RenderRequest, RenderSettings, Spheres};
/// use glam::Vec3;
///
/// let scene = Spheres::one(Vec3::ZERO, 0.5);
/// let camera = Camera::paper_view(0, 64, 64);
/// let settings = RenderSettings::new(Mode::Lambert);
/// let plan = RenderPlan::new(&settings)?.with_tile_size(16);
/// let done = AtomicU32::new(0);
/// let progress = |f: f32| { done.fetch_max(f.to_bits(), Ordering::Relaxed); };
/// let image = RenderRequest::new(&scene, &camera, &settings)
///     .plan(plan)
///     .progress(&progress)
///     .cancel(&|| false)
///     .render()?;
/// assert_eq!(f32::from_bits(done.load(Ordering::Relaxed)), 1.0);
/// assert_eq!(image.rgb, sdfmo_render::render(&scene, &camera, &settings)?.rgb);
/// # Ok::<(), sdfmo_render::RenderError>(())
/// ```
#[must_use = "a request renders nothing until `render` is called"]
pub struct RenderRequest<'a, T> {
    scene: &'a T,
    camera: &'a Camera,
    settings: RenderSettings,
    plan: Option<RenderPlan>,
    progress: Option<&'a (dyn Fn(f32) + Sync)>,
    cancel: Option<&'a (dyn Fn() -> bool + Sync)>,
}

impl<'a, T: Traceable> RenderRequest<'a, T> {
    /// The render of `scene` seen by `camera` with the plan of `settings`.
    pub fn new(scene: &'a T, camera: &'a Camera, settings: &RenderSettings) -> Self {
        RenderRequest {
            scene,
            camera,
            settings: *settings,
            plan: None,
            progress: None,
            cancel: None,
        }
    }

    /// Renders with `plan` (made by [`RenderPlan::new`] and adjusted) instead of the plan of
    /// the settings.
    pub fn plan(mut self, plan: RenderPlan) -> Self {
        self.plan = Some(plan);
        self
    }

    /// Calls `progress` with the fraction of the image's tiles done so far, once per band of
    /// tiles (a row of tiles, 8 pixels high by default), from the worker threads (so not in
    /// order: keep the largest, as a progress bar's position does).
    pub fn progress(mut self, progress: &'a (dyn Fn(f32) + Sync)) -> Self {
        self.progress = Some(progress);
        self
    }

    /// Stops early with [`RenderError::Cancelled`] when `cancel` returns true. It is asked
    /// from the worker threads before each tile, so a render stops within about one tile's
    /// time per worker (the Python package's Ctrl-C).
    pub fn cancel(mut self, cancel: &'a (dyn Fn() -> bool + Sync)) -> Self {
        self.cancel = Some(cancel);
        self
    }

    /// Renders.
    ///
    /// # Errors
    /// [`RenderError::InvalidCamera`], [`RenderError::InvalidSettings`] (settings or plan),
    /// [`RenderError::Cancelled`].
    pub fn render(&self) -> Result<Rendered, RenderError> {
        let plan = match self.plan {
            Some(plan) => plan,
            None => RenderPlan::new(&self.settings)?,
        };
        plan.validate()?;
        let (scene, camera) = (self.scene, self.camera);
        let frame = camera.frame()?;
        let (bmin, bmax) = scene.bounds();
        let ctx = Ctx {
            scene,
            frame,
            plan,
            range: DepthRange::new(camera.eye, bmin, bmax),
            light: light_dir(),
            eps: scene.epsilon(),
            occupied: occupied_boxes(scene, &plan, frame.eye.as_vec3()),
            progress: self.progress,
            tiles_done: AtomicUsize::new(0),
            cancel: self.cancel,
            cancelled: AtomicBool::new(false),
        };
        let rendered = ctx.run();
        if ctx.cancelled.load(Ordering::Relaxed) {
            return Err(RenderError::Cancelled);
        }
        Ok(rendered)
    }
}

/// The padded boxes a render tests rays against before tracing them (a ray that misses its
/// box hits nothing).
struct OccupiedBoxes {
    /// For primary rays: [`Traceable::primary_bounds`] from the eye, or the occupied box where
    /// other rays are traced too (a larger box is as good a test).
    primary: Option<(Vec3, Vec3)>,
    /// For shadow and occlusion rays: [`Traceable::occupied_bounds`] (not found when the
    /// render traces none).
    secondary: Option<(Vec3, Vec3)>,
}

/// The boxes of `scene` for a render with `plan` from `eye`: one box search either way.
fn occupied_boxes<T: Traceable>(scene: &T, plan: &RenderPlan, eye: Vec3) -> OccupiedBoxes {
    let pad = |b: Option<(Vec3, Vec3)>| {
        b.map(|(lo, hi)| {
            (
                lo - Vec3::splat(OCCUPIED_PAD),
                hi + Vec3::splat(OCCUPIED_PAD),
            )
        })
    };
    if plan.shadow_rays || plan.ao_samples > 0 {
        let whole = pad(scene.occupied_bounds());
        OccupiedBoxes {
            primary: whole,
            secondary: whole,
        }
    } else {
        OccupiedBoxes {
            primary: pad(scene.primary_bounds(eye)),
            secondary: None,
        }
    }
}

struct Ctx<'a, T> {
    scene: &'a T,
    frame: CameraFrame,
    plan: RenderPlan,
    range: DepthRange,
    light: Vec3,
    eps: f32,
    /// The padded boxes the rays are tested against (`None`: trace every ray).
    occupied: OccupiedBoxes,
    /// Called with the fraction of tiles done after each band of tiles.
    progress: Option<&'a (dyn Fn(f32) + Sync)>,
    /// Tiles done so far (for `progress`).
    tiles_done: AtomicUsize,
    /// Asked before each tile: stop rendering when it returns true.
    cancel: Option<&'a (dyn Fn() -> bool + Sync)>,
    /// Whether `cancel` said to stop (the remaining tiles are skipped).
    cancelled: AtomicBool,
}

/// One band of the image (a row of tiles): its first row and its pixels.
struct Band<'a> {
    y0: u32,
    rgb: &'a mut [u8],
    depth: Option<&'a mut [f32]>,
    normals: Option<&'a mut [Vec3]>,
}

/// The output of one tile: its column, size and pixels, row-major within the tile (no pixels
/// when the tile was culled: all background).
struct Tile {
    x0: u32,
    w: u32,
    h: u32,
    rgb: Vec<u8>,
    depth: Vec<f32>,
    normals: Vec<Vec3>,
    counters: Counters,
}

impl Tile {
    /// A tile of no pixels (skipped after a cancellation; its band keeps the background).
    fn empty(x0: u32, w: u32, h: u32) -> Tile {
        Tile {
            x0,
            w,
            h,
            rgb: Vec::new(),
            depth: Vec::new(),
            normals: Vec::new(),
            counters: Counters::default(),
        }
    }
}

impl<T: Traceable> Ctx<'_, T> {
    fn run(&self) -> Rendered {
        let start = Instant::now();
        let (w, h) = (self.frame.width, self.frame.height);
        let n = w as usize * h as usize;
        let mut rgb = vec![0u8; n * 3];
        let mut depth = if self.plan.keep_depth {
            vec![f32::INFINITY; n]
        } else {
            Vec::new()
        };
        let mut normals = if self.plan.keep_normals {
            vec![Vec3::ZERO; n]
        } else {
            Vec::new()
        };
        // The image is cut into bands of one tile row, and each band's tiles are copied into it
        // by the worker that finishes them: the assembly (and the first touch of the image's
        // pages) runs in parallel instead of after the tiles, on the calling thread.
        let band_pixels = self.plan.tile_size as usize * w as usize;
        let rgb_bands = rgb.chunks_mut(band_pixels * 3);
        let mut depth_bands = depth.chunks_mut(band_pixels);
        let mut normal_bands = normals.chunks_mut(band_pixels);
        let bands: Vec<Band> = rgb_bands
            .enumerate()
            .map(|(i, rgb)| Band {
                y0: i as u32 * self.plan.tile_size,
                rgb,
                depth: depth_bands.next(),
                normals: normal_bands.next(),
            })
            .collect();
        let counters = bands.into_par_iter().map(|band| self.band(band)).reduce(
            Counters::default,
            |mut a, b| {
                a += b;
                a
            },
        );
        Rendered {
            width: w,
            height: h,
            rgb,
            depth: self.plan.keep_depth.then_some(depth),
            normals: self.plan.keep_normals.then_some(normals),
            counters,
            render_ms: start.elapsed().as_secs_f64() * 1e3,
            kernel_ms: None,
        }
    }

    /// Renders the tiles of one band (in parallel) and copies them into it; returns their
    /// counters.
    fn band(&self, band: Band<'_>) -> Counters {
        let (w, ts) = (self.frame.width, self.plan.tile_size);
        let tiles_x = w.div_ceil(ts);
        let tiles_total = tiles_x * self.frame.height.div_ceil(ts);
        let tiles: Vec<Tile> = (0..tiles_x)
            .into_par_iter()
            .map(|i| {
                if self.is_cancelled() {
                    return Tile::empty(i * ts, 0, 0);
                }
                self.tile(i * ts, band.y0)
            })
            .collect();
        // Once per band, not per tile: a far view culls most tiles in a few instructions each,
        // and a report per tile cost 1 % of its frame (abc5 from radius 12, callgrind).
        if let Some(progress) = self.progress {
            let n = tiles_x as usize;
            let done = self.tiles_done.fetch_add(n, Ordering::Relaxed) + n;
            progress(done as f32 / tiles_total as f32);
        }
        let mut counters = Counters::default();
        let Band {
            rgb,
            mut depth,
            mut normals,
            ..
        } = band;
        for t in &tiles {
            counters += t.counters;
            if t.rgb.is_empty() {
                continue; // culled: background, which the band already holds
            }
            for row in 0..t.h {
                let dst = (row * w + t.x0) as usize;
                let src = (row * t.w) as usize;
                let len = t.w as usize;
                rgb[dst * 3..(dst + len) * 3].copy_from_slice(&t.rgb[src * 3..(src + len) * 3]);
                if let Some(depth) = depth.as_deref_mut() {
                    depth[dst..dst + len].copy_from_slice(&t.depth[src..src + len]);
                }
                if let Some(normals) = normals.as_deref_mut() {
                    normals[dst..dst + len].copy_from_slice(&t.normals[src..src + len]);
                }
            }
        }
        counters
    }

    /// Whether the render was cancelled (asking `cancel` until it says so once).
    fn is_cancelled(&self) -> bool {
        let Some(cancel) = self.cancel else {
            return false;
        };
        if self.cancelled.load(Ordering::Relaxed) {
            return true;
        }
        let stop = cancel();
        if stop {
            self.cancelled.store(true, Ordering::Relaxed);
        }
        stop
    }

    fn tile(&self, x0: u32, y0: u32) -> Tile {
        let ts = self.plan.tile_size;
        let tw = ts.min(self.frame.width - x0);
        let th = ts.min(self.frame.height - y0);
        let n = (tw * th) as usize;
        if self.tile_misses_occupied(x0, y0, tw, th) {
            return Tile {
                x0,
                w: tw,
                h: th,
                rgb: Vec::new(),
                depth: Vec::new(),
                normals: Vec::new(),
                counters: Counters {
                    rays: n as u64,
                    ..Counters::default()
                },
            };
        }
        let mut tile = Tile {
            x0,
            w: tw,
            h: th,
            rgb: vec![0; n * 3],
            depth: if self.plan.keep_depth {
                vec![f32::INFINITY; n]
            } else {
                Vec::new()
            },
            normals: if self.plan.keep_normals {
                vec![Vec3::ZERO; n]
            } else {
                Vec::new()
            },
            counters: Counters::default(),
        };
        // Camera terms cached per tile: the same f64 sums as `CameraFrame::ray`, bit for bit.
        let columns: Vec<DVec3> = (x0..x0 + tw).map(|px| self.frame.column(px)).collect();
        let eye = self.frame.eye.as_vec3();
        let primary = self.occupied.primary;
        // Where the tile's four corner rays meet the box, every ray of the tile does (the rays
        // from a point that meet a convex box make a convex cone, and a pixel's direction is an
        // affine mix of the corners'): the per-ray test below is skipped. It only saves work (a
        // ray that misses the box hits nothing), so no pixel changes; it took 5 % of a far
        // view's instructions (abc5 from radius 12), most of them inside the object's outline.
        let corner_rays = [(0, 0), (tw - 1, 0), (0, th - 1), (tw - 1, th - 1)];
        let every_ray_meets = corner_rays.iter().all(|&(col, row)| {
            let dir = columns[col as usize] + self.frame.row(y0 + row);
            Self::meets_occupied(primary, eye, dir.as_vec3(), f32::INFINITY)
        });
        // Packets of PACKET_COLS × PACKET_ROWS neighbouring pixels traced together (one octree
        // walk for all; each ray's hit is exactly its single-ray hit).
        for row0 in (0..th).step_by(PACKET_ROWS) {
            let row_terms: [DVec3; PACKET_ROWS] =
                core::array::from_fn(|r| self.frame.row(y0 + (row0 + r as u32).min(th - 1)));
            for col0 in (0..tw).step_by(PACKET_COLS) {
                let mut rays = RayPacket {
                    origin: eye,
                    dirs: [Vec3::ZERO; PACKET],
                    lanes: 0,
                    t_max: f32::INFINITY,
                };
                for (l, dir) in rays.dirs.iter_mut().enumerate() {
                    let (col, row) = (
                        col0 + (l % PACKET_COLS) as u32,
                        row0 + (l / PACKET_COLS) as u32,
                    );
                    if col >= tw || row >= th {
                        continue;
                    }
                    let (column, row_term) = (columns[col as usize], row_terms[l / PACKET_COLS]);
                    // Rays that miss the occupied box are rejected on the unnormalised
                    // direction (same line; the box's padding dwarfs the rounding), before the
                    // f64 normalisation: most pixels of a typical view never need their exact
                    // ray.
                    tile.counters.rays += 1;
                    if !every_ray_meets
                        && !Self::meets_occupied(
                            primary,
                            eye,
                            (column + row_term).as_vec3(),
                            f32::INFINITY,
                        )
                    {
                        continue; // background (already there)
                    }
                    *dir = CameraFrame::direction(column, row_term);
                    rays.lanes |= 1 << l;
                }
                if rays.lanes == 0 {
                    continue;
                }
                let mut hits = [None; PACKET];
                self.scene.first_hits(&rays, &mut hits);
                for (l, hit) in hits.iter().enumerate() {
                    if let Some(hit) = hit {
                        let (col, row) = (
                            col0 + (l % PACKET_COLS) as u32,
                            row0 + (l / PACKET_COLS) as u32,
                        );
                        let at = TilePixel {
                            x: x0 + col,
                            y: y0 + row,
                            index: (row * tw + col) as usize,
                        };
                        self.shade(eye, rays.dirs[l], hit, at, &mut tile);
                    }
                }
            }
        }
        tile
    }

    /// Whether no primary ray of the tile can meet the occupied box
    /// ([`CameraFrame::tile_misses_box`]).
    fn tile_misses_occupied(&self, x0: u32, y0: u32, tw: u32, th: u32) -> bool {
        self.occupied
            .primary
            .is_some_and(|(lo, hi)| self.frame.tile_misses_box(x0, y0, tw, th, lo, hi))
    }

    /// Whether the ray `[0, t_max]` touches `bounds` (one of [`OccupiedBoxes`]), if any (if
    /// not, it hits nothing).
    #[inline]
    fn meets_occupied(bounds: Option<(Vec3, Vec3)>, o: Vec3, d: Vec3, t_max: f32) -> bool {
        bounds.is_none_or(|(lo, hi)| {
            sdfmo_trace::ray_meets_box(&sdfmo_trace::Ray { origin: o, dir: d }, lo, hi, 0.0, t_max)
        })
    }

    /// The pixel of a primary ray that hit: depth, normal and colour.
    #[inline]
    fn shade(&self, o: Vec3, d: Vec3, hit: &T::Hit, at: TilePixel, tile: &mut Tile) {
        let TilePixel {
            x: px,
            y: py,
            index: i,
        } = at;
        let c = &mut tile.counters;
        c.hits += 1;
        let t = self.scene.hit_t(hit);
        if self.plan.keep_depth {
            tile.depth[i] = t;
        }
        let mut n = Vec3::ZERO;
        if self.plan.normals {
            c.normal_evals += 1;
            n = self.scene.normal(o, d, hit);
            if n.dot(d) > 0.0 {
                n = -n; // two-sided: face the viewer
            }
            if self.plan.keep_normals {
                tile.normals[i] = n;
            }
        }
        // Normal and lambert modes always have `plan.normals` (validated).
        let rgb: [u8; 3] = match self.plan.mode {
            Mode::Mask => [255; 3],
            Mode::Depth => [depth_grey(t, self.range); 3],
            Mode::Normal => normal_rgb(n),
            Mode::Lambert => [self.lambert(o + d * t, n, px, py, c); 3],
        };
        tile.rgb[i * 3..i * 3 + 3].copy_from_slice(&rgb);
    }

    #[inline]
    fn lambert(&self, p: Vec3, n: Vec3, px: u32, py: u32, c: &mut Counters) -> u8 {
        let start = p + n * self.eps;
        let ndl = n.dot(self.light);
        let mut shadow = 1.0;
        if self.plan.shadow_rays && ndl > 0.0 {
            c.shadow_rays += 1;
            if Self::meets_occupied(self.occupied.secondary, start, self.light, f32::INFINITY)
                && self.scene.occluded(start, self.light, 0.0, f32::INFINITY)
            {
                shadow = 0.0;
            }
        }
        let mut ambient = 1.0;
        if self.plan.ao_samples > 0 {
            let mut rng = PixelRng::new(px, py);
            let mut open = 0u32;
            for _ in 0..self.plan.ao_samples {
                let dir = cosine_hemisphere(n, rng.next_f32(), rng.next_f32());
                if !(Self::meets_occupied(self.occupied.secondary, start, dir, AO_DISTANCE)
                    && self.scene.occluded(start, dir, 0.0, AO_DISTANCE))
                {
                    open += 1;
                }
            }
            c.ao_rays += u64::from(self.plan.ao_samples);
            ambient = open as f32 / self.plan.ao_samples as f32;
        }
        lambert_value(n, shadow, ambient)
    }
}

/// A pixel of a tile being shaded: its image coordinates (the occlusion samples' seed) and its
/// index in the tile's buffers.
#[derive(Clone, Copy)]
struct TilePixel {
    x: u32,
    y: u32,
    index: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hits every ray at a distance that encodes its direction, so the depth buffer shows
    /// exactly which ray each pixel cast.
    struct DirectionProbe;

    impl Traceable for DirectionProbe {
        type Hit = f32;
        fn first_hit(&self, o: Vec3, d: Vec3, _t0: f32, _t1: f32) -> Option<f32> {
            Some(10.0 + d.x + 3.0 * d.y + 7.0 * d.z + o.x)
        }
        fn hit_t(&self, hit: &f32) -> f32 {
            *hit
        }
        fn normal(&self, _o: Vec3, d: Vec3, _hit: &f32) -> Vec3 {
            -d
        }
    }

    /// Progress: once per band of tiles, the largest report 1, and the image and counters those
    /// of `render` (occlusion rays included), on 2 threads.
    #[test]
    fn progress_counts_every_band_and_changes_nothing() {
        use std::sync::Mutex;
        let scene = crate::Spheres::one(Vec3::ZERO, 0.5);
        let camera = Camera::paper_views(70, 50)[1];
        let settings = RenderSettings::new(Mode::Lambert).with_ao_samples(2);
        let reports = Mutex::new(Vec::new());
        let on = |f: f32| reports.lock().unwrap().push(f);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let with = pool.install(|| {
            RenderRequest::new(&scene, &camera, &settings)
                .progress(&on)
                .render()
                .unwrap()
        });
        let without = render(&scene, &camera, &settings).unwrap();
        assert_eq!(with.rgb, without.rgb);
        assert_eq!(with.counters, without.counters);
        let plan = RenderPlan::new(&settings).unwrap();
        let bands = 50u32.div_ceil(plan.tile_size);
        let reports = reports.into_inner().unwrap();
        assert_eq!(reports.len(), bands as usize);
        assert_eq!(reports.iter().copied().fold(0.0, f32::max), 1.0);
    }

    #[test]
    fn tiles_cast_exactly_the_cameras_primary_rays() {
        let camera = Camera::new(
            Vec3::new(0.7, -1.3, 2.9),
            Vec3::new(0.1, 0.2, 0.0),
            52.0,
            45,
            37,
        );
        let settings = RenderSettings::new(Mode::Depth);
        let plan = RenderPlan::new(&settings).unwrap().with_tile_size(16);
        let r = RenderRequest::new(&DirectionProbe, &camera, &settings)
            .plan(plan)
            .render()
            .unwrap();
        let depth = r.depth.unwrap();
        for py in 0..camera.height {
            for px in 0..camera.width {
                let (o, d) = camera.primary_ray(px, py);
                let expect = 10.0 + d.x + 3.0 * d.y + 7.0 * d.z + o.x;
                assert_eq!(
                    depth[(py * camera.width + px) as usize],
                    expect,
                    "pixel ({px},{py})"
                );
            }
        }
    }

    #[test]
    fn culled_tiles_hold_no_pixel_whose_ray_meets_the_occupied_box() {
        let boxes = [
            (Vec3::new(-0.9, -0.19, -0.47), Vec3::new(0.9, 0.19, 0.47)),
            (Vec3::new(0.2, 0.3, -0.1), Vec3::new(0.25, 0.9, 0.05)),
            (Vec3::new(-1.0, -1.0, -1.0), Vec3::new(-0.8, 1.0, 1.0)),
        ];
        let mut culled = 0;
        for (view, occupied) in (0..8).zip(boxes.iter().cycle()) {
            let camera = if view < 4 {
                Camera::paper_view(view, 61, 47)
            } else {
                Camera::new(Vec3::new(0.3, 1.9, -2.2), Vec3::ZERO, 75.0, 53, 64)
            };
            let frame = camera.frame().unwrap();
            let plan = RenderPlan::new(&RenderSettings::new(Mode::Mask))
                .unwrap()
                .with_tile_size(5);
            let ctx = Ctx {
                scene: &DirectionProbe,
                frame,
                plan,
                range: DepthRange::new(camera.eye, Vec3::splat(-1.0), Vec3::ONE),
                light: light_dir(),
                eps: 1e-4,
                occupied: OccupiedBoxes {
                    primary: Some(*occupied),
                    secondary: None,
                },
                progress: None,
                tiles_done: AtomicUsize::new(0),
                cancel: None,
                cancelled: AtomicBool::new(false),
            };
            for y0 in (0..frame.height).step_by(5) {
                for x0 in (0..frame.width).step_by(5) {
                    let (tw, th) = (5.min(frame.width - x0), 5.min(frame.height - y0));
                    if !ctx.tile_misses_occupied(x0, y0, tw, th) {
                        continue;
                    }
                    culled += 1;
                    for py in y0..y0 + th {
                        for px in x0..x0 + tw {
                            let (o, d) = camera.primary_ray(px, py);
                            assert!(
                                !Ctx::<DirectionProbe>::meets_occupied(
                                    ctx.occupied.primary,
                                    o,
                                    d,
                                    f32::INFINITY
                                ),
                                "({px},{py})"
                            );
                        }
                    }
                }
            }
        }
        assert!(culled > 200, "{culled} tiles culled");
    }
}
