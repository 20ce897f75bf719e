//! Secrets the server hands out: tokens nobody else can guess.

use std::hash::{BuildHasher, Hasher};

/// A 128-bit secret as 32 hex digits, from the operating system's random source.
pub fn random_token() -> String {
    let mut bytes = [0u8; 16];
    if getrandom::fill(&mut bytes).is_err() {
        // No OS randomness (it does not happen on the systems bw4t runs on): the standard
        // library's per-process random hash keys and the clock, still unguessable from outside.
        let half = |salt: u64| {
            let mut h = std::collections::hash_map::RandomState::new().build_hasher();
            h.write_u64(salt);
            h.write_u128(
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_nanos()),
            );
            h.finish()
        };
        bytes[..8].copy_from_slice(&half(1).to_le_bytes());
        bytes[8..].copy_from_slice(&half(2).to_le_bytes());
    }
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
