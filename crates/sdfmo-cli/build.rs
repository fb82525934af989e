//! Resolves the shared test data for this crate's data tests and marks them ignored when it is
//! absent (see `sdfmo-testdata`). (The git commit of the sweep's provenance is recorded by
//! sdfmo-harness's build script.)

fn main() {
    sdfmo_testdata::build_script();
}
