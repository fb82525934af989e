//! The manifest of a dataset sweep (`sdfmo sweep --manifest FILE`) and the shard of it this
//! process runs (`--shard K/N`, or the array index of a Slurm or Kubernetes job).
//!
//! **Format.** A file whose name ends in `.csv` is CSV with two columns, `id,path` (a first row
//! `id,path` is a header; fields may be quoted); any other file is one path per line. Blank
//! lines and lines starting with `#` are skipped. A relative path is taken against the
//! manifest's folder; with `--confine` a path must stay inside that folder (no absolute path,
//! no `..`, no symbolic link leading out). The file is read whole, so it must hold at most
//! [`MAX_MANIFEST_BYTES`] and [`MAX_ENTRIES`] entries: split a bigger dataset into several
//! manifests (ABC's chunks of 10,000 models take about 0.5 MB each).
//!
//! **Problems of one line** (an empty path, a path listed twice under two ids, a path outside
//! the folder under `--confine`) do not stop the sweep: the entry is kept with its problem and
//! the shard that owns it records it as a failure, so every line of the manifest ends up in the
//! report exactly once. A file that is missing or malformed fails when its model runs,
//! likewise. An id given twice is an error of the whole manifest, naming it: ledgers and the
//! merge know a model by its id, and a second line of the same id could only shadow the first.
//!
//! **Fingerprints.** Each entry has a [`Entry::fingerprint`] of its position, id, name and path
//! as written. A ledger record counts for an entry only when both match (not the id alone): a
//! record of an edited, reordered or shortened manifest is stale and the model runs again.
//!
//! **Names.** Each entry gets a model name for the rows and the image folders: the CSV id, or
//! the file stem, made safe for file names ([`super::sanitize`]) and unique over the *whole*
//! manifest in line order (`part`, `part_2`, …), so it is the same in every shard.
//!
//! **Assignment.** Entry i (0-based, in manifest order, blank and comment lines not counted)
//! belongs to shard i mod N: deterministic, balanced to within one model, and independent of
//! what any other shard does.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use crate::error::{error_line, ManifestError, ShardError};

/// Largest manifest read (64 MiB, about a million ABC paths).
pub const MAX_MANIFEST_BYTES: u64 = 64 << 20;
/// Most entries a manifest may hold.
pub const MAX_ENTRIES: usize = 1_000_000;

/// One model of the manifest.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Entry {
    /// Position among the entries (0-based, manifest order).
    pub index: usize,
    /// Line of the manifest (1-based), for messages.
    pub line: usize,
    /// The id: the CSV id, or the path as written.
    pub id: String,
    /// The model name in rows and file names (unique over the manifest).
    pub name: String,
    /// The file to load, or why the line cannot name one.
    pub path: Result<PathBuf, String>,
    /// [`entry_fingerprint`] of the entry: what a ledger record must carry to count for it.
    pub fingerprint: String,
}

/// A parsed manifest.
#[derive(Clone, Debug)]
pub struct Manifest {
    /// Every entry, problems included.
    pub entries: Vec<Entry>,
}

/// Which shard of the manifest this process runs: `index` of `count`, 0-based. Read back (from
/// a `shard.json`) it is checked as [`Shard::new`] checks it: a count of 0 or an index out of
/// range is an error of the file, never a division by zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "UncheckedShard")]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

/// A [`Shard`] as read, before [`Shard::new`] checks it.
#[derive(serde::Deserialize)]
struct UncheckedShard {
    index: usize,
    count: usize,
}

impl TryFrom<UncheckedShard> for Shard {
    type Error = String;

    fn try_from(s: UncheckedShard) -> Result<Shard, String> {
        Shard::new(s.index, s.count).map_err(|e| e.to_string())
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The job arrays whose task index names a shard, in the order [`Shard::resolve`] tries them:
/// the index variable, the count variable, the variable of the first index (Slurm numbers its
/// tasks from `--array`'s start) and what to set a missing count to.
const JOB_ARRAYS: [(&str, &str, Option<&str>, &str); 2] = [
    (
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_COUNT",
        Some("SLURM_ARRAY_TASK_MIN"),
        "",
    ),
    (
        "JOB_COMPLETION_INDEX",
        "SDFMO_SHARD_COUNT",
        None,
        " (set it to the Job's completions)",
    ),
];

impl Shard {
    /// The whole manifest in one process.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Whether entry `index` belongs to this shard.
    pub fn owns(&self, index: usize) -> bool {
        index % self.count == self.index
    }

    /// How many of the entries `0..entries` belong to this shard.
    pub fn owned(&self, entries: usize) -> usize {
        entries.saturating_sub(self.index).div_ceil(self.count)
    }

    /// Position of entry `index` among this shard's entries (`index` must be one of them).
    pub fn slot(&self, index: usize) -> usize {
        index / self.count
    }

    /// `--shard K/N` if given; else `SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN` of
    /// `SLURM_ARRAY_TASK_COUNT` in a Slurm array job; else `JOB_COMPLETION_INDEX` of
    /// `SDFMO_SHARD_COUNT` in a Kubernetes indexed Job; else the whole manifest.
    pub fn resolve(given: Option<Shard>) -> Result<Shard, ShardError> {
        Self::resolve_from(given, |k| std::env::var(k).ok())
    }

    /// [`Shard::resolve`] with the environment read through `env`.
    pub fn resolve_from(
        given: Option<Shard>,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<Shard, ShardError> {
        if let Some(s) = given {
            return Ok(s);
        }
        let num = |var: &'static str| -> Result<Option<usize>, ShardError> {
            env(var)
                .map(|value| {
                    value
                        .trim()
                        .parse::<usize>()
                        .map_err(|source| ShardError::NotACount { var, value, source })
                })
                .transpose()
        };
        for (index_var, count_var, min_var, hint) in JOB_ARRAYS {
            let Some(id) = num(index_var)? else {
                continue;
            };
            let count = num(count_var)?.ok_or(ShardError::Unpaired {
                set: index_var,
                missing: count_var,
                hint,
            })?;
            let Some(min_var) = min_var else {
                return Shard::new(id, count);
            };
            let min = num(min_var)?.unwrap_or(0);
            let index = id
                .checked_sub(min)
                .filter(|&i| i < count)
                .ok_or(ShardError::ArrayTask { id, min, count })?;
            return Shard::new(index, count);
        }
        Ok(Shard::ALL)
    }

    /// A checked shard: `count ≥ 1`, `index < count`.
    pub fn new(index: usize, count: usize) -> Result<Shard, ShardError> {
        if count == 0 || index >= count || count > MAX_ENTRIES {
            return Err(ShardError::OutOfRange {
                index,
                count,
                max: MAX_ENTRIES,
            });
        }
        Ok(Shard { index, count })
    }
}

/// Parses `K/N` (0-based K).
pub fn parse_shard(s: &str) -> Result<Shard, String> {
    let bad = || format!("expected a shard K/N with 0 <= K < N (e.g. 0/8), got {s:?}");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let k: usize = k.trim().parse().map_err(|_| bad())?;
    let n: usize = n.trim().parse().map_err(|_| bad())?;
    Shard::new(k, n).map_err(|e| e.to_string())
}

impl Manifest {
    /// Reads and parses `file` (see the module documentation); `confine` keeps every path in
    /// the manifest's folder.
    pub fn read(file: &Path, confine: bool) -> Result<Manifest, ManifestError> {
        let text = sdf_multioctree::io::read_regular_to_string(file, MAX_MANIFEST_BYTES).map_err(
            |source| ManifestError::Read {
                limit: MAX_MANIFEST_BYTES,
                source,
            },
        )?;
        let folder = file
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let csv = file
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        let raw = if csv {
            csv_lines(&text).map_err(|source| ManifestError::Csv {
                path: file.to_path_buf(),
                source,
            })?
        } else {
            text.lines()
                .enumerate()
                .map(|(i, l)| Raw {
                    line: i + 1,
                    id: None,
                    path: l.trim().to_owned(),
                    problem: None,
                })
                .filter(|r| !r.path.is_empty() && !r.path.starts_with('#'))
                .collect()
        };
        if raw.len() > MAX_ENTRIES {
            return Err(ManifestError::TooManyEntries {
                path: file.to_path_buf(),
                entries: raw.len(),
                max: MAX_ENTRIES,
            });
        }
        if raw.is_empty() {
            return Err(ManifestError::Empty {
                path: file.to_path_buf(),
            });
        }
        let mut entries = Vec::with_capacity(raw.len());
        let mut seen_id: HashMap<String, usize> = HashMap::new();
        for raw in &raw {
            let id = raw.id.as_deref().unwrap_or(&raw.path);
            if let Some(first) = seen_id.insert(id.to_owned(), raw.line) {
                return Err(ManifestError::DuplicateId {
                    path: file.to_path_buf(),
                    line: raw.line,
                    id: id.chars().take(120).collect(),
                    first,
                });
            }
        }
        let mut seen_path: HashMap<PathBuf, usize> = HashMap::new();
        let mut names: HashSet<String> = HashSet::new();
        for (index, raw) in raw.into_iter().enumerate() {
            let Raw {
                line,
                id,
                path,
                problem,
            } = raw;
            let id = id.unwrap_or_else(|| path.clone());
            let mut resolved = match problem {
                Some(p) => Err(p),
                None => resolve(folder, &path, confine),
            };
            if let Ok(p) = &resolved {
                if let Some(first) = seen_path.get(p) {
                    resolved = Err(format!(
                        "{} is listed twice (first on line {first})",
                        p.display()
                    ));
                }
            }
            if let Ok(p) = &resolved {
                seen_path.entry(p.clone()).or_insert(line);
            }
            let base = if csv {
                super::sanitize(&id)
            } else {
                super::sanitize(&sdf_multioctree::mesh::mesh_name(Path::new(&path)))
            };
            let name = unique(&base, &mut names);
            let fingerprint = entry_fingerprint(index, &id, &name, &path);
            entries.push(Entry {
                index,
                line,
                id,
                name,
                path: resolved,
                fingerprint,
            });
        }
        Ok(Manifest { entries })
    }
}

/// The fingerprint of a manifest entry: FNV-1a (64 bits, 16 hex digits) of its position, id,
/// model name and path as written, each length-prefixed. A ledger record counts for the entry
/// only when it carries the same; any edit of the line, or a move of it to another position,
/// makes the old record stale. A fingerprint to tell entries apart, not a defence against
/// forgery (the merge checks what a record says on its own).
pub fn entry_fingerprint(index: usize, id: &str, name: &str, path: &str) -> String {
    let mut h = Fnv::default();
    h.write(&(index as u64).to_le_bytes());
    for part in [id, name, path] {
        h.write(&(part.len() as u64).to_le_bytes());
        h.write(part.as_bytes());
    }
    format!("{:016x}", h.0)
}

/// The fingerprint of a whole manifest: FNV-1a of its entries' fingerprints in order, so shards
/// of one manifest agree on it and shards of an edited one do not.
pub fn manifest_fingerprint<'a>(entries: impl IntoIterator<Item = &'a str>) -> String {
    let mut h = Fnv::default();
    for e in entries {
        h.write(e.as_bytes());
        h.write(b"\n");
    }
    format!("{:016x}", h.0)
}

/// 64-bit FNV-1a.
struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// `base`, or `base_2`, `base_3`, … when taken; the result is added to `taken`.
fn unique(base: &str, taken: &mut HashSet<String>) -> String {
    let name = if taken.contains(base) {
        (2..)
            .map(|i| format!("{base}_{i}"))
            .find(|n| !taken.contains(n))
            .unwrap_or_else(|| base.to_owned())
    } else {
        base.to_owned()
    };
    taken.insert(name.clone());
    name
}

/// The path of a manifest line: relative to `folder`, or confined to it.
fn resolve(folder: &Path, path: &str, confine: bool) -> Result<PathBuf, String> {
    if path.is_empty() {
        return Err("the path is empty".to_owned());
    }
    if confine {
        return sdf_multioctree::io::resolve_in_folder(folder, path).map_err(|e| error_line(&e));
    }
    Ok(folder.join(path))
}

/// A data line of a manifest before its path is resolved.
struct Raw {
    /// 1-based line number.
    line: usize,
    /// The CSV id (None in a plain list).
    id: Option<String>,
    /// The path as written.
    path: String,
    /// Why the line names no model, when it cannot.
    problem: Option<String>,
}

/// The data lines of a CSV manifest, header and comments skipped.
fn csv_lines(text: &str) -> Result<Vec<Raw>, csv::Error> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut out = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let record = record?;
        let line = record.position().map_or(i + 1, |p| p.line() as usize);
        if record.iter().all(str::is_empty) {
            continue;
        }
        let (id, path) = match (record.get(0), record.get(1), record.len()) {
            (Some(id), Some(path), 2) => (id.to_owned(), path.to_owned()),
            _ => {
                // A line of another shape is kept, as a failure of its own.
                let fields = record.len();
                let text: String = record.iter().collect::<Vec<_>>().join(",");
                out.push(Raw {
                    line,
                    id: Some(format!(
                        "line {line}: {}",
                        text.chars().take(60).collect::<String>()
                    )),
                    path: String::new(),
                    problem: Some(format!("expected two fields id,path, found {fields}")),
                });
                continue;
            }
        };
        if out.is_empty() && id.eq_ignore_ascii_case("id") && path.eq_ignore_ascii_case("path") {
            continue;
        }
        out.push(Raw {
            line,
            id: Some(id),
            path,
            problem: None,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// The manifest `text`, written as `name` in a fresh folder and read back (not confined).
    fn read_written(name: &str, text: &str) -> (tempfile::TempDir, Manifest) {
        let dir = tempfile::tempdir().unwrap();
        let man = Manifest::read(&write(dir.path(), name, text), false).unwrap();
        (dir, man)
    }

    #[test]
    fn plain_lists_skip_blank_and_comment_lines_and_resolve_against_the_folder() {
        let (dir, man) = read_written(
            "m.txt",
            "# models\n\na/part.obj\n  b/part.obj  \n\n/abs/x.stl\nc/part.obj\n",
        );
        let e = &man.entries;
        assert_eq!(e.len(), 4);
        assert_eq!((e[0].line, e[0].index), (3, 0));
        assert_eq!(e[0].path, Ok(dir.path().join("a/part.obj")));
        assert_eq!(e[1].path, Ok(dir.path().join("b/part.obj")));
        assert_eq!(e[2].path, Ok(PathBuf::from("/abs/x.stl")));
        // Names are unique over the manifest, ids are the paths as written.
        let names: Vec<&str> = e.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names, ["part", "part_2", "x", "part_3"]);
    }

    #[test]
    fn a_duplicate_id_is_an_error_naming_it() {
        // Issue 32: the second line of an id was kept as a failure of that id, which the ledger
        // (one record per id) then dropped: the model vanished from the report.
        let dir = tempfile::tempdir().unwrap();
        for (name, text, line) in [
            ("m.txt", "a/part.obj\nb.obj\na/part.obj\n", 3),
            ("m.csv", "id,path\nx,a.obj\ny,b.obj\nx,c.obj\n", 4),
        ] {
            let e = Manifest::read(&write(dir.path(), name, text), false).unwrap_err();
            let e = error_line(&e);
            assert!(e.contains(&format!("line {line}: the id")), "{e}");
            assert!(e.contains("given twice"), "{e}");
        }
    }

    #[test]
    fn fingerprints_change_with_any_part_of_the_entry() {
        let f = entry_fingerprint(3, "id", "name", "a/b.obj");
        assert_eq!(f.len(), 16);
        assert_eq!(f, entry_fingerprint(3, "id", "name", "a/b.obj"));
        for g in [
            entry_fingerprint(4, "id", "name", "a/b.obj"),
            entry_fingerprint(3, "id2", "name", "a/b.obj"),
            entry_fingerprint(3, "id", "name_2", "a/b.obj"),
            entry_fingerprint(3, "id", "name", "a/c.obj"),
            // Length prefixes: moving a character between fields changes it.
            entry_fingerprint(3, "idn", "ame", "a/b.obj"),
        ] {
            assert_ne!(f, g);
        }
        assert_ne!(
            manifest_fingerprint(["a", "b"]),
            manifest_fingerprint(["b", "a"])
        );
    }

    #[test]
    fn csv_manifests_have_ids_a_header_and_quoted_paths() {
        let (dir, man) = read_written(
            "m.csv",
            "id,path\n\
             bracket,parts/b.obj\n\
             \"odd, id\",\"with, comma.stl\"\n\
             same,parts/b.obj\n\
             empty,\n\
             three,a,b\n",
        );
        let e = &man.entries;
        assert_eq!(e.len(), 5, "{e:?}");
        assert_eq!(
            (e[0].id.as_str(), e[0].name.as_str()),
            ("bracket", "bracket")
        );
        assert_eq!(e[1].path, Ok(dir.path().join("with, comma.stl")));
        assert_eq!(e[1].name, "odd__id");
        assert!(
            e[2].path.as_ref().unwrap_err().contains("listed twice"),
            "{e:?}"
        );
        assert_eq!(e[3].path, Err("the path is empty".into()));
        assert!(
            e[4].path.is_err() && e[4].id.starts_with("line 6"),
            "{:?}",
            e[4]
        );
    }

    #[test]
    fn confine_refuses_paths_that_leave_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("in")).unwrap();
        write(&dir.path().join("in"), "ok.obj", "");
        write(dir.path(), "secret.obj", "");
        let m = write(
            &dir.path().join("in"),
            "m.txt",
            "ok.obj\n../secret.obj\n/etc/passwd\n",
        );
        let man = Manifest::read(&m, true).unwrap();
        assert!(man.entries[0].path.is_ok());
        for e in &man.entries[1..] {
            assert!(
                e.path.as_ref().unwrap_err().contains("outside the folder"),
                "{e:?}"
            );
        }
        // Without --confine the same manifest resolves them.
        assert!(Manifest::read(&m, false).unwrap().entries[1].path.is_ok());
    }

    #[test]
    fn bad_manifests_are_one_clear_error() {
        let dir = tempfile::tempdir().unwrap();
        let empty = write(dir.path(), "e.txt", "\n# nothing\n\n");
        assert!(error_line(&Manifest::read(&empty, false).unwrap_err()).contains("lists no model"));
        let missing = dir.path().join("none.txt");
        assert!(Manifest::read(&missing, false).is_err());
        // A file over the limit is refused from its size, before reading (a sparse 1 GB file).
        let big = dir.path().join("big.txt");
        std::fs::File::create(&big)
            .unwrap()
            .set_len(1 << 30)
            .unwrap();
        let e = error_line(&Manifest::read(&big, false).unwrap_err());
        assert!(e.contains("more than the limit"), "{e}");
        let binary = write(dir.path(), "b.txt", "a.obj\n");
        std::fs::write(&binary, [b'a', 0xff, b'\n']).unwrap();
        assert!(Manifest::read(&binary, false).is_err());
        assert!(Manifest::read(Path::new("/dev/zero"), false).is_err());
    }

    #[test]
    fn shards_partition_the_entries_and_come_from_the_environment() {
        for n in 1..6 {
            for i in 0..23 {
                let owners = (0..n)
                    .filter(|&k| Shard { index: k, count: n }.owns(i))
                    .count();
                assert_eq!(owners, 1);
            }
        }
        assert_eq!(parse_shard("3/8").unwrap(), Shard { index: 3, count: 8 });
        assert_eq!(Shard { index: 1, count: 4 }.owned(9), 2);
        assert_eq!(Shard { index: 0, count: 4 }.owned(9), 3);
        assert_eq!(Shard { index: 5, count: 8 }.owned(3), 0);
        // Issue 32: a shard.json saying count 0 panicked the merge (index % 0, exit 70).
        for bad in [r#"{"index":0,"count":0}"#, r#"{"index":3,"count":2}"#] {
            let e = serde_json::from_str::<Shard>(bad).unwrap_err().to_string();
            assert!(e.contains("need 0 <= K < N"), "{e}");
        }
        for bad in ["8/8", "1/0", "x/2", "2", "-1/3"] {
            assert!(parse_shard(bad).is_err(), "{bad}");
        }
        fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
            move |k: &str| {
                vars.iter()
                    .find(|(n, _)| *n == k)
                    .map(|(_, v)| v.to_string())
            }
        }
        let slurm = [
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ];
        assert_eq!(
            Shard::resolve_from(None, env(&slurm)).unwrap(),
            Shard { index: 4, count: 8 }
        );
        let given = Shard { index: 0, count: 2 };
        assert_eq!(
            Shard::resolve_from(Some(given), env(&slurm)).unwrap(),
            given
        );
        let k8s = [("JOB_COMPLETION_INDEX", "2"), ("SDFMO_SHARD_COUNT", "3")];
        assert_eq!(
            Shard::resolve_from(None, env(&k8s)).unwrap(),
            Shard { index: 2, count: 3 }
        );
        assert!(Shard::resolve_from(None, env(&[("JOB_COMPLETION_INDEX", "2")])).is_err());
        let gap = [
            ("SLURM_ARRAY_TASK_ID", "9"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ];
        assert!(Shard::resolve_from(None, env(&gap)).is_err());
        assert_eq!(Shard::resolve_from(None, env(&[])).unwrap(), Shard::ALL);
    }
}
