//! The experiment harness of sdf-multioctree, behind `sdfmo sweep`: for each mesh, method and
//! depth, build, render the paper's four views, compare with the mesh reference; write the
//! results as JSON, CSV, a Markdown table, plots and a page (modules `report`, `plots`).
//!
//! Over a dataset (`--manifest`, docs/scale.md): `manifest` (which models, which shard),
//! `shard` (run a shard: one process per model, `isolate`; one ledger line per model,
//! `ledger`) and `merge` (the shards' folders into one dataset report).
//!
//! A front-end fills [`SweepOptions`] (the [`SweepStep`] to run and the settings), calls [`run`]
//! and prints the [`Outcome`]. A shard runs each model in a child process of the running
//! executable, `EXE sweep --isolated-model=NAME … -- MESH`: the executable must be a front-end
//! that hands those flags back to [`run`] as [`SweepStep::Model`] (the `sdfmo` binary of
//! sdfmo-cli).
#![deny(missing_docs)]

pub mod error;
pub mod files;
pub mod input;
mod isolate;
mod ledger;
mod manifest;
mod merge;
mod options;
mod plots;
pub mod progress;
mod report;
mod shard;
mod workers;

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use sdf_multioctree::build::{self, BuildRequest, BuildSettings, BuildStats};
use sdf_multioctree::distance::SignMode;
use sdf_multioctree::format::PackedOctree;
use sdf_multioctree::metrics;
use sdf_multioctree::render::{Camera, OctreeScene, PaperProtocol};
use serde_json::json;

pub use error::{HarnessError, ModelsFailed, Result};
#[cfg(unix)]
pub use isolate::limit_address_space;
pub use manifest::{parse_shard, Shard};
pub use options::{Outcome, ShardStep, SweepMethod, SweepOptions, SweepStep};
use report::{Model, Provenance, Report, Row, SweepSettings};
pub use shard::EXIT_MODELS_FAILED;
pub use workers::Workers;

use crate::files::write_derived_png;
use crate::input::{load_input, InputMesh};

/// The build memory budget: `max_memory`, else the builder's default (half the physical
/// memory).
fn memory_budget(max_memory: Option<u64>) -> Option<u64> {
    max_memory.or_else(sdf_multioctree::build::default_memory_budget)
}

/// Relative path (from the output directory) of an image of the sweep.
pub fn image_rel(model: &str, file: &str) -> String {
    format!("images/{model}/{file}")
}

/// File name of a view of a configuration, and of its FLIP heat map.
pub fn view_file(method: &str, depth: u8, view: usize) -> String {
    format!("{method}_d{depth}_{view}.png")
}

/// File name of the FLIP heat map of a view.
pub fn heatmap_file(method: &str, depth: u8, view: usize) -> String {
    format!("{method}_d{depth}_{view}_flip.png")
}

/// File name of a reference view.
pub fn reference_file(view: usize) -> String {
    format!("reference_{view}.png")
}

/// The methods of the sweep, each once, in the order given.
fn unique_methods(args: &SweepOptions) -> Vec<SweepMethod> {
    let mut methods: Vec<SweepMethod> = Vec::new();
    for m in &args.methods {
        if !methods.contains(m) {
            methods.push(*m);
        }
    }
    methods
}

/// The settings a sweep records.
fn sweep_settings(args: &SweepOptions) -> SweepSettings {
    SweepSettings {
        depths: args.depths.clone().collect(),
        methods: unique_methods(args)
            .iter()
            .map(|m| m.name().to_owned())
            .collect(),
        size: args.size,
        max_voxels: args.max_voxels,
        fit_corners: args.fit_corners,
        // Provenance: the number of workers actually used, never `null`.
        threads: Some(args.threads.unwrap_or_else(rayon::current_num_threads)),
        views: Camera::paper_views(args.size, args.size).len(),
    }
}

/// Runs the sweep `args` asks for (see [`SweepOptions`] for which) and returns what to print.
///
/// # Errors
///
/// [`HarnessError`]: bad input (a mesh, manifest, shard folder or extra-rows file; the error
/// names it), a build over the memory budget, or a file that cannot be written. A shard whose
/// models failed is not an error: [`Outcome::error`] says so.
pub fn run(args: &SweepOptions) -> Result<Outcome> {
    match &args.step {
        SweepStep::Run { meshes, extra_rows } => run_meshes(args, meshes, extra_rows),
        SweepStep::Shard(step) => shard::run(args, step, &sweep_settings(args)),
        SweepStep::Merge { shards } => merge::run(args, shards),
        SweepStep::Model { name, mesh } => run_isolated(args, name, mesh),
    }
}

/// Sweeps `meshes` (none: the demo part) with the rows of `extra_rows` beside them.
fn run_meshes(args: &SweepOptions, meshes: &[PathBuf], extra_rows: &[PathBuf]) -> Result<Outcome> {
    let paths: Vec<Option<&Path>> = if meshes.is_empty() {
        vec![None]
    } else {
        meshes.iter().map(|p| Some(p.as_path())).collect()
    };
    // Every mesh is loaded, and every build checked against the memory budget, before any
    // work: a bad last mesh or too deep a depth fails in seconds, not after the others.
    let inputs = paths
        .iter()
        .map(|p| load_input(*p))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let plan = Plan::checked(args, &inputs)?;
    let (methods, depths) = (&plan.methods, &plan.depths);
    // The models' names are settled before any work, so that a row of `--extra-rows` that
    // would repeat one of this sweep's configurations is refused now.
    let mut taken: Vec<String> = Vec::new();
    let names: Vec<String> = inputs
        .iter()
        .map(|input| {
            let name = unique_name(&sanitize(&input.name), &taken);
            taken.push(name.clone());
            name
        })
        .collect();
    let swept: Vec<(String, String, Vec<u8>)> = names
        .iter()
        .flat_map(|n| {
            methods
                .iter()
                .map(|m| (n.clone(), m.name().to_owned(), depths.clone()))
        })
        .collect();
    let extra = report::extra::load(extra_rows, &swept)?;
    let out = &args.output;
    sdf_multioctree::io::create_derived_dir(out, Path::new("images"))?;
    let settings = sweep_settings(args);

    let steps = inputs.len() * (1 + methods.len() * depths.len());
    let bar = progress::steps(steps as u64, "starting");

    let mut rows: Vec<Row> = Vec::new();
    let mut models: Vec<Model> = Vec::new();
    let mut files: Vec<String> = Vec::new();
    let report_of = |models: &[Model], rows: &[Row]| {
        let mut all = rows.to_vec();
        all.extend(extra.rows.iter().cloned());
        Report::new(
            settings.clone(),
            Provenance::current(&settings, usize::from(args.frames)),
            models.to_vec(),
            all,
            extra.files.clone(),
        )
    };
    for (mut input, name) in inputs.into_iter().zip(names) {
        input.name = name;
        let sweep = Sweep {
            args,
            plan: &plan,
            bar: &bar,
            report_of: Some(&report_of),
        };
        let model = sweep_model(&sweep, &input, &models, &mut rows)?;
        models.push(model);
        files = report::write_tables(out, &report_of(&models, &rows))?;
    }
    bar.set_message("plots and page");
    let report = report_of(&models, &rows);
    files.extend(plots::write_plots(
        out,
        &report.rows,
        report.provenance.frames,
    )?);
    files.push(report::write_html(out, &report, &files)?);
    bar.finish_and_clear();

    if args.json {
        return Outcome::json(&json!({
            "output": out.display().to_string(),
            "settings": settings,
            "models": report.models,
            "rows": report.rows,
            "files": files,
        }));
    }
    let mut s = report::table_md(&report)?;
    s.push_str(&format!(
        "\nWrote {} (open {} in a browser).\n",
        files.join(", "),
        out.join("index.html").display()
    ));
    Ok(Outcome::text(s))
}

/// The settings of one build of the sweep.
fn build_settings(args: &SweepOptions, method: SweepMethod, depth: u8) -> BuildSettings {
    BuildSettings::new(depth, method.method(args.max_voxels))
        .with_bits(sdf_multioctree::format::ValueBits::Eight)
        .with_margin(sdf_multioctree::DEFAULT_MARGIN)
        .with_sign(SignMode::Auto)
        .with_fit_corners(args.fit_corners)
}

/// Makes the report of the models and rows so far (with the extra rows).
type ReportOf<'a> = dyn Fn(&[Model], &[Row]) -> Report + 'a;

/// The configurations a sweep runs and the memory budget its builds were checked against.
struct Plan {
    methods: Vec<SweepMethod>,
    depths: Vec<u8>,
    budget: Option<u64>,
    /// The pool of `threads` the builds, renders and image writes run on.
    workers: Workers,
}

impl Plan {
    /// The plan of `args`, with the deepest build of each method on each of `inputs` checked
    /// against the memory budget.
    fn checked(args: &SweepOptions, inputs: &[InputMesh]) -> Result<Plan> {
        let plan = Plan {
            methods: unique_methods(args),
            depths: args.depths.clone().collect(),
            budget: memory_budget(args.max_memory),
            workers: Workers::new(args.threads)?,
        };
        for input in inputs {
            for &method in &plan.methods {
                let deepest = build_settings(args, method, *args.depths.end());
                build::check_memory(&input.mesh, &deepest, plan.budget).map_err(|source| {
                    HarnessError::OverBudget {
                        method: method.name(),
                        mesh: input.source.clone(),
                        source: Box::new(source),
                    }
                })?;
            }
        }
        Ok(plan)
    }
}

/// What every model of a sweep shares: the arguments, the report of the results so far, the
/// plan and the progress bar.
#[derive(Clone, Copy)]
struct Sweep<'a> {
    args: &'a SweepOptions,
    plan: &'a Plan,
    bar: &'a indicatif::ProgressBar,
    /// The report of the models and rows so far (with the extra rows), rewritten after each
    /// row; `None` in a shard's model process, which prints its rows instead.
    report_of: Option<&'a ReportOf<'a>>,
}

/// A shard's model process (`--isolated-model NAME`): sweeps its one mesh under `name`, writes
/// its images into the output folder and prints `{"model", "rows"}` as one JSON line.
fn run_isolated(args: &SweepOptions, name: &str, mesh: &Path) -> Result<Outcome> {
    let mut input = load_input(Some(mesh))?;
    input.name = sanitize(name);
    let plan = Plan::checked(args, std::slice::from_ref(&input))?;
    sdf_multioctree::io::create_derived_dir(&args.output, Path::new("images"))?;
    let bar = indicatif::ProgressBar::hidden();
    let sweep = Sweep {
        args,
        plan: &plan,
        bar: &bar,
        report_of: None,
    };
    let mut rows = Vec::new();
    let model = sweep_model(&sweep, &input, &[], &mut rows)?;
    let output = serde_json::to_value(shard::ModelOutput { model, rows }).map_err(|source| {
        HarnessError::Serialise {
            what: "a model's rows",
            source,
        }
    })?;
    Outcome::json(&output)
}

/// Renders the reference of one model, then builds, renders and compares every configuration;
/// the rows go to `rows` (the tables are rewritten after each, with the `models` done so far).
fn sweep_model(
    sweep: &Sweep,
    input: &InputMesh,
    models: &[Model],
    rows: &mut Vec<Row>,
) -> Result<Model> {
    let Sweep {
        args,
        plan,
        bar,
        report_of,
    } = *sweep;
    let (methods, depths) = (&plan.methods, &plan.depths);
    let workers = &plan.workers;
    let name = &input.name;
    let img_dir: PathBuf =
        sdf_multioctree::io::create_derived_dir(&args.output, &Path::new("images").join(name))?;
    bar.set_message(format!("{name}: reference"));
    let protocol = workers
        .install(|| PaperProtocol::new(&input.mesh, sdf_multioctree::DEFAULT_MARGIN, args.size))
        .map_err(|source| HarnessError::Reference {
            mesh: input.source.clone(),
            source: Box::new(source),
        })?
        .with_frames(usize::from(args.frames));
    for (k, reference) in protocol.references().iter().enumerate() {
        write_derived_png(&img_dir.join(reference_file(k)), reference)?;
    }
    bar.inc(1);

    let run = ModelRun {
        workers,
        protocol: &protocol,
        img_dir: &img_dir,
        name,
    };
    let mut add_row = |row: Row| -> Result<()> {
        rows.push(row);
        // Keep the files current after every row: a long sweep that is stopped keeps its
        // results so far.
        if let Some(report_of) = report_of {
            report::write_tables(&args.output, &report_of(models, rows))?;
        }
        bar.inc(1);
        Ok(())
    };
    for &method in methods {
        if args.levels {
            // One file with every level; each level is scored as a build of its depth.
            let (first, last) = (depths[0], depths[depths.len() - 1]);
            let stage = format!("{name}: {} levels {first}..={last}: build", method.name());
            let settings = build_settings(args, method, last);
            let (lod, stats) = build_in_stage(sweep, &stage, &input.mesh, settings, |request| {
                request.levels(first)
            })
            .map_err(build_failed(
                method,
                format!("with levels {first}..={last}"),
                input,
            ))?;
            for ((octree, stats), entry) in lod.levels().iter().zip(&stats).zip(lod.entries()) {
                bar.set_message(format!("{name}: {} level {}", method.name(), entry.level));
                add_row(run.score(method, octree, stats, Some(entry.end()))?)?;
            }
        } else {
            for &depth in depths {
                let stage = format!("{name}: {} depth {depth}: build", method.name());
                let settings = build_settings(args, method, depth);
                let (octree, stats) =
                    build_in_stage(sweep, &stage, &input.mesh, settings, |request| {
                        request.octree()
                    })
                    .map_err(build_failed(
                        method,
                        format!("depth {depth}"),
                        input,
                    ))?;
                bar.set_message(format!("{name}: {} depth {depth}: render", method.name()));
                add_row(run.score(method, &octree, &stats, None)?)?;
            }
        }
    }
    Ok(Model {
        model: name.clone(),
        source: input.source.clone(),
        triangles: input.mesh.triangle_count(),
        reference_render_ms: protocol.reference_ms(),
    })
}

/// Builds `mesh` with `settings` on the sweep's workers within its memory budget, the bar
/// showing `stage` and then the build's progress in percent; `finish` asks the request for one
/// octree or for levels.
fn build_in_stage<T: Send>(
    sweep: &Sweep,
    stage: &str,
    mesh: &sdf_multioctree::mesh::TriMesh,
    settings: BuildSettings,
    finish: impl FnOnce(&BuildRequest<'_>) -> std::result::Result<T, build::BuildError> + Send,
) -> std::result::Result<T, build::BuildError> {
    let bar = sweep.bar;
    bar.set_message(stage.to_owned());
    let on_progress = |f: f32| bar.set_message(format!("{stage} {:.0}%", f * 100.0));
    sweep.plan.workers.install(|| {
        finish(
            &BuildRequest::new(mesh, settings)
                .memory_budget(sweep.plan.budget)
                .progress(&on_progress),
        )
    })
}

/// The error of a failed build of `input` with `method` at `depths` (`depth D`, or `with
/// levels A..=B`).
fn build_failed(
    method: SweepMethod,
    depths: String,
    input: &InputMesh,
) -> impl FnOnce(build::BuildError) -> HarnessError + '_ {
    move |source| HarnessError::Build {
        method: method.name(),
        depths,
        mesh: input.source.clone(),
        source: Box::new(source),
    }
}

/// One model being swept: what scoring an octree of it needs.
struct ModelRun<'a> {
    workers: &'a Workers,
    protocol: &'a PaperProtocol,
    img_dir: &'a Path,
    name: &'a str,
}

impl ModelRun<'_> {
    /// Renders `octree` (built with `method`; its depth is the row's) on the paper protocol,
    /// writes its views and FLIP maps, and returns its row; `bytes_read` for a level of a file
    /// with levels.
    fn score(
        &self,
        method: SweepMethod,
        octree: &PackedOctree,
        stats: &BuildStats,
        bytes_read: Option<u64>,
    ) -> Result<Row> {
        let depth = octree.depth();
        let score = self
            .workers
            .install(|| self.protocol.score(&OctreeScene(octree)))
            .map_err(|source| HarnessError::Score {
                method: method.name(),
                depth,
                source: Box::new(source),
            })?;
        // PNG encoding is single-threaded: the views and heat maps in parallel.
        self.workers.install(|| {
            score
                .views
                .par_iter()
                .enumerate()
                .try_for_each(|(k, view)| {
                    write_derived_png(
                        &self.img_dir.join(view_file(method.name(), depth, k)),
                        &view.image,
                    )?;
                    write_derived_png(
                        &self.img_dir.join(heatmap_file(method.name(), depth, k)),
                        &metrics::flip_heatmap(&view.flip),
                    )
                })
        })?;
        let psnr = score.psnr();
        Ok(Row {
            model: self.name.to_owned(),
            method: method.name().to_owned(),
            depth,
            psnr: psnr.is_finite().then_some(psnr),
            flip: score.flip(),
            bytes: stats.bytes,
            lod: None,
            bytes_read,
            build_ms: Some(stats.build_ms),
            render_ms: score.render_ms(),
            nodes: Some(stats.nodes),
            leaves: Some(stats.leaves),
            voxels: Some(stats.voxels),
            surface_voxels: Some(stats.surface_voxels),
            cap_hits: Some(stats.cap_hits),
            psnr_views: score
                .views
                .iter()
                .map(|v| v.psnr.is_finite().then_some(v.psnr))
                .collect(),
            flip_views: score.views.iter().map(|v| f64::from(v.flip.mean)).collect(),
        })
    }
}

/// A model name safe in file names and HTML: letters, digits, `-`, `_`, `.`; others become `_`.
pub fn sanitize(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    let s = s.trim_start_matches('.').to_owned();
    if s.is_empty() {
        "mesh".to_owned()
    } else {
        s
    }
}

/// Whether `name` is a name the sweep itself writes into file names and pages (a model or a
/// method): one that [`sanitize`] leaves as it is, so non-empty, no leading `.`, only letters,
/// digits, `-`, `_` and `.` (no separator, no `..`, nothing absolute). Every name read back
/// from outside (a ledger, `shard.json`, extra rows) must pass it before it names a file.
pub fn is_safe_name(name: &str) -> bool {
    sanitize(name) == name
}

/// `name`, or `name_2`, `name_3`, … when a model of that name is already there.
fn unique_name(name: &str, names: &[String]) -> String {
    let taken = |n: &str| names.iter().any(|m| m == n);
    if !taken(name) {
        return name.to_owned();
    }
    (2..)
        .map(|i| format!("{name}_{i}"))
        .find(|n| !taken(n))
        .unwrap_or_else(|| name.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_safe_and_unique() {
        assert_eq!(sanitize("abc 1<x>"), "abc_1_x_");
        assert_eq!(sanitize("..hidden"), "hidden");
        assert_eq!(sanitize(""), "mesh");
        for bad in ["", "..", "../x", "/etc", "a/b", ".hidden", "a\\b", "é"] {
            assert!(!is_safe_name(bad), "{bad:?}");
        }
        assert!(is_safe_name("part_000001") && is_safe_name("-dash") && is_safe_name("a..b"));
        let m = |n: &str| n.to_owned();
        assert_eq!(unique_name("a", &[m("b")]), "a");
        assert_eq!(unique_name("a", &[m("a"), m("a_2")]), "a_3");
    }
}
