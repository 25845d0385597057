//! The interpreter's modal state: every G group, F, S, T, the spindle, the canned-cycle data
//! Fanuc keeps between blocks, and the programmed position in machine coordinates. Later issues
//! read it for the Macro B system variables (`#4001…`, `#5001…`). It also holds the run's
//! copies of the tables a program may change (work offsets, tool offsets, the G92 shift), so
//! that a change lasts for the run and the next run starts from the config again.

use cnc402_config::{
    MAX_AXES, MAX_SPINDLES, MachineConfig, PlaneDefault, ReturnPlane, ToolOffset, Units,
};
use cnc402_lang::ast::Span;
use cnc402_motion::segment::{AxisPos, Plane, Source, SpindleDir};

use crate::canon::{CanonState, CutterComp, FeedMode, PathMode, ProgramUnits};

/// Group 08: tool length compensation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToolLength {
    /// G49
    Off,
    /// G43: the H offset is added along the tool axis.
    Plus,
    /// G44: the H offset is subtracted.
    Minus,
}

impl ToolLength {
    pub fn code(self) -> u32 {
        match self {
            ToolLength::Off => 49,
            ToolLength::Plus => 43,
            ToolLength::Minus => 44,
        }
    }
}

/// Group 01 motion mode (what axis words do outside a canned cycle).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    Rapid,
    Linear,
    ArcCw,
    ArcCcw,
}

/// A canned cycle of group 09 (G80 is "none").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cycle {
    G73,
    G74,
    G76,
    G81,
    G82,
    G83,
    G84,
    G85,
    G86,
    G87,
    G88,
    G89,
}

impl Cycle {
    pub fn from_code(code: u32) -> Option<Cycle> {
        Some(match code {
            73 => Cycle::G73,
            74 => Cycle::G74,
            76 => Cycle::G76,
            81 => Cycle::G81,
            82 => Cycle::G82,
            83 => Cycle::G83,
            84 => Cycle::G84,
            85 => Cycle::G85,
            86 => Cycle::G86,
            87 => Cycle::G87,
            88 => Cycle::G88,
            89 => Cycle::G89,
            _ => return None,
        })
    }
    pub fn code(self) -> u32 {
        match self {
            Cycle::G73 => 73,
            Cycle::G74 => 74,
            Cycle::G76 => 76,
            Cycle::G81 => 81,
            Cycle::G82 => 82,
            Cycle::G83 => 83,
            Cycle::G84 => 84,
            Cycle::G85 => 85,
            Cycle::G86 => 86,
            Cycle::G87 => 87,
            Cycle::G88 => 88,
            Cycle::G89 => 89,
        }
    }
}

/// The data Fanuc keeps while a canned cycle stays active (cleared by G80 and group 01 codes).
/// Lengths are in mm as programmed: absolute work values in G90, distances in G91.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CycleData {
    /// R level (G90: work coordinate; G91: distance from the initial level).
    pub r: Option<f64>,
    /// Bottom (G90: work coordinate; G91: distance from the R level).
    pub z: Option<f64>,
    /// Peck depth (G73/G83/peck tapping) or shift amount (G76/G87), mm.
    pub q: Option<f64>,
    /// Dwell, seconds.
    pub p: Option<f64>,
    /// Machine position along the drilling axis when the cycle mode was entered.
    pub initial: f64,
    /// The part of the tool length offset vector that `initial` lacks (after G28/G30/G53
    /// moved Z; 0 otherwise). The drilling moves restore the whole vector, so a G91 R level
    /// is `initial + initial_tlo_pending + R`, as a `G91 Z` move from there would be.
    pub initial_tlo_pending: f64,
    /// LinuxCNC: the machine level the last block of this series returned to, where LinuxCNC
    /// takes the tool to be (after G88 too: the operator took it out); `None` before the
    /// series' first block has drilled.
    pub lc_level: Option<f64>,
    /// LinuxCNC: the machine level the series began at, when the preliminary move made R the
    /// initial level; a G91 R still counts from here, as rs274 counts it.
    pub lc_g91_r_from: Option<f64>,
}

/// What is cut off at a corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CornerCut {
    /// `,R`: an arc of this radius (mm).
    Round(f64),
    /// `,C`: a chamfer this far (mm) from the corner along both moves.
    Chamfer(f64),
}

/// A G1 move held back by its corner word: from `start` to the (virtual) corner `corner`.
#[derive(Clone, Debug, PartialEq)]
pub struct PendingCorner {
    pub cut: CornerCut,
    pub start: AxisPos,
    pub corner: AxisPos,
    pub feed: f64,
    /// The block of the held move (its segments carry it).
    pub source: Source,
    /// The corner word, for errors found at the next block.
    pub word: Span,
    pub file: std::sync::Arc<str>,
    /// The corner block's text when it is a one-line window of a program read line by line
    /// (`word` is a span in it, not in the next block's window).
    pub window: Option<cnc402_lang::SourceFile>,
}

/// Everything modal.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalState {
    pub motion: Motion,
    pub cycle: Option<Cycle>,
    pub cycle_data: CycleData,
    pub plane: Plane,
    /// G20 (true) / G21.
    pub inch: bool,
    /// G91 (true) / G90.
    pub incremental: bool,
    /// G90.1 (true: I/J/K are the centre in work coordinates) / G91.1 (incremental from the
    /// start point, Fanuc's only mode; the default at program start).
    pub arc_center_absolute: bool,
    /// G95 (true) / G94.
    pub feed_per_rev: bool,
    /// 0..=5 for G54..G59.
    pub work_offset: usize,
    /// G99 (true) / G98.
    pub return_to_r: bool,
    /// F in mm/min (G94) or mm/rev (G95), as last programmed.
    pub feed: f64,
    /// S, rpm, of the selected spindle.
    pub speed: f64,
    /// M3/M4/M5 as last programmed for the selected spindle.
    pub spindle: SpindleDir,
    /// The selected spindle's number (Fanuc's modal `P` of an S/M3/M4/M5/M19 block; 1 at
    /// program start): what S, M3/M4/M5, M19, taps and cycles act on.
    pub spindle_sel: u8,
    /// Each spindle's S and M3/M4/M5 by number − 1, while another one is selected (the
    /// selected one's are `speed` and `spindle`).
    pub parked: [(f64, SpindleDir); MAX_SPINDLES],
    /// M29 rigid tapping mode (until G80 or a group 01 code).
    pub rigid: bool,
    /// T as last programmed (selected for the next M6).
    pub tool_selected: u32,
    /// The tool in the spindle after the last M6.
    pub tool_loaded: Option<u32>,
    /// Programmed position, machine coordinates, mm / degrees; C (the spindle) is the program's
    /// view, 0 at program start. On the tool axis it includes `tlo_in_pos`.
    pub pos: AxisPos,
    /// Group 08 (G43/G44/G49).
    pub tool_length: ToolLength,
    /// The H number last programmed (`#4111`); 0 at start.
    pub h: u32,
    /// The tool length offset vector G43/G44 asked for, mm along the tool axis (0 in G49).
    /// Its value is taken when H (or G43/G44) is programmed: a later change of the table
    /// takes effect at the next H, as on Fanuc.
    pub tlo: f64,
    /// The part of the vector that `pos` includes. Equal to `tlo`, except after G28/G30/G53
    /// moved the tool axis: Fanuc cancels the vector there (the tool sits on the machine
    /// position given) and restores it at the tool axis's next programmed move.
    pub tlo_in_pos: f64,
    /// The tool axis (Z, "type A"), if the machine has one.
    pub tool_axis: Option<usize>,
    /// G54..G59 for this run: the config's, changed by `G10 L2` and `#5221…`.
    pub work_offsets: [[f64; MAX_AXES]; 6],
    /// The G92 shift, added to every work coordinate system; 0 at program start.
    pub shift: [f64; MAX_AXES],
    /// Tool offsets 1..=400 for this run (`tool_offsets[n - 1]`): the config's, changed by
    /// `G10 L10–L13` and `#10001…`.
    pub tool_offsets: Vec<ToolOffset>,
    /// The last G28/G30 intermediate point (machine), per axis, for G29.
    pub ref_mid: [Option<f64>; MAX_AXES],
    /// Group 15: 61 (exact stop), 63 (tapping), 64 (cutting; the default unless the config's
    /// `interp.path_mode` says "exact"); G08 P1/P0 set 64/61. Path segments carry it as their
    /// [`SegmentEnd`]; the lookahead blends `Continuous` ends.
    pub path_mode: u32,
    /// G9 in the current block: its motion ends in an exact stop whatever the path mode.
    pub exact_stop_once: bool,
    /// The tolerance of G64 (mm, > 0): its `P` word, else the config's
    /// `interp.path_tolerance`.
    pub path_tolerance: f64,
    /// G64's collinearity tolerance (mm, ≥ 0; LinuxCNC's Q): its `Q` word, else the
    /// config's `interp.collinear_tolerance`.
    pub path_collinear: f64,
    /// A G1 move held back by its `,R`/`,C` corner word until the next block's move.
    pub pending_corner: Option<PendingCorner>,
    /// Machine M codes (`[mcodes]`) whose once-a-run note was given (at most one per
    /// configured code).
    pub noted_mcodes: Vec<u32>,
    /// Coolant: M7 (mist), M8 (flood); M9 turns both off.
    pub mist: bool,
    pub flood: bool,
    /// LinuxCNC: the G91 polar increments of the block being run (`@` radius in program
    /// units, `^` degrees; set by the block translation in `flow/lcblock.rs`): a G17 canned
    /// cycle's repeats each turn and stretch the last hole by them, as LinuxCNC drills a
    /// bolt circle.
    pub polar_step: Option<[f64; 2]>,
    /// Group 07: G41/G42 with D and radius, `None` in G40 (see `block/comp.rs`).
    pub comp: Option<CutterComp>,
    /// The D number last programmed (0: none).
    pub d: u32,
    /// G41/G42 ran and no move in the plane has started the compensation yet.
    pub comp_starting: bool,
}

impl ModalState {
    /// The state at program start: config defaults, G0, G94, G54, G80, spindle stopped.
    pub fn new(cfg: &MachineConfig, start: AxisPos) -> Self {
        ModalState {
            motion: Motion::Rapid,
            cycle: None,
            cycle_data: CycleData::default(),
            polar_step: None,
            plane: match cfg.interp.plane {
                PlaneDefault::XY => Plane::XY,
                PlaneDefault::ZX => Plane::ZX,
                PlaneDefault::YZ => Plane::YZ,
            },
            inch: cfg.interp.units == Units::Inch,
            incremental: false,
            arc_center_absolute: false,
            feed_per_rev: false,
            work_offset: 0,
            return_to_r: cfg.interp.return_plane == ReturnPlane::R,
            feed: 0.0,
            speed: 0.0,
            spindle: SpindleDir::Stop,
            spindle_sel: 1,
            parked: [(0.0, SpindleDir::Stop); MAX_SPINDLES],
            rigid: false,
            tool_selected: 0,
            tool_loaded: None,
            pos: start,
            tool_length: ToolLength::Off,
            h: 0,
            tlo: 0.0,
            tlo_in_pos: 0.0,
            tool_axis: cfg.axis_index('Z'),
            work_offsets: cfg.work_offsets,
            shift: [0.0; MAX_AXES],
            tool_offsets: cfg.tool_offsets.clone(),
            ref_mid: [None; MAX_AXES],
            path_mode: match cfg.interp.path_mode {
                cnc402_config::PathModeDefault::Continuous => 64,
                cnc402_config::PathModeDefault::ExactStop => 61,
            },
            exact_stop_once: false,
            path_tolerance: cfg.interp.path_tolerance,
            path_collinear: cfg.interp.collinear_tolerance,
            pending_corner: None,
            noted_mcodes: Vec::new(),
            mist: false,
            flood: false,
            comp: None,
            d: 0,
            comp_starting: false,
        }
    }

    /// Machine position of the work zero of axis `i`: the active G54–G59 offset plus the G92
    /// shift (what `#5041…` subtracts from the machine position).
    pub fn work_zero(&self, i: usize) -> f64 {
        self.work_offsets[self.work_offset][i] + self.shift[i]
    }

    /// What a programmed absolute coordinate of axis `i` is added to for its machine position:
    /// the work zero plus, on the tool axis, the tool length offset vector.
    pub fn origin(&self, i: usize) -> f64 {
        self.work_zero(i) + self.tlo_of(i)
    }

    /// The tool length offset vector on axis `i` (0 off the tool axis).
    pub fn tlo_of(&self, i: usize) -> f64 {
        if self.tool_axis == Some(i) {
            self.tlo
        } else {
            0.0
        }
    }

    /// The programmed position of axis `i` in work coordinates without the tool length offset
    /// (`#5001…`), mm / degrees.
    pub fn programmed(&self, i: usize) -> f64 {
        let t = if self.tool_axis == Some(i) {
            self.tlo_in_pos
        } else {
            0.0
        };
        self.pos[i] - self.work_zero(i) - t
    }

    /// The state canonical operations carry ([`CanonState`]): modes, the work → machine
    /// offset of every axis as the position carries it, tool and tool length.
    pub fn canon_state(&self) -> CanonState {
        let offset = AxisPos(self.canon_offsets());
        CanonState {
            plane: self.plane,
            units: self.canon_units(),
            feed_mode: self.canon_feed_mode(),
            path_mode: self.canon_path_mode(),
            work_offset: self.work_offset,
            offset,
            tool: self.tool_loaded,
            tool_length_mode: self.tool_length.code(),
            h: self.h,
            tool_length: self.tlo,
            tool_axis: self.tool_axis,
            comp: self.comp,
        }
    }

    /// Whether `self.canon_state() == *s`, field by field as the derived `PartialEq`
    /// compares them, without building the state (asked once per operation).
    pub fn canon_state_is(&self, s: &CanonState) -> bool {
        s.plane == self.plane
            && s.units == self.canon_units()
            && s.feed_mode == self.canon_feed_mode()
            && s.path_mode == self.canon_path_mode()
            && s.work_offset == self.work_offset
            && s.tool == self.tool_loaded
            && s.tool_length_mode == self.tool_length.code()
            && s.h == self.h
            && s.tool_length == self.tlo
            && s.tool_axis == self.tool_axis
            && s.comp == self.comp
            && s.offset.0 == self.canon_offsets()
    }

    /// Work → machine on every axis as operations carry it: the work zero plus the part of
    /// the tool length offset vector that the position includes.
    fn canon_offsets(&self) -> [f64; MAX_AXES] {
        std::array::from_fn(|i| {
            let tlo = if self.tool_axis == Some(i) {
                self.tlo_in_pos
            } else {
                0.0
            };
            self.work_zero(i) + tlo
        })
    }

    fn canon_units(&self) -> ProgramUnits {
        if self.inch {
            ProgramUnits::Inch
        } else {
            ProgramUnits::Mm
        }
    }

    fn canon_feed_mode(&self) -> FeedMode {
        if self.feed_per_rev {
            FeedMode::PerRevolution
        } else {
            FeedMode::PerMinute
        }
    }

    fn canon_path_mode(&self) -> PathMode {
        match self.path_mode {
            _ if self.exact_stop_once => PathMode::ExactStop,
            61 => PathMode::ExactStop,
            63 => PathMode::Tapping,
            _ => PathMode::Continuous {
                tolerance: self.path_tolerance,
                collinear: self.path_collinear,
            },
        }
    }

    /// mm per program length unit.
    pub fn unit(&self) -> f64 {
        if self.inch { 25.4 } else { 1.0 }
    }

    /// The spindle is commanded to turn (M3/M4 with S > 0).
    pub fn spindle_turning(&self) -> bool {
        self.spindle != SpindleDir::Stop && self.speed > 0.0
    }

    /// Spindle `number` is commanded to turn, selected or not.
    pub fn spindle_turning_of(&self, number: u8) -> bool {
        if number == self.spindle_sel {
            return self.spindle_turning();
        }
        let slot = usize::from(number).wrapping_sub(1);
        self.parked
            .get(slot)
            .is_some_and(|&(speed, dir)| dir != SpindleDir::Stop && speed > 0.0)
    }

    /// Makes spindle `number` (1..=[`MAX_SPINDLES`]; another number changes nothing) the
    /// selected one: the selected spindle's S and direction are parked, `number`'s taken up.
    pub fn select_spindle(&mut self, number: u8) {
        let old = usize::from(self.spindle_sel) - 1;
        let Some(new) = usize::from(number).checked_sub(1) else {
            return;
        };
        if old == new || new >= MAX_SPINDLES {
            return;
        }
        self.parked[old] = (self.speed, self.spindle);
        (self.speed, self.spindle) = self.parked[new];
        self.spindle_sel = number;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A state with every field `CanonState` reads set from `v` (small values, repeats
    /// likely, so that equal and unequal pairs both occur; NaN included).
    fn state(v: &[u8]) -> ModalState {
        let cfg = MachineConfig::default_machine();
        let mut st = ModalState::new(&cfg, AxisPos::default());
        let f = |b: u8| match b % 6 {
            4 => f64::NAN,
            5 => -0.0,
            k => f64::from(k) - 1.0,
        };
        st.plane = [Plane::XY, Plane::ZX, Plane::YZ][v[0] as usize % 3];
        st.inch = v[1] % 2 == 1;
        st.feed_per_rev = v[2] % 2 == 1;
        st.path_mode = [61, 63, 64][v[3] as usize % 3];
        st.exact_stop_once = v[4] % 2 == 1;
        st.path_tolerance = f(v[5]);
        st.path_collinear = f(v[6]);
        st.work_offset = v[7] as usize % 2;
        st.work_offsets[1][v[8] as usize % MAX_AXES] = f(v[9]);
        st.shift[v[10] as usize % MAX_AXES] = f(v[11]);
        st.tool_loaded = (!v[12].is_multiple_of(3)).then_some(u32::from(v[12] % 3));
        st.tool_length = [ToolLength::Off, ToolLength::Plus, ToolLength::Minus][v[13] as usize % 3];
        st.h = u32::from(v[14] % 2);
        st.tlo = f(v[15]);
        st.tlo_in_pos = f(v[16]);
        st.tool_axis = (!v[17].is_multiple_of(3)).then_some(v[17] as usize % 3);
        st.comp = (!v[18].is_multiple_of(3)).then_some(CutterComp {
            side: if v[18] % 3 == 1 {
                crate::canon::CompSide::Left
            } else {
                crate::canon::CompSide::Right
            },
            d: u32::from(v[19] % 2),
            radius: f(v[20]),
        });
        st
    }

    proptest! {
        /// The comparison that decides whether an operation shares the last one's state
        /// answers as building the state and comparing it would: every modal value the
        /// state holds, changed, makes a new state.
        #[test]
        fn canon_state_is_answers_as_building_it_would(
            a in proptest::collection::vec(0u8..12, 21),
            changed in 0usize..21,
            to in 0u8..12,
        ) {
            // Two states that differ (if at all) in one value.
            let mut b = a.clone();
            b[changed] = to;
            let (sa, sb) = (state(&a), state(&b));
            let built = sb.canon_state();
            prop_assert_eq!(sa.canon_state_is(&built), sa.canon_state() == built);
            prop_assert_eq!(sb.canon_state_is(&built), built == built.clone());
        }
    }
}
