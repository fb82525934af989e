//! The builder's error type.

use thiserror::Error;

/// What can go wrong in [`crate::build`].
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum BuildError {
    /// All triangles have zero area, or the mesh has no extent to normalise.
    #[error("degenerate mesh: {0}")]
    DegenerateMesh(String),
    /// The depth is outside the supported range.
    #[error("depth {depth} is out of range (1..={max})")]
    InvalidDepth {
        /// The requested depth.
        depth: u8,
        /// The deepest supported.
        max: u8,
    },
    /// The predicted peak memory of the build exceeds the budget
    /// ([`estimate_memory`](crate::estimate_memory)).
    #[error(
        "depth {depth} would need about {} of memory, more than the budget of {}",
        human_bytes(*estimate),
        human_bytes(*budget)
    )]
    MemoryBudget {
        /// The requested depth.
        depth: u8,
        /// Predicted peak bytes.
        estimate: u64,
        /// The budget in bytes.
        budget: u64,
    },
    /// The levels of detail asked for cannot be built ([`BuildRequest::levels`](crate::BuildRequest::levels)).
    #[error("levels {coarsest}..={depth}: {why}")]
    InvalidLevels {
        /// The coarsest level asked for.
        coarsest: u8,
        /// The leaf depth.
        depth: u8,
        /// What is wrong.
        why: &'static str,
    },
    /// `Method::Multi { max_voxels: 0 }`.
    #[error("max_voxels must be at least 1 (got {0})")]
    InvalidMaxVoxels(u8),
    /// The normalisation margin is not in [0, 0.5).
    #[error("margin {0} is out of range [0, 0.5)")]
    InvalidMargin(f32),
    /// The distance structure refused the mesh.
    #[error("building the distance structure")]
    Distance(#[from] sdfmo_distance::DistanceError),
    /// The caller's cancel function returned true ([`BuildRequest::cancel`](crate::BuildRequest::cancel)).
    #[error("the build was cancelled")]
    Cancelled,
    /// Packing the octree failed.
    #[error("packing the octree")]
    Format(#[from] sdfmo_format::FormatError),
}

/// `Result` with a [`BuildError`].
pub type Result<T> = std::result::Result<T, BuildError>;

/// `1536 MiB` → "1.5 GiB": bytes for people.
pub(crate) fn human_bytes(b: u64) -> String {
    const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut v = b as f64;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{b} bytes")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}
