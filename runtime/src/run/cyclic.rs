//! The one cyclic loop of a run, generic over its [`CycleClock`]: start-up attempts until the
//! drives are enabled, then one controller step per tick at the time the clock gives, until
//! the controller is done. Virtual time (the embedded simulator) and real time (a CAN socket,
//! or `--realtime`) differ only in their clock; the tick path allocates, logs and locks nothing
//! beyond what the clock itself does.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_drives::bus::BusCounters;
use nix::errno::Errno;

use super::error::RunError;
use crate::controller::{CycleController, Step};
use crate::link::{DriveLink, Startup};
use crate::program_stop::StopGate;
use crate::ring::{MoveConsumer, StatusProducer};
use crate::rt::LatencySummary;
use crate::status::Outcome;

/// Start-up may take this long (boot, SDO configuration, enable) before it is a fault.
pub(super) const STARTUP_LIMIT: Duration = Duration::from_secs(10);

/// What the loop tells its clock about the controller.
#[derive(Clone, Copy, Debug)]
pub(super) struct LoopState {
    /// The controller has a move, a stop or the end to work on.
    pub(super) has_work: bool,
    /// Holding at a program stop.
    pub(super) held: bool,
}

impl LoopState {
    fn of(ctrl: &CycleController<Box<dyn DriveLink>>) -> LoopState {
        LoopState {
            has_work: ctrl.has_work(),
            held: ctrl.is_held() || ctrl.is_feed_held(),
        }
    }
}

/// What a clock measured over the cyclic phase.
pub(super) struct ClockEnd {
    /// Time the cyclic phase took on the clock (the bus load is over it).
    pub(super) elapsed: Duration,
    /// Wall-clock time of the run as the report gives it.
    pub(super) wall: Duration,
    /// Wake-up latency (real time only).
    pub(super) latency: Option<LatencySummary>,
    /// The real-time privileges the loop got (real time only).
    pub(super) grant: Option<String>,
}

/// How time advances for the loop, and what runs beside it on the loop's thread.
pub(super) trait CycleClock {
    /// The time of the current start-up attempt, since the clock began.
    fn now(&self) -> Instant;
    /// Waits until the next start-up attempt is due.
    fn wait_startup(&mut self) -> Result<(), Errno>;
    /// The drives are enabled: the cyclic phase starts now.
    fn start_cyclic(&mut self);
    /// Waits until the next tick is due and returns its time; `None` when there is no tick
    /// to run yet (ask again). Called once per tick: it must not allocate, log or lock in
    /// real time.
    fn next_tick(&mut self, state: LoopState) -> Result<Option<Instant>, Errno>;
    /// After each tick, with the controller's state after it.
    fn ticked(&mut self, state: LoopState, step: &Step);
    /// The cyclic phase is over.
    fn finish(&mut self) -> ClockEnd;
}

/// What the loop side hands back at the end.
pub(super) struct LoopEnd {
    pub(super) outcome: Outcome,
    pub(super) ticks: u64,
    pub(super) starved: u64,
    pub(super) dropped: u64,
    /// Per axis, from the controller (exact even when status records were dropped).
    pub(super) max_following_error: [f64; MAX_AXES],
    /// Rigid-tap moves the controller started.
    pub(super) tap_moves: u64,
    /// Feed time, path deviation, exact stops (from the controller).
    pub(super) path: crate::path_figures::PathFigures,
    pub(super) counters: BusCounters,
    pub(super) bitrate: u32,
    pub(super) elapsed: Duration,
    pub(super) latency: Option<LatencySummary>,
    pub(super) grant: Option<String>,
    pub(super) wall: Duration,
    /// The drives could not be taken to rest after the run.
    pub(super) shutdown_error: Option<String>,
    /// Per axis, whether it had its machine reference.
    pub(super) homed: [bool; MAX_AXES],
    /// Feed holds, resumes and overrides the loop applied.
    pub(super) panel: crate::operator::PanelLog,
}

/// The loop's ends of the rings and its shared flags.
pub(super) struct LoopIo {
    pub(super) moves: MoveConsumer,
    pub(super) status: StatusProducer,
    /// Raised to stop the machine the way a fault does (SIGINT, a feeder gone).
    pub(super) stop_request: Arc<AtomicBool>,
    pub(super) gate: Arc<StopGate>,
    /// The operator's panel and a command file's triggered commands.
    pub(super) panel: Option<(Arc<crate::operator::Panel>, crate::operator::Schedule)>,
}

/// Starts `link` up and runs the cycle on it to the end, on `clock`. `ready` is called once
/// the drives are enabled, with the position they stand at (the feeder starts from there);
/// `wall0` is when the run began on the wall clock (a failed start-up reports from it).
pub(super) fn run_cyclic<C: CycleClock>(
    clock: &mut C,
    cfg: &MachineConfig,
    mut link: Box<dyn DriveLink>,
    io: LoopIo,
    wall0: std::time::Instant,
    ready: impl FnOnce(&mut C, &[f64; MAX_AXES]) -> Result<(), RunError>,
) -> Result<LoopEnd, RunError> {
    let start = loop {
        let now = clock.now();
        match link.startup(now) {
            Startup::Pending if now.nanos() < STARTUP_LIMIT.as_nanos() as u64 => {}
            Startup::Pending => {
                let why = Outcome::StartupFailed(startup_timeout());
                return Ok(failed_end(why, &*link, now, wall0));
            }
            Startup::Ready(p) => break p,
            // Start-up blocks (boot over a real bus): the bus load of its traffic is over the
            // time it took, not over the instant it began.
            Startup::Failed(s) => {
                let why = Outcome::StartupFailed(s);
                return Ok(failed_end(why, &*link, clock.now(), wall0));
            }
        }
        if let Err(e) = clock.wait_startup() {
            let _ = link.shutdown();
            return Err(RunError::clock(e));
        }
    };
    ready(clock, &start)?;
    clock.start_cyclic();
    let c0 = link.counters();
    let stop_request = io.stop_request;
    let mut ctrl =
        CycleController::new(cfg, start, link, io.moves, io.status, stop_request.clone())
            .with_stop_gate(io.gate);
    if let Some((panel, schedule)) = io.panel {
        ctrl = ctrl.with_panel(panel, schedule);
    }
    let outcome = loop {
        let tick = match clock.next_tick(LoopState::of(&ctrl)) {
            Ok(t) => t,
            Err(e) => {
                // No clock, no ticks: nothing can be timed, so the drives are disabled at
                // once (they stop on their own disable reaction) and the run ends.
                let _ = ctrl.link_mut().shutdown();
                return Err(RunError::clock(e));
            }
        };
        if crate::rt::sigint_seen() {
            stop_request.store(true, Ordering::SeqCst);
        }
        let Some(now) = tick else { continue };
        let step = ctrl.step(now);
        clock.ticked(LoopState::of(&ctrl), &step);
        if let Step::Done(o) = step {
            break o;
        }
    };
    let t = clock.finish();
    Ok(LoopEnd {
        latency: t.latency,
        grant: t.grant,
        ..cyclic_end(&mut ctrl, outcome, c0, t.elapsed, t.wall)
    })
}

fn startup_timeout() -> String {
    format!(
        "the drives were not enabled within {} s",
        STARTUP_LIMIT.as_secs()
    )
}

/// The end of a cyclic phase that ran: the controller's counters, the cyclic phase's bus
/// traffic since `c0` (disabling afterwards is not part of the bus load), then the drives
/// disabled.
fn cyclic_end(
    ctrl: &mut CycleController<Box<dyn DriveLink>>,
    outcome: Outcome,
    c0: BusCounters,
    elapsed: Duration,
    wall: Duration,
) -> LoopEnd {
    let counters = counters_since(ctrl.link().counters(), c0);
    let shutdown_error = ctrl.link_mut().shutdown().err();
    let bus = (counters, ctrl.link().bitrate(), ctrl.link().homed());
    LoopEnd {
        shutdown_error,
        ..controller_end(ctrl, outcome, bus, elapsed, wall)
    }
}

/// What `ctrl` counted over the cyclic phase, with the bus's `(counters, bitrate, homed)`.
pub(super) fn controller_end<L: DriveLink>(
    ctrl: &CycleController<L>,
    outcome: Outcome,
    bus: (BusCounters, u32, [bool; MAX_AXES]),
    elapsed: Duration,
    wall: Duration,
) -> LoopEnd {
    LoopEnd {
        outcome,
        ticks: ctrl.ticks(),
        starved: ctrl.starved_ticks(),
        dropped: ctrl.dropped_status(),
        max_following_error: ctrl.max_following_error(),
        tap_moves: ctrl.tap_moves(),
        path: ctrl.path_figures(),
        counters: bus.0,
        bitrate: bus.1,
        homed: bus.2,
        elapsed,
        latency: None,
        grant: None,
        wall,
        shutdown_error: None,
        panel: *ctrl.panel_log(),
    }
}

/// The end of a run whose drives never got enabled.
fn failed_end(
    outcome: Outcome,
    link: &dyn DriveLink,
    now: Instant,
    wall0: std::time::Instant,
) -> LoopEnd {
    LoopEnd {
        outcome,
        ticks: 0,
        starved: 0,
        dropped: 0,
        max_following_error: [0.0; MAX_AXES],
        tap_moves: 0,
        path: Default::default(),
        counters: link.counters(),
        bitrate: link.bitrate(),
        homed: link.homed(),
        elapsed: Duration::from_nanos(now.nanos()),
        latency: None,
        grant: None,
        wall: wall0.elapsed(),
        shutdown_error: None,
        panel: Default::default(),
    }
}

/// Counters of the cyclic phase only (boot traffic left out of the bus load).
pub(super) fn counters_since(end: BusCounters, start: BusCounters) -> BusCounters {
    BusCounters {
        tx_frames: end.tx_frames.saturating_sub(start.tx_frames),
        rx_frames: end.rx_frames.saturating_sub(start.rx_frames),
        bus_frames: end.bus_frames.saturating_sub(start.bus_frames),
        bus_bits: end.bus_bits.saturating_sub(start.bus_bits),
        dropped: end.dropped.saturating_sub(start.dropped),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ring::{LoopInput, Producer, move_ring, status_ring};

    /// A clock that has no tick ready at every other poll and fails at tick `fail_at`.
    #[derive(Default)]
    struct ScriptedClock {
        now: Instant,
        polls: u32,
        ticks: u32,
        ticked: u32,
        startup_waits: u32,
        fail_at: Option<u32>,
    }

    impl CycleClock for ScriptedClock {
        fn now(&self) -> Instant {
            self.now
        }
        fn wait_startup(&mut self) -> Result<(), Errno> {
            self.startup_waits += 1;
            self.now += Duration::from_millis(1);
            Ok(())
        }
        fn start_cyclic(&mut self) {}
        fn next_tick(&mut self, _: LoopState) -> Result<Option<Instant>, Errno> {
            self.polls += 1;
            if self.polls % 2 == 1 {
                return Ok(None);
            }
            self.ticks += 1;
            if Some(self.ticks) == self.fail_at {
                return Err(Errno::EINVAL);
            }
            self.now += Duration::from_millis(1);
            Ok(Some(self.now))
        }
        fn ticked(&mut self, _: LoopState, _: &Step) {
            self.ticked += 1;
        }
        fn finish(&mut self) -> ClockEnd {
            ClockEnd {
                elapsed: Duration::from_millis(self.ticked.into()),
                wall: Duration::ZERO,
                latency: None,
                grant: Some("scripted".into()),
            }
        }
    }

    /// Runs an empty program (only its end) on the bus-less model with `clock`.
    fn run(clock: &mut ScriptedClock) -> (Result<LoopEnd, RunError>, bool) {
        let cfg = MachineConfig::default_machine();
        let (mut moves_tx, moves) = move_ring(4);
        assert!(moves_tx.try_push(LoopInput::End).is_ok());
        let (status, _status_rx) = status_ring(1 << 12);
        let io = LoopIo {
            moves,
            status,
            stop_request: Arc::new(AtomicBool::new(false)),
            gate: Arc::new(StopGate::default()),
            panel: None,
        };
        let link = Box::new(crate::testing::model_link(&cfg, None));
        let mut ready = false;
        let wall0 = std::time::Instant::now();
        let r = run_cyclic(clock, &cfg, link, io, wall0, |_, _| {
            ready = true;
            Ok(())
        });
        (r, ready)
    }

    #[test]
    fn the_loop_steps_once_per_tick_its_clock_gives() {
        let mut clock = ScriptedClock::default();
        let (r, ready) = run(&mut clock);
        let end = r.expect("the run ended");
        assert!(ready && clock.startup_waits > 0);
        assert_eq!(end.outcome, Outcome::Finished);
        // Polls without a tick step nothing.
        assert_eq!((end.ticks, clock.ticked), (clock.ticks.into(), clock.ticks));
        assert_eq!(clock.polls, 2 * clock.ticks);
        assert_eq!(end.grant.as_deref(), Some("scripted"));
    }

    #[test]
    fn a_failing_clock_ends_the_run_with_a_clock_error() {
        let mut clock = ScriptedClock {
            fail_at: Some(2),
            ..ScriptedClock::default()
        };
        let (r, _) = run(&mut clock);
        assert!(matches!(r, Err(RunError::Clock(_))), "{:?}", r.err());
        assert_eq!(clock.ticked, 1);
    }
}
