//! drivectl's errors: every failure carries a message in protocol terms (node, object, abort
//! code and name, state) and one of the documented exit codes ([`Exit`]).

use core::fmt;

use cnc402_drives::bus::BusError;
use cnc402_drives::master::{BootError, SdoError, SdoErrorKind, SequenceError};

/// Exit codes (also in `drivectl --help` and README.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exit {
    /// 0: success.
    Ok = 0,
    /// 1: an error not covered below (internal, I/O on a log file).
    Other = 1,
    /// 2: bad command line (clap's own usage errors use 2 too), value out of range, target
    /// outside the soft limits.
    Usage = 2,
    /// 3: the drive aborted an SDO transfer (abort code and name printed).
    SdoAbort = 3,
    /// 4: no answer in time: absent node, SDO timeout, no boot-up / heartbeat.
    Timeout = 4,
    /// 5: the drive is in the wrong state: stuck in a CiA 402 state, in FAULT, refuses a mode,
    /// a safety stop during jog/move/identify, identify on a drive that is not enabled.
    DriveState = 5,
    /// 6: the CAN transport failed: interface missing, kernel without CAN, bus-off, down.
    Bus = 6,
    /// 7: protocol error: wrong data type/size, SDO protocol violation, not a CiA 402 device.
    Protocol = 7,
    /// 8: a file could not be read or parsed (machine config, EDS/DCF).
    File = 8,
}

/// The exit code table as printed in `--help`.
pub const EXIT_CODE_TABLE: &str = "\
Exit codes:
  0  success
  1  other error (internal, writing the log file)
  2  usage: bad arguments, value out of range for its type, target outside soft limits
  3  SDO abort: the drive refused the transfer (abort code and its name are printed)
  4  timeout: absent node, no SDO response, no boot-up or heartbeat in time
  5  drive state: stuck in a CiA 402 state (state and why printed), drive in FAULT,
     mode refused or not confirmed by 0x6061, safety stop during jog/move/identify,
     identify on a drive that is not enabled
  6  CAN transport: no such interface, kernel without CAN (errno 97), bus-off, down
  7  protocol: wrong data type/size, SDO protocol violation, not a CiA 402 device
  8  file: machine config or EDS/DCF unreadable or invalid";

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
    /// Exit 2.
    pub fn usage(m: impl Into<String>) -> CliError {
        CliError::new(Exit::Usage, m)
    }
    /// Exit 5.
    pub fn state(m: impl Into<String>) -> CliError {
        CliError::new(Exit::DriveState, m)
    }
    /// Exit 4.
    pub fn timeout(m: impl Into<String>) -> CliError {
        CliError::new(Exit::Timeout, m)
    }
    /// Exit 7.
    pub fn protocol(m: impl Into<String>) -> CliError {
        CliError::new(Exit::Protocol, m)
    }
    /// A short machine-readable kind for `--json` error output.
    pub fn kind(&self) -> &'static str {
        match self.exit {
            Exit::Ok => "ok",
            Exit::Other => "other",
            Exit::Usage => "usage",
            Exit::SdoAbort => "sdo_abort",
            Exit::Timeout => "timeout",
            Exit::DriveState => "drive_state",
            Exit::Bus => "bus",
            Exit::Protocol => "protocol",
            Exit::File => "file",
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
            Exit::Other
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
