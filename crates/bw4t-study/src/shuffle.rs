//! Seeded shuffles: the same seed and words always give the same order (a participant's
//! random order of the conditions, their order of a questionnaire's items and rows).

/// Shuffles `list` by a Fisher-Yates shuffle drawn from splitmix64, started at the FNV-1a
/// hash of `seed` (little-endian) and `words`' bytes one after the other.
pub(crate) fn shuffle<T>(list: &mut [T], seed: u64, words: &[&[u8]]) {
    let bytes = seed.to_le_bytes().into_iter().chain(words.iter().flat_map(|w| w.iter().copied()));
    let mut rng = bw4t_map::SeededRng::new(bw4t_map::fnv1a(bytes));
    for i in (1..list.len()).rev() {
        list.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
    }
}
