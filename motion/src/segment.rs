//! `Segment`: the one type between the interpreter and motion. A segment says where every
//! configured axis must end up and how to get there (a rigid tap is its own kind, carrying its
//! coupling), how it ends (exact stop or continuous), plus the events that must be sequenced
//! with motion (dwell, spindle, spindle orientation, tool change, coolant, stop, message).
//! Positions are absolute machine coordinates in each axis's unit (mm, degrees), indexed like
//! `MachineConfig::axes`. Also the one path-length definition ([`path_length`]).

use std::sync::Arc;

pub use cnc402_config::MAX_AXES;
use cnc402_config::{AxisKind, MachineConfig};

/// Absolute machine position of every configured axis (index = position in the config's axis
/// list); entries past the configured count are 0 and ignored.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AxisPos(pub [f64; MAX_AXES]);

impl std::ops::Index<usize> for AxisPos {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        &self.0[i]
    }
}
impl std::ops::IndexMut<usize> for AxisPos {
    fn index_mut(&mut self, i: usize) -> &mut f64 {
        &mut self.0[i]
    }
}

/// Where a segment came from, for every message that must name a program location.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Source {
    pub file: Arc<str>,
    /// 1-based line number.
    pub line: u32,
    /// The block's N number, if it had one.
    pub n: Option<u32>,
}

/// The working plane of an arc: the two axes it turns in and the axis normal to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    /// G17: X-Y, normal Z.
    XY,
    /// G18: Z-X, normal Y.
    ZX,
    /// G19: Y-Z, normal X.
    YZ,
}

impl Plane {
    /// The plane's axis letters: (first, second, normal), e.g. `XY` → `('X', 'Y', 'Z')`. The
    /// first and second follow the right-handed order (G18 is Z then X), so CCW is positive.
    pub fn letters(self) -> (char, char, char) {
        match self {
            Plane::XY => ('X', 'Y', 'Z'),
            Plane::ZX => ('Z', 'X', 'Y'),
            Plane::YZ => ('Y', 'Z', 'X'),
        }
    }

    /// An arc centre given as X Y Z (like `SegmentKind::Arc::center`) in this plane's
    /// (first, second) coordinates.
    pub fn center_in_plane(self, center: [f64; 3]) -> [f64; 2] {
        match self {
            Plane::XY => [center[0], center[1]],
            Plane::ZX => [center[2], center[0]],
            Plane::YZ => [center[1], center[2]],
        }
    }
}

/// The angle (radians, > 0) an arc sweeps from `start` to `end` around `center`, all in the
/// plane's (first, second) coordinates, turning `dir` with `turns` extra full turns. End on
/// start (to 1e-9 of arc length) is a whole turn: `turns = 0` gives one full circle (as G2/G3
/// with I/J program it), `turns = 1` also one, `turns = n` n turns. The one definition the
/// planner and the interpreter's path length share.
///
/// ```
/// use cnc402_motion::segment::{ArcDir, arc_sweep};
/// use std::f64::consts::{FRAC_PI_2, TAU};
/// let q = arc_sweep([1.0, 0.0], [0.0, 1.0], [0.0, 0.0], ArcDir::Ccw, 0);
/// assert!((q - FRAC_PI_2).abs() < 1e-12);
/// let full = arc_sweep([1.0, 0.0], [1.0, 0.0], [0.0, 0.0], ArcDir::Cw, 0);
/// assert!((full - TAU).abs() < 1e-12);
/// ```
pub fn arc_sweep(start: [f64; 2], end: [f64; 2], center: [f64; 2], dir: ArcDir, turns: u32) -> f64 {
    use std::f64::consts::TAU;
    let rm = (start[0] - center[0])
        .hypot(start[1] - center[1])
        .max((end[0] - center[0]).hypot(end[1] - center[1]));
    let a0 = (start[1] - center[1]).atan2(start[0] - center[0]);
    let a1 = (end[1] - center[1]).atan2(end[0] - center[0]);
    let mut base = match dir {
        ArcDir::Ccw => (a1 - a0).rem_euclid(TAU),
        ArcDir::Cw => (a0 - a1).rem_euclid(TAU),
    };
    // End on start (to rounding) is a whole turn, not 2π − ε plus `turns` more.
    if (TAU - base) * rm < 1e-9 {
        base = 0.0;
    }
    let sweep = base + f64::from(turns) * TAU;
    if sweep * rm < 1e-9 {
        // End = start with turns = 0: a full circle.
        base + TAU
    } else {
        sweep
    }
}

/// The in-plane length of an arc (see [`arc_sweep`]): the swept angle times the mean of the
/// start and end radius (they differ by at most the arc tolerance). A helical component is
/// the caller's: `arc_length(..).hypot(h)`.
pub fn arc_length(
    start: [f64; 2],
    end: [f64; 2],
    center: [f64; 2],
    dir: ArcDir,
    turns: u32,
) -> f64 {
    let r0 = (start[0] - center[0]).hypot(start[1] - center[1]);
    let r1 = (end[0] - center[0]).hypot(end[1] - center[1]);
    0.5 * (r0 + r1) * arc_sweep(start, end, center, dir, turns)
}

/// What a path length needs to know of the configured axes: how many there are, which are
/// linear, and their names (an arc finds its plane axes by name).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathAxes {
    n: usize,
    linear: [bool; MAX_AXES],
    names: [char; MAX_AXES],
}

impl PathAxes {
    /// The axes of `cfg` (at most [`MAX_AXES`]).
    pub fn new(cfg: &MachineConfig) -> PathAxes {
        let mut linear = [false; MAX_AXES];
        let mut names = ['\0'; MAX_AXES];
        let n = cfg.axes.len().min(MAX_AXES);
        for (i, a) in cfg.axes.iter().take(n).enumerate() {
            linear[i] = a.kind == AxisKind::Linear;
            names[i] = a.name;
        }
        PathAxes { n, linear, names }
    }

    /// The index of the axis named `name`.
    pub fn index(&self, name: char) -> Option<usize> {
        self.names[..self.n].iter().position(|&a| a == name)
    }

    /// Squared straight-line distance from `a` to `b` over the linear axes, and over the
    /// rotary ones.
    /// (Slices of the configured axes, zipped: no bounds check per axis; inlined into the
    /// interpreter, which sums it per segment.)
    #[inline]
    fn squared_distances(&self, a: &AxisPos, b: &AxisPos) -> (f64, f64) {
        let (mut lin2, mut rot2) = (0.0, 0.0);
        let n = self.n.min(MAX_AXES);
        for ((a, b), &linear) in a.0[..n].iter().zip(&b.0[..n]).zip(&self.linear[..n]) {
            let d = b - a;
            if linear {
                lin2 += d * d;
            } else {
                rot2 += d * d;
            }
        }
        (lin2, rot2)
    }

    /// Straight-line distance from `a` to `b` over the linear axes only (mm): what the report
    /// sums tick by tick, where the spindle turning in speed mode is no path.
    pub fn linear_distance(&self, a: &AxisPos, b: &AxisPos) -> f64 {
        self.squared_distances(a, b).0.sqrt()
    }

    /// The length of a straight move from `a` to `b`: mm over the linear axes that move,
    /// degrees over the rotary axes when only rotary axes move.
    #[inline]
    pub fn line_length(&self, a: &AxisPos, b: &AxisPos) -> f64 {
        let (lin2, rot2) = self.squared_distances(a, b);
        if lin2 > 0.0 { lin2.sqrt() } else { rot2.sqrt() }
    }

    /// The length of an arc or helix from `start` to `end` turning in the plane of axes
    /// `plane_axes` (first, second) around `center` (in those axes): the in-plane
    /// [`arc_length`] combined with the straight travel of every other linear axis.
    pub fn helix_length(
        &self,
        start: &AxisPos,
        end: &AxisPos,
        plane_axes: [usize; 2],
        center: [f64; 2],
        dir: ArcDir,
        turns: u32,
    ) -> f64 {
        let [p, q] = plane_axes;
        let mut h2 = 0.0;
        for i in 0..self.n {
            if self.linear[i] && i != p && i != q {
                let d = end.0[i] - start.0[i];
                h2 += d * d;
            }
        }
        let (s2, e2) = ([start.0[p], start.0[q]], [end.0[p], end.0[q]]);
        arc_length(s2, e2, center, dir, turns).hypot(h2.sqrt())
    }
}

/// The path length of a segment of kind `kind` that starts at `start`, in the planner's path
/// parameter unit: lines and taps as [`PathAxes::line_length`], arcs as
/// [`PathAxes::helix_length`]; 0 for every kind that is no path, and for an arc whose plane
/// axes are not configured (the planner refuses it). The one definition the planner, the
/// interpreter's `@ITPPATH` and the report share.
///
/// ```
/// use cnc402_config::MachineConfig;
/// use cnc402_motion::segment::{AxisPos, PathAxes, SegmentKind, path_length};
/// let axes = PathAxes::new(&MachineConfig::default_machine());
/// let mut end = AxisPos::default();
/// end[0] = 3.0; // X
/// end[1] = 4.0; // Y
/// end[3] = 90.0; // C: rotary, no path while a linear axis moves
/// let l = path_length(&AxisPos::default(), &SegmentKind::Linear { end, feed: 100.0 }, &axes);
/// assert_eq!(l, 5.0);
/// ```
pub fn path_length(start: &AxisPos, kind: &SegmentKind, axes: &PathAxes) -> f64 {
    match kind {
        SegmentKind::Rapid { end }
        | SegmentKind::Linear { end, .. }
        | SegmentKind::Tap(TapSegment { end, .. }) => axes.line_length(start, end),
        SegmentKind::Arc {
            end,
            center,
            plane,
            dir,
            turns,
            ..
        } => {
            let (a, b, _) = plane.letters();
            match (axes.index(a), axes.index(b)) {
                (Some(p), Some(q)) => axes.helix_length(
                    start,
                    end,
                    [p, q],
                    plane.center_in_plane(*center),
                    *dir,
                    *turns,
                ),
                _ => 0.0,
            }
        }
        _ => 0.0,
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArcDir {
    /// G2
    Cw,
    /// G3
    Ccw,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpindleDir {
    /// M3
    Cw,
    /// M4
    Ccw,
    /// M5
    Stop,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopKind {
    /// M0
    Program,
    /// M1
    Optional,
    /// M2
    End,
    /// M30
    EndRewind,
    /// A wait for other channels (Fanuc multi-path `M100…` with `P`, the C-like `wait_mark`):
    /// the channel comes to rest here and goes on once every channel in `channels` (a bit
    /// per channel; 0 = all channels) has reached a `WaitMark` with the same `mark`. A
    /// one-channel machine passes it at once.
    WaitMark { mark: u16, channels: u16 },
}

/// How a segment ends: whether the machine must come to rest exactly on its end point before
/// the next segment starts, or may pass near it. The interpreter stamps it from the path mode
/// (G61/G63: exact stop; G64: continuous) on path segments; taps and every non-path segment
/// end in an exact stop. The [`crate::Lookahead`] blends a junction when the segments on both
/// sides are `Continuous`; [`crate::Planner::plan`] alone stops at every end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SegmentEnd {
    /// Come to rest on the end point (G61, G63, taps, every non-path segment).
    ExactStop,
    /// G64: the path may pass within `tolerance` (mm, > 0) of the end point; runs of feed
    /// lines whose corners lie within `collinear` (mm, LinuxCNC's `G64 Q`; 0 = never) of one
    /// straight line run as that line (see [`crate::collinear`]).
    Continuous { tolerance: f64, collinear: f64 },
}

/// A rigid tap: the tool (drilling) axis and the spindle axis, a position axis here, move
/// together in one straight line at `feed`, one spindle turn per `pitch` of tool travel.
///
/// Sign convention: `pitch` is signed like the coupling ratio, `pitch / 360` = Δtool / Δspindle
/// (mm per degree). A right-hand tap (G84) into a hole below the R level moves the tool down
/// while C counts up, so its pitch is negative; the retract has the same sign (both axes
/// reverse).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TapSegment {
    pub end: AxisPos,
    /// Path speed in mm/min, as [`SegmentKind::Linear`]'s.
    pub feed: f64,
    /// Index of the tool (drilling) axis, a linear axis.
    pub tool: u8,
    /// Index of the spindle axis.
    pub spindle: u8,
    /// mm of tool travel per spindle turn, signed (see the type's doc).
    pub pitch: f64,
}

impl TapSegment {
    /// The coupling this tap holds while it runs.
    pub fn coupling(&self) -> TapCoupling {
        TapCoupling {
            tool: self.tool,
            spindle: self.spindle,
            ratio: self.pitch / 360.0,
        }
    }
}

/// A rigid-tap coupling in force during a move: the `tool` axis moves `ratio` units per unit
/// of the spindle axis `spindle` (degrees). It travels with the planned move and the loop's
/// status records, so nothing downstream guesses it from geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TapCoupling {
    pub tool: u8,
    pub spindle: u8,
    /// Δtool / Δspindle (mm per degree, signed): [`TapSegment::pitch`] / 360.
    pub ratio: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub enum SegmentKind {
    /// G0: the fastest straight line the axes allow.
    Rapid { end: AxisPos },
    /// G1 (and cycle feeds). `feed` is the path speed in units/min over the linear axes that
    /// move; over the rotary axes when only rotary axes move.
    Linear { end: AxisPos, feed: f64 },
    /// A rigid tap (G74/G84 moves, and a feed move of a linear axis with the spindle axis):
    /// planned and timed like `Linear`, with the coupling carried along.
    Tap(TapSegment),
    /// G2/G3, with an optional helical component along the plane's normal (and any other axis
    /// moving linearly with it). `center` is in machine coordinates, X Y Z. `turns` counts
    /// extra full turns (0 = less than one turn; a full circle is `turns = 1` with end = start).
    Arc {
        end: AxisPos,
        center: [f64; 3],
        plane: Plane,
        dir: ArcDir,
        turns: u32,
        feed: f64,
    },
    /// G4, and the P dwell of cycles.
    Dwell { seconds: f64 },
    /// M3/M4/M5 with S: the axis of spindle number `spindle` (1 = the program's default;
    /// Fanuc `P`, LinuxCNC `$` select another) runs in speed mode. `rpm` ≥ 0.
    Spindle {
        rpm: f64,
        dir: SpindleDir,
        spindle: u8,
    },
    /// Spindle orientation (G76/G87 before the shift; M19) of spindle number `spindle`
    /// (see `Spindle`), its own axis standing for "the spindle axis" and "C" below: with the
    /// spindle at rest, a
    /// jerk-limited position move of the spindle axis the shorter way round to the nearest
    /// physical angle ≡ `angle` (degrees, 0 ≤ angle < 360) mod 360. Physical means machine C,
    /// i.e. program C plus the spindle offset that speed-mode runs leave (see the crate doc):
    /// the interpreter cannot know it. With `program: None` (M19, G76/G87) the move turns the
    /// spindle without changing program C (the turn goes into the offset, like a speed-mode
    /// run), so later C moves still turn by exactly their programmed difference. With
    /// `program: Some(c)` (G28/G30 C: the axis reads its reference position afterwards, as on
    /// Fanuc) program C becomes `c`, which must be ≡ `angle` (mod 360): afterwards the
    /// physical angle ≡ program C, so a later absolute C move lands on its angle.
    SpindleOrient {
        angle: f64,
        program: Option<f64>,
        spindle: u8,
    },
    /// T with M6.
    ToolChange { tool: u32 },
    /// M7 (mist on), M8 (flood on), M9 (both off): the coolant state from here on.
    Coolant { mist: bool, flood: bool },
    /// M0/M1/M2/M30.
    Stop { kind: StopKind },
    /// A message for the operator (MSG, `(MSG, …)`).
    Message { text: String },
}

impl SegmentKind {
    /// Moves along a path (rapid, linear, arc, tap), the kinds a path mode applies to.
    pub fn is_path(&self) -> bool {
        matches!(
            self,
            SegmentKind::Rapid { .. }
                | SegmentKind::Linear { .. }
                | SegmentKind::Tap(_)
                | SegmentKind::Arc { .. }
        )
    }

    /// A feed move from `from` to `end` that couples axis `tool` with axis `spindle` at
    /// `pitch`: a `Tap` when both move, else a plain `Linear` (a move that turns no spindle
    /// or feeds no tool couples nothing). The one rule for programmed and canned taps.
    pub fn tap_or_feed(
        from: &AxisPos,
        end: AxisPos,
        feed: f64,
        (tool, spindle): (usize, usize),
        pitch: f64,
    ) -> SegmentKind {
        if end[tool] == from[tool] || end[spindle] == from[spindle] {
            SegmentKind::Linear { end, feed }
        } else {
            SegmentKind::Tap(TapSegment {
                end,
                feed,
                tool: tool as u8,
                spindle: spindle as u8,
                pitch,
            })
        }
    }

    /// Where a straight move (rapid, linear, tap) ends; `None` for arcs and events.
    pub fn line_end(&self) -> Option<&AxisPos> {
        match self {
            SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. } => Some(end),
            SegmentKind::Tap(t) => Some(&t.end),
            _ => None,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    pub kind: SegmentKind,
    pub source: Source,
    /// How the segment ends (see [`SegmentEnd`]).
    pub ends: SegmentEnd,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI, TAU};

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn arc_sweep_direction_turns_and_end_on_start() {
        let (s, e, c) = ([1.0, 0.0], [0.0, 1.0], [0.0, 0.0]);
        assert!(close(arc_sweep(s, e, c, ArcDir::Ccw, 0), FRAC_PI_2));
        assert!(close(arc_sweep(s, e, c, ArcDir::Cw, 0), 3.0 * FRAC_PI_2));
        assert!(close(
            arc_sweep(s, e, c, ArcDir::Ccw, 2),
            FRAC_PI_2 + 2.0 * TAU
        ));
        // End on start: turns 0 and 1 are one circle, 3 is three.
        for (turns, want) in [(0, TAU), (1, TAU), (3, 3.0 * TAU)] {
            assert!(close(arc_sweep(s, s, c, ArcDir::Cw, turns), want));
        }
        // End a rounding error short of start is still a whole turn, not 2π − ε + 2π.
        let e = [(1e-13f64).cos(), (-1e-13f64).sin()];
        assert!(close(arc_sweep(s, e, c, ArcDir::Ccw, 1), TAU));
        // Half circle, radius 2, off-origin centre.
        let l = arc_length([3.0, 1.0], [-1.0, 1.0], [1.0, 1.0], ArcDir::Ccw, 0);
        assert!(close(l, 2.0 * PI));
    }

    #[test]
    fn plane_letters_and_center_agree() {
        let c = [1.0, 2.0, 3.0];
        for p in [Plane::XY, Plane::ZX, Plane::YZ] {
            let (a, b, _) = p.letters();
            let at = |l: char| c[(l as u8 - b'X') as usize];
            assert_eq!(p.center_in_plane(c), [at(a), at(b)]);
        }
    }
}
