//! A 64-bit digest of bytes (FNV-1a): tells a file or a saved state from a changed or damaged
//! one. Not a defence against someone who recomputes it; fast enough for every state written
//! out of the process.

const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const PRIME: u64 = 0x0000_0100_0000_01b3;

/// The FNV-1a digest of `bytes`.
pub fn digest(bytes: &[u8]) -> u64 {
    bytes.iter().fold(OFFSET, |h, &b| (h ^ u64::from(b)).wrapping_mul(PRIME))
}

#[cfg(test)]
mod tests {
    use super::digest;

    /// The published FNV-1a 64 test vectors.
    #[test]
    fn known_values() {
        assert_eq!(digest(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(digest(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(digest(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
