//! Shared helpers for the benchmarks: where the test meshes are, the knobs read from the
//! environment, the two methods compared and a build at a depth.

use std::path::PathBuf;
use std::str::FromStr;

use sdfmo_build::{build, BuildSettings, BuildStats, Method};
use sdfmo_format::PackedOctree;
use sdfmo_mesh::{load_mesh, TriMesh};

/// The two methods every benchmark compares, with their labels: the SVO baseline and the
/// multi-octree at the paper's voxel cap.
pub const METHODS: [(&str, Method); 2] = [
    ("svo", Method::Svo),
    ("multi", Method::Multi { max_voxels: 8 }),
];

/// The test mesh `NAME.stl` from [`data_dir`], or `None` (with a note on stderr) when it cannot
/// be loaded, so a run without the data skips it.
pub fn load_stl(name: &str) -> Option<TriMesh> {
    let path = data_dir().join(format!("{name}.stl"));
    match load_mesh(&path) {
        Ok(m) => Some(m.mesh),
        Err(e) => {
            eprintln!("note: skipping {name}: {e} (set SDFMO_TEST_DATA)");
            None
        }
    }
}

/// `name` parsed from the environment, `default` when unset or unparsable.
pub fn env_num<T: FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// The depths listed in `name` (comma-separated), `default` when unset.
pub fn env_depths(name: &str, default: &str) -> Vec<u8> {
    env_list(name, default)
        .iter()
        .filter_map(|d| d.parse().ok())
        .collect()
}

/// A pool of `threads` workers: the libraries run on the caller's pool, a benchmark installs
/// this one around what it measures.
pub fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a pool of benchmark threads")
}

/// Builds `mesh` at `depth` with `method` (defaults otherwise) on `pool`, panicking on error
/// (a benchmark's input).
pub fn build_at(
    mesh: &TriMesh,
    depth: u8,
    method: Method,
    pool: &rayon::ThreadPool,
) -> (PackedOctree, BuildStats) {
    pool.install(|| build(mesh, &BuildSettings::new(depth, method)))
        .expect("build")
}

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
