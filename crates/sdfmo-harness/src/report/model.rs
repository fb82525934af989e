//! The report's one typed model: what a sweep measured ([`Row`]s), of what ([`Model`]s), with
//! what ([`SweepSettings`], [`Provenance`]), and what it adds up to ([`Summary`]). results.json is
//! this model serialised by serde; the CSV, Markdown and HTML renderers read it and nothing else,
//! and other producers (a merge of sharded runs, a peer such as NGLOD through `--extra-rows`)
//! feed it rows of the same schema (docs/cli.md, "The row schema").

use serde::{Deserialize, Serialize};

/// One line of the results: a model built with a method at a depth, measured over the views.
///
/// The fields a producer other than the sweep may not have (a neural peer has no voxels) are
/// optional; the sweep always fills them, and an absent one is left out of results.json.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Row {
    /// Model name (file stem, or `demo`).
    pub model: String,
    /// `svo`, `multi`, or another producer's method (`nglod`).
    pub method: String,
    /// Octree depth: the table row this result sits in (a peer's level of detail states the
    /// depth it is compared with, and its own level in `lod`).
    pub depth: u8,
    /// The producer's own level of detail, when it has levels that are not octree depths
    /// (NGLOD's LOD k, compared at `depth`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod: Option<u8>,
    /// Bytes a reader needs to draw this row's octree when it is a level of one file with
    /// levels (`sweep --levels`): the file's header and every level up to this one, so the
    /// finest level's is the whole file. Absent for a separate build (its file is `bytes`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bytes_read: Option<u64>,
    /// Mean PSNR over the views in dB; `None` (JSON `null`) when infinite (identical images).
    /// Required when read: a missing key must not read as "identical images".
    #[serde(deserialize_with = "required_nullable")]
    pub psnr: Option<f64>,
    /// Mean FLIP over the views.
    pub flip: f64,
    /// Bytes of the representation as saved (the packed octree file; a peer's parameters).
    pub bytes: usize,
    /// Build time (ms).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub build_ms: Option<f64>,
    /// Render time of one view (ms): the mean over the views of each view's median frame.
    pub render_ms: f64,
    /// Octree nodes (inner and leaves).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<usize>,
    /// Leaves.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leaves: Option<usize>,
    /// Voxels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub voxels: Option<usize>,
    /// Surface voxels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface_voxels: Option<usize>,
    /// Leaves that hit the voxel cap.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cap_hits: Option<usize>,
    /// PSNR of each view (`None` = infinite).
    #[serde(default)]
    pub psnr_views: Vec<Option<f64>>,
    /// FLIP of each view.
    #[serde(default)]
    pub flip_views: Vec<f64>,
}

/// An `Option` that must be present (possibly `null`): serde's derive treats a missing
/// `Option` field as `None` unless the field has its own deserializer.
fn required_nullable<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    Option::<f64>::deserialize(d)
}

/// What the sweep knows of a model besides its rows.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Model {
    /// Name used in the rows and file names.
    pub model: String,
    /// Path, or `demo`.
    pub source: String,
    /// Triangles after loading.
    pub triangles: usize,
    /// Mean render time of one reference view (ms).
    pub reference_render_ms: f64,
}

/// Settings recorded next to the results.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SweepSettings {
    /// Depths swept.
    pub depths: Vec<u8>,
    /// Methods swept.
    pub methods: Vec<String>,
    /// Width and height of each view.
    pub size: u32,
    /// Voxel cap of the multi-octree.
    pub max_voxels: u8,
    /// Corners fitted to the surface in every build (`BuildSettings::fit_corners`; absent,
    /// `false`, in results written before the setting).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fit_corners: bool,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// Views per configuration.
    pub views: usize,
}

#[cfg(test)]
impl SweepSettings {
    /// The tests' settings: `depths` at `size`², the SVO and the multi-octree of 8 voxels, one
    /// thread, the four paper views.
    pub(crate) fn for_tests(depths: Vec<u8>, size: u32) -> SweepSettings {
        SweepSettings {
            depths,
            methods: vec!["svo".into(), "multi".into()],
            size,
            max_voxels: 8,
            fit_corners: false,
            threads: Some(1),
            views: 4,
        }
    }
}

/// Where and with what a sweep ran, recorded in results.json and on the page.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Provenance {
    /// `sdfmo-cli` and its version.
    pub program: String,
    /// The git commit the binary was built from, when it was built from a git checkout.
    pub git_commit: Option<String>,
    /// CPU model (`model name` in `/proc/cpuinfo`), when known.
    pub cpu: Option<String>,
    /// Logical CPUs of the machine.
    pub cpus: usize,
    /// Worker threads the sweep used.
    pub threads: usize,
    /// When the results were written, UTC (`YYYY-MM-DDTHH:MM:SSZ`).
    pub date: String,
    /// Renders of each view whose median time is a row's `render_ms` (absent in results
    /// written before render times were medians: one frame).
    #[serde(default = "one_frame")]
    pub frames: usize,
}

fn one_frame() -> usize {
    1
}

impl Provenance {
    /// The provenance of this process, with the sweep's worker count and frames per view.
    pub fn current(settings: &SweepSettings, frames: usize) -> Provenance {
        let cpu = std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_owned())
        });
        Provenance {
            program: format!("sdfmo-cli {}", env!("CARGO_PKG_VERSION")),
            git_commit: option_env!("SDFMO_GIT_COMMIT").map(str::to_owned),
            cpu,
            cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
            threads: settings.threads.unwrap_or_else(rayon::current_num_threads),
            date: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
            frames,
        }
    }
}

/// Rows that came from another producer (`--extra-rows FILE`): where from and how many.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ExtraRows {
    /// The file, as given.
    pub file: String,
    /// Rows it contributed.
    pub rows: usize,
    /// Methods among them, in order of appearance.
    pub methods: Vec<String>,
}

/// Medians over the models of one method at one depth.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct MethodSummary {
    /// Method.
    pub method: String,
    /// Depth.
    pub depth: u8,
    /// Models with this configuration.
    pub models: usize,
    /// Median PSNR in dB (`None` when the median is infinite: identical images).
    pub psnr: Option<f64>,
    /// Median FLIP.
    pub flip: f64,
    /// Median size in bytes.
    pub bytes: f64,
    /// Median build time (ms), over the rows that have one.
    pub build_ms: Option<f64>,
    /// Median render time of one view (ms).
    pub render_ms: f64,
}

/// The multi-octree against the SVO at one depth, over the models that have both.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct GainSummary {
    /// Depth.
    pub depth: u8,
    /// Models with both methods at this depth.
    pub models: usize,
    /// Median PSNR gain, multi − SVO, in dB (over the models where both are finite).
    pub median_psnr_gain: Option<f64>,
    /// Worst (smallest) PSNR gain in dB.
    pub worst_psnr_gain: Option<f64>,
    /// Median FLIP change, multi − SVO (negative is better).
    pub median_flip_change: Option<f64>,
    /// Median size ratio, multi / SVO.
    pub median_size_ratio: Option<f64>,
    /// Median render-time ratio, multi / SVO.
    pub median_render_ratio: Option<f64>,
}

/// What the rows add up to, per method and depth and per depth between the two methods.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Summary {
    /// Per method and depth (methods in the report's order, depths ascending).
    pub methods: Vec<MethodSummary>,
    /// Per depth, the multi-octree against the SVO (depths ascending; absent without both).
    pub gains: Vec<GainSummary>,
}

/// The whole report. Serialised (through a `serde_json::Value`, which sorts every object's
/// keys), it is results.json.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Report {
    /// Files of rows from other producers merged into this report (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra_rows: Vec<ExtraRows>,
    /// The models swept, in order.
    pub models: Vec<Model>,
    /// Where and with what it ran.
    pub provenance: Provenance,
    /// Every result: the sweep's, then the extra rows.
    pub rows: Vec<Row>,
    /// The sweep's settings.
    pub settings: SweepSettings,
    /// Medians over the models.
    #[serde(default)]
    pub summary: Summary,
}

/// Gain of the multi-octree over the SVO in PSNR (None when either is missing or infinite).
pub fn psnr_gain(multi: &Row, svo: &Row) -> Option<f64> {
    Some(multi.psnr? - svo.psnr?)
}

/// The median, `None` when empty or not finite.
fn finite_median(values: Vec<f64>) -> Option<f64> {
    sdf_multioctree::metrics::median(values).filter(|v| v.is_finite())
}

impl Report {
    /// The report of `rows` of `models`, summarised.
    pub fn new(
        settings: SweepSettings,
        provenance: Provenance,
        models: Vec<Model>,
        rows: Vec<Row>,
        extra_rows: Vec<ExtraRows>,
    ) -> Report {
        let mut report = Report {
            extra_rows,
            models,
            provenance,
            rows,
            settings,
            summary: Summary::default(),
        };
        report.summary = report.summarise();
        report
    }

    /// The row of `model`, `method` and `depth`.
    pub fn find(&self, model: &str, method: &str, depth: u8) -> Option<&Row> {
        self.rows
            .iter()
            .find(|r| r.model == model && r.method == method && r.depth == depth)
    }

    /// The methods of the tables: the sweep's, then the other producers' in order of appearance.
    pub fn methods(&self) -> Vec<String> {
        let mut methods = self.settings.methods.clone();
        for r in &self.rows {
            if !methods.contains(&r.method) {
                methods.push(r.method.clone());
            }
        }
        methods
    }

    /// The depths of the tables: the sweep's and the other producers', ascending.
    pub fn depths(&self) -> Vec<u8> {
        let mut depths = self.settings.depths.clone();
        depths.extend(self.rows.iter().map(|r| r.depth));
        depths.sort_unstable();
        depths.dedup();
        depths
    }

    /// The models' names: the swept ones in order, then those only the rows name.
    pub fn model_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.models.iter().map(|m| m.model.clone()).collect();
        for r in &self.rows {
            if !names.contains(&r.model) {
                names.push(r.model.clone());
            }
        }
        names
    }

    /// Whether both the SVO and the multi-octree were swept (the gain columns).
    pub fn compares_methods(&self) -> bool {
        let m = &self.settings.methods;
        m.iter().any(|m| m == "svo") && m.iter().any(|m| m == "multi")
    }

    fn summarise(&self) -> Summary {
        let names = self.model_names();
        let depths = self.depths();
        let mut methods = Vec::new();
        for method in self.methods() {
            for &depth in &depths {
                let rows: Vec<&Row> = names
                    .iter()
                    .filter_map(|m| self.find(m, &method, depth))
                    .collect();
                if rows.is_empty() {
                    continue;
                }
                let of = |f: &dyn Fn(&Row) -> f64| rows.iter().map(|r| f(r)).collect();
                methods.push(MethodSummary {
                    method: method.clone(),
                    depth,
                    models: rows.len(),
                    psnr: finite_median(of(&|r| r.psnr.unwrap_or(f64::INFINITY))),
                    flip: finite_median(of(&|r| r.flip)).unwrap_or(f64::NAN),
                    bytes: finite_median(of(&|r| r.bytes as f64)).unwrap_or(f64::NAN),
                    build_ms: finite_median(rows.iter().filter_map(|r| r.build_ms).collect()),
                    render_ms: finite_median(of(&|r| r.render_ms)).unwrap_or(f64::NAN),
                });
            }
        }
        let mut gains = Vec::new();
        for &depth in &self.settings.depths {
            let pairs: Vec<(&Row, &Row)> = names
                .iter()
                .filter_map(|m| Some((self.find(m, "multi", depth)?, self.find(m, "svo", depth)?)))
                .collect();
            if pairs.is_empty() {
                continue;
            }
            let psnr: Vec<f64> = pairs.iter().filter_map(|(a, b)| psnr_gain(a, b)).collect();
            let worst = psnr.iter().copied().fold(f64::INFINITY, f64::min);
            gains.push(GainSummary {
                depth,
                models: pairs.len(),
                median_psnr_gain: finite_median(psnr),
                worst_psnr_gain: worst.is_finite().then_some(worst),
                median_flip_change: finite_median(
                    pairs.iter().map(|(a, b)| a.flip - b.flip).collect(),
                ),
                median_size_ratio: finite_median(
                    pairs
                        .iter()
                        .map(|(a, b)| a.bytes as f64 / b.bytes.max(1) as f64)
                        .collect(),
                ),
                median_render_ratio: finite_median(
                    pairs
                        .iter()
                        .filter(|(_, b)| b.render_ms > 0.0)
                        .map(|(a, b)| a.render_ms / b.render_ms)
                        .collect(),
                ),
            });
        }
        Summary { methods, gains }
    }
}
