//! sdfmo-mesh (placeholder)
