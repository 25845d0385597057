//! Real time for a CAN socket (or `--realtime` on the simulator): ticks at absolute
//! CLOCK_MONOTONIC deadlines on the loop's own thread, each wake-up's lateness recorded, and a
//! wake-up a whole period late or more skipping the missed deadlines instead of bursting.

use std::sync::Arc;
use std::time::Duration;

use cnc402_drives::Instant;
use nix::errno::Errno;

use super::cyclic::{ClockEnd, CycleClock, LoopState};
use super::stats::LoopCounters;
use crate::controller::Step;
use crate::rt::{LatencyHistogram, RtGrant, monotonic_ns, sleep_until, tick_deadline};

/// CLOCK_MONOTONIC at a fixed period, from the moment it is made.
pub(super) struct RealTimeClock {
    period_ns: u64,
    /// CLOCK_MONOTONIC when the clock began (its `Instant::ZERO`).
    t0: u64,
    /// The deadline of the last start-up attempt or tick.
    next: u64,
    /// When the cyclic phase began, on CLOCK_MONOTONIC and on the wall clock.
    cyclic_from: (u64, std::time::Instant),
    latency: LatencyHistogram,
    /// Deadlines let pass (see `LatencySummary::skipped`).
    skipped: u64,
    grant: RtGrant,
    /// The same wake-ups, for the reporting side's periodic figures (`--stats-every`).
    counters: Arc<LoopCounters>,
}

impl RealTimeClock {
    /// A clock ticking every `period_ns` from now; `grant` is what the loop thread was given;
    /// each wake-up is also counted in `counters`.
    pub(super) fn new(
        period_ns: u64,
        grant: RtGrant,
        counters: Arc<LoopCounters>,
    ) -> RealTimeClock {
        let t0 = monotonic_ns();
        RealTimeClock {
            period_ns,
            t0,
            next: t0,
            cyclic_from: (t0, std::time::Instant::now()),
            latency: LatencyHistogram::new(5000, period_ns / 2),
            skipped: 0,
            grant,
            counters,
        }
    }
}

impl CycleClock for RealTimeClock {
    fn now(&self) -> Instant {
        Instant::from_nanos(monotonic_ns().saturating_sub(self.t0))
    }

    fn wait_startup(&mut self) -> Result<(), Errno> {
        self.next += self.period_ns;
        sleep_until(self.next)
    }

    fn start_cyclic(&mut self) {
        // Start-up on a real bus blocks for seconds (boot, SDO, enable): the cyclic deadlines
        // start from now, not from before it (no burst of catch-up ticks).
        self.next = self.next.max(monotonic_ns());
        self.cyclic_from = (monotonic_ns(), std::time::Instant::now());
    }

    fn next_tick(&mut self, _: LoopState) -> Result<Option<Instant>, Errno> {
        self.next += self.period_ns;
        sleep_until(self.next)?;
        let woke = monotonic_ns();
        let latency_ns = woke.saturating_sub(self.next);
        self.latency.record(latency_ns);
        // Missed whole deadlines: this tick runs now and the next is a period later.
        let (at, missed) = tick_deadline(self.next, woke, self.period_ns);
        // Same late threshold as the histogram's (half a period).
        self.counters
            .woke(latency_ns, latency_ns > self.period_ns / 2, missed);
        self.next = at;
        self.skipped += missed;
        // The cycle's time is its deadline (the master's contract); lateness is measured.
        Ok(Some(Instant::from_nanos(self.next.saturating_sub(self.t0))))
    }

    fn ticked(&mut self, _: LoopState, _: &Step) {}

    fn finish(&mut self) -> ClockEnd {
        let wall = self.cyclic_from.1.elapsed();
        let elapsed = Duration::from_nanos(monotonic_ns().saturating_sub(self.cyclic_from.0));
        let mut latency = self.latency.summary();
        latency.skipped = self.skipped;
        ClockEnd {
            elapsed,
            wall,
            latency: Some(latency),
            grant: Some(self.grant.describe()),
        }
    }
}
