//! Motion: the planner gives every segment a jerk-limited velocity profile within the axes'
//! limits, and the fixed-period interpolator samples it into per-axis setpoints. Pure: no I/O,
//! no clock; time advances only by the period passed in.

pub mod profile;
pub mod segment;

pub use cnc402_config::MAX_AXES;
pub use segment::*;
