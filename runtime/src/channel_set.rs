//! Several channels in one period: each channel's [`CycleController`] (its own interpolator
//! and move ring, on a [`ChannelPort`] instead of the bus) prepares its setpoints, the set
//! merges them by axis ownership into one [`DriveLink::cycle`] (one master, one SYNC), splits
//! the feedback back and completes each. It also holds channels at wait marks, detects a wait
//! that can never end, and spreads a channel's stop to the others per its `on_error`.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use cnc402_config::{ChannelView, MAX_AXES, MAX_CHANNELS, OnError};
use cnc402_drives::Instant;
use cnc402_drives::bus::BusCounters;
use cnc402_motion::Tick;

use crate::channels::ChannelSignal;
use crate::controller::{CycleController, Step, stop_without_drive};
use crate::link::{DriveFeedback, DriveLink, DriveStop, Startup, StopCause};
use crate::machine_io::OUTPUTS;
use crate::status::Outcome;

/// A channel's controller's view of the drives: the set exchanges for it. It keeps the
/// output switches the controller asked for until the set passes them to the real link.
#[derive(Clone, Copy, Debug, Default)]
pub struct ChannelPort {
    outputs: [Option<bool>; OUTPUTS.len()],
}

impl ChannelPort {
    /// The output switches asked for since the last call (index into [`OUTPUTS`]).
    fn take_outputs(&mut self) -> [Option<bool>; OUTPUTS.len()] {
        std::mem::take(&mut self.outputs)
    }
}

impl DriveLink for ChannelPort {
    fn startup(&mut self, _: Instant) -> Startup {
        Startup::Failed("a channel starts with the machine's link, not on its own".into())
    }
    fn cycle(
        &mut self,
        _: Instant,
        _: &[f64; MAX_AXES],
        _: &mut [DriveFeedback; MAX_AXES],
    ) -> Result<(), DriveStop> {
        Ok(())
    }
    fn quick_stop(&mut self, _: Instant, _: &mut [DriveFeedback; MAX_AXES]) -> bool {
        true
    }
    fn counters(&self) -> BusCounters {
        BusCounters::default()
    }
    fn bitrate(&self) -> u32 {
        0
    }
    fn shutdown(&mut self) -> Result<(), String> {
        Ok(())
    }
    fn set_output(&mut self, which: cnc402_drives::master::Output, on: bool) {
        if let Some(k) = OUTPUTS.iter().position(|(o, _)| *o == which) {
            self.outputs[k] = Some(on);
        }
    }
}

/// One channel of the set.
pub struct Member {
    pub ctrl: CycleController<ChannelPort>,
    /// Machine axis index of each of the channel's axes.
    map: [usize; MAX_AXES],
    n: usize,
    /// CANopen node of each of its axes (0: none), to find whose drive raised a stop.
    nodes: [u8; MAX_AXES],
    on_error: OnError,
    tick: Option<Tick>,
    /// How it ended (`None` while it runs).
    pub outcome: Option<Outcome>,
    /// What the board and the reporting side read of this channel (its state, line, end);
    /// lock-free.
    signal: Option<Arc<ChannelSignal>>,
    /// It takes programs one after another from the board and ends with the run (see
    /// `crate::channels`); otherwise it ends with its program.
    resident: bool,
    /// Raised by its feeder when its program fails while it runs: the channel stops as a
    /// program error (and the others as its `on_error` says), not as an operator's stop.
    program_failed: Option<Arc<AtomicBool>>,
}

impl Member {
    /// Channel `view`'s controller (built on `view.config`, with wait marks on).
    pub fn new(ctrl: CycleController<ChannelPort>, view: &ChannelView) -> Member {
        let n = view.axes.len().min(MAX_AXES);
        let mut map = [0; MAX_AXES];
        let mut nodes = [0; MAX_AXES];
        for (k, &a) in view.axes.iter().take(n).enumerate() {
            map[k] = a;
            nodes[k] = view.config.axes[k].node.unwrap_or(0);
        }
        Member {
            ctrl: ctrl.with_wait_marks(),
            map,
            n,
            nodes,
            on_error: view.on_error,
            tick: None,
            outcome: None,
            signal: None,
            resident: false,
            program_failed: None,
        }
    }

    /// Stops as a program error once `flag` is raised (its feeder's stop flag).
    pub fn with_failure_flag(mut self, flag: Arc<AtomicBool>) -> Member {
        self.program_failed = Some(flag);
        self
    }

    /// Its program failed while it ran (the next step stops it as a program error).
    pub fn program_failed(&self) -> bool {
        self.program_failed
            .as_ref()
            .is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// A resident channel (see [`Member::resident`](Self)) reporting through `signal`.
    pub fn resident(self, signal: Arc<ChannelSignal>) -> Member {
        Member {
            resident: true,
            ..self.signalled(signal)
        }
    }

    /// A channel reporting its state, line and end through `signal`.
    pub fn signalled(mut self, signal: Arc<ChannelSignal>) -> Member {
        self.signal = Some(signal);
        self
    }

    fn live(&self) -> bool {
        self.outcome.is_none()
    }

    /// A resident channel with no program queued or running.
    fn idle_resident(&self) -> bool {
        self.resident
            && self
                .signal
                .as_ref()
                .is_some_and(|s| !s.busy.load(Ordering::SeqCst))
    }
}

/// A wait that could never end: per channel the line it stood at and its wait mark.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Deadlock {
    pub lines: [u32; MAX_CHANNELS],
    pub marks: [Option<(u16, u16)>; MAX_CHANNELS],
    /// Channels that had ended (a wait for them never ends).
    pub ended: [bool; MAX_CHANNELS],
}

/// See the module doc.
pub struct ChannelSet<L: DriveLink> {
    link: L,
    members: Vec<Member>,
    commands: [f64; MAX_AXES],
    feedback: [DriveFeedback; MAX_AXES],
    deadlock: Option<Deadlock>,
}

impl<L: DriveLink> ChannelSet<L> {
    /// The set of `members` (channel order, at most [`MAX_CHANNELS`]) on `link`, the drives
    /// standing at `start` (machine axes).
    pub fn new(link: L, members: Vec<Member>, start: [f64; MAX_AXES]) -> ChannelSet<L> {
        let mut feedback = [DriveFeedback::default(); MAX_AXES];
        for (f, &p) in feedback.iter_mut().zip(&start) {
            f.actual = p;
        }
        ChannelSet {
            link,
            members,
            commands: start,
            feedback,
            deadlock: None,
        }
    }

    pub fn members(&self) -> &[Member] {
        &self.members
    }

    pub fn members_mut(&mut self) -> &mut [Member] {
        &mut self.members
    }

    pub fn link(&self) -> &L {
        &self.link
    }

    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }

    /// The link, the channels and the deadlock that stopped them, if one did (after the
    /// run).
    pub fn into_parts(self) -> (L, Vec<Member>, Option<Deadlock>) {
        (self.link, self.members, self.deadlock)
    }

    /// The deadlock that stopped the channels, if one did.
    pub fn deadlock(&self) -> Option<&Deadlock> {
        self.deadlock.as_ref()
    }

    /// Every channel has ended.
    pub fn is_done(&self) -> bool {
        self.members.iter().all(|m| !m.live())
    }

    /// One period at `now` for every channel still running; true once all have ended.
    /// Allocation-free.
    pub fn step(&mut self, now: Instant) -> bool {
        for m in self.members.iter_mut().filter(|m| m.live()) {
            if m.program_failed() && m.ctrl.first_stop().is_none() {
                m.ctrl.stop_for(stop_without_drive(StopCause::ProgramError));
            }
            if let (true, Some(sig)) = (m.resident, &m.signal) {
                m.ctrl.set_discarding(sig.reset.load(Ordering::Relaxed));
            }
            m.tick = Some(m.ctrl.prepare());
            for (k, on) in m.ctrl.link_mut().take_outputs().into_iter().enumerate() {
                if let Some(on) = on {
                    self.link.set_output(OUTPUTS[k].0, on);
                }
            }
            let sent = m.ctrl.sent();
            for (&a, &x) in m.map[..m.n].iter().zip(sent) {
                self.commands[a] = x;
            }
        }
        // A channel that ended keeps its axes at its last setpoints (the link holds them).
        let live = || self.members.iter().filter(|m| m.live());
        let all_quick = live().all(|m| m.ctrl.wants_quick_stop());
        let (raised, machine_stopped) = if all_quick {
            (None, self.link.quick_stop(now, &mut self.feedback))
        } else {
            let r = self.link.cycle(now, &self.commands, &mut self.feedback);
            (r.err(), false)
        };
        let owner = raised.and_then(|r| self.owner_of(r.node));
        let to_all = owner.is_none_or(|k| self.members[k].on_error == OnError::All);
        for (k, m) in self.members.iter_mut().enumerate() {
            let Some(t) = m.tick.take() else { continue };
            let fb = m.ctrl.feedback_mut();
            for (f, &a) in fb.iter_mut().zip(&m.map[..m.n]) {
                *f = self.feedback[a];
            }
            let r = raised.filter(|_| to_all || owner == Some(k));
            // Alone in its quick stop, a channel's motion is at rest and its axes held: it
            // has ended; the machine's quick stop comes when every channel is there.
            let stopped = machine_stopped || !all_quick;
            if let Step::Done(o) = m.ctrl.complete(&t, r, stopped) {
                m.outcome = Some(o);
            }
            if let Some(sig) = &m.signal {
                sig.at_mark
                    .store(m.ctrl.at_mark().is_some(), Ordering::Relaxed);
                sig.line.store(m.ctrl.line(), Ordering::Relaxed);
                sig.dead.store(!m.live(), Ordering::Relaxed);
            }
        }
        self.spread_stops();
        self.wait_marks();
        self.end_residents();
        self.is_done()
    }

    /// Once every channel that runs one program has ended, the resident channels without
    /// a program end too (nobody is left to start one).
    fn end_residents(&mut self) {
        let others_ended = self.members.iter().all(|m| m.resident || !m.live());
        if !others_ended {
            return;
        }
        let rest = |m: &Member| m.live() && m.idle_resident() && m.ctrl.is_at_rest();
        if self.members.iter().filter(|m| m.live()).all(rest) {
            for m in self.members.iter_mut().filter(|m| m.live()) {
                m.outcome = Some(Outcome::Finished);
            }
        }
    }

    /// The channel whose drive is `node` (`None` for 0: the bus, the operator).
    fn owner_of(&self, node: u8) -> Option<usize> {
        if node == 0 {
            return None;
        }
        self.members
            .iter()
            .position(|m| m.nodes[..m.n].contains(&node))
    }

    /// A channel that stopped with `on_error = "all"` stops the others along their paths.
    fn spread_stops(&mut self) {
        let first = self
            .members
            .iter()
            .any(|m| m.on_error == OnError::All && m.ctrl.first_stop().is_some());
        if !first {
            return;
        }
        for m in self.members.iter_mut().filter(|m| m.live()) {
            if m.ctrl.first_stop().is_none() {
                m.ctrl.stop_for(stop_without_drive(StopCause::OtherChannel));
            }
        }
    }

    /// Releases the channels whose wait mark every channel they wait for has reached; stops
    /// every channel when a wait can never end.
    fn wait_marks(&mut self) {
        let count = self.members.len().min(MAX_CHANNELS);
        let mark_of = |j: usize| self.members[j].ctrl.at_mark();
        let ended = |j: usize| {
            let m = &self.members[j];
            let at_rest = m.ctrl.is_ending() || m.idle_resident();
            !m.live() || (at_rest && m.ctrl.at_mark().is_none())
        };
        let mut release = [false; MAX_CHANNELS];
        let mut stuck = false;
        let mut waiting = 0;
        for (k, r) in release.iter_mut().enumerate().take(count) {
            let Some((mark, bits)) = mark_of(k) else {
                continue;
            };
            waiting += 1;
            let wanted = |j: usize| j != k && (bits == 0 || bits & (1 << j) != 0);
            // A channel this machine does not have, or one that has ended, never comes.
            let never = (bits != 0 && u32::from(bits) >> count != 0)
                || (0..count).filter(|&j| wanted(j)).any(ended);
            stuck |= never;
            *r = !never
                && (0..count)
                    .filter(|&j| wanted(j))
                    .all(|j| mark_of(j).is_some_and(|(m, _)| m == mark));
        }
        let running = (0..count).filter(|&j| !ended(j)).count();
        let released = release.iter().any(|&r| r);
        if waiting > 0 && !released && (stuck || waiting == running) {
            self.stop_deadlocked(count);
            return;
        }
        for (m, _) in self.members.iter_mut().zip(release).filter(|(_, r)| *r) {
            m.ctrl.release_mark();
        }
    }

    fn stop_deadlocked(&mut self, count: usize) {
        let mut d = Deadlock::default();
        for k in 0..count {
            let m = &self.members[k];
            d.lines[k] = m.ctrl.line();
            d.marks[k] = m.ctrl.at_mark();
            d.ended[k] = !m.live() || m.ctrl.is_ending();
        }
        self.deadlock = Some(d);
        // A channel that ended its program settles as it would have.
        let stuck = |m: &&mut Member| {
            let at_rest = m.ctrl.is_ending() || m.idle_resident();
            m.live() && (!at_rest || m.ctrl.at_mark().is_some())
        };
        for m in self.members.iter_mut().filter(stuck) {
            m.ctrl
                .stop_for(stop_without_drive(StopCause::ChannelDeadlock));
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;
    use std::time::Duration;

    use cnc402_config::MachineConfig;
    use cnc402_lang::SourceFile;
    use cnc402_motion::{AxisPos, MoveKind, PlannedMove, SegmentEnd, StopKind};

    use super::*;
    use crate::feeder::Feeder;
    use crate::link::FaultPlan;
    use crate::ring::{Consumer, LoopInput, Producer, StatusConsumer, move_ring, status_ring};
    use crate::status::Status;

    fn two_channels(on_error: &str) -> MachineConfig {
        let text = include_str!("../../examples/axioma/two-channel.toml")
            .replace("on_error = \"all\"", &format!("on_error = {on_error:?}"));
        MachineConfig::parse(
            &text,
            std::path::Path::new("examples/axioma/two-channel.toml"),
        )
        .expect("config")
    }

    /// What a channel's program is made of in these tests: NC text, or a wait mark.
    enum Part<'a> {
        Nc(&'a str),
        Mark(u16, u16, u32),
    }

    /// The moves of `parts` on channel `view`, the feeder planning each text from where the
    /// last one ended (`pos`).
    fn moves(view: &ChannelView, parts: &[Part]) -> Vec<LoopInput> {
        let mut out = Vec::new();
        let mut pos = AxisPos::default();
        for p in parts {
            match p {
                Part::Nc(text) => {
                    let src = SourceFile::new("t.nc", *text);
                    let ast = cnc402_lang::parse(&src).expect("parse");
                    let mut f = Feeder::new(&view.config, src, ast, pos);
                    while let Some(mv) = f.next_move().expect("program") {
                        if let MoveKind::Path(p) = &mv.kind {
                            pos = p.end;
                        }
                        out.push(LoopInput::Move(mv));
                    }
                }
                Part::Mark(mark, channels, line) => out.push(LoopInput::Move(PlannedMove {
                    line: *line,
                    n: None,
                    kind: MoveKind::ProgramStop {
                        kind: StopKind::WaitMark {
                            mark: *mark,
                            channels: *channels,
                        },
                    },
                    ends: SegmentEnd::ExactStop,
                })),
            }
        }
        out.push(LoopInput::End);
        out
    }

    /// Runs the channels' `programs` on the bus-less model to the end; per channel its
    /// status records.
    fn run(
        cfg: &MachineConfig,
        programs: [&[Part]; 2],
        fault: Option<FaultPlan>,
    ) -> (ChannelSet<crate::testing::ModelLink>, Vec<Vec<Status>>) {
        let stop = Arc::new(AtomicBool::new(false));
        let mut members = Vec::new();
        let mut rings: Vec<StatusConsumer> = Vec::new();
        for (k, parts) in programs.iter().enumerate() {
            let view = cfg.channel(k).expect("channel");
            let (mut tx, rx) = move_ring(512);
            for m in moves(&view, parts) {
                assert!(tx.try_push(m).is_ok(), "ring too small");
            }
            let (st, sr) = status_ring(1 << 16);
            let ctrl = CycleController::new(
                &view.config,
                [0.0; MAX_AXES],
                ChannelPort::default(),
                rx,
                st,
                stop.clone(),
            );
            members.push(Member::new(ctrl, &view));
            rings.push(sr);
            std::mem::forget(tx);
        }
        let mut link = crate::testing::model_link(cfg, fault);
        let mut now = Instant::ZERO;
        while !matches!(link.startup(now), Startup::Ready(_)) {
            now += Duration::from_millis(2);
        }
        let mut set = ChannelSet::new(link, members, [0.0; MAX_AXES]);
        let mut out = vec![Vec::new(), Vec::new()];
        for _ in 0..200_000 {
            now += Duration::from_millis(2);
            let done = set.step(now);
            for (o, r) in out.iter_mut().zip(rings.iter_mut()) {
                while let Some(s) = r.try_pop() {
                    o.push(s);
                }
            }
            if done {
                return (set, out);
            }
        }
        panic!("the channels never ended");
    }

    /// The first tick at which axis `i`'s command passes `x`.
    fn first_past(st: &[Status], i: usize, x: f64) -> u64 {
        st.iter()
            .find(|s| s.cmd[i] > x + 1e-6)
            .expect("never passed")
            .tick
    }

    #[test]
    fn two_channels_move_their_own_axes_in_one_loop() {
        let cfg = two_channels("all");
        let (set, st) = run(
            &cfg,
            [
                &[Part::Nc("G90 G0 X10 Y5\n")],
                &[Part::Nc("G90 G1 U20 W-5 F3000\n")],
            ],
            None,
        );
        assert!(
            set.members()
                .iter()
                .all(|m| m.outcome == Some(Outcome::Finished))
        );
        let last0 = st[0].last().unwrap();
        let last1 = st[1].last().unwrap();
        assert!((last0.cmd[0] - 10.0).abs() < 1e-9 && (last0.cmd[1] - 5.0).abs() < 1e-9);
        // Channel 1's axes U V W: U to 20, W to -5.
        assert!((last1.cmd[0] - 20.0).abs() < 1e-9 && (last1.cmd[2] + 5.0).abs() < 1e-9);
        // The two moved at once, not one after the other.
        assert_eq!(first_past(&st[0], 0, 0.0), first_past(&st[1], 0, 0.0));
        // Feedback went back to its own channel: U's actual reached 20.
        assert!((last1.act[0] - 20.0).abs() < 1e-3, "{:?}", last1.act);
    }

    #[test]
    fn a_wait_mark_holds_until_every_channel_is_there_then_all_go_on_the_same_tick() {
        let cfg = two_channels("all");
        let (set, st) = run(
            &cfg,
            [
                &[
                    Part::Nc("G90 G0 X1\n"),
                    Part::Mark(7, 0, 2),
                    Part::Nc("G90 G0 X2\n"),
                ],
                &[
                    Part::Nc("G90 G1 U50 F600\n"),
                    Part::Mark(7, 0, 9),
                    Part::Nc("G90 G0 U60\n"),
                ],
            ],
            None,
        );
        assert!(
            set.members()
                .iter()
                .all(|m| m.outcome == Some(Outcome::Finished))
        );
        let x_on = first_past(&st[0], 0, 1.0);
        let u_on = first_past(&st[1], 0, 50.0);
        assert_eq!(x_on, u_on, "both leave the mark on the same tick");
        // X waited for U's 5 s move.
        let x_at = first_past(&st[0], 0, 0.999);
        assert!(x_on > x_at + 1000, "X held at its mark: {x_at} → {x_on}");
        assert!(set.deadlock().is_none());
    }

    #[test]
    fn marks_that_disagree_are_a_deadlock_naming_each_line_and_nothing_moves_on() {
        let cfg = two_channels("all");
        let (set, st) = run(
            &cfg,
            [
                &[
                    Part::Nc("G90 G0 X1\n"),
                    Part::Mark(1, 0, 4),
                    Part::Nc("G0 X2\n"),
                ],
                &[
                    Part::Nc("G90 G0 U1\n"),
                    Part::Mark(2, 0, 6),
                    Part::Nc("G0 U2\n"),
                ],
            ],
            None,
        );
        let d = set.deadlock().expect("a deadlock");
        assert_eq!(&d.lines[..2], &[4, 6]);
        assert_eq!(&d.marks[..2], &[Some((1, 0)), Some((2, 0))]);
        for m in set.members() {
            match &m.outcome {
                Some(Outcome::Stopped { stop, .. }) => {
                    assert_eq!(stop.cause, StopCause::ChannelDeadlock)
                }
                o => panic!("{o:?}"),
            }
        }
        assert!(st[0].iter().all(|s| s.cmd[0] <= 1.0 + 1e-9));
        assert!(st[1].iter().all(|s| s.cmd[0] <= 1.0 + 1e-9));
    }

    #[test]
    fn waiting_for_a_channel_that_ended_is_a_deadlock() {
        let cfg = two_channels("all");
        let (set, _) = run(
            &cfg,
            [
                &[
                    Part::Nc("G90 G0 X1\n"),
                    Part::Mark(3, 0b10, 5),
                    Part::Nc("G0 X2\n"),
                ],
                &[Part::Nc("G90 G0 U1\n")],
            ],
            None,
        );
        let d = set.deadlock().expect("a deadlock");
        assert_eq!(d.marks[0], Some((3, 0b10)));
        assert!(d.ended[1]);
        assert_eq!(set.members()[1].outcome, Some(Outcome::Finished));
    }

    #[test]
    fn a_mark_for_a_channel_the_machine_lacks_is_a_deadlock() {
        let cfg = two_channels("all");
        let (set, _) = run(
            &cfg,
            [&[Part::Mark(3, 0b100, 1)], &[Part::Mark(3, 0b100, 1)]],
            None,
        );
        assert!(set.deadlock().is_some());
    }

    fn fault_on_u() -> Option<FaultPlan> {
        Some(FaultPlan {
            node: 5,
            at: Duration::from_millis(200),
            emcy: 0x2310,
        })
    }

    #[test]
    fn a_fault_in_one_channel_stops_every_channel_by_default() {
        let cfg = two_channels("all");
        let (set, st) = run(
            &cfg,
            [
                &[Part::Nc("G90 G1 X100 F600\n")],
                &[Part::Nc("G90 G1 U100 F600\n")],
            ],
            fault_on_u(),
        );
        let cause = |k: usize| match &set.members()[k].outcome {
            Some(Outcome::Stopped { stop, .. }) => stop.cause,
            o => panic!("{o:?}"),
        };
        assert_eq!(cause(1), StopCause::DriveFault);
        assert_ne!(
            cause(0),
            StopCause::OtherChannel,
            "a drive fault is said as it is"
        );
        // X stopped along its path well before its end.
        let x = st[0].last().unwrap().cmd[0];
        assert!(x < 50.0, "X went on to {x}");
    }

    #[test]
    fn on_error_channel_stops_only_the_faulty_channel() {
        let cfg = two_channels("channel");
        let (set, st) = run(
            &cfg,
            [
                &[Part::Nc("G90 G1 X30 F1200\n")],
                &[Part::Nc("G90 G1 U100 F600\n")],
            ],
            fault_on_u(),
        );
        assert_eq!(set.members()[0].outcome, Some(Outcome::Finished));
        assert!(matches!(
            &set.members()[1].outcome,
            Some(Outcome::Stopped { stop, .. }) if stop.cause == StopCause::DriveFault
        ));
        assert!((st[0].last().unwrap().cmd[0] - 30.0).abs() < 1e-9);
    }
}
