//! Helpers shared by the command line's integration tests: running the real `sdfmo` binary and
//! checking that it succeeded, or refused as the command line refuses (exit 2, one line).
// Each test file uses some of them.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::process::{Command, Output};

/// The binary under test.
pub const SDFMO: &str = env!("CARGO_BIN_EXE_sdfmo");

/// A fresh temporary folder named `sdfmo-{name}-…`, removed when dropped.
pub fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("sdfmo-{name}-"))
        .tempdir()
        .unwrap()
}

/// Runs `sdfmo` with `args` (`&str`, paths, or a mix through `&dyn AsRef<OsStr>`); stdin
/// closed, stdout and stderr captured.
pub fn sdfmo<S: AsRef<OsStr>>(args: &[S]) -> Output {
    Command::new(SDFMO)
        .args(args)
        .output()
        .expect("cannot run sdfmo")
}

/// The run's stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts that the run succeeded (its stderr in the message otherwise).
pub fn succeeded(o: &Output, what: &str) {
    assert!(o.status.success(), "{what}: {}", stderr(o));
}

/// Runs `sdfmo` with `args`, asserts that it succeeded and returns its stdout.
pub fn ok<S: AsRef<OsStr> + std::fmt::Debug>(args: &[S]) -> String {
    let o = sdfmo(args);
    succeeded(&o, &format!("{args:?}"));
    String::from_utf8(o.stdout).expect("stdout is UTF-8")
}

/// Asserts a refusal as the command line makes one: exit 2 and one line on stderr that
/// contains `needle`, without a panic or an internal error; `what` names the case.
pub fn refused(o: &Output, needle: &str, what: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{what}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{what}: {err}");
    assert!(err.contains(needle), "{what}: {needle:?} not in {err:?}");
    for sign in ["panicked", "RUST_BACKTRACE", "internal error"] {
        assert!(!err.contains(sign), "{what}: {err}");
    }
}
