//! drivectl's errors: every failure carries a message in protocol terms (node, object, abort
//! code and name, state) and a cause ([`Exit`]) that maps to one of the exit codes shared by
//! all binaries (docs/exit-codes.md).

use core::fmt;

use cnc402_config::exit;
use cnc402_drives::bus::BusError;
use cnc402_drives::master::{BootError, SdoError, SdoErrorKind, SequenceError};

/// What ended a command; [`Exit::code`] maps each cause onto the exit codes all binaries of
/// the workspace share (`cnc402_config::exit`, docs/exit-codes.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exit {
    /// Success.
    Ok,
    /// A bad command line, a value out of range for its type, a target outside the soft
    /// limits.
    Usage,
    /// The drive aborted an SDO transfer (abort code and name printed).
    SdoAbort,
    /// No answer in time: absent node, SDO timeout, no boot-up / heartbeat.
    Timeout,
    /// The drive is in the wrong state: stuck in a CiA 402 state, in FAULT, refuses a mode,
    /// a safety stop during jog/move/identify, identify on a drive that is not enabled.
    DriveState,
    /// The CAN transport failed: interface missing, kernel without CAN, bus-off, down.
    Bus,
    /// Protocol error: wrong data type/size, SDO protocol violation, not a CiA 402 device.
    Protocol,
    /// The machine config or an EDS/DCF is unreadable or invalid.
    Config,
    /// A local file or the terminal failed (the `--log` file, the TUI).
    Io,
    /// A master state drivectl should never meet (busy, no bus capacity, no drive).
    Internal,
}

impl Exit {
    /// The process exit code of this cause.
    pub fn code(self) -> u8 {
        match self {
            Exit::Ok => exit::OK,
            Exit::Usage => exit::USAGE,
            Exit::SdoAbort => exit::SDO_ABORT,
            Exit::Timeout => exit::TIMEOUT,
            Exit::DriveState => exit::FAULT,
            Exit::Bus | Exit::Io => exit::IO,
            Exit::Protocol => exit::PROTOCOL,
            Exit::Config => exit::CONFIG,
            Exit::Internal => exit::INTERNAL,
        }
    }
}

/// A failure: exit code plus message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CliError {
    /// The exit code.
    pub exit: Exit,
    /// What went wrong, in protocol terms.
    pub message: String,
}

impl CliError {
    /// An error with this code and message.
    pub fn new(exit: Exit, message: impl Into<String>) -> CliError {
        CliError {
            exit,
            message: message.into(),
        }
    }
    /// A usage error.
    pub fn usage(m: impl Into<String>) -> CliError {
        CliError::new(Exit::Usage, m)
    }
    /// The drive is in the wrong state.
    pub fn state(m: impl Into<String>) -> CliError {
        CliError::new(Exit::DriveState, m)
    }
    /// No answer in time.
    pub fn timeout(m: impl Into<String>) -> CliError {
        CliError::new(Exit::Timeout, m)
    }
    /// A protocol error.
    pub fn protocol(m: impl Into<String>) -> CliError {
        CliError::new(Exit::Protocol, m)
    }
    /// A short machine-readable kind for `--json` error output.
    pub fn kind(&self) -> &'static str {
        match self.exit {
            Exit::Ok => "ok",
            Exit::Usage => "usage",
            Exit::SdoAbort => "sdo_abort",
            Exit::Timeout => "timeout",
            Exit::DriveState => "drive_state",
            Exit::Bus => "bus",
            Exit::Protocol => "protocol",
            Exit::Config => "config",
            Exit::Io => "io",
            Exit::Internal => "internal",
        }
    }
    /// Prefixes the message with context.
    pub fn context(mut self, what: impl fmt::Display) -> CliError {
        self.message = format!("{what}: {}", self.message);
        self
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for CliError {}

/// The exit code an SDO failure maps to.
pub fn sdo_exit(kind: &SdoErrorKind) -> Exit {
    match kind {
        SdoErrorKind::Aborted(_) => Exit::SdoAbort,
        SdoErrorKind::Timeout { .. } => Exit::Timeout,
        SdoErrorKind::Protocol { .. } | SdoErrorKind::WrongSize { .. } => Exit::Protocol,
        SdoErrorKind::Bus(_) => Exit::Bus,
        SdoErrorKind::Busy | SdoErrorKind::NoBusCapacity { .. } | SdoErrorKind::NoDrive { .. } => {
            Exit::Internal
        }
    }
}

impl From<SdoError> for CliError {
    fn from(e: SdoError) -> CliError {
        let mut message = e.to_string();
        if let SdoErrorKind::Timeout { .. } = e.kind {
            message.push_str(&format!(
                " — is node {} on the bus and in PRE-OPERATIONAL or OPERATIONAL?",
                e.node
            ));
        }
        CliError::new(sdo_exit(&e.kind), message)
    }
}

impl From<BusError> for CliError {
    fn from(e: BusError) -> CliError {
        CliError::new(Exit::Bus, e.to_string())
    }
}

impl From<SequenceError> for CliError {
    fn from(e: SequenceError) -> CliError {
        match e {
            SequenceError::Sdo(s) => s.into(),
            SequenceError::Bus(b) => b.into(),
            SequenceError::Stuck { .. } => CliError::state(e.to_string()),
        }
    }
}

impl From<BootError> for CliError {
    fn from(e: BootError) -> CliError {
        let exit = match &e {
            BootError::NoBootUp { .. } => Exit::Timeout,
            BootError::Sdo(s) => sdo_exit(&s.kind),
            BootError::NotCia402 { .. } => Exit::Protocol,
            BootError::Bus(_) => Exit::Bus,
            _ => Exit::DriveState,
        };
        CliError::new(exit, e.to_string())
    }
}

/// Result alias.
pub type Result<T> = core::result::Result<T, CliError>;
