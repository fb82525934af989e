//! `sdfmo sweep --manifest FILE [--shard K/N] -o DIR`: one shard of a dataset sweep. Each model
//! of the shard runs in its own process ([`super::isolate`]); each finished model, done or
//! failed, is one line of `DIR/ledger.jsonl` ([`super::ledger`]); a rerun skips what the ledger
//! holds. At the end the shard writes its tables (`results.json`, `results.csv`, `table.md`)
//! over its successful models and `shard.json` (which shard, settings, failures), and exits
//! with [`ModelsFailed`] (exit code 3) when any model of the shard failed.

use std::ffi::OsString;
use std::path::Path;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::isolate::{self, Limits};
use super::ledger::{self, Ledger, Record};
use super::manifest::{self, Entry, Manifest, Shard};
use super::report::dataset::Failure;
use super::{report, Model, Row, SweepSettings};
use crate::error::{HarnessError, ModelsFailed, Result, ShardError};
use crate::files::write_derived;
use crate::progress;
use crate::{Outcome, ShardStep, SweepOptions};

/// File name of a shard's description inside its output folder.
pub const SHARD_FILE: &str = "shard.json";

/// Largest `shard.json` read back (it lists one fingerprint, a line of 24 bytes, per model of
/// the shard: a whole manifest of [`manifest::MAX_ENTRIES`] in one shard takes about 24 MB).
pub const MAX_SHARD_FILE_BYTES: u64 = 64 << 20;

/// Exit code of a shard (or merge) that finished but recorded failed models.
pub const EXIT_MODELS_FAILED: u8 = 3;

/// What `shard.json` says.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShardInfo {
    /// The manifest as given.
    pub manifest: String,
    /// Entries in the whole manifest.
    pub manifest_entries: usize,
    /// [`manifest::manifest_fingerprint`] of the whole manifest (empty in folders written
    /// before fingerprints).
    #[serde(default)]
    pub manifest_hash: String,
    /// The fingerprints of this shard's entries in manifest order (`entries[k]` is entry
    /// `shard.index + k · shard.count`): what a merge checks each ledger record against.
    #[serde(default)]
    pub entries: Vec<String>,
    /// Which shard.
    pub shard: Shard,
    /// [`ledger::settings_hash`] of the settings.
    pub settings_hash: String,
    /// The settings.
    pub settings: SweepSettings,
    /// Models of this shard.
    pub models: usize,
    /// Models that succeeded.
    pub done: usize,
    /// Models that failed: (name, error).
    pub failures: Vec<Failure>,
    /// Wall time of this invocation (ms).
    pub wall_ms: f64,
    /// Models this invocation ran (the others were in the ledger already).
    pub ran: usize,
}

impl Failure {
    /// The failure a ledger record holds, if it is one.
    pub fn of(r: &Record) -> Option<Failure> {
        (!r.ok()).then(|| Failure {
            index: r.index,
            id: r.id.clone(),
            model: r.name.clone(),
            source: r.source.clone(),
            error: r.error.clone().unwrap_or_else(|| "no result".to_owned()),
        })
    }
}

/// What a model's process prints (one JSON line on stdout).
#[derive(Debug, Serialize, Deserialize)]
pub struct ModelOutput {
    /// The model's facts.
    pub model: Model,
    /// Its rows.
    pub rows: Vec<Row>,
}

/// Runs this process's shard of `step`'s manifest.
pub fn run(args: &SweepOptions, step: &ShardStep, settings: &SweepSettings) -> Result<Outcome> {
    let start = Instant::now();
    let manifest_path = step.manifest.as_path();
    let manifest = Manifest::read(manifest_path, step.confine)?;
    let shard = Shard::resolve(step.shard)?;
    let out = &args.output;
    sdf_multioctree::io::create_derived_dir(out, Path::new("images"))?;
    let hash = ledger::settings_hash(settings);
    // One folder per shard: a ledger of another shard (or manifest) is never appended to.
    let info_path = out.join(SHARD_FILE);
    if std::fs::symlink_metadata(&info_path).is_ok() {
        let bytes =
            sdf_multioctree::io::read_beneath(out, Path::new(SHARD_FILE), MAX_SHARD_FILE_BYTES)?;
        let old: ShardInfo =
            serde_json::from_slice(&bytes).map_err(|source| HarnessError::NotShardDescription {
                path: info_path.clone(),
                source,
            })?;
        if old.shard != shard || old.manifest_entries != manifest.entries.len() {
            return Err(ShardError::OtherShardsFolder {
                out: out.clone(),
                held: old.shard,
                held_entries: old.manifest_entries,
                shard,
                entries: manifest.entries.len(),
            }
            .into());
        }
    }
    // A record counts only for the entry it ran: same position, id and fingerprint.
    let current = |r: &Record| {
        manifest
            .entries
            .get(r.index)
            .is_some_and(|e| e.id == r.id && e.fingerprint == r.entry)
    };
    let mut ledger = Ledger::open(out, &hash, &current)?;
    let mine: Vec<&Entry> = manifest
        .entries
        .iter()
        .filter(|e| shard.owns(e.index))
        .collect();
    let todo: Vec<&Entry> = mine
        .iter()
        .copied()
        .filter(|e| match ledger.get(&e.id) {
            None => true,
            Some(r) => step.retry_failed && !r.ok(),
        })
        .collect();
    let skipped = mine.len() - todo.len();
    let limits = Limits {
        timeout: step.model_timeout.map(Duration::from_secs_f64),
        address_space: isolate::address_space_cap(super::memory_budget(args.max_memory)),
    };
    let bar = progress::steps(todo.len() as u64, "starting");
    if ledger.ignored > 0 {
        bar.println(format!(
            "shard {shard}: {} ledger records ignored (other settings, edited or moved manifest \
             lines, or replaced by a later record)",
            ledger.ignored
        ));
    }
    if skipped > 0 {
        bar.println(format!(
            "shard {shard}: {skipped} of {} models already in {} (skipped)",
            mine.len(),
            ledger::ledger_path(out).display()
        ));
    }
    for e in &todo {
        bar.set_message(e.name.clone());
        let record = run_entry(args, e, limits)?;
        ledger.append(record)?;
        bar.inc(1);
    }
    bar.finish_and_clear();

    let records = ledger.records();
    let mut models: Vec<Model> = Vec::new();
    let mut rows: Vec<Row> = Vec::new();
    let mut failures: Vec<Failure> = Vec::new();
    for r in records.iter().filter(|r| shard.owns(r.index)) {
        match (&r.model, Failure::of(r)) {
            (Some(m), None) => {
                models.push(m.clone());
                rows.extend(r.rows.iter().cloned());
            }
            (_, f) => failures.extend(f),
        }
    }
    let files = report::write_tables(
        out,
        &report::Report::new(
            settings.clone(),
            report::Provenance::current(settings, usize::from(args.frames)),
            models.clone(),
            rows.clone(),
            Vec::new(),
        ),
    )?;
    let info = ShardInfo {
        manifest: manifest_path.display().to_string(),
        manifest_entries: manifest.entries.len(),
        manifest_hash: manifest::manifest_fingerprint(
            manifest.entries.iter().map(|e| e.fingerprint.as_str()),
        ),
        entries: mine.iter().map(|e| e.fingerprint.clone()).collect(),
        shard,
        settings_hash: hash,
        settings: settings.clone(),
        models: mine.len(),
        done: models.len(),
        failures: failures.clone(),
        wall_ms: start.elapsed().as_secs_f64() * 1e3,
        ran: todo.len(),
    };
    let bytes = serde_json::to_vec_pretty(&info).map_err(|source| HarnessError::Serialise {
        what: "shard.json",
        source,
    })?;
    write_derived(&info_path, &bytes)?;
    let outcome = if args.json {
        Outcome::json(&serde_json::json!({
            "output": out.display().to_string(),
            "shard": info,
            "files": files,
        }))?
    } else {
        let mut s = format!(
            "shard {shard}: {} models, {} done, {} failed, {} ran now, {} skipped ({}).\n",
            mine.len(),
            models.len(),
            failures.len(),
            todo.len(),
            skipped,
            ledger::ledger_path(out).display()
        );
        for f in &failures {
            s.push_str(&format!(
                "  failed: {} ({}): {}\n",
                f.model, f.source, f.error
            ));
        }
        Outcome::text(s)
    };
    if !failures.is_empty() {
        return Ok(outcome.then_fail(
            ModelsFailed {
                failed: failures.len(),
                total: mine.len(),
            }
            .into(),
        ));
    }
    Ok(outcome)
}

/// Runs one manifest entry in its own process and returns its ledger record.
fn run_entry(args: &SweepOptions, e: &Entry, limits: Limits) -> Result<Record> {
    let mut record = Record {
        ledger: ledger::LEDGER_VERSION,
        settings: String::new(),
        index: e.index,
        id: e.id.clone(),
        entry: e.fingerprint.clone(),
        name: e.name.clone(),
        source: String::new(),
        model: None,
        rows: Vec::new(),
        error: None,
        wall_ms: 0.0,
        peak_rss_bytes: None,
    };
    let path = match &e.path {
        Ok(p) => p,
        Err(problem) => {
            record.error = Some(format!("manifest line {}: {problem}", e.line));
            return Ok(record);
        }
    };
    record.source = path.display().to_string();
    let run = isolate::run_child(&child_args(args, path, &e.name), limits)?;
    record.wall_ms = run.wall_ms;
    record.peak_rss_bytes = run.peak_rss_bytes;
    match run.result.and_then(|out| {
        serde_json::from_slice::<ModelOutput>(&out)
            .map_err(|err| format!("its process printed no result ({err})"))
    }) {
        Ok(o) => {
            record.model = Some(o.model);
            record.rows = o.rows;
        }
        Err(err) => record.error = Some(err),
    }
    Ok(record)
}

/// The arguments of the process that sweeps one model: the same settings, this model only.
/// Every option is one `--flag=value` word and the mesh comes last after `--`, so a model name
/// or a path starting with `-` is never read as an option.
fn child_args(args: &SweepOptions, path: &Path, name: &str) -> Vec<OsString> {
    let mut v: Vec<OsString> = vec!["sweep".into()];
    let mut model = OsString::from("--isolated-model=");
    model.push(name);
    v.push(model);
    v.push(format!("--depths={}..{}", args.depths.start(), args.depths.end()).into());
    let methods: Vec<&str> = args.methods.iter().map(|m| m.name()).collect();
    v.push(format!("--methods={}", methods.join(",")).into());
    v.push(format!("--size={}", args.size).into());
    v.push(format!("--max-voxels={}", args.max_voxels).into());
    if args.fit_corners {
        v.push("--fit-corners".into());
    }
    v.push(format!("--frames={}", args.frames).into());
    if args.levels {
        v.push("--levels".into());
    }
    if let Some(m) = args.max_memory {
        v.push(format!("--max-memory={m}").into());
    }
    if let Some(t) = args.threads {
        v.push(format!("--threads={t}").into());
    }
    let mut output = OsString::from("--output=");
    output.push(&args.output);
    v.push(output);
    v.push("--".into());
    v.push(path.into());
    v
}
