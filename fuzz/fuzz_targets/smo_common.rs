//! What the `.smo` targets share: trying an input as given and *resealed* (its last four bytes
//! replaced by the CRC-32 of the rest). Random bytes almost never carry a valid CRC-32; the
//! resealed copy lets the fuzzer reach the structural checks behind the checksum, where a
//! hostile file would attack.

use sdfmo_format::crc32;

/// Runs `check` on `data`, then (inputs of at least 4 bytes) on `data` resealed.
pub fn with_resealed(data: &[u8], mut check: impl FnMut(&[u8])) {
    check(data);
    if data.len() >= 4 {
        let mut sealed = data.to_vec();
        let n = sealed.len();
        let crc = crc32(&sealed[..n - 4]);
        sealed[n - 4..].copy_from_slice(&crc.to_le_bytes());
        check(&sealed);
    }
}
