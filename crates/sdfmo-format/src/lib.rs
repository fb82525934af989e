//! sdfmo-format (placeholder)
