//! The eight CiA 402 power states and the device control commands.

use core::fmt;

use crate::words::{Controlword, Statusword};

/// A CiA 402 power state, as decoded from the statusword.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum State {
    /// Initialising; the drive leaves it by itself.
    NotReadyToSwitchOn,
    /// Power stage off, drive waiting for shutdown.
    SwitchOnDisabled,
    /// Ready; power stage may be off.
    ReadyToSwitchOn,
    /// Power stage on, no torque.
    SwitchedOn,
    /// The drive follows its setpoints.
    OperationEnabled,
    /// Quick stop in progress (or held, per 0x605A).
    QuickStopActive,
    /// Fault detected; the fault reaction runs.
    FaultReactionActive,
    /// Fault; waiting for a fault reset edge.
    Fault,
}

impl State {
    /// All eight states.
    pub const ALL: [State; 8] = [
        State::NotReadyToSwitchOn,
        State::SwitchOnDisabled,
        State::ReadyToSwitchOn,
        State::SwitchedOn,
        State::OperationEnabled,
        State::QuickStopActive,
        State::FaultReactionActive,
        State::Fault,
    ];

    /// `(mask, value)` that identifies this state in a statusword.
    pub const fn mask_value(self) -> (u16, u16) {
        match self {
            State::NotReadyToSwitchOn => (0x4F, 0x00),
            State::SwitchOnDisabled => (0x4F, 0x40),
            State::ReadyToSwitchOn => (0x6F, 0x21),
            State::SwitchedOn => (0x6F, 0x23),
            State::OperationEnabled => (0x6F, 0x27),
            State::QuickStopActive => (0x6F, 0x07),
            State::FaultReactionActive => (0x4F, 0x0F),
            State::Fault => (0x4F, 0x08),
        }
    }

    /// Decodes the state from a statusword by the CiA 402 masks; `None` if no state matches
    /// (e.g. 0x0001, or bit 3 with bit 6).
    ///
    /// ```
    /// use cia402::{State, Statusword};
    /// assert_eq!(State::from_statusword(Statusword(0x0237)), Some(State::OperationEnabled));
    /// assert_eq!(State::from_statusword(Statusword(0x0250)), Some(State::SwitchOnDisabled));
    /// assert_eq!(State::from_statusword(Statusword(0x0001)), None);
    /// ```
    pub const fn from_statusword(sw: Statusword) -> Option<State> {
        let mut i = 0;
        while i < State::ALL.len() {
            let s = State::ALL[i];
            let (mask, value) = s.mask_value();
            if sw.0 & mask == value {
                return Some(s);
            }
            i += 1;
        }
        None
    }

    /// Statusword state bits a device reports in this state (bit 4 voltage enabled set where
    /// the power stage has voltage, bit 5 quick stop high unless a quick stop runs).
    pub const fn statusword_bits(self) -> u16 {
        match self {
            State::NotReadyToSwitchOn => 0x0000,
            State::SwitchOnDisabled => 0x0040,
            State::ReadyToSwitchOn => 0x0031,
            State::SwitchedOn => 0x0033,
            State::OperationEnabled => 0x0037,
            State::QuickStopActive => 0x0017,
            State::FaultReactionActive => 0x001F,
            State::Fault => 0x0008,
        }
    }

    /// Whether the power stage produces torque (the drive may move).
    pub const fn is_powered(self) -> bool {
        matches!(
            self,
            State::OperationEnabled | State::QuickStopActive | State::FaultReactionActive
        )
    }

    /// FAULT or FAULT REACTION ACTIVE.
    pub const fn is_fault(self) -> bool {
        matches!(self, State::Fault | State::FaultReactionActive)
    }

    /// The name as CiA 402 writes it (upper case).
    pub const fn name(self) -> &'static str {
        match self {
            State::NotReadyToSwitchOn => "NOT READY TO SWITCH ON",
            State::SwitchOnDisabled => "SWITCH ON DISABLED",
            State::ReadyToSwitchOn => "READY TO SWITCH ON",
            State::SwitchedOn => "SWITCHED ON",
            State::OperationEnabled => "OPERATION ENABLED",
            State::QuickStopActive => "QUICK STOP ACTIVE",
            State::FaultReactionActive => "FAULT REACTION ACTIVE",
            State::Fault => "FAULT",
        }
    }
}

impl fmt::Display for State {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A device control command (bits 0..=3 of the controlword). Fault reset is separate: it is
/// the rising edge of bit 7.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Command {
    /// 0x06: transitions 2, 6, 8.
    Shutdown,
    /// 0x07: transition 3 (switch on) and 5 (disable operation).
    SwitchOn,
    /// 0x0F: transitions 4 and 16 (and 3+4 from READY TO SWITCH ON).
    EnableOperation,
    /// 0x00 (bit 1 low): transitions 7, 9, 10, 12.
    DisableVoltage,
    /// 0x02 (bit 1 high, bit 2 low): transitions 7, 10, 11.
    QuickStop,
}

impl Command {
    /// The canonical controlword for this command (fault reset bit low).
    pub const fn controlword(self) -> Controlword {
        match self {
            Command::Shutdown => Controlword::SHUTDOWN,
            Command::SwitchOn => Controlword::SWITCH_ON_CMD,
            Command::EnableOperation => Controlword::ENABLE_OPERATION_CMD,
            Command::DisableVoltage => Controlword::DISABLE_VOLTAGE,
            Command::QuickStop => Controlword::QUICK_STOP_CMD,
        }
    }

    /// Lower-case name for messages.
    pub const fn name(self) -> &'static str {
        match self {
            Command::Shutdown => "shutdown",
            Command::SwitchOn => "switch on",
            Command::EnableOperation => "enable operation",
            Command::DisableVoltage => "disable voltage",
            Command::QuickStop => "quick stop",
        }
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

// The words' meaning as states and commands lives here, so that `words` (the bits) depends
// on nothing and the state machine on the words.
impl Controlword {
    /// The state machine command encoded in bits 0..=3 (CiA 402 table of device control
    /// commands). Every bit pattern is one command; fault reset is an edge of bit 7 and
    /// is not returned here.
    ///
    /// ```
    /// use cia402::{Command, Controlword};
    /// assert_eq!(Controlword(0x000F).command(), Command::EnableOperation);
    /// assert_eq!(Controlword(0x000B).command(), Command::QuickStop);
    /// ```
    pub const fn command(self) -> Command {
        if !self.enable_voltage() {
            Command::DisableVoltage
        } else if self.quick_stop_requested() {
            Command::QuickStop
        } else if !self.switch_on() {
            Command::Shutdown
        } else if !self.enable_operation() {
            Command::SwitchOn
        } else {
            Command::EnableOperation
        }
    }
}

impl From<Command> for Controlword {
    fn from(c: Command) -> Controlword {
        c.controlword()
    }
}

impl fmt::Display for Controlword {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#06x} ({})", self.0, self.command())
    }
}

impl Statusword {
    /// The power state, or `None` for a bit pattern no state has.
    pub const fn state(self) -> Option<State> {
        State::from_statusword(self)
    }
}

impl fmt::Display for Statusword {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.state() {
            Some(s) => write!(f, "{:#06x} ({s})", self.0),
            None => write!(f, "{:#06x} (no state)", self.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_state_decodes_from_its_own_bits_and_the_notes_values() {
        for s in State::ALL {
            assert_eq!(
                State::from_statusword(Statusword(s.statusword_bits())),
                Some(s)
            );
            let (_, value) = s.mask_value();
            assert_eq!(State::from_statusword(Statusword(value)), Some(s));
            // Upper bits (warning, remote, target reached, CSP bits) do not change the state.
            assert_eq!(
                State::from_statusword(Statusword(s.statusword_bits() | 0xFE90)),
                Some(s)
            );
        }
        // Real drives report these.
        assert_eq!(Statusword(0x0250).state(), Some(State::SwitchOnDisabled));
        assert_eq!(Statusword(0x0231).state(), Some(State::ReadyToSwitchOn));
        assert_eq!(Statusword(0x1637).state(), Some(State::OperationEnabled));
        assert_eq!(Statusword(0x0218).state(), Some(State::Fault));
        assert_eq!(Statusword(0x0228).state(), Some(State::Fault));
    }

    #[test]
    fn exactly_one_or_no_state_per_statusword() {
        let mut undefined = 0;
        for sw in 0..=u16::MAX {
            let n = State::ALL
                .iter()
                .filter(|s| {
                    let (m, v) = s.mask_value();
                    sw & m == v
                })
                .count();
            assert!(n <= 1, "{sw:#06x} matches {n} states");
            if n == 0 {
                assert_eq!(Statusword(sw).state(), None);
                undefined += 1;
            }
        }
        assert!(undefined > 0);
        assert_eq!(Statusword(0x0001).state(), None);
    }

    #[test]
    fn controlword_commands_decode_per_table() {
        // CiA 402 command table: (bits 3..0 pattern with x = don't care) → command.
        for cw in 0u16..=0x1FF {
            let b = |i: u16| cw & (1 << i) != 0;
            let expected = if !b(1) {
                Command::DisableVoltage
            } else if !b(2) {
                Command::QuickStop
            } else if !b(0) {
                Command::Shutdown
            } else if !b(3) {
                Command::SwitchOn
            } else {
                Command::EnableOperation
            };
            assert_eq!(Controlword(cw).command(), expected, "{cw:#06x}");
        }
        assert_eq!(Controlword(0x06).command(), Command::Shutdown);
        assert_eq!(Controlword(0x0E).command(), Command::Shutdown);
        assert_eq!(Controlword(0x07).command(), Command::SwitchOn);
        assert_eq!(Controlword(0x0F).command(), Command::EnableOperation);
        assert_eq!(Controlword(0x00).command(), Command::DisableVoltage);
        assert_eq!(Controlword(0x0D).command(), Command::DisableVoltage);
        assert_eq!(Controlword(0x02).command(), Command::QuickStop);
        assert_eq!(Controlword(0x0B).command(), Command::QuickStop);
        for c in [
            Command::Shutdown,
            Command::SwitchOn,
            Command::EnableOperation,
            Command::DisableVoltage,
            Command::QuickStop,
        ] {
            assert_eq!(c.controlword().command(), c);
        }
    }

    #[test]
    fn named_bits() {
        let cw = Controlword(0x018F);
        assert!(cw.switch_on() && cw.enable_voltage() && cw.enable_operation());
        assert!(cw.fault_reset() && cw.halt() && !cw.quick_stop_requested());
        assert!(Controlword(0x0B).quick_stop_requested());
        let sw = Statusword(0x3EA8);
        assert!(sw.fault() && sw.warning() && sw.remote() && sw.target_reached());
        assert!(sw.internal_limit() && sw.follows_command() && sw.following_error());
        assert_eq!(Statusword(0).with(Statusword::REMOTE, true).bits(), 0x200);
        assert_eq!(
            Controlword(0x8F).with(Controlword::FAULT_RESET, false),
            Controlword(0x0F)
        );
    }
}
