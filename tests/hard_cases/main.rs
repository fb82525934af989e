//! End-to-end hard-case tests of the whole pipeline (mesh → build → pack → trace → render →
//! metrics) through the facade's public API. Results: `docs/results/hard-cases.md`.

mod bad_input;
mod common;
mod degenerate;
mod gaps;
mod grazing;
mod open_nonmanifold;
mod rims;
mod scale;
mod thin;
