//! Shared helpers for the benchmarks: where the test meshes are, and list-valued knobs.

use std::path::PathBuf;

/// The shared test-mesh directory: `SDFMO_TEST_DATA`, else `../shared/data` beside the workspace
/// (a relative value is taken against the workspace root; see `sdfmo-testdata`).
pub fn data_dir() -> PathBuf {
    sdfmo_testdata::test_data_dir(env!("CARGO_MANIFEST_DIR").as_ref())
}

/// A comma-separated environment variable as a list of trimmed, non-empty items (`default` when
/// the variable is unset).
pub fn env_list(name: &str, default: &str) -> Vec<String> {
    std::env::var(name)
        .unwrap_or_else(|_| default.to_string())
        .split(',')
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn env_list_splits_trims_and_drops_empties() {
        assert_eq!(
            env_list("SDFMO_BENCH_SURELY_UNSET_VARIABLE", " a, b ,,c "),
            vec!["a", "b", "c"]
        );
    }
}
