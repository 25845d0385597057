//! The master side of the CiA 402 state machine: given the statusword the drive reports,
//! which controlword to send next to reach a goal state, and where and why the drive is
//! stuck when it does not get there. Time is counted in calls to [`EnableSequencer::step`]
//! (one per cycle), so the sequencer stays free of clocks.

use core::fmt;

use crate::state::{Command, State};
use crate::words::{Controlword, Statusword};

/// The state the master wants the drive in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Goal {
    /// OPERATION ENABLED: shutdown, switch on, enable operation (fault reset first if
    /// fault resets are allowed).
    OperationEnabled,
    /// SWITCHED ON (disable operation from OPERATION ENABLED).
    SwitchedOn,
    /// READY TO SWITCH ON (shutdown).
    ReadyToSwitchOn,
    /// SWITCH ON DISABLED (disable voltage). FAULT also counts as reached: the power stage is
    /// off there too and no fault reset is sent.
    SwitchOnDisabled,
    /// Stop with the drive's quick stop: QUICK STOP ACTIVE or SWITCH ON DISABLED reached;
    /// FAULT and FAULT REACTION ACTIVE also count (the fault reaction stops the motor).
    QuickStop,
}

impl fmt::Display for Goal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Goal::OperationEnabled => State::OperationEnabled.name(),
            Goal::SwitchedOn => State::SwitchedOn.name(),
            Goal::ReadyToSwitchOn => State::ReadyToSwitchOn.name(),
            Goal::SwitchOnDisabled => State::SwitchOnDisabled.name(),
            Goal::QuickStop => "QUICK STOP",
        };
        f.write_str(s)
    }
}

/// Why the drive is not moving towards the goal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StuckReason {
    /// The statusword matches no CiA 402 state.
    UndefinedStatusword,
    /// The drive stays in NOT READY TO SWITCH ON (still initialising).
    NotReady,
    /// The fault reaction does not end.
    FaultReactionNotEnding,
    /// Fault reset edges were sent and the drive stays in FAULT (the cause persists).
    FaultPersists {
        /// Rising edges of bit 7 sent so far.
        resets_sent: u32,
    },
    /// The drive is in FAULT and fault resets are not allowed for this goal.
    InFault,
    /// The drive ignores the command sent to leave its state.
    CommandIgnored {
        /// The command sent.
        command: Command,
    },
}

/// A report that the drive has not moved towards the goal for longer than the patience.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stuck {
    /// The state the drive is stuck in (`None`: undefined statusword).
    pub state: Option<State>,
    /// The last statusword seen.
    pub statusword: Statusword,
    /// What the sequencer wanted.
    pub goal: Goal,
    /// Why.
    pub reason: StuckReason,
    /// Steps (cycles) spent without a state change.
    pub steps: u32,
}

impl fmt::Display for Stuck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.state {
            Some(s) => write!(f, "stuck in {s}")?,
            None => write!(f, "stuck in no state")?,
        }
        write!(f, " for {} cycles (goal {}): ", self.steps, self.goal)?;
        match self.reason {
            StuckReason::UndefinedStatusword => write!(
                f,
                "statusword {:#06x} matches no CiA 402 state",
                self.statusword.0
            )?,
            StuckReason::NotReady => write!(f, "drive does not finish initialising")?,
            StuckReason::FaultReactionNotEnding => write!(f, "fault reaction does not end")?,
            StuckReason::FaultPersists { resets_sent } => {
                write!(f, "{resets_sent} fault reset edges sent, fault persists")?
            }
            StuckReason::InFault => write!(f, "drive in FAULT, fault reset not allowed")?,
            StuckReason::CommandIgnored { command } => {
                write!(f, "{command} ({:#06x}) ignored", command.controlword().0)?
            }
        }
        let sw = self.statusword;
        if !sw.remote() {
            write!(f, "; remote bit 9 low (drive ignores the controlword)")?;
        }
        if self.state == Some(State::SwitchOnDisabled) && !sw.has(Statusword::QUICK_STOP) {
            write!(
                f,
                "; quick stop bit 5 low (a quick stop input may hold the drive)"
            )?;
        }
        if sw.warning() {
            write!(f, "; warning bit 7 set")?;
        }
        if sw.internal_limit() {
            write!(f, "; internal limit bit 11 set")?;
        }
        write!(f, " (statusword {:#06x})", sw.0)
    }
}

/// Where the sequencer is after a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// The drive is in the goal state.
    Reached,
    /// On the way; the drive is in this state.
    Moving(Option<State>),
    /// No state change for longer than the patience. The sequencer keeps sending the same
    /// command; the master decides whether to give up.
    Stuck(Stuck),
}

/// One step's output: the controlword to send now, and the progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// Send this controlword this cycle (mode-specific bits and halt are left to the master).
    pub controlword: Controlword,
    /// How far the drive is.
    pub progress: Progress,
}

impl Step {
    /// Whether this step sends enable operation from SWITCHED ON (transition 4): the master
    /// must have written the target position = actual position before this frame, or the
    /// drive jumps to a stale target.
    pub fn enables_operation(&self, sw: Statusword) -> bool {
        sw.state() == Some(State::SwitchedOn)
            && self.controlword.command() == Command::EnableOperation
    }
}

/// Master-side CiA 402 sequencer: call [`step`](Self::step) once per cycle with the latest
/// statusword; send the returned controlword.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EnableSequencer {
    goal: Goal,
    reset_faults: bool,
    patience: u32,
    last_state: Option<Option<State>>,
    steps_in_state: u32,
    last_sent: Controlword,
    resets_sent: u32,
}

impl EnableSequencer {
    /// Default patience: steps without a state change before [`Progress::Stuck`].
    pub const DEFAULT_PATIENCE: u32 = 100;

    /// A sequencer towards `goal`. Fault resets are allowed for [`Goal::OperationEnabled`],
    /// [`Goal::SwitchedOn`] and [`Goal::ReadyToSwitchOn`].
    pub fn new(goal: Goal) -> EnableSequencer {
        EnableSequencer {
            goal,
            reset_faults: !matches!(goal, Goal::SwitchOnDisabled | Goal::QuickStop),
            patience: Self::DEFAULT_PATIENCE,
            last_state: None,
            steps_in_state: 0,
            last_sent: Controlword::DISABLE_VOLTAGE,
            resets_sent: 0,
        }
    }

    /// Steps (cycles) without a state change before the drive is reported stuck (min 1).
    pub fn with_patience(mut self, steps: u32) -> EnableSequencer {
        self.patience = steps.max(1);
        self
    }

    /// Whether FAULT is left with fault reset edges (otherwise it is reported stuck).
    pub fn with_fault_reset(mut self, allowed: bool) -> EnableSequencer {
        self.reset_faults = allowed;
        self
    }

    /// Changes the goal (counters restart; the fault reset policy follows the new goal).
    pub fn set_goal(&mut self, goal: Goal) {
        if goal != self.goal {
            let patience = self.patience;
            let last_sent = self.last_sent;
            *self = EnableSequencer::new(goal).with_patience(patience);
            self.last_sent = last_sent;
        }
    }

    /// The goal.
    pub fn goal(&self) -> Goal {
        self.goal
    }

    /// The controlword sent by the last step.
    pub fn last_controlword(&self) -> Controlword {
        self.last_sent
    }

    fn reached(&self, state: State) -> bool {
        match self.goal {
            Goal::OperationEnabled => state == State::OperationEnabled,
            Goal::SwitchedOn => state == State::SwitchedOn,
            Goal::ReadyToSwitchOn => state == State::ReadyToSwitchOn,
            Goal::SwitchOnDisabled => matches!(state, State::SwitchOnDisabled | State::Fault),
            Goal::QuickStop => matches!(
                state,
                State::QuickStopActive
                    | State::SwitchOnDisabled
                    | State::Fault
                    | State::FaultReactionActive
            ),
        }
    }

    /// The command that moves `state` one transition closer to the goal (or holds it).
    fn command_for(&self, state: State) -> Command {
        use Command::*;
        match self.goal {
            Goal::SwitchOnDisabled => DisableVoltage,
            Goal::QuickStop => QuickStop,
            Goal::ReadyToSwitchOn => match state {
                State::QuickStopActive => DisableVoltage,
                _ => Shutdown,
            },
            Goal::SwitchedOn => match state {
                State::SwitchOnDisabled => Shutdown,
                State::QuickStopActive => DisableVoltage,
                _ => SwitchOn,
            },
            Goal::OperationEnabled => match state {
                State::SwitchOnDisabled => Shutdown,
                State::ReadyToSwitchOn => SwitchOn,
                State::SwitchedOn | State::OperationEnabled => EnableOperation,
                // Leave a quick stop through SWITCH ON DISABLED rather than transition 16:
                // re-enabling from a held quick stop resumes motion without the master's
                // target = actual handshake.
                State::QuickStopActive => DisableVoltage,
                State::NotReadyToSwitchOn | State::FaultReactionActive | State::Fault => {
                    DisableVoltage
                }
            },
        }
    }

    /// Given the drive's latest statusword, the controlword to send now and the progress.
    pub fn step(&mut self, sw: Statusword) -> Step {
        let state = sw.state();
        if self.last_state == Some(state) {
            self.steps_in_state = self.steps_in_state.saturating_add(1);
        } else {
            self.last_state = Some(state);
            self.steps_in_state = 0;
        }
        let (controlword, reason) = match state {
            None => (
                self.last_sent.with(Controlword::FAULT_RESET, false),
                Some(StuckReason::UndefinedStatusword),
            ),
            Some(s) if self.reached(s) => {
                let cw = if s == State::Fault || s == State::FaultReactionActive {
                    Controlword::DISABLE_VOLTAGE
                } else {
                    self.command_for(s).controlword()
                };
                self.resets_sent = 0;
                self.last_sent = cw;
                return Step {
                    controlword: cw,
                    progress: Progress::Reached,
                };
            }
            Some(State::Fault) => {
                if self.reset_faults {
                    // A rising edge needs a word with bit 7 low first.
                    let cw = if self.last_sent.fault_reset() {
                        Controlword::DISABLE_VOLTAGE
                    } else {
                        self.resets_sent = self.resets_sent.saturating_add(1);
                        Controlword::FAULT_RESET_CMD
                    };
                    (
                        cw,
                        Some(StuckReason::FaultPersists {
                            resets_sent: self.resets_sent,
                        }),
                    )
                } else {
                    (Controlword::DISABLE_VOLTAGE, Some(StuckReason::InFault))
                }
            }
            Some(State::FaultReactionActive) => (
                Controlword::DISABLE_VOLTAGE,
                Some(StuckReason::FaultReactionNotEnding),
            ),
            Some(State::NotReadyToSwitchOn) => {
                (Controlword::DISABLE_VOLTAGE, Some(StuckReason::NotReady))
            }
            Some(s) => {
                let command = self.command_for(s);
                (
                    command.controlword(),
                    Some(StuckReason::CommandIgnored { command }),
                )
            }
        };
        self.last_sent = controlword;
        let stuck_now =
            self.steps_in_state >= self.patience || (reason == Some(StuckReason::InFault));
        let progress = match reason {
            Some(reason) if stuck_now => Progress::Stuck(Stuck {
                state,
                statusword: sw,
                goal: self.goal,
                reason,
                steps: self.steps_in_state,
            }),
            _ => Progress::Moving(state),
        };
        Step {
            controlword,
            progress,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::DeviceStateMachine;
    use crate::mode::QuickStopOption;

    const ALL_GOALS: [Goal; 5] = [
        Goal::OperationEnabled,
        Goal::SwitchedOn,
        Goal::ReadyToSwitchOn,
        Goal::SwitchOnDisabled,
        Goal::QuickStop,
    ];

    fn device_in(target: State, option: QuickStopOption) -> DeviceStateMachine {
        crate::device::tests::machine_in(target, option)
    }

    /// Runs sequencer against device; the device finishes a fault reaction / quick stop one
    /// cycle after it starts and leaves NOT READY after 3 cycles.
    fn run(
        seq: &mut EnableSequencer,
        dev: &mut DeviceStateMachine,
        max: u32,
    ) -> (u32, Vec<Controlword>) {
        let mut sent = Vec::new();
        for i in 0..max {
            let sw = Statusword(dev.statusword().0 | Statusword::REMOTE);
            let step = seq.step(sw);
            if step.progress == Progress::Reached {
                return (i, sent);
            }
            if let Progress::Stuck(s) = step.progress {
                panic!("{s}");
            }
            if step.enables_operation(sw) {
                assert_eq!(dev.state(), State::SwitchedOn);
            }
            sent.push(step.controlword);
            dev.on_controlword(step.controlword);
            if i == 2 {
                dev.init_done();
            }
            dev.fault_reaction_done();
            dev.quick_stop_done();
        }
        panic!("goal {:?} not reached from {:?}", seq.goal(), dev.state());
    }

    #[test]
    fn every_goal_is_reached_from_every_state_with_every_quick_stop_option() {
        for option in (0..=8).map(|v| QuickStopOption::from_i16(v).unwrap()) {
            for from in State::ALL {
                for goal in ALL_GOALS {
                    let mut dev = device_in(from, option);
                    let mut seq = EnableSequencer::new(goal).with_patience(20);
                    let (steps, _) = run(&mut seq, &mut dev, 30);
                    assert!(steps <= 8, "{from} → {goal}: {steps} steps");
                    assert!(
                        seq.reached(dev.state()),
                        "{from} → {goal}: in {}",
                        dev.state()
                    );
                }
            }
        }
    }

    #[test]
    fn enable_from_switch_on_disabled_sends_the_textbook_sequence() {
        let mut dev = device_in(State::SwitchOnDisabled, QuickStopOption::QuickStopRamp);
        let mut seq = EnableSequencer::new(Goal::OperationEnabled);
        let (_, sent) = run(&mut seq, &mut dev, 10);
        assert_eq!(
            sent,
            vec![Controlword(0x06), Controlword(0x07), Controlword(0x0F)]
        );
    }

    #[test]
    fn fault_reset_is_an_edge_then_enable() {
        let mut dev = device_in(State::Fault, QuickStopOption::QuickStopRamp);
        let mut seq = EnableSequencer::new(Goal::OperationEnabled);
        let (_, sent) = run(&mut seq, &mut dev, 10);
        assert_eq!(sent[0], Controlword(0x80));
        assert_eq!(
            &sent[1..],
            &[Controlword(0x06), Controlword(0x07), Controlword(0x0F)]
        );
    }

    #[test]
    fn persisting_fault_is_reported_with_edges_counted() {
        let mut seq = EnableSequencer::new(Goal::OperationEnabled).with_patience(6);
        let sw = Statusword(State::Fault.statusword_bits() | Statusword::REMOTE);
        let mut words = Vec::new();
        let mut last = None;
        for _ in 0..7 {
            let s = seq.step(sw);
            words.push(s.controlword.0);
            last = Some(s.progress);
        }
        // 0x80, 0x00, 0x80, … : every other word is a rising edge.
        assert_eq!(words, vec![0x80, 0x00, 0x80, 0x00, 0x80, 0x00, 0x80]);
        match last {
            Some(Progress::Stuck(s)) => {
                assert_eq!(s.state, Some(State::Fault));
                assert_eq!(s.reason, StuckReason::FaultPersists { resets_sent: 4 });
                let text = s.to_string();
                assert!(text.starts_with("stuck in FAULT for 6 cycles"), "{text}");
                assert!(text.contains("4 fault reset edges sent"), "{text}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn ignored_shutdown_names_state_command_and_hints() {
        let mut seq = EnableSequencer::new(Goal::OperationEnabled).with_patience(3);
        // A drive held in SWITCH ON DISABLED with bit 5 low and remote low.
        let sw = Statusword(0x0040);
        let mut p = Progress::Reached;
        for _ in 0..4 {
            let s = seq.step(sw);
            assert_eq!(s.controlword, Controlword::SHUTDOWN);
            p = s.progress;
        }
        let Progress::Stuck(s) = p else {
            panic!("{p:?}")
        };
        assert_eq!(
            s.reason,
            StuckReason::CommandIgnored {
                command: Command::Shutdown
            }
        );
        let text = s.to_string();
        assert!(text.starts_with("stuck in SWITCH ON DISABLED"), "{text}");
        assert!(text.contains("shutdown (0x0006) ignored"), "{text}");
        assert!(text.contains("quick stop bit 5 low"), "{text}");
        assert!(text.contains("remote bit 9 low"), "{text}");
    }

    #[test]
    fn not_stuck_before_patience_and_reset_by_a_state_change() {
        let mut seq = EnableSequencer::new(Goal::OperationEnabled).with_patience(3);
        let sod = Statusword(0x0250);
        for _ in 0..3 {
            assert!(matches!(seq.step(sod).progress, Progress::Moving(_)));
        }
        assert!(matches!(seq.step(sod).progress, Progress::Stuck(_)));
        let rtso = Statusword(0x0231);
        assert!(matches!(
            seq.step(rtso).progress,
            Progress::Moving(Some(State::ReadyToSwitchOn))
        ));
    }

    #[test]
    fn undefined_statusword_and_fault_without_reset() {
        let mut seq = EnableSequencer::new(Goal::OperationEnabled).with_patience(1);
        seq.step(Statusword(0x0001));
        let Progress::Stuck(s) = seq.step(Statusword(0x0001)).progress else {
            panic!()
        };
        assert_eq!(s.reason, StuckReason::UndefinedStatusword);
        assert_eq!(s.state, None);

        let mut seq = EnableSequencer::new(Goal::OperationEnabled).with_fault_reset(false);
        let step = seq.step(Statusword(0x0008));
        assert_eq!(step.controlword, Controlword(0));
        let Progress::Stuck(s) = step.progress else {
            panic!()
        };
        assert_eq!(s.reason, StuckReason::InFault);
    }

    #[test]
    fn disable_and_quick_stop_accept_fault_without_resetting() {
        for goal in [Goal::SwitchOnDisabled, Goal::QuickStop] {
            let mut seq = EnableSequencer::new(goal);
            let s = seq.step(Statusword(0x0008));
            assert_eq!(s.progress, Progress::Reached);
            assert!(!s.controlword.fault_reset());
        }
    }

    #[test]
    fn quick_stop_from_operation_enabled_sends_0x02_once_reached_holds() {
        let mut dev = device_in(State::OperationEnabled, QuickStopOption::QuickStopRampStay);
        let mut seq = EnableSequencer::new(Goal::QuickStop);
        let (_, sent) = run(&mut seq, &mut dev, 5);
        assert_eq!(sent, vec![Controlword(0x02)]);
        assert_eq!(dev.state(), State::QuickStopActive);
        // Then enabling again goes through SWITCH ON DISABLED, not transition 16.
        seq.set_goal(Goal::OperationEnabled);
        let (_, sent) = run(&mut seq, &mut dev, 10);
        assert_eq!(
            sent,
            vec![
                Controlword(0x00),
                Controlword(0x06),
                Controlword(0x07),
                Controlword(0x0F)
            ]
        );
    }

    #[test]
    fn enables_operation_flags_exactly_the_transition_4_frame() {
        let mut dev = device_in(State::SwitchOnDisabled, QuickStopOption::QuickStopRamp);
        let mut seq = EnableSequencer::new(Goal::OperationEnabled);
        let mut flagged = 0;
        for _ in 0..6 {
            let sw = dev.statusword();
            let s = seq.step(sw);
            if s.enables_operation(sw) {
                flagged += 1;
            }
            dev.on_controlword(s.controlword);
        }
        assert_eq!(flagged, 1);
        assert_eq!(dev.state(), State::OperationEnabled);
    }
}
