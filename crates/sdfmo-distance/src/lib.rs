//! sdfmo-distance (placeholder)
