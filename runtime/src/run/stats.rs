//! Periodic figures of a long run (`cnc402 run --stats-every S`, `hil-tests/soak.sh`): the
//! real-time loop counts its wake-ups in a few atomics (no lock, no allocation in the 1 ms
//! loop), the reporting side adds the following error it drains, and once per interval hands
//! a [`StatsSample`] to the caller's progress callback.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use cnc402_config::MAX_AXES;

use crate::status::Status;

/// What the real-time loop thread has counted, read by the reporting side.
#[derive(Debug, Default)]
pub(super) struct LoopCounters {
    wakeups: AtomicU64,
    late: AtomicU64,
    skipped: AtomicU64,
    /// The largest wake-up latency since the reporting side last took it.
    window_max_ns: AtomicU64,
}

impl LoopCounters {
    /// One wake-up `latency_ns` after its deadline, `late` as the latency histogram counts
    /// it, `missed` deadlines let pass.
    #[inline]
    pub(super) fn woke(&self, latency_ns: u64, late: bool, missed: u64) {
        self.wakeups.fetch_add(1, Ordering::Relaxed);
        if late {
            self.late.fetch_add(1, Ordering::Relaxed);
        }
        if missed > 0 {
            self.skipped.fetch_add(missed, Ordering::Relaxed);
        }
        self.window_max_ns.fetch_max(latency_ns, Ordering::Relaxed);
    }
}

/// One interval's figures (`--stats-every`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StatsSample {
    /// Wall-clock seconds since the cyclic phase began.
    pub wall_s: f64,
    /// The last tick drained (program time = tick · period).
    pub tick: u64,
    /// Whether the wake-up figures below were measured (real time) or are all 0 (virtual).
    pub real_time: bool,
    /// Wake-ups so far, late ones (more than half a period) and deadlines let pass: totals.
    pub wakeups: u64,
    pub late: u64,
    pub skipped: u64,
    /// The largest wake-up latency in this interval, µs.
    pub wake_max_us: f64,
    /// The largest |following error| per axis in this interval (axis units, config order).
    pub following_error_max: [f64; MAX_AXES],
}

/// The reporting side's half: the interval, the following error seen since the last sample.
pub(super) struct Stats {
    every: Duration,
    t0: Option<Instant>,
    next: Option<Instant>,
    counters: Option<std::sync::Arc<LoopCounters>>,
    fe_max: [f64; MAX_AXES],
}

impl Stats {
    /// A sample every `every` (at least 1 ms); `counters` when the loop runs in real time.
    pub(super) fn new(every: Duration, counters: Option<std::sync::Arc<LoopCounters>>) -> Stats {
        Stats {
            every: every.max(Duration::from_millis(1)),
            t0: None,
            next: None,
            counters,
            fe_max: [0.0; MAX_AXES],
        }
    }

    /// A status record drained from the loop.
    pub(super) fn observe(&mut self, s: &Status) {
        for (m, fe) in self.fe_max.iter_mut().zip(s.following_error) {
            if fe.is_finite() {
                *m = m.max(fe.abs());
            }
        }
    }

    /// The sample when one is due at `now` (the clock starts at the first call), having
    /// drained up to `tick`.
    pub(super) fn due(&mut self, now: Instant, tick: u64) -> Option<StatsSample> {
        let t0 = *self.t0.get_or_insert(now);
        let next = *self.next.get_or_insert(now + self.every);
        if now < next {
            return None;
        }
        // Intervals stay on the grid from t0 even when the caller was late.
        let mut n = next;
        while n <= now {
            n += self.every;
        }
        self.next = Some(n);
        let mut sample = StatsSample {
            wall_s: now.duration_since(t0).as_secs_f64(),
            tick,
            following_error_max: std::mem::take(&mut self.fe_max),
            ..StatsSample::default()
        };
        if let Some(c) = &self.counters {
            sample.real_time = true;
            sample.wakeups = c.wakeups.load(Ordering::Relaxed);
            sample.late = c.late.load(Ordering::Relaxed);
            sample.skipped = c.skipped.load(Ordering::Relaxed);
            sample.wake_max_us = c.window_max_ns.swap(0, Ordering::Relaxed) as f64 / 1000.0;
        }
        Some(sample)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn stats_sample_takes_the_interval_maxima_and_the_totals() {
        let c = Arc::new(LoopCounters::default());
        let mut st = Stats::new(Duration::from_secs(10), Some(c.clone()));
        let t0 = Instant::now();
        assert_eq!(st.due(t0, 0), None);
        c.woke(300_000, false, 0);
        c.woke(2_500_000, true, 2);
        let mut s = Status::default();
        s.following_error[1] = -0.02;
        st.observe(&s);
        s.following_error[1] = f64::NAN;
        st.observe(&s);
        assert_eq!(st.due(t0 + Duration::from_secs(5), 7), None);
        let a = st.due(t0 + Duration::from_secs(25), 9).unwrap();
        assert_eq!((a.tick, a.wakeups, a.late, a.skipped), (9, 2, 1, 2));
        assert_eq!(a.wake_max_us, 2500.0);
        assert_eq!(a.following_error_max[1], 0.02);
        // The next interval starts empty; the grid stays at multiples of 10 s.
        assert_eq!(st.due(t0 + Duration::from_secs(29), 10), None);
        let b = st.due(t0 + Duration::from_secs(30), 11).unwrap();
        assert_eq!(
            (b.wakeups, b.wake_max_us, b.following_error_max[1]),
            (2, 0.0, 0.0)
        );
    }
}
