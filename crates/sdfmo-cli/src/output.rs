//! Writing results: stdout (human or JSON), atomic files, numbered file names.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;

/// Prints one JSON object (one line) on stdout.
pub fn print_json(value: &serde_json::Value) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer(&mut out, value).context("cannot write to stdout")?;
    writeln!(out).context("cannot write to stdout")?;
    out.flush().context("cannot write to stdout")
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

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, flushed, then
/// renamed over the target, so a reader never sees half a file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .with_context(|| format!("{}: not a file path", path.display()))?;
    let tmp = dir.join(format!(
        ".{}.tmp-{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(e).with_context(|| format!("cannot write {}", path.display()));
    }
    Ok(())
}

/// Encodes an RGB image as PNG and writes it atomically.
pub fn write_png(path: &Path, img: &image::RgbImage) -> anyhow::Result<()> {
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png)
        .with_context(|| format!("cannot encode {}", path.display()))?;
    write_atomic(path, &buf.into_inner())
}

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
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("sdfmo-cli-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("x.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        assert!(write_atomic(&dir.join("missing/x.txt"), b"x").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
