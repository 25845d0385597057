//! `MotionError`: why a segment cannot be planned or a move cannot be started. Heap-free and
//! `Copy`, so the real-time side can return it without allocating; it names the program line.

use std::fmt;

/// A planning or sequencing error, with the program line (and N number) it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionError {
    pub line: u32,
    pub n: Option<u32>,
    pub kind: MotionErrorKind,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MotionErrorKind {
    /// A feed move (G1/G2/G3) with a feed that is zero, negative or not finite.
    BadFeed(f64),
    /// An end position (or arc center) that is not finite; `axis` is the axis letter
    /// (`'?'` for an arc center).
    NonFinite { axis: char },
    /// A dwell that is negative or not finite.
    BadDwell(f64),
    /// A spindle speed that is negative or not finite.
    BadRpm(f64),
    /// A spindle orientation angle outside 0 ≤ angle < 360 or not finite.
    BadOrientAngle(f64),
    /// A spindle orientation that sets program C to a value not ≡ its angle (mod 360), or
    /// not finite: afterwards the physical angle would not be ≡ program C.
    BadOrientProgram { angle: f64, program: f64 },
    /// A spindle speed above the axis' `max_rpm` / `max_velocity`.
    SpindleTooFast { rpm: f64, max_rpm: f64 },
    /// A spindle command for spindle `number` on a machine without that spindle axis.
    NoSpindle { number: u8 },
    /// A rigid tap whose tool axis is not a configured linear axis, whose spindle axis is not
    /// a configured spindle's, or whose pitch is zero or not finite (axis indices).
    BadTap { tool: u8, spindle: u8, pitch: f64 },
    /// A position move of the spindle axis while it runs in speed mode (M3/M4 active).
    SpindleRunning,
    /// An arc whose plane needs an axis the machine does not have.
    MissingPlaneAxis { axis: char },
    /// An arc whose start or end lies on its center.
    ZeroRadius,
    /// An arc whose start and end radius differ by more than the configured tolerance.
    RadiusMismatch { start: f64, end: f64 },
    /// A linear axis would leave its soft limits.
    SoftLimit {
        axis: char,
        value: f64,
        min: f64,
        max: f64,
    },
    /// The axes' limits give no usable profile (a limit is zero or not finite).
    BadLimits,
    /// The path length overflows, or the move would last more than 2^53 periods (an axis
    /// asked to move absurdly far).
    TooLong,
    /// `Interpolator::start` with a path move that does not begin where the last one ended.
    NotAtStart,
    /// `Interpolator::start` while a move is still running.
    Busy,
    /// `Interpolator::start` after `request_stop`, before `clear_stop`.
    Stopped,
}

impl fmt::Display for MotionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}", self.line)?;
        if let Some(n) = self.n {
            write!(f, " (N{n})")?;
        }
        write!(f, ": ")?;
        match self.kind {
            MotionErrorKind::BadFeed(v) => write!(f, "feed move with feed {v} (must be > 0)"),
            MotionErrorKind::NonFinite { axis } => write!(f, "axis {axis}: position not finite"),
            MotionErrorKind::BadDwell(s) => write!(f, "dwell of {s} s (must be ≥ 0)"),
            MotionErrorKind::BadRpm(r) => write!(f, "spindle speed {r} rpm (must be ≥ 0)"),
            MotionErrorKind::BadOrientAngle(a) => {
                write!(
                    f,
                    "spindle orientation angle {a}° (must be 0 ≤ angle < 360)"
                )
            }
            MotionErrorKind::BadOrientProgram { angle, program } => write!(
                f,
                "spindle orientation to {angle}° sets program C to {program} (must be ≡ the angle mod 360)"
            ),
            MotionErrorKind::SpindleTooFast { rpm, max_rpm } => {
                write!(f, "spindle speed {rpm} rpm above the maximum {max_rpm} rpm")
            }
            MotionErrorKind::NoSpindle { number: 1 } => {
                write!(f, "spindle command but no spindle axis")
            }
            MotionErrorKind::NoSpindle { number } => {
                write!(
                    f,
                    "command for spindle {number}, which the machine does not have"
                )
            }
            MotionErrorKind::BadTap {
                tool,
                spindle,
                pitch,
            } => write!(
                f,
                "rigid tap of axis #{tool} with axis #{spindle} at pitch {pitch} (needs a linear \
                 tool axis, the spindle axis and a finite pitch ≠ 0)"
            ),
            MotionErrorKind::SpindleRunning => write!(
                f,
                "the spindle axis is moved as a position axis while it runs (stop it with M5 first)"
            ),
            MotionErrorKind::MissingPlaneAxis { axis } => {
                write!(f, "arc plane needs axis {axis}, which is not configured")
            }
            MotionErrorKind::ZeroRadius => write!(f, "arc start or end lies on its center"),
            MotionErrorKind::RadiusMismatch { start, end } => {
                write!(f, "arc radius {start} at the start but {end} at the end")
            }
            MotionErrorKind::SoftLimit {
                axis,
                value,
                min,
                max,
            } => write!(
                f,
                "axis {axis} to {value} leaves its soft limits {min}..{max}"
            ),
            MotionErrorKind::BadLimits => write!(f, "axis limits give no usable profile"),
            MotionErrorKind::TooLong => write!(f, "move too long (absurd distance or duration)"),
            MotionErrorKind::NotAtStart => {
                write!(f, "move does not start where the previous one ended")
            }
            MotionErrorKind::Busy => write!(f, "a move is still running"),
            MotionErrorKind::Stopped => write!(f, "motion is stopped"),
        }
    }
}

impl std::error::Error for MotionError {}
