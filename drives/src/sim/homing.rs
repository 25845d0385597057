//! The simulated machine around one drive — limit switches, a home switch, encoder index
//! pulses — and the drive's homing mode on it: each supported CiA 402 method as a sequence of
//! searches at the homing speeds and acceleration (0x6099, 0x609A), the switch or index edge
//! latched exactly (as drive hardware latches it), then a slow return to the home point.
//! Positions here are counts in the drive's direction (after 0x607E), before the home shift.

use cia402::objects as o;
use cia402::{Direction, HomingMethod, HomingStatus, HomingTarget};
use cnc402_config::AxisConfig;

/// Where the switches and index pulses are, in counts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MachineIo {
    /// The negative limit switch is active below this (its edge: where a homing run that
    /// leaves the switch stops is off it).
    pub negative_limit: Option<f64>,
    /// The positive limit switch is active above this.
    pub positive_limit: Option<f64>,
    /// The home switch's edge.
    pub home_edge: Option<f64>,
    /// Whether the home switch is active above its edge (else below).
    pub home_above: bool,
    /// An index pulse at every multiple of this many counts.
    pub index_every: Option<f64>,
    /// How far a homing search may travel before it is given up (counts).
    pub search_limit: f64,
    /// 0x60FD bits that are always on (`sim.inputs`: e.g. a closed E-stop chain).
    pub static_inputs: u32,
}

impl MachineIo {
    /// The `sim` machine of `axis`, in motor counts.
    pub fn of_axis(axis: &AxisConfig) -> MachineIo {
        let cpu = axis.counts_per_unit.abs();
        let m = &axis.sim.machine;
        // A search that finds nothing gives up after one and a half times the axis's travel
        // (a linear axis: its soft-limit span; a rotary one: a turn).
        let span = match (m.limit_switches, axis.soft_limits) {
            (Some((lo, hi)), _) | (None, Some((lo, hi))) => hi - lo,
            (None, None) => 360.0,
        };
        MachineIo {
            negative_limit: m.limit_switches.map(|(lo, _)| lo * cpu),
            positive_limit: m.limit_switches.map(|(_, hi)| hi * cpu),
            home_edge: m.home_switch.map(|h| h * cpu),
            home_above: m.home_switch_above,
            index_every: m.index_pulse_counts.map(f64::from),
            search_limit: (1.5 * span * cpu).max(1.0),
            static_inputs: m.inputs,
        }
    }

    /// The same machine seen by a drive whose direction is inverted (0x607E): positions
    /// negated, the limit switches swapped, the home switch's side flipped.
    pub fn inverted(self, inverted: bool) -> MachineIo {
        if !inverted {
            return self;
        }
        MachineIo {
            negative_limit: self.positive_limit.map(|p| -p),
            positive_limit: self.negative_limit.map(|p| -p),
            home_edge: self.home_edge.map(|p| -p),
            home_above: !self.home_above,
            ..self
        }
    }

    /// The limit switch's position on `side`.
    fn limit(&self, side: Direction) -> Option<f64> {
        match side {
            Direction::Negative => self.negative_limit,
            Direction::Positive => self.positive_limit,
        }
    }

    fn limit_active(&self, side: Direction, p: f64) -> bool {
        match side {
            Direction::Negative => self.negative_limit.is_some_and(|l| p < l),
            Direction::Positive => self.positive_limit.is_some_and(|l| p > l),
        }
    }

    fn home_active(&self, p: f64) -> bool {
        self.home_edge
            .is_some_and(|e| if self.home_above { p >= e } else { p <= e })
    }

    /// 0x60FD at position `p`: bit 0 negative limit, bit 1 positive limit, bit 2 home switch.
    pub fn inputs(&self, p: f64) -> u32 {
        let mut bits = self.static_inputs;
        if self.limit_active(Direction::Negative, p) {
            bits |= o::INPUT_NEGATIVE_LIMIT;
        }
        if self.limit_active(Direction::Positive, p) {
            bits |= o::INPUT_POSITIVE_LIMIT;
        }
        if self.home_active(p) {
            bits |= o::INPUT_HOME_SWITCH;
        }
        bits
    }

    /// The first index pulse passed moving from `a` (excluded) to `b` (included).
    fn index_between(&self, a: f64, b: f64) -> Option<f64> {
        let n = self.index_every?;
        let k = if b > a {
            (a / n).floor() + 1.0
        } else {
            (a / n).ceil() - 1.0
        };
        let p = k * n;
        let passed = if b > a { p <= b } else { p >= b };
        passed.then_some(p)
    }
}

/// The homing parameters the drive was given, in counts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomingParams {
    /// 0x6098.
    pub method: HomingMethod,
    /// 0x6099:1, counts/s.
    pub speed_switch: f64,
    /// 0x6099:2, counts/s.
    pub speed_zero: f64,
    /// 0x609A, counts/s².
    pub acceleration: f64,
}

/// What the current leg of the homing run looks for.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Seek {
    /// The limit switch on this side becoming active.
    LimitOn(Direction),
    /// The limit switch on this side becoming inactive (moving off it).
    LimitOff(Direction),
    /// The home switch becoming active.
    HomeOn,
    /// The home switch becoming inactive: its edge.
    HomeOff,
    /// An index pulse.
    Index,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Stage {
    /// Moving in `dir` at `speed` until `seek` is found.
    Search {
        dir: Direction,
        speed: f64,
        seek: Seek,
    },
    /// Braking after finding `seek` at `at`; `home` once the home point is known.
    Braking {
        found: Seek,
        at: f64,
    },
    /// Moving back to the home point at the zero speed.
    Return {
        home: f64,
    },
    Done {
        home: f64,
    },
    Failed,
}

/// One homing run (controlword bit 4 rising edge to attained or error).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomingRun {
    params: HomingParams,
    stage: Stage,
    /// Velocity, counts/s.
    velocity: f64,
    travelled: f64,
}

fn opposite(d: Direction) -> Direction {
    match d {
        Direction::Negative => Direction::Positive,
        Direction::Positive => Direction::Negative,
    }
}

impl HomingRun {
    /// Starts `params.method` at position `p`.
    pub fn start(params: HomingParams, p: f64, io: &MachineIo) -> HomingRun {
        let fast = params.speed_switch;
        let slow = params.speed_zero;
        let stage = match params.method.target() {
            HomingTarget::CurrentPosition => Stage::Done { home: p.round() },
            HomingTarget::Index { direction } => Stage::Search {
                dir: direction,
                speed: slow,
                seek: Seek::Index,
            },
            HomingTarget::LimitSwitch { side, .. } if io.limit_active(side, p) => Stage::Search {
                dir: opposite(side),
                speed: slow,
                seek: Seek::LimitOff(side),
            },
            HomingTarget::LimitSwitch { side, .. } => Stage::Search {
                dir: side,
                speed: fast,
                seek: Seek::LimitOn(side),
            },
            HomingTarget::HomeSwitch { active_side } => {
                // The edge is approached slowly from the switch's active side.
                let (dir, speed, seek) = if io.home_active(p) {
                    (opposite(active_side), slow, Seek::HomeOff)
                } else {
                    (active_side, fast, Seek::HomeOn)
                };
                Stage::Search { dir, speed, seek }
            }
        };
        HomingRun {
            params,
            stage,
            velocity: 0.0,
            travelled: 0.0,
        }
    }

    /// The statusword's view of the run.
    pub fn status(&self) -> HomingStatus {
        match self.stage {
            Stage::Done { .. } => HomingStatus::Completed,
            Stage::Failed => HomingStatus::Error,
            Stage::Return { .. } => HomingStatus::AttainedMoving,
            Stage::Braking { found, .. } if self.is_home(found) => HomingStatus::AttainedMoving,
            _ => HomingStatus::InProgress,
        }
    }

    /// The home point once homing completed (counts, before the shift).
    pub fn home(&self) -> Option<f64> {
        match self.stage {
            Stage::Done { home } => Some(home),
            _ => None,
        }
    }

    /// Whether finding `seek` ends the search (the home point is where it was found).
    fn is_home(&self, seek: Seek) -> bool {
        match (self.params.method.target(), seek) {
            (_, Seek::Index) => true,
            (HomingTarget::LimitSwitch { index, .. }, Seek::LimitOff(_)) => !index,
            (HomingTarget::HomeSwitch { .. }, Seek::HomeOff) => true,
            _ => false,
        }
    }

    /// The leg after finding `found` (while braking to a stop).
    fn next_leg(&self, found: Seek, at: f64) -> Stage {
        let slow = self.params.speed_zero;
        if self.is_home(found) {
            return Stage::Return { home: at.round() };
        }
        let (dir, seek) = match found {
            Seek::LimitOn(side) => (opposite(side), Seek::LimitOff(side)),
            Seek::LimitOff(side) => (opposite(side), Seek::Index),
            Seek::HomeOn => match self.params.method.target() {
                HomingTarget::HomeSwitch { active_side } => (opposite(active_side), Seek::HomeOff),
                _ => return Stage::Failed,
            },
            Seek::HomeOff | Seek::Index => return Stage::Failed,
        };
        Stage::Search {
            dir,
            speed: slow,
            seek,
        }
    }

    /// Where `seek` happens between `a` and `b` (moving from `a` to `b`), if it does.
    fn found(seek: Seek, io: &MachineIo, a: f64, b: f64) -> Option<f64> {
        match seek {
            Seek::LimitOn(side) => io.limit_active(side, b).then_some(io.limit(side)).flatten(),
            Seek::LimitOff(side) => (!io.limit_active(side, b))
                .then_some(io.limit(side))
                .flatten(),
            Seek::HomeOn => io.home_active(b).then_some(io.home_edge).flatten(),
            Seek::HomeOff => (!io.home_active(b)).then_some(io.home_edge).flatten(),
            Seek::Index => io.index_between(a, b),
        }
    }

    /// A limit switch met that the search does not look for: homing error.
    fn hit_other_limit(&self, seek: Seek, dir: Direction, io: &MachineIo, p: f64) -> bool {
        let wanted = match seek {
            Seek::LimitOn(s) | Seek::LimitOff(s) => Some(s),
            _ => None,
        };
        wanted != Some(dir) && io.limit_active(dir, p)
    }

    /// The velocity one cycle of `dt` seconds later, towards `goal` at the homing
    /// acceleration.
    fn accelerate(&mut self, goal: f64, dt: f64) {
        let dv = self.params.acceleration * dt;
        self.velocity += (goal - self.velocity).clamp(-dv, dv);
    }

    /// One cycle at position `p`: returns the counts to move.
    pub fn step(&mut self, p: f64, dt: f64, io: &MachineIo) -> f64 {
        let step = match self.stage {
            Stage::Search { dir, speed, seek } => {
                self.accelerate(dir.sign() * speed, dt);
                let step = self.velocity * dt;
                if let Some(at) = Self::found(seek, io, p, p + step) {
                    self.stage = Stage::Braking { found: seek, at };
                } else if self.hit_other_limit(seek, dir, io, p + step)
                    || self.travelled > io.search_limit
                {
                    self.stage = Stage::Failed;
                }
                step
            }
            Stage::Braking { found, at } => {
                self.accelerate(0.0, dt);
                if self.velocity == 0.0 {
                    self.stage = self.next_leg(found, at);
                }
                self.velocity * dt
            }
            Stage::Return { home } => {
                let max = self.params.speed_zero * dt;
                // The last step lands on the home point whatever rounding the position has.
                if (home - p).abs() <= max {
                    self.stage = Stage::Done { home };
                }
                (home - p).clamp(-max, max)
            }
            Stage::Failed => {
                self.accelerate(0.0, dt);
                self.velocity * dt
            }
            Stage::Done { .. } => 0.0,
        };
        self.travelled += step.abs();
        step
    }

    /// Whether the run has ended (completed, or failed and stopped).
    pub fn finished(&self) -> bool {
        match self.stage {
            Stage::Done { .. } => true,
            Stage::Failed => self.velocity == 0.0,
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn io() -> MachineIo {
        MachineIo {
            negative_limit: Some(-100_000.0),
            positive_limit: Some(100_000.0),
            home_edge: Some(12_345.0),
            home_above: true,
            index_every: Some(4096.0),
            search_limit: 300_000.0,
            static_inputs: 0,
        }
    }

    fn params(method: i8) -> HomingParams {
        HomingParams {
            method: HomingMethod::new(method).unwrap(),
            speed_switch: 20_000.0,
            speed_zero: 2_000.0,
            acceleration: 200_000.0,
        }
    }

    /// Runs `method` from `start` to its end (at most 10⁶ cycles of 1 ms); returns the home
    /// point (or `None` on error) and the final position.
    fn run(method: i8, start: f64, io: &MachineIo) -> (Option<f64>, f64) {
        let mut h = HomingRun::start(params(method), start, io);
        let mut p = start;
        for _ in 0..1_000_000 {
            if h.finished() {
                return (h.home(), p);
            }
            p += h.step(p, 0.001, io);
        }
        panic!("method {method} from {start} did not end: {h:?}");
    }

    #[test]
    fn home_switch_methods_end_at_the_edge_from_either_side() {
        let io = io();
        for start in [-50_000.0, 0.0, 12_344.0, 12_346.0, 60_000.0] {
            for m in [19, 20] {
                let (home, p) = run(m, start, &io);
                assert_eq!(home, Some(12_345.0), "method {m} from {start}");
                assert_eq!(p, 12_345.0);
            }
        }
        let below = MachineIo {
            home_above: false,
            ..io
        };
        for start in [-50_000.0, 40_000.0] {
            assert_eq!(run(21, start, &below).0, Some(12_345.0), "{start}");
        }
    }

    #[test]
    fn limit_switch_methods_end_at_the_edge_or_the_next_index() {
        let io = io();
        for start in [-99_000.0, 0.0, 77_777.0, -100_500.0] {
            assert_eq!(run(17, start, &io).0, Some(-100_000.0), "17 from {start}");
            // The first index pulse on the positive side of the negative limit: -98304.
            assert_eq!(run(1, start, &io).0, Some(-24.0 * 4096.0), "1 from {start}");
        }
        for start in [0.0, 100_200.0] {
            assert_eq!(run(18, start, &io).0, Some(100_000.0));
            assert_eq!(run(2, start, &io).0, Some(24.0 * 4096.0));
        }
    }

    #[test]
    fn index_and_current_position_methods() {
        let io = io();
        assert_eq!(run(34, 5000.0, &io).0, Some(8192.0));
        assert_eq!(run(33, 5000.0, &io).0, Some(4096.0));
        assert_eq!(run(34, -5000.0, &io).0, Some(-4096.0));
        assert_eq!(run(35, 777.4, &io), (Some(777.0), 777.4));
        assert_eq!(run(37, -3.0, &io).0, Some(-3.0));
    }

    #[test]
    fn a_switch_that_is_never_found_is_a_homing_error() {
        let no_home = MachineIo {
            home_edge: None,
            ..io()
        };
        // Runs into a limit switch.
        let mut h = HomingRun::start(params(19), 0.0, &no_home);
        let mut p = 0.0;
        for _ in 0..100_000 {
            if h.finished() {
                break;
            }
            p += h.step(p, 0.001, &no_home);
        }
        assert_eq!(h.status(), HomingStatus::Error);
        assert!((100_000.0..110_000.0).contains(&p), "{p}");
        // No switches at all: gives up after the search limit.
        let bare = MachineIo {
            search_limit: 50_000.0,
            ..MachineIo::default()
        };
        assert_eq!(run(19, 0.0, &bare).0, None);
        assert_eq!(run(17, 0.0, &bare).0, None);
        assert_eq!(run(34, 0.0, &bare).0, None);
    }

    #[test]
    fn inputs_and_inversion() {
        let io = io();
        assert_eq!(io.inputs(0.0), 0);
        assert_eq!(io.inputs(20_000.0), o::INPUT_HOME_SWITCH);
        assert_eq!(io.inputs(-100_000.0), 0, "on the edge: off");
        assert_eq!(io.inputs(-100_000.5), o::INPUT_NEGATIVE_LIMIT);
        assert_eq!(
            io.inputs(100_001.0),
            o::INPUT_POSITIVE_LIMIT | o::INPUT_HOME_SWITCH
        );
        let inv = io.inverted(true);
        // Motor at +100001 is drive position -100001: the drive's negative limit.
        assert_eq!(
            inv.inputs(-100_001.0),
            o::INPUT_NEGATIVE_LIMIT | o::INPUT_HOME_SWITCH
        );
        assert_eq!(inv.inputs(-20_000.0), o::INPUT_HOME_SWITCH);
        assert_eq!(inv.inputs(20_000.0), 0);
    }
}
