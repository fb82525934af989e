//! `--extra-rows FILE`: rows of the results.json row schema from another producer (a peer such
//! as NGLOD, another sweep), read and checked before the sweep starts, then merged into the
//! report's tables, plots and page. The schema is documented in docs/cli.md ("The row schema").

use std::path::{Path, PathBuf};

use sdf_multioctree::io::{read_regular_to_string, IoError};

use super::model::{ExtraRows, Row};

/// Largest extra-rows file read: 64 MiB is about 200 000 rows with their per-view values, far
/// beyond any table a page can show, and small enough to hold in memory twice while parsing.
pub const MAX_EXTRA_ROWS_FILE: u64 = 64 << 20;

/// Deepest depth a row may state: the sweep's own limit (`--depths` within 1..=16).
pub const MAX_DEPTH: u8 = 16;

/// Why a file of extra rows was refused.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExtraRowsError {
    /// The file could not be read (missing, not a regular file, too large, not UTF-8).
    #[error(transparent)]
    Read(IoError),
    /// The file is not JSON, or a row does not fit the schema (a missing or mistyped field, an
    /// unknown field).
    #[error("{}: not a results.json or an array of rows: {source}", path.display())]
    Schema {
        /// The file.
        path: PathBuf,
        /// The parser's error, with its line and column.
        #[source]
        source: serde_json::Error,
    },
    /// A row parses but its values cannot be right.
    #[error("{}: row {index} ({model} {method} depth {depth}): {reason}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The row's index in the file's rows, from 0.
        index: usize,
        /// Its model.
        model: String,
        /// Its method.
        method: String,
        /// Its depth.
        depth: u8,
        /// What is wrong.
        reason: String,
    },
    /// Two rows, in the files or in the sweep, are of the same model, method and depth.
    #[error(
        "{}: row {index} repeats {model} {method} depth {depth}, which {other} already has",
        path.display()
    )]
    Duplicate {
        /// The file.
        path: PathBuf,
        /// The repeated row's index in the file, from 0.
        index: usize,
        /// Its model.
        model: String,
        /// Its method.
        method: String,
        /// Its depth.
        depth: u8,
        /// Where the first one is: an earlier row or file, or the sweep itself.
        other: String,
    },
}

/// Rows read from the files, and the record of where each file's rows came from.
#[derive(Debug, Default)]
pub struct Extra {
    /// Every row, in file order.
    pub rows: Vec<Row>,
    /// One record per file.
    pub files: Vec<ExtraRows>,
}

/// Reads and checks every file. `swept` names the (model, method, depths) the sweep will
/// produce itself, so a row that would repeat one is refused now, not after hours of work.
///
/// # Errors
/// [`ExtraRowsError`] for the first bad file or row.
pub fn load(
    files: &[PathBuf],
    swept: &[(String, String, Vec<u8>)],
) -> Result<Extra, ExtraRowsError> {
    let mut extra = Extra::default();
    for path in files {
        let text =
            read_regular_to_string(path, MAX_EXTRA_ROWS_FILE).map_err(ExtraRowsError::Read)?;
        let rows = parse(path, &text)?;
        let mut methods: Vec<String> = Vec::new();
        for (index, row) in rows.iter().enumerate() {
            check(path, index, row)?;
            let duplicate = |other: String| ExtraRowsError::Duplicate {
                path: path.clone(),
                index,
                model: row.model.clone(),
                method: row.method.clone(),
                depth: row.depth,
                other,
            };
            if swept.iter().any(|(model, method, depths)| {
                *model == row.model && *method == row.method && depths.contains(&row.depth)
            }) {
                return Err(duplicate("this sweep".into()));
            }
            let same =
                |r: &Row| r.model == row.model && r.method == row.method && r.depth == row.depth;
            if let Some(i) = rows[..index].iter().position(same) {
                return Err(duplicate(format!("row {i} of the same file")));
            }
            if extra.rows.iter().any(same) {
                return Err(duplicate("an earlier file".into()));
            }
            if !methods.contains(&row.method) {
                methods.push(row.method.clone());
            }
        }
        extra.files.push(ExtraRows {
            file: path.display().to_string(),
            rows: rows.len(),
            methods,
        });
        extra.rows.extend(rows);
    }
    Ok(extra)
}

fn parse(path: &Path, text: &str) -> Result<Vec<Row>, ExtraRowsError> {
    let schema = |source| ExtraRowsError::Schema {
        path: path.to_path_buf(),
        source,
    };
    // Two forms: a whole results.json (its `rows`; the other keys belong to whoever wrote it
    // and are ignored here), or a bare array of rows. Parsed as a value first and then as the
    // one form it is, so an error names the field a row got wrong (serde's `untagged` would
    // say only "did not match any variant").
    let value: serde_json::Value = serde_json::from_str(text).map_err(schema)?;
    let rows = match value {
        serde_json::Value::Object(mut map) if map.contains_key("rows") => {
            serde_json::from_value::<Vec<Row>>(map.remove("rows").unwrap_or_default())
        }
        other => serde_json::from_value::<Vec<Row>>(other),
    };
    rows.map_err(schema)
}

/// The checks serde's types cannot make, on a row read from a file: names safe in file names and
/// tables, a depth the tables can hold, finite and meaningful numbers.
fn check(path: &Path, index: usize, row: &Row) -> Result<(), ExtraRowsError> {
    match row_problem(row) {
        None => Ok(()),
        Some(reason) => Err(ExtraRowsError::Invalid {
            path: path.to_path_buf(),
            index,
            model: row.model.clone(),
            method: row.method.clone(),
            depth: row.depth,
            reason,
        }),
    }
}

/// Highest PSNR a row may state (dB). The sweep's images are 8-bit RGB of at most 8192² pixels
/// (`--size`), so the smallest non-zero mean squared error is one level in one channel of one
/// pixel, 1 / (3 · 8192²), and the highest finite PSNR 10 · log10(255² · 3 · 8192²) ≈ 131.2
/// dB; identical images are `null`. 200 dB leaves room for a producer with larger images.
pub const MAX_PSNR_DB: f64 = 200.0;

/// What is wrong with a row from outside this process (a file of extra rows, a shard's
/// ledger), or `None`: the one set of checks every reader of rows applies. Names must be what
/// the sweep's own writer makes ([`super::super::is_safe_name`]); the depth within
/// 1..=[`MAX_DEPTH`]; PSNR finite, ≥ 0 and at most [`MAX_PSNR_DB`]; FLIP within 0..=1; times
/// finite and ≥ 0; bytes positive.
pub fn row_problem(row: &Row) -> Option<String> {
    check_row(row).err()
}

fn check_row(row: &Row) -> Result<(), String> {
    if !super::super::is_safe_name(&row.model) {
        return Err(format!(
            "model name {:?} must be letters, digits, '-', '_' or '.' (not first)",
            row.model
        ));
    }
    if !super::super::is_safe_name(&row.method) {
        return Err(format!(
            "method name {:?} must be letters, digits, '-', '_' or '.' (not first)",
            row.method
        ));
    }
    if !(1..=MAX_DEPTH).contains(&row.depth) {
        return Err(format!("depth must be within 1..={MAX_DEPTH}"));
    }
    // 1e300 in full is 301 digits: large values in exponent form.
    let num = |v: f64| {
        if v.abs() < 1e9 {
            v.to_string()
        } else {
            format!("{v:e}")
        }
    };
    let finite_nonneg = |name: &str, v: f64| {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(format!("{name} {} must be finite and ≥ 0", num(v)))
        }
    };
    let psnr = |name: &str, v: f64| {
        finite_nonneg(name, v)?;
        if v > MAX_PSNR_DB {
            return Err(format!(
                "{name} {} dB is above {MAX_PSNR_DB} dB, more than 8-bit images can give",
                num(v)
            ));
        }
        Ok(())
    };
    if let Some(p) = row.psnr {
        psnr("psnr", p)?;
    }
    if !(0.0..=1.0).contains(&row.flip) {
        return Err(format!("flip {} must be within 0..=1", row.flip));
    }
    if row.bytes == 0 {
        return Err("bytes must be positive".into());
    }
    finite_nonneg("render_ms", row.render_ms)?;
    if let Some(ms) = row.build_ms {
        finite_nonneg("build_ms", ms)?;
    }
    for p in row.psnr_views.iter().flatten() {
        psnr("a view's psnr", *p)?;
    }
    if let Some(f) = row.flip_views.iter().find(|f| !(0.0..=1.0).contains(*f)) {
        return Err(format!("a view's flip {f} must be within 0..=1"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    const NGLOD: &str = r#"[{"model": "abc1", "method": "nglod", "depth": 7, "lod": 2,
        "psnr": 27.28, "flip": 0.08, "bytes": 140000, "render_ms": 719.0}]"#;

    #[test]
    fn both_forms_load_and_record_their_file() {
        let dir = tempfile::tempdir().unwrap();
        let bare = write(dir.path(), "bare.json", NGLOD);
        let results = write(
            dir.path(),
            "results.json",
            &format!(
                r#"{{"settings": {{}}, "rows": {}}}"#,
                NGLOD.replace("abc1", "abc3")
            ),
        );
        let extra = load(&[bare.clone(), results], &[]).unwrap();
        assert_eq!(extra.rows.len(), 2);
        assert_eq!(extra.rows[0].lod, Some(2));
        assert_eq!(extra.rows[0].build_ms, None);
        assert_eq!(extra.rows[1].model, "abc3");
        assert_eq!(extra.files[0].methods, vec!["nglod".to_owned()]);
        assert_eq!(extra.files[0].file, bare.display().to_string());
    }

    #[test]
    fn bad_files_are_typed_errors_naming_the_cause() {
        let dir = tempfile::tempdir().unwrap();
        let err = |text: &str| {
            let p = write(dir.path(), "x.json", text);
            load(&[p], &[]).unwrap_err()
        };
        let missing = load(&[dir.path().join("none.json")], &[]).unwrap_err();
        assert!(matches!(missing, ExtraRowsError::Read(_)), "{missing}");
        assert!(matches!(err("{"), ExtraRowsError::Schema { .. }));
        // A missing required field, an unknown one (a typo), a wrong type.
        let e = err(
            r#"[{"model": "a", "method": "m", "depth": 7, "psnr": null, "flip": 0.1,
            "bytes": 1}]"#,
        );
        assert!(e.to_string().contains("missing field `render_ms`"), "{e}");
        // `psnr` may be null (identical images) but not missing.
        let e = err(
            r#"[{"model": "a", "method": "m", "depth": 7, "flip": 0.1, "bytes": 1,
            "render_ms": 1.0}]"#,
        );
        assert!(e.to_string().contains("missing field `psnr`"), "{e}");
        let e = err(&NGLOD.replace("\"lod\"", "\"lods\""));
        assert!(e.to_string().contains("lods"), "{e}");
        let e = err(&NGLOD.replace("\"depth\": 7", "\"depth\": \"7\""));
        assert!(matches!(e, ExtraRowsError::Schema { .. }), "{e}");
        // Values the types allow but the tables cannot hold.
        for (from, to) in [
            ("\"depth\": 7", "\"depth\": 0"),
            ("\"flip\": 0.08", "\"flip\": 1.5"),
            ("\"bytes\": 140000", "\"bytes\": 0"),
            ("\"render_ms\": 719.0", "\"render_ms\": -1"),
            ("\"psnr\": 27.28", "\"psnr\": 1e300"),
            ("\"abc1\"", "\"../abc1\""),
            ("\"nglod\"", "\"ng lod\""),
        ] {
            let e = err(&NGLOD.replace(from, to));
            assert!(
                matches!(e, ExtraRowsError::Invalid { index: 0, .. }),
                "{to}: {e}"
            );
        }
        let twice = NGLOD.replace("}]", "}, ") + &NGLOD[1..];
        let e = err(&twice);
        assert!(
            matches!(e, ExtraRowsError::Duplicate { index: 1, .. }),
            "{e}"
        );
        let p = write(dir.path(), "y.json", NGLOD);
        let swept = [("abc1".to_owned(), "nglod".to_owned(), vec![6, 7])];
        let e = load(&[p], &swept).unwrap_err();
        assert!(e.to_string().contains("this sweep"), "{e}");
    }
}
