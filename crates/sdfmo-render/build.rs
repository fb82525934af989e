//! Resolves the shared test data for this crate's data tests and marks them ignored when it is
//! absent (see `sdfmo-testdata`).

fn main() {
    sdfmo_testdata::build_script();
}
