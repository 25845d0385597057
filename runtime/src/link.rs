//! The loop's view of the drives: [`DriveLink`], one exchange of setpoints for feedback per
//! period, plus start-up (boot, configure, enable) and quick stop. The CANopen master over a
//! bus implements it (the product's one drive model is the master's); a bus-less test double
//! lives in `crate::testing` (feature `testing`).

use cnc402_config::MAX_AXES;
use cnc402_drives::Instant;
use cnc402_drives::bus::{BusCounters, BusError};

/// What one drive reported in one cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DriveFeedback {
    /// Position actual value 0x6064 in axis units, unwrapped (the link follows INT32 wraps).
    pub actual: f64,
    /// Statusword 0x6041 (0 for an axis without a drive).
    pub statusword: u16,
    /// The following error the link's monitor sees (command delayed by the drive's dead time
    /// minus actual), axis units.
    pub following_error: f64,
    /// How many cycles older than the freshest possible sample `actual` is (a TPDO that came
    /// late on a loaded bus); compare axes only at equal age.
    pub age: u32,
    /// `actual` in counts, exact (the link's unwrapped 0x6064 count; `as i32` is the value
    /// on the wire).
    pub actual_counts: i64,
    /// The setpoint this cycle's command became (INT32 counts, wrapping), as sent.
    pub target: i32,
}

/// Why the machine must stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopCause {
    /// A drive is in FAULT (statusword bit 3), with or without an EMCY.
    DriveFault,
    /// An EMCY with an error code other than "no error" arrived.
    Emergency,
    /// A drive's heartbeat was not seen within its timeout.
    HeartbeatLost,
    /// A drive's TPDO was missing for the configured number of cycles.
    TpdoMissing,
    /// Following error (setpoint − 0x6064) beyond the axis window for its time-out.
    FollowingError,
    /// The bus failed (bus-off, interface down, I/O error).
    Bus,
    /// A drive left OPERATION ENABLED (or NMT OPERATIONAL) without a fault.
    NotEnabled,
    /// A drive sent its boot-up message during cyclic operation: it reset itself (watchdog,
    /// power dip) and lost its configuration.
    DriveRebooted,
    /// A commanded position was not finite.
    BadSetpoint,
    /// The operator asked (SIGINT).
    Operator,
    /// A move could not be started (an interpreter/planner inconsistency).
    Motion,
    /// A drive's 0x60FD reports a limit switch (`limit_switch_inputs`).
    LimitSwitch,
    /// The E-stop chain opened (`[machine] estop_input`).
    EstopOpen,
    /// Another channel stopped (its fault or motion error, with `on_error = "all"`).
    OtherChannel,
    /// Channels wait for each other at wait marks that can never all be reached.
    ChannelDeadlock,
    /// The channel's program ended in an error while it ran (a multi-channel run stops that
    /// channel along its path, and the others as its `on_error` says).
    ProgramError,
}

impl StopCause {
    /// Short human text.
    pub fn describe(self) -> &'static str {
        match self {
            StopCause::DriveFault => "drive fault",
            StopCause::Emergency => "emergency message",
            StopCause::HeartbeatLost => "heartbeat lost",
            StopCause::TpdoMissing => "feedback PDO missing",
            StopCause::FollowingError => "following error beyond window",
            StopCause::Bus => "CAN bus error",
            StopCause::NotEnabled => "drive left operation enabled",
            StopCause::DriveRebooted => "drive rebooted (boot-up during cyclic operation)",
            StopCause::BadSetpoint => "commanded position not finite",
            StopCause::Operator => "operator stop (SIGINT)",
            StopCause::Motion => "motion error",
            StopCause::LimitSwitch => "limit switch",
            StopCause::EstopOpen => "E-stop open",
            StopCause::OtherChannel => "another channel stopped",
            StopCause::ChannelDeadlock => "channel wait deadlock",
            StopCause::ProgramError => "program error",
        }
    }
}

/// A safety reaction: what happened and on which drive. Heap-free, so the loop can carry it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriveStop {
    pub cause: StopCause,
    /// CANopen node id of the drive concerned (0 = not a drive: operator, bus, motion).
    pub node: u8,
    /// Its last statusword.
    pub statusword: u16,
    /// The EMCY error code it sent, if any.
    pub emcy: Option<u16>,
    /// For a bus stop: what failed (bus-off, interface down, I/O error).
    pub bus: Option<BusError>,
}

impl DriveStop {
    /// The cause for a person: `describe()`, with the kind of a bus error in brackets
    /// ("CAN bus error (bus-off)"). Not for the loop: it allocates.
    pub fn cause_text(&self) -> String {
        let cause = self.cause.describe();
        match self.bus {
            None => cause.to_string(),
            Some(e) => format!("{cause} ({})", bus_error_kind(e)),
        }
    }
}

/// A bus error's kind in a few words.
fn bus_error_kind(e: BusError) -> String {
    match e {
        BusError::BusOff => "bus-off".into(),
        BusError::Down => "interface down".into(),
        BusError::TxQueueFull => "transmit queue full".into(),
        BusError::Io(errno) => format!("I/O error, errno {errno}"),
    }
}

/// Progress of start-up, polled once per period.
#[derive(Clone, Debug, PartialEq)]
pub enum Startup {
    /// Still booting / configuring / enabling.
    Pending,
    /// Every drive is in OPERATION ENABLED, holding this actual position (axis units, indexed
    /// like the config's axes).
    Ready([f64; MAX_AXES]),
    /// Start-up failed (which drive, which object or state, and why).
    Failed(String),
}

/// The drives as the loop sees them. Implementations must not allocate, log or lock in
/// [`cycle`](Self::cycle) and [`quick_stop`](Self::quick_stop).
pub trait DriveLink {
    /// One start-up step at `now` (boot, SDO configuration, enable). Called every period until
    /// it returns `Ready` or `Failed`; never from the cyclic part. May allocate and log.
    fn startup(&mut self, now: Instant) -> Startup;
    /// One cycle at `now`: send `commands` (axis units, config axis order) and SYNC, and fill
    /// `feedback` with what came back. Returns the first safety reaction the monitors
    /// raised; a stop is reported once, later cycles keep exchanging with the healthy drives.
    fn cycle(
        &mut self,
        now: Instant,
        commands: &[f64; MAX_AXES],
        feedback: &mut [DriveFeedback; MAX_AXES],
    ) -> Result<(), DriveStop>;
    /// Commands quick stop to every drive (one step per call, fills `feedback` like `cycle`).
    /// Returns true once every drive has stopped (quick stop active, disabled or in fault).
    fn quick_stop(&mut self, now: Instant, feedback: &mut [DriveFeedback; MAX_AXES]) -> bool;
    /// Frame and bit counters of the bus (zero for a bus-less link).
    fn counters(&self) -> BusCounters;
    /// Bit rate for bus load (0 for a bus-less link).
    fn bitrate(&self) -> u32;
    /// After the cyclic phase: take the drives to a safe rest (power stage off). Blocking,
    /// not real-time.
    fn shutdown(&mut self) -> Result<(), String>;
    /// Per axis, whether it has its machine reference (homed, or an absolute encoder); a
    /// link without drives has none.
    fn homed(&self) -> [bool; MAX_AXES] {
        [false; MAX_AXES]
    }
    /// Switches machine output `which` (`[machine] outputs`) from the next cycle on; a link
    /// without it does nothing. Must not allocate, log or block (the loop calls it).
    fn set_output(&mut self, which: cnc402_drives::master::Output, on: bool) {
        let _ = (which, on);
    }
}

/// A boxed link is a link (a run picks its link, simulated or on a socket, at run time).
impl<L: DriveLink + ?Sized> DriveLink for Box<L> {
    fn startup(&mut self, now: Instant) -> Startup {
        (**self).startup(now)
    }
    fn cycle(
        &mut self,
        now: Instant,
        commands: &[f64; MAX_AXES],
        feedback: &mut [DriveFeedback; MAX_AXES],
    ) -> Result<(), DriveStop> {
        (**self).cycle(now, commands, feedback)
    }
    fn quick_stop(&mut self, now: Instant, feedback: &mut [DriveFeedback; MAX_AXES]) -> bool {
        (**self).quick_stop(now, feedback)
    }
    fn counters(&self) -> BusCounters {
        (**self).counters()
    }
    fn bitrate(&self) -> u32 {
        (**self).bitrate()
    }
    fn shutdown(&mut self) -> Result<(), String> {
        (**self).shutdown()
    }
    fn homed(&self) -> [bool; MAX_AXES] {
        (**self).homed()
    }
    fn set_output(&mut self, which: cnc402_drives::master::Output, on: bool) {
        (**self).set_output(which, on)
    }
}

/// A drive fault to inject into a simulated machine: `node` goes to FAULT with `emcy` at
/// `at` (time since start of the cyclic phase).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultPlan {
    pub node: u8,
    pub at: core::time::Duration,
    pub emcy: u16,
}

/// Statusword of a drive in OPERATION ENABLED with voltage, quick stop off and remote set.
pub const SW_OPERATION_ENABLED: u16 = 0x0237;
/// Statusword of a drive in FAULT (voltage and remote still set).
pub const SW_FAULT: u16 = 0x0218;
/// Statusword of a drive in QUICK STOP ACTIVE.
pub const SW_QUICK_STOP_ACTIVE: u16 = 0x0217;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bus_stop_names_its_kind_and_other_stops_do_not_change() {
        let stop = |cause, bus| DriveStop {
            cause,
            node: 0,
            statusword: 0,
            emcy: None,
            bus,
        };
        let text = |bus| stop(StopCause::Bus, Some(bus)).cause_text();
        assert_eq!(text(BusError::BusOff), "CAN bus error (bus-off)");
        assert_eq!(text(BusError::Down), "CAN bus error (interface down)");
        assert_eq!(text(BusError::Io(5)), "CAN bus error (I/O error, errno 5)");
        assert_eq!(
            stop(StopCause::Operator, None).cause_text(),
            "operator stop (SIGINT)"
        );
    }
}
