//! Cyclic operation: once per period, [`Master::cycle`] takes in what arrived (TPDO1 =
//! statusword + position actual, EMCY, heartbeats, SDO responses), runs the safety monitors,
//! and sends one RPDO1 per drive (controlword + target position, INT32 counts, wrapping) and
//! then a SYNC. No allocation, no clock, no logging; per-axis state lives in fixed arrays.
//!
//! Following error rule: the TPDO read in cycle k was sampled at SYNC k−1, where the drive
//! took the command sent in cycle k−1; a drive with a pure delay of d cycles (the axis's
//! `dynamics.delay_cycles`, else `feedback_delay_cycles`) tracks the command of cycle k−1−d.
//! With a drive model (`dynamics`) the drive is expected where its first-order loop puts it
//! (the commands through the model's lag), so a slow drive's normal lag on a move is not
//! error and what trips is a drive off its model (blocked, saturated, faulty). So the monitor
//! compares the fresh actual with the expected position of `1 + d + age` cycles earlier.
//! Age: per drive the master counts SYNCs still owed a TPDO (+1 per SYNC, −1 per TPDO). A
//! drive's steady lateness is the lowest count seen since enabling (a drive whose TPDO always
//! misses the cycle edge shows 1 from its first answer on); a count above it is either a late
//! TPDO (the backlog drains: a later cycle brings two) or a lost one. While undecided the
//! sample's age is the reading whose error continues the last one (they differ by a cycle's
//! travel); after `RESYNC_CYCLES` cycles with exactly one TPDO each, the excess is written off.
//! Trip (as CiA 402 0x6065/0x6066 on the drive side): |error| beyond the window in more
//! consecutive fresh samples than `following_error_timeout_ms` has cycles (0 = the first one).
//! A sample older than the command history (`COMMAND_HISTORY`, e.g. after a loop stall) is not
//! comparable: never matched with a clamped command, counted, and no reset of the TPDO monitor.

use cia402::{Controlword, Goal, Progress, State, Statusword};
use cnc402_config::MAX_AXES;

use super::boot::MappedPdos;
#[cfg(test)]
use super::boot::RPDO1_LAYOUT;
use super::sdo::{SdoError, SdoEvent};
use super::stop::{SafetyStop, StopReason};
use super::{COMMAND_HISTORY, Master, Phase, StopMode};
use crate::bus::{BusError, CanBus};
use crate::time::Instant;
use crate::wire::{
    CanFrame, EmcyRepr, Function, HeartbeatRepr, NmtState, PdoObject, PdoValues, SyncRepr,
};
use cnc402_config::busload::PdoLayout as BusPdoLayout;

/// What one cycle gives back, per axis (indexed like `config.axes`; `Copy`, no heap).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Feedback {
    /// Cycles since enabling (this one included).
    pub cycle: u64,
    /// Configured axes.
    pub axis_count: usize,
    /// Actual position in axis units (virtual axes: the command).
    pub actual: [f64; MAX_AXES],
    /// The command taken this cycle.
    pub command: [f64; MAX_AXES],
    /// Expected position (the delayed command through the drive model) minus actual (see
    /// the module doc), axis units; holds its last value
    /// while samples are older than the command history (not comparable).
    pub following_error: [f64; MAX_AXES],
    /// The last statusword of each drive (`None` for virtual axes).
    pub statusword: [Option<Statusword>; MAX_AXES],
    /// Whether the drive's TPDO1 arrived since the previous cycle.
    pub fresh: [bool; MAX_AXES],
    /// How many SYNCs older than the last one the actual position is (0: it answers the
    /// previous cycle's SYNC; more when TPDOs arrive late on a loaded bus). Compare actual
    /// positions of different axes only at equal age (e.g. the coupling checker).
    pub age: [u32; MAX_AXES],
    /// A stop reaction is running (the latched stop: [`Master::stop_reason`]).
    pub stopping: bool,
    /// Actual position in counts, exact: the unwrapped 0x6064 count (virtual axes: the
    /// target). `as i32` gives the wrapping value on the wire.
    pub actual_counts: [i64; MAX_AXES],
    /// The target position this cycle's command becomes (counts, wrapping): the RPDO1 value
    /// while running or stopping (scaled once, here).
    pub target: [i32; MAX_AXES],
}

impl Feedback {
    /// Feedback with nothing in it (before the first cycle).
    pub const EMPTY: Feedback = Feedback {
        cycle: 0,
        axis_count: 0,
        actual: [0.0; MAX_AXES],
        command: [0.0; MAX_AXES],
        following_error: [0.0; MAX_AXES],
        statusword: [None; MAX_AXES],
        fresh: [false; MAX_AXES],
        age: [0; MAX_AXES],
        stopping: false,
        actual_counts: [0; MAX_AXES],
        target: [0; MAX_AXES],
    };

    /// The CiA 402 state of axis `i`'s drive.
    pub fn state(&self, i: usize) -> Option<State> {
        self.statusword
            .get(i)
            .copied()
            .flatten()
            .and_then(Statusword::state)
    }
    /// Actual positions of the configured axes.
    pub fn actual(&self) -> &[f64] {
        &self.actual[..self.axis_count.min(MAX_AXES)]
    }
}

/// Decodes a TPDO1 by the standard layout ([`TPDO1_LAYOUT`]); `None` when its length is
/// not the layout's.
#[cfg(test)]
fn parse_tpdo1(data: &[u8]) -> Option<(Statusword, i32)> {
    match parse_feedback(&MappedPdos::of(BusPdoLayout::Standard), 1, data)? {
        (Some(sw), Some(pos)) => Some((sw, pos)),
        _ => None,
    }
}

/// The feedback in TPDO `pdo` (1-based) by the layouts the drive has: (statusword,
/// position), each `None` when that PDO does not carry it; `None` as a whole when the PDO is
/// not one the master uses or the frame does not fit its layout.
fn parse_feedback(
    pdos: &MappedPdos,
    pdo: u8,
    data: &[u8],
) -> Option<(Option<Statusword>, Option<i32>)> {
    let layout = pdos.tx.get(usize::from(pdo).checked_sub(1)?)?;
    if layout.byte_len() == 0 {
        return None;
    }
    let v = layout.unpack(data).ok()?;
    Some((
        v.get(PdoObject::Statusword).map(|w| Statusword(w as u16)),
        // INTEGER32 on the wire: the raw bits are the two's complement count.
        v.get(PdoObject::PositionActual).map(|p| p as u32 as i32),
    ))
}

/// Encodes an RPDO1 by the standard layout ([`RPDO1_LAYOUT`]).
#[cfg(test)]
fn rpdo1(cob_id: u16, cw: Controlword, target: i32) -> CanFrame {
    pdo_frame(&RPDO1_LAYOUT, cob_id, cw, target)
}

/// `layout` packed with the controlword and the target (each left out if not mapped).
fn pdo_frame(
    layout: &crate::wire::PdoLayout,
    cob_id: u16,
    cw: Controlword,
    target: i32,
) -> CanFrame {
    // A fixed mapping may carry the mode of operation: it stays CSP (8).
    let values = PdoValues::new()
        .with(PdoObject::Controlword, cw.bits() as u64)
        .with(PdoObject::TargetPosition, target as u32 as u64)
        .with(PdoObject::ModesOfOperation, 8);
    let (data, len) = layout.pack(&values);
    // The id is 0x200/0x300 + node (≤ 0x37F) and the layout at most 8 bytes.
    CanFrame::from_parts(cob_id, data, len)
}

/// Cycles in a row with exactly one TPDO1 each after which SYNCs still owed beyond a drive's
/// steady lateness are written off as lost TPDOs (a merely late TPDO is followed sooner by a
/// cycle that brings two: the backlog drains).
pub const RESYNC_CYCLES: u32 = 8;

impl super::AxisSlot {
    /// The command the sample taken in cycle `k` answers if it is `age` cycles old, or
    /// `None` when that command is older than the history keeps (`COMMAND_HISTORY` cycles):
    /// such a sample is not comparable — never clamped to the oldest entry.
    fn reference(&self, k: usize, age: u32) -> Option<f64> {
        let lag = self.fe_lag.checked_add(age as usize)?;
        (lag < COMMAND_HISTORY).then(|| self.history[(k + COMMAND_HISTORY - lag) % COMMAND_HISTORY])
    }

    /// The drive model's response to this cycle's command (the command itself when the
    /// model has no lag: exactly, so runs without a model compare as before).
    fn expect(&mut self, cmd: f64) -> f64 {
        self.expected = if self.model_alpha >= 1.0 {
            cmd
        } else {
            self.expected + self.model_alpha * (cmd - self.expected)
        };
        self.expected
    }

    /// The following error of the sample in `actual` read at age `age` (see `reference`).
    fn error_at(&self, k: usize, age: u32) -> Option<f64> {
        self.reference(k, age).map(|r| r - self.actual)
    }

    /// The age of the sample just taken in (cycle `k`), by the rule in the module doc; updates
    /// the steady lateness and writes off lost TPDOs.
    fn sample_age(&mut self, k: usize) -> u32 {
        self.late_base = self.late_base.min(self.owed);
        if self.owed > self.late_base && self.window_tpdos == 1 {
            self.ambiguous_cycles += 1;
        } else {
            self.ambiguous_cycles = 0;
        }
        if self.ambiguous_cycles >= RESYNC_CYCLES {
            self.owed = self.late_base;
            self.ambiguous_cycles = 0;
        }
        if self.owed <= self.late_base {
            return self.owed;
        }
        // Late (answers an older SYNC) or on time after a loss: the tracking lag changes
        // little from one cycle to the next, the two readings differ by a cycle's travel.
        // A reading older than the history cannot be checked: take the sample as late (it
        // is then not comparable, see `reference`) rather than guess against a wrong command.
        let (Some(late), Some(lost)) = (
            self.error_at(k, self.owed),
            self.error_at(k, self.late_base),
        ) else {
            return self.owed;
        };
        if (lost - self.following_error).abs() < (late - self.following_error).abs() {
            self.late_base
        } else {
            self.owed
        }
    }

    /// Takes in this cycle's sample (cycle `k`): its age and following error when a TPDO1
    /// came, else the held sample ages; counts TPDO misses once a SYNC went out.
    fn take_sample(&mut self, k: usize, running: bool, sync_sent: bool) {
        if self.tpdo_this_cycle {
            self.age = self.sample_age(k);
            self.compare_sample(k, running);
        } else {
            // The held sample is one SYNC older than it was.
            self.age = self.age.saturating_add(1);
        }
        // A sample too old to compare is no usable feedback either: stale feedback that
        // lasts trips the TPDO monitor.
        if sync_sent {
            if self.tpdo_this_cycle && self.fe_comparable {
                self.tpdo_missing = 0;
            } else {
                self.tpdo_missing = self.tpdo_missing.saturating_add(1);
            }
        }
        self.window_tpdos = 0;
    }

    /// The following error of the fresh sample at its age, and the count of samples beyond
    /// the window in a row (the maximum is kept while running).
    fn compare_sample(&mut self, k: usize, running: bool) {
        match self.error_at(k, self.age) {
            Some(e) => {
                self.fe_comparable = true;
                self.following_error = e;
                if self.window > 0.0 && e.abs() > self.window {
                    self.fe_beyond = self.fe_beyond.saturating_add(1);
                } else {
                    self.fe_beyond = 0;
                }
                if running {
                    self.max_following_error = self.max_following_error.max(e.abs());
                }
            }
            None => {
                // Older than the history: the error keeps its last value, the persistence
                // count neither grows nor restarts.
                self.fe_comparable = false;
                self.fe_not_comparable = self.fe_not_comparable.saturating_add(1);
            }
        }
    }

    /// The controlword and target of this drive's RPDO1 in `phase` (`None`: idle, nothing
    /// is sent); `command` is this cycle's command in counts. Steps the enable sequencer
    /// while enabling or disabling, and remembers what is sent.
    fn next_rpdo(&mut self, phase: Phase, command: i32) -> Option<(Controlword, i32)> {
        let sw = self.statusword.unwrap_or(Statusword(0));
        let (cw, target) = match phase {
            Phase::Idle => return None,
            Phase::Enabling => {
                let step = self.sequencer.step(sw);
                self.progress = step.progress;
                (step.controlword, self.target)
            }
            Phase::Running => (
                Controlword(Controlword::ENABLE_OPERATION_CMD.0 | self.mode_bits),
                command,
            ),
            Phase::Stopping => (
                if self.quick_stop {
                    Controlword::QUICK_STOP_CMD
                } else {
                    Controlword::ENABLE_OPERATION_CMD
                },
                command,
            ),
            Phase::Disabling => {
                let step = self.sequencer.step(sw);
                self.disabled = step.progress == Progress::Reached;
                (step.controlword, self.target)
            }
        };
        self.controlword = cw;
        self.target = target;
        Some((cw, target))
    }
}

impl Master {
    fn slot_of(&self, node: crate::wire::NodeId) -> Option<usize> {
        self.axes[..self.n_axes]
            .iter()
            .position(|a| a.node == Some(node))
    }

    /// Takes in one received frame (no sending here: SDO requests it produces go out in the
    /// next send phase, which also paces SDO traffic to one frame per drive per cycle).
    pub(crate) fn absorb(&mut self, frame: &CanFrame, now: Instant) {
        match frame.function() {
            Function::Tpdo(pdo @ (1 | 2), node) => {
                let Some(i) = self.slot_of(node) else {
                    self.unexpected_frames += 1;
                    return;
                };
                match parse_feedback(&self.axes[i].pdos, pdo, frame.data()) {
                    Some((sw, pos)) => {
                        let a = &mut self.axes[i];
                        if sw.is_some() {
                            a.statusword = sw;
                            a.statusword_at = Some(now);
                        }
                        if let Some(pos) = pos {
                            a.set_actual_raw(pos);
                            a.tpdo_this_cycle = true;
                            a.tpdos = a.tpdos.wrapping_add(1);
                            a.owed = a.owed.saturating_sub(1);
                            a.window_tpdos = a.window_tpdos.saturating_add(1);
                        }
                    }
                    None => self.unexpected_frames += 1,
                }
            }
            Function::Tpdo(super::inputs::INPUTS_TPDO, node) => {
                match (
                    self.slot_of(node),
                    super::inputs::parse_inputs(frame.data()),
                ) {
                    (Some(i), Some(v)) => self.axes[i].inputs = Some(v),
                    _ => self.unexpected_frames += 1,
                }
            }
            Function::Emcy(node) => match (self.slot_of(node), EmcyRepr::parse(frame)) {
                (Some(i), Ok(e)) => {
                    // The first EMCY since the last clear is the cause; the ones after it (a
                    // drive sending one per cycle) are only counted: fixed memory, no log.
                    let a = &mut self.axes[i];
                    a.emcys = a.emcys.wrapping_add(1);
                    if e.code != 0 && a.emcy.is_none() {
                        a.emcy = Some(e.into());
                    }
                }
                _ => self.unexpected_frames += 1,
            },
            Function::Heartbeat(node) => match (self.slot_of(node), HeartbeatRepr::parse(frame)) {
                (Some(i), Ok(hb)) => {
                    let a = &mut self.axes[i];
                    if hb.state == NmtState::BootUp {
                        a.boot_ups = a.boot_ups.saturating_add(1);
                    }
                    a.last_heartbeat = Some(now);
                    a.nmt = Some(hb.state);
                    a.booted = true;
                }
                _ => self.unexpected_frames += 1,
            },
            Function::SdoTx(node) => {
                let Some(i) = self.slot_of(node) else {
                    self.unexpected_frames += 1;
                    return;
                };
                let a = &mut self.axes[i];
                if let Some(c) = a.sdo.as_mut() {
                    match c.on_frame(frame, now) {
                        SdoEvent::Send(f) => a.sdo_tx = Some(f),
                        SdoEvent::Done => a.sdo_outcome = Some(Ok(())),
                        SdoEvent::Failed(e, abort) => {
                            a.sdo_tx = abort;
                            a.sdo_outcome = Some(Err(e));
                        }
                        SdoEvent::NotMine | SdoEvent::Idle => {}
                    }
                }
            }
            _ => self.unexpected_frames += 1,
        }
    }

    fn stop_for(&self, i: usize, reason: StopReason, now: Instant) -> SafetyStop {
        let a = &self.axes[i];
        SafetyStop {
            reason,
            axis: Some(a.name),
            axis_index: Some(i),
            node: a.node.map(|n| n.get()),
            statusword: a.statusword,
            emcy: a.emcy,
            at: now,
            line: None,
        }
    }

    fn bus_stop(&self, e: BusError, now: Instant) -> SafetyStop {
        SafetyStop {
            reason: StopReason::Bus(e),
            axis: None,
            axis_index: None,
            node: None,
            statusword: None,
            emcy: None,
            at: now,
            line: None,
        }
    }

    /// The first monitor that trips for drive axis `i` (Running phase only).
    fn monitor(&self, i: usize, now: Instant) -> Option<StopReason> {
        let a = &self.axes[i];
        a.node?;
        let state = a.statusword.and_then(Statusword::state);
        if state.is_some_and(State::is_fault) {
            return Some(StopReason::DriveFault);
        }
        if a.emcy.is_some() {
            return Some(StopReason::Emergency);
        }
        if let Some(r) = self.inputs_stop(i) {
            return Some(r);
        }
        if a.tpdo_this_cycle && state != Some(State::OperationEnabled) {
            return Some(StopReason::NotEnabled);
        }
        if let Some(t) = a.last_heartbeat
            && self.heartbeat_ms > 0
            && now.saturating_since(t) > self.heartbeat_timeout
        {
            return Some(StopReason::HeartbeatLost {
                silent_ms: now.saturating_since(t).as_millis() as u64,
            });
        }
        if let Some(s) = a.nmt
            && s != NmtState::Operational
        {
            return Some(StopReason::NmtState(s));
        }
        if let Some(t) = a.statusword_at
            && self.pdo_layout == BusPdoLayout::Compact
            && now.saturating_since(t) > self.statusword_timeout
        {
            return Some(StopReason::StatuswordStale {
                silent_ms: now.saturating_since(t).as_millis() as u64,
            });
        }
        if a.tpdo_missing >= self.tpdo_timeout_cycles {
            return Some(StopReason::TpdoMissing {
                cycles: a.tpdo_missing,
            });
        }
        if a.tpdo_this_cycle
            && !a.homing_active
            && a.fe_comparable
            && a.window > 0.0
            && a.following_error.abs() > a.window
            && a.fe_beyond > a.fe_timeout_cycles
        {
            return Some(StopReason::FollowingError {
                error: a.following_error,
                window: a.window,
            });
        }
        None
    }

    /// Latches `stop` and starts the stop reaction. Following the path, the drive that
    /// tripped gets quick stop unless it only sent an EMCY and is still enabled: it can take
    /// the decelerating path like the others (in a tap, quick-stopping Z or C alone would
    /// decouple them).
    fn trip(&mut self, stop: SafetyStop) {
        self.stop = Some(stop);
        self.phase = Phase::Stopping;
        if matches!(stop.reason, StopReason::EstopOpen { .. }) {
            self.estop_reaction();
            return;
        }
        let still_follows = stop.reason == StopReason::Emergency;
        for (i, a) in self.axes[..self.n_axes].iter_mut().enumerate() {
            if self.options.stop_mode == StopMode::QuickStop
                || (stop.axis_index == Some(i) && !still_follows)
            {
                a.quick_stop = true;
            }
        }
    }

    /// One period. `commands` are the positions in axis units for the configured axes
    /// (indexed like `config.axes`; a missing entry holds the last command). `now` is the
    /// cycle's time (the caller's deadline). Returns the feedback, or the safety stop the
    /// first time a monitor trips — the stop reaction has then already been sent, and later
    /// cycles return `Ok` with [`Feedback::stopping`] set. Allocation-free.
    ///
    /// The steps, in this order: take in what arrived, take each axis's command and sample,
    /// run the monitors, then the send phase (RPDO1 per drive, SYNC, the master's heartbeat,
    /// at most one SDO frame per drive).
    pub fn cycle<B: CanBus + ?Sized>(
        &mut self,
        bus: &mut B,
        now: Instant,
        commands: &[f64],
    ) -> Result<Feedback, SafetyStop> {
        let mut tripped = self.receive_pending(bus, now);
        let running = self.phase == Phase::Running;
        if running || self.phase == Phase::Stopping {
            self.cycles += 1;
        }
        let mut fb = Feedback {
            cycle: self.cycles,
            axis_count: self.n_axes,
            ..Feedback::EMPTY
        };
        for i in 0..self.n_axes {
            let cmd = match self.command_for(i, commands) {
                Ok(cmd) => cmd,
                Err(held) => {
                    if running && tripped.is_none() {
                        tripped = Some(self.stop_for(i, StopReason::BadSetpoint, now));
                    }
                    held
                }
            };
            self.take_axis(i, cmd, running, &mut fb);
        }
        if running && tripped.is_none() {
            tripped = self.first_monitor_stop(now);
        }
        if let Some(s) = tripped {
            if self.stop.is_none() {
                self.trip(s);
            } else {
                tripped = None;
            }
        }
        // Every frame of the send phase goes out even after a failed one; the first error
        // is the one reported.
        let rpdo_err = self.send_rpdos(bus, &fb.target);
        let sync_err = self.send_sync(bus);
        let heartbeat_err = self.send_master_heartbeat(bus, now);
        let outputs_err = if matches!(self.phase, Phase::Running | Phase::Stopping) {
            self.send_outputs(bus, now)
        } else {
            None
        };
        let sdo_err = self.send_sdo_frames(bus, now);
        if let Some(e) = rpdo_err
            .or(sync_err)
            .or(heartbeat_err)
            .or(outputs_err)
            .or(sdo_err)
            && self.stop.is_none()
            && running
        {
            let s = self.bus_stop(e, now);
            self.trip(s);
            tripped = Some(s);
        }
        fb.stopping = self.phase == Phase::Stopping;
        self.last_feedback = fb;
        match tripped {
            Some(s) => Err(s),
            None => Ok(fb),
        }
    }

    /// Takes in every frame waiting on the bus; a receive error ends that with a bus stop.
    fn receive_pending<B: CanBus + ?Sized>(
        &mut self,
        bus: &mut B,
        now: Instant,
    ) -> Option<SafetyStop> {
        loop {
            match bus.recv() {
                Ok(Some(f)) => self.absorb(&f, now),
                Ok(None) => return None,
                Err(e) => return Some(self.bus_stop(e, now)),
            }
        }
    }

    /// Axis `i`'s command this cycle: `commands[i]`, or the last command when the entry is
    /// missing; `Err` with the last command (held) when the entry is not finite.
    fn command_for(&self, i: usize, commands: &[f64]) -> Result<f64, f64> {
        let last = self.axes[i].last_command;
        let cmd = commands.get(i).copied().unwrap_or(last);
        if cmd.is_finite() { Ok(cmd) } else { Err(last) }
    }

    /// Records axis `i`'s command `cmd` in its history, takes in its sample (drives) or
    /// echoes the command (virtual axes), and fills the axis's entries of `fb`.
    fn take_axis(&mut self, i: usize, cmd: f64, running: bool, fb: &mut Feedback) {
        let k = self.cycles as usize;
        let sync_sent = self.sync_sent;
        let a = &mut self.axes[i];
        a.last_command = cmd;
        a.history[k % COMMAND_HISTORY] = a.expect(cmd);
        if a.node.is_some() {
            a.take_sample(k, running, sync_sent);
            fb.age[i] = a.age;
        } else {
            a.actual = cmd;
            a.following_error = 0.0;
        }
        fb.target[i] = a.to_counts(cmd);
        fb.actual_counts[i] = if a.node.is_some() {
            a.actual_counts
        } else {
            fb.target[i] as i64
        };
        fb.actual[i] = a.actual;
        fb.command[i] = cmd;
        fb.following_error[i] = a.following_error;
        fb.statusword[i] = a.statusword;
        fb.fresh[i] = a.tpdo_this_cycle;
    }

    /// The stop of the first drive whose monitor trips (in axis order).
    fn first_monitor_stop(&self, now: Instant) -> Option<SafetyStop> {
        (0..self.n_axes).find_map(|i| {
            self.monitor(i, now)
                .map(|reason| self.stop_for(i, reason, now))
        })
    }

    /// RPDO1 to every drive with the controlword of the phase; `targets` are this cycle's
    /// commands in counts (sent while running or stopping). Returns the first send error.
    fn send_rpdos<B: CanBus + ?Sized>(
        &mut self,
        bus: &mut B,
        targets: &[i32; MAX_AXES],
    ) -> Option<BusError> {
        let mut err = None;
        for (a, &target) in self.axes[..self.n_axes].iter_mut().zip(targets) {
            let Some(node) = a.node else { continue };
            a.tpdo_this_cycle = false;
            let Some((cw, target)) = a.next_rpdo(self.phase, target) else {
                continue;
            };
            let id = node.get() as u16;
            let [rx1, rx2] = a.pdos.rx;
            let sent = match self.pdo_layout {
                BusPdoLayout::Standard => bus.send(&pdo_frame(&rx1, 0x200 + id, cw, target)),
                BusPdoLayout::Compact => {
                    // The controlword when it changes, and every refresh period unchanged.
                    a.controlword_refresh_in = a.controlword_refresh_in.saturating_sub(1);
                    let cw_sent = if a.controlword_sent != Some(cw) || a.controlword_refresh_in == 0
                    {
                        a.controlword_sent = Some(cw);
                        a.controlword_refresh_in = self.event_refresh_cycles;
                        bus.send(&pdo_frame(&rx2, 0x300 + id, cw, target))
                    } else {
                        Ok(())
                    };
                    cw_sent.and(bus.send(&pdo_frame(&rx1, 0x200 + id, cw, target)))
                }
            };
            if let Err(e) = sent {
                err = err.or(Some(e));
            }
        }
        err
    }

    /// The SYNC (outside the idle phase): every drive then owes one more TPDO1.
    fn send_sync<B: CanBus + ?Sized>(&mut self, bus: &mut B) -> Option<BusError> {
        if self.phase == Phase::Idle {
            return None;
        }
        let err = bus.send(&SyncRepr { counter: None }.emit()).err();
        self.sync_sent = true;
        self.syncs = self.syncs.wrapping_add(1);
        for a in self.axes[..self.n_axes].iter_mut() {
            if a.node.is_some() {
                a.owed = a.owed.saturating_add(1);
            }
        }
        err
    }

    /// The master's own heartbeat when due (the drives' 0x1016 consumer watches it): a
    /// master that stops cycling falls silent, and each drive takes its 0x6007 reaction
    /// (quick stop).
    fn send_master_heartbeat<B: CanBus + ?Sized>(
        &mut self,
        bus: &mut B,
        now: Instant,
    ) -> Option<BusError> {
        if self.phase == Phase::Idle || self.heartbeat_ms == 0 {
            return None;
        }
        if self.next_heartbeat.is_some_and(|t| now < t) {
            // Not due yet.
            return None;
        }
        let hb = HeartbeatRepr {
            node: self.master_node,
            state: NmtState::Operational,
        };
        let err = bus.send(&hb.emit()).err();
        self.heartbeats_sent = self.heartbeats_sent.wrapping_add(1);
        // On the producer's grid; after a gap, restart from now rather than burst.
        let period = core::time::Duration::from_millis(self.heartbeat_ms as u64);
        let next = self.next_heartbeat.map_or(now + period, |t| t + period);
        self.next_heartbeat = Some(if next <= now { now + period } else { next });
        err
    }

    /// At most one SDO frame per drive (aborts always; requests as the credit allows).
    /// SDO frames use the bus time the cyclic frames leave free (a request and its response
    /// per 270 bits of credit), so they delay no PDO by more than that.
    fn send_sdo_frames<B: CanBus + ?Sized>(
        &mut self,
        bus: &mut B,
        now: Instant,
    ) -> Option<BusError> {
        let cap = self.sdo_free_bits.max(2.0 * SDO_EXCHANGE_BITS);
        self.sdo_credit = (self.sdo_credit + self.sdo_free_bits).min(cap);
        let mut err = None;
        for a in self.axes[..self.n_axes].iter_mut() {
            if let Some(c) = a.sdo.as_mut()
                && let SdoEvent::Failed(e, abort) = c.poll(now)
            {
                a.sdo_outcome = Some(Err(e));
                a.sdo_tx = abort;
            }
            let is_abort = a.sdo.as_ref().is_some_and(|c| !c.is_busy());
            if a.sdo_tx.is_some() && (is_abort || self.sdo_credit >= SDO_EXCHANGE_BITS) {
                if !is_abort {
                    self.sdo_credit -= SDO_EXCHANGE_BITS;
                }
                if let Some(f) = a.sdo_tx.take()
                    && let Err(e) = bus.send(&f)
                {
                    err = err.or(Some(e));
                }
            }
        }
        err
    }

    /// Sends quick stop (controlword 0x02) to every drive from the next cycle on; the caller
    /// keeps calling [`cycle`](Self::cycle) while the drives brake.
    pub fn quick_stop(&mut self) {
        if matches!(self.phase, Phase::Running | Phase::Stopping) {
            self.phase = Phase::Stopping;
            for a in self.axes[..self.n_axes].iter_mut() {
                a.quick_stop = true;
            }
        }
    }

    /// From the next cycle on, takes every drive to SWITCH ON DISABLED (power stage off) with
    /// the CiA 402 sequencer; [`is_disabled`](Self::is_disabled) says when all are there.
    pub fn request_disable(&mut self) {
        if self.phase == Phase::Idle {
            return;
        }
        self.phase = Phase::Disabling;
        for a in self.axes[..self.n_axes].iter_mut() {
            a.sequencer.set_goal(Goal::SwitchOnDisabled);
            a.disabled = a.node.is_none();
            a.target = a.to_counts(a.last_command);
        }
    }

    /// Whether every drive reached SWITCH ON DISABLED (or FAULT) after
    /// [`request_disable`](Self::request_disable).
    pub fn is_disabled(&self) -> bool {
        self.phase == Phase::Disabling && self.axes[..self.n_axes].iter().all(|a| a.disabled)
    }

    /// Starts an SDO read of `index:sub` on axis `axis`'s drive during cyclic operation; the
    /// frames go out in the following cycles' send phases (one per cycle) and PDOs keep
    /// flowing. Poll [`take_sdo_outcome`](Self::take_sdo_outcome).
    pub fn start_sdo_upload(
        &mut self,
        axis: usize,
        index: u16,
        sub: u8,
        now: Instant,
    ) -> Result<(), SdoError> {
        self.check_sdo_capacity(axis, index, sub)?;
        let a = self.drive_slot(axis, index, sub)?;
        let c = a.sdo.as_mut().ok_or_else(|| no_drive(axis, index, sub))?;
        let f = c.start_upload(index, sub, now)?;
        a.sdo_outcome = None;
        a.sdo_tx = Some(f);
        Ok(())
    }

    /// Starts an SDO write during cyclic operation (see
    /// [`start_sdo_upload`](Self::start_sdo_upload)). Data up to 256 bytes does not allocate.
    pub fn start_sdo_download(
        &mut self,
        axis: usize,
        index: u16,
        sub: u8,
        data: &[u8],
        now: Instant,
    ) -> Result<(), SdoError> {
        self.check_sdo_capacity(axis, index, sub)?;
        let a = self.drive_slot(axis, index, sub)?;
        let c = a.sdo.as_mut().ok_or_else(|| no_drive(axis, index, sub))?;
        let f = c.start_download(index, sub, data, now)?;
        a.sdo_outcome = None;
        a.sdo_tx = Some(f);
        Ok(())
    }

    /// In cyclic operation an SDO exchange must fit in the bus time the cyclic frames leave
    /// free, draining within a few cycles: otherwise it would hold TPDOs back long enough to
    /// trip the TPDO monitor (4 CSP axes at 1 ms on 1 Mbit/s leave ~2 %).
    fn check_sdo_capacity(&self, axis: usize, index: u16, sub: u8) -> Result<(), SdoError> {
        if self.phase == Phase::Idle {
            return Ok(());
        }
        let drain_cycles = SDO_EXCHANGE_BITS / self.sdo_free_bits.max(1e-9);
        if drain_cycles <= (self.tpdo_timeout_cycles as f64 / 2.0).max(1.0) {
            return Ok(());
        }
        Err(SdoError {
            node: self
                .axes
                .get(axis)
                .and_then(|a| a.node)
                .map(|n| n.get())
                .unwrap_or(0),
            index,
            sub,
            write: false,
            kind: super::sdo::SdoErrorKind::NoBusCapacity {
                cyclic_load_percent: self.cyclic_load_percent(),
            },
        })
    }

    fn drive_slot(
        &mut self,
        axis: usize,
        index: u16,
        sub: u8,
    ) -> Result<&mut super::AxisSlot, SdoError> {
        if axis >= self.n_axes {
            return Err(no_drive(axis, index, sub));
        }
        Ok(&mut self.axes[axis])
    }

    /// The outcome of the last in-cycle SDO transfer on `axis`, once it has ended (taken).
    pub fn take_sdo_outcome(&mut self, axis: usize) -> Option<Result<(), SdoError>> {
        self.axes.get_mut(axis).and_then(|a| a.sdo_outcome.take())
    }

    /// The data of the last completed in-cycle SDO upload on `axis`.
    pub fn sdo_data(&self, axis: usize) -> &[u8] {
        self.axes
            .get(axis)
            .and_then(|a| a.sdo.as_ref())
            .map(|c| c.data())
            .unwrap_or(&[])
    }
}

/// Bits of one SDO request and its response (two 8-byte frames, worst-case stuffing).
pub use cnc402_config::busload::SDO_EXCHANGE_BITS;

fn no_drive(axis: usize, index: u16, sub: u8) -> SdoError {
    SdoError {
        node: 0,
        index,
        sub,
        write: false,
        kind: super::sdo::SdoErrorKind::NoDrive { axis },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pdo_codecs() {
        let f = rpdo1(0x203, Controlword::ENABLE_OPERATION_CMD, -2);
        assert_eq!(f.to_string(), "203#0F00FEFFFFFF");
        assert_eq!(
            parse_tpdo1(&[0x37, 0x16, 0x00, 0x00, 0x00, 0x80]),
            Some((Statusword(0x1637), i32::MIN))
        );
        assert_eq!(parse_tpdo1(&[0; 5]), None);
    }

    use crate::bus::BusCounters;
    use crate::wire::{EmcyRepr, HeartbeatRepr, NodeId};
    use cnc402_config::MachineConfig;
    use std::collections::VecDeque;

    /// A bus the test scripts: frames to receive are queued by hand, sent frames recorded.
    #[derive(Default)]
    struct Script {
        rx: VecDeque<CanFrame>,
        tx: Vec<CanFrame>,
        fail_send: Option<BusError>,
    }

    impl CanBus for Script {
        fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
            if let Some(e) = self.fail_send {
                return Err(e);
            }
            self.tx.push(*frame);
            Ok(())
        }
        fn recv(&mut self) -> Result<Option<CanFrame>, BusError> {
            Ok(self.rx.pop_front())
        }
        fn counters(&self) -> BusCounters {
            BusCounters::default()
        }
    }

    fn tpdo(node: u8, sw: u16, pos: i32) -> CanFrame {
        let mut d = [0u8; 6];
        d[..2].copy_from_slice(&sw.to_le_bytes());
        d[2..].copy_from_slice(&pos.to_le_bytes());
        CanFrame::new(0x180 + node as u16, &d).unwrap()
    }

    /// A master for the shipped machine put straight into Running, all drives enabled at 0.
    fn running() -> (Master, Script, Instant) {
        let mut m = Master::new(&MachineConfig::default_machine()).unwrap();
        m.phase = Phase::Running;
        let now = Instant::from_millis(100);
        for a in m.axes[..4].iter_mut() {
            a.statusword = Some(Statusword(0x1237));
            a.last_heartbeat = Some(now);
        }
        (m, Script::default(), now)
    }

    /// One cycle with a TPDO from every drive (statusword OPERATION ENABLED, position 0)
    /// plus `extra` frames.
    fn step(
        m: &mut Master,
        bus: &mut Script,
        now: Instant,
        extra: &[CanFrame],
    ) -> Result<Feedback, SafetyStop> {
        for n in 1..=4 {
            bus.rx.push_back(tpdo(n, 0x1237, 0));
        }
        bus.rx.extend(extra.iter().copied());
        m.cycle(bus, now, &[0.0; 4])
    }

    #[test]
    fn emcy_without_a_fault_state_is_an_emergency_stop() {
        let (mut m, mut bus, now) = running();
        step(&mut m, &mut bus, now, &[]).unwrap();
        let e = EmcyRepr {
            node: NodeId::new(2).unwrap(),
            code: 0x4310,
            register: 0x09,
            manufacturer: [0; 5],
        }
        .emit();
        let s = step(&mut m, &mut bus, now, &[e]).unwrap_err();
        assert_eq!(s.reason, StopReason::Emergency);
        assert_eq!((s.axis, s.node), (Some('Y'), Some(2)));
        assert_eq!(
            s.emcy.map(|e| (e.code, e.text())),
            Some((0x4310, "temperature"))
        );
        // The stop reaction went out in the same cycle: quick stop to every drive, then SYNC.
        let tail: Vec<String> = bus.tx[bus.tx.len() - 5..]
            .iter()
            .map(|f| f.to_string())
            .collect();
        assert_eq!(
            tail,
            [
                "201#020000000000",
                "202#020000000000",
                "203#020000000000",
                "204#020000000000",
                "080#"
            ]
        );
        // Reported once; later cycles carry on with the stop reaction.
        assert!(step(&mut m, &mut bus, now, &[]).unwrap().stopping);
    }

    #[test]
    fn an_emcy_storm_stops_once_with_the_first_code_and_is_only_counted_after() {
        let (mut m, mut bus, now) = running();
        let emcy = |code| {
            EmcyRepr {
                node: NodeId::new(3).unwrap(),
                code,
                register: 0x01,
                manufacturer: [0; 5],
            }
            .emit()
        };
        let s = step(
            &mut m,
            &mut bus,
            now,
            &[emcy(0x5530), emcy(0x3210), emcy(0x5530)],
        )
        .unwrap_err();
        assert_eq!((s.reason, s.node), (StopReason::Emergency, Some(3)));
        assert_eq!(s.emcy.map(|e| e.code), Some(0x5530), "the first one");
        for _ in 0..100 {
            assert!(
                step(&mut m, &mut bus, now, &[emcy(0x4210)])
                    .unwrap()
                    .stopping
            );
        }
        assert_eq!(m.emcys_received(2), 103);
        assert_eq!(m.last_emcy(2).map(|e| e.code), Some(0x5530));
        assert_eq!(m.unexpected_frames(), 0);
    }

    #[test]
    fn error_reset_emcy_is_not_a_stop() {
        let (mut m, mut bus, now) = running();
        let e = EmcyRepr {
            node: NodeId::new(1).unwrap(),
            code: 0,
            register: 0,
            manufacturer: [0; 5],
        }
        .emit();
        step(&mut m, &mut bus, now, &[e]).unwrap();
    }

    #[test]
    fn a_drive_that_reboots_or_disables_mid_run_stops_the_machine() {
        let (mut m, mut bus, now) = running();
        let boot = HeartbeatRepr {
            node: NodeId::new(3).unwrap(),
            state: crate::wire::NmtState::BootUp,
        }
        .emit();
        let s = step(&mut m, &mut bus, now, &[boot]).unwrap_err();
        assert_eq!(
            s.reason,
            StopReason::NmtState(crate::wire::NmtState::BootUp)
        );
        assert_eq!(s.node, Some(3));

        let (mut m, mut bus, now) = running();
        bus.rx.push_back(tpdo(1, 0x1237, 0));
        bus.rx.push_back(tpdo(2, 0x1237, 0));
        bus.rx.push_back(tpdo(3, 0x0250, 0)); // SWITCH ON DISABLED
        bus.rx.push_back(tpdo(4, 0x1237, 0));
        let s = m.cycle(&mut bus, now, &[0.0; 4]).unwrap_err();
        assert_eq!(s.reason, StopReason::NotEnabled);
        assert!(s.to_string().contains("SWITCH ON DISABLED"), "{s}");
    }

    #[test]
    fn non_finite_setpoint_and_bus_errors_stop() {
        let (mut m, mut bus, now) = running();
        let s = m
            .cycle(&mut bus, now, &[0.0, f64::NAN, 0.0, 0.0])
            .unwrap_err();
        assert_eq!(s.reason, StopReason::BadSetpoint);
        assert_eq!(s.axis, Some('Y'));
        // The NaN never reached the wire: Y's target stayed at the last command (0).
        assert!(bus.tx.iter().any(|f| f.to_string() == "202#020000000000"));

        let (mut m, mut bus, now) = running();
        bus.fail_send = Some(BusError::TxQueueFull);
        let s = step(&mut m, &mut bus, now, &[]).unwrap_err();
        assert_eq!(s.reason, StopReason::Bus(BusError::TxQueueFull));
        assert_eq!(s.node, None);
    }

    #[test]
    fn malformed_and_foreign_frames_are_counted_not_trusted() {
        let (mut m, mut bus, now) = running();
        let short = CanFrame::new(0x182, &[0x37, 0x12, 0, 0, 0]).unwrap();
        let stranger = CanFrame::new(0x18A, &[0; 6]).unwrap();
        bus.rx.extend([short, stranger]);
        let fb = m.cycle(&mut bus, now, &[0.0; 4]).unwrap();
        assert!(!fb.fresh[1]);
        assert_eq!(m.unexpected_frames(), 2);
    }

    #[test]
    fn position_unwraps_across_the_int32_limits_both_ways() {
        let (mut m, mut bus, now) = running();
        let cpu = m.axes[3].counts_per_unit;
        for raw in [i32::MAX - 10, i32::MIN + 5, i32::MIN + 100, i32::MAX - 3] {
            bus.rx.push_back(tpdo(4, 0x1237, raw));
            m.cycle(&mut bus, now, &[0.0, 0.0, 0.0, m.axes[3].actual])
                .unwrap_or_else(|s| {
                    // Following error is irrelevant here; only the unwrapping is looked at.
                    assert!(matches!(s.reason, StopReason::FollowingError { .. }));
                    *m.last_feedback()
                });
        }
        // +16 over the top, +95, then back over the limit by −104.
        let expected = (i32::MAX as i64 - 10) + 16 + 95 - 104;
        assert_eq!(expected, i32::MAX as i64 - 3);
        assert_eq!(m.axes[3].actual_counts, expected);
        assert!((m.axes[3].actual - expected as f64 / cpu).abs() < 1e-9);
    }

    /// The persistence rule at a period that does not divide the time-out: 5 ms at 2 ms is
    /// 2 whole cycles, so the 3rd consecutive sample beyond the window trips (6 ms > 5 ms).
    /// A sample inside the window restarts the count; a cycle without a sample does not.
    #[test]
    fn following_error_persistence_counts_fresh_samples() {
        let mut config = MachineConfig::default_machine();
        config.bus.period_us = 2000;
        config.axes[0].following_error_timeout_ms = 5;
        let mut m = Master::new(&config).unwrap();
        assert_eq!(m.axes[0].fe_timeout_cycles, 2);
        m.phase = Phase::Running;
        let mut now = Instant::from_millis(100);
        for a in m.axes[..4].iter_mut() {
            a.statusword = Some(Statusword(0x1237));
            a.last_heartbeat = Some(now);
        }
        let mut bus = Script::default();
        // X's actual: 1 mm (10 000 counts) off a command of 0 is beyond the 0.5 mm window.
        let mut step = |x: Option<i32>| {
            if let Some(x) = x {
                bus.rx.push_back(tpdo(1, 0x1237, x));
            }
            for n in 2..=4 {
                bus.rx.push_back(tpdo(n, 0x1237, 0));
            }
            now += core::time::Duration::from_millis(2);
            m.cycle(&mut bus, now, &[0.0; 4])
        };
        step(Some(0)).unwrap();
        step(Some(10_000)).unwrap();
        step(Some(10_000)).unwrap();
        step(Some(0)).unwrap(); // back inside: the count restarts
        step(Some(10_000)).unwrap();
        step(Some(-10_000)).unwrap();
        let fb = step(None).unwrap(); // no sample: neither counted nor reset
        assert!(!fb.fresh[0]);
        let stop = step(Some(10_000)).unwrap_err();
        assert_eq!(
            stop.reason,
            StopReason::FollowingError {
                error: -1.0,
                window: 0.5
            }
        );
        assert_eq!((stop.axis, stop.node), (Some('X'), Some(1)));
        assert_eq!(stop.statusword, Some(Statusword(0x1237)));
    }
}
