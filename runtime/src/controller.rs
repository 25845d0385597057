//! The cycle controller: the code that runs once per period, the same in virtual and real
//! time. It takes planned moves from the move ring, ticks the interpolator, exchanges
//! setpoints for feedback through the [`DriveLink`], runs the stop sequence, and pushes one
//! [`Status`] per tick into the status ring. It never allocates, logs, locks or reads a clock:
//! `now` is passed in.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use cnc402_config::{AxisKind, MAX_AXES, MAX_SPINDLES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_motion::{AxisPos, Interpolator, MoveKind};

use crate::link::{DriveFeedback, DriveLink, DriveStop, StopCause};
use crate::matching::Matching;
use crate::ring::{Consumer, LoopInput, MoveConsumer, Observer, Producer, StatusProducer};
use crate::status::{Outcome, Phase, Status, TapCoupling, within_one_count};

/// Ticks the drives get to come to rest after the last setpoint before the run ends.
pub const SETTLE_TICKS: u32 = 50;
/// Ticks quick stop may take before the run ends anyway.
pub const QUICK_STOP_TICKS: u32 = 500;

/// Most moves started in one tick: blended moves shorter than a period pass between samples
/// (at 0.01 mm blocks and 100 mm/s, ten a tick); past this the path pauses a tick.
pub const MOVES_PER_TICK: u32 = 256;

/// What one [`CycleController::step`] left behind.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Keep calling `step` every period.
    Continue,
    /// The cyclic phase is over.
    Done(Outcome),
}

/// Per-axis constants the loop needs, copied out of the config once.
#[derive(Clone, Copy, Debug)]
pub struct AxisTable {
    pub n: usize,
    pub counts_per_unit: [f64; MAX_AXES],
    pub linear: [bool; MAX_AXES],
    /// Spindle 1's axis.
    pub spindle: Option<usize>,
    /// Every spindle's axis, by number − 1.
    pub spindles: [Option<usize>; MAX_SPINDLES],
    /// CANopen node of each axis's drive (0: none).
    pub nodes: [u8; MAX_AXES],
    /// The drive's dead time in cycles (config `feedback_delay_cycles`, 0–16: the same figure
    /// the master's following-error rule uses; the simulator's `sim.delay_cycles` only
    /// describes the simulated drive).
    pub delay_cycles: [u32; MAX_AXES],
}

impl AxisTable {
    /// From the config.
    pub fn new(cfg: &MachineConfig) -> AxisTable {
        let n = cfg.axes.len().min(MAX_AXES);
        let mut counts_per_unit = [1.0; MAX_AXES];
        let mut linear = [false; MAX_AXES];
        let mut nodes = [0u8; MAX_AXES];
        let mut delay_cycles = [0u32; MAX_AXES];
        for (i, a) in cfg.axes.iter().take(n).enumerate() {
            counts_per_unit[i] = a.counts_per_unit;
            linear[i] = a.kind == AxisKind::Linear;
            nodes[i] = a.node.unwrap_or(0);
            delay_cycles[i] = a.feedback_delay_cycles;
        }
        AxisTable {
            n,
            counts_per_unit,
            linear,
            spindle: cfg.spindle_index().filter(|&i| i < n),
            spindles: cfg.spindle_axes().map(|a| a.filter(|&i| i < n)),
            nodes,
            delay_cycles,
        }
    }
}

/// See the module doc.
pub struct CycleController<L: DriveLink> {
    interp: Interpolator,
    axes: AxisTable,
    moves: MoveConsumer,
    status: StatusProducer,
    link: L,
    stop_request: Arc<AtomicBool>,
    tick: u64,
    phase: Phase,
    phase_ticks: u32,
    input_done: bool,
    tap: Option<TapCoupling>,
    /// The path's setpoints (and a tap follower's): what the status shows.
    commands: [f64; MAX_AXES],
    /// What the drives get: `commands` with the matched axes (a tap's, the contouring set)
    /// shaped by `matching`.
    sent: [f64; MAX_AXES],
    matching: Matching,
    feedback: [DriveFeedback; MAX_AXES],
    /// The first stop, the line executing then and its move number.
    stop: Option<(DriveStop, u32, u64)>,
    motion_error: Option<cnc402_motion::MotionError>,
    starved: u64,
    dropped: u64,
    /// Largest |following error| per axis over every tick, kept here so that it is exact
    /// even when status records are dropped.
    max_following_error: [f64; MAX_AXES],
    /// Rigid-tap moves started (coupled spindle and tool axis).
    tap_moves: u64,
    last_line: u32,
    moves_started: u64,
    /// Tool and spindle command at the start of the current tap move.
    tap_anchor: (f64, f64),
    /// Set when the spindle or the tool axis drive itself stops during a tap: the other
    /// axis of the pair follows its actual position instead of the path (see `follow_actual`).
    follow: Option<TapFollow>,
    /// Each spindle's actual motion (by number − 1), tracked in every mode.
    spindle_tracks: [SpindleTrack; MAX_SPINDLES],
    /// The tool axis's actual motion during a tap (for a follow led by the tool axis).
    tool_track: SpindleTrack,
    /// Program stops (M0/M1): `None` passes them (log and go on).
    gate: Option<Arc<crate::program_stop::StopGate>>,
    /// Holding at a program stop until the gate releases it.
    held: bool,
    /// A manual tool change's hold ended this tick and the tool was clamped: the next block
    /// starts on the next tick (clamp first, and the report names the M6's line for it
    /// whenever the operator's answer came).
    clamped_now: bool,
    /// Feed time, path deviation and exact stops (the report's path figures).
    path: crate::path_figures::PathTracker,
    /// Feed hold and overrides: the operator's panel, its triggered commands, what the loop
    /// applied last and the record of it (see `take_panel`).
    panel: Option<Arc<crate::operator::Panel>>,
    schedule: crate::operator::Schedule,
    applied: crate::operator::PanelState,
    panel_log: crate::operator::PanelLog,
    period_us: u64,
    last_n: Option<u32>,
    /// The panel change applied this tick, for the status (and so the trace).
    panel_now: Option<crate::operator::PanelAction>,
    /// Coolant, spindle enable and tool clamp as the program sets them.
    outputs: crate::machine_io::LoopOutputs,
    /// Wait marks hold (a channel of several); off, they pass as on a one-channel machine.
    wait_marks: bool,
    /// At rest at a wait mark `(mark, channels)` until the channel set releases it.
    mark: Option<(u16, u16)>,
    /// A channel reset: the path stops, queued moves are dropped, the channel stays running.
    discarding: bool,
}

/// One axis of a tap slaved to the other's actual position after that one's drive stopped
/// following (fault, reboot, lost SYNC or feedback), so that the thread stays coupled while
/// the leader brakes on its own: the tool axis after the spindle (the usual case), or the
/// spindle after the tool axis.
#[derive(Clone, Copy, Debug)]
struct TapFollow {
    c: TapCoupling,
    anchor: (f64, f64),
    /// The spindle leads (the tool axis follows); else the tool axis leads.
    spindle_leads: bool,
}

/// Cycles over which a leader's motion is extrapolated past its last sample: its feedback
/// normally lags one or two cycles; when it stops coming (a drive that rebooted or lost
/// SYNC stands still), extrapolating further would drive the follower away on a stale
/// velocity.
const MAX_EXTRAPOLATION_TICKS: u64 = 2;

/// An axis's actual motion as the feedback shows it: last sample, the tick it was taken
/// at (tick − age), and its velocity in units per cycle.
#[derive(Clone, Copy, Debug, Default)]
struct SpindleTrack {
    last: Option<(u64, f64)>,
    velocity: f64,
}

impl<L: DriveLink> CycleController<L> {
    /// A controller holding `start` (machine position the drives reported at enable, axis
    /// units), so that the first setpoint is where each drive stands. It reads moves from
    /// `moves` and writes status to `status`; `stop_request` is polled every tick (SIGINT).
    pub fn new(
        cfg: &MachineConfig,
        start: [f64; MAX_AXES],
        link: L,
        moves: MoveConsumer,
        status: StatusProducer,
        stop_request: Arc<AtomicBool>,
    ) -> CycleController<L> {
        let axes = AxisTable::new(cfg);
        let start = start_position(&axes, &start);
        let mut feedback = [DriveFeedback::default(); MAX_AXES];
        for (f, &p) in feedback.iter_mut().zip(&start.0).take(axes.n) {
            f.actual = p;
        }
        CycleController {
            interp: Interpolator::new(cfg, start),
            axes,
            moves,
            status,
            link,
            stop_request,
            tick: 0,
            phase: Phase::Running,
            phase_ticks: 0,
            input_done: false,
            tap: None,
            commands: start.0,
            sent: start.0,
            matching: Matching::new(cfg, &start.0),
            feedback,
            stop: None,
            motion_error: None,
            starved: 0,
            dropped: 0,
            max_following_error: [0.0; MAX_AXES],
            tap_moves: 0,
            last_line: 0,
            moves_started: 0,
            tap_anchor: (0.0, 0.0),
            follow: None,
            spindle_tracks: [SpindleTrack::default(); MAX_SPINDLES],
            tool_track: SpindleTrack::default(),
            gate: None,
            held: false,
            clamped_now: false,
            path: Default::default(),
            panel: None,
            schedule: Default::default(),
            applied: Default::default(),
            panel_log: Default::default(),
            period_us: u64::from(cfg.bus.period_us),
            last_n: None,
            panel_now: None,
            outputs: crate::machine_io::LoopOutputs::new(cfg),
            wait_marks: false,
            mark: None,
            discarding: false,
        }
    }

    /// Holds at wait marks (`StopKind::WaitMark`) until [`release_mark`](Self::release_mark):
    /// a channel of a machine with several.
    pub fn with_wait_marks(mut self) -> Self {
        self.wait_marks = true;
        self
    }

    /// The wait mark this controller holds at, `(mark, channel bits)`, if any.
    pub fn at_mark(&self) -> Option<(u16, u16)> {
        self.mark.filter(|_| self.phase == Phase::Running)
    }

    /// A channel reset (`on`): the path decelerates to rest and every queued move is
    /// dropped (counted as started, so the feeder's motion sync sees them done) until it is
    /// turned off; the controller stays in the running phase and takes moves again after.
    pub fn set_discarding(&mut self, on: bool) {
        if on && !self.discarding && !self.interp.is_idle() {
            self.interp.request_stop();
        }
        self.discarding = on;
    }

    /// Drops the queued moves and ends a reset's stop once at rest (see `set_discarding`).
    fn discard(&mut self) {
        while let Some(input) = self.moves.try_pop() {
            if let LoopInput::Move(_) = input {
                self.moves_started += 1;
            }
        }
        self.mark = None;
        self.held = false;
        if self.interp.is_held() {
            self.interp.clear_stop();
        }
    }

    /// The other channels reached the mark: the next move starts on the next period.
    pub fn release_mark(&mut self) {
        self.mark = None;
    }

    /// The program is over or stopping: no more moves will start (a channel waiting for
    /// this one waits forever).
    pub fn is_ending(&self) -> bool {
        self.phase != Phase::Running || (self.input_done && self.interp.is_idle())
    }

    /// Running, idle, nothing queued, not held: a resident channel between programs.
    pub fn is_at_rest(&self) -> bool {
        self.phase == Phase::Running
            && self.interp.is_idle()
            && self.moves.is_empty()
            && !self.held
            && self.mark.is_none()
    }

    /// The first stop of this run (a drive's, the operator's, a motion error's), with the
    /// line executing then.
    pub fn first_stop(&self) -> Option<(DriveStop, u32)> {
        if let Some(e) = self.motion_error {
            return Some((stop_without_drive(StopCause::Motion), e.line));
        }
        self.stop.map(|(s, line, _)| (s, line))
    }

    /// The line of the move executing.
    pub fn line(&self) -> u32 {
        self.last_line
    }

    /// Stops this controller's motion along its path for `stop` (another channel's fault,
    /// a deadlock), as a safety reaction of its own would.
    pub fn stop_for(&mut self, stop: DriveStop) {
        self.begin_stop(stop);
    }

    /// Takes feed hold, resume and overrides from `panel` (set at once from the terminal)
    /// and from `schedule` (a command file's triggered commands), each tick.
    pub fn with_panel(
        mut self,
        panel: Arc<crate::operator::Panel>,
        schedule: crate::operator::Schedule,
    ) -> Self {
        self.panel = Some(panel);
        self.schedule = schedule;
        self
    }

    /// The panel changes applied so far (hold, resume, overrides) with their tick and line.
    pub fn panel_log(&self) -> &crate::operator::PanelLog {
        &self.panel_log
    }

    /// In a feed hold with the path at rest and no triggered command left to end it: the
    /// operator holds, as at a program stop (virtual time paces itself to the wall clock).
    pub fn is_feed_held(&self) -> bool {
        self.applied.hold
            && self.interp.is_feed_held()
            && self.schedule.pending() == 0
            && self.phase == Phase::Running
    }

    /// Holds at program stops as `gate` says (M0, M1 with optional stop): with `Wait` the
    /// next move is not started until the gate is released (setpoints hold, the drives stay
    /// enabled and monitored); with `End` the program ends there (settle, `Finished`).
    pub fn with_stop_gate(mut self, gate: Arc<crate::program_stop::StopGate>) -> Self {
        self.gate = Some(gate);
        self
    }

    /// Holding at a program stop.
    pub fn is_held(&self) -> bool {
        self.held && self.phase == Phase::Running
    }

    /// Ticks in which the interpolator had nothing to do while the program was not over (the
    /// feeder fell behind). Harmless between exact-stop moves, but counted.
    pub fn starved_ticks(&self) -> u64 {
        self.starved
    }

    /// Status records lost because the status ring was full.
    pub fn dropped_status(&self) -> u64 {
        self.dropped
    }

    /// Rigid-tap moves started so far (counted here, so known even when status records that
    /// would show the tap windows were dropped).
    pub fn tap_moves(&self) -> u64 {
        self.tap_moves
    }

    /// Feed time, path deviation and exact stops over every tick so far (exact whatever
    /// [`dropped_status`](Self::dropped_status) says).
    pub fn path_figures(&self) -> crate::path_figures::PathFigures {
        self.path.figures
    }

    /// Largest |following error| per axis (axis units) over every tick so far, as the link's
    /// monitor saw it: exact whatever [`dropped_status`](Self::dropped_status) says.
    pub fn max_following_error(&self) -> [f64; MAX_AXES] {
        self.max_following_error
    }

    /// Whether a tick now would do anything but hold position waiting for the feeder: a
    /// move runs or is queued, the program is over, or a stop is under way or requested.
    /// The virtual-time driver steps only then, so virtual time does not depend on how fast
    /// the feeder thread is.
    pub fn has_work(&self) -> bool {
        if self.short_of_moves() {
            return false;
        }
        self.phase != Phase::Running
            || self.held
            || self.applied.hold
            || self.mark.is_some()
            || self.input_done
            || !self.interp.is_idle()
            || !self.moves.is_empty()
            || self.stop_request.load(Ordering::Relaxed)
            || self.matching.is_active()
    }

    /// The path is at speed between two blended moves and the ring may not hold the moves the
    /// next tick runs through (moves shorter than a period pass several a tick): it is neither
    /// full nor holding the end of the blended chain (see `ends_the_chain`; the feeder stops
    /// pushing before a buffer stop such as M0, so waiting for more would wait forever). A
    /// tick now could pause the path for want of a move; virtual time waits for the feeder
    /// instead, so a G64 run on the embedded simulator does not depend on how fast the feeder
    /// thread plans. Allocation-free; the ring is scanned only between blended moves.
    pub fn short_of_moves(&self) -> bool {
        self.phase == Phase::Running
            && !self.held
            && !self.input_done
            && self.interp.needs_next_move()
            && !self.moves.is_full()
            && !self.moves.iter().any(ends_the_chain)
    }

    /// Ticks run so far.
    pub fn ticks(&self) -> u64 {
        self.tick
    }

    /// The drive link (for counters after the run).
    pub fn link(&self) -> &L {
        &self.link
    }

    /// Gives the drive link back (after the run).
    pub fn into_link(self) -> L {
        self.link
    }

    /// The drive link, mutable (shutdown after the run).
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }

    /// Runs one period at `now`: [`prepare`](Self::prepare), the exchange with the drive
    /// link, [`complete`](Self::complete). Allocation-free.
    pub fn step(&mut self, now: Instant) -> Step {
        let t = self.prepare();
        let (raised, all_stopped) = if self.wants_quick_stop() {
            (None, self.link.quick_stop(now, &mut self.feedback))
        } else {
            (
                self.link.cycle(now, &self.sent, &mut self.feedback).err(),
                false,
            )
        };
        self.complete(&t, raised, all_stopped)
    }

    /// The part of a period before the exchange with the drives: requests, the next moves,
    /// the interpolator's tick and the setpoints to send ([`sent`](Self::sent)). A loop of
    /// several channels prepares each, exchanges once for all, then completes each.
    pub fn prepare(&mut self) -> cnc402_motion::Tick {
        self.take_requests();
        self.take_panel();
        if self.discarding && self.phase == Phase::Running {
            self.discard();
        }
        let free = !self.held && self.mark.is_none() && !self.discarding;
        if self.phase == Phase::Running && free && !std::mem::take(&mut self.clamped_now) {
            // A blended move shorter than the rest of the period passes between two samples
            // (the interpolator stays idle): start moves until one takes this tick (none from
            // rest in a feed hold).
            let mut started = 0;
            while self.interp.is_idle()
                && started < MOVES_PER_TICK
                && !self.feed_hold_keeps_back()
                && self.next_move()
            {
                started += 1;
            }
        } else if self.phase == Phase::Stopping {
            // A stop ramp that runs on along the blended moves after the current one.
            let mut started = 0;
            while self.interp.wants_next_move() && started < MOVES_PER_TICK && self.next_move() {
                started += 1;
            }
        }

        let t = self.interp.tick();
        if let Some(cnc402_motion::MoveEvent::ProgramStop { kind }) = t.event {
            self.program_stop(kind);
        }
        if self.outputs.event(t.event, &mut self.link) {
            // A manual tool change holds as M0 does (unless the gate passes it).
            self.program_stop(cnc402_motion::StopKind::Program);
            if !self.held {
                self.outputs.hold_ended(&mut self.link);
            }
        }
        if self.input_done && self.interp.is_idle() {
            self.outputs.program_done(&mut self.link);
        }
        self.last_line = t.line;
        self.last_n = t.n;
        self.commands = t.pos.0;
        if let Some(f) = &self.follow {
            let (i, v) = follow_actual(
                f,
                [&self.tool_track, self.spindle_track_of(f.c.spindle)],
                &self.axes,
                self.tick,
                &self.feedback,
            );
            self.commands[i] = v;
            // The follower meets the leader's actual position by its own model.
            self.matching.cancel(i);
        }
        self.sent = self.commands;
        let tapping = self.tap.is_some() && !self.interp.is_idle() && !self.interp.is_held();
        self.matching.apply(&mut self.sent, tapping);
        t
    }

    /// The setpoints [`prepare`](Self::prepare) made for the drives (axis units, this
    /// controller's axis order).
    pub fn sent(&self) -> &[f64; MAX_AXES] {
        &self.sent
    }

    /// The drives' feedback for this period, filled by the exchange before
    /// [`complete`](Self::complete).
    pub fn feedback_mut(&mut self) -> &mut [DriveFeedback; MAX_AXES] {
        &mut self.feedback
    }

    /// The drives are to get quick stop this period instead of setpoints.
    pub fn wants_quick_stop(&self) -> bool {
        self.phase == Phase::QuickStop
    }

    /// The part of a period after the exchange: `raised` is the safety reaction the link
    /// returned, `all_stopped` whether every drive reported standstill in a quick stop.
    pub fn complete(
        &mut self,
        t: &cnc402_motion::Tick,
        raised: Option<DriveStop>,
        all_stopped: bool,
    ) -> Step {
        self.track_spindle();
        if let Some(s) = raised {
            self.begin_stop(s);
        }
        self.follow_if_left_enabled();
        self.path.sample(
            &self.axes.linear[..self.axes.n],
            &self.commands,
            t.path_velocity,
            t.state,
            self.follow.is_some(),
        );
        if self.contouring() {
            let act = std::array::from_fn(|i| self.feedback[i].actual);
            let age = std::array::from_fn(|i| self.feedback[i].age);
            let linear = &self.axes.linear[..self.axes.n];
            self.path.sample_actual(linear, &act, &age, self.tick);
        }
        self.publish_status(t, raised);
        self.tick += 1;
        self.phase_ticks = self.phase_ticks.saturating_add(1);
        self.advance_phase(all_stopped)
    }

    /// The operator's stop request, and the release (or end) of a hold at a program stop.
    #[inline]
    fn take_requests(&mut self) {
        if self.phase == Phase::Running && self.stop_request.load(Ordering::Relaxed) {
            self.begin_stop(stop_without_drive(StopCause::Operator));
        }
        // Held at a program stop: released by the operator's resume, or ended there.
        if self.held
            && let Some(g) = &self.gate
        {
            if g.end_requested() {
                self.held = false;
                self.input_done = true;
            } else if g.released() {
                self.held = false;
            }
            if !self.held {
                self.clamped_now = self.outputs.hold_ended(&mut self.link);
            }
        }
    }

    /// The panel's triggered commands due now, then whatever changed on the panel, applied
    /// to the interpolator and recorded (atomics and fixed-size tables only).
    #[inline]
    fn take_panel(&mut self) {
        let Some(panel) = &self.panel else {
            return;
        };
        if self.phase != Phase::Running {
            return;
        }
        let micros = self.tick.saturating_mul(self.period_us);
        self.schedule.take_due(micros, self.last_n, |s| {
            panel.apply(s.command.action, s.input_line)
        });
        let now = panel.state();
        if now == self.applied {
            if self.is_feed_held() && panel.is_closed() {
                // End of the operator's input in a feed hold: nobody can resume; the
                // program ends here (a controlled stop, already at rest).
                self.begin_stop(stop_without_drive(StopCause::Operator));
            }
            return;
        }
        use crate::operator::PanelAction;
        let mut changes = [None; 4];
        if now.hold != self.applied.hold {
            self.interp.set_feed_hold(now.hold);
            changes[0] = Some(if now.hold {
                PanelAction::Hold
            } else {
                PanelAction::Resume
            });
        }
        if now.feed != self.applied.feed {
            self.interp.set_feed_override(f64::from(now.feed) / 100.0);
            changes[1] = Some(PanelAction::Feed(now.feed));
        }
        if now.spindle != self.applied.spindle {
            self.interp
                .set_spindle_override(f64::from(now.spindle) / 100.0);
            changes[2] = Some(PanelAction::Spindle(now.spindle));
        }
        if now.rapid != self.applied.rapid {
            self.interp.set_rapid_override(f64::from(now.rapid) / 100.0);
            changes[3] = Some(PanelAction::Rapid(now.rapid));
        }
        let input_line = panel.input_line();
        for action in changes.into_iter().flatten() {
            self.panel_now = Some(action);
            self.panel_log.push(crate::operator::PanelEvent {
                action,
                tick: self.tick,
                line: self.last_line,
                n: self.last_n,
                input_line,
            });
        }
        self.applied = now;
    }

    /// A feed hold keeps the next move of the ring from starting (see
    /// `Interpolator::holds_before`: the path is at rest, and it is not a tap's tap out).
    #[inline]
    fn feed_hold_keeps_back(&self) -> bool {
        if !self.applied.hold {
            return false;
        }
        match self.moves.iter().next() {
            Some(LoopInput::Move(m)) => self.interp.holds_before(m),
            _ => false,
        }
    }

    /// A program stop (M0, M1 with optional stop) of `kind` reached: the interpolator is idle
    /// after it, so holding here means no next move is started (atomics only, no lock or
    /// allocation).
    #[inline]
    fn program_stop(&mut self, kind: cnc402_motion::StopKind) {
        if let cnc402_motion::StopKind::WaitMark { mark, channels } = kind
            && self.wait_marks
            && self.phase == Phase::Running
        {
            self.mark = Some((mark, channels));
            return;
        }
        let Some(g) = &self.gate else {
            return;
        };
        if self.phase != Phase::Running {
            return;
        }
        match g.decide_at(kind, self.moves_started) {
            crate::program_stop::StopDecision::Hold => {
                g.hold();
                self.held = true;
            }
            crate::program_stop::StopDecision::End => self.input_done = true,
            crate::program_stop::StopDecision::Continue
            | crate::program_stop::StopDecision::Pass => {}
        }
    }

    /// Every spindle's (and in a tap the tool axis's) actual velocity from its feedback,
    /// per tick, updated when the drive has sampled a newer position.
    #[inline]
    fn track_spindle(&mut self) {
        for (track, axis) in self.spindle_tracks.iter_mut().zip(self.axes.spindles) {
            if let Some(sp) = axis {
                track.update(&self.feedback[sp], self.tick);
            }
        }
        if let Some(c) = self.tap.or(self.follow.map(|f| f.c)) {
            self.tool_track
                .update(&self.feedback[c.tool as usize], self.tick);
        }
    }

    /// The track of the spindle on axis `axis` (a tap's `TapCoupling::spindle`).
    #[inline]
    fn spindle_track_of(&self, axis: u8) -> &SpindleTrack {
        let k = self
            .axes
            .spindles
            .iter()
            .position(|&a| a == Some(usize::from(axis)))
            .unwrap_or(0);
        &self.spindle_tracks[k]
    }

    /// Records this tick's status (a full ring drops it, counted) and the largest following
    /// errors.
    #[inline]
    fn publish_status(&mut self, t: &cnc402_motion::Tick, raised: Option<DriveStop>) {
        let mut st = Status {
            tick: self.tick,
            line: t.line,
            phase: self.phase,
            cmd: self.commands,
            cmd_counts: [0; MAX_AXES],
            act: [0.0; MAX_AXES],
            act_counts: [0; MAX_AXES],
            following_error: [0.0; MAX_AXES],
            age: [0; MAX_AXES],
            statusword: [0; MAX_AXES],
            event: t.event,
            tap: if t.state == cnc402_motion::TickState::Moving || self.phase == Phase::Stopping {
                self.tap
            } else {
                None
            },
            stop: raised,
            moves_started: self.moves_started,
            idle: self.interp.is_idle(),
            spindle_follow: self.follow.is_some(),
            panel: self.panel_now.take(),
            outputs: self.outputs.state,
        };
        for i in 0..self.axes.n {
            let f = &self.feedback[i];
            st.act[i] = f.actual;
            // The link's exact counts: the master scaled the command once and holds the
            // unwrapped actual count.
            st.cmd_counts[i] = f.target;
            st.act_counts[i] = f.actual_counts as i32;
            st.following_error[i] = f.following_error;
            let fe = f.following_error.abs();
            if fe.is_finite() && fe > self.max_following_error[i] {
                self.max_following_error[i] = fe;
            }
            st.age[i] = f.age;
            st.statusword[i] = f.statusword;
        }
        if self.status.try_push(st).is_err() {
            self.dropped += 1;
        }
    }

    /// The phase this tick ends in, and whether the run is over (`all_stopped`: every drive
    /// reported standstill in a quick stop).
    #[inline]
    fn advance_phase(&mut self, all_stopped: bool) -> Step {
        match self.phase {
            Phase::Running => {
                if self.input_done && self.interp.is_idle() {
                    self.enter(Phase::Settling);
                }
                Step::Continue
            }
            Phase::Stopping => {
                // Shaped setpoints catch up with the held path first (bounded: see
                // `Matching::is_active`).
                if self.interp.is_held() && !self.matching.is_active() {
                    self.enter(Phase::QuickStop);
                }
                Step::Continue
            }
            Phase::QuickStop => {
                if all_stopped || self.phase_ticks >= QUICK_STOP_TICKS {
                    Step::Done(self.outcome())
                } else {
                    Step::Continue
                }
            }
            Phase::Settling => {
                // The last setpoint is the program's end exactly, shaped or not.
                if (self.phase_ticks >= SETTLE_TICKS || self.settled())
                    && !self.matching.is_active()
                {
                    Step::Done(Outcome::Finished)
                } else {
                    Step::Continue
                }
            }
        }
    }

    fn outcome(&self) -> Outcome {
        if let Some(error) = self.motion_error {
            return Outcome::MotionFailed { error };
        }
        match self.stop {
            Some((stop, line, move_index)) => Outcome::Stopped {
                stop,
                line,
                move_index,
            },
            None => Outcome::Finished,
        }
    }

    fn enter(&mut self, phase: Phase) {
        self.phase = phase;
        self.phase_ticks = 0;
    }

    /// Whether the drives are still following the path as a contour: not once a drive stopped
    /// following (only an operator's stop decelerates along the path), nor in the quick
    /// stop, nor while a tap's axis follows a stopped drive.
    fn contouring(&self) -> bool {
        let path_kept = self
            .stop
            .is_none_or(|(s, _, _)| s.cause == StopCause::Operator);
        path_kept && self.phase != Phase::QuickStop && self.follow.is_none()
    }

    /// Every drive's actual position is within one count of its last setpoint.
    fn settled(&self) -> bool {
        (0..self.axes.n).all(|i| {
            let f = &self.feedback[i];
            within_one_count(f.actual_counts as i32, f.target)
        })
    }

    fn begin_stop(&mut self, stop: DriveStop) {
        self.mark = None;
        if self.stop.is_none() && self.motion_error.is_none() {
            self.stop = Some((stop, self.last_line, self.moves_started));
        }
        // A drive that only sent an EMCY still follows the path (the master keeps it so)
        // until its statusword shows otherwise (`follow_if_left_enabled`).
        if stop.cause != StopCause::Emergency {
            self.follow_node(stop.node);
        }
        if matches!(self.phase, Phase::Running | Phase::Settling) {
            self.interp.request_stop();
            self.enter(Phase::Stopping);
        }
    }

    /// The drive at `node` itself stopped following in the middle of a tap: if it is the
    /// spindle's or the tool axis's, its setpoints no longer move it, so the other axis of
    /// the pair follows where it actually is.
    fn follow_node(&mut self, node: u8) {
        if let Some(c) = self.tap
            && self.follow.is_none()
            && node != 0
            && !self.interp.is_idle()
        {
            let spindle_leads = node == self.axes.nodes[c.spindle as usize];
            if spindle_leads || node == self.axes.nodes[c.tool as usize] {
                self.follow = Some(TapFollow {
                    c,
                    anchor: self.tap_anchor,
                    spindle_leads,
                });
            }
        }
    }

    /// After an EMCY stop, the drive that sent it may go on to show FAULT (or leave
    /// OPERATION ENABLED) a cycle later: from then on it no longer follows.
    fn follow_if_left_enabled(&mut self) {
        let Some((stop, _, _)) = self.stop else {
            return;
        };
        // Only while the path decelerates: the quick stop at rest takes every drive out of
        // OPERATION ENABLED anyway.
        if self.phase != Phase::Stopping
            || self.follow.is_some()
            || stop.cause != StopCause::Emergency
            || stop.node == 0
        {
            return;
        }
        let Some(i) = (0..self.axes.n).find(|&i| self.axes.nodes[i] == stop.node) else {
            return;
        };
        let state = cia402::Statusword(self.feedback[i].statusword).state();
        if state != Some(cia402::State::OperationEnabled) {
            self.follow_node(stop.node);
        }
    }

    /// Starts the next move of the ring; false when there was none (or only `End`).
    fn next_move(&mut self) -> bool {
        match self.moves.try_pop() {
            Some(LoopInput::Move(mv)) => {
                self.moves_started += 1;
                self.outputs.move_started(&mv.kind, &mut self.link);
                self.tap = match &mv.kind {
                    MoveKind::Path(p) => p.tap,
                    _ => None,
                };
                self.path.started(match &mv.kind {
                    MoveKind::Path(p) => Some(p),
                    _ => None,
                });
                if let Some(c) = self.tap {
                    self.tap_moves += 1;
                    self.tap_anchor = (
                        self.commands[c.tool as usize],
                        self.commands[c.spindle as usize],
                    );
                    self.matching.start(c, &self.commands);
                }
                if let Err(e) = self.interp.start(mv) {
                    self.motion_error = Some(e);
                    self.last_line = e.line;
                    self.begin_stop(stop_without_drive(StopCause::Motion));
                }
            }
            Some(LoopInput::End) => {
                self.input_done = true;
                return false;
            }
            None => {
                if !self.input_done {
                    self.starved += 1;
                }
                return false;
            }
        }
        true
    }
}

impl SpindleTrack {
    /// Takes in the axis's feedback at `tick` (a newer sample updates the velocity).
    fn update(&mut self, f: &DriveFeedback, tick: u64) {
        let sampled = tick.saturating_sub(f.age as u64);
        match self.last {
            Some((t0, p0)) if sampled > t0 => {
                self.velocity = (f.actual - p0) / (sampled - t0) as f64;
                self.last = Some((sampled, f.actual));
            }
            Some(_) => {}
            None => self.last = Some((sampled, f.actual)),
        }
    }
}

/// The follower's command (axis index, position) that keeps the thread on the leader's
/// actual position: the leader's last sample extrapolated with its velocity over the
/// feedback age (at most [`MAX_EXTRAPOLATION_TICKS`]), one period and the follower drive's
/// dead time, so that the hand-over from the path is smooth and the follower meets the
/// leader where it will be when the command takes effect. `tracks` = [tool, spindle].
fn follow_actual(
    f: &TapFollow,
    tracks: [&SpindleTrack; 2],
    axes: &AxisTable,
    tick: u64,
    fb: &[DriveFeedback; MAX_AXES],
) -> (usize, f64) {
    let (ti, si) = (f.c.tool as usize, f.c.spindle as usize);
    let (leader, follower, track) = if f.spindle_leads {
        (si, ti, tracks[1])
    } else {
        (ti, si, tracks[0])
    };
    let (sampled, p) = track.last.unwrap_or((tick, fb[leader].actual));
    let stale = tick.saturating_sub(sampled).min(MAX_EXTRAPOLATION_TICKS);
    let lead = stale as f64 + 1.0 + axes.delay_cycles[follower] as f64;
    let p = p + track.velocity * lead;
    if f.spindle_leads {
        (ti, f.anchor.0 + f.c.ratio * (p - f.anchor.1))
    } else if f.c.ratio != 0.0 {
        (si, f.anchor.1 + (p - f.anchor.0) / f.c.ratio)
    } else {
        (si, fb[si].actual)
    }
}

/// A stop that no drive raised (the operator's, a motion error).
pub(crate) fn stop_without_drive(cause: StopCause) -> DriveStop {
    DriveStop {
        cause,
        node: 0,
        statusword: 0,
        emcy: None,
        bus: None,
    }
}

/// The start position of the configured axes (entries past them are 0).
pub fn start_position(axes: &AxisTable, pos: &[f64; MAX_AXES]) -> AxisPos {
    let mut p = AxisPos::default();
    p.0[..axes.n].copy_from_slice(&pos[..axes.n]);
    p
}

/// True for a ring entry after which the blended chain does not go on: the program's end, a
/// move that is not a path move (dwell, spindle, tool change, events), or a path move that
/// ends at rest.
fn ends_the_chain(input: &LoopInput) -> bool {
    match input {
        LoopInput::End => true,
        LoopInput::Move(m) => match &m.kind {
            MoveKind::Path(p) => p.end_speed == 0.0,
            _ => true,
        },
    }
}
