//! Symmetric quantisation of corner distances.
//!
//! A corner value `v` (normalised units) is stored as the integer
//! `q = round(clamp(v / dmax, −1, 1) · Q)` with `Q = 127` at 8 bits and `Q = 32767` at 16 bits,
//! rounding half away from zero, and read back as `q · dmax / Q`. `dmax` is the diagonal of a
//! leaf cell, `√3 · 2 / 2^depth`: a distance sample can differ from its neighbour corner's by at
//! most that much, so the range loses nothing that matters for the zero crossing.
//!
//! The code range is symmetric (`−Q..=Q`; −128 and −32768 are never written and are rejected on
//! load), so `0` is exact and negating a voxel (a surface voxel's `F` and `−F`) is exact.
//! The error for `|v| ≤ dmax` is at most `dmax / Q / 2` (plus f32 rounding of the product).

use crate::ValueBits;

/// Diagonal of a leaf cell at `depth` in the root cube `[-1, 1]³`: `√3 · 2 / 2^depth`.
#[inline]
pub fn voxel_diagonal(depth: u8) -> f32 {
    (3.0f64.sqrt() * f64::from(crate::cell_size(depth))) as f32
}

/// The largest code magnitude `Q` for these bits (127 or 32767).
#[inline]
pub const fn max_code(bits: ValueBits) -> i32 {
    match bits {
        ValueBits::Eight => i8::MAX as i32,
        ValueBits::Sixteen => i16::MAX as i32,
    }
}

/// The factor that turns a code into a distance: `dmax / Q`.
#[inline]
pub fn dequant_scale(depth: u8, bits: ValueBits) -> f32 {
    (voxel_diagonal(depth) as f64 / max_code(bits) as f64) as f32
}

/// Quantises `value` (finite) to a code in `−Q..=Q`: clamp to `±dmax`, round to nearest.
#[inline]
pub fn quantize(value: f32, dmax: f32, bits: ValueBits) -> i32 {
    let q = max_code(bits) as f64;
    let x = (value as f64 / dmax as f64).clamp(-1.0, 1.0) * q;
    // f64::round rounds half away from zero: symmetric, so quantize(−v) == −quantize(v).
    x.round() as i32
}

/// Reads a code back as a distance: `code · dmax / Q` (given the precomputed [`dequant_scale`]).
#[inline]
pub fn dequantize(code: i32, scale: f32) -> f32 {
    code as f32 * scale
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn bound(depth: u8, bits: ValueBits) -> f32 {
        let dmax = voxel_diagonal(depth);
        // Half a step, plus a few f32 ulps of dmax for the product's rounding.
        dmax / max_code(bits) as f32 / 2.0 + dmax * 4.0 * f32::EPSILON
    }

    #[test]
    fn diagonal_matches_definition() {
        assert!((voxel_diagonal(0) - 2.0 * 3f32.sqrt()).abs() < 1e-6);
        assert!((voxel_diagonal(9) - 3f32.sqrt() * 2.0 / 512.0).abs() < 1e-9);
    }

    #[test]
    fn zero_and_extremes_are_exact() {
        for bits in [ValueBits::Eight, ValueBits::Sixteen] {
            let dmax = voxel_diagonal(5);
            assert_eq!(quantize(0.0, dmax, bits), 0);
            assert_eq!(quantize(-0.0, dmax, bits), 0);
            assert_eq!(quantize(dmax, dmax, bits), max_code(bits));
            assert_eq!(quantize(-dmax, dmax, bits), -max_code(bits));
            // Clamped beyond the range.
            assert_eq!(quantize(1e30, dmax, bits), max_code(bits));
            assert_eq!(quantize(-1e30, dmax, bits), -max_code(bits));
        }
    }

    proptest! {
        #[test]
        fn error_bound(depth in 0u8..=16, t in -1.0f32..=1.0) {
            // Both widths at every drawn value (the codes stay within ±max_code).
            let dmax = voxel_diagonal(depth);
            let v = t * dmax;
            for (bits, max) in [(ValueBits::Eight, 127), (ValueBits::Sixteen, 32767)] {
                let q = quantize(v, dmax, bits);
                prop_assert!((-max..=max).contains(&q));
                let back = dequantize(q, dequant_scale(depth, bits));
                prop_assert!((back - v).abs() <= bound(depth, bits),
                    "{bits:?}: v {v} back {back} err {} bound {}", (back - v).abs(), bound(depth, bits));
            }
        }

        #[test]
        fn negation_is_exact(depth in 0u8..=16, v in -10.0f32..10.0) {
            let dmax = voxel_diagonal(depth);
            for bits in [ValueBits::Eight, ValueBits::Sixteen] {
                prop_assert_eq!(quantize(-v, dmax, bits), -quantize(v, dmax, bits));
            }
        }

        #[test]
        fn clamped_values_saturate(depth in 0u8..=16, t in 1.0f32..1e6) {
            let dmax = voxel_diagonal(depth);
            prop_assert_eq!(quantize(t * dmax, dmax, ValueBits::Eight), 127);
            prop_assert_eq!(quantize(-t * dmax, dmax, ValueBits::Sixteen), -32767);
        }
    }
}
