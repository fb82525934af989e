//! Command-line arguments (clap derive) and the parsers of their values.

use std::ops::RangeInclusive;
use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Triangle meshes to sparse multi-voxel signed-distance octrees, and a ray tracer for them.
#[derive(Debug, Parser)]
#[command(name = "sdfmo", version, about, long_about = None)]
pub struct Cli {
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands of `sdfmo`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Mesh statistics: triangles, vertices, parts, components, open and non-manifold edges;
    /// for a `.smo` file, its levels with their voxels and bytes.
    Info(InfoArgs),
    /// Signed distances of points to a mesh (in the normalised frame of the octree).
    Distance(DistanceArgs),
    /// Builds an octree (SVO baseline or multi-octree) from a mesh and saves it as `.smo`.
    Build(BuildArgs),
    /// Ray traces a `.smo` octree to PNG (and optionally EXR).
    Render(RenderArgs),
    /// Ray traces the source mesh with the same cameras and shading (the reference image).
    RenderMesh(RenderMeshArgs),
    /// PSNR and FLIP between a reference and a test image, optionally a FLIP heat map.
    Compare(CompareArgs),
    /// Build, render and compare over meshes, methods and depths: tables, plots and a web page.
    Sweep(Box<SweepArgs>),
    /// Writes seeded CAD-like parts (plates with holes and slots, bosses, fins, fillets, stacked
    /// blocks, open sheets) as OBJ files, with a manifest for `sweep --manifest`.
    GenerateParts(GeneratePartsArgs),
}

/// `sdfmo generate-parts`.
#[derive(Debug, Args)]
pub struct GeneratePartsArgs {
    /// Number of parts, 1..=1000000.
    #[arg(short = 'n', long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub count: u64,
    /// Seed of the set: part i is `cad_part(part_seed(SEED, i))`, the same on every run.
    #[arg(long, value_name = "SEED", default_value_t = 1)]
    pub seed: u64,
    /// Index of the first part (to extend a set: the parts FIRST..FIRST+N).
    #[arg(long, value_name = "FIRST", default_value_t = 0)]
    pub first: u64,
    /// Output folder (created if missing): `part_NNNNNN.obj` and `manifest.csv` (id,path).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Print one JSON object on stdout instead of the human summary.
    #[arg(long)]
    pub json: bool,
}

/// `sdfmo info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Mesh file (OBJ, glTF/GLB, STL), or a `.smo` octree (recognised by its magic bytes; a
    /// file with levels may be a prefix, e.g. a download in progress); without it, the
    /// built-in demo part.
    pub mesh: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the human summary.
    #[arg(long)]
    pub json: bool,
}

/// How the sign of a distance is decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SignArg {
    /// Pseudo-normals for closed manifolds, winding numbers otherwise (from the topology).
    Auto,
    /// Angle-weighted pseudo-normals (closed manifold meshes).
    Pseudonormal,
    /// Generalised winding number (open or non-manifold meshes).
    Winding,
}

/// `sdfmo distance`.
#[derive(Debug, Args)]
pub struct DistanceArgs {
    /// Mesh file (OBJ, glTF/GLB, STL).
    pub mesh: PathBuf,
    /// Text file of points, one `x y z` a line, in model units (the mesh's own coordinates, as
    /// Python and the library take them; `--normalized` for the octree's frame); blank lines and
    /// lines starting with `#` are skipped. The distances are in the points' units.
    #[arg(long, value_name = "FILE")]
    pub points: PathBuf,
    /// The points (and so the distances) are in the normalised frame: the root cube [-1, 1]³ the
    /// mesh is normalised into with margin 0.05, as the builder does.
    #[arg(long)]
    pub normalized: bool,
    /// Sign method.
    #[arg(long, value_enum, default_value_t = SignArg::Auto)]
    pub sign: SignArg,
    /// Output file (one signed distance a line); default stdout.
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// Worker threads for the queries (default: all cores).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Print one JSON object on stdout (with the distances in it unless `-o` is given).
    #[arg(long)]
    pub json: bool,
}

/// Octree construction method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Classic sparse voxel octree: one voxel per leaf (the paper's baseline).
    Svo,
    /// Multi-octree: one voxel per connected component in a leaf, surface voxels.
    Multi,
}

impl MethodArg {
    /// The name used in tables and file names.
    pub fn name(self) -> &'static str {
        match self {
            MethodArg::Svo => "svo",
            MethodArg::Multi => "multi",
        }
    }
}

/// Quantisation of the corner values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BitsArg {
    /// 8 bits per corner (default, compact).
    #[value(name = "8")]
    Eight,
    /// 16 bits per corner (high quality).
    #[value(name = "16")]
    Sixteen,
}

/// The `.smo` layout `sdfmo build` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    /// Version 1.x: eight corner codes per voxel (default; what the tracers read).
    #[value(name = "1")]
    V1,
    /// Version 3.1: bricks of 4³ cells that store each shared corner once (FORMAT.md, "Bricks
    /// (version 3.0)"), with narrow private voxels ("Narrow private voxels (version 3.1)"; 3.0
    /// when a leaf holds more than 127 voxels); depth ≥ 2. With `--lod`, version 4.1: the levels as bricks, each finer
    /// level coded from the one before it (FORMAT.md, "Levels of bricks");
    /// coarsest level ≥ 2. Loaded as 1.x octrees for now.
    #[value(name = "3")]
    V3,
}

/// `sdfmo build`.
#[derive(Debug, Args)]
pub struct BuildArgs {
    /// Mesh file (OBJ, glTF/GLB, STL); without it, the built-in demo part.
    pub mesh: Option<PathBuf>,
    /// Octree depth, 1..=16: leaves of edge 2/2^DEPTH in the root cube [-1, 1]³.
    #[arg(short, long, value_name = "DEPTH", value_parser = parse_depth, allow_hyphen_values = true)]
    pub depth: u8,
    /// Construction method.
    #[arg(long, value_enum, default_value_t = MethodArg::Multi)]
    pub method: MethodArg,
    /// Most voxels per leaf, 1..=255 (multi-octree only).
    #[arg(long, value_name = "N", default_value_t = 8, value_parser = clap::value_parser!(u8).range(1..))]
    pub max_voxels: u8,
    /// Memory budget of the build, e.g. `8G`, `512M` or bytes (default: half the physical
    /// memory). A build whose predicted peak exceeds it is refused before it starts.
    #[arg(long, value_name = "SIZE", value_parser = parse_memory)]
    pub max_memory: Option<u64>,
    /// Bits per quantised corner value.
    #[arg(long, value_enum, default_value_t = BitsArg::Eight)]
    pub bits: BitsArg,
    /// Sign method of the distances.
    #[arg(long, value_enum, default_value_t = SignArg::Auto)]
    pub sign: SignArg,
    /// Worker threads (default: all cores); the output is the same for any count.
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Output `.smo` file (written atomically; must end in `.smo`).
    #[arg(short, long, value_name = "OUT.smo")]
    pub output: PathBuf,
    /// Levels of detail: write every level from `--coarsest` to DEPTH, coarsest first (a
    /// version-2.0 file; each level is what a build of that depth makes).
    #[arg(long)]
    pub lod: bool,
    /// The coarsest level written with `--lod`, 1..=DEPTH (default: DEPTH − 4, at least 1).
    #[arg(long, value_name = "LEVEL", requires = "lod", value_parser = parse_depth)]
    pub coarsest: Option<u8>,
    /// File format: 1 (1.x; 2.0 with `--lod`) or 3 (3.1 bricks, a third of the bytes; with
    /// `--lod`, 4.1: levels of bricks, about the bytes of the finest level alone).
    #[arg(long, value_enum, default_value_t = FormatArg::V1)]
    pub format: FormatArg,
    /// Write the compressed container (FORMAT.md, "Compressed files"): the same octree in
    /// about a tenth of the bytes, decoded on load by every reader. LEVEL is zstd's, 1..=22
    /// (default: the library's `DEFAULT_COMPRESSION_LEVEL`, 9; 19 is about 10 % smaller and
    /// several times slower to write).
    #[arg(long, value_name = "LEVEL", num_args = 0..=1, require_equals = true,
          value_parser = clap::value_parser!(i32).range(1..=22))]
    pub compress: Option<Option<i32>>,
    /// Corners fitted to the surface: the shared corner values chosen so that the voxels' zero
    /// set follows the mesh (a least-squares fit within a few quantisation steps of the exact
    /// distance) instead of the exact distance: +1.03 dB median at depth 9 (multi), the same
    /// leaves, voxels and bytes, 1.5–3.5× the build time at depth 9.
    #[arg(long)]
    pub fit_corners: bool,
    /// Print one JSON object on stdout instead of the human summary.
    #[arg(long)]
    pub json: bool,
}

impl BuildArgs {
    /// The coarsest level to build: `None` without `--lod`.
    pub fn coarsest_level(&self) -> Option<u8> {
        self.lod
            .then(|| self.coarsest.unwrap_or(self.depth.saturating_sub(4).max(1)))
    }

    /// The zstd level of `--compress` (bare: the library's default): `None` without it.
    pub fn compress_level(&self) -> Option<i32> {
        self.compress.map(|level| {
            level.unwrap_or(sdf_multioctree::format::compressed::DEFAULT_COMPRESSION_LEVEL)
        })
    }
}

/// What a render computes and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    /// White where a ray hits, black elsewhere.
    Mask,
    /// Grey levels of the hit distance.
    Depth,
    /// Normals mapped to colours.
    Normal,
    /// White Lambertian surface, one directional light plus ambient (the paper's shading).
    Lambert,
}

/// Where `sdfmo render` traces its rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum DeviceArg {
    /// The CPU kernel (sdfmo-trace), on `--threads` threads.
    #[default]
    Cpu,
    /// The WGSL kernel (sdfmo-gpu) on the first GPU adapter wgpu finds (`WGPU_ADAPTER_NAME`
    /// picks one); no shadows or ambient occlusion.
    Gpu,
}

/// A list of predefined cameras.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ViewsArg {
    /// The paper's four views: radius 3 in the y = 0 plane, looking at the origin, fov 60°.
    Paper,
}

/// Camera, mode and output options shared by `render` and `render-mesh`.
#[derive(Debug, Args)]
pub struct RenderOptions {
    /// Output PNG (must end in `.png`); with several views `_0`, `_1`, … are inserted before
    /// the extension.
    #[arg(short, long, value_name = "OUT.png")]
    pub output: PathBuf,
    /// What to compute and write.
    #[arg(long, value_enum, default_value_t = ModeArg::Lambert)]
    pub mode: ModeArg,
    /// Shadows from the light (lambert mode only; an error with other modes).
    #[arg(long)]
    pub shadows: bool,
    /// Ambient-occlusion rays per pixel, 0..=1024 (0: none; lambert mode only).
    #[arg(long, value_name = "N", default_value_t = 0,
          value_parser = clap::value_parser!(u32).range(0..=i64::from(sdf_multioctree::render::MAX_AO_SAMPLES)))]
    pub ao: u32,
    /// Camera position, in model units (the mesh's own coordinates; `--normalized` for the
    /// octree's frame). Default: the paper's view 0, (0, 0, 3) in the normalised frame.
    #[arg(long, value_name = "x,y,z", value_parser = parse_vec3, allow_hyphen_values = true, conflicts_with = "views")]
    pub eye: Option<[f32; 3]>,
    /// Point looked at, in model units like `--eye` (default: the origin of the normalised
    /// frame, the centre of the model's bounding box).
    #[arg(long, value_name = "x,y,z", value_parser = parse_vec3, allow_hyphen_values = true, conflicts_with = "views")]
    pub target: Option<[f32; 3]>,
    /// `--eye` and `--target` are in the normalised frame, the root cube [-1, 1]³ the octree and
    /// the paper's views are defined in, instead of model units.
    #[arg(long, conflicts_with = "views")]
    pub normalized: bool,
    /// Vertical field of view in degrees (default 60).
    #[arg(long, value_name = "DEG", value_parser = parse_fov, conflicts_with = "views")]
    pub fov: Option<f32>,
    /// Render a predefined set of views instead of one camera.
    #[arg(long, value_enum)]
    pub views: Option<ViewsArg>,
    /// Image size in pixels, `WxH` or `N` for a square.
    #[arg(long, value_name = "WxH", value_parser = parse_size, default_value = "1024x1024")]
    pub size: (u32, u32),
    /// Worker threads (default: all cores); the image is the same for any count.
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Also write the image as f32 EXR: RGB, plus the ray distance (Z) in depth mode and the
    /// normal (N.X, N.Y, N.Z) in normal mode (must end in `.exr`; numbered like the PNG with
    /// several views). All images of one command are written, or none.
    #[arg(long, value_name = "OUT.exr")]
    pub exr: Option<PathBuf>,
    /// Renders of each view, 1..=100: the times reported (`render_ms`, `gpu_ms`) are each
    /// view's median over them, so that a timing run does not pay a process start and a cold
    /// cache per frame (every render of a view is the same image; the last one is written).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..=100))]
    pub frames: u16,
    /// Print one JSON object on stdout instead of the human summary.
    #[arg(long)]
    pub json: bool,
}

/// `sdfmo render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Octree file written by `sdfmo build`.
    pub octree: PathBuf,
    /// Trace on the CPU or on a GPU (the same images; `--json` adds `device` and `gpu_ms`).
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu)]
    pub device: DeviceArg,
    /// Draw level LEVEL of a file with levels (`sdfmo build --lod`; default: the finest). A
    /// file without levels has one, its depth.
    #[arg(long, value_name = "LEVEL", value_parser = clap::value_parser!(u8).range(0..=16))]
    pub lod: Option<u8>,
    /// Screen-space error of a file with levels: each ray stops at the coarsest level whose
    /// voxels project to at most E pixels at its hit distance, with `--device cpu` or `gpu`
    /// (the same rule; default: off, the finest level or `--lod`).
    #[arg(long, value_name = "E", conflicts_with = "lod", value_parser = parse_pixel_error)]
    pub pixel_error: Option<f32>,
    /// Camera, mode and outputs.
    #[command(flatten)]
    pub opts: RenderOptions,
}

/// `sdfmo render-mesh`.
#[derive(Debug, Args)]
pub struct RenderMeshArgs {
    /// Mesh file (OBJ, glTF/GLB, STL), normalised exactly as the builder does; without it, the
    /// built-in demo part.
    pub mesh: Option<PathBuf>,
    /// Camera, mode and outputs.
    #[command(flatten)]
    pub opts: RenderOptions,
}

/// `sdfmo compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// Reference image (PNG).
    pub reference: PathBuf,
    /// Test image (PNG) of the same size.
    pub test: PathBuf,
    /// Write the FLIP error map as a colour heat map (PNG).
    #[arg(long, value_name = "OUT.png")]
    pub heatmap: Option<PathBuf>,
    /// Print one JSON object on stdout; `psnr` is `null` when the images are identical
    /// (infinite PSNR), with `"identical": true`.
    #[arg(long)]
    pub json: bool,
}

/// `sdfmo sweep`: without a step, a sweep of the meshes given (the same as `sweep run`); the
/// flag forms `--manifest` and `--merge` are the steps `shard` and `merge`, kept for scripts.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct SweepArgs {
    /// The step to run, named for what it does.
    #[command(subcommand)]
    pub step: Option<SweepStep>,
    /// Mesh files; without any, the built-in demo part.
    pub meshes: Vec<PathBuf>,
    /// Depths, methods, sizes, threads, frames.
    #[command(flatten)]
    pub settings: SweepSettingsArgs,
    /// Build each model with each method once, with levels of detail from the first depth to
    /// the last (`build --lod`), and score every level of that one file: the rows are those of
    /// separate builds (a level is, byte for byte, that depth's build) plus the bytes a reader
    /// needs for each level (`bytes_read`); the report gains a "levels of one file" table and
    /// a plot of PSNR against bytes read.
    #[arg(long, conflicts_with = "merge")]
    pub levels: bool,
    /// Rows from another producer (a results.json, or a JSON array of rows in its row schema;
    /// docs/cli.md), merged into the tables, plots and page; repeatable. Checked before any
    /// work: a bad file or a row repeating one of this sweep's configurations is an error.
    #[arg(long = "extra-rows", value_name = "FILE")]
    pub extra_rows: Vec<PathBuf>,
    /// Output folder and format.
    #[command(flatten)]
    pub out: SweepOutputArgs,
    /// The step `shard`: sweep the models a manifest lists (one path per line, or CSV
    /// `id,path`; relative to the manifest's folder), each in its own process with a ledger in
    /// the output folder (docs/scale.md).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["meshes", "merge"])]
    pub manifest: Option<PathBuf>,
    /// Which models of the manifest, with --manifest.
    #[command(flatten)]
    pub dataset: SweepDatasetArgs,
    /// The step `merge`: merge the output folders of shards (or of one manifest sweep) into
    /// one dataset report in -o.
    #[arg(long, value_name = "DIR", num_args = 1.., conflicts_with = "meshes")]
    pub merge: Vec<PathBuf>,
    /// Internal: sweep one mesh as a shard's child process under this model name, print one
    /// JSON line (its rows) and write its images, nothing else.
    #[arg(long, value_name = "NAME", hide = true, conflicts_with_all = ["manifest", "merge"])]
    pub isolated_model: Option<String>,
}

/// The steps of `sdfmo sweep`.
#[derive(Debug, Subcommand)]
pub enum SweepStep {
    /// Sweep the meshes given (the built-in demo part without any): build, render and compare
    /// each method and depth; tables, plots and a page in -o. The same as `sweep [MESH…]`.
    Run(SweepRunArgs),
    /// Run one shard of a dataset manifest: each model in its own process, one ledger line per
    /// model, resumable (docs/scale.md). The same as `sweep --manifest FILE`.
    Shard(SweepShardArgs),
    /// Merge the output folders of a manifest's shards into one dataset report in -o. The same
    /// as `sweep --merge DIR…`.
    Merge(SweepMergeArgs),
}

/// `sdfmo sweep run`.
#[derive(Debug, Args)]
pub struct SweepRunArgs {
    /// Mesh files; without any, the built-in demo part.
    pub meshes: Vec<PathBuf>,
    /// Depths, methods, sizes, threads, frames.
    #[command(flatten)]
    pub settings: SweepSettingsArgs,
    /// Score every level of one build with levels of detail per model and method (as
    /// `sweep --levels`).
    #[arg(long)]
    pub levels: bool,
    /// Rows from another producer merged into the tables, plots and page (as
    /// `sweep --extra-rows`); repeatable.
    #[arg(long = "extra-rows", value_name = "FILE")]
    pub extra_rows: Vec<PathBuf>,
    /// Output folder and format.
    #[command(flatten)]
    pub out: SweepOutputArgs,
}

/// `sdfmo sweep shard`.
#[derive(Debug, Args)]
pub struct SweepShardArgs {
    /// The manifest: one mesh path per line, or CSV `id,path`; relative to its folder.
    #[arg(value_name = "MANIFEST")]
    pub manifest: PathBuf,
    /// Depths, methods, sizes, threads, frames.
    #[command(flatten)]
    pub settings: SweepSettingsArgs,
    /// Score every level of one build with levels of detail (as `sweep --levels`).
    #[arg(long)]
    pub levels: bool,
    /// Which models, with what limits.
    #[command(flatten)]
    pub dataset: SweepDatasetArgs,
    /// Output folder and format.
    #[command(flatten)]
    pub out: SweepOutputArgs,
}

/// `sdfmo sweep merge`.
#[derive(Debug, Args)]
pub struct SweepMergeArgs {
    /// The output folders of the shards (or of one manifest sweep).
    #[arg(value_name = "DIR", required = true, num_args = 1..)]
    pub shards: Vec<PathBuf>,
    /// Output folder and format.
    #[command(flatten)]
    pub out: SweepOutputArgs,
}

/// The settings every sweep of meshes runs with.
#[derive(Debug, Args)]
pub struct SweepSettingsArgs {
    /// Depths, inclusive, within 1..=16: `A..B` (or `A..=B`, or one depth `A`).
    #[arg(long, value_name = "A..B", value_parser = parse_depths, default_value = "6..9")]
    pub depths: RangeInclusive<u8>,
    /// Methods, comma separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "svo,multi")]
    pub methods: Vec<MethodArg>,
    /// Image size of each (square) view in pixels.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(8..=8192), default_value_t = 1024)]
    pub size: u32,
    /// Most voxels per leaf of the multi-octree, 1..=255.
    #[arg(long, value_name = "N", default_value_t = 8, value_parser = clap::value_parser!(u8).range(1..))]
    pub max_voxels: u8,
    /// Corners fitted to the surface in every build (as `build --fit-corners`): the rows show
    /// what the fit gains and what it costs in build time.
    #[arg(long)]
    pub fit_corners: bool,
    /// Memory budget of each build (as for `build --max-memory`); checked for the deepest
    /// depth of every mesh before any work.
    #[arg(long, value_name = "SIZE", value_parser = parse_memory)]
    pub max_memory: Option<u64>,
    /// Worker threads for builds and renders (default: all cores).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Renders of each view per configuration; the render time is their median, 1..=100.
    #[arg(long, value_name = "N", default_value_t = SWEEP_FRAMES, value_parser = clap::value_parser!(u16).range(1..=100))]
    pub frames: u16,
}

/// Renders of each view per configuration unless `--frames` says otherwise (also the frames a
/// merge records in its provenance).
pub const SWEEP_FRAMES: u16 = 5;

/// Where a sweep writes.
#[derive(Debug, Args)]
pub struct SweepOutputArgs {
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR", default_value = "sweep")]
    pub output: PathBuf,
    /// Print one JSON object on stdout (the rows) instead of the human summary.
    #[arg(long)]
    pub json: bool,
}

/// Which models of a manifest a shard runs, and its limits.
#[derive(Debug, Args)]
pub struct SweepDatasetArgs {
    /// Refuse manifest paths outside the manifest's folder (absolute, `..`, links).
    #[arg(long, requires = "manifest")]
    pub confine: bool,
    /// Run shard K of N (0-based): the models at positions K, K + N, … Default: from
    /// SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT, or JOB_COMPLETION_INDEX and
    /// SDFMO_SHARD_COUNT, else the whole manifest.
    #[arg(long, value_name = "K/N", requires = "manifest", value_parser = sdfmo_harness::parse_shard)]
    pub shard: Option<sdfmo_harness::Shard>,
    /// Wall-time limit of each model in seconds; a model over it is killed and recorded as
    /// failed.
    #[arg(long, value_name = "SECONDS", requires = "manifest", value_parser = parse_timeout)]
    pub model_timeout: Option<f64>,
    /// Run again the models the ledger holds as failed.
    #[arg(long, requires = "manifest")]
    pub retry_failed: bool,
}

/// Parses a timeout in seconds (positive, at most a week).
pub fn parse_timeout(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t > 0.0 && t <= 7.0 * 86400.0 => Ok(t),
        _ => Err(format!(
            "expected a time limit in seconds, more than 0 and at most 604800, got {s:?}"
        )),
    }
}

/// Parses `x,y,z` into three finite numbers.
pub fn parse_vec3(s: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected x,y,z (three numbers), got {s:?}"));
    }
    let mut v = [0.0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        let x: f32 = p.parse().map_err(|_| format!("{p:?} is not a number"))?;
        if !x.is_finite() {
            return Err(format!("{p:?} is not finite"));
        }
        *slot = x;
    }
    Ok(v)
}

/// Parses a field of view in degrees, in (0, 180).
pub fn parse_fov(s: &str) -> Result<f32, String> {
    let f: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if !(f > 0.0 && f < 180.0) {
        return Err(format!("field of view {f} must be in (0, 180) degrees"));
    }
    Ok(f)
}

/// Parses `WxH` (or `N` for N×N), within the renderer's one image-size limit
/// ([`sdf_multioctree::render::check_image_size`]).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = match s.split_once(['x', 'X']) {
        Some((w, h)) => (w, h),
        None => (s, s),
    };
    let parse = |t: &str| -> Result<u32, String> {
        t.trim()
            .parse()
            .map_err(|_| format!("expected WxH (e.g. 1024x768), got {s:?}"))
    };
    let (w, h) = (parse(w)?, parse(h)?);
    sdf_multioctree::render::check_image_size(u64::from(w), u64::from(h))
        .map_err(|e| e.to_string())?;
    Ok((w, h))
}

/// Parses a thread count (at least 1).
pub fn parse_threads(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=1024).contains(&n) => Ok(n),
        _ => Err(format!(
            "thread count must be a number in 1..=1024, got {s:?}"
        )),
    }
}

/// Deepest depth the builder accepts.
const MAX_DEPTH: u8 = sdf_multioctree::format::MAX_DEPTH;

/// Parses an octree depth in 1..=16 (the builder's range).
/// Parses a screen-space error in pixels: a finite number > 0.
pub fn parse_pixel_error(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(e) if e.is_finite() && e > 0.0 => Ok(e),
        _ => Err(format!("the pixel error must be a number > 0, got {s:?}")),
    }
}

pub fn parse_depth(s: &str) -> Result<u8, String> {
    match s.trim().parse::<i64>() {
        Ok(d) if (1..=i64::from(MAX_DEPTH)).contains(&d) => Ok(d as u8),
        _ => Err(format!(
            "depth must be an integer in 1..={MAX_DEPTH}, got {s:?}"
        )),
    }
}

/// Parses a memory size: bytes, or a number with `K`, `M`, `G` or `T` (powers of 1024,
/// optional `iB`/`B`), at least 1 MiB.
pub fn parse_memory(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let upper = t.to_ascii_uppercase();
    let digits = upper.trim_end_matches("IB").trim_end_matches('B');
    let (num, shift) = match digits.chars().last() {
        Some('K') => (&digits[..digits.len() - 1], 10),
        Some('M') => (&digits[..digits.len() - 1], 20),
        Some('G') => (&digits[..digits.len() - 1], 30),
        Some('T') => (&digits[..digits.len() - 1], 40),
        _ => (digits, 0),
    };
    let bad = || format!("expected a memory size such as 8G, 512M or 1000000 bytes, got {s:?}");
    let v: f64 = num.trim().parse().map_err(|_| bad())?;
    let bytes = v * (1u64 << shift) as f64;
    if !(bytes.is_finite() && bytes >= (1u64 << 20) as f64 && bytes < 2f64.powi(63)) {
        return Err(format!("memory size {s:?} must be between 1M and 8E bytes"));
    }
    Ok(bytes as u64)
}

/// Parses `A..B`, `A..=B` (both inclusive) or `A`.
pub fn parse_depths(s: &str) -> Result<RangeInclusive<u8>, String> {
    let num = |t: &str| -> Result<u8, String> {
        t.trim()
            .parse::<u8>()
            .map_err(|_| format!("expected depths A..B (e.g. 6..9), got {s:?}"))
    };
    let (a, b) = if let Some((a, b)) = s.split_once("..=") {
        (num(a)?, num(b)?)
    } else if let Some((a, b)) = s.split_once("..") {
        (num(a)?, num(b)?)
    } else {
        let a = num(s)?;
        (a, a)
    };
    if a == 0 || a > b || b > MAX_DEPTH {
        return Err(format!(
            "depth range {a}..{b} must be non-empty and within 1..={MAX_DEPTH}"
        ));
    }
    Ok(a..=b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn clap_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn vec3_parses_negative_and_rejects_junk() {
        assert_eq!(parse_vec3("-2,1.5, 3").unwrap(), [-2.0, 1.5, 3.0]);
        assert!(parse_vec3("1,2").is_err());
        assert!(parse_vec3("1,2,x").is_err());
        assert!(parse_vec3("1,2,inf").is_err());
    }

    #[test]
    fn size_parses_both_forms_and_bounds() {
        assert_eq!(parse_size("96x64").unwrap(), (96, 64));
        assert_eq!(parse_size("32").unwrap(), (32, 32));
        assert!(parse_size("0x10").is_err());
        assert!(parse_size("100000x10").is_err());
        // The renderer's one limit: 32768 per side, 2^28 pixels.
        assert_eq!(parse_size("32768x8192").unwrap(), (32768, 8192));
        assert!(parse_size("32769x1").is_err());
        assert!(parse_size("16384x16385")
            .unwrap_err()
            .contains("at most 32768 per side and 268435456 pixels"));
        assert!(parse_size("ax b").is_err());
    }

    #[test]
    fn depths_are_inclusive() {
        assert_eq!(parse_depths("5..6").unwrap(), 5..=6);
        assert_eq!(parse_depths("6..=10").unwrap(), 6..=10);
        assert_eq!(parse_depths("7").unwrap(), 7..=7);
        assert!(parse_depths("9..6").is_err());
        assert!(parse_depths("0..3").is_err());
        assert!(parse_depths("15..20").is_err());
        assert_eq!(parse_depth("16").unwrap(), 16);
        for bad in ["0", "17", "-1", "x", "255"] {
            assert!(parse_depth(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn memory_sizes() {
        assert_eq!(parse_memory("8G").unwrap(), 8 << 30);
        assert_eq!(parse_memory("512MiB").unwrap(), 512 << 20);
        assert_eq!(parse_memory("1.5g").unwrap(), 3 << 29);
        assert_eq!(parse_memory("2000000").unwrap(), 2_000_000);
        for bad in ["", "G", "-1G", "12", "1Q", "nan"] {
            assert!(parse_memory(bad).is_err(), "{bad}");
        }
        assert!(parse_depths("a..b").is_err());
    }

    #[test]
    fn fov_and_threads_are_bounded() {
        assert!(parse_fov("0").is_err());
        assert!(parse_fov("180").is_err());
        assert_eq!(parse_fov("45").unwrap(), 45.0);
        assert!(parse_threads("0").is_err());
        assert_eq!(parse_threads("2").unwrap(), 2);
    }

    #[test]
    fn eye_conflicts_with_paper_views() {
        let r = Cli::try_parse_from([
            "sdfmo", "render", "a.smo", "-o", "x.png", "--views", "paper", "--eye", "1,2,3",
        ]);
        assert!(r.is_err());
        let r = Cli::try_parse_from(["sdfmo", "render", "a.smo", "-o", "x.png", "--eye=-1,2,3"]);
        assert!(r.is_ok(), "{r:?}");
    }

    #[test]
    fn sweep_methods_are_a_comma_list() {
        let cli = Cli::try_parse_from(["sdfmo", "sweep", "--methods", "multi,svo"]).unwrap();
        match cli.command {
            Command::Sweep(a) => {
                assert_eq!(a.settings.methods, vec![MethodArg::Multi, MethodArg::Svo])
            }
            other => panic!("parsed as {other:?}"),
        }
    }
}
