//! The planner: turns each [`Segment`] into a heap-free [`PlannedMove`] — the geometry plus a
//! jerk-limited path profile s(t) whose speed, acceleration and jerk keep every moving axis
//! within its limits and the path within the programmed feed. It remembers where the previous
//! segment ended (and whether the spindle runs), so segments only carry their end points.

use std::f64::consts::{PI, TAU};

use cnc402_config::{AxisKind, MAX_SPINDLES, MachineConfig};

use crate::error::{MotionError, MotionErrorKind};
use crate::profile::{JerkProfile, Limits, PathProfile, ProfileError, State, rest_to_rest};
use crate::segment::{
    ArcDir, AxisPos, MAX_AXES, PathAxes, Plane, Segment, SegmentEnd, SegmentKind, SpindleDir,
    StopKind, TapCoupling, TapSegment, arc_sweep,
};

/// A segment made ready for the interpolator. `Copy` and heap-free: the source location is
/// kept as `line` and `n`, and a message's text stays with the caller's [`Segment`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlannedMove {
    /// 1-based program line.
    pub line: u32,
    /// The block's N number.
    pub n: Option<u32>,
    pub kind: MoveKind,
    /// How the segment ends, as the interpreter stamped it (the [`crate::Lookahead`] blends
    /// `Continuous` ends; [`Planner::plan`] alone stops exactly at every end).
    pub ends: SegmentEnd,
}

/// What a planned move does. (`Path` is large on purpose: moves travel by value through
/// fixed-capacity rings, and a box would allocate.)
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MoveKind {
    /// A move along a path (G0, G1, G2/G3, taps).
    Path(PathMove),
    /// Hold position for `ticks` periods (`seconds` rounded up to whole periods, at least 1).
    Dwell { seconds: f64, ticks: u64 },
    /// Spindle speed mode: ramp the axis of spindle number `spindle` to `velocity` (deg/s,
    /// signed: M3 > 0, M4 < 0, M5 = 0) under `acceleration`/`jerk`; the move completes when
    /// the spindle is at speed (at rest for 0), and the spindle keeps turning during later
    /// moves.
    Spindle {
        velocity: f64,
        acceleration: f64,
        jerk: f64,
        spindle: u8,
    },
    /// Spindle orientation: with the spindle at rest, turn it the shorter way to the nearest
    /// machine C ≡ `angle` (mod 360) within `limits` (deg/s, deg/s², deg/s³). The interpolator
    /// resolves the target against machine C when the move starts (only it knows the spindle
    /// offset), so the duration is not known here. Program C does not change, or becomes
    /// `program` (≡ `angle` mod 360) when it is given (G28/G30 C).
    SpindleOrient {
        angle: f64,
        limits: Limits,
        program: Option<f64>,
        /// The spindle's number (its axis is the one oriented).
        spindle: u8,
    },
    /// T with M6: reported to the caller in one tick.
    ToolChange { tool: u32 },
    /// M7/M8/M9: the coolant state, reported to the caller in one tick.
    Coolant { mist: bool, flood: bool },
    /// M0/M1/M2/M30: reported to the caller in one tick; the caller decides whether to pause.
    ProgramStop { kind: StopKind },
    /// An operator message; the text stays with the caller's `Segment`.
    Message,
}

/// A move along a path: positions are program (machine) coordinates, every configured axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathMove {
    pub start: AxisPos,
    pub end: AxisPos,
    pub geometry: Geometry,
    /// Path length in the path parameter's unit: mm over the linear axes that move (degrees
    /// over the rotary axes when only rotary axes move; arcs: the helix length).
    pub length: f64,
    /// The bounds on path speed/acceleration/jerk that every axis's limits and the feed gave.
    pub limits: Limits,
    /// s(t) from 0 to `length`, stretched so that it lasts exactly `ticks` periods.
    pub profile: JerkProfile,
    /// Number of interpolator periods the move takes (≥ 1); the last one lands on `end`.
    pub ticks: u64,
    pub rapid: bool,
    /// A rigid tap's coupling of tool and spindle axis, from its [`TapSegment`].
    pub tap: Option<TapCoupling>,
    /// Where this move lies on `profile`: the profile's s at the move's start (0 unless the
    /// lookahead planned several moves under one profile), and the profile's times at which
    /// the move starts and ends. An exact-stop move has 0, 0 and `ticks` periods.
    pub s_offset: f64,
    pub t_begin: f64,
    pub t_end: f64,
    /// Path speed at the move's end: 0 for an exact stop; > 0 when the lookahead blends it
    /// into the next move (the interpolator then carries the fractional period over).
    pub end_speed: f64,
    /// The feed override (≥ 1) the move was planned with: feed override above 100 % raises
    /// the feed where moves are planned (so every limit holds), and the interpolator runs
    /// the move at rate override / `feed_scale` (≤ 1). 1 for rapids and taps.
    pub feed_scale: f64,
}

/// The shape of a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Geometry {
    /// Every axis moves in proportion to s/length.
    Line,
    Arc(ArcGeometry),
}

/// A circular (or slightly spiral, when start and end radius differ within tolerance) arc in
/// a plane; all other axes move in proportion to s/length (helix).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcGeometry {
    pub plane: Plane,
    pub dir: ArcDir,
    pub turns: u32,
    /// Machine X Y Z of the center, as programmed.
    pub center: [f64; 3],
    /// Axis indices of the plane's first and second axis (XY: X,Y; ZX: Z,X; YZ: Y,Z).
    pub axes: [usize; 2],
    /// The center in the plane's (first, second) axes.
    pub center_2d: [f64; 2],
    pub start_angle: f64,
    /// Signed angle swept (CCW > 0), including the extra full turns.
    pub sweep: f64,
    pub start_radius: f64,
    pub end_radius: f64,
}

impl PathMove {
    /// The position at path parameter `s` (0 ≤ s ≤ length), on the true curve.
    #[inline]
    pub fn point(&self, s: f64) -> AxisPos {
        let u = if self.length > 0.0 {
            s / self.length
        } else {
            0.0
        };
        let mut p = self.start;
        for i in 0..MAX_AXES {
            p.0[i] = self.start.0[i] + (self.end.0[i] - self.start.0[i]) * u;
        }
        if let Geometry::Arc(arc) = &self.geometry {
            let th = arc.start_angle + arc.sweep * u;
            let r = arc.start_radius + (arc.end_radius - arc.start_radius) * u;
            let (sin, cos) = th.sin_cos();
            p.0[arc.axes[0]] = arc.center_2d[0] + r * cos;
            p.0[arc.axes[1]] = arc.center_2d[1] + r * sin;
        }
        p
    }

    /// d(position)/ds at path parameter `s`: every axis's rate per unit of path (the unit
    /// tangent over the linear axes for a line; rotary axes in their unit per path unit).
    pub fn tangent(&self, s: f64) -> AxisPos {
        let mut d = AxisPos::default();
        if self.length <= 0.0 {
            return d;
        }
        for i in 0..MAX_AXES {
            d.0[i] = (self.end.0[i] - self.start.0[i]) / self.length;
        }
        if let Geometry::Arc(arc) = &self.geometry {
            let u = s / self.length;
            let th = arc.start_angle + arc.sweep * u;
            let r = arc.start_radius + (arc.end_radius - arc.start_radius) * u;
            let dr = arc.end_radius - arc.start_radius;
            let (sin, cos) = th.sin_cos();
            d.0[arc.axes[0]] = (dr * cos - r * sin * arc.sweep) / self.length;
            d.0[arc.axes[1]] = (dr * sin + r * cos * arc.sweep) / self.length;
        }
        d
    }
}

/// Plans segments in program order; see the module doc.
#[derive(Clone, Debug)]
pub struct Planner {
    axes: [AxisData; MAX_AXES],
    n_axes: usize,
    /// The axis of each spindle by number (`[0]`: spindle 1).
    spindles: [Option<usize>; MAX_SPINDLES],
    period: f64,
    arc_tolerance: f64,
    path_axes: PathAxes,
    pos: AxisPos,
    /// Per spindle (by number − 1): runs in speed mode.
    spindle_running: [bool; MAX_SPINDLES],
    /// The share of every axis's acceleration a path profile may use (1 for exact stops; the
    /// lookahead keeps the rest for the velocity jumps at blended junctions).
    accel_share: f64,
    /// Feed override above 100 % (1 ≤ scale ≤ 2) applied to the feed of the next feed moves
    /// (not rapids, not taps); see [`Planner::set_feed_scale`].
    feed_scale: f64,
}

#[derive(Clone, Copy, Debug, Default)]
struct AxisData {
    name: char,
    linear: bool,
    v: f64,
    a: f64,
    j: f64,
    soft: Option<(f64, f64)>,
    max_rpm: f64,
}

impl Planner {
    /// A planner for `config`'s axes and period, starting at machine position 0 with the
    /// spindle at rest (see [`Planner::set_position`]).
    pub fn new(config: &MachineConfig) -> Planner {
        let mut axes = [AxisData::default(); MAX_AXES];
        let n_axes = config.axes.len().min(MAX_AXES);
        for (d, a) in axes.iter_mut().zip(&config.axes) {
            *d = AxisData {
                name: a.name,
                linear: a.kind == AxisKind::Linear,
                v: a.max_velocity,
                a: a.max_acceleration,
                j: a.max_jerk,
                soft: a.soft_limits,
                max_rpm: a.max_rpm.unwrap_or(0.0),
            };
        }
        Planner {
            axes,
            n_axes,
            spindles: config.spindle_axes().map(|a| a.filter(|&i| i < MAX_AXES)),
            period: config.bus.period_s(),
            arc_tolerance: config.interp.arc_tolerance,
            path_axes: PathAxes::new(config),
            pos: AxisPos::default(),
            spindle_running: [false; MAX_SPINDLES],
            accel_share: 1.0,
            feed_scale: 1.0,
        }
    }

    /// The share (0 < share ≤ 1) of every axis's acceleration the next path profiles may
    /// use; see [`crate::lookahead`].
    pub(crate) fn set_accel_share(&mut self, share: f64) {
        self.accel_share = share;
    }

    /// The axes' acceleration limits and the period, for the lookahead's junction bounds.
    pub(crate) fn axis_accelerations(&self) -> ([f64; MAX_AXES], usize, f64) {
        let mut a = [0.0; MAX_AXES];
        for (d, ax) in a.iter_mut().zip(&self.axes[..self.n_axes]) {
            *d = ax.a;
        }
        (a, self.n_axes, self.period)
    }

    /// Feed override above 100 %: the next feed moves (G1, G2/G3; not rapids, whose override
    /// is their own, nor rigid taps, which Fanuc runs at 100 %) are planned at `scale` × F
    /// (clamped to 1–2), still within every axis's limits. Below 100 % the interpolator
    /// slows the planned profile down instead (see `Interpolator::set_feed_override`).
    pub fn set_feed_scale(&mut self, scale: f64) {
        self.feed_scale = if scale.is_finite() {
            scale.clamp(1.0, 2.0)
        } else {
            1.0
        };
    }

    /// Sets where the next segment starts (machine coordinates; C in program coordinates).
    pub fn set_position(&mut self, pos: AxisPos) {
        self.pos = pos;
        for i in self.n_axes..MAX_AXES {
            self.pos.0[i] = 0.0;
        }
    }

    /// Where the next segment starts.
    pub fn position(&self) -> AxisPos {
        self.pos
    }

    /// True after an M3/M4 with S > 0 of any spindle, until its M5 (or S0).
    pub fn spindle_running(&self) -> bool {
        self.spindle_running.contains(&true)
    }

    /// Tells the planner whether the spindles run (after a stop has brought them to rest, or
    /// when re-syncing with the interpolator: see `Interpolator::spindle_running`): every
    /// spindle.
    pub fn set_spindle_running(&mut self, running: bool) {
        self.spindle_running = [running; MAX_SPINDLES];
    }

    /// The axis of spindle `number` and its slot in the per-spindle arrays.
    fn spindle_slot(&self, number: u8) -> Result<(usize, usize), MotionErrorKind> {
        let slot = usize::from(number).wrapping_sub(1);
        match self.spindles.get(slot) {
            Some(Some(axis)) => Ok((slot, *axis)),
            _ => Err(MotionErrorKind::NoSpindle { number }),
        }
    }

    /// Plans one segment starting where the previous one ended. On error nothing changes.
    pub fn plan(&mut self, seg: &Segment) -> Result<PlannedMove, MotionError> {
        let line = seg.source.line;
        let n = seg.source.n;
        let kind = self
            .move_kind(&seg.kind)
            .map_err(|kind| MotionError { line, n, kind })?;
        if let MoveKind::Path(m) = &kind {
            self.pos = m.end;
        }
        Ok(PlannedMove {
            line,
            n,
            kind,
            ends: seg.ends,
        })
    }

    /// What the interpolator does for `kind`. On error nothing changes.
    fn move_kind(&mut self, kind: &SegmentKind) -> Result<MoveKind, MotionErrorKind> {
        Ok(match kind {
            SegmentKind::Rapid { end } => {
                let end = self.check_end(end)?;
                MoveKind::Path(self.line_move(end, f64::INFINITY, true)?)
            }
            SegmentKind::Linear { end, feed } => {
                check_feed(*feed)?;
                let end = self.check_end(end)?;
                let mut m = self.line_move(end, feed / 60.0 * self.feed_scale, false)?;
                m.feed_scale = self.feed_scale;
                MoveKind::Path(m)
            }
            SegmentKind::Tap(tap) => {
                check_feed(tap.feed)?;
                self.check_tap(tap)?;
                let end = self.check_end(&tap.end)?;
                let mut m = self.line_move(end, tap.feed / 60.0, false)?;
                m.tap = Some(tap.coupling());
                MoveKind::Path(m)
            }
            SegmentKind::Arc {
                end,
                center,
                plane,
                dir,
                turns,
                feed,
            } => {
                check_feed(*feed)?;
                let end = self.check_end(end)?;
                if center.iter().any(|c| !c.is_finite()) {
                    return Err(MotionErrorKind::NonFinite { axis: '?' });
                }
                let feed = feed / 60.0 * self.feed_scale;
                let mut m = self.arc_move(end, *center, *plane, *dir, *turns, feed)?;
                m.feed_scale = self.feed_scale;
                MoveKind::Path(m)
            }
            SegmentKind::Dwell { seconds } => {
                if !(seconds.is_finite() && *seconds >= 0.0) {
                    return Err(MotionErrorKind::BadDwell(*seconds));
                }
                let ticks = ((seconds / self.period).ceil() as u64).max(1);
                MoveKind::Dwell {
                    seconds: *seconds,
                    ticks,
                }
            }
            SegmentKind::Spindle { rpm, dir, spindle } => {
                self.spindle_move(*rpm, *dir, *spindle)?
            }
            SegmentKind::SpindleOrient {
                angle,
                program,
                spindle,
            } => self.orient_move(*angle, *program, *spindle)?,
            SegmentKind::ToolChange { tool } => MoveKind::ToolChange { tool: *tool },
            SegmentKind::Coolant { mist, flood } => MoveKind::Coolant {
                mist: *mist,
                flood: *flood,
            },
            SegmentKind::Stop { kind } => MoveKind::ProgramStop { kind: *kind },
            SegmentKind::Message { .. } => MoveKind::Message,
        })
    }

    /// M3/M4/M5 at `rpm` of spindle `number`: its new speed (deg/s) and ramp limits.
    fn spindle_move(
        &mut self,
        rpm: f64,
        dir: SpindleDir,
        number: u8,
    ) -> Result<MoveKind, MotionErrorKind> {
        let (slot, si) = self.spindle_slot(number)?;
        if !(rpm.is_finite() && rpm >= 0.0) {
            return Err(MotionErrorKind::BadRpm(rpm));
        }
        let ax = self.axes[si];
        let max_rpm = ax.max_rpm.min(ax.v / 6.0);
        let sign = match dir {
            SpindleDir::Cw => 1.0,
            SpindleDir::Ccw => -1.0,
            SpindleDir::Stop => 0.0,
        };
        if sign != 0.0 && rpm > max_rpm * (1.0 + 1e-12) {
            return Err(MotionErrorKind::SpindleTooFast { rpm, max_rpm });
        }
        let velocity = sign * rpm.min(max_rpm) * 6.0;
        self.spindle_running[slot] = velocity != 0.0;
        Ok(MoveKind::Spindle {
            velocity,
            acceleration: ax.a,
            jerk: ax.j,
            spindle: number,
        })
    }

    /// M19 of spindle `number` to `angle` (its axis reads `program` afterwards, when
    /// given): the spindle at rest turns there within its axis limits.
    fn orient_move(
        &mut self,
        angle: f64,
        program: Option<f64>,
        number: u8,
    ) -> Result<MoveKind, MotionErrorKind> {
        let (slot, si) = self.spindle_slot(number)?;
        if !(angle.is_finite() && (0.0..360.0).contains(&angle)) {
            return Err(MotionErrorKind::BadOrientAngle(angle));
        }
        if let Some(c) = program
            && !orient_program_agrees(angle, c)
        {
            return Err(MotionErrorKind::BadOrientProgram { angle, program: c });
        }
        if self.spindle_running[slot] {
            return Err(MotionErrorKind::SpindleRunning);
        }
        let ax = self.axes[si];
        let max_rpm = if ax.max_rpm > 0.0 {
            ax.max_rpm
        } else {
            f64::INFINITY
        };
        let limits = Limits {
            velocity: ax.v.min(max_rpm * 6.0),
            acceleration: ax.a,
            jerk: ax.j,
        };
        if !limits.is_valid() {
            return Err(MotionErrorKind::BadLimits);
        }
        if let Some(c) = program {
            self.pos.0[si] = c;
        }
        Ok(MoveKind::SpindleOrient {
            angle,
            limits,
            program,
            spindle: number,
        })
    }

    /// Finite, within soft limits, spindle not moved while running; zeroes unused entries.
    fn check_end(&self, end: &AxisPos) -> Result<AxisPos, MotionErrorKind> {
        let mut e = AxisPos::default();
        for i in 0..self.n_axes {
            let ax = &self.axes[i];
            let v = end.0[i];
            if !v.is_finite() {
                return Err(MotionErrorKind::NonFinite { axis: ax.name });
            }
            self.check_soft(i, v)?;
            e.0[i] = v;
        }
        for (si, running) in self.spindles.iter().zip(self.spindle_running) {
            if let Some(si) = *si
                && running
                && e.0[si] != self.pos.0[si]
            {
                return Err(MotionErrorKind::SpindleRunning);
            }
        }
        Ok(e)
    }

    /// A tap couples a configured linear axis with the configured spindle axis at a finite,
    /// non-zero pitch (the loop indexes its axis arrays with them).
    fn check_tap(&self, tap: &TapSegment) -> Result<(), MotionErrorKind> {
        let tool = usize::from(tap.tool);
        let tool_ok = tool < self.n_axes && self.axes[tool].linear;
        let spindle_ok = self.spindles.contains(&Some(usize::from(tap.spindle)));
        if tool_ok && spindle_ok && tap.pitch.is_finite() && tap.pitch != 0.0 {
            Ok(())
        } else {
            Err(MotionErrorKind::BadTap {
                tool: tap.tool,
                spindle: tap.spindle,
                pitch: tap.pitch,
            })
        }
    }

    fn check_soft(&self, i: usize, v: f64) -> Result<(), MotionErrorKind> {
        let ax = &self.axes[i];
        if let Some((min, max)) = ax.soft
            && ax.linear
            && !(v >= min - 1e-9 && v <= max + 1e-9)
        {
            return Err(MotionErrorKind::SoftLimit {
                axis: ax.name,
                value: v,
                min,
                max,
            });
        }
        Ok(())
    }

    /// A straight line: path length over the linear axes that move (rotary if only they
    /// move); each axis i moving by Δi bounds the path by limit_i · L / |Δi|.
    fn line_move(&self, end: AxisPos, feed: f64, rapid: bool) -> Result<PathMove, MotionErrorKind> {
        let start = self.pos;
        let length = self.path_axes.line_length(&start, &end);
        let mut lim = Limits {
            velocity: feed,
            acceleration: f64::INFINITY,
            jerk: f64::INFINITY,
        };
        if length > 0.0 {
            for i in 0..self.n_axes {
                let k = (end.0[i] - start.0[i]).abs() / length;
                self.bound_axis(&mut lim, i, k);
            }
        }
        self.finish(start, end, Geometry::Line, length, lim, rapid)
    }

    fn bound_axis(&self, lim: &mut Limits, i: usize, k: f64) {
        if k > 0.0 {
            let ax = &self.axes[i];
            lim.velocity = lim.velocity.min(ax.v / k);
            lim.acceleration = lim.acceleration.min(ax.a * self.accel_share / k);
            lim.jerk = lim.jerk.min(ax.j / k);
        }
    }

    /// Builds the profile and stretches it to a whole number of periods (k ≥ 1 only lowers
    /// speed, acceleration and jerk).
    fn finish(
        &self,
        start: AxisPos,
        end: AxisPos,
        geometry: Geometry,
        length: f64,
        lim: Limits,
        rapid: bool,
    ) -> Result<PathMove, MotionErrorKind> {
        let (profile, ticks) = if length > 0.0 {
            let p = rest_to_rest(length, lim).map_err(|e| match e {
                ProfileError::BadDistance(_) => MotionErrorKind::TooLong,
                _ => MotionErrorKind::BadLimits,
            })?;
            let n = (p.duration() / self.period).ceil();
            // Beyond 2^53 periods (285,000 years at 1 ms) tick counts stop being exact.
            if n.is_nan() || n > 9_007_199_254_740_992.0 {
                return Err(MotionErrorKind::TooLong);
            }
            let ticks = (n as u64).max(1);
            let k = ticks as f64 * self.period / p.duration();
            (p.time_scaled(k), ticks)
        } else {
            (JerkProfile::hold(State::default()), 1)
        };
        Ok(PathMove {
            start,
            end,
            geometry,
            length,
            limits: lim,
            profile,
            ticks,
            rapid,
            tap: None,
            s_offset: 0.0,
            t_begin: 0.0,
            t_end: ticks as f64 * self.period,
            end_speed: 0.0,
            feed_scale: 1.0,
        })
    }

    /// An arc or helix. Speed bounds (conservative; r = the smaller of the two radii, and
    /// k = |d(plane point)/ds| ≤ (r_max·|sweep| + |Δr|)/L):
    /// - plane axes: k·v ≤ v_max; centripetal (k·v)²/r ≤ a_max/2 and tangential k·a ≤
    ///   a_max·√3/2, so |accel| = √(a_c² + a_t²) ≤ a_max on each plane axis;
    /// - jerk of circular motion is (j_t − v³/r²)·T + (3·v·a_t/r)·N: we keep (k·v)³/r² ≤
    ///   j_max/4, 3·(k·v)(k·a)/r ≤ j_max/4 and k·j ≤ j_max/2, so |jerk| ≤ j_max;
    /// - every other axis moves linearly with s and is bounded like on a line.
    ///
    /// The plane limits are the smaller of the two plane axes' limits.
    fn arc_move(
        &self,
        end: AxisPos,
        center: [f64; 3],
        plane: Plane,
        dir: ArcDir,
        turns: u32,
        feed: f64,
    ) -> Result<PathMove, MotionErrorKind> {
        let start = self.pos;
        let (l0, l1, _) = plane.letters();
        let find = |l: char| {
            self.axes[..self.n_axes]
                .iter()
                .position(|a| a.name == l)
                .ok_or(MotionErrorKind::MissingPlaneAxis { axis: l })
        };
        let (p, q) = (find(l0)?, find(l1)?);
        let c = plane.center_in_plane(center);
        let r0 = (start.0[p] - c[0]).hypot(start.0[q] - c[1]);
        let r1 = (end.0[p] - c[0]).hypot(end.0[q] - c[1]);
        if !(r0 > 1e-9 && r1 > 1e-9) {
            return Err(MotionErrorKind::ZeroRadius);
        }
        if (r0 - r1).abs() > self.arc_tolerance + 1e-9 * r0.max(r1) {
            return Err(MotionErrorKind::RadiusMismatch { start: r0, end: r1 });
        }
        let a0 = (start.0[q] - c[1]).atan2(start.0[p] - c[0]);
        let rm = r0.max(r1);
        let (s2, e2) = ([start.0[p], start.0[q]], [end.0[p], end.0[q]]);
        let sweep_abs = arc_sweep(s2, e2, c, dir, turns);
        let sweep = match dir {
            ArcDir::Ccw => sweep_abs,
            ArcDir::Cw => -sweep_abs,
        };
        // Soft limits at the arc's extreme points in the plane.
        for m in 0..4 {
            let th = m as f64 * PI / 2.0;
            let d = if sweep > 0.0 {
                (th - a0).rem_euclid(TAU)
            } else {
                (a0 - th).rem_euclid(TAU)
            };
            if d <= sweep_abs {
                let (i, v) = match m {
                    0 => (p, c[0] + rm),
                    1 => (q, c[1] + rm),
                    2 => (p, c[0] - rm),
                    _ => (q, c[1] - rm),
                };
                self.check_soft(i, v)?;
            }
        }
        let length = self
            .path_axes
            .helix_length(&start, &end, [p, q], c, dir, turns);
        let rmin = r0.min(r1);
        let k = (rm * sweep_abs + (r1 - r0).abs()) / length;
        let (ap, bp) = (&self.axes[p], &self.axes[q]);
        let (vp, amp, jp) = (
            ap.v.min(bp.v),
            ap.a.min(bp.a) * self.accel_share,
            ap.j.min(bp.j),
        );
        let mut lim = Limits {
            velocity: feed
                .min(vp / k)
                .min((amp * rmin / 2.0).sqrt() / k)
                .min((jp * rmin * rmin / 4.0).cbrt() / k),
            acceleration: amp * 0.75f64.sqrt() / k,
            jerk: jp / (2.0 * k),
        };
        for i in 0..self.n_axes {
            if i != p && i != q {
                self.bound_axis(&mut lim, i, (end.0[i] - start.0[i]).abs() / length);
            }
        }
        lim.acceleration = lim
            .acceleration
            .min(jp * rmin / (12.0 * k * k * lim.velocity));
        let geometry = Geometry::Arc(ArcGeometry {
            plane,
            dir,
            turns,
            center,
            axes: [p, q],
            center_2d: c,
            start_angle: a0,
            sweep,
            start_radius: r0,
            end_radius: r1,
        });
        self.finish(start, end, geometry, length, lim, false)
    }
}

/// True when program C `c` is finite and ≡ the orientation `angle` (mod 360), up to rounding
/// relative to |c|.
pub(crate) fn orient_program_agrees(angle: f64, c: f64) -> bool {
    let d = (c - angle).rem_euclid(360.0);
    c.is_finite() && d.min(360.0 - d) <= 1e-9 * (1.0 + c.abs())
}

fn check_feed(feed: f64) -> Result<(), MotionErrorKind> {
    if feed.is_finite() && feed > 0.0 {
        Ok(())
    } else {
        Err(MotionErrorKind::BadFeed(feed))
    }
}
