//! Secrets the server hands out: tokens nobody else can guess.

use std::hash::{BuildHasher, Hasher};

/// A 128-bit secret as 32 hex digits, from the standard library's per-process random
/// hash keys and the clock.
pub fn random_token() -> String {
    let half = |salt: u64| {
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u64(salt);
        h.write_u128(
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos()),
        );
        h.finish()
    };
    format!("{:016x}{:016x}", half(1), half(2))
}
