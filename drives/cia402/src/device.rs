//! The device side of the CiA 402 state machine: controlwords and internal events in,
//! numbered transitions out. The drive model decides when a fault happens, when a quick stop
//! or a fault reaction has finished, and what the motor does in each state.

use crate::mode::QuickStopOption;
use crate::state::{Command, State};
use crate::words::{Controlword, Statusword};

/// A CiA 402 state transition, numbered as in the standard's state diagram.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Transition {
    /// 0: power on → NOT READY TO SWITCH ON (by construction).
    T0,
    /// 1: initialisation done → SWITCH ON DISABLED.
    T1,
    /// 2: shutdown, SWITCH ON DISABLED → READY TO SWITCH ON.
    T2,
    /// 3: switch on, READY TO SWITCH ON → SWITCHED ON.
    T3,
    /// 4: enable operation, SWITCHED ON → OPERATION ENABLED.
    T4,
    /// 5: disable operation, OPERATION ENABLED → SWITCHED ON.
    T5,
    /// 6: shutdown, SWITCHED ON → READY TO SWITCH ON.
    T6,
    /// 7: disable voltage or quick stop, READY TO SWITCH ON → SWITCH ON DISABLED.
    T7,
    /// 8: shutdown, OPERATION ENABLED → READY TO SWITCH ON.
    T8,
    /// 9: disable voltage, OPERATION ENABLED → SWITCH ON DISABLED.
    T9,
    /// 10: disable voltage or quick stop, SWITCHED ON → SWITCH ON DISABLED.
    T10,
    /// 11: quick stop, OPERATION ENABLED → QUICK STOP ACTIVE.
    T11,
    /// 12: quick stop finished (options 0..=4) or disable voltage, QUICK STOP ACTIVE →
    /// SWITCH ON DISABLED.
    T12,
    /// 13: fault detected, any state → FAULT REACTION ACTIVE.
    T13,
    /// 14: fault reaction finished → FAULT.
    T14,
    /// 15: fault reset edge, FAULT → SWITCH ON DISABLED.
    T15,
    /// 16: enable operation in QUICK STOP ACTIVE (options 5..=8) → OPERATION ENABLED.
    T16,
}

/// The device's CiA 402 state machine.
///
/// Feed every received controlword to [`on_controlword`](Self::on_controlword) (it keeps the
/// previous bit 7 to detect the fault-reset edge); call [`fault`](Self::fault) when the drive
/// detects a fault, and [`fault_reaction_done`](Self::fault_reaction_done) /
/// [`quick_stop_done`](Self::quick_stop_done) when the motor has stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceStateMachine {
    state: State,
    last_fault_reset_bit: bool,
    quick_stop_option: QuickStopOption,
}

impl Default for DeviceStateMachine {
    fn default() -> Self {
        Self::new()
    }
}

impl DeviceStateMachine {
    /// A drive just powered on: NOT READY TO SWITCH ON (transition 0), quick stop option 2.
    pub const fn new() -> DeviceStateMachine {
        DeviceStateMachine {
            state: State::NotReadyToSwitchOn,
            last_fault_reset_bit: false,
            quick_stop_option: QuickStopOption::QuickStopRamp,
        }
    }

    /// The current state.
    pub const fn state(&self) -> State {
        self.state
    }

    /// Sets the quick stop option code (0x605A) that decides transitions 12 and 16.
    pub fn set_quick_stop_option(&mut self, option: QuickStopOption) {
        self.quick_stop_option = option;
    }

    /// The quick stop option code in force.
    pub const fn quick_stop_option(&self) -> QuickStopOption {
        self.quick_stop_option
    }

    /// The state bits of the statusword (bits 0..=6); the drive model adds bits 7..=15.
    pub const fn statusword(&self) -> Statusword {
        Statusword(self.state.statusword_bits())
    }

    /// Initialisation finished: NOT READY TO SWITCH ON → SWITCH ON DISABLED (transition 1).
    /// Returns `None` in any other state.
    pub fn init_done(&mut self) -> Option<Transition> {
        if self.state == State::NotReadyToSwitchOn {
            self.state = State::SwitchOnDisabled;
            Some(Transition::T1)
        } else {
            None
        }
    }

    /// Applies a received controlword; returns the transition taken, if any.
    ///
    /// READY TO SWITCH ON with enable operation (0x0F) takes transitions 3 and 4 at once, as
    /// the standard allows; the return value is then [`Transition::T4`]. In FAULT only the
    /// rising edge of bit 7 acts (transition 15); in NOT READY TO SWITCH ON and FAULT
    /// REACTION ACTIVE controlwords are ignored (bit 7 is still tracked).
    pub fn on_controlword(&mut self, cw: Controlword) -> Option<Transition> {
        let edge = cw.fault_reset() && !self.last_fault_reset_bit;
        self.last_fault_reset_bit = cw.fault_reset();
        let cmd = cw.command();
        let (next, t) = match (self.state, cmd) {
            (State::Fault, _) if edge => (State::SwitchOnDisabled, Transition::T15),
            (State::Fault | State::FaultReactionActive | State::NotReadyToSwitchOn, _) => {
                return None;
            }
            (State::SwitchOnDisabled, Command::Shutdown) => {
                (State::ReadyToSwitchOn, Transition::T2)
            }
            (State::SwitchOnDisabled, _) => return None,
            (State::ReadyToSwitchOn, Command::SwitchOn) => (State::SwitchedOn, Transition::T3),
            (State::ReadyToSwitchOn, Command::EnableOperation) => {
                (State::OperationEnabled, Transition::T4)
            }
            (State::ReadyToSwitchOn, Command::DisableVoltage | Command::QuickStop) => {
                (State::SwitchOnDisabled, Transition::T7)
            }
            (State::ReadyToSwitchOn, Command::Shutdown) => return None,
            (State::SwitchedOn, Command::EnableOperation) => {
                (State::OperationEnabled, Transition::T4)
            }
            (State::SwitchedOn, Command::Shutdown) => (State::ReadyToSwitchOn, Transition::T6),
            (State::SwitchedOn, Command::DisableVoltage | Command::QuickStop) => {
                (State::SwitchOnDisabled, Transition::T10)
            }
            (State::SwitchedOn, Command::SwitchOn) => return None,
            (State::OperationEnabled, Command::SwitchOn) => (State::SwitchedOn, Transition::T5),
            (State::OperationEnabled, Command::Shutdown) => {
                (State::ReadyToSwitchOn, Transition::T8)
            }
            (State::OperationEnabled, Command::DisableVoltage) => {
                (State::SwitchOnDisabled, Transition::T9)
            }
            (State::OperationEnabled, Command::QuickStop) => {
                if self.quick_stop_option.coasts() {
                    // Option 0 switches the power stage off at once: 11 then 12.
                    (State::SwitchOnDisabled, Transition::T12)
                } else {
                    (State::QuickStopActive, Transition::T11)
                }
            }
            (State::OperationEnabled, Command::EnableOperation) => return None,
            (State::QuickStopActive, Command::DisableVoltage) => {
                (State::SwitchOnDisabled, Transition::T12)
            }
            (State::QuickStopActive, Command::EnableOperation)
                if self.quick_stop_option.stays_in_quick_stop() =>
            {
                (State::OperationEnabled, Transition::T16)
            }
            (State::QuickStopActive, _) => return None,
        };
        self.state = next;
        Some(t)
    }

    /// The drive detected a fault: any state except FAULT / FAULT REACTION ACTIVE → FAULT
    /// REACTION ACTIVE (transition 13). A second fault during the reaction is absorbed.
    pub fn fault(&mut self) -> Option<Transition> {
        if self.state.is_fault() {
            None
        } else {
            self.state = State::FaultReactionActive;
            Some(Transition::T13)
        }
    }

    /// The fault reaction has finished (motor stopped, power stage off): → FAULT (14).
    pub fn fault_reaction_done(&mut self) -> Option<Transition> {
        if self.state == State::FaultReactionActive {
            self.state = State::Fault;
            Some(Transition::T14)
        } else {
            None
        }
    }

    /// The quick stop ramp has finished: → SWITCH ON DISABLED (12) for options 0..=4; the
    /// drive stays in QUICK STOP ACTIVE for options 5..=8 (returns `None`).
    pub fn quick_stop_done(&mut self) -> Option<Transition> {
        if self.state == State::QuickStopActive && !self.quick_stop_option.stays_in_quick_stop() {
            self.state = State::SwitchOnDisabled;
            Some(Transition::T12)
        } else {
            None
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Puts a machine into `target` through its public interface.
    pub(crate) fn machine_in(target: State, option: QuickStopOption) -> DeviceStateMachine {
        let mut m = DeviceStateMachine::new();
        m.set_quick_stop_option(option);
        let drive = |m: &mut DeviceStateMachine, cws: &[u16]| {
            for &c in cws {
                m.on_controlword(Controlword(c));
            }
        };
        match target {
            State::NotReadyToSwitchOn => {}
            State::SwitchOnDisabled => {
                m.init_done();
            }
            State::ReadyToSwitchOn => {
                m.init_done();
                drive(&mut m, &[0x06]);
            }
            State::SwitchedOn => {
                m.init_done();
                drive(&mut m, &[0x06, 0x07]);
            }
            State::OperationEnabled => {
                m.init_done();
                drive(&mut m, &[0x06, 0x07, 0x0F]);
            }
            State::QuickStopActive => {
                // Option 0 coasts straight through; reach QUICK STOP ACTIVE with a ramp, then
                // switch to the option under test.
                m.set_quick_stop_option(QuickStopOption::QuickStopRamp);
                m.init_done();
                drive(&mut m, &[0x06, 0x07, 0x0F, 0x02]);
                m.set_quick_stop_option(option);
            }
            State::FaultReactionActive => {
                m.init_done();
                m.fault();
            }
            State::Fault => {
                m.init_done();
                m.fault();
                m.fault_reaction_done();
            }
        }
        assert_eq!(m.state(), target);
        m
    }

    /// The standard's transition table, written out independently of the implementation:
    /// (from, command) → (to, transition), for the default (ramp, then disable) option.
    fn expected(from: State, cmd: Command) -> Option<(State, Transition)> {
        use Command::*;
        use State::*;
        use Transition::*;
        Some(match (from, cmd) {
            (SwitchOnDisabled, Shutdown) => (ReadyToSwitchOn, T2),
            (ReadyToSwitchOn, SwitchOn) => (SwitchedOn, T3),
            (ReadyToSwitchOn, EnableOperation) => (OperationEnabled, T4),
            (ReadyToSwitchOn, DisableVoltage) => (SwitchOnDisabled, T7),
            (ReadyToSwitchOn, QuickStop) => (SwitchOnDisabled, T7),
            (SwitchedOn, EnableOperation) => (OperationEnabled, T4),
            (SwitchedOn, Shutdown) => (ReadyToSwitchOn, T6),
            (SwitchedOn, DisableVoltage) => (SwitchOnDisabled, T10),
            (SwitchedOn, QuickStop) => (SwitchOnDisabled, T10),
            (OperationEnabled, SwitchOn) => (SwitchedOn, T5),
            (OperationEnabled, Shutdown) => (ReadyToSwitchOn, T8),
            (OperationEnabled, DisableVoltage) => (SwitchOnDisabled, T9),
            (OperationEnabled, QuickStop) => (QuickStopActive, T11),
            (QuickStopActive, DisableVoltage) => (SwitchOnDisabled, T12),
            _ => return None,
        })
    }

    #[test]
    fn every_state_and_controlword_follows_the_table() {
        for from in State::ALL {
            for cw in 0u16..=0x1FF {
                // Bit 7 low here: fault reset edges are tested separately.
                if cw & 0x80 != 0 {
                    continue;
                }
                let mut m = machine_in(from, QuickStopOption::QuickStopRamp);
                let t = m.on_controlword(Controlword(cw));
                match expected(from, Controlword(cw).command()) {
                    Some((to, tr)) => {
                        assert_eq!((m.state(), t), (to, Some(tr)), "{from} + {cw:#06x}")
                    }
                    None => assert_eq!((m.state(), t), (from, None), "{from} + {cw:#06x}"),
                }
            }
        }
    }

    #[test]
    fn fault_from_every_state_and_reset_only_on_rising_edge() {
        for from in State::ALL {
            let mut m = machine_in(from, QuickStopOption::QuickStopRamp);
            let t = m.fault();
            if from.is_fault() {
                assert_eq!((m.state(), t), (from, None));
            } else {
                assert_eq!(
                    (m.state(), t),
                    (State::FaultReactionActive, Some(Transition::T13))
                );
            }
            // Fault reset is ignored while the reaction runs…
            assert_eq!(m.on_controlword(Controlword(0x00)), None);
            if m.state() == State::FaultReactionActive {
                assert_eq!(m.on_controlword(Controlword(0x80)), None);
                assert_eq!(m.state(), State::FaultReactionActive);
                assert_eq!(m.fault_reaction_done(), Some(Transition::T14));
            } else {
                // Already in FAULT: raise bit 7 while not yet… it is an edge and resets.
                assert_eq!(m.on_controlword(Controlword(0x80)), Some(Transition::T15));
                m.fault();
                m.fault_reaction_done();
            }
            assert_eq!(m.state(), State::Fault);
            // …a level that was already high when FAULT was reached is not an edge…
            assert_eq!(m.on_controlword(Controlword(0x80)), None);
            assert_eq!(m.on_controlword(Controlword(0x8F)), None);
            // …other commands do nothing in FAULT…
            for cw in [0x00, 0x06, 0x07, 0x0F, 0x02] {
                assert_eq!(m.on_controlword(Controlword(cw)), None);
                assert_eq!(m.state(), State::Fault);
            }
            // …and the rising edge resets, with any low bits.
            assert_eq!(m.on_controlword(Controlword(0x86)), Some(Transition::T15));
            assert_eq!(m.state(), State::SwitchOnDisabled);
        }
    }

    #[test]
    fn rising_edge_outside_fault_is_only_its_command() {
        let mut m = machine_in(State::SwitchOnDisabled, QuickStopOption::QuickStopRamp);
        assert_eq!(m.on_controlword(Controlword(0x86)), Some(Transition::T2));
        assert_eq!(m.state(), State::ReadyToSwitchOn);
    }

    #[test]
    fn quick_stop_options_decide_transitions_12_and_16() {
        for v in 0..=8 {
            let opt = QuickStopOption::from_i16(v).unwrap();
            let mut m = machine_in(State::OperationEnabled, opt);
            let t = m.on_controlword(Controlword(0x02));
            if v == 0 {
                assert_eq!(
                    (m.state(), t),
                    (State::SwitchOnDisabled, Some(Transition::T12))
                );
                continue;
            }
            assert_eq!(
                (m.state(), t),
                (State::QuickStopActive, Some(Transition::T11))
            );
            // Re-enable (16) only for the staying options.
            let mut again = m.clone();
            let t16 = again.on_controlword(Controlword(0x0F));
            if v >= 5 {
                assert_eq!(
                    (again.state(), t16),
                    (State::OperationEnabled, Some(Transition::T16))
                );
            } else {
                assert_eq!((again.state(), t16), (State::QuickStopActive, None));
            }
            let done = m.quick_stop_done();
            if v <= 4 {
                assert_eq!(
                    (m.state(), done),
                    (State::SwitchOnDisabled, Some(Transition::T12))
                );
            } else {
                assert_eq!((m.state(), done), (State::QuickStopActive, None));
                assert_eq!(m.on_controlword(Controlword(0x00)), Some(Transition::T12));
            }
        }
    }

    #[test]
    fn init_done_only_from_not_ready() {
        let mut m = DeviceStateMachine::new();
        assert_eq!(m.state(), State::NotReadyToSwitchOn);
        assert_eq!(m.on_controlword(Controlword(0x06)), None);
        assert_eq!(m.init_done(), Some(Transition::T1));
        assert_eq!(m.init_done(), None);
        assert_eq!(m.fault_reaction_done(), None);
        assert_eq!(m.quick_stop_done(), None);
        assert_eq!(m.statusword().state(), Some(State::SwitchOnDisabled));
    }
}
