//! How late realtime ticks start, counted across matches: a histogram of lateness in
//! 100-microsecond steps (atomics, so every match's task records without a lock), and
//! the ticks skipped because the host was later than a whole period.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// The width of one bucket.
const STEP: Duration = Duration::from_micros(100);
/// Buckets up to 100 ms; later ticks fall in the last.
const BUCKETS: usize = 1001;

/// Lateness of realtime ticks: when each tick was made, after it fell due.
pub struct TickLateness {
    buckets: Vec<AtomicU64>,
    skipped: AtomicU64,
}

impl std::fmt::Debug for TickLateness {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TickLateness").field("ticks", &self.ticks()).finish_non_exhaustive()
    }
}

impl Default for TickLateness {
    fn default() -> Self {
        TickLateness {
            buckets: (0..BUCKETS).map(|_| AtomicU64::new(0)).collect(),
            skipped: AtomicU64::new(0),
        }
    }
}

impl TickLateness {
    /// Counts one tick made `late` after it fell due, and `skipped` ticks passed over.
    pub fn record(&self, late: Duration, skipped: u64) {
        let bucket = (late.as_micros() / STEP.as_micros()).min(BUCKETS as u128 - 1) as usize;
        self.buckets[bucket].fetch_add(1, Ordering::Relaxed);
        if skipped > 0 {
            self.skipped.fetch_add(skipped, Ordering::Relaxed);
        }
    }

    /// Ticks counted.
    pub fn ticks(&self) -> u64 {
        self.buckets.iter().map(|b| b.load(Ordering::Relaxed)).sum()
    }

    /// Ticks skipped because the match was more than a period late.
    pub fn skipped(&self) -> u64 {
        self.skipped.load(Ordering::Relaxed)
    }

    /// The lateness that fraction `q` (0..=1) of the ticks stayed within, to the bucket's
    /// upper edge (100 ms or more reads as 100 ms).
    pub fn quantile(&self, q: f64) -> Duration {
        let counts: Vec<u64> = self.buckets.iter().map(|b| b.load(Ordering::Relaxed)).collect();
        let total: u64 = counts.iter().sum();
        let wanted = ((total as f64) * q.clamp(0.0, 1.0)).ceil() as u64;
        let mut seen = 0;
        for (i, count) in counts.iter().enumerate() {
            seen += count;
            if seen >= wanted.max(1) {
                return STEP * (i as u32 + 1);
            }
        }
        Duration::ZERO
    }

    /// Forgets every count (for a fresh measurement window).
    pub fn reset(&self) {
        for b in &self.buckets {
            b.store(0, Ordering::Relaxed);
        }
        self.skipped.store(0, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_follow_the_counts() {
        let l = TickLateness::default();
        for _ in 0..98 {
            l.record(Duration::from_micros(50), 0);
        }
        l.record(Duration::from_millis(5), 0);
        l.record(Duration::from_secs(1), 3);
        assert_eq!(l.ticks(), 100);
        assert_eq!(l.skipped(), 3);
        assert_eq!(l.quantile(0.5), Duration::from_micros(100));
        assert_eq!(l.quantile(0.99), Duration::from_micros(5100));
        assert_eq!(l.quantile(1.0), Duration::from_micros(100_100));
        l.reset();
        assert_eq!(l.ticks(), 0);
    }
}
