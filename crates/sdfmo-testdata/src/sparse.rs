//! Huge sparse files and the process's peak memory: what the tests of the loaders use to show
//! that a file whose header declares another size than it has is refused after reading its
//! header (issue 32), in one place for the mesh and `.smo` loaders.

use std::path::{Path, PathBuf};

/// Length of the files [`sparse_file`] makes: 3 GiB.
pub const SPARSE_LEN: u64 = 3 << 30;

/// `bytes` written to `name` in `dir`, the file then extended to [`SPARSE_LEN`] without
/// writing (a sparse file: the tail reads as zeros and takes no disk). Panics on an I/O error
/// (a test helper).
pub fn sparse_file(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).expect("write the head of the sparse file");
    std::fs::OpenOptions::new()
        .write(true)
        .open(&path)
        .and_then(|f| f.set_len(SPARSE_LEN))
        .expect("extend the sparse file");
    path
}

/// Peak resident memory of this process in bytes since the last [`reset_peak_rss`] (Linux:
/// `VmHWM` of `/proc/self/status`), or `None` elsewhere.
pub fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Resets the peak that [`peak_rss`] reports to the current resident memory (Linux >= 4.0;
/// elsewhere nothing happens).
pub fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}
