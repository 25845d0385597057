//! One fixed-bucket histogram for timing statistics (loop wake-up latency, SYNC periods):
//! integer nanoseconds in, exact count/min/max/mean, and p50/p99 from the buckets. The
//! buckets are allocated once in the constructor; [`Histogram::record`] never allocates, so
//! it can run inside the 1 ms loop.

/// A histogram of durations in nanoseconds: `fine_buckets` buckets of `fine_width_ns`, then
/// `coarse_buckets` buckets of `coarse_width_ns` above them; samples beyond the coarse range
/// are counted in an overflow and reach the figures through the exact maximum.
///
/// Percentiles use the nearest rank: the sample of rank `ceil(p·n)` (1-based, at least 1)
/// of the sorted samples. The lowest and highest ranks are the exact min and max; any other
/// rank is the midpoint of the bucket holding it, clamped to [min, max], so it is within
/// half a bucket width of the exact sample (0.5 µs in 1 µs buckets, 0.5 ms in 1 ms
/// buckets). A rank that falls in the overflow is the max.
#[derive(Clone, Debug)]
pub struct Histogram {
    /// Fine buckets, then coarse ones.
    counts: Box<[u64]>,
    fine_width_ns: u64,
    fine_buckets: usize,
    coarse_width_ns: u64,
    overflow: u64,
    n: u64,
    sum_ns: u128,
    min_ns: u64,
    max_ns: u64,
}

/// The figures of a [`Histogram`] with samples: count, min, max and mean exact; p50/p99 to
/// the resolution the type describes. All in nanoseconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary {
    pub count: u64,
    pub min_ns: u64,
    pub max_ns: u64,
    pub mean_ns: f64,
    pub p50_ns: f64,
    pub p99_ns: f64,
}

impl Histogram {
    /// `fine_buckets` buckets `fine_width_ns` wide from 0, then `coarse_buckets` buckets
    /// `coarse_width_ns` wide (widths of 0 count as 1 ns). Allocates the buckets once.
    pub fn new(
        fine_width_ns: u64,
        fine_buckets: usize,
        coarse_width_ns: u64,
        coarse_buckets: usize,
    ) -> Histogram {
        Histogram {
            counts: vec![0; fine_buckets + coarse_buckets].into_boxed_slice(),
            fine_width_ns: fine_width_ns.max(1),
            fine_buckets,
            coarse_width_ns: coarse_width_ns.max(1),
            overflow: 0,
            n: 0,
            sum_ns: 0,
            min_ns: u64::MAX,
            max_ns: 0,
        }
    }

    /// 1 µs buckets up to `fine_us` µs, then 1 ms buckets for `coarse_ms` ms more: the
    /// layout of loop latency and SYNC period statistics.
    pub fn micros_then_millis(fine_us: usize, coarse_ms: usize) -> Histogram {
        Histogram::new(1_000, fine_us, 1_000_000, coarse_ms)
    }

    /// Adds one sample. Never allocates.
    #[inline]
    pub fn record(&mut self, ns: u64) {
        self.n += 1;
        self.sum_ns += ns as u128;
        self.min_ns = self.min_ns.min(ns);
        self.max_ns = self.max_ns.max(ns);
        let fine_end = self.fine_end_ns();
        let i = if ns < fine_end {
            (ns / self.fine_width_ns) as usize
        } else {
            let k = (ns - fine_end) / self.coarse_width_ns;
            self.fine_buckets
                .saturating_add(usize::try_from(k).unwrap_or(usize::MAX))
        };
        match self.counts.get_mut(i) {
            Some(c) => *c += 1,
            None => self.overflow += 1,
        }
    }

    /// Forgets every sample (keeps the buckets).
    pub fn clear(&mut self) {
        self.counts.fill(0);
        self.overflow = 0;
        self.n = 0;
        self.sum_ns = 0;
        self.min_ns = u64::MAX;
        self.max_ns = 0;
    }

    /// Samples recorded.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// Samples beyond the coarse range.
    pub fn overflow(&self) -> u64 {
        self.overflow
    }

    /// Number of buckets (fixed at construction).
    pub fn bucket_count(&self) -> usize {
        self.counts.len()
    }

    /// The exact smallest sample.
    pub fn min_ns(&self) -> Option<u64> {
        (self.n > 0).then_some(self.min_ns)
    }

    /// The exact largest sample.
    pub fn max_ns(&self) -> Option<u64> {
        (self.n > 0).then_some(self.max_ns)
    }

    /// The exact mean (sum kept as an integer).
    pub fn mean_ns(&self) -> Option<f64> {
        (self.n > 0).then(|| self.sum_ns as f64 / self.n as f64)
    }

    fn fine_end_ns(&self) -> u64 {
        self.fine_width_ns.saturating_mul(self.fine_buckets as u64)
    }

    /// Lower edge and width of bucket `i` (ns).
    fn bucket(&self, i: usize) -> (f64, f64) {
        if i < self.fine_buckets {
            let w = self.fine_width_ns as f64;
            (i as f64 * w, w)
        } else {
            let w = self.coarse_width_ns as f64;
            (
                self.fine_end_ns() as f64 + (i - self.fine_buckets) as f64 * w,
                w,
            )
        }
    }

    /// Percentile `p` (0..=1, clamped; NaN counts as 0) in ns: see the type's doc for the
    /// rank and the resolution. `None` without samples.
    pub fn percentile_ns(&self, p: f64) -> Option<f64> {
        if self.n == 0 {
            return None;
        }
        let p = if p.is_nan() { 0.0 } else { p.clamp(0.0, 1.0) };
        let rank = ((p * self.n as f64).ceil() as u64).clamp(1, self.n);
        let (min, max) = (self.min_ns as f64, self.max_ns as f64);
        if rank == 1 {
            return Some(min);
        }
        if rank == self.n {
            return Some(max);
        }
        let mut seen = 0u64;
        for (i, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= rank {
                let (lo, w) = self.bucket(i);
                return Some((lo + w / 2.0).clamp(min, max));
            }
        }
        Some(max)
    }

    /// Count, min, max, mean, p50 and p99; `None` without samples.
    pub fn summary(&self) -> Option<Summary> {
        Some(Summary {
            count: self.n,
            min_ns: self.min_ns()?,
            max_ns: self.max_ns()?,
            mean_ns: self.mean_ns()?,
            p50_ns: self.percentile_ns(0.5)?,
            p99_ns: self.percentile_ns(0.99)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nearest rank `ceil(p·n)` of the sorted samples.
    fn exact(v: &[u64], p: f64) -> u64 {
        let mut v = v.to_vec();
        v.sort_unstable();
        let rank = ((p * v.len() as f64).ceil() as usize).clamp(1, v.len());
        v[rank - 1]
    }

    fn hist(v: &[u64]) -> Histogram {
        let mut h = Histogram::micros_then_millis(5_000, 2_000);
        for &x in v {
            h.record(x);
        }
        h
    }

    #[test]
    fn percentiles_within_half_a_bucket_of_the_nearest_rank() {
        // 1 ms periods with ±40 µs jitter and a few late ones, in ns.
        let mut v: Vec<u64> = (0..10_000u64)
            .map(|i| 960_370 + (i * 7919 % 81) * 1_000)
            .collect();
        v.extend([1_480_200, 2_210_900, 3_999_500, 20_300_000]);
        let h = hist(&v);
        for p in [0.0, 0.1, 0.5, 0.9, 0.99, 0.999, 0.9999, 1.0] {
            let (got, e) = (h.percentile_ns(p).unwrap(), exact(&v, p) as f64);
            let half = if e < 5e6 { 500.0 } else { 500_000.0 };
            assert!((got - e).abs() <= half, "p{p}: {got} vs {e}");
        }
        let s = h.summary().unwrap();
        assert_eq!(s.count, v.len() as u64);
        assert_eq!((s.min_ns, s.max_ns), (960_370, 20_300_000));
        let mean = v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
        assert!((s.mean_ns - mean).abs() < 1e-6, "{}", s.mean_ns);
        // The nearest-rank p50 is 1000.37 µs here; the bucket midpoint is 1000.5 µs.
        assert_eq!(exact(&v, 0.5), 1_000_370);
        assert_eq!(s.p50_ns, 1_000_500.0);
    }

    #[test]
    fn p99_beyond_the_fine_range_is_a_bucket_not_the_maximum() {
        // 90 at 10 µs, 9 at 20.3 ms, one at 150 ms: p99 is 20.3 ms to 0.5 ms, not 150 ms.
        let mut v = vec![10_000; 90];
        v.extend([20_300_000; 9]);
        v.push(150_000_000);
        let h = hist(&v);
        let s = h.summary().unwrap();
        assert_eq!(s.p50_ns, 10_500.0); // the middle of bucket [10, 11) µs: exact is 10 µs
        assert_eq!(s.p99_ns, 20_500_000.0);
        assert_eq!(s.max_ns, 150_000_000);
        // Beyond the coarse range: counted, and the figures come from the exact max.
        let h = hist(&[1_000, 5_000_000_000, 7_000_000_000]);
        assert_eq!(h.overflow(), 2);
        assert_eq!(h.percentile_ns(0.5), Some(7e9));
        assert_eq!(h.percentile_ns(0.0), Some(1_000.0));
    }

    #[test]
    fn one_sample_and_no_samples() {
        let h = hist(&[1_234_560]);
        let s = h.summary().unwrap();
        assert_eq!(
            (s.count, s.min_ns, s.max_ns, s.mean_ns, s.p50_ns, s.p99_ns),
            (
                1,
                1_234_560,
                1_234_560,
                1_234_560.0,
                1_234_560.0,
                1_234_560.0
            )
        );
        let mut h = Histogram::micros_then_millis(10, 10);
        assert_eq!(h.summary(), None);
        assert_eq!(h.percentile_ns(f64::NAN), None);
        h.record(u64::MAX); // no overflow of the sum or the index
        assert_eq!(h.max_ns(), Some(u64::MAX));
        assert_eq!(h.overflow(), 1);
        h.clear();
        assert_eq!((h.count(), h.overflow()), (0, 0));
    }

    #[test]
    fn memory_is_fixed() {
        let mut h = Histogram::micros_then_millis(5_000, 995);
        let len = h.bucket_count();
        for i in 0..1_000_000u64 {
            h.record(900_000 + (i % 200) * 1_000);
        }
        assert_eq!(h.bucket_count(), len);
        assert_eq!(h.count(), 1_000_000);
        assert!((h.percentile_ns(0.5).unwrap() - 999_500.0).abs() < 1e-9);
    }
}
