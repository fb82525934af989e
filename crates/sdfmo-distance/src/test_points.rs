//! Proptest strategies for the SIMD lanes' tests: coordinates and points that make degenerate,
//! axis-aligned and tiny triangles, and queries on their corners.

use glam::Vec3;
use proptest::prelude::*;

/// A coordinate: mostly in [−2, 2], often exactly 0 or ½ (repeated values make degenerate and
/// axis-aligned triangles, and queries on corners), sometimes within 1e-3 of 0.
pub(crate) fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![-2.0f32..2.0, Just(0.0f32), Just(0.5f32), -1e-3f32..1e-3,]
}

/// A point of three [`coord`]s.
pub(crate) fn point() -> impl Strategy<Value = Vec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// One to four triangles of [`point`]s: a packet's worth.
pub(crate) fn packet_triangles() -> impl Strategy<Value = Vec<[Vec3; 3]>> {
    prop::collection::vec(
        (point(), point(), point()).prop_map(|(a, b, c)| [a, b, c]),
        1..=4,
    )
}
