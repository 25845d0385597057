//! Wake-up latency of periodic loops: how late each absolute-deadline wake-up was, summarised
//! as p50/p99/max (nearest-rank percentiles) plus how many wake-ups missed a whole period.

use serde::Serialize;

/// Summary of a set of wake-up latencies, all in nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct LatencySummary {
    /// Number of samples summarised.
    pub samples: usize,
    /// Median lateness.
    pub p50_ns: u64,
    /// 99th percentile (nearest rank).
    pub p99_ns: u64,
    /// Largest lateness seen.
    pub max_ns: u64,
    /// Arithmetic mean.
    pub mean_ns: u64,
    /// Wake-ups late by a whole period or more (a tick that a 1 ms loop would have missed).
    pub late_by_a_period: usize,
}

/// Nearest-rank percentile of sorted samples: the smallest sample such that at least `pct` %
/// of all samples are less than or equal to it. `None` for an empty slice.
///
/// ```
/// use cnc402_hil::latency::percentile;
/// let sorted: Vec<u64> = (1..=100).collect();
/// assert_eq!(percentile(&sorted, 50), Some(50));
/// assert_eq!(percentile(&sorted, 99), Some(99));
/// assert_eq!(percentile(&sorted, 100), Some(100));
/// ```
pub fn percentile(sorted: &[u64], pct: u32) -> Option<u64> {
    if sorted.is_empty() {
        return None;
    }
    let n = sorted.len() as u64;
    let pct = u64::from(pct.min(100));
    // rank = ceil(pct/100 * n), at least 1.
    let rank = (pct * n).div_ceil(100).max(1);
    sorted.get((rank - 1) as usize).copied()
}

/// Summarises `samples` (sorted in place) for a loop of period `period_ns`. `None` when there
/// are no samples.
pub fn summarize(samples: &mut [u64], period_ns: u64) -> Option<LatencySummary> {
    samples.sort_unstable();
    let n = samples.len();
    let p50_ns = percentile(samples, 50)?;
    let p99_ns = percentile(samples, 99)?;
    let max_ns = *samples.last()?;
    let sum: u128 = samples.iter().map(|&s| u128::from(s)).sum();
    let mean_ns = u64::try_from(sum / n as u128).unwrap_or(u64::MAX);
    let late_by_a_period = if period_ns == 0 {
        0
    } else {
        samples.len() - samples.partition_point(|&s| s < period_ns)
    };
    Some(LatencySummary {
        samples: n,
        p50_ns,
        p99_ns,
        max_ns,
        mean_ns,
        late_by_a_period,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_has_no_summary() {
        assert_eq!(summarize(&mut [], 1_000_000), None);
        assert_eq!(percentile(&[], 50), None);
    }

    #[test]
    fn single_sample_is_every_percentile() {
        let s = summarize(&mut [7], 1_000).unwrap();
        assert_eq!((s.p50_ns, s.p99_ns, s.max_ns, s.mean_ns), (7, 7, 7, 7));
        assert_eq!(s.late_by_a_period, 0);
    }

    #[test]
    fn unsorted_input_is_sorted_and_ranked() {
        // 1..=200 shuffled deterministically: p50 = 100, p99 = 198, max = 200.
        let mut v: Vec<u64> = (1..=200).map(|i| (i * 73) % 200 + 1).collect();
        let s = summarize(&mut v, 150).unwrap();
        assert_eq!(s.samples, 200);
        assert_eq!(s.p50_ns, 100);
        assert_eq!(s.p99_ns, 198);
        assert_eq!(s.max_ns, 200);
        assert_eq!(s.mean_ns, 100); // 100.5 truncated
        assert_eq!(s.late_by_a_period, 51); // 150..=200
    }

    #[test]
    fn one_outlier_shows_in_max_not_p99() {
        let mut v = vec![10_000u64; 999];
        v.push(7_000_000);
        let s = summarize(&mut v, 1_000_000).unwrap();
        assert_eq!(s.p99_ns, 10_000);
        assert_eq!(s.max_ns, 7_000_000);
        assert_eq!(s.late_by_a_period, 1);
    }
}
