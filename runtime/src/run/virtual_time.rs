//! Virtual time for the embedded simulator: each tick right after the last, as fast as the CPU
//! allows, on the calling thread, which also drains the status ring between ticks. Time runs
//! only while the loop has something to do (so results do not depend on how fast the feeder
//! plans), and at the wall clock's pace while held at a program stop.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use cnc402_drives::Instant;
use nix::errno::Errno;

use super::cyclic::{ClockEnd, CycleClock, LoopState};
use super::side::Side;
use crate::controller::Step;
use crate::ring::{Observer, STATUS_RING, StatusConsumer};

/// Virtual time, and the reporting side it shares the thread with.
pub(super) struct VirtualClock<'s, 'a> {
    period: Duration,
    now: Instant,
    /// `now` when the cyclic phase began.
    cyclic_from: Instant,
    wall0: std::time::Instant,
    /// Polls in a row that found nothing to do (a few yields, then short sleeps).
    spins: u32,
    /// While held: when the hold began on the wall clock, and the ticks since.
    held_since: Option<(std::time::Instant, u32)>,
    /// The interpreter waited for motion when the last tick was taken.
    waiting: bool,
    /// A poll with nothing to do already found the feeder thread ended.
    feeder_ended_seen: bool,
    side: &'s mut Side<'a>,
    status: StatusConsumer,
    stop_request: Arc<AtomicBool>,
}

impl<'s, 'a> VirtualClock<'s, 'a> {
    /// Virtual time from zero at `period` a tick; `wall0` is when the run began.
    pub(super) fn new(
        period: Duration,
        wall0: std::time::Instant,
        side: &'s mut Side<'a>,
        status: StatusConsumer,
        stop_request: Arc<AtomicBool>,
    ) -> Self {
        VirtualClock {
            period,
            now: Instant::ZERO,
            cyclic_from: Instant::ZERO,
            wall0,
            spins: 0,
            held_since: None,
            waiting: false,
            feeder_ended_seen: false,
            side,
            status,
            stop_request,
        }
    }

    /// The reporting side (it starts the feeder when the drives are ready).
    pub(super) fn side(&mut self) -> &mut Side<'a> {
        self.side
    }

    /// Nothing to do yet: the feeder thread is still planning. Waits a little for it, and
    /// stops the machine if it ended without `End` (an error). The first time it is seen
    /// ended, the loop looks at the ring once more: the feeder may have pushed its last moves
    /// and `End` after the loop's state was taken and before it ended (that race stopped
    /// whole runs as an operator stop at line 0).
    fn wait_for_feeder(&mut self) {
        if self.side.feeder.as_ref().is_some_and(|h| h.is_finished()) {
            if self.feeder_ended_seen {
                self.stop_request.store(true, Ordering::SeqCst);
            }
            self.feeder_ended_seen = true;
            return;
        }
        self.spins += 1;
        if self.spins > 64 {
            std::thread::sleep(Duration::from_micros(50));
        } else {
            std::thread::yield_now();
        }
    }

    /// Held at a program stop: virtual time advances at the wall clock's pace (the drives
    /// hold position and stay monitored) until the operator resumes. Deadlines are absolute
    /// from the start of the hold, so a slow machine's long sleeps do not make the pause
    /// shorter in program time than it was on the clock.
    fn pace_hold(&mut self) {
        let (since, n) = self
            .held_since
            .get_or_insert_with(|| (std::time::Instant::now(), 0));
        *n += 1;
        let due = *since + self.period * *n;
        if let Some(left) = due.checked_duration_since(std::time::Instant::now()) {
            std::thread::sleep(left);
        }
    }
}

impl CycleClock for VirtualClock<'_, '_> {
    fn now(&self) -> Instant {
        self.now
    }

    fn wait_startup(&mut self) -> Result<(), Errno> {
        self.now += self.period;
        Ok(())
    }

    fn start_cyclic(&mut self) {
        self.cyclic_from = self.now;
    }

    fn next_tick(&mut self, state: LoopState) -> Result<Option<Instant>, Errno> {
        // Virtual time only runs while there is something to do: a move, a stop, the end, or
        // an interpreter waiting for the motion before a position read.
        self.waiting = self.side.shared.waiting.load(Ordering::SeqCst);
        if !state.has_work && (!self.waiting || self.side.shared.motion_done()) {
            self.wait_for_feeder();
            return Ok(None);
        }
        self.spins = 0;
        if state.held {
            self.pace_hold();
        } else {
            self.held_since = None;
        }
        self.now += self.period;
        Ok(Some(self.now))
    }

    fn ticked(&mut self, state: LoopState, step: &Step) {
        if self.waiting
            || state.held
            || self.status.occupied_len() >= STATUS_RING / 2
            || *step != Step::Continue
        {
            self.side.drain(&mut self.status);
        }
    }

    fn finish(&mut self) -> ClockEnd {
        self.side.drain(&mut self.status);
        ClockEnd {
            elapsed: self.now.saturating_since(self.cyclic_from),
            wall: self.wall0.elapsed(),
            latency: None,
            grant: None,
        }
    }
}
