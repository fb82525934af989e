//! Shared helpers for the benchmarks (data directory lookup).
