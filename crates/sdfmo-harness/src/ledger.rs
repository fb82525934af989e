//! The ledger of a shard: `DIR/ledger.jsonl`, one JSON line per finished model (its rows, or
//! its error), appended with [`sdf_multioctree::io::AppendLog`] (one write and a sync per
//! line; a line torn by a kill is dropped when the ledger is reopened).
//!
//! Every record carries the hash of the settings that decide its rows ([`settings_hash`]) and
//! the fingerprint of the manifest entry it is for ([`super::manifest::entry_fingerprint`]:
//! position, id, name, path). A rerun with the same settings skips every model its ledger holds
//! a current record of (done or failed; failed ones again with `--retry-failed`), so a killed or
//! preempted shard resumes where it stopped; a rerun with other settings, or a record of an
//! entry that has since been edited or moved, is ignored and the model runs again (the old
//! records stay in the file, and neither the shard's report nor a merge reads them). Of several
//! current records of one id the last wins (a retried failure is replaced by its retry).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{Model, Row, SweepSettings};
use crate::error::{HarnessError, Result};

/// The ledger's file name inside a shard's output folder.
pub const LEDGER_FILE: &str = "ledger.jsonl";
/// Version of the record layout (2: records carry their entry's fingerprint; records of
/// version 1 are ignored, and their models run again).
pub const LEDGER_VERSION: u32 = 2;
/// Largest ledger read back, checked before reading (about a million records of a few
/// kilobytes would not fit: a shard of ABC's size is tens of thousands).
pub const MAX_LEDGER_BYTES: u64 = 4 << 30;

/// One finished model: its rows, or why it has none.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Record {
    /// [`LEDGER_VERSION`].
    pub ledger: u32,
    /// [`settings_hash`] of the run that wrote it.
    pub settings: String,
    /// Position of the model in the manifest.
    pub index: usize,
    /// Its manifest id.
    pub id: String,
    /// [`super::manifest::entry_fingerprint`] of its manifest entry when it ran.
    pub entry: String,
    /// Its model name (rows, image folder).
    pub name: String,
    /// The path it was loaded from (empty when the manifest line named none).
    pub source: String,
    /// The model's facts when it succeeded.
    pub model: Option<Model>,
    /// Its rows (empty when it failed).
    pub rows: Vec<Row>,
    /// The error line when it failed.
    pub error: Option<String>,
    /// Wall time of the model, child process included (ms).
    pub wall_ms: f64,
    /// Peak resident memory of the model's process, when it reported it (bytes).
    pub peak_rss_bytes: Option<u64>,
}

impl Record {
    /// Whether the model succeeded.
    pub fn ok(&self) -> bool {
        self.error.is_none() && self.model.is_some()
    }
}

/// The hash of what decides a sweep's rows: depths, methods, image size, voxel cap, views,
/// fitted corners (only when on, so that earlier ledgers keep their hash) and the program's
/// version (not the thread count, which changes no row, nor the limits, which
/// only decide whether a model fails). CRC-32 of the settings' JSON, 8 hex digits: a
/// fingerprint to tell runs apart, not a defence against forgery.
pub fn settings_hash(settings: &SweepSettings) -> String {
    let mut key = serde_json::json!({
        "version": env!("CARGO_PKG_VERSION"),
        "depths": settings.depths,
        "methods": settings.methods,
        "size": settings.size,
        "max_voxels": settings.max_voxels,
        "views": settings.views,
    });
    if settings.fit_corners {
        key["fit_corners"] = serde_json::Value::Bool(true);
    }
    format!("{:08x}", crc32fast::hash(key.to_string().as_bytes()))
}

/// Which records count: those whose entry is still the manifest's entry at their position.
pub type Current<'a> = dyn Fn(&Record) -> bool + 'a;

/// A shard's ledger, open for appending, with the records of the current settings.
pub struct Ledger {
    log: sdf_multioctree::io::AppendLog,
    hash: String,
    /// Current records of the current settings by id (the last of an id wins).
    records: HashMap<String, Record>,
    /// Records of other settings or of stale entries, or unreadable lines, that were ignored.
    pub ignored: usize,
}

impl Ledger {
    /// Opens (or creates) `dir/ledger.jsonl` and reads the records written with `hash` that
    /// `current` accepts.
    pub fn open(dir: &Path, hash: &str, current: &Current) -> Result<Ledger> {
        let path = ledger_path(dir);
        let (log, bytes) = sdf_multioctree::io::AppendLog::open(&path, MAX_LEDGER_BYTES)?;
        let (records, ignored) = parse(&bytes, hash, current);
        Ok(Ledger {
            log,
            hash: hash.to_owned(),
            records,
            ignored,
        })
    }

    /// The record of `id` under the current settings, if any.
    pub fn get(&self, id: &str) -> Option<&Record> {
        self.records.get(id)
    }

    /// Appends `record` (stamped with the current settings' hash) and keeps it.
    pub fn append(&mut self, mut record: Record) -> Result<()> {
        record.settings.clone_from(&self.hash);
        record.ledger = LEDGER_VERSION;
        let line = serde_json::to_string(&record).map_err(|source| HarnessError::Serialise {
            what: "a ledger record",
            source,
        })?;
        self.log.append(line.as_bytes())?;
        self.records.insert(record.id.clone(), record);
        Ok(())
    }

    /// Every record of the current settings, in manifest order.
    pub fn records(&self) -> Vec<&Record> {
        let mut v: Vec<&Record> = self.records.values().collect();
        v.sort_by_key(|r| r.index);
        v
    }
}

/// `dir/ledger.jsonl`.
pub fn ledger_path(dir: &Path) -> PathBuf {
    dir.join(LEDGER_FILE)
}

/// Reads the records of `hash` that `current` accepts from a finished shard's folder (for
/// `--merge`), in manifest order, with the count of lines ignored. The folder is someone
/// else's: the ledger is read without following a link ([`sdf_multioctree::io::read_beneath`])
/// and its size checked against `limit` before reading.
pub fn read(dir: &Path, hash: &str, current: &Current, limit: u64) -> Result<(Vec<Record>, usize)> {
    let bytes = sdf_multioctree::io::read_beneath(dir, Path::new(LEDGER_FILE), limit)?;
    let complete = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let (records, ignored) = parse(&bytes[..complete], hash, current);
    let mut v: Vec<Record> = records.into_values().collect();
    v.sort_by_key(|r| r.index);
    Ok((v, ignored))
}

/// The current records of `hash` by id (last wins), and how many lines were ignored.
fn parse(bytes: &[u8], hash: &str, current: &Current) -> (HashMap<String, Record>, usize) {
    let mut records = HashMap::new();
    let mut ignored = 0;
    for line in bytes.split(|&b| b == b'\n').filter(|l| !l.is_empty()) {
        match serde_json::from_slice::<Record>(line) {
            Ok(r) if r.settings == hash && r.ledger == LEDGER_VERSION && current(&r) => {
                if records.insert(r.id.clone(), r).is_some() {
                    ignored += 1;
                }
            }
            _ => ignored += 1,
        }
    }
    (records, ignored)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(size: u32) -> SweepSettings {
        SweepSettings::for_tests(vec![5, 6], size)
    }

    fn record(id: &str, index: usize) -> Record {
        Record {
            ledger: 0,
            settings: String::new(),
            index,
            id: id.into(),
            entry: format!("e{index}"),
            name: id.into(),
            source: format!("{id}.obj"),
            model: None,
            rows: Vec::new(),
            error: Some("cannot read".into()),
            wall_ms: 1.0,
            peak_rss_bytes: None,
        }
    }

    #[test]
    fn the_hash_follows_the_settings_that_decide_rows_only() {
        let a = settings(64);
        let mut b = a.clone();
        b.threads = Some(7);
        assert_eq!(settings_hash(&a), settings_hash(&b));
        assert_ne!(settings_hash(&a), settings_hash(&settings(65)));
        assert_eq!(settings_hash(&a).len(), 8);
    }

    #[test]
    fn a_rerun_sees_its_records_and_other_settings_start_over() {
        let dir = tempfile::tempdir().unwrap();
        let (h1, h2) = (settings_hash(&settings(64)), settings_hash(&settings(32)));
        let all = |_: &Record| true;
        let mut l = Ledger::open(dir.path(), &h1, &all).unwrap();
        l.append(record("b", 1)).unwrap();
        l.append(record("a", 0)).unwrap();
        drop(l);
        let l = Ledger::open(dir.path(), &h1, &all).unwrap();
        assert!(l.get("a").is_some() && l.get("b").is_some());
        assert_eq!(
            l.records().iter().map(|r| r.index).collect::<Vec<_>>(),
            [0, 1]
        );
        drop(l);
        let mut l = Ledger::open(dir.path(), &h2, &all).unwrap();
        assert!(l.get("a").is_none());
        assert_eq!(l.ignored, 2);
        l.append(record("a", 0)).unwrap();
        drop(l);
        let (v, ignored) = read(dir.path(), &h2, &all, MAX_LEDGER_BYTES).unwrap();
        assert_eq!((v.len(), ignored), (1, 2));
    }

    #[test]
    fn stale_records_do_not_count_and_a_retry_replaces_a_failure() {
        // Issue 32: records were matched by id alone, so a record of an edited manifest line
        // counted; and of two records of one id the first won, so `--retry-failed` kept the
        // failure.
        let dir = tempfile::tempdir().unwrap();
        let h = settings_hash(&settings(64));
        let all = |_: &Record| true;
        let mut l = Ledger::open(dir.path(), &h, &all).unwrap();
        l.append(record("a", 0)).unwrap();
        let mut done = record("a", 0);
        done.error = None;
        done.model = Some(Model {
            model: "a".into(),
            source: "a.obj".into(),
            triangles: 1,
            reference_render_ms: 1.0,
        });
        l.append(done).unwrap();
        assert!(l.get("a").unwrap().ok());
        drop(l);
        let l = Ledger::open(dir.path(), &h, &all).unwrap();
        assert!(l.get("a").unwrap().ok());
        assert_eq!(l.ignored, 1);
        drop(l);
        // The manifest's entry 0 is now another line: both records are stale.
        let edited = |r: &Record| r.entry == "e0-edited";
        let l = Ledger::open(dir.path(), &h, &edited).unwrap();
        assert!(l.get("a").is_none());
        assert_eq!(l.ignored, 2);
    }

    #[test]
    fn ledger_numbers_read_back_to_the_same_bits() {
        // Without serde_json's float_roundtrip, the 47-model dataset run's merged rows differed
        // from the single process's in the last bit of 88 values, e.g. this PSNR read back as
        // 41.08875730870293.
        let mut r = record("a", 0);
        r.wall_ms = 41.088757308702924;
        let line = serde_json::to_string(&r).unwrap();
        let back: Record = serde_json::from_str(&line).unwrap();
        assert_eq!(back.wall_ms.to_bits(), 41.088757308702924f64.to_bits());
    }
}
