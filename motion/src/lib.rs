//! Motion: the planner gives every segment a jerk-limited velocity profile within the axes'
//! limits, and the fixed-period interpolator samples it into per-axis setpoints. Pure: no I/O,
//! no clock; time advances only by the period passed in.
//!
//! # The spindle
//! A machine has up to two spindles; `Spindle` and `SpindleOrient` name theirs by number
//! (`spindle`, 1 or 2), and each has its own speed mode, offset, override and orientation on
//! its own axis ("C" below is that axis). Both may turn at once; a position move may not
//! turn an axis whose spindle runs.
//!
//! `Spindle { rpm, dir, .. }` puts the spindle axis in speed mode: its velocity ramps (jerk-limited,
//! within its acceleration, jerk and `max_rpm`) to ±rpm·6 deg/s and the move completes when it
//! is at speed ("spindle at speed"; rpm 0 / M5: when it is at rest). The spindle keeps turning
//! during later moves and its position keeps counting, never wrapped (an f64 in degrees: after
//! 10 h at 6000 rpm, 1.3·10⁹ deg, one ulp is 2.4·10⁻⁷ deg = 9·10⁻⁵ counts at 131072
//! counts/rev, and each sample is computed from the ramp's start, not summed, so errors do not
//! accumulate). Wrapping to INT32 is [`to_counts_wrapping`], for the drives layer.
//!
//! Position moves of the spindle axis (rigid tapping: a `Tap` move of Z with C) are only
//! allowed with the spindle at rest. The interpreter cannot know where a speed-mode run left
//! the spindle, so program C coordinates are re-based: when the spindle comes to rest the
//! interpolator sets `offset = machine C − program C`, and outputs machine C = program C +
//! offset; a move from program C0 to C1 turns the spindle by exactly C1 − C0 from wherever it
//! stopped. (Hence the exact-end guarantee of a move holds bit-for-bit for C only while the
//! offset is 0; otherwise the end is `end[C] + offset`.)
//!
//! `SpindleOrient { angle, program }` (M19, G76/G87, G28/G30 C) is resolved here for the same
//! reason: with the spindle at rest, a jerk-limited position move (the axis's velocity capped
//! at `max_rpm`, its acceleration and jerk) turns machine C the shorter way (≤ 180°, ties
//! forward) to the nearest `angle + 360·n` (one rounding), exactly on its last tick. With
//! `program: None` program C does not change; the turn goes into the offset, so a later tap
//! from program C0 to C1 still turns exactly C1 − C0, now starting at the oriented angle. With
//! `program: Some(c)` (G28/G30 C, c ≡ angle mod 360) program C becomes c and the offset
//! becomes a whole number of turns (up to rounding), so the physical angle ≡ program C: a
//! later `G0 C45` ends on the physical angle 45.
//!
//! # Limits
//! Lines: each moving axis i bounds path speed, acceleration and jerk by its limit · L/|Δi|.
//! Arcs and helices are bounded conservatively (see `Planner`'s arc code): centripetal
//! acceleration ≤ a/2, tangential ≤ a·√3/2, and the three jerk terms of circular motion to
//! j/4 + j/4 + j/2 of the plane axes' smaller limits. Because every trajectory is C² and
//! piecewise cubic in time, the n-th finite difference of the sampled setpoints is an average
//! of the n-th derivative, so sampled velocity, acceleration and jerk stay within the limits up
//! to float rounding (tests allow 2ⁿ·64·ε·(max|x|+1)/Pⁿ).
//!
//! # Ticks
//! A move of N ticks outputs samples at t = P, 2P, … NP; its profile is stretched (never
//! sped up) so that NP is exactly its duration and the N-th sample is the end position,
//! bit-for-bit. Blended moves ([`Lookahead`]) share one profile per group and last fractions
//! of periods: the interpolator carries the rest of the period into the next move (and passes
//! over moves shorter than it), and the last move of a chain, ending at rest, still lands
//! exactly on its end. The sample at t = 0 is the previous move's last one, which is this move's
//! start. Dwells, tool changes, program stops and messages pass through as ticks with a
//! [`TickState`] and [`MoveEvent`].
//!
//! ```
//! use std::sync::Arc;
//! use cnc402_config::MachineConfig;
//! use cnc402_motion::*;
//!
//! let cfg = MachineConfig::default_machine();
//! let mut planner = Planner::new(&cfg);
//! let mut ip = Interpolator::new(&cfg, AxisPos::default());
//! let mut end = AxisPos::default();
//! end[0] = 10.0; // X
//! let seg = Segment {
//!     kind: SegmentKind::Linear { end, feed: 1200.0 },
//!     source: Source { file: Arc::from("demo.nc"), line: 1, n: Some(10) },
//!     ends: SegmentEnd::ExactStop,
//! };
//! ip.start(planner.plan(&seg)?)?; // plan off the loop; start() and tick() never allocate
//! let mut ticks = 0;
//! loop {
//!     let t = ip.tick(); // once per period: send t.pos to the drives
//!     ticks += 1;
//!     if t.finished {
//!         assert_eq!(t.pos, end);
//!         break;
//!     }
//! }
//! assert!(ticks > 500); // 10 mm at 20 mm/s, plus the ramps
//! # Ok::<(), MotionError>(())
//! ```

pub mod collinear;
pub mod counts;
pub mod error;
pub mod interpolator;
pub mod lookahead;
pub mod matching;
pub mod planner;
pub mod profile;
pub mod segment;

pub use cnc402_config::MAX_AXES;
pub use counts::to_counts_wrapping;
pub use error::{MotionError, MotionErrorKind};
pub use interpolator::{Interpolator, MoveEvent, Tick, TickState};
pub use lookahead::Lookahead;
pub use planner::{ArcGeometry, Geometry, MoveKind, PathMove, PlannedMove, Planner};
pub use profile::{JerkProfile, Limits, PathProfile, State};
pub use segment::*;
