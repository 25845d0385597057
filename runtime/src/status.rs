//! The record the loop sends out every tick ([`Status`]) and how a run ended ([`Outcome`]).
//! `Copy` and heap-free: it travels through the status ring.

use cnc402_config::MAX_AXES;
pub use cnc402_motion::TapCoupling;
use cnc402_motion::{MotionError, MoveEvent};

use crate::link::DriveStop;

/// What the loop is doing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Phase {
    /// Running the program.
    #[default]
    Running,
    /// Decelerating along the path after a stop request or safety reaction.
    Stopping,
    /// Path at rest; quick stop commanded to the drives.
    QuickStop,
    /// Program done; waiting for the drives to settle on the last setpoint.
    Settling,
}

/// One tick as the loop saw it. (`Default`: tick 0, running, every axis at 0 with no
/// feedback, no event: a base for records built field by field.)
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Status {
    /// Tick number from the start of the cyclic phase (t = tick · period).
    pub tick: u64,
    /// Program line of the move executing.
    pub line: u32,
    pub phase: Phase,
    /// Commanded machine position (mm / degrees), unwrapped.
    pub cmd: [f64; MAX_AXES],
    /// The setpoints sent (INT32 counts, wrapping).
    pub cmd_counts: [i32; MAX_AXES],
    /// Actual position from 0x6064, unwrapped, in mm / degrees.
    pub act: [f64; MAX_AXES],
    /// Actual position in counts (wrapping), as on the wire.
    pub act_counts: [i32; MAX_AXES],
    /// Following error as the link's monitor sees it (dead time excluded), axis units.
    pub following_error: [f64; MAX_AXES],
    /// Age of each actual position in cycles (see [`crate::link::DriveFeedback::age`]).
    pub age: [u32; MAX_AXES],
    pub statusword: [u16; MAX_AXES],
    /// Non-motion program event finished on this tick.
    pub event: Option<MoveEvent>,
    /// The rigid-tap coupling of the move executing, if it is one (from its planned move).
    pub tap: Option<TapCoupling>,
    /// The safety reaction raised on this tick, if any.
    pub stop: Option<DriveStop>,
    /// Moves taken from the move ring so far.
    pub moves_started: u64,
    /// The interpolator has nothing to do after this tick.
    pub idle: bool,
    /// The spindle (or tool axis) drive stopped following its setpoints during a tap and the
    /// other axis follows its actual position instead (the path setpoints mean nothing).
    pub spindle_follow: bool,
    /// The operator's panel change (feed hold, resume, an override) applied on this tick.
    pub panel: Option<crate::operator::PanelAction>,
    /// The machine outputs as the program set them (`crate::machine_io::OUTPUTS` bits).
    pub outputs: u8,
}

/// Whether two wrapping INT32 positions are within one count of each other. The difference
/// wraps and is compared by `unsigned_abs`, so `i32::MIN` (whose `abs` panics in debug and
/// stays negative, "settled", in release) reads as far apart.
pub fn within_one_count(a: i32, b: i32) -> bool {
    a.wrapping_sub(b).unsigned_abs() <= 1
}

/// How the run ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// The program ran to its end.
    Finished,
    /// A safety reaction or operator stop brought the machine to rest; `line` is the program
    /// line that was executing when it happened.
    Stopped {
        stop: DriveStop,
        line: u32,
        /// Number of the move executing (1-based, as [`Status::moves_started`]): with the
        /// feeder's file table it names the file when the line is in an included file.
        move_index: u64,
    },
    /// A move could not be started; the machine was stopped.
    MotionFailed { error: MotionError },
    /// The drives could not be started (nothing moved).
    StartupFailed(String),
}

#[cfg(test)]
mod tests {
    use super::within_one_count;

    #[test]
    fn within_one_count_extreme_difference_is_not_settled() {
        // 0 - i32::MIN wraps to i32::MIN: `.abs()` panicked in debug and gave a negative
        // number (<= 1, "settled") in release.
        assert!(!within_one_count(0, i32::MIN));
        assert!(!within_one_count(i32::MIN, 0));
        assert!(!within_one_count(i32::MAX, -1));
        assert!(within_one_count(i32::MAX, i32::MIN)); // one count apart across the wrap
        assert!(within_one_count(5, 4));
        assert!(within_one_count(-7, -7));
        assert!(!within_one_count(5, 3));
    }
}
