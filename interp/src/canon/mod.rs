//! The canonical layer: what the interpreter decided a program does, before anything is
//! turned into machine coordinates. Each [`CanonOp`] is one operation in work coordinates
//! (moves, rigid taps, canned cycles with their holes, spindle, tool, coolant, stops) with its
//! source and the modal state it ran under, so that a later stage (lowering to motion
//! segments, a post-processor, a verification view) can still see "G84 at these holes".

use std::sync::Arc;

use cnc402_motion::segment::{
    ArcDir, AxisPos, MAX_AXES, Plane, SegmentEnd, Source, SpindleDir, StopKind,
};

pub mod json;

/// One canonical operation: what, from where, under which state.
#[derive(Clone, Debug, PartialEq)]
pub struct CanonOp {
    pub kind: CanonKind,
    pub source: Source,
    pub state: Arc<CanonState>,
}

/// Program units as written (positions in canonical operations are always mm / degrees).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgramUnits {
    /// G21
    Mm,
    /// G20
    Inch,
}

/// How F is read (group 05).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FeedMode {
    /// G94: mm/min.
    PerMinute,
    /// G95: mm per spindle revolution (feeds in canonical moves are already mm/min).
    PerRevolution,
}

/// Group 15: how path segments meet, as programmed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PathMode {
    /// G61: every segment ends in an exact stop.
    ExactStop,
    /// G63: tapping mode (exact stop, overrides ignored).
    Tapping,
    /// G64: continuous path within `tolerance` mm of the programmed corner.
    Continuous { tolerance: f64 },
}

impl PathMode {
    /// How a path segment programmed in this mode ends.
    pub fn segment_end(self) -> SegmentEnd {
        match self {
            PathMode::ExactStop | PathMode::Tapping => SegmentEnd::ExactStop,
            PathMode::Continuous { tolerance } => SegmentEnd::Continuous { tolerance },
        }
    }

    /// The G code (61, 63, 64).
    pub fn code(self) -> u32 {
        match self {
            PathMode::ExactStop => 61,
            PathMode::Tapping => 63,
            PathMode::Continuous { .. } => 64,
        }
    }
}

/// The modal state an operation ran under. Shared (`Arc`) by consecutive operations that ran
/// under the same state, so a long program does not copy it per move.
#[derive(Clone, Debug, PartialEq)]
pub struct CanonState {
    pub plane: Plane,
    pub units: ProgramUnits,
    pub feed_mode: FeedMode,
    pub path_mode: PathMode,
    /// The active work coordinate system: 0..=5 for G54..G59.
    pub work_offset: usize,
    /// Work → machine, per axis (index as in the config's axis list): the work zero (G54–G59
    /// plus the G92 shift) plus, on the tool axis, the tool length offset vector that the
    /// position carries. `machine = work + offset`.
    pub offset: AxisPos,
    /// The tool in the spindle (after the last M6), if any.
    pub tool: Option<u32>,
    /// Group 08: 43, 44 or 49.
    pub tool_length_mode: u32,
    /// The H number last programmed (0: none).
    pub h: u32,
    /// The tool length offset vector along the tool axis, mm (0 in G49).
    pub tool_length: f64,
    /// The tool axis (type A: Z), if the machine has one.
    pub tool_axis: Option<usize>,
}

impl CanonState {
    /// Machine coordinates of a work position (the one conversion; lowering uses it).
    pub fn to_machine(&self, work: &AxisPos) -> AxisPos {
        let mut m = *work;
        for i in 0..MAX_AXES {
            m.0[i] = work.0[i] + self.offset.0[i];
        }
        m
    }

    /// Work coordinates of a machine position.
    pub fn to_work(&self, machine: &AxisPos) -> AxisPos {
        let mut w = *machine;
        for i in 0..MAX_AXES {
            w.0[i] = machine.0[i] - self.offset.0[i];
        }
        w
    }

    /// An X Y Z point (arc centres) in machine coordinates, given the machine's axis
    /// indices of X, Y and Z.
    pub fn xyz_to_machine(&self, p: [f64; 3], xyz: [Option<usize>; 3]) -> [f64; 3] {
        let mut m = p;
        for (k, i) in xyz.into_iter().enumerate() {
            if let Some(i) = i {
                m[k] = p[k] + self.offset.0[i];
            }
        }
        m
    }

    /// An X Y Z machine point in work coordinates.
    pub fn xyz_to_work(&self, p: [f64; 3], xyz: [Option<usize>; 3]) -> [f64; 3] {
        let mut w = p;
        for (k, i) in xyz.into_iter().enumerate() {
            if let Some(i) = i {
                w[k] = p[k] - self.offset.0[i];
            }
        }
        w
    }
}

/// What an operation does. Positions are work coordinates of every configured axis
/// (mm / degrees; C, the spindle axis, is the program's view).
#[derive(Clone, Debug, PartialEq)]
pub enum CanonKind {
    /// G0.
    Rapid { end: AxisPos },
    /// G1 (feed in mm/min over the linear axes that move).
    Linear { end: AxisPos, feed: f64 },
    /// G2/G3 with an optional helical part; `center` is X Y Z in work coordinates.
    Arc {
        end: AxisPos,
        center: [f64; 3],
        plane: Plane,
        dir: ArcDir,
        turns: u32,
        feed: f64,
    },
    /// A programmed coupled move of the tool axis with the spindle axis in position mode
    /// (the C-like language's `G1 Z.. C..` of source 000): one rigid-tap stroke.
    RigidTap(RigidTapStroke),
    /// A canned cycle block (G73–G89) that drilled: its kind, words and holes. Lowering
    /// expands it into positioning, feed, tap, dwell and spindle segments.
    CannedCycle(Box<CannedCycle>),
    /// G4 (seconds).
    Dwell { seconds: f64 },
    /// M3/M4/M5 with S.
    Spindle { rpm: f64, dir: SpindleDir },
    /// M19, G28/G30 C: see `SegmentKind::SpindleOrient`.
    SpindleOrient { angle: f64, program: Option<f64> },
    /// T with M6.
    ToolChange { tool: u32 },
    /// M7/M8/M9.
    Coolant { mist: bool, flood: bool },
    /// M0/M1/M2/M30.
    ProgramStop { kind: StopKind },
    /// An operator message.
    Message { text: String },
}

/// One rigid-tap stroke: the tool axis and the spindle axis move together, one spindle turn
/// per `pitch` mm of tool-axis travel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidTapStroke {
    pub end: AxisPos,
    /// mm/min along the tool axis.
    pub feed: f64,
    /// Axis indices.
    pub tool: u8,
    pub spindle: u8,
    /// Signed mm of tool-axis travel per spindle revolution: Δtool = pitch · Δspindle / 360.
    pub pitch: f64,
}

/// A canned cycle (group 09) as Fanuc keeps it, resolved to levels along the drilling axis.
#[derive(Clone, Debug, PartialEq)]
pub struct CannedCycle {
    /// 73, 74, 76, 81…89.
    pub code: u32,
    /// The words the cycle ran with (modal cycle data, mm as programmed: work coordinates in
    /// G90, distances in G91).
    pub words: CycleWords,
    /// Axis indices: the plane's first and second axis, and the drilling axis.
    pub axes: [usize; 3],
    /// Where the block starts (work coordinates).
    pub start: AxisPos,
    /// The hole positions along the plane's first and second axis (work coordinates), one
    /// per repeat.
    pub holes: Vec<[f64; 2]>,
    /// Drilling-axis levels (work coordinates): initial, R, bottom, and where each hole ends
    /// (R in G99, initial in G98; G87 always initial).
    pub initial_level: f64,
    pub r_level: f64,
    pub bottom: f64,
    pub return_level: f64,
    /// Feed of the drilling moves, mm/min.
    pub feed: f64,
    /// The rigid tap of G74/G84.
    pub tap: Option<TapPlan>,
    /// What the expansion needs from the machine and the modal state.
    pub plan: CyclePlan,
}

/// The cycle's words as programmed (mm, seconds; `None`: not set).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CycleWords {
    pub r: Option<f64>,
    pub z: Option<f64>,
    pub q: Option<f64>,
    /// Dwell at the bottom, seconds.
    pub p: Option<f64>,
    /// F as programmed (mm/min in G94, mm/rev in G95).
    pub f: f64,
    /// The repeat count (K or L).
    pub repeats: u32,
    /// G91.
    pub incremental: bool,
    /// G99 (true) / G98.
    pub return_to_r: bool,
}

/// A rigid tap's plan: pitch, direction and how it pecks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TapPlan {
    /// The spindle axis index.
    pub spindle: usize,
    /// mm per revolution (> 0).
    pub pitch: f64,
    /// M3 for G84 (right-hand), M4 for G74 (left-hand).
    pub dir: SpindleDir,
    /// Peck depth (Q), if pecking.
    pub peck: Option<f64>,
    /// How far each peck backs out (`interp.tap_peck_retract`).
    pub peck_retract: f64,
}

/// Values the expansion of a cycle takes from the config and the spindle state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CyclePlan {
    /// G73 retract, G83 re-entry clearance (`interp.peck_retract`, `interp.peck_clearance`).
    pub peck_retract: f64,
    pub peck_clearance: f64,
    /// G76/G87 orientation angle, when the machine has a spindle axis.
    pub orient_angle: Option<f64>,
    /// The spindle as the block found it: restored after taps, G86, G88, G76, G87.
    pub spindle_turning: bool,
    pub speed: f64,
    pub spindle_dir: SpindleDir,
}

impl CanonKind {
    /// The name `cnc402 canon` prints.
    pub fn name(&self) -> &'static str {
        match self {
            CanonKind::Rapid { .. } => "rapid",
            CanonKind::Linear { .. } => "linear",
            CanonKind::Arc { .. } => "arc",
            CanonKind::RigidTap(_) => "rigid_tap",
            CanonKind::CannedCycle(_) => "canned_cycle",
            CanonKind::Dwell { .. } => "dwell",
            CanonKind::Spindle { .. } => "spindle",
            CanonKind::SpindleOrient { .. } => "spindle_orient",
            CanonKind::ToolChange { .. } => "tool_change",
            CanonKind::Coolant { .. } => "coolant",
            CanonKind::ProgramStop { .. } => "program_stop",
            CanonKind::Message { .. } => "message",
        }
    }

    /// Whether this operation moves an axis or waits (what resets the runaway counter).
    pub fn is_motion(&self) -> bool {
        matches!(
            self,
            CanonKind::Rapid { .. }
                | CanonKind::Linear { .. }
                | CanonKind::Arc { .. }
                | CanonKind::RigidTap(_)
                | CanonKind::CannedCycle(_)
                | CanonKind::Dwell { .. }
        )
    }
}
