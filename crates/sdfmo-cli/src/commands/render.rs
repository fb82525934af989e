//! `sdfmo render` and `sdfmo render-mesh`: the octree, or the source mesh as the reference.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use sdf_multioctree::distance::{reshape_fans, MeshDistance, SignMode};
use sdf_multioctree::format::{FormatError, SmoFile, SmoPrefix};
use sdf_multioctree::mesh::Normalization;
use sdf_multioctree::metrics;
use sdf_multioctree::render::{
    self, Camera, Counters, LevelRequest, LevelScene, MeshScene, Mode, RenderSettings, Rendered,
    Traceable,
};
use sdf_multioctree::{Device, Renderer};
use serde_json::json;

use crate::args::{DeviceArg, ModeArg, RenderArgs, RenderMeshArgs, RenderOptions, ViewsArg};
use crate::commands::{load_input, Workers};
use crate::output::{check_output_as, ensure_parent, indexed_path, print_json, print_text};
use crate::progress;
use sdf_multioctree::io::Naming;

/// Renders a `.smo` octree, on the CPU or on a GPU: the level `--lod` names (default: the
/// finest the data holds) or each ray's by `--pixel-error`, of a whole file or of a file with
/// levels cut where a level ends (a note on stderr says which levels are missing).
pub fn run_octree(args: &RenderArgs) -> anyhow::Result<()> {
    let outputs = check_options(&args.opts)?;
    let device = match args.device {
        DeviceArg::Cpu => Device::Cpu,
        DeviceArg::Gpu => {
            check_gpu_options(&args.opts)?;
            Device::Gpu
        }
    };
    let mut renderer = open_renderer(args, device)?;
    // Header first (a FIFO or device is refused unopened, a compressed file decoded); a 3.0
    // file is kept as its bricks, which either device traces as they are.
    let data =
        SmoFile::load_prefix(&args.octree, renderer.max_file_bytes()).map_err(|e| match e {
            // I/O errors name the file already; format errors do not.
            FormatError::Io(io) => anyhow::Error::new(io),
            e => anyhow::Error::new(e)
                .context(format!("cannot load octree {}", args.octree.display())),
        })?;
    let request = match (args.lod, args.pixel_error) {
        (Some(level), _) => LevelRequest::Level(level),
        (None, Some(pixels)) => LevelRequest::PixelError(pixels),
        (None, None) => LevelRequest::Finest,
    };
    let source = args.octree.display().to_string();
    // The request is checked before any work (the camera only sets a pixel error's scale).
    let (w, h) = args.opts.size;
    let first = request
        .scene(&data.file, &Camera::paper_view(0, w, h))
        .with_context(|| format!("cannot render {source}"))?;
    if !data.is_complete() {
        let drawing = match first {
            LevelScene::Level(s) => format!("drawing level {}", s.0.depth()),
            LevelScene::Bricks(s) => format!("drawing level {}", s.0.depth()),
            LevelScene::PixelError(_) => {
                format!(
                    "choosing among {} by the pixel error",
                    levels_text(data.held())
                )
            }
        };
        eprintln!(
            "note: {source} holds {} of {} (a prefix); {drawing}",
            levels_text(data.held()),
            range_text(data.declared)
        );
    }
    let frame = sdf_multioctree::file_frame(&data.file);
    let levels = FileLevels {
        data: &data,
        request,
    };
    let device_name = renderer.device_name().to_owned();
    let by = RenderedBy {
        source: &source,
        device: &device_name,
        timing: renderer.gpu().map(|g| g.timing().name()),
        levels: Some(levels),
    };
    // Errors on a GPU name its adapter.
    let on = match device {
        Device::Cpu => String::new(),
        Device::Gpu => format!(" on {device_name}"),
    };
    let mut prepared = renderer
        .prepare(&data.file, request)
        .with_context(|| format!("cannot render {source}{on}"))?;
    let settings = settings(&args.opts);
    // `--threads` is a CPU option (`check_gpu_options`): a GPU render runs without a pool.
    let workers = Workers::new(args.opts.threads)?;
    // A GPU frame is one dispatch: its progress moves per view only.
    let mut view = |cam: &Camera, progress: &Progress<'_>| -> anyhow::Result<Rendered> {
        workers
            .install(|| prepared.render_with(cam, &settings, Some(progress), None))
            .with_context(|| format!("cannot render {source}{on}"))
    };
    render_all(&mut view, &by, &args.opts, &frame, &outputs)
}

/// "levels 6-8", or "level 8" for one.
fn levels_text((coarsest, finest): (u8, u8)) -> String {
    if coarsest == finest {
        format!("level {coarsest}")
    } else {
        format!("levels {coarsest}-{finest}")
    }
}

/// "6-10", or "8" for one level.
fn range_text((coarsest, finest): (u8, u8)) -> String {
    if coarsest == finest {
        coarsest.to_string()
    } else {
        format!("{coarsest}-{finest}")
    }
}

/// The levels of the file a render draws from, for `--json`'s `levels`.
#[derive(Clone, Copy)]
struct FileLevels<'a> {
    data: &'a SmoPrefix,
    request: LevelRequest,
}

/// What a render's summary says of where its images come from: the input, the device that
/// traced the rays, how a GPU timed its kernel, and an octree file's levels.
struct RenderedBy<'a> {
    /// Names the input.
    source: &'a str,
    /// Where the rays were traced: "cpu" or the GPU adapter's name.
    device: &'a str,
    /// How a GPU timed its kernel.
    timing: Timing,
    /// The levels of a `.smo` input (none for a mesh).
    levels: Option<FileLevels<'a>>,
}

impl<'a> RenderedBy<'a> {
    /// Rays traced on the CPU.
    fn cpu(source: &'a str) -> RenderedBy<'a> {
        RenderedBy {
            source,
            device: "cpu",
            timing: None,
            levels: None,
        }
    }
}

/// `"levels"` of `--json`: the levels the file has (`file`), those the data holds (`held`;
/// fewer for a prefix) and those the views were drawn at (`drawn`: the one level, or with a
/// pixel error every level the rule can choose for each view's eye), each a list of levels.
fn levels_json(levels: &FileLevels<'_>, cams: &[Camera]) -> anyhow::Result<serde_json::Value> {
    let list = |(a, b): (u8, u8)| (a..=b).collect::<Vec<u8>>();
    let FileLevels { data, request } = *levels;
    let mut drawn = std::collections::BTreeSet::new();
    for cam in cams {
        let (a, b) = request.scene(&data.file, cam)?.levels(cam.eye);
        drawn.extend(a..=b);
    }
    Ok(json!({
        "file": list(data.declared),
        "held": list(data.held()),
        "drawn": drawn,
    }))
}

/// The renderer of `sdfmo render --device`; on a GPU, the file's length is checked against the
/// adapter's limit before the file is read (issue 19: a 2.18 GB file used to be read, copied and
/// validated, 4.26 GB at the peak, before it was refused).
fn open_renderer(args: &RenderArgs, device: Device) -> anyhow::Result<Renderer> {
    // The facade's error says "GPU: …" already.
    let renderer = Renderer::new(device).context("cannot render")?;
    if let (Some(gpu), Ok(meta)) = (renderer.gpu(), std::fs::metadata(&args.octree)) {
        gpu.check_file_size(meta.len()).with_context(|| {
            format!(
                "cannot render {} on {}",
                args.octree.display(),
                gpu.adapter_name()
            )
        })?;
    }
    Ok(renderer)
}

/// The GPU kernel renders the primary rays only: shadows, occlusion and a thread count are
/// CPU options.
fn check_gpu_options(opts: &RenderOptions) -> anyhow::Result<()> {
    if opts.shadows || opts.ao > 0 {
        anyhow::bail!("--shadows and --ao are not available with --device gpu (primary rays only); use --device cpu");
    }
    if opts.threads.is_some() {
        anyhow::bail!("--threads applies to --device cpu only");
    }
    Ok(())
}

/// What a view's render reports its progress to: the fraction of the view done.
type Progress<'a> = dyn Fn(f32) + Sync + 'a;

/// One CPU render per camera (no GPU time).
fn cpu_views<'a, T: Traceable>(
    scene: &'a T,
    opts: &'a RenderOptions,
    source: &'a str,
) -> anyhow::Result<impl FnMut(&Camera, &Progress<'_>) -> anyhow::Result<Rendered> + 'a> {
    let settings = settings(opts);
    let workers = Workers::new(opts.threads)?;
    Ok(move |cam: &Camera, progress: &Progress<'_>| {
        workers
            .install(|| {
                render::RenderRequest::new(scene, cam, &settings)
                    .progress(progress)
                    .render()
            })
            .with_context(|| format!("cannot render {source}"))
    })
}

/// Renders the source mesh, normalised exactly as the builder does, so the images line up with
/// the octree's.
pub fn run_mesh(args: &RenderMeshArgs) -> anyhow::Result<()> {
    let outputs = check_options(&args.opts)?;
    let input = load_input(args.mesh.as_deref())?;
    // Only the surface matters for the images: flat fans re-triangulated.
    let reshaped = reshape_fans(&input.mesh);
    let mesh = reshaped.as_ref().map_or(&input.mesh, |r| &r.mesh);
    let (normalized, frame) = mesh.normalized(sdf_multioctree::DEFAULT_MARGIN);
    let dist = MeshDistance::new(&normalized, SignMode::Auto)
        .with_context(|| format!("cannot prepare ray queries on {}", input.source))?;
    let scene = MeshScene(&dist);
    let mut view = cpu_views(&scene, &args.opts, &input.source)?;
    let by = RenderedBy::cpu(&input.source);
    render_all(&mut view, &by, &args.opts, &frame, &outputs)
}

/// How a GPU measured its kernel time (`timestamps` or `wall`); `None` on the CPU.
type Timing = Option<&'static str>;

/// The files one view writes: the PNG and, when asked, the EXR.
type ViewOutputs = (PathBuf, Option<PathBuf>);

/// Several views number the names the user gave (`out.png` → `out_2.png`): derived names,
/// where a symbolic link is replaced instead of followed; one view writes the name as given.
fn output_naming(views: usize) -> Naming {
    if views > 1 {
        Naming::Derived
    } else {
        Naming::Given
    }
}

/// Checks the options before any work: flags the mode cannot use are errors, and every output
/// (numbered per view) must have the right extension and be a file that may be replaced.
/// Returns the outputs of each view.
fn check_options(opts: &RenderOptions) -> anyhow::Result<Vec<ViewOutputs>> {
    if opts.mode != ModeArg::Lambert && (opts.shadows || opts.ao > 0) {
        anyhow::bail!(
            "--shadows and --ao apply to --mode lambert only (the {} mode casts no light rays)",
            opts.mode.name()
        );
    }
    let views = cameras(opts, &Normalization::IDENTITY).len();
    let naming = output_naming(views);
    let name = |p: &PathBuf, k: usize| {
        if views > 1 {
            indexed_path(p, k)
        } else {
            p.clone()
        }
    };
    (0..views)
        .map(|k| {
            let png = name(&opts.output, k);
            check_output_as(&png, "the image (-o)", &["png"], naming)?;
            let exr = match &opts.exr {
                Some(p) => {
                    let p = name(p, k);
                    check_output_as(&p, "the EXR image (--exr)", &["exr"], naming)?;
                    Some(p)
                }
                None => None,
            };
            Ok((png, exr))
        })
        .collect()
}

impl ModeArg {
    /// The renderer's mode.
    pub fn mode(self) -> Mode {
        match self {
            ModeArg::Mask => Mode::Mask,
            ModeArg::Depth => Mode::Depth,
            ModeArg::Normal => Mode::Normal,
            ModeArg::Lambert => Mode::Lambert,
        }
    }

    /// The flag's spelling.
    pub fn name(self) -> &'static str {
        match self {
            ModeArg::Mask => "mask",
            ModeArg::Depth => "depth",
            ModeArg::Normal => "normal",
            ModeArg::Lambert => "lambert",
        }
    }
}

/// The cameras the options ask for: the paper's four views, or one camera (paper view 0 with
/// `--eye`, `--target`, `--fov` overriding its parts). `--eye` and `--target` are model units
/// mapped through `frame` (the source's normalisation, by [`sdf_multioctree::placed_camera`] as
/// Python's) unless `--normalized`.
pub fn cameras(opts: &RenderOptions, frame: &Normalization) -> Vec<Camera> {
    let (w, h) = opts.size;
    let mut paper = Camera::paper_views(w, h);
    if opts.views == Some(ViewsArg::Paper) {
        return paper;
    }
    let frame = (!opts.normalized).then_some(frame);
    let cam = sdf_multioctree::placed_camera(
        paper.swap_remove(0),
        opts.eye,
        opts.target,
        opts.fov,
        frame,
    );
    vec![cam]
}

/// The render settings the options ask for.
pub fn settings(opts: &RenderOptions) -> RenderSettings {
    RenderSettings::new(opts.mode.mode())
        .with_shadows(opts.shadows)
        .with_ao_samples(opts.ao)
}

/// Counters as a JSON object.
pub fn counters_json(c: &Counters) -> serde_json::Value {
    json!({
        "rays": c.rays,
        "normal_evals": c.normal_evals,
        "shadow_rays": c.shadow_rays,
        "ao_rays": c.ao_rays,
        "hits": c.hits,
    })
}

/// Renders every camera with `render_view` (the image, on a GPU with the kernel's time), writes
/// the PNGs (and EXRs) all or none, prints times and counters. `by` says where the images come
/// from, `frame` is the source's normalisation (for `--eye`/`--target` in model units).
fn render_all(
    render_view: &mut dyn FnMut(&Camera, &Progress<'_>) -> anyhow::Result<Rendered>,
    by: &RenderedBy<'_>,
    opts: &RenderOptions,
    frame: &Normalization,
    outputs: &[ViewOutputs],
) -> anyhow::Result<()> {
    let RenderedBy {
        source,
        device,
        timing,
        ..
    } = *by;
    let cams = cameras(opts, frame);
    ensure_parent(&opts.output)?;
    if let Some(exr) = &opts.exr {
        ensure_parent(exr)?;
    }

    let naming = output_naming(cams.len());
    // A fraction over all views, moved by the renderer's tiles within each (one 2048² view with
    // occlusion takes many seconds).
    let bar = progress::fraction("rendering");
    let views_n = cams.len().max(1) as f32;
    let mut views = Vec::new();
    let mut total = Counters::default();
    let mut total_ms = 0.0;
    let mut total_gpu_ms: Option<f64> = None;
    // Every image is encoded and staged (written to a synced temporary) before the first is
    // renamed into place: an encoding error or a full disk leaves every destination as it was.
    let mut batch = sdf_multioctree::io::OutputBatch::new();
    for (cam, (png, exr)) in cams.iter().zip(outputs) {
        let k = views.len() as f32;
        if cams.len() > 1 {
            bar.set_message(format!(
                "rendering view {} of {}",
                views.len() + 1,
                cams.len()
            ));
        }
        let frames = u32::from(opts.frames.max(1));
        let (mut frame_ms, mut frame_gpu_ms) = (Vec::new(), Vec::new());
        let mut last = None;
        for frame in 0..frames {
            let on_progress = |f: f32| {
                let f = (frame as f32 + f) / frames as f32;
                progress::set_fraction(&bar, (k + f) / views_n)
            };
            let r = render_view(cam, &on_progress)?;
            frame_ms.push(r.render_ms);
            frame_gpu_ms.extend(r.kernel_ms);
            last = Some(r);
        }
        let mut r = last.expect("at least one frame");
        let mut gpu_ms = r.kernel_ms;
        r.render_ms = metrics::median(frame_ms).unwrap_or(r.render_ms);
        gpu_ms = gpu_ms.and(metrics::median(frame_gpu_ms));
        batch.stage_as(png, &render::encode_png(&r, png)?, naming)?;
        if let Some(p) = exr {
            batch.stage_as(p, &render::encode_exr(&r, p)?, naming)?;
        }
        total += r.counters;
        total_ms += r.render_ms;
        if let Some(g) = gpu_ms {
            *total_gpu_ms.get_or_insert(0.0) += g;
        }
        views.push((png.clone(), exr.clone(), r.render_ms, gpu_ms, r.counters));
        progress::set_fraction(&bar, views.len() as f32 / views_n);
    }
    batch.commit()?;
    bar.finish_and_clear();

    let (w, h) = opts.size;
    if opts.json {
        let per_view: Vec<_> = views
            .iter()
            .map(|(png, exr, ms, gpu_ms, c)| {
                json!({
                    "output": png.display().to_string(),
                    "exr": exr.as_ref().map(|p| p.display().to_string()),
                    "render_ms": ms,
                    "gpu_ms": gpu_ms,
                    "counters": counters_json(c),
                })
            })
            .collect();
        return print_json(&json!({
            "source": source,
            "mode": opts.mode.name(),
            "frame": if opts.normalized { "normalized" } else { "model" },
            "width": w,
            "height": h,
            "device": device,
            "views": per_view,
            "render_ms": total_ms,
            "gpu_ms": total_gpu_ms,
            "gpu_timing": timing,
            "frames": opts.frames,
            "counters": counters_json(&total),
            "levels": by.levels.as_ref().map(|l| levels_json(l, &cams)).transpose()?,
        }));
    }
    let mut s = String::new();
    for (png, exr, ms, gpu_ms, c) in &views {
        let _ = write!(s, "{} ({}x{} {}", png.display(), w, h, opts.mode.name());
        if let Some(e) = exr {
            let _ = write!(s, ", {}", e.display());
        }
        let _ = write!(s, "): {ms:.1} ms");
        if let Some(g) = gpu_ms {
            let _ = write!(s, " ({g:.2} ms kernel on {device})");
        }
        let _ = writeln!(
            s,
            ", {} rays ({} hits), {} normals, {} shadow rays, {} AO rays",
            c.rays, c.hits, c.normal_evals, c.shadow_rays, c.ao_rays
        );
    }
    if views.len() > 1 {
        let _ = writeln!(s, "total {total_ms:.1} ms over {} views", views.len());
    }
    print_text(&s)
}
