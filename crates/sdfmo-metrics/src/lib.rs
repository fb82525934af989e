//! sdfmo-metrics (placeholder)
