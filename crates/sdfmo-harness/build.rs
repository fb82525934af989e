//! Records the git commit the harness is built from (the sweep's provenance) when the sources
//! are a git checkout.

use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    let dir = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let git = |args: &[&str]| -> Option<String> {
        let out = Command::new("git")
            .args(args)
            .current_dir(&dir)
            .output()
            .ok()?;
        let text = String::from_utf8(out.stdout).ok()?;
        (out.status.success() && !text.trim().is_empty()).then(|| text.trim().to_owned())
    };
    let Some(commit) = git(&["rev-parse", "HEAD"]) else {
        return;
    };
    println!("cargo::rustc-env=SDFMO_GIT_COMMIT={commit}");
    // Rerun when HEAD moves: HEAD itself (a branch switch), the branch's ref file, packed refs.
    // Only existing files: a missing one would rerun this script, and rebuild, every time.
    let mut watch = vec![git(&["rev-parse", "--git-path", "HEAD"])];
    if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
        watch.push(git(&["rev-parse", "--git-path", &branch]));
    }
    watch.push(git(&["rev-parse", "--git-path", "packed-refs"]));
    for path in watch.into_iter().flatten() {
        let path = dir.join(Path::new(&path));
        if path.is_file() {
            println!("cargo::rerun-if-changed={}", path.display());
        }
    }
}
