//! Morton (Z-order) codes matching the corner/octant convention `i = 4x + 2y + z`.
//!
//! Bit `3b + 2` of a code is bit `b` of x, `3b + 1` of y, `3b` of z, so the three bits of one
//! level read as an octant index `4x + 2y + z`, and sorting leaves by code is the same as
//! ordering them by their path of octants from the root (the breadth-first leaf order of the
//! packed octree).

/// Spreads the low 21 bits of `v` so that bit `b` lands at bit `3b`.
#[inline]
fn split3(v: u32) -> u64 {
    let mut x = u64::from(v) & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// Morton code of a cell coordinate (each component < 2^21).
#[inline]
pub fn encode(c: [u32; 3]) -> u64 {
    split3(c[0]) << 2 | split3(c[1]) << 1 | split3(c[2])
}

/// Gathers every third bit of `x` (from bit 0) into the low bits: the inverse of `split3`.
#[inline]
fn compact3(v: u64) -> u32 {
    let mut x = v & 0x1249_2492_4924_9249;
    x = (x | x >> 2) & 0x10c3_0c30_c30c_30c3;
    x = (x | x >> 4) & 0x100f_00f0_0f00_f00f;
    x = (x | x >> 8) & 0x001f_0000_ff00_00ff;
    x = (x | x >> 16) & 0x001f_0000_0000_ffff;
    x = (x | x >> 32) & 0x1f_ffff;
    x as u32
}

/// The cell coordinate of a Morton code: `decode(encode(c)) == c` (each component < 2^21).
#[inline]
pub fn decode(code: u64) -> [u32; 3] {
    [compact3(code >> 2), compact3(code >> 1), compact3(code)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive(c: [u32; 3]) -> u64 {
        let mut code = 0u64;
        for b in 0..21 {
            let x = u64::from(c[0] >> b & 1);
            let y = u64::from(c[1] >> b & 1);
            let z = u64::from(c[2] >> b & 1);
            code |= (4 * x + 2 * y + z) << (3 * b);
        }
        code
    }

    #[test]
    fn decode_inverts_encode() {
        for c in [
            [0, 0, 0],
            [1, 2, 3],
            [0x1f_ffff, 0, 0x1f_ffff],
            [12345, 678, 2_000_000],
        ] {
            assert_eq!(decode(encode(c)), c);
        }
    }

    #[test]
    fn matches_naive_interleave() {
        let samples = [
            [0, 0, 0],
            [1, 0, 0],
            [0, 1, 0],
            [0, 0, 1],
            [65535, 0, 12345],
            [0x1f_ffff, 0x1f_ffff, 0x1f_ffff],
            [77, 4095, 2048],
        ];
        for c in samples {
            assert_eq!(encode(c), naive(c), "{c:?}");
        }
    }

    #[test]
    fn octant_convention() {
        // One level: the code is the octant index 4x + 2y + z.
        assert_eq!(encode([1, 0, 0]), 4);
        assert_eq!(encode([0, 1, 0]), 2);
        assert_eq!(encode([0, 0, 1]), 1);
        assert_eq!(encode([1, 1, 1]), 7);
    }
}
