//! The values a safety monitor produces: [`SafetyStop`] names the axis, node, statusword
//! (decoded state), EMCY code with a short text, and leaves room for the program line, which
//! the caller adds with [`SafetyStop::at_line`].

use core::fmt;

use cia402::Statusword;

use crate::bus::BusError;
use crate::time::Instant;
use crate::wire::{EmcyRepr, NmtState};

/// An EMCY message as received: code, error register, manufacturer bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emcy {
    /// Error code (CiA 301 / CiA 402).
    pub code: u16,
    /// Error register 0x1001.
    pub register: u8,
    /// Manufacturer-specific bytes.
    pub manufacturer: [u8; 5],
}

impl From<EmcyRepr> for Emcy {
    fn from(r: EmcyRepr) -> Emcy {
        Emcy {
            code: r.code,
            register: r.register,
            manufacturer: r.manufacturer,
        }
    }
}

impl Emcy {
    /// A short text for the code.
    pub fn text(&self) -> &'static str {
        emcy_text(self.code)
    }
}

impl fmt::Display for Emcy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "EMCY {:#06x} ({})", self.code, self.text())
    }
}

/// A short text for an EMCY error code: the exact code where this project knows it
/// (CiA 301 communication codes, CiA 402 following error), else its CiA 301 class.
pub fn emcy_text(code: u16) -> &'static str {
    match code {
        0x0000 => "error reset / no error",
        0x8110 => "CAN overrun, objects lost",
        0x8120 => "CAN in error passive mode",
        0x8130 => "life guard or heartbeat error",
        0x8140 => "recovered from bus-off",
        0x8210 => "PDO not processed due to length error",
        0x8220 => "PDO length exceeded",
        0x8250 => "RPDO timeout",
        0x8611 => "following error",
        0x8612 => "reference limit",
        0x7500 => "communication error",
        0x6010 => "software reset (watchdog)",
        _ => match code >> 8 {
            0x10 => "generic error",
            0x20..=0x2F => "current",
            0x30..=0x3F => "voltage",
            0x40..=0x4F => "temperature",
            0x50..=0x5F => "device hardware",
            0x60..=0x6F => "device software",
            0x70..=0x7F => "additional modules",
            0x80 => "monitoring",
            0x81 => "communication",
            0x82 => "protocol error",
            0x83..=0x8F => "monitoring (drive)",
            0x90..=0x9F => "external error",
            0xF0..=0xFE => "additional functions",
            0xFF => "device specific",
            _ => "unknown error code",
        },
    }
}

/// Why the machine is being stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StopReason {
    /// The drive reports FAULT or FAULT REACTION ACTIVE.
    DriveFault,
    /// The drive sent an EMCY (not an error reset) while its statusword shows no fault yet.
    Emergency,
    /// A drive left OPERATION ENABLED without a fault (e.g. its quick stop input, or disabled).
    NotEnabled,
    /// The drive's heartbeat was not seen for this long (over `bus.heartbeat_timeout_ms`).
    HeartbeatLost {
        /// Milliseconds since the last heartbeat.
        silent_ms: u64,
    },
    /// The drive's heartbeat reports an NMT state other than OPERATIONAL (a reset or stop).
    NmtState(NmtState),
    /// The drive's TPDO1 was missing for this many consecutive cycles.
    TpdoMissing {
        /// Consecutive cycles.
        cycles: u32,
    },
    /// |command − actual| beyond the axis's following error window.
    FollowingError {
        /// Command (delayed, see `cyclic`) minus actual, in axis units.
        error: f64,
        /// The window, in axis units.
        window: f64,
    },
    /// Compact layout: the drive's event-driven statusword (TPDO2) did not come for this
    /// long, more than its event timer allows (three timer periods, or the TPDO time-out).
    StatuswordStale {
        /// Milliseconds since the last statusword.
        silent_ms: u64,
    },
    /// A commanded position was not finite.
    BadSetpoint,
    /// The CAN transport failed.
    Bus(BusError),
    /// The drive's 0x60FD reports a limit switch (bit 0 negative, bit 1 positive).
    LimitSwitch {
        /// The positive one.
        positive: bool,
    },
    /// The E-stop input (`[machine] estop_input`, a 0x60FD bit) opened.
    EstopOpen {
        /// The 0x60FD bit.
        bit: u8,
    },
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StopReason::DriveFault => write!(f, "drive fault"),
            StopReason::Emergency => write!(f, "emergency message"),
            StopReason::NotEnabled => write!(f, "drive left OPERATION ENABLED"),
            StopReason::HeartbeatLost { silent_ms } => {
                write!(f, "heartbeat lost (none for {silent_ms} ms)")
            }
            StopReason::StatuswordStale { silent_ms } => write!(
                f,
                "statusword stale: no TPDO2 statusword for {silent_ms} ms (its event timer \
                 sends one every heartbeat period)"
            ),
            StopReason::NmtState(NmtState::BootUp) => {
                write!(
                    f,
                    "drive rebooted (boot-up message during cyclic operation)"
                )
            }
            StopReason::NmtState(s) => write!(f, "drive left NMT OPERATIONAL ({s:?})"),
            StopReason::TpdoMissing { cycles } => {
                write!(f, "TPDO1 missing for {cycles} consecutive cycles")
            }
            StopReason::FollowingError { error, window } => {
                write!(f, "following error {error:.4} beyond window ±{window:.4}")
            }
            StopReason::BadSetpoint => write!(f, "commanded position not finite"),
            StopReason::Bus(e) => write!(f, "CAN bus: {e}"),
            StopReason::LimitSwitch { positive } => write!(
                f,
                "{} limit switch (0x60FD bit {})",
                if *positive { "positive" } else { "negative" },
                u8::from(*positive)
            ),
            StopReason::EstopOpen { bit } => write!(f, "E-stop open (0x60FD bit {bit} is 0)"),
        }
    }
}

/// A safety stop: the first monitor that tripped, with everything a person needs to find
/// the cause. The master has already switched to its stop reaction when it returns this.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafetyStop {
    /// What tripped.
    pub reason: StopReason,
    /// The axis letter (`None` for a bus-wide cause).
    pub axis: Option<char>,
    /// The axis index in the config.
    pub axis_index: Option<usize>,
    /// The drive's node id.
    pub node: Option<u8>,
    /// The drive's last statusword (its state decodes with `Statusword::state`).
    pub statusword: Option<Statusword>,
    /// The first EMCY the drive sent since enabling (the cause when more followed).
    pub emcy: Option<Emcy>,
    /// When the master noticed.
    pub at: Instant,
    /// The program line being executed (filled by the caller).
    pub line: Option<u32>,
}

impl SafetyStop {
    /// This stop with the program line set.
    pub fn at_line(mut self, line: u32) -> SafetyStop {
        self.line = Some(line);
        self
    }
}

impl fmt::Display for SafetyStop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.axis, self.node) {
            (Some(a), Some(n)) => write!(f, "axis {a} (node {n}): ")?,
            (Some(a), None) => write!(f, "axis {a}: ")?,
            (None, Some(n)) => write!(f, "node {n}: ")?,
            (None, None) => {}
        }
        write!(f, "{}", self.reason)?;
        if let Some(sw) = self.statusword {
            write!(f, "; statusword {sw}")?;
        }
        if let Some(e) = self.emcy {
            write!(f, "; {e}")?;
        }
        if let Some(l) = self.line {
            write!(f, "; at program line {l}")?;
        }
        write!(f, " (t = {})", self.at)
    }
}

impl std::error::Error for SafetyStop {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texts_and_display() {
        assert_eq!(emcy_text(0x8611), "following error");
        assert_eq!(emcy_text(0x2310), "current");
        assert_eq!(emcy_text(0x4210), "temperature");
        assert_eq!(emcy_text(0xFF01), "device specific");
        let s = SafetyStop {
            reason: StopReason::DriveFault,
            axis: Some('Z'),
            axis_index: Some(2),
            node: Some(3),
            statusword: Some(Statusword(0x0218)),
            emcy: Some(Emcy {
                code: 0x8611,
                register: 0x20,
                manufacturer: [0; 5],
            }),
            at: Instant::from_millis(1500),
            line: None,
        }
        .at_line(42);
        let t = s.to_string();
        for part in [
            "axis Z (node 3)",
            "drive fault",
            "FAULT",
            "0x8611",
            "following error",
            "line 42",
        ] {
            assert!(t.contains(part), "{t} lacks {part}");
        }
    }
}
