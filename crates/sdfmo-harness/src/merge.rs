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
//! From the ledgers the merge makes one typed [`DatasetReport`] (the single run's report of the
//! models that succeeded, plus the failures, the shards and the statistics of
//! [`super::report::dataset`]) and `OUT` gets:
//! - `results.json`: that report (the single run's schema, `settings`, `provenance`, `models`,
//!   `rows`, `summary`, plus `failures`, `dataset`, `shards`, `manifest`, `settings_hash`);
//! - `results.csv` (the rows), `failures.csv`, and the report through the templates:
//!   `dataset.md` and `index.html`; the plots `dataset_psnr_gain_cdf.png`,
//!   `dataset_size_ratio_cdf.png`, `dataset_time_vs_triangles.png`;
//! - `images/` with the reference, both methods' first view and FLIP maps of the worst models.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use super::ledger::{self, Record};
use super::manifest::{self, Shard};
use super::report::dataset::{
    depth_stats, time_fit, DatasetReport, DatasetStats, Failure, ShardSummary,
};
use super::report::extra::{row_problem, MAX_DEPTH};
use super::report::{dataset_page, results_json, Provenance, Report};
use super::shard::{ShardInfo, MAX_SHARD_FILE_BYTES, SHARD_FILE};
use super::{heatmap_file, image_rel, reference_file, view_file, Model, Row, SweepSettings};
use crate::error::{HarnessError, HashPair, MergeError, Result};
use crate::files::write_derived;
use crate::{Outcome, SweepMethod, SweepOptions};

mod plots;

/// Largest image copied from a shard folder (a 8192² PNG of noise is about 200 MB).
const MAX_IMAGE_BYTES: u64 = 256 << 20;

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

/// Checks that shard folder `s` belongs to the run of the `first`: the same settings, the same
/// manifest length and shard count, the same manifest.
fn same_run(first: &ShardDir, s: &ShardDir) -> Result<()> {
    let (a, b) = (&first.info, &s.info);
    let pair = |hash: &str, first_hash: &str| HashPair {
        dir: s.dir.clone(),
        first: first.dir.clone(),
        hash: hash.to_owned(),
        first_hash: first_hash.to_owned(),
    };
    if b.settings_hash != a.settings_hash || b.settings != a.settings {
        let hashes = pair(&b.settings_hash, &a.settings_hash);
        return Err(MergeError::OtherSettings(hashes).into());
    }
    if b.manifest_entries != a.manifest_entries || b.shard.count != a.shard.count {
        return Err(MergeError::OtherRun {
            dir: s.dir.clone(),
            shard: b.shard,
            entries: b.manifest_entries,
            first: first.dir.clone(),
            first_shard: a.shard,
            first_entries: a.manifest_entries,
        }
        .into());
    }
    if b.manifest_hash != a.manifest_hash {
        let hashes = pair(&b.manifest_hash, &a.manifest_hash);
        return Err(MergeError::ManifestVersions(hashes).into());
    }
    Ok(())
}

/// Reads the shards' folders and checks they make one whole run.
fn read_shards(dirs: &[PathBuf]) -> Result<Vec<ShardDir>> {
    let mut out: Vec<ShardDir> = Vec::new();
    for dir in dirs {
        let path = dir.join(SHARD_FILE);
        let bytes =
            sdf_multioctree::io::read_beneath(dir, Path::new(SHARD_FILE), MAX_SHARD_FILE_BYTES)
                .map_err(|source| MergeError::NotShardFolder {
                    dir: dir.clone(),
                    source,
                })?;
        let info: ShardInfo =
            serde_json::from_slice(&bytes).map_err(|source| HarnessError::NotShardDescription {
                path: path.clone(),
                source,
            })?;
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
    for s in &out[1..] {
        same_run(&out[0], s)?;
    }
    let first = &out[0].info;
    let count = first.shard.count;
    let mut seen: HashMap<usize, &Path> = HashMap::new();
    for s in &out {
        if let Some(other) = seen.insert(s.info.shard.index, &s.dir) {
            return Err(MergeError::ShardTwice {
                shard: s.info.shard,
                first: other.to_path_buf(),
                second: s.dir.clone(),
            }
            .into());
        }
    }
    let missing: Vec<String> = (0..count)
        .filter(|k| !seen.contains_key(k))
        .map(|k| Shard { index: k, count }.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(MergeError::ShardsMissing { missing }.into());
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
        return Err(MergeError::Fingerprints {
            whole,
            named: first.manifest_hash.clone(),
        }
        .into());
    }
    Ok(out)
}

/// `path` made absolute with every existing part's links resolved (what it will be once
/// created), for comparing folders.
fn resolved(path: &Path) -> std::result::Result<PathBuf, MergeError> {
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
fn check_output_apart(out: &Path, dirs: &[PathBuf]) -> std::result::Result<(), MergeError> {
    let target = resolved(out)?;
    for d in dirs {
        let d_real = d
            .canonicalize()
            .map_err(|source| MergeError::Unresolvable {
                dir: d.clone(),
                source,
            })?;
        if target.starts_with(&d_real) {
            return Err(MergeError::OutputInsideInput {
                out: out.to_path_buf(),
                shard: d.clone(),
            });
        }
    }
    Ok(())
}

/// Runs the merge.
pub fn run(args: &SweepOptions, dirs: &[PathBuf]) -> Result<Outcome> {
    let shards = read_shards(dirs)?;
    let out = &args.output;
    check_output_apart(out, dirs)?;
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
    let points: Vec<(usize, f64)> = all
        .iter()
        .filter_map(|(_, r)| r.model.as_ref().map(|m| (m.triangles, r.wall_ms)))
        .collect();
    let dataset = DatasetStats {
        manifest_models: info.manifest_entries,
        done: models.len(),
        failed: failures.len(),
        depths: depth_stats(&settings, &models, &rows),
        time_per_model: time_fit(&points),
    };
    let provenance = Provenance::current(&settings, usize::from(args.frames));
    let report = DatasetReport {
        dataset,
        failures,
        manifest: info.manifest.clone(),
        report: Report::new(settings, provenance, models, rows, Vec::new()),
        settings_hash: info.settings_hash.clone(),
        shards: shards
            .iter()
            .map(|s| ShardSummary {
                folder: s.dir.display().to_string(),
                shard: s.info.shard,
                models: s.info.models,
                wall_ms: s.info.wall_ms,
            })
            .collect(),
    };
    let stats = &report.dataset;
    let settings = &report.report.settings;

    // The worst models' images, copied from their shard's folder.
    let dir_of: HashMap<&str, &Path> = all
        .iter()
        .map(|(s, r)| (r.name.as_str(), s.dir.as_path()))
        .collect();
    let mut files: Vec<String> = Vec::new();
    for m in stats.shown() {
        let Some(src) = dir_of.get(m) else {
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

    write_derived(&out.join("results.json"), results_json(&report)?.as_bytes())?;
    write_derived(
        &out.join("results.csv"),
        super::report::csv::csv(&report.report)?.as_bytes(),
    )?;
    write_derived(
        &out.join("failures.csv"),
        failures_csv(&report.failures)?.as_bytes(),
    )?;
    files.extend(["results.json", "results.csv", "failures.csv"].map(String::from));
    files.extend(plots::write(
        out,
        settings,
        &report.report.models,
        &report.report.rows,
    )?);
    let md = dataset_page::markdown(&report)?;
    write_derived(&out.join("dataset.md"), md.as_bytes())?;
    files.push("dataset.md".into());
    write_derived(
        &out.join("index.html"),
        dataset_page::html(&report)?.as_bytes(),
    )?;
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
    let unfinished = stats.unfinished();
    if unfinished > 0 {
        let first = (0..info.manifest_entries)
            .filter(|i| !entries.contains(i))
            .take(5)
            .collect();
        return Ok(outcome.then_fail(
            MergeError::Unfinished {
                unfinished,
                total: stats.manifest_models,
                first,
            }
            .into(),
        ));
    }
    Ok(outcome)
}

/// The failures as CSV.
fn failures_csv(failures: &[Failure]) -> Result<String> {
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
    Ok(super::report::csv::text(w)?)
}
