//! `sdfmo sweep --merge DIR... -o OUT`: the output folders of a manifest sweep's shards (or of
//! one unsharded manifest sweep) into one dataset report.
//!
//! Every folder must come from the same manifest and settings (`shard.json`'s settings hash and
//! manifest fingerprint) and together they must hold every shard exactly once. A record counts
//! for a manifest entry only when its position, id and entry fingerprint are the entry's as its
//! shard last saw it (stale records of an edited or reordered manifest are skipped); every
//! entry without such a record is unfinished, and the merge says which.
//!
//! **A shard folder is untrusted input**: it was written by a job and copied across machines
//! and shared volumes. Nothing in it is followed or believed unchecked: `shard.json`, the ledger
//! and the images are read without following any symbolic link below the folder
//! ([`sdf_multioctree::io::read_beneath`]) and with a size limit checked before reading; model
//! and method names must be names the sweep itself writes ([`super::is_safe_name`], methods the
//! sweep's own), so every path the merge writes stays inside `OUT`; numbers are range-checked
//! (shard counts, depths, PSNR, FLIP, times: [`super::report::extra::row_problem`], the checks
//! extra rows get); and `OUT` may not be one of the shard folders or inside one. A bad value is
//! an error naming the file, the record and the value.
//!
//! From the ledgers `OUT` gets:
//! - `results.json`: the single run's schema (`settings`, `provenance`, `models`, `rows`) plus
//!   `failures` and `dataset` (the statistics below) and `shards`;
//! - `results.csv` (the rows), `failures.csv`, `dataset.md`, `index.html` and the plots
//!   `dataset_psnr_gain_cdf.png`, `dataset_size_ratio_cdf.png`, `dataset_time_vs_triangles.png`;
//! - `images/` with the reference, both methods' first view and FLIP maps of the worst models.
//!
//! Statistics per depth d, over the models with both methods at d: the distribution
//! (quantiles) of ΔPSNR = PSNR(multi) − PSNR(SVO), ΔFLIP = FLIP(multi) − FLIP(SVO) and the
//! size ratio bytes(multi) / bytes(SVO); the share of models where the multi-octree's PSNR is
//! higher; and the share where the multi-octree at d beats the SVO at d + 1.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use serde::Serialize;

use super::ledger::{self, Record};
use super::manifest::{self, Shard};
use super::report::extra::{row_problem, MAX_DEPTH};
use super::shard::{Failure, ShardInfo, MAX_SHARD_FILE_BYTES, SHARD_FILE};
use super::{heatmap_file, image_rel, reference_file, view_file, Model, Row, SweepSettings};
use crate::files::write_derived;
use crate::{Outcome, SweepMethod, SweepOptions};

mod page;
mod plots;

/// Models shown with their images in the "worst models" table.
const WORST: usize = 6;

/// Largest image copied from a shard folder (a 8192² PNG of noise is about 200 MB).
const MAX_IMAGE_BYTES: u64 = 256 << 20;

/// Why shard folders cannot be merged into `OUT`. Each names the file and what is wrong.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MergeError {
    /// `OUT` is one of the shard folders, or inside one: the merge would overwrite its input.
    #[error(
        "-o {} is inside the shard folder {}: merge into a folder of its own",
        out.display(),
        shard.display()
    )]
    OutputInsideInput {
        /// The output folder as given.
        out: PathBuf,
        /// The shard folder it is in.
        shard: PathBuf,
    },
    /// `OUT` cannot be placed: `..` after a folder that does not exist yet.
    #[error("-o {}: cannot tell where it lands (`..` after a folder that does not exist)", out.display())]
    OutputUnresolved {
        /// The output folder as given.
        out: PathBuf,
    },
    /// `shard.json` says what no sweep writes.
    #[error("{}: {reason}", path.display())]
    BadShardFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A current ledger record says what no sweep writes.
    #[error("{}: the record of {id:?} (manifest entry {index}): {reason}", path.display())]
    BadRecord {
        /// The ledger.
        path: PathBuf,
        /// The record's manifest position.
        index: usize,
        /// Its id (shortened to 120 characters).
        id: String,
        /// What is wrong.
        reason: String,
    },
}

/// Quantiles reported: the minimum, the deciles 10 and 90, the quartiles, the median, the
/// maximum.
pub const QUANTILES: [f64; 7] = [0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0];

/// A distribution summarised by [`QUANTILES`] (nearest rank), `null` for an infinite value.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Distribution {
    /// Values counted.
    pub n: usize,
    /// Value at each of [`QUANTILES`].
    pub quantiles: Vec<Option<f64>>,
    /// Mean of the finite values.
    pub mean: Option<f64>,
}

impl Distribution {
    /// Of `values` (infinite ones sort to the ends).
    pub fn of(mut values: Vec<f64>) -> Distribution {
        values.retain(|v| !v.is_nan());
        values.sort_by(f64::total_cmp);
        let n = values.len();
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        Distribution {
            n,
            quantiles: QUANTILES
                .iter()
                .map(|&q| {
                    (n > 0)
                        .then(|| values[nearest_rank(q, n)])
                        .filter(|v| v.is_finite())
                })
                .collect(),
            mean: (!finite.is_empty()).then(|| finite.iter().sum::<f64>() / finite.len() as f64),
        }
    }

    /// The median.
    pub fn median(&self) -> Option<f64> {
        self.quantiles[3]
    }
}

/// Index of quantile `q` of `n` sorted values, nearest rank.
fn nearest_rank(q: f64, n: usize) -> usize {
    ((q * n as f64).ceil() as usize).clamp(1, n) - 1
}

/// One depth's comparison of the two methods over the dataset.
#[derive(Clone, Debug, Serialize)]
pub struct DepthStats {
    /// The depth.
    pub depth: u8,
    /// Models with both methods at this depth.
    pub models: usize,
    /// ΔPSNR (dB): multi − SVO.
    pub psnr_gain: Distribution,
    /// ΔFLIP: multi − SVO (negative is better).
    pub flip_change: Distribution,
    /// bytes(multi) / bytes(SVO).
    pub size_ratio: Distribution,
    /// Share of the models where the multi-octree's PSNR is higher than the SVO's.
    pub multi_beats_svo: f64,
    /// Share where the multi-octree's FLIP is lower.
    pub multi_beats_svo_flip: f64,
    /// Share where the multi-octree at this depth has a higher PSNR than the SVO one level
    /// deeper (`None` at the deepest depth).
    pub multi_beats_deeper_svo: Option<f64>,
    /// The models with the lowest ΔPSNR, worst first: (model, ΔPSNR).
    pub worst: Vec<(String, Option<f64>)>,
}

/// A least-squares line `ms = intercept + slope · triangles` of time per model.
#[derive(Clone, Debug, Serialize)]
pub struct TimeFit {
    /// Models fitted.
    pub models: usize,
    /// ms per model at zero triangles.
    pub intercept_ms: f64,
    /// ms per triangle.
    pub slope_ms_per_triangle: f64,
    /// Mean wall time per model (ms).
    pub mean_ms: f64,
    /// Total wall time of the models (ms), summed over the shards.
    pub total_ms: f64,
}

/// What the merge adds to the single run's results.
#[derive(Clone, Debug, Serialize)]
pub struct DatasetStats {
    /// Models in the manifest.
    pub manifest_models: usize,
    /// Models with rows.
    pub done: usize,
    /// Models that failed.
    pub failed: usize,
    /// Per depth.
    pub depths: Vec<DepthStats>,
    /// Wall time per model (its process, load to last image) against its triangles.
    pub time_per_model: Option<TimeFit>,
}

/// PSNR with `None` (identical images) as +∞.
fn psnr(r: &Row) -> f64 {
    r.psnr.unwrap_or(f64::INFINITY)
}

/// Difference of two PSNRs that may be infinite (∞ − ∞ = 0).
fn gain(multi: f64, svo: f64) -> f64 {
    if multi == svo {
        0.0
    } else {
        multi - svo
    }
}

/// The statistics of `rows` for `settings`' depths.
pub fn depth_stats(settings: &SweepSettings, models: &[Model], rows: &[Row]) -> Vec<DepthStats> {
    let find: HashMap<(&str, &str, u8), &Row> = rows
        .iter()
        .map(|r| ((r.model.as_str(), r.method.as_str(), r.depth), r))
        .collect();
    let deepest = settings.depths.iter().copied().max().unwrap_or(0);
    settings
        .depths
        .iter()
        .map(|&d| {
            let mut gains = Vec::new();
            let mut flips = Vec::new();
            let mut ratios = Vec::new();
            let (mut beats, mut beats_flip, mut deeper, mut deeper_n) = (0, 0, 0, 0);
            let mut worst: Vec<(String, f64)> = Vec::new();
            for m in models {
                let name = m.model.as_str();
                let (Some(s), Some(mu)) =
                    (find.get(&(name, "svo", d)), find.get(&(name, "multi", d)))
                else {
                    continue;
                };
                let g = gain(psnr(mu), psnr(s));
                gains.push(g);
                worst.push((name.to_owned(), g));
                flips.push(mu.flip - s.flip);
                ratios.push(mu.bytes as f64 / s.bytes.max(1) as f64);
                beats += usize::from(g > 0.0);
                beats_flip += usize::from(mu.flip < s.flip);
                if let Some(s1) = find.get(&(name, "svo", d + 1)) {
                    deeper_n += 1;
                    deeper += usize::from(gain(psnr(mu), psnr(s1)) > 0.0);
                }
            }
            worst.sort_by(|a, b| a.1.total_cmp(&b.1).then_with(|| a.0.cmp(&b.0)));
            worst.truncate(WORST);
            let n = gains.len();
            let share = |k: usize, of: usize| if of == 0 { 0.0 } else { k as f64 / of as f64 };
            DepthStats {
                depth: d,
                models: n,
                psnr_gain: Distribution::of(gains),
                flip_change: Distribution::of(flips),
                size_ratio: Distribution::of(ratios),
                multi_beats_svo: share(beats, n),
                multi_beats_svo_flip: share(beats_flip, n),
                multi_beats_deeper_svo: (d < deepest && deeper_n > 0)
                    .then(|| share(deeper, deeper_n)),
                worst: worst
                    .into_iter()
                    .map(|(m, g)| (m, g.is_finite().then_some(g)))
                    .collect(),
            }
        })
        .collect()
}

/// The least-squares line of the records' wall time against their triangles.
pub fn time_fit(records: &[&Record]) -> Option<TimeFit> {
    let pts: Vec<(f64, f64)> = records
        .iter()
        .filter_map(|r| r.model.as_ref().map(|m| (m.triangles as f64, r.wall_ms)))
        .collect();
    let n = pts.len() as f64;
    if pts.is_empty() {
        return None;
    }
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    Some(TimeFit {
        models: pts.len(),
        intercept_ms: my - slope * mx,
        slope_ms_per_triangle: slope,
        mean_ms: my,
        total_ms: pts.iter().map(|p| p.1).sum(),
    })
}

/// One shard folder, read.
struct ShardDir {
    dir: PathBuf,
    info: ShardInfo,
    records: Vec<Record>,
}

/// What is wrong with a `shard.json`'s own values, or `None`: the settings are ones a sweep
/// can run (depths within 1..=16 in increasing order, the sweep's methods each once, the sizes
/// its flags allow), and the counts agree with the shard.
fn info_problem(info: &ShardInfo) -> Option<String> {
    let s = &info.settings;
    let methods: Vec<&str> = SweepMethod::ALL.iter().map(|m| m.name()).collect();
    let problem = if info.manifest_entries == 0 || info.manifest_entries > manifest::MAX_ENTRIES {
        format!(
            "manifest_entries {} is not within 1..={}",
            info.manifest_entries,
            manifest::MAX_ENTRIES
        )
    } else if s.depths.is_empty()
        || s.depths.iter().any(|d| !(1..=MAX_DEPTH).contains(d))
        || s.depths.windows(2).any(|w| w[0] >= w[1])
    {
        format!(
            "settings.depths {:?} are not increasing depths within 1..={MAX_DEPTH}",
            s.depths
        )
    } else if s.methods.is_empty()
        || s.methods.iter().any(|m| !methods.contains(&m.as_str()))
        || (1..s.methods.len()).any(|i| s.methods[..i].contains(&s.methods[i]))
    {
        format!(
            "settings.methods {:?} are not some of {methods:?}, each once",
            s.methods
                .iter()
                .map(|m| m.chars().take(40).collect::<String>())
                .collect::<Vec<_>>()
        )
    } else if !(8..=8192).contains(&s.size) || s.max_voxels == 0 || !(1..=64).contains(&s.views) {
        format!(
            "settings size {}, max_voxels {} or views {} are out of range",
            s.size, s.max_voxels, s.views
        )
    } else if s.threads == Some(0) {
        "settings.threads is 0".to_owned()
    } else if info.entries.len() != info.shard.owned(info.manifest_entries)
        || info.models != info.entries.len()
    {
        if info.entries.is_empty() && info.manifest_hash.is_empty() {
            "written by an older sdfmo, without entry fingerprints: rerun the shard with this \
             version (it resumes nothing, its ledger records are of the old layout)"
                .to_owned()
        } else {
            format!(
                "shard {} of {} entries owns {} of them, but the file lists {} fingerprints and \
                 {} models",
                info.shard,
                info.manifest_entries,
                info.shard.owned(info.manifest_entries),
                info.entries.len(),
                info.models
            )
        }
    } else if !info.wall_ms.is_finite() || info.wall_ms < 0.0 {
        format!("wall_ms {} must be finite and ≥ 0", info.wall_ms)
    } else {
        return None;
    };
    Some(problem)
}

/// What is wrong with a current ledger record, or `None`: its name is one the sweep writes, its
/// rows are of its model, of the settings' methods and depths, each once, and pass the row
/// checks every reader of rows applies; its times are finite.
fn record_problem(r: &Record, settings: &SweepSettings) -> Option<String> {
    if !super::is_safe_name(&r.name) {
        return Some(format!(
            "model name {:?} must be letters, digits, '-', '_' or '.' (not first)",
            r.name.chars().take(120).collect::<String>()
        ));
    }
    if !r.wall_ms.is_finite() || r.wall_ms < 0.0 {
        return Some(format!("wall_ms {} must be finite and ≥ 0", r.wall_ms));
    }
    if let Some(m) = &r.model {
        if m.model != r.name {
            return Some(format!("its model is named {:?}", m.model));
        }
        if !m.reference_render_ms.is_finite() || m.reference_render_ms < 0.0 {
            return Some(format!(
                "reference_render_ms {} must be finite and ≥ 0",
                m.reference_render_ms
            ));
        }
    }
    for (i, row) in r.rows.iter().enumerate() {
        let problem = if row.model != r.name {
            Some(format!("its model is {:?}", row.model))
        } else if !settings.methods.contains(&row.method) {
            Some(format!(
                "method {:?} is not one of the settings'",
                row.method
            ))
        } else if !settings.depths.contains(&row.depth) {
            Some(format!("depth {} is not one of the settings'", row.depth))
        } else if r.rows[..i]
            .iter()
            .any(|o| o.method == row.method && o.depth == row.depth)
        {
            Some("it repeats an earlier row's method and depth".to_owned())
        } else {
            row_problem(row)
        };
        if let Some(p) = problem {
            return Some(format!("row {i}: {p}"));
        }
    }
    None
}

/// Reads the shards' folders and checks they make one whole run.
fn read_shards(dirs: &[PathBuf]) -> anyhow::Result<Vec<ShardDir>> {
    let mut out: Vec<ShardDir> = Vec::new();
    for dir in dirs {
        let path = dir.join(SHARD_FILE);
        let bytes =
            sdf_multioctree::io::read_beneath(dir, Path::new(SHARD_FILE), MAX_SHARD_FILE_BYTES)
                .with_context(|| {
                    format!(
                        "{} is not the output folder of a manifest sweep",
                        dir.display()
                    )
                })?;
        let info: ShardInfo = serde_json::from_slice(&bytes)
            .with_context(|| format!("{} is not a shard description", path.display()))?;
        if let Some(reason) = info_problem(&info) {
            return Err(MergeError::BadShardFile { path, reason }.into());
        }
        let shard = info.shard;
        let current = |r: &Record| {
            shard.owns(r.index)
                && r.index < info.manifest_entries
                && info.entries.get(shard.slot(r.index)) == Some(&r.entry)
        };
        let (records, _) =
            ledger::read(dir, &info.settings_hash, &current, ledger::MAX_LEDGER_BYTES)?;
        for r in &records {
            if let Some(reason) = record_problem(r, &info.settings) {
                return Err(MergeError::BadRecord {
                    path: ledger::ledger_path(dir),
                    index: r.index,
                    id: r.id.chars().take(120).collect(),
                    reason,
                }
                .into());
            }
        }
        out.push(ShardDir {
            dir: dir.clone(),
            info,
            records,
        });
    }
    let first = &out[0].info;
    for s in &out[1..] {
        if s.info.settings_hash != first.settings_hash || s.info.settings != first.settings {
            bail!(
                "{} ran with other settings than {} (settings {} against {}): merge shards of one run",
                s.dir.display(),
                out[0].dir.display(),
                s.info.settings_hash,
                first.settings_hash
            );
        }
        if s.info.manifest_entries != first.manifest_entries
            || s.info.shard.count != first.shard.count
        {
            bail!(
                "{} is shard {} of a manifest of {} models, {} is shard {} of {}: merge shards of one run",
                s.dir.display(),
                s.info.shard,
                s.info.manifest_entries,
                out[0].dir.display(),
                first.shard,
                first.manifest_entries
            );
        }
        if s.info.manifest_hash != first.manifest_hash {
            bail!(
                "{} and {} ran on different versions of the manifest (fingerprints {} and {}): \
                 rerun the older shard with the current manifest",
                s.dir.display(),
                out[0].dir.display(),
                s.info.manifest_hash,
                first.manifest_hash
            );
        }
    }
    let count = first.shard.count;
    let mut seen: HashMap<usize, &Path> = HashMap::new();
    for s in &out {
        if let Some(other) = seen.insert(s.info.shard.index, &s.dir) {
            bail!(
                "shard {} is given twice ({} and {})",
                s.info.shard,
                other.display(),
                s.dir.display()
            );
        }
    }
    let missing: Vec<String> = (0..count)
        .filter(|k| !seen.contains_key(k))
        .map(|k| Shard { index: k, count }.to_string())
        .collect();
    if !missing.is_empty() {
        bail!(
            "shards {} are missing: give every shard's folder",
            missing.join(", ")
        );
    }
    // The shards' fingerprints, interleaved back into manifest order, must be the manifest the
    // shards name: shards of two versions of a manifest of the same length do not mix.
    let by_index: HashMap<usize, &ShardInfo> =
        out.iter().map(|s| (s.info.shard.index, &s.info)).collect();
    let fingerprints = (0..first.manifest_entries).map(|i| {
        let info = by_index[&(i % count)];
        info.entries[info.shard.slot(i)].as_str()
    });
    let whole = manifest::manifest_fingerprint(fingerprints);
    if whole != first.manifest_hash {
        bail!(
            "the shards' entry fingerprints make the manifest {whole}, not the {} their shard.json \
             files name: merge shards of one run",
            first.manifest_hash
        );
    }
    Ok(out)
}

/// `path` made absolute with every existing part's links resolved (what it will be once
/// created), for comparing folders.
fn resolved(path: &Path) -> Result<PathBuf, MergeError> {
    let unresolved = || MergeError::OutputUnresolved {
        out: path.to_path_buf(),
    };
    let mut rest: Vec<&std::ffi::OsStr> = Vec::new();
    let mut at = path;
    loop {
        let probe = if at.as_os_str().is_empty() {
            Path::new(".")
        } else {
            at
        };
        if let Ok(real) = probe.canonicalize() {
            let mut p = real;
            p.extend(rest.iter().rev());
            return Ok(p);
        }
        match at.components().next_back() {
            Some(std::path::Component::Normal(name)) => rest.push(name),
            Some(std::path::Component::CurDir) => {}
            _ => return Err(unresolved()),
        }
        at = at.parent().ok_or_else(unresolved)?;
    }
}

/// Refuses an `out` that is one of `dirs` or inside one.
fn check_output_apart(out: &Path, dirs: &[PathBuf]) -> anyhow::Result<()> {
    let target = resolved(out)?;
    for d in dirs {
        let d_real = d
            .canonicalize()
            .with_context(|| format!("cannot resolve {}", d.display()))?;
        if target.starts_with(&d_real) {
            return Err(MergeError::OutputInsideInput {
                out: out.to_path_buf(),
                shard: d.clone(),
            }
            .into());
        }
    }
    Ok(())
}

/// Runs the merge.
pub fn run(args: &SweepOptions) -> anyhow::Result<Outcome> {
    let shards = read_shards(&args.merge)?;
    let out = &args.output;
    check_output_apart(out, &args.merge)?;
    sdf_multioctree::io::create_derived_dir(out, Path::new("images"))?;
    let info = &shards[0].info;
    let mut settings = info.settings.clone();
    settings.threads = shards.iter().filter_map(|s| s.info.settings.threads).max();
    let mut all: Vec<(&ShardDir, &Record)> = shards
        .iter()
        .flat_map(|s| s.records.iter().map(move |r| (s, r)))
        .collect();
    all.sort_by_key(|(_, r)| r.index);
    // Stale records were skipped: what is left holds each entry, id and name at most once, or
    // the folders were tampered with.
    let mut ids = HashSet::new();
    let mut names = HashSet::new();
    let mut entries = HashSet::new();
    for (s, r) in &all {
        let twice = if !ids.insert(r.id.as_str()) {
            Some("its id is in another current record")
        } else if !names.insert(r.name.as_str()) {
            Some("its model name is in another current record")
        } else if !entries.insert(r.index) {
            Some("its manifest entry has another current record")
        } else {
            None
        };
        if let Some(reason) = twice {
            return Err(MergeError::BadRecord {
                path: ledger::ledger_path(&s.dir),
                index: r.index,
                id: r.id.chars().take(120).collect(),
                reason: reason.to_owned(),
            }
            .into());
        }
    }
    let mut models: Vec<Model> = Vec::new();
    let mut rows: Vec<Row> = Vec::new();
    let mut failures: Vec<Failure> = Vec::new();
    for (_, r) in &all {
        match (&r.model, Failure::of(r)) {
            (Some(m), None) => {
                models.push(m.clone());
                rows.extend(r.rows.iter().cloned());
            }
            (_, f) => failures.extend(f),
        }
    }
    // Every index is below manifest_entries and counted once (above): no underflow.
    let unfinished = info.manifest_entries - entries.len();
    let records: Vec<&Record> = all.iter().map(|(_, r)| *r).collect();
    let stats = DatasetStats {
        manifest_models: info.manifest_entries,
        done: models.len(),
        failed: failures.len(),
        depths: depth_stats(&settings, &models, &rows),
        time_per_model: time_fit(&records),
    };

    // The worst models' images, copied from their shard's folder.
    let dir_of: HashMap<&str, &Path> = all
        .iter()
        .map(|(s, r)| (r.name.as_str(), s.dir.as_path()))
        .collect();
    let mut shown: Vec<String> = Vec::new();
    for d in &stats.depths {
        for (m, _) in &d.worst {
            if !shown.contains(m) {
                shown.push(m.clone());
            }
        }
    }
    let mut files: Vec<String> = Vec::new();
    for m in &shown {
        let Some(src) = dir_of.get(m.as_str()) else {
            continue;
        };
        sdf_multioctree::io::create_derived_dir(out, &Path::new("images").join(m))?;
        let mut wanted = vec![reference_file(0)];
        for &d in &settings.depths {
            for method in &settings.methods {
                wanted.push(view_file(method, d, 0));
                wanted.push(heatmap_file(method, d, 0));
            }
        }
        for f in wanted {
            let rel = image_rel(m, &f);
            // No link below the shard folder is followed; a missing image is left out.
            match sdf_multioctree::io::read_beneath(src, Path::new(&rel), MAX_IMAGE_BYTES) {
                Ok(bytes) => write_derived(&out.join(&rel), &bytes)?,
                Err(e) if e.os_kind() == Some(std::io::ErrorKind::NotFound) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }

    let shard_list: Vec<serde_json::Value> = shards
        .iter()
        .map(|s| {
            serde_json::json!({
                "folder": s.dir.display().to_string(),
                "shard": s.info.shard,
                "models": s.info.models,
                "wall_ms": s.info.wall_ms,
            })
        })
        .collect();
    let provenance = super::report::Provenance::current(&settings, usize::from(args.frames));
    // The single run's model (its summary and CSV), the dataset's additions beside it.
    let report = super::report::Report::new(
        settings.clone(),
        provenance.clone(),
        models.clone(),
        rows.clone(),
        Vec::new(),
    );
    let results = serde_json::json!({
        "settings": settings,
        "provenance": provenance,
        "models": models,
        "rows": rows,
        "summary": report.summary,
        "failures": failures,
        "dataset": stats,
        "shards": shard_list,
        "manifest": info.manifest,
        "settings_hash": info.settings_hash,
    });
    let mut text = serde_json::to_string_pretty(&results)?;
    text.push('\n');
    write_derived(&out.join("results.json"), text.as_bytes())?;
    write_derived(
        &out.join("results.csv"),
        super::report::csv::csv(&report)?.as_bytes(),
    )?;
    write_derived(
        &out.join("failures.csv"),
        failures_csv(&failures)?.as_bytes(),
    )?;
    files.extend(["results.json", "results.csv", "failures.csv"].map(String::from));
    files.extend(plots::write(out, &settings, &stats, &models, &rows)?);
    let md = page::markdown(&settings, &stats, &failures, &models, &rows, unfinished);
    write_derived(&out.join("dataset.md"), md.as_bytes())?;
    files.push("dataset.md".into());
    let html = page::html(&page::Page {
        settings: &settings,
        stats: &stats,
        failures: &failures,
        models: &models,
        rows: &rows,
        shown: &shown,
        provenance: &provenance,
        shards: shards.len(),
        unfinished,
        manifest: &info.manifest,
    });
    write_derived(&out.join("index.html"), html.as_bytes())?;
    files.push("index.html".into());

    let outcome = if args.json {
        Outcome::json(&serde_json::json!({
            "output": out.display().to_string(),
            "models": stats.manifest_models,
            "done": stats.done,
            "failed": stats.failed,
            "dataset": stats,
            "files": files,
        }))?
    } else {
        Outcome::text(format!(
            "{md}\nWrote {} (open {} in a browser).\n",
            files.join(", "),
            out.join("index.html").display()
        ))
    };
    if unfinished > 0 {
        let first: Vec<String> = (0..info.manifest_entries)
            .filter(|i| !entries.contains(i))
            .take(5)
            .map(|i| i.to_string())
            .collect();
        return Ok(outcome.then_fail(anyhow::anyhow!(
            "{unfinished} of {} models have no current ledger record (manifest entries {}{}): a \
             shard did not finish, or ran before the manifest was edited (rerun it, then merge \
             again)",
            stats.manifest_models,
            first.join(", "),
            if unfinished > first.len() {
                ", …"
            } else {
                ""
            }
        )));
    }
    Ok(outcome)
}

/// The failures as CSV.
fn failures_csv(failures: &[Failure]) -> anyhow::Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(["index", "id", "model", "source", "error"])?;
    for f in failures {
        w.write_record([
            f.index.to_string().as_str(),
            &f.id,
            &f.model,
            &f.source,
            &f.error,
        ])?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(model: &str, method: &str, depth: u8, psnr: Option<f64>, bytes: usize) -> Row {
        Row {
            model: model.into(),
            method: method.into(),
            depth,
            psnr,
            flip: if method == "multi" { 0.1 } else { 0.2 },
            bytes,
            ..Row::default()
        }
    }

    fn model(name: &str) -> Model {
        Model {
            model: name.into(),
            source: name.into(),
            triangles: 100,
            reference_render_ms: 1.0,
        }
    }

    #[test]
    fn quantiles_are_nearest_rank_and_infinities_are_null() {
        let d = Distribution::of(vec![3.0, 1.0, 2.0, 4.0, f64::NAN]);
        assert_eq!(d.n, 4);
        assert_eq!(
            d.quantiles,
            [1.0, 1.0, 1.0, 2.0, 3.0, 4.0, 4.0].map(Some).to_vec()
        );
        assert_eq!(d.mean, Some(2.5));
        let d = Distribution::of(vec![f64::INFINITY, 1.0]);
        assert_eq!(d.quantiles[6], None);
        assert_eq!(d.median(), Some(1.0));
        assert_eq!(Distribution::of(Vec::new()).median(), None);
    }

    #[test]
    fn depth_stats_compare_the_methods_per_model() {
        let settings = SweepSettings::for_tests(vec![5, 6], 64);
        let rows = vec![
            row("a", "svo", 5, Some(20.0), 100),
            row("a", "multi", 5, Some(26.0), 120),
            row("a", "svo", 6, Some(25.0), 400),
            row("a", "multi", 6, Some(30.0), 440),
            row("b", "svo", 5, Some(22.0), 100),
            row("b", "multi", 5, Some(21.0), 100),
            row("b", "svo", 6, None, 400),
            row("b", "multi", 6, None, 400),
        ];
        let s = depth_stats(&settings, &[model("a"), model("b")], &rows);
        assert_eq!(s[0].models, 2);
        assert_eq!(s[0].psnr_gain.quantiles[0], Some(-1.0));
        assert_eq!(s[0].psnr_gain.quantiles[6], Some(6.0));
        assert_eq!(s[0].multi_beats_svo, 0.5);
        assert_eq!(s[0].multi_beats_svo_flip, 1.0);
        // a: multi d5 26 > svo d6 25; b: 21 < ∞.
        assert_eq!(s[0].multi_beats_deeper_svo, Some(0.5));
        assert_eq!(s[1].multi_beats_deeper_svo, None);
        assert_eq!(s[0].worst[0], ("b".to_owned(), Some(-1.0)));
        assert_eq!(s[0].size_ratio.quantiles[6], Some(1.2));
        // ∞ − ∞ counts as no gain.
        assert_eq!(s[1].psnr_gain.quantiles[0], Some(0.0));
    }

    #[test]
    fn the_time_fit_is_a_least_squares_line() {
        let rec = |tri: usize, ms: f64| Record {
            ledger: 1,
            settings: String::new(),
            index: 0,
            id: String::new(),
            entry: String::new(),
            name: String::new(),
            source: String::new(),
            model: Some(Model {
                triangles: tri,
                ..model("x")
            }),
            rows: Vec::new(),
            error: None,
            wall_ms: ms,
            peak_rss_bytes: None,
        };
        let rs = [rec(0, 10.0), rec(100, 30.0), rec(200, 50.0)];
        let f = time_fit(&rs.iter().collect::<Vec<_>>()).unwrap();
        assert!((f.slope_ms_per_triangle - 0.2).abs() < 1e-12);
        assert!((f.intercept_ms - 10.0).abs() < 1e-9);
        assert_eq!(f.total_ms, 90.0);
    }
}
