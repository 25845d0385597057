//! SYNC period statistics for `monitor` and its TUI: a bounded histogram of the periods
//! between SYNC frames, with exact count, min, max and mean.

use cnc402_drives::Instant;
use cnc402_drives::stats::Histogram;

/// Fine buckets: 1 µs wide over 0..5 ms (SYNC periods of a few ms at most, jitter in µs).
const FINE_BUCKETS: usize = 5_000;
/// Coarse buckets: 1 ms wide over 5 ms..1 s; longer periods (a bus pause) count only in the
/// max.
const COARSE_BUCKETS: usize = 995;

/// SYNC period statistics in bounded memory: a [`Histogram`] (allocated once, ~47 KiB,
/// whatever the number of samples) with exact count, min, max and mean.
///
/// Percentile resolution ([`Histogram`]'s): the nearest-rank sample's bucket middle, clamped
/// to the exact min/max, so within 0.5 µs of the exact value below 5 ms and within 0.5 ms
/// from 5 ms to 1 s; a percentile that falls above 1 s is the max. The lowest and highest
/// ranks (p0, p100, and p99 of fewer than 100 samples) are exact.
#[derive(Clone, Debug)]
pub struct PeriodStats {
    pub(crate) hist: Histogram,
    /// The last SYNC seen by [`PeriodStats::on_sync`].
    last_sync: Option<Instant>,
}

impl Default for PeriodStats {
    fn default() -> Self {
        PeriodStats {
            hist: Histogram::micros_then_millis(FINE_BUCKETS, COARSE_BUCKETS),
            last_sync: None,
        }
    }
}

/// Nanoseconds in µs.
pub(crate) fn us(ns: f64) -> f64 {
    ns / 1000.0
}

impl PeriodStats {
    /// Adds one period (µs, kept to the nanosecond); a negative one counts as 0, a
    /// non-finite one is ignored.
    pub fn push(&mut self, us: f64) {
        if !us.is_finite() {
            return;
        }
        // Saturating float-to-int cast: beyond u64 ns counts as the largest value.
        self.hist.record((us.max(0.0) * 1000.0).round() as u64);
    }

    /// A SYNC received at `t`: records the period since the previous one (none for the
    /// first).
    pub fn on_sync(&mut self, t: Instant) {
        if let Some(prev) = self.last_sync {
            let ns = t.saturating_since(prev).as_nanos();
            self.hist.record(u64::try_from(ns).unwrap_or(u64::MAX));
        }
        self.last_sync = Some(t);
    }

    /// Number of periods recorded.
    pub fn count(&self) -> u64 {
        self.hist.count()
    }

    /// The exact shortest period (µs), if any.
    pub fn min(&self) -> Option<f64> {
        self.hist.min_ns().map(|n| us(n as f64))
    }

    /// Percentile `p` (0..=1) in µs: the nearest-rank sample `ceil(n·p)`, to the resolution
    /// given on the type. `None` without samples.
    pub fn percentile(&self, p: f64) -> Option<f64> {
        self.hist.percentile_ns(p).map(us)
    }

    /// `(count, mean, p50, p99, max)` in µs; mean and max exact, p50/p99 bucketed.
    pub fn summary(&self) -> Option<(u64, f64, f64, f64, f64)> {
        let s = self.hist.summary()?;
        Some((
            s.count,
            us(s.mean_ns),
            us(s.p50_ns),
            us(s.p99_ns),
            us(s.max_ns as f64),
        ))
    }
}
