//! Seeded shuffles: the same seed and words always give the same order (a participant's
//! random order of the conditions, their order of a questionnaire's items and rows).

/// Shuffles `list` by a Fisher-Yates shuffle drawn from splitmix64, started at the FNV-1a
/// hash of `seed` (little-endian) and `words`' bytes one after the other.
pub(crate) fn shuffle<T>(list: &mut [T], seed: u64, words: &[&[u8]]) {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in seed.to_le_bytes().iter().chain(words.iter().flat_map(|w| w.iter())) {
        h = (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    for i in (1..list.len()).rev() {
        h = h.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = h;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        list.swap(i, (z % (i as u64 + 1)) as usize);
    }
}
