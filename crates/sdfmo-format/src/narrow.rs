//! Format 3.1's private sections: the private leaf groups of 16 leaves (24 bytes) with a wide
//! bit per leaf, and *narrow* private voxels (`FORMAT.md`, "Narrow private voxels (version
//! 3.1)"; the measurement that chose them: `examples/narrow_estimate.rs`).
//!
//! A narrow voxel stores its four base codes `c000 c001 c010 c100` (corner index `4x + 2y + z`)
//! and its four mixed differences
//!
//! ```text
//! xy  = c110 − c100 − c010 + c000      xz  = c101 − c100 − c001 + c000
//! yz  = c011 − c010 − c001 + c000      xyz = c111 − c110 − c101 − c011 + c100 + c010 + c001 − c000
//! ```
//!
//! in signed fields of half the code width (4 bits at 8-bit codes, 8 at 16-bit): `6·b` bytes
//! instead of `8·b` (`b` = bytes per code). A voxel is at unit offset `3·v + wide_before(v)` of
//! the private corners section in units of `2·b` bytes; a 3.0 file is the case where every
//! voxel is wide (`wide_before(v) = v`).

use crate::octree::{byte_sum, bytes_at, group_at, low_bits};
use crate::ValueBits;

/// The low seven bits of every byte: a 3.1 count byte's count.
const COUNT_BITS: u64 = 0x7f7f_7f7f_7f7f_7f7f;
/// The wide bit of a 3.1 count byte.
pub(crate) const WIDE_BIT: u8 = 0x80;

/// A private leaf as its group record places it: its voxels `first .. first + count` of the
/// private flags, and where their codes are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct PrivateSpan {
    /// The leaf's first private voxel.
    pub(crate) first: u32,
    /// Its voxels (1..=255 in 3.0, 1..=127 in 3.1).
    pub(crate) count: u32,
    /// Wide voxels before the leaf's first voxel.
    pub(crate) wide_before: u32,
    /// Whether the leaf's voxels are stored whole (always in 3.0).
    pub(crate) wide: bool,
}

/// The counts of the wide leaves among the count bytes `x` (the others 0).
#[inline(always)]
fn wide_counts(x: u64) -> u64 {
    let wide = (x >> 7) & 0x0101_0101_0101_0101;
    x & COUNT_BITS & wide.wrapping_mul(0xff)
}

/// The bytes of the 3.1 group record at `at` of `b`: first voxel, wide voxels before, the two
/// words of count bytes (slots 0–7, 8–15).
#[inline(always)]
pub(crate) fn group31_at(b: &[u8], at: usize) -> (u32, u32, [u64; 2]) {
    let r = bytes_at::<24>(b, at);
    let u32_at = |i: usize| u32::from_le_bytes([r[i], r[i + 1], r[i + 2], r[i + 3]]);
    let u64_at = |i: usize| {
        u64::from_le_bytes([
            r[i],
            r[i + 1],
            r[i + 2],
            r[i + 3],
            r[i + 4],
            r[i + 5],
            r[i + 6],
            r[i + 7],
        ])
    };
    (u32_at(0), u32_at(4), [u64_at(8), u64_at(16)])
}

/// Private leaf `j` of a 3.x file of minor version `minor`, from its group record in the
/// private leaves section at byte `section` of `b`: one group read and two byte sums (3.1: four).
/// Panics past the end of `b`.
#[inline(always)]
pub(crate) fn private_leaf_at(b: &[u8], section: usize, minor: u16, j: u32) -> PrivateSpan {
    if minor == 0 {
        let (first, counts) = group_at(b, section + (j as usize >> 3) * 12);
        let shift = (j & 7) * 8;
        let first = first + byte_sum(low_bits(counts, shift));
        return PrivateSpan {
            first,
            count: (counts >> shift & 0xff) as u32,
            wide_before: first,
            wide: true,
        };
    }
    let (first, wide, [lo, hi]) = group31_at(b, section + (j as usize >> 4) * 24);
    let s = j & 15;
    let (below_lo, below_hi, byte) = if s < 8 {
        (low_bits(lo, 8 * s), 0, (lo >> (8 * s)) as u8)
    } else {
        (lo, low_bits(hi, 8 * (s - 8)), (hi >> (8 * (s - 8))) as u8)
    };
    PrivateSpan {
        first: first + byte_sum(below_lo & COUNT_BITS) + byte_sum(below_hi & COUNT_BITS),
        count: u32::from(byte & !WIDE_BIT),
        wide_before: wide + byte_sum(wide_counts(below_lo)) + byte_sum(wide_counts(below_hi)),
        wide: byte & WIDE_BIT != 0,
    }
}

/// The four mixed differences `xy, xz, yz, xyz` of a voxel's codes (`4x + 2y + z`).
#[inline]
pub(crate) fn mixed_differences(c: [i32; 8]) -> [i32; 4] {
    [
        c[6] - c[4] - c[2] + c[0],
        c[5] - c[4] - c[1] + c[0],
        c[3] - c[2] - c[1] + c[0],
        c[7] - c[6] - c[5] - c[3] + c[4] + c[2] + c[1] - c[0],
    ]
}

/// Bits of a narrow voxel's difference field: half the code width.
#[inline]
const fn field_bits(bits: ValueBits) -> u32 {
    match bits {
        ValueBits::Eight => 4,
        ValueBits::Sixteen => 8,
    }
}

/// Whether the voxel with codes `c` can be stored narrow: every mixed difference fits a signed
/// field of half the code width.
pub(crate) fn fits_narrow(c: [i32; 8], bits: ValueBits) -> bool {
    let half = 1 << (field_bits(bits) - 1);
    mixed_differences(c)
        .iter()
        .all(|d| (-half..half).contains(d))
}

/// Writes the narrow voxel `c` (which [`fits_narrow`]) into `out` (`6·b` bytes).
pub(crate) fn put_narrow(out: &mut [u8], c: [i32; 8], bits: ValueBits) {
    let d = mixed_differences(c);
    let b = bits.bytes();
    for (i, k) in [0, 1, 2, 4].into_iter().enumerate() {
        out[i * b..(i + 1) * b].copy_from_slice(&(c[k] as i16).to_le_bytes()[..b]);
    }
    match bits {
        ValueBits::Eight => {
            out[4] = (d[0] & 15 | (d[1] & 15) << 4) as u8;
            out[5] = (d[2] & 15 | (d[3] & 15) << 4) as u8;
        }
        ValueBits::Sixteen => {
            for (i, x) in d.into_iter().enumerate() {
                out[8 + i] = x as i8 as u8;
            }
        }
    }
}

/// Writes private voxel `c` at the start of `out`, narrow (`6·b` bytes; it must
/// [`fit`](fits_narrow)) or, `wide`, whole (`8·b`); returns the bytes written. The inverse of
/// [`private_codes`].
pub(crate) fn put_private(out: &mut [u8], c: [i32; 8], wide: bool, bits: ValueBits) -> usize {
    let b = bits.bytes();
    if !wide {
        put_narrow(out, c, bits);
        return 6 * b;
    }
    for (k, x) in c.into_iter().enumerate() {
        out[k * b..(k + 1) * b].copy_from_slice(&(x as i16).to_le_bytes()[..b]);
    }
    8 * b
}

/// The eight codes of the narrow voxel at `at` of `b` (not range-checked: a validator checks
/// them in −Q..=Q, where they fit an `i16`).
#[inline(always)]
pub(crate) fn narrow_codes(b: &[u8], at: usize, bits: ValueBits) -> [i32; 8] {
    let (base, d) = match bits {
        ValueBits::Eight => {
            let r = bytes_at::<6>(b, at);
            let nib = |x: u8| i32::from((x << 4) as i8 >> 4);
            (
                [r[0], r[1], r[2], r[3]].map(|x| i32::from(x as i8)),
                [nib(r[4]), nib(r[4] >> 4), nib(r[5]), nib(r[5] >> 4)],
            )
        }
        ValueBits::Sixteen => {
            let r = bytes_at::<12>(b, at);
            (
                std::array::from_fn(|i| i32::from(i16::from_le_bytes([r[2 * i], r[2 * i + 1]]))),
                std::array::from_fn(|i| i32::from(r[8 + i] as i8)),
            )
        }
    };
    let [c000, c001, c010, c100] = base;
    let c011 = c010 + c001 - c000 + d[2];
    let c101 = c100 + c001 - c000 + d[1];
    let c110 = c100 + c010 - c000 + d[0];
    let c111 = c110 + c101 + c011 - c100 - c010 - c001 + c000 + d[3];
    [c000, c001, c010, c011, c100, c101, c110, c111]
}

/// The eight codes of a wide voxel at `at` of `b`.
#[inline(always)]
pub(crate) fn wide_codes(b: &[u8], at: usize, bits: ValueBits) -> [i32; 8] {
    match bits {
        ValueBits::Eight => bytes_at::<8>(b, at).map(|c| i32::from(c as i8)),
        ValueBits::Sixteen => {
            let c = bytes_at::<16>(b, at);
            std::array::from_fn(|i| i32::from(i16::from_le_bytes([c[2 * i], c[2 * i + 1]])))
        }
    }
}

/// The byte offset in the private corners section of private voxel `voxel` with `wide_before`
/// wide voxels before it: `2·b·(3·voxel + wide_before)`.
#[inline(always)]
pub(crate) fn corner_offset(voxel: u32, wide_before: u32, bits: ValueBits) -> usize {
    2 * bits.bytes() * (3 * voxel as usize + wide_before as usize)
}

/// The eight codes of a private voxel at byte `at` of `b` (see [`corner_offset`]).
#[inline(always)]
pub(crate) fn private_codes(b: &[u8], at: usize, wide: bool, bits: ValueBits) -> [i32; 8] {
    if wide {
        wide_codes(b, at, bits)
    } else {
        narrow_codes(b, at, bits)
    }
}

/// Every slot's count byte of the private leaf groups `groups` of a 3.x file of minor version
/// `minor` (padding slots 0), with the wide bit (always set in 3.0 for a real slot).
pub(crate) fn slots(groups: &[u8], minor: u16) -> impl Iterator<Item = (u32, bool)> + '_ {
    let (size, head) = if minor == 0 { (12, 4) } else { (24, 8) };
    groups
        .chunks_exact(size)
        .flat_map(move |g| g[head..].iter())
        .map(move |&n| {
            if minor == 0 {
                (u32::from(n), true)
            } else {
                (u32::from(n & !WIDE_BIT), n & WIDE_BIT != 0)
            }
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every voxel whose differences fit reads back as written, at both widths.
    #[test]
    fn narrow_voxels_round_trip() {
        let cases: [[i32; 8]; 3] = [
            [-5, 1, 7, 9, -3, 2, 8, 10],
            [4, 4, -4, -4, 4, 4, -4, -4],
            [127, 120, 121, 114, 126, 119, 120, 113],
        ];
        for bits in [ValueBits::Eight, ValueBits::Sixteen] {
            for c in cases {
                assert!(fits_narrow(c, bits));
                let mut out = [0u8; 12];
                put_narrow(&mut out, c, bits);
                assert_eq!(narrow_codes(&out, 0, bits), c);
            }
        }
        // xy = 8: one over the 4-bit field.
        let c = [0, 0, 0, 0, 0, 0, 8, 8];
        assert!(!fits_narrow(c, ValueBits::Eight));
        assert!(fits_narrow(c, ValueBits::Sixteen));
    }

    /// The 3.1 group read: slots before `s` give the first voxel and the wide voxels before.
    #[test]
    fn group_slots_sum_counts_and_wide_counts() {
        let mut g = vec![0u8; 24];
        g[..4].copy_from_slice(&100u32.to_le_bytes());
        g[4..8].copy_from_slice(&40u32.to_le_bytes());
        let counts: [u8; 16] = [
            2,
            3 | WIDE_BIT,
            1,
            2,
            2,
            1 | WIDE_BIT,
            2,
            2,
            5,
            3 | WIDE_BIT,
            2,
            0,
            0,
            0,
            0,
            0,
        ];
        g[8..].copy_from_slice(&counts);
        let (mut v, mut w) = (100, 40);
        for (s, &n) in counts.iter().enumerate().take(11) {
            let span = private_leaf_at(&g, 0, 1, s as u32);
            let count = u32::from(n & 0x7f);
            let wide = n & WIDE_BIT != 0;
            assert_eq!(
                span,
                PrivateSpan {
                    first: v,
                    count,
                    wide_before: w,
                    wide
                },
                "slot {s}"
            );
            v += count;
            w += if wide { count } else { 0 };
        }
    }
}
