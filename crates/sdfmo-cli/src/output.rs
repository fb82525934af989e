//! Writing results: stdout (human or JSON), atomic files, numbered file names.

use sdf_multioctree::io::Naming;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;

/// Prints one JSON object (one line) on stdout. Serialised first, so that a closed stdout is
/// a plain `io::Error` (broken pipe: success) rather than one wrapped in serde's error.
pub fn print_json(value: &serde_json::Value) -> anyhow::Result<()> {
    let mut line = serde_json::to_string(value).context("cannot serialise the JSON output")?;
    line.push('\n');
    print_text(&line)
}

/// Prints text on stdout (a human summary).
pub fn print_text(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .context("cannot write to stdout")
}

/// A finite number as JSON, or `null` for ±∞ and NaN (JSON has no infinities; PSNR of two
/// identical images is +∞ and is written as `null` next to an explicit flag).
pub fn json_f64(x: f64) -> serde_json::Value {
    serde_json::Number::from_f64(x).map_or(serde_json::Value::Null, serde_json::Value::Number)
}

/// An f32 as JSON with its shortest decimal (`0.1`, not the widened `0.10000000149011612`);
/// `null` when not finite.
pub fn json_f32(x: f32) -> serde_json::Value {
    json_f64(x.to_string().parse().unwrap_or(f64::NAN))
}

/// Writes `bytes` to `path` atomically with [`sdf_multioctree::io::write_atomic`] (fresh temporary file,
/// fsync, rename; directories, devices and FIFOs refused; a symbolic link's target replaced).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    Ok(sdf_multioctree::io::write_atomic(path, bytes)?)
}

/// Checks an output path before any work ([`sdf_multioctree::io::check_output`]): it must name a
/// file that may be replaced and, when `extensions` is not empty, end in one of them, so that
/// `-o image.jpg` does not silently get PNG bytes.
pub fn check_output(
    path: &Path,
    what: &str,
    extensions: &'static [&'static str],
) -> anyhow::Result<()> {
    check_output_as(path, what, extensions, Naming::Given)
}

/// [`check_output`] for an output named as `naming` says: a derived name (a numbered sibling)
/// may be a symbolic link, which the write replaces ([`Naming::Derived`]).
pub fn check_output_as(
    path: &Path,
    what: &str,
    extensions: &'static [&'static str],
    naming: Naming,
) -> anyhow::Result<()> {
    Ok(sdf_multioctree::io::check_output(
        path, what, extensions, naming,
    )?)
}

pub use sdfmo_harness::files::write_derived;

/// `out.png` → `out_3.png` (the index before the extension); without an extension `out_3`.
pub fn indexed_path(path: &Path, index: usize) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match path.extension() {
        Some(ext) => format!("{stem}_{index}.{}", ext.to_string_lossy()),
        None => format!("{stem}_{index}"),
    };
    path.with_file_name(name)
}

/// Creates the parent directory of an output file if it is missing.
pub fn ensure_parent(path: &Path) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create directory {}", dir.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indexed_path_inserts_before_the_extension() {
        assert_eq!(
            indexed_path(Path::new("dir/v.png"), 0),
            PathBuf::from("dir/v_0.png")
        );
        assert_eq!(
            indexed_path(Path::new("a.b.exr"), 3),
            PathBuf::from("a.b_3.exr")
        );
        assert_eq!(
            indexed_path(Path::new("noext"), 1),
            PathBuf::from("noext_1")
        );
    }

    #[test]
    fn infinite_numbers_become_null() {
        assert_eq!(json_f64(f64::INFINITY), serde_json::Value::Null);
        assert_eq!(json_f64(1.5), serde_json::json!(1.5));
        assert_eq!(json_f32(0.1).to_string(), "0.1");
        assert_eq!(json_f32(f32::NAN), serde_json::Value::Null);
    }

    #[test]
    fn outputs_are_checked_by_extension_and_kind() {
        assert!(check_output(Path::new("a/out.PNG"), "-o", &["png"]).is_ok());
        let e = check_output(Path::new("out.jpg"), "-o", &["png"]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "out.jpg: -o must end in .png (the format follows the extension)"
        );
        assert!(check_output(Path::new("noext"), "-o", &["smo"]).is_err());
        assert!(check_output(Path::new("adir/"), "-o", &["png"]).is_err());
        assert!(check_output(Path::new("/dev/null"), "-o", &[]).is_err());
    }
}
