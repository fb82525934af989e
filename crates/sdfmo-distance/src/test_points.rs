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

/// A proptest of an 8-wide AVX pass against the 4-wide code it pairs: `fn name(lo, hi, more
/// arguments in their strategies) { body }` runs `body` on 2,000 cases with `lo` and `hi` two
/// [`packet_triangles`], on x86-64 only, and passes at once on a CPU without AVX (the searches
/// never call the pass there).
macro_rules! avx_pair_proptest {
    (
        $(#[$doc:meta])*
        fn $name:ident($lo:ident, $hi:ident, $($arg:ident in $strategy:expr),+ $(,)?) $body:block
    ) => {
        proptest! {
            #![proptest_config(ProptestConfig::with_cases(2000))]
            $(#[$doc])*
            #[cfg(target_arch = "x86_64")]
            #[test]
            fn $name(
                $lo in $crate::test_points::packet_triangles(),
                $hi in $crate::test_points::packet_triangles(),
                $($arg in $strategy),+
            ) {
                if !std::is_x86_feature_detected!("avx") {
                    return Ok(());
                }
                $body
            }
        }
    };
}
pub(crate) use avx_pair_proptest;

/// Checks that an 8-wide pass's `lanes` are, to the bit, the 4-wide code's lanes of the low
/// packet then those of the high one (NaN wherever the 4-wide lane is NaN, whatever its bits:
/// the solid angle of a degenerate triangle).
pub(crate) fn lanes_match_4_wide(
    lanes: &[f32; 8],
    lo: [f32; 4],
    hi: [f32; 4],
) -> Result<(), TestCaseError> {
    for (lane, (x, y)) in lanes.iter().zip(lo.iter().chain(&hi)).enumerate() {
        prop_assert!(
            x.to_bits() == y.to_bits() || x.is_nan() && y.is_nan(),
            "lane {}: {} vs {}",
            lane,
            x,
            y
        );
    }
    Ok(())
}
