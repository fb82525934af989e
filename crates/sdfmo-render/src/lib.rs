//! sdfmo-render (placeholder)
