//! The canonical layer: what the interpreter decided a program does, before anything is
//! turned into machine coordinates. Each [`CanonOp`] is one operation in work coordinates
//! (moves, rigid taps, canned cycles with their holes, spindle, tool, coolant, stops) with its
//! source and the modal state it ran under, so that a later stage (lowering to motion
//! segments, a post-processor, a verification view) can still see "G84 at these holes".

use std::sync::Arc;

use cnc402_motion::segment::{
    AxisPos, MAX_AXES, Plane, SegmentEnd, SegmentKind, Source, SpindleDir,
};

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
    /// G64: continuous path within `tolerance` mm of the programmed corner; feed lines within
    /// `collinear` mm of one straight line may run as that line (LinuxCNC's Q; 0 = never).
    Continuous { tolerance: f64, collinear: f64 },
}

impl PathMode {
    /// How a path segment programmed in this mode ends.
    pub fn segment_end(self) -> SegmentEnd {
        match self {
            PathMode::ExactStop | PathMode::Tapping => SegmentEnd::ExactStop,
            PathMode::Continuous {
                tolerance,
                collinear,
            } => SegmentEnd::Continuous {
                tolerance,
                collinear,
            },
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
    /// Cutter radius compensation (G41/G42 with its D), `None` in G40.
    pub comp: Option<CutterComp>,
}

/// Which side of the programmed contour the tool runs on, looking along the motion with the
/// plane's normal towards the viewer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompSide {
    /// G41
    Left,
    /// G42
    Right,
}

/// Active cutter radius compensation: side, D number and the radius (geometry + wear of D,
/// taken when G41/G42 ran, as Fanuc takes the tool length at H).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutterComp {
    pub side: CompSide,
    pub d: u32,
    pub radius: f64,
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

    /// An X Y Z point (arc centres) shifted by `sign` × the offset, given the machine's axis
    /// indices of X, Y and Z (+1: work → machine, −1: machine → work).
    fn xyz_shift(&self, p: [f64; 3], xyz: [Option<usize>; 3], sign: f64) -> [f64; 3] {
        let mut m = p;
        for (k, i) in xyz.into_iter().enumerate() {
            if let Some(i) = i {
                m[k] = p[k] + sign * self.offset.0[i];
            }
        }
        m
    }

    /// `kind` with its positions (end, arc centre) moved from work to machine coordinates
    /// (`to_machine: true`) or back.
    pub fn convert(
        &self,
        mut kind: SegmentKind,
        xyz: [Option<usize>; 3],
        to_machine: bool,
    ) -> SegmentKind {
        self.convert_in_place(&mut kind, xyz, to_machine);
        kind
    }

    /// [`convert`](Self::convert) where `kind` lies (lowering: the kind is not moved in and
    /// out). The same sums as [`to_machine`](Self::to_machine) and
    /// [`to_work`](Self::to_work).
    pub fn convert_in_place(
        &self,
        kind: &mut SegmentKind,
        xyz: [Option<usize>; 3],
        to_machine: bool,
    ) {
        let pos = |p: &mut AxisPos| {
            for i in 0..MAX_AXES {
                if to_machine {
                    p.0[i] += self.offset.0[i];
                } else {
                    p.0[i] -= self.offset.0[i];
                }
            }
        };
        let sign = if to_machine { 1.0 } else { -1.0 };
        match kind {
            SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. } => pos(end),
            SegmentKind::Tap(t) => pos(&mut t.end),
            SegmentKind::Arc { end, center, .. } => {
                pos(end);
                *center = self.xyz_shift(*center, xyz, sign);
            }
            _ => {}
        }
    }
}

/// What an operation does. Positions are work coordinates of every configured axis
/// (mm / degrees; C, the spindle axis, is the program's view).
#[derive(Clone, Debug, PartialEq)]
pub enum CanonKind {
    /// An operation that is one motion segment: rapid (G0), linear (G1), arc or helix
    /// (G2/G3, centre X Y Z in work coordinates), rigid-tap stroke (`Tap`: a programmed
    /// coupled move of the tool axis with the spindle axis, `G1 Z.. C..` as the source-000
    /// cycles write it), dwell, spindle, orientation, tool change, coolant, program stop,
    /// message. The same kinds as [`SegmentKind`], so nothing is lost or renamed on the way
    /// down; only the positions differ (work here, machine there).
    Single(SegmentKind),
    /// A canned cycle block (G73–G89) that drilled: its kind, words and holes. Lowering
    /// expands it into positioning, feed, tap, dwell and spindle segments.
    CannedCycle(Box<CannedCycle>),
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
    /// The number of the cycle's spindle (the selected one): its axis is `TapPlan::spindle`.
    pub spindle: u8,
    /// The spindle as the block found it: restored after taps, G86, G88, G76, G87.
    pub spindle_turning: bool,
    pub speed: f64,
    pub spindle_dir: SpindleDir,
    /// LinuxCNC's cycle (the `linuxcnc` dialect); `None`: Fanuc's.
    pub linuxcnc: Option<LinuxCncCycle>,
}

/// How LinuxCNC's canned cycle starts: on the series' first block a tool below R first goes
/// straight to R; every hole is positioned with one rapid to its XY at the higher of the
/// level LinuxCNC takes the tool to be at and the return level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinuxCncCycle {
    /// The block starts the series.
    pub first: bool,
    /// Where LinuxCNC takes the tool to be along the drilling axis (work coordinates): the
    /// current level on the first block, else the last block's return level.
    pub level: f64,
}

/// Whether `ops`, run from machine position `from`, make real motion: a move that changes a
/// position (by more than 1e-9), an arc, a canned cycle, or a dwell longer than 0. The one
/// rule for what resets the runaway guard (G-code blocks and the C-like program's requests
/// alike): messages, zero dwells and zero-length moves are not motion, so a loop of them
/// ends as a runaway instead of spinning forever.
pub fn makes_motion<'a>(ops: impl IntoIterator<Item = &'a CanonOp>, from: &AxisPos) -> bool {
    let mut pos = *from;
    for op in ops {
        let end = match &op.kind {
            CanonKind::CannedCycle(_) => return true,
            CanonKind::Single(k) => match k {
                SegmentKind::Arc { .. } => return true,
                SegmentKind::Dwell { seconds } if *seconds > 0.0 => return true,
                _ => match k.line_end() {
                    Some(end) => end,
                    None => continue,
                },
            },
        };
        let end = op.state.to_machine(end);
        if end
            .0
            .iter()
            .zip(pos.0.iter())
            .any(|(a, b)| (a - b).abs() > 1e-9)
        {
            return true;
        }
        pos = end;
    }
    false
}
