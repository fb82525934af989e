//! sdfmo-trace (placeholder)
