//! The fixed-period interpolator: samples one [`PlannedMove`] at a time, one period per
//! [`Interpolator::tick`], into a commanded position for every configured axis. Time is the
//! tick count times the period, so a late call never distorts the path. It also runs the
//! spindle in speed mode alongside moves and performs controlled stops along the path,
//! and the operator's feed hold and overrides ([`rate`]). Nothing here allocates.

mod rate;

use cnc402_config::{MAX_SPINDLES, MachineConfig};

use crate::error::{MotionError, MotionErrorKind};
use crate::planner::{MoveKind, PathMove, PlannedMove, orient_program_agrees};
use crate::profile::{JerkProfile, Limits, PathProfile, State, rest_to_rest, velocity_change};
use crate::segment::{AxisPos, MAX_AXES, StopKind};
use rate::RateClock;

/// What one tick produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tick {
    /// Commanded machine position of every configured axis (the spindle axis includes the
    /// spindle offset, see the crate doc).
    pub pos: AxisPos,
    /// Program line and N number of the move this tick belongs to (the last one when idle).
    pub line: u32,
    pub n: Option<u32>,
    pub state: TickState,
    /// The move given to `start` completed with this tick; `start` the next one.
    pub finished: bool,
    /// A non-motion event of the program, reported once (on the tick that finishes it).
    pub event: Option<MoveEvent>,
    /// Path speed (path units/s) of this sample; during a spindle orientation, its speed
    /// (deg/s, unsigned).
    pub path_velocity: f64,
    /// Each spindle's speed in deg/s, by number (`[0]`: spindle 1; 0 in position mode, which
    /// includes orientation, and for a spindle the machine does not have).
    pub spindle_velocity: [f64; MAX_SPINDLES],
}

/// What the interpolator was doing during a tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TickState {
    /// No move; holding position.
    Idle,
    /// Moving along a path, or orienting the spindle.
    Moving,
    /// Holding position for a dwell; `remaining` periods after this one.
    Dwelling { remaining: u64 },
    /// Waiting for the spindle to reach the commanded speed.
    SpindleRamp,
    /// Reporting a non-motion event (see [`Tick::event`]).
    Event,
    /// Decelerating after `request_stop`.
    Stopping,
    /// At rest after `request_stop`; `clear_stop` returns to `Idle`.
    Held,
}

/// The program's non-motion events, for the caller to act on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MoveEvent {
    ToolChange {
        tool: u32,
    },
    Coolant {
        mist: bool,
        flood: bool,
    },
    ProgramStop {
        kind: StopKind,
    },
    /// The text is in the caller's `Segment` of this line.
    Message,
}

// Large variants on purpose: boxing them would allocate in the real-time loop.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
enum Job {
    Idle,
    Held,
    Path {
        mv: PathMove,
        k: u64,
        /// The profile time of tick 0: sample k is at `t_base + k·P` (0 after rest; a blended
        /// move starts where the last one's fractional period left off).
        t_base: f64,
        /// The stop ramp, when a stop is under way (see [`PathStop`]).
        stop: Option<PathStop>,
        /// Profile time lost to feed hold and override: sample k is at
        /// `t_base + k·P + lag` (0 while the rate is 1).
        lag: f64,
    },
    Dwell {
        left: u64,
    },
    /// Waiting for the spindle in this slot (number − 1) to reach its speed.
    SpindleRamp {
        slot: usize,
    },
    Orient {
        /// The oriented spindle's slot (number − 1).
        slot: usize,
        orient: OrientMove,
        k: u64,
        /// Stop profile (in the orient move's own distance) and the tick it starts at.
        stop: Option<(JerkProfile, u64)>,
    },
    Event(MoveEvent),
}

/// A stop ramp along a path: on tick k the ramp is at time `t0 + (k − k0)·P`, and the move's
/// own s is the ramp's s minus `s_base` (the ramp distance that earlier moves of a blended
/// chain took up). A ramp started in the move itself has `t0 = s_base = 0`.
#[derive(Clone, Copy, Debug)]
struct PathStop {
    ramp: JerkProfile,
    k0: u64,
    t0: f64,
    s_base: f64,
}

/// Where a stop ramp goes on after a blended move ended under it: the ramp time of the next
/// sample and the ramp distance used up so far.
#[derive(Clone, Copy, Debug)]
struct StopCarry {
    ramp: JerkProfile,
    t_next: f64,
    s_base: f64,
}

/// A blended move ended at speed: what the next move needs to continue without a break.
#[derive(Clone, Copy, Debug)]
struct Blend {
    /// Where the move ended (the next one must start there).
    end: AxisPos,
    /// Profile time past the move's end of the next sample, minus one period (in (−P, 0]).
    carry: f64,
    /// Path speed and acceleration at the last sample (for a stop between moves).
    last: State,
    /// Path distance from the last sample to `end`.
    remaining: f64,
    /// The ended move's path limits.
    limits: Limits,
}

/// A spindle orientation resolved against machine C: C = `from` + `sign`·s(t), landing on
/// `target` (≡ the angle mod 360, |target − from| ≤ 180) exactly on tick `ticks`.
#[derive(Clone, Copy, Debug)]
struct OrientMove {
    from: f64,
    target: f64,
    sign: f64,
    limits: Limits,
    profile: JerkProfile,
    ticks: u64,
}

impl OrientMove {
    /// The nearest machine C ≡ `angle` (mod 360) to `from` (ties: forward), computed as
    /// `angle` + 360·n with one rounding, so it is within half an ulp of the angle mod 360
    /// (1.2·10⁻⁷° at 1.3·10⁹°, far below a count).
    fn new(from: f64, angle: f64, limits: Limits, period: f64) -> Option<OrientMove> {
        let n = ((from - angle) / 360.0 + 0.5).floor();
        let mut target = angle + 360.0 * n;
        // The quotient's rounding can put the choice one turn off; fix it (ties forward).
        if target - from > 180.0 {
            target -= 360.0;
        } else if from - target >= 180.0 {
            target += 360.0;
        }
        let d = target - from;
        let profile = rest_to_rest(d.abs(), limits).ok()?;
        let (profile, ticks) = if profile.duration() > 0.0 {
            let n = (profile.duration() / period).ceil().max(1.0);
            // At most half a turn: far from any tick-count overflow.
            let ticks = n as u64;
            (profile.time_scaled(n * period / profile.duration()), ticks)
        } else {
            (profile, 1)
        };
        Some(OrientMove {
            from,
            target,
            sign: if d < 0.0 { -1.0 } else { 1.0 },
            limits,
            profile,
            ticks,
        })
    }
}

#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
enum SpindleRun {
    /// Position mode: machine C = program C + offset.
    Position,
    /// Speed mode: C (machine, degrees) = profile sampled `k` periods after its start.
    Speed { profile: JerkProfile, k: u64 },
}

/// One spindle: its axis and limits, and the state of its speed mode. Each spindle has its
/// own offset, speed, override and orientation; they act on its axis alone.
#[derive(Clone, Copy, Debug)]
struct SpindleAxis {
    index: usize,
    acceleration: f64,
    jerk: f64,
    max_velocity: f64,
    /// Machine C − program C in position mode (the turn of speed-mode runs), C its axis.
    offset: f64,
    spin: SpindleRun,
    /// Spindle override (0.5–1.2) and the speed the program commanded (deg/s, signed).
    override_factor: f64,
    commanded: f64,
}

impl SpindleAxis {
    fn at_rest(&self) -> bool {
        matches!(self.spin, SpindleRun::Position)
    }

    /// The commanded speed with the override, within the axis's max velocity.
    fn target(&self) -> f64 {
        let v = self.commanded * self.override_factor;
        v.clamp(-self.max_velocity, self.max_velocity)
    }
}

/// See the module doc. Built once per machine; every method is allocation-free.
#[derive(Clone, Debug)]
pub struct Interpolator {
    period: f64,
    /// The spindles by number (`[0]`: spindle 1).
    spindles: [Option<SpindleAxis>; MAX_SPINDLES],
    /// Program-coordinate position of the last sample.
    prog: AxisPos,
    job: Job,
    stopping: bool,
    line: u32,
    n: Option<u32>,
    last: AxisPos,
    /// Set while the last move ended at speed and the next has not started.
    blend: Option<Blend>,
    /// A stop ramp that must go on along the next move of a blended chain.
    stop_carry: Option<StopCarry>,
    /// Ticks that found no next move while the path was at speed (the feeder fell behind:
    /// the path paused on the spot).
    starved_at_speed: u64,
    /// Feed hold and feed override (time scaling of path moves).
    rate: RateClock,
    /// The last move started was a rigid tap's tap in (its tap out follows).
    inside_tap: bool,
}

impl Interpolator {
    /// An idle interpolator holding `start` (machine coordinates), spindle at rest, spindle
    /// offset 0, period from `config.bus.period_us`.
    pub fn new(config: &MachineConfig, start: AxisPos) -> Interpolator {
        let n_axes = config.axes.len().min(MAX_AXES);
        let mut prog = start;
        for i in n_axes..MAX_AXES {
            prog.0[i] = 0.0;
        }
        let spindles = config.spindle_axes().map(|axis| {
            axis.filter(|&i| i < MAX_AXES).map(|i| SpindleAxis {
                index: i,
                acceleration: config.axes[i].max_acceleration,
                jerk: config.axes[i].max_jerk,
                max_velocity: config.axes[i].max_velocity,
                offset: 0.0,
                spin: SpindleRun::Position,
                override_factor: 1.0,
                commanded: 0.0,
            })
        });
        Interpolator {
            period: config.bus.period_s(),
            spindles,
            prog,
            job: Job::Idle,
            stopping: false,
            line: 0,
            n: None,
            last: prog,
            blend: None,
            stop_carry: None,
            starved_at_speed: 0,
            rate: RateClock::new(),
            inside_tap: false,
        }
    }

    /// Feed hold on or off. On, the path decelerates along itself to rest (every axis
    /// together, within the move's limits) and stays there; off, it accelerates back and
    /// runs on as planned. A rigid tap is not held (it finishes; see `rate`). The caller
    /// starts no move from rest while holding.
    pub fn set_feed_hold(&mut self, hold: bool) {
        self.rate.hold = hold;
    }

    /// Feed override as a factor, 0–2 (clamped). Up to 1 it slows the planned profile
    /// down; above 1 it takes effect through the planner (`Planner::set_feed_scale`): a move
    /// runs at override / its `feed_scale`, at most as planned.
    pub fn set_feed_override(&mut self, factor: f64) {
        self.rate.feed = if factor.is_finite() {
            factor.clamp(0.0, 2.0)
        } else {
            1.0
        };
    }

    /// Rapid override as a factor (0–1, clamped): rapids run their planned profile slowed
    /// down by it (feed override does not act on them).
    pub fn set_rapid_override(&mut self, factor: f64) {
        self.rate.rapid = if factor.is_finite() {
            factor.clamp(0.0, 1.0)
        } else {
            1.0
        };
    }

    /// Spindle override of every spindle as a factor (see
    /// [`set_spindle_override_of`](Self::set_spindle_override_of)).
    pub fn set_spindle_override(&mut self, factor: f64) {
        for number in 1..=MAX_SPINDLES as u8 {
            self.set_spindle_override_of(number, factor);
        }
    }

    /// Spindle override of spindle `number` as a factor (0.5–1.2, clamped; never above its
    /// axis's max velocity): a turning spindle ramps to the new speed within its limits.
    pub fn set_spindle_override_of(&mut self, number: u8, factor: f64) {
        let f = if factor.is_finite() {
            factor.clamp(0.5, 1.2)
        } else {
            1.0
        };
        let (prog, period, stopping) = (self.prog, self.period, self.stopping);
        let Some(sp) = self.spindle_mut(number) else {
            return;
        };
        if f == sp.override_factor {
            return;
        }
        sp.override_factor = f;
        if !sp.at_rest() && !stopping && sp.commanded != 0.0 {
            let now = spindle_state(sp, &prog, period);
            sp.spin = SpindleRun::Speed {
                profile: velocity_change(now, sp.target(), sp.acceleration, sp.jerk),
                k: 0,
            };
        }
    }

    /// Spindle `number` (1-based), if the machine has it.
    fn spindle_mut(&mut self, number: u8) -> Option<&mut SpindleAxis> {
        let slot = usize::from(number).checked_sub(1)?;
        self.spindles.get_mut(slot)?.as_mut()
    }

    /// Whether a feed hold keeps `next` from starting now: the path is at rest (no blended
    /// move wants a successor) and `next` is not the tap out of a rigid tap whose tap in ran
    /// last (Fanuc: the hold takes effect after the return to R).
    pub fn holds_before(&self, next: &PlannedMove) -> bool {
        if !self.rate.hold || self.needs_next_move() || self.wants_next_move() {
            return false;
        }
        let tap_out = matches!(&next.kind, MoveKind::Path(p) if p.tap.is_some());
        !(tap_out && self.inside_tap)
    }

    /// The rate path moves run at (1: as planned; 0: held).
    pub fn feed_rate(&self) -> f64 {
        self.rate.r
    }

    /// True while a feed hold has the path at rest: a path move stopped on its path, or
    /// none running.
    pub fn is_feed_held(&self) -> bool {
        self.rate.hold
            && match &self.job {
                Job::Path { mv, .. } => mv.tap.is_none() && self.rate.r == 0.0,
                Job::Idle => self.blend.is_none(),
                _ => false,
            }
    }

    /// True while a stop ramp must continue along the next move of a blended chain: give it
    /// with [`Interpolator::start`] before the next tick (the only start accepted while
    /// stopping).
    pub fn wants_next_move(&self) -> bool {
        self.stop_carry.is_some() && matches!(self.job, Job::Idle)
    }

    /// True between two moves of a blended chain: the path is at speed and the next tick
    /// needs the next move (without it the path pauses on the spot, see
    /// [`starved_at_speed`](Self::starved_at_speed)).
    pub fn needs_next_move(&self) -> bool {
        matches!(self.job, Job::Idle) && self.blend.is_some()
    }

    /// Ticks that found the path at speed with no next move (see the module doc).
    pub fn starved_at_speed(&self) -> u64 {
        self.starved_at_speed
    }

    /// The period in seconds.
    pub fn period(&self) -> f64 {
        self.period
    }

    /// True when a new move may be started.
    pub fn is_idle(&self) -> bool {
        matches!(self.job, Job::Idle) && !self.stopping
    }

    /// True once a requested stop has brought every axis (and the spindle) to rest.
    pub fn is_held(&self) -> bool {
        self.stopping
            && (matches!(self.job, Job::Held)
                || (matches!(self.job, Job::Idle) && self.stop_carry.is_none()))
            && !self.spindle_running()
    }

    /// True while a stop has been requested and not cleared.
    pub fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// The last commanded machine position.
    pub fn position(&self) -> AxisPos {
        self.last
    }

    /// The last position in program coordinates (the spindle axis without its offset): what
    /// `Planner::set_position` needs after a stop.
    pub fn program_position(&self) -> AxisPos {
        self.prog
    }

    /// Machine C − program C of spindle 1 (the angle it turned in speed mode).
    pub fn spindle_offset(&self) -> f64 {
        self.spindle_offset_of(1)
    }

    /// Machine − program position of spindle `number`'s axis (0 without that spindle).
    pub fn spindle_offset_of(&self, number: u8) -> f64 {
        let slot = usize::from(number).wrapping_sub(1);
        self.spindles
            .get(slot)
            .and_then(|s| s.as_ref())
            .map_or(0.0, |s| s.offset)
    }

    /// Sets spindle 1's machine C − program C (see
    /// [`set_spindle_offset_of`](Self::set_spindle_offset_of)).
    pub fn set_spindle_offset(&mut self, offset: f64) -> bool {
        self.set_spindle_offset_of(1, offset)
    }

    /// Sets machine − program position of spindle `number`'s axis, e.g. at start-up so that
    /// the first setpoint equals the drive's actual position (`actual − program`) whatever
    /// angle the spindle was left at. Only while idle with the spindle at rest (else returns
    /// false and changes nothing).
    pub fn set_spindle_offset_of(&mut self, number: u8, offset: f64) -> bool {
        if !self.is_idle() || !offset.is_finite() {
            return false;
        }
        let prog = self.prog;
        let Some(sp) = self.spindle_mut(number).filter(|s| s.at_rest()) else {
            return false;
        };
        sp.offset = offset;
        let i = sp.index;
        self.last.0[i] = prog.0[i] + offset;
        true
    }

    /// True while any spindle axis is in speed mode (turning or ramping).
    pub fn spindle_running(&self) -> bool {
        self.spindles.iter().flatten().any(|s| !s.at_rest())
    }

    /// Starts the next move. It must start where the last one ended (program coordinates,
    /// exactly: the planner chains them); a path move may not turn the spindle axis while it
    /// runs in speed mode.
    pub fn start(&mut self, mv: PlannedMove) -> Result<(), MotionError> {
        let err = |kind| MotionError {
            line: mv.line,
            n: mv.n,
            kind,
        };
        let chained_stop = self.stopping && self.wants_next_move();
        if self.stopping && !(chained_stop && matches!(mv.kind, MoveKind::Path(_))) {
            return Err(err(MotionErrorKind::Stopped));
        }
        if !matches!(self.job, Job::Idle) {
            return Err(err(MotionErrorKind::Busy));
        }
        if self.blend.is_some() && !matches!(mv.kind, MoveKind::Path(_)) {
            // A blended move is always followed by a path move; anything else would stop
            // the path dead.
            return Err(err(MotionErrorKind::NotAtStart));
        }
        self.job = match mv.kind {
            MoveKind::Path(p) => {
                let expected = self.blend.map_or(self.prog, |b| b.end);
                if p.start != expected {
                    return Err(err(MotionErrorKind::NotAtStart));
                }
                let turns_running =
                    |sp: &SpindleAxis| !sp.at_rest() && p.end.0[sp.index] != p.start.0[sp.index];
                if self.spindles.iter().flatten().any(turns_running) {
                    return Err(err(MotionErrorKind::SpindleRunning));
                }
                let blend = self.blend.take();
                let carry = blend.map_or(0.0, |b| b.carry);
                if let Some(c) = &mut self.stop_carry {
                    if c.ramp.sample(c.t_next).s - c.s_base > p.length && p.end_speed > 0.0 {
                        // The ramp passes this whole move before the next sample.
                        c.s_base += p.length;
                        self.blend = blend.map(|b| Blend { end: p.end, ..b });
                        return Ok(());
                    }
                } else if let Some(b) = blend
                    && p.end_speed > 0.0
                    && p.t_begin + carry + self.period * self.rate.r > p.t_end
                {
                    // The whole move lies between two samples: on to the next one.
                    self.blend = Some(Blend {
                        end: p.end,
                        carry: p.t_begin + carry - p.t_end,
                        remaining: b.remaining + p.length,
                        limits: p.limits,
                        ..b
                    });
                    return Ok(());
                }
                let stop = self.stop_carry.take().map(|c| PathStop {
                    ramp: c.ramp,
                    k0: 0,
                    t0: c.t_next - self.period,
                    s_base: c.s_base,
                });
                if blend.is_none() {
                    self.rate.start_at_rest(self.rate.target(&p));
                }
                self.inside_tap = p.tap.is_some() && !self.inside_tap;
                Job::Path {
                    mv: p,
                    k: 0,
                    t_base: p.t_begin + carry,
                    stop,
                    lag: 0.0,
                }
            }
            MoveKind::Dwell { ticks, .. } => Job::Dwell { left: ticks.max(1) },
            MoveKind::Spindle {
                velocity,
                acceleration,
                jerk,
                spindle: number,
            } => {
                let (prog, period) = (self.prog, self.period);
                let Some(sp) = self.spindle_mut(number) else {
                    return Err(err(MotionErrorKind::NoSpindle { number }));
                };
                let now = spindle_state(sp, &prog, period);
                sp.commanded = velocity;
                sp.spin = SpindleRun::Speed {
                    profile: velocity_change(now, sp.target(), acceleration, jerk),
                    k: 0,
                };
                Job::SpindleRamp {
                    slot: usize::from(number) - 1,
                }
            }
            MoveKind::SpindleOrient {
                angle,
                limits,
                program,
                spindle: number,
            } => {
                let (prog, period) = (self.prog, self.period);
                let Some(sp) = self.spindle_mut(number) else {
                    return Err(err(MotionErrorKind::NoSpindle { number }));
                };
                if !sp.at_rest() {
                    return Err(err(MotionErrorKind::SpindleRunning));
                }
                if !(angle.is_finite() && (0.0..360.0).contains(&angle)) {
                    return Err(err(MotionErrorKind::BadOrientAngle(angle)));
                }
                if let Some(c) = program
                    && !orient_program_agrees(angle, c)
                {
                    return Err(err(MotionErrorKind::BadOrientProgram { angle, program: c }));
                }
                let from = prog.0[sp.index] + sp.offset;
                let Some(orient) = OrientMove::new(from, angle, limits, period) else {
                    return Err(err(MotionErrorKind::BadLimits));
                };
                if let Some(c) = program {
                    // Program C reads `c` from here on (G28/G30 C); machine C does not jump:
                    // the offset takes the difference, and the turn goes into it at the end.
                    sp.offset = from - c;
                    let i = sp.index;
                    self.prog.0[i] = c;
                }
                Job::Orient {
                    slot: usize::from(number) - 1,
                    orient,
                    k: 0,
                    stop: None,
                }
            }
            MoveKind::ToolChange { tool } => Job::Event(MoveEvent::ToolChange { tool }),
            MoveKind::Coolant { mist, flood } => Job::Event(MoveEvent::Coolant { mist, flood }),
            MoveKind::ProgramStop { kind } => Job::Event(MoveEvent::ProgramStop { kind }),
            MoveKind::Message => Job::Event(MoveEvent::Message),
        };
        self.line = mv.line;
        self.n = mv.n;
        Ok(())
    }

    /// Decelerates the current move along its own path (jerk-limited, within the move's
    /// path limits, so axes moving together — Z and C of a tap — stay coupled) and the
    /// spindle to rest, then holds. A dwell or event is dropped at once. Starting new moves
    /// is refused until [`Interpolator::clear_stop`].
    pub fn request_stop(&mut self) {
        if self.stopping {
            return;
        }
        self.stopping = true;
        match &mut self.job {
            Job::Path {
                mv,
                k,
                t_base,
                stop,
                lag,
            } => {
                let sampled = mv.profile.sample(*t_base + *k as f64 * self.period + *lag);
                // In real time: the feed hold or override may be scaling the profile.
                let mut now = self.rate.scale(sampled);
                now.s -= mv.s_offset;
                // A blended move may hand the ramp on to the next move: no room needed here.
                let room = if mv.end_speed > 0.0 {
                    f64::INFINITY
                } else {
                    mv.length
                };
                if let Some(ramp) = stop_ramp(now, mv.limits, room) {
                    *stop = Some(PathStop {
                        ramp,
                        k0: *k,
                        t0: 0.0,
                        s_base: 0.0,
                    });
                }
            }
            Job::Idle if self.blend.is_some() => self.stop_from_blend(),
            Job::Orient {
                orient, k, stop, ..
            } => {
                let now = orient.profile.sample(*k as f64 * self.period);
                if let Some(sp) = stop_ramp(now, orient.limits, orient.profile.end().s) {
                    *stop = Some((sp, *k));
                }
            }
            _ => self.job = Job::Held,
        }
        let (prog, period) = (self.prog, self.period);
        for ax in self.spindles.iter_mut().flatten() {
            if !ax.at_rest() {
                let now = spindle_state(ax, &prog, period);
                ax.spin = SpindleRun::Speed {
                    profile: velocity_change(now, 0.0, ax.acceleration, ax.jerk),
                    k: 0,
                };
            }
        }
    }

    /// Between two blended moves: the stop ramp starts from the last sample and runs on along
    /// the next move.
    fn stop_from_blend(&mut self) {
        if let Some(b) = self.blend {
            let from = State { s: 0.0, ..b.last };
            let ramp = velocity_change(from, 0.0, b.limits.acceleration, b.limits.jerk);
            self.stop_carry = Some(StopCarry {
                ramp,
                t_next: self.period,
                s_base: b.remaining,
            });
        }
    }

    /// After a stop has come to rest: forget the interrupted move and become idle at the
    /// held position. Returns false (and does nothing) if not yet held.
    pub fn clear_stop(&mut self) -> bool {
        if !self.is_held() {
            return false;
        }
        self.stopping = false;
        self.job = Job::Idle;
        self.blend = None;
        self.stop_carry = None;
        true
    }

    /// Advances one period and returns the setpoints for it.
    pub fn tick(&mut self) -> Tick {
        // The spindles first: a ramp move completes when its spindle is at speed.
        let mut spin = [SpindleTick::AT_REST; MAX_SPINDLES];
        for (slot, t) in spin.iter_mut().enumerate() {
            *t = self.advance_spindle(slot);
        }
        let ramp_done = match self.job {
            Job::SpindleRamp { slot } => spin[slot].ramp_done,
            _ => true,
        };
        let job = self.advance_job(ramp_done);
        let state = if !self.stopping {
            job.state
        } else if self.is_held() {
            TickState::Held
        } else {
            TickState::Stopping
        };
        let mut pos = self.prog;
        for (slot, sp) in self.spindles.iter().enumerate() {
            let Some(sp) = sp else { continue };
            // An orientation commands the spindle axis itself, over a speed run.
            let oriented = job.spindle_pos.filter(|o| o.0 == slot).map(|o| o.1);
            pos.0[sp.index] = oriented
                .or(spin[slot].pos)
                .unwrap_or(self.prog.0[sp.index] + sp.offset);
        }
        self.last = pos;
        Tick {
            pos,
            line: self.line,
            n: self.n,
            state,
            finished: job.finished,
            event: job.event,
            path_velocity: job.path_velocity,
            spindle_velocity: spin.map(|s| s.velocity),
        }
    }

    /// One period of spindle `slot`'s speed run (none: no spindle position of its own, and
    /// no ramp to wait for). A ramp that ends at rest returns the spindle to position mode.
    #[inline]
    fn advance_spindle(&mut self, slot: usize) -> SpindleTick {
        let prog = self.prog;
        let Some(sp) = self.spindles[slot].as_mut() else {
            return SpindleTick::AT_REST;
        };
        let SpindleRun::Speed { profile, k } = &mut sp.spin else {
            return SpindleTick::AT_REST;
        };
        *k += 1;
        let t = *k as f64 * self.period;
        let st = profile.sample(t);
        let ramp_done = t >= profile.duration();
        if ramp_done && profile.end().v == 0.0 {
            // At rest: position mode again, re-based so that program C continues from
            // where the spindle stopped.
            let c = profile.end().s;
            sp.offset = c - prog.0[sp.index];
            sp.spin = SpindleRun::Position;
            SpindleTick {
                pos: Some(c),
                velocity: 0.0,
                ramp_done,
            }
        } else {
            SpindleTick {
                pos: Some(st.s),
                velocity: st.v,
                ramp_done,
            }
        }
    }

    /// One period of the current job (`ramp_done`: the spindle is at its commanded speed).
    #[inline]
    fn advance_job(&mut self, ramp_done: bool) -> JobTick {
        let p = self.period;
        let mut out = JobTick {
            state: TickState::Moving,
            finished: false,
            event: None,
            path_velocity: 0.0,
            spindle_pos: None,
        };
        match &mut self.job {
            Job::Idle => {
                out.state = TickState::Idle;
                if self.blend.is_some() || self.stop_carry.is_some() {
                    // The path is at speed and no move came: it pauses on the spot.
                    self.starved_at_speed += 1;
                    if self.stopping {
                        // No move to carry the stop ramp on: the stop ends here.
                        self.stop_carry = None;
                        self.blend = None;
                        self.job = Job::Held;
                    }
                }
            }
            Job::Held => out.state = TickState::Stopping,
            Job::Path {
                mv,
                k,
                t_base,
                stop,
                lag,
            } => {
                *k += 1;
                let mv = *mv;
                if stop.is_none() {
                    let t_now = *t_base + (*k - 1) as f64 * p + *lag;
                    *lag += self.rate.lag_step(&mv, t_now, p);
                }
                let t = *t_base + *k as f64 * p + *lag;
                match path_along(&mv, t, stop, *k, p, &self.rate) {
                    PathAlong::On(st) => {
                        self.prog = mv.point(st.s);
                        out.path_velocity = st.v;
                    }
                    PathAlong::StopDone(st) => {
                        self.prog = mv.point(st.s);
                        out.path_velocity = st.v;
                        self.job = Job::Held;
                    }
                    PathAlong::End => {
                        self.prog = mv.end;
                        out.finished = self.end_job();
                    }
                    PathAlong::Blend(st, carry) => {
                        self.prog = mv.point(st.s);
                        out.path_velocity = st.v;
                        out.finished = true;
                        self.blend = Some(Blend {
                            end: mv.end,
                            carry,
                            last: st,
                            remaining: mv.length - st.s,
                            limits: mv.limits,
                        });
                        self.job = Job::Idle;
                        if self.stopping {
                            // A stop whose ramp found no room in this move (it was braking
                            // already): it goes on along the next one.
                            self.stop_from_blend();
                        }
                    }
                    PathAlong::StopCarry(st, c) => {
                        self.prog = mv.point(st.s);
                        out.path_velocity = st.v;
                        self.stop_carry = Some(c);
                        self.blend = Some(Blend {
                            end: mv.end,
                            carry: 0.0,
                            last: st,
                            remaining: mv.length - st.s,
                            limits: mv.limits,
                        });
                        self.job = Job::Idle;
                    }
                }
            }
            Job::Orient {
                slot,
                orient,
                k,
                stop,
            } => {
                *k += 1;
                let slot = *slot;
                let o = *orient;
                let (c, done) = match along(&o.profile, o.ticks, stop, *k, p) {
                    Along::On(st) => {
                        out.path_velocity = st.v;
                        (o.from + o.sign * st.s, false)
                    }
                    Along::StopDone(st) => {
                        out.path_velocity = st.v;
                        (o.from + o.sign * st.s, true)
                    }
                    Along::End => (o.target, true),
                };
                out.spindle_pos = Some((slot, c));
                if done {
                    // Program C stays (or was set when the move started); the turn goes into
                    // the offset (as after a speed run).
                    if let Some(sp) = self.spindles[slot].as_mut() {
                        sp.offset = c - self.prog.0[sp.index];
                    }
                    out.finished = self.end_job();
                }
            }
            Job::Dwell { left } => {
                *left = left.saturating_sub(1);
                out.state = TickState::Dwelling { remaining: *left };
                if *left == 0 {
                    out.finished = true;
                    self.job = Job::Idle;
                }
            }
            Job::SpindleRamp { .. } => {
                out.state = TickState::SpindleRamp;
                if ramp_done {
                    out.finished = true;
                    self.job = Job::Idle;
                }
            }
            Job::Event(e) => {
                out.state = TickState::Event;
                out.event = Some(*e);
                out.finished = true;
                self.job = Job::Idle;
            }
        }
        out
    }

    /// A move has reached its end: held there while a stop is under way, else finished
    /// (true) and idle.
    #[inline]
    fn end_job(&mut self) -> bool {
        if self.stopping {
            self.job = Job::Held;
            false
        } else {
            self.job = Job::Idle;
            true
        }
    }
}

/// What one period of a speed run gave [`Interpolator::tick`].
#[derive(Clone, Copy)]
struct SpindleTick {
    /// Machine C, when the speed run commands it.
    pos: Option<f64>,
    velocity: f64,
    /// The ramp has reached its speed (true without a speed run).
    ramp_done: bool,
}

impl SpindleTick {
    /// A spindle in position mode (or none): nothing of its own, no ramp to wait for.
    const AT_REST: SpindleTick = SpindleTick {
        pos: None,
        velocity: 0.0,
        ramp_done: true,
    };
}

/// A spindle's machine position, velocity and acceleration at the last tick (`prog`: the
/// program position, read in position mode).
fn spindle_state(sp: &SpindleAxis, prog: &AxisPos, period: f64) -> State {
    match &sp.spin {
        SpindleRun::Position => State {
            s: prog.0[sp.index] + sp.offset,
            v: 0.0,
            a: 0.0,
        },
        SpindleRun::Speed { profile, k } => profile.sample(*k as f64 * period),
    }
}

/// What one period of the job gave [`Interpolator::tick`].
struct JobTick {
    /// The state unless a stop is under way.
    state: TickState,
    finished: bool,
    event: Option<MoveEvent>,
    path_velocity: f64,
    /// The oriented spindle's slot and machine position, when an orientation commands it.
    spindle_pos: Option<(usize, f64)>,
}

/// The ramp from `now` to rest within `lim`, for a move of `length`: none when the
/// planned profile is itself the quickest stop.
fn stop_ramp(now: State, lim: Limits, length: f64) -> Option<JerkProfile> {
    let sp = velocity_change(now, 0.0, lim.acceleration, lim.jerk);
    // The ramp turns back only if the acceleration in hand cannot be taken out before v
    // reaches 0 — then we are already braking to the end point, and the planned profile is
    // itself the quickest stop. Same if it would overrun.
    let reverses = -now.v - now.a * now.a.abs() / (2.0 * lim.jerk) > 0.0;
    (!reverses && sp.end().s <= length).then_some(sp)
}

/// Where a path move is on one tick. (Large on purpose: boxing would allocate in the loop.)
#[allow(clippy::large_enum_variant)]
enum PathAlong {
    /// Along its profile or stop ramp (s in the move's own path parameter).
    On(State),
    /// At the end of its stop ramp: at rest.
    StopDone(State),
    /// On its last tick: at its end point (at rest).
    End,
    /// Its last sample before the next move of a blended chain takes over; the next
    /// sample is `carry` + one period past this move's end on the profile.
    Blend(State, f64),
    /// Its last sample under a stop ramp that goes on along the next move.
    StopCarry(State, StopCarry),
}

/// Where path move `mv` is at profile time `t` (tick `k`), on its stop ramp if one was begun.
/// A move that ends at speed hands over one sample early: the next sample belongs to the next
/// move, `t + P − t_end` into it.
/// Profile samples are seen through `rate` (feed hold and override).
#[inline]
fn path_along(
    mv: &PathMove,
    t: f64,
    stop: &Option<PathStop>,
    k: u64,
    period: f64,
    rate: &RateClock,
) -> PathAlong {
    if let Some(st) = stop {
        let tr = st.t0 + (k - st.k0) as f64 * period;
        let mut now = st.ramp.sample(tr);
        if st.s_base != 0.0 || mv.end_speed > 0.0 {
            now = clamp_s(
                State {
                    s: now.s - st.s_base,
                    ..now
                },
                mv.length,
            );
        }
        if tr >= st.ramp.duration() {
            return PathAlong::StopDone(now);
        }
        if mv.end_speed > 0.0 && st.ramp.sample(tr + period).s - st.s_base > mv.length {
            let carry = StopCarry {
                ramp: st.ramp,
                t_next: tr + period,
                s_base: st.s_base + mv.length,
            };
            return PathAlong::StopCarry(now, carry);
        }
        return PathAlong::On(now);
    }
    if mv.end_speed > 0.0 {
        let mut st = rate.scale(mv.profile.sample(t));
        st.s -= mv.s_offset;
        // The next sample is one period at this rate later (the rate changes little in a
        // period; a sample that falls short of this move's end lands on its end).
        if t + period * rate.r > mv.t_end {
            return PathAlong::Blend(clamp_s(st, mv.length), t - mv.t_end);
        }
        return PathAlong::On(clamp_s(st, mv.length));
    }
    if t >= mv.t_end {
        return PathAlong::End;
    }
    let mut st = rate.scale(mv.profile.sample(t));
    if mv.s_offset != 0.0 {
        st.s = (st.s - mv.s_offset).clamp(0.0, mv.length);
    }
    PathAlong::On(st)
}

/// `st` with s kept within the move (rounding of the offset subtraction).
#[inline]
fn clamp_s(st: State, length: f64) -> State {
    State {
        s: st.s.clamp(0.0, length),
        ..st
    }
}

/// Where a move is on one tick.
enum Along {
    /// Along its profile, or its stop ramp.
    On(State),
    /// At the end of its stop ramp: at rest.
    StopDone(State),
    /// On its last tick: at its end point.
    End,
}

/// Where a move of `ticks` periods is on tick `k`: on its stop ramp (started on tick `k0`)
/// if one was begun, else on its own profile.
#[inline]
fn along(
    profile: &JerkProfile,
    ticks: u64,
    stop: &Option<(JerkProfile, u64)>,
    k: u64,
    period: f64,
) -> Along {
    match stop {
        Some((sp, k0)) => {
            let t = (k - *k0) as f64 * period;
            let st = sp.sample(t);
            if t >= sp.duration() {
                Along::StopDone(st)
            } else {
                Along::On(st)
            }
        }
        None if k >= ticks => Along::End,
        None => Along::On(profile.sample(k as f64 * period)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::Planner;
    use crate::segment::{Segment, SegmentKind, Source};
    use cnc402_config::MachineConfig;

    /// M7/M8/M9 reach the caller as one event tick, with their line, and move nothing.
    #[test]
    fn coolant_is_an_event_of_one_tick() {
        let cfg = MachineConfig::default_machine();
        let start = AxisPos::default();
        let mut planner = Planner::new(&cfg);
        planner.set_position(start);
        let mut ip = Interpolator::new(&cfg, start);
        for (line, (mist, flood)) in [(3, (false, true)), (4, (true, true)), (5, (false, false))] {
            let seg = Segment {
                kind: SegmentKind::Coolant { mist, flood },
                source: Source {
                    file: "t.nc".into(),
                    line,
                    n: None,
                },
                ends: crate::segment::SegmentEnd::ExactStop,
            };
            let mv = planner.plan(&seg).expect("plans");
            assert_eq!(mv.kind, MoveKind::Coolant { mist, flood });
            ip.start(mv).expect("starts");
            let t = ip.tick();
            assert!(t.finished);
            assert_eq!(t.state, TickState::Event);
            assert_eq!(t.event, Some(MoveEvent::Coolant { mist, flood }));
            assert_eq!((t.line, t.pos), (line, start));
        }
    }
}
