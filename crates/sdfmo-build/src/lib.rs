//! sdfmo-build (placeholder)
