//! Where the tests of sdf-multioctree find their shared data, resolved once, in one place.
//!
//! The workspace's tests read two directories from the project's shared folder, checked out
//! beside the repository:
//!
//! | variable | default | holds |
//! |---|---|---|
//! | [`DATA_VAR`] (`SDFMO_TEST_DATA`) | `../shared/data` | the test meshes (STL, OBJ, GLB) |
//! | [`GOLDEN_VAR`] (`SDFMO_GOLDEN`) | `../shared/golden/flip` | NVIDIA's FLIP outputs (`golden.json`) |
//!
//! A relative value, and the default, is resolved against the **workspace root**: the nearest
//! directory at or above the crate's manifest directory whose `Cargo.toml` has a `[workspace]`
//! table ([`workspace_root`]); outside a workspace (a crate unpacked from a registry), against
//! the crate's own directory. So `SDFMO_TEST_DATA=../shared/data cargo test -p sdfmo-mesh` means
//! the same directory in every crate.
//!
//! # Reporting absent data as skipped
//!
//! libtest cannot ignore a test at run time, so the decision is made when the tests are
//! compiled: a crate with data tests calls [`build_script`] from its `build.rs`, which
//!
//! - passes the resolved directories to the crate as `SDFMO_TEST_DATA_DIR` and
//!   `SDFMO_GOLDEN_DIR` (read them with `env!`);
//! - sets `cfg(sdfmo_no_test_data)` when the mesh directory does not exist and
//!   `cfg(sdfmo_no_golden_data)` when the golden directory has no `golden.json`, unless
//!   [`REQUIRE_VAR`] (`SDFMO_REQUIRE_TEST_DATA`) is `1`: then the tests run and fail;
//! - reruns when any of the three variables changes.
//!
//! Each data test then carries
//! `#[cfg_attr(sdfmo_no_test_data, ignore = "no test data: set SDFMO_TEST_DATA")]` and is listed
//! as `ignored` (with the reason) instead of passing without checking anything. The build
//! script does not watch the directories themselves (a missing path would make cargo rerun it,
//! and rebuild the crate, on every build): after creating the shared folder, set or change
//! `SDFMO_TEST_DATA` once, or `cargo clean -p CRATE`.
#![deny(missing_docs)]

pub mod sparse;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// The variable naming the test-mesh directory.
pub const DATA_VAR: &str = "SDFMO_TEST_DATA";
/// The variable naming the golden FLIP directory.
pub const GOLDEN_VAR: &str = "SDFMO_GOLDEN";
/// `SDFMO_REQUIRE_TEST_DATA=1` turns absent data into failing tests (CI sets it).
pub const REQUIRE_VAR: &str = "SDFMO_REQUIRE_TEST_DATA";
/// Default of [`DATA_VAR`], relative to the workspace root.
pub const DEFAULT_DATA: &str = "../shared/data";
/// Default of [`GOLDEN_VAR`], relative to the workspace root.
pub const DEFAULT_GOLDEN: &str = "../shared/golden/flip";
/// The cfg [`build_script`] sets when the test meshes are absent (and not required).
pub const NO_DATA_CFG: &str = "sdfmo_no_test_data";
/// The cfg [`build_script`] sets when the golden FLIP data is absent (and not required).
pub const NO_GOLDEN_CFG: &str = "sdfmo_no_golden_data";

/// The nearest directory at or above `start` whose `Cargo.toml` declares a `[workspace]`.
pub fn workspace_root(start: &Path) -> Option<PathBuf> {
    start.ancestors().find_map(|dir| {
        let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).ok()?;
        manifest
            .lines()
            .any(|line| line.trim() == "[workspace]")
            .then(|| dir.to_path_buf())
    })
}

/// The directory `value` names (or `default` when it is `None` or empty), a relative path taken
/// against the workspace root above `manifest_dir` (or `manifest_dir` itself outside a
/// workspace). Pure: reads no environment variable.
pub fn resolve(value: Option<&OsStr>, default: &str, manifest_dir: &Path) -> PathBuf {
    let named = match value {
        Some(v) if !v.is_empty() => PathBuf::from(v),
        _ => PathBuf::from(default),
    };
    if named.is_absolute() {
        return named;
    }
    let base = workspace_root(manifest_dir).unwrap_or_else(|| manifest_dir.to_path_buf());
    base.join(named)
}

/// The test-mesh directory for the crate at `manifest_dir` (pass `env!("CARGO_MANIFEST_DIR")`):
/// [`DATA_VAR`] or [`DEFAULT_DATA`], resolved by [`resolve`]. Not checked for existence.
pub fn test_data_dir(manifest_dir: &Path) -> PathBuf {
    resolve(
        std::env::var_os(DATA_VAR).as_deref(),
        DEFAULT_DATA,
        manifest_dir,
    )
}

/// The golden FLIP directory for the crate at `manifest_dir`: [`GOLDEN_VAR`] or
/// [`DEFAULT_GOLDEN`], resolved by [`resolve`]. Not checked for existence.
pub fn golden_dir(manifest_dir: &Path) -> PathBuf {
    resolve(
        std::env::var_os(GOLDEN_VAR).as_deref(),
        DEFAULT_GOLDEN,
        manifest_dir,
    )
}

/// Whether absent data must fail the tests (`SDFMO_REQUIRE_TEST_DATA=1`).
pub fn required() -> bool {
    std::env::var_os(REQUIRE_VAR).is_some_and(|v| v == "1")
}

/// Whether `dir` holds the golden FLIP data (its `golden.json`).
pub fn has_golden(dir: &Path) -> bool {
    dir.join("golden.json").is_file()
}

/// What [`build_script`] tells cargo, as lines (`cargo::…`), given the resolved mesh and golden
/// directories `data` and `golden` and whether the data is [`required`].
pub fn build_script_lines(data: &Path, golden: &Path, required: bool) -> Vec<String> {
    let mut lines = vec![
        format!("cargo::rerun-if-env-changed={DATA_VAR}"),
        format!("cargo::rerun-if-env-changed={GOLDEN_VAR}"),
        format!("cargo::rerun-if-env-changed={REQUIRE_VAR}"),
        format!("cargo::rustc-check-cfg=cfg({NO_DATA_CFG})"),
        format!("cargo::rustc-check-cfg=cfg({NO_GOLDEN_CFG})"),
        format!("cargo::rustc-env=SDFMO_TEST_DATA_DIR={}", data.display()),
        format!("cargo::rustc-env=SDFMO_GOLDEN_DIR={}", golden.display()),
    ];
    if !required && !data.is_dir() {
        lines.push(format!("cargo::rustc-cfg={NO_DATA_CFG}"));
    }
    if !required && !has_golden(golden) {
        lines.push(format!("cargo::rustc-cfg={NO_GOLDEN_CFG}"));
    }
    lines
}

/// The body of a `build.rs` for a crate with data tests: prints [`build_script_lines`] for the
/// crate being built (`CARGO_MANIFEST_DIR` of the build script) and the current environment.
pub fn build_script() {
    let manifest_dir = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let lines = build_script_lines(
        &test_data_dir(&manifest_dir),
        &golden_dir(&manifest_dir),
        required(),
    );
    for line in lines {
        println!("{line}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory tree `ws/{Cargo.toml with [workspace], crates/a/Cargo.toml}`.
    fn tree(name: &str) -> PathBuf {
        let root =
            std::env::temp_dir().join(format!("sdfmo-testdata-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let krate = root.join("ws/crates/a");
        std::fs::create_dir_all(&krate).unwrap();
        std::fs::write(
            root.join("ws/Cargo.toml"),
            "[package]\nname = \"x\"\n\n[workspace]\n",
        )
        .unwrap();
        std::fs::write(krate.join("Cargo.toml"), "[package]\nname = \"a\"\n").unwrap();
        root
    }

    #[test]
    fn workspace_root_is_the_manifest_with_a_workspace_table() {
        let root = tree("root");
        let krate = root.join("ws/crates/a");
        assert_eq!(workspace_root(&krate), Some(root.join("ws")));
        assert_eq!(workspace_root(&root.join("ws")), Some(root.join("ws")));
        // `[workspace.package]` alone does not make a workspace root.
        std::fs::write(
            root.join("ws/Cargo.toml"),
            "[workspace.package]\nversion = \"1\"\n",
        )
        .unwrap();
        assert_ne!(workspace_root(&krate), Some(root.join("ws")));
        std::fs::remove_dir_all(&root).unwrap();
    }

    /// The old behaviour: `SDFMO_TEST_DATA=../shared/data` was taken relative to each crate's
    /// directory (`crates/a/../shared/data`), which does not exist, and the tests skipped.
    #[test]
    fn relative_value_is_taken_against_the_workspace_root_not_the_crate() {
        let root = tree("relative");
        let krate = root.join("ws/crates/a");
        let got = resolve(Some(OsStr::new("../shared/data")), DEFAULT_DATA, &krate);
        assert_eq!(got, root.join("ws/../shared/data"));
        assert_eq!(
            resolve(None, DEFAULT_DATA, &krate),
            root.join("ws/../shared/data")
        );
        assert_eq!(
            resolve(Some(OsStr::new("")), DEFAULT_GOLDEN, &krate),
            root.join("ws/../shared/golden/flip")
        );
        let abs = root.join("elsewhere");
        assert_eq!(resolve(Some(abs.as_os_str()), DEFAULT_DATA, &krate), abs);
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn outside_a_workspace_the_crate_directory_is_the_base() {
        let root = tree("outside");
        std::fs::write(root.join("ws/Cargo.toml"), "[package]\nname = \"x\"\n").unwrap();
        let krate = root.join("ws/crates/a");
        assert_eq!(workspace_root(&krate), None);
        assert_eq!(
            resolve(None, DEFAULT_DATA, &krate),
            krate.join(DEFAULT_DATA)
        );
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn absent_data_sets_the_ignore_cfgs_unless_required() {
        let root = tree("cfg");
        let data = root.join("data");
        let golden = root.join("golden");
        let cfg = |lines: &[String], c: &str| lines.contains(&format!("cargo::rustc-cfg={c}"));

        let lines = build_script_lines(&data, &golden, false);
        assert!(cfg(&lines, NO_DATA_CFG) && cfg(&lines, NO_GOLDEN_CFG));
        assert!(lines.contains(&format!(
            "cargo::rustc-env=SDFMO_TEST_DATA_DIR={}",
            data.display()
        )));

        let lines = build_script_lines(&data, &golden, true);
        assert!(!cfg(&lines, NO_DATA_CFG) && !cfg(&lines, NO_GOLDEN_CFG));

        std::fs::create_dir_all(&data).unwrap();
        std::fs::create_dir_all(&golden).unwrap();
        let lines = build_script_lines(&data, &golden, false);
        assert!(!cfg(&lines, NO_DATA_CFG));
        assert!(
            cfg(&lines, NO_GOLDEN_CFG),
            "a golden directory without golden.json is absent"
        );
        std::fs::write(golden.join("golden.json"), "{}").unwrap();
        assert!(!cfg(
            &build_script_lines(&data, &golden, false),
            NO_GOLDEN_CFG
        ));
        std::fs::remove_dir_all(&root).unwrap();
    }
}
