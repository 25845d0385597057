//! The block layer's state as the interpreter holds it ([`Machine`]): the configuration, the
//! operator switches, the modal state, the motion sync and the path length handed out. It runs
//! blocks ([`Exec`]) and answers the system variables that read or change this state.

use cnc402_config::MachineConfig;
use cnc402_lang::Dialect;
use cnc402_lang::ast::Line;
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::{
    AxisPos, PathAxes, Plane, Segment, SegmentKind, Source, TapSegment, path_length,
};

use std::collections::VecDeque;
use std::sync::Arc;

use super::exec::{AxisMap, Exec};
use super::options::Options;
use super::state::{ModalState, Motion};
use super::words::Words;
use crate::canon::{CanonOp, CanonState};
use crate::host::{ExactStop, MotionSync};
use crate::vars::{MVal, VarClass};

/// Block execution state: what every block runs against.
pub struct Machine {
    pub(crate) cfg: MachineConfig,
    pub(crate) map: AxisMap,
    pub(crate) opts: Options,
    pub(crate) state: ModalState,
    pub(crate) sync: Box<dyn MotionSync>,
    /// Length of every segment handed out so far (mm), and where the last one ended.
    pub(crate) path_len: f64,
    pub(crate) path_end: AxisPos,
    /// The configured axes as path lengths need them (read once: `cfg` does not change).
    path_axes: PathAxes,
    /// The state of the last canonical operation (shared by the next while unchanged).
    pub(crate) canon: Option<Arc<CanonState>>,
    /// `canon` is the canonical state of `state` as the plain-block lane left it, nothing
    /// else having run since (see `super::plain`): the lane's next block shares it without
    /// comparing.
    pub(crate) lane_canon: bool,
    /// The dialect of the running main program (sub-programs without a header of their own
    /// are read in it).
    pub(crate) dialect: Dialect,
}

/// The modal state a program starts in: `opts.start`, and `opts.default_spindle` selected
/// when the machine has it.
fn start_state(cfg: &MachineConfig, opts: &Options) -> ModalState {
    let mut st = ModalState::new(cfg, opts.start);
    if cfg.spindle_axis(opts.default_spindle).is_some() {
        st.select_spindle(opts.default_spindle);
    }
    st
}

impl Machine {
    /// The machine `cfg` at the start of a program, exact-stop sync.
    pub(crate) fn new(cfg: &MachineConfig, opts: Options) -> Machine {
        Machine {
            state: start_state(cfg, &opts),
            cfg: cfg.clone(),
            map: AxisMap::new(cfg),
            sync: Box::new(ExactStop),
            path_len: 0.0,
            path_end: opts.start,
            path_axes: PathAxes::new(cfg),
            canon: None,
            lane_canon: false,
            dialect: cfg.interp.dialect,
            opts,
        }
    }

    /// A fresh start for the next program: modal state and path length (the sync stays).
    pub(crate) fn reset(&mut self) {
        self.state = start_state(&self.cfg, &self.opts);
        self.path_len = 0.0;
        self.path_end = self.opts.start;
        self.canon = None;
        self.lane_canon = false;
    }

    /// The canonical operation of one segment of `kind` (machine positions) from `source`,
    /// made outside a block's execution (`#3006`'s message and stop).
    pub(crate) fn single_op(&mut self, kind: SegmentKind, source: Source) -> CanonOp {
        super::exec::single_op(self.map.xyz, &self.state, &mut self.canon, kind, source)
    }

    /// Runs one block of `line` with its words collected (its operations gathered in `out`, a
    /// spare vector emptied first): its operations, and whether it ended
    /// the program (M2/M30).
    pub(crate) fn execute(
        &mut self,
        src: &SourceFile,
        words: &mut Words,
        line: &Line,
        out: Vec<CanonOp>,
    ) -> Result<(Vec<CanonOp>, bool), NcError> {
        let mut ops = VecDeque::from(out);
        ops.clear();
        let end = self.execute_into(src, words, line, &mut ops)?;
        Ok((Vec::from(ops), end))
    }

    /// [`execute`](Self::execute) with the block's operations appended to `out` (none on an
    /// error): the interpreter's queue, so that they are not moved into it.
    pub(crate) fn execute_into(
        &mut self,
        src: &SourceFile,
        words: &mut Words,
        line: &Line,
        out: &mut VecDeque<CanonOp>,
    ) -> Result<bool, NcError> {
        Exec::execute(
            (&self.cfg, &self.map),
            &self.opts,
            (src, self.dialect),
            (&mut self.state, &mut self.canon),
            (words, line),
            out,
        )
    }

    /// The main program ended (its last line): a move still held by a `,R`/`,C` corner word
    /// has no next move to round into.
    pub(crate) fn end_of_program(&self, src: &SourceFile) -> Result<(), NcError> {
        match &self.state.pending_corner {
            Some(p) if p.file == src.name => Err(NcError::new(
                p.window.as_ref().unwrap_or(src),
                p.word,
                "corner rounding/chamfer: the program ends after this move",
            )
            .with_expected("a G1 move in the plane in the block after a `,R`/`,C` block")),
            Some(_) => Err(NcError::new(
                src,
                cnc402_lang::ast::Span::default(),
                "corner rounding/chamfer: the program ends after a move with ,R/,C",
            )),
            None => Ok(()),
        }
    }

    /// Adds a handed-out segment's length to the path length.
    #[inline]
    pub(crate) fn account(&mut self, s: &Segment) {
        match &s.kind {
            // A straight move's length as `path_length` takes it, without its second match.
            SegmentKind::Rapid { end }
            | SegmentKind::Linear { end, .. }
            | SegmentKind::Tap(TapSegment { end, .. }) => {
                self.path_len += self.path_axes.line_length(&self.path_end, end);
                self.path_end = *end;
            }
            SegmentKind::Arc { end, .. } => {
                self.path_len += path_length(&self.path_end, &s.kind, &self.path_axes);
                self.path_end = *end;
            }
            // G28/G30 C: program C reads the reference from here (the turn is no path).
            SegmentKind::SpindleOrient {
                program: Some(c),
                spindle,
                ..
            } => {
                if let Some(i) = self.cfg.spindle_axis(*spindle) {
                    self.path_end[i] = *c;
                }
            }
            _ => {}
        }
    }

    /// A program length on axis `i` from mm (linear axes in inch programs) or degrees.
    fn in_program_units(&self, i: usize, v: f64) -> f64 {
        if self.cfg.axes[i].kind.is_rotary() {
            v
        } else {
            v / self.state.unit()
        }
    }

    /// Reads `#n` when this layer owns it: modal information, positions (a position read
    /// first waits for motion through the [`MotionSync`]), work and tool offsets. The other
    /// classes (locals, common, non-volatile, program flow) are the caller's: an error here.
    pub(crate) fn read_var(&mut self, n: i64) -> Result<MVal, String> {
        let class = VarClass::of(n, self.cfg.axes.len())?;
        self.read_class(n, class, false)
    }

    /// [`read_var`](Self::read_var) of an already classified `#n`; `modal_call`: a G66 is in
    /// force (`#4012`).
    pub(crate) fn read_class(
        &mut self,
        n: i64,
        class: VarClass,
        modal_call: bool,
    ) -> Result<MVal, String> {
        let unit = self.state.unit();
        Ok(match class {
            VarClass::GroupCode(g) => self.group_code(g, modal_call),
            VarClass::ModalInfo(k) => match k {
                9 => Some(self.state.feed / unit),
                7 => Some(f64::from(self.state.d)),
                11 => Some(f64::from(self.state.h)),
                19 => Some(self.state.speed),
                20 => Some(f64::from(self.state.tool_selected)),
                2 | 8 => None,
                _ => return Err(format!("#{n} is not a modal information variable")),
            },
            // Fanuc: the block end point without the tool length offset.
            VarClass::Programmed(i) => Some(self.in_program_units(i, self.state.programmed(i))),
            // The tool length offset vector in force (Z; 0 on the other axes).
            VarClass::ToolLengthVector(i) => Some(self.in_program_units(i, self.state.tlo_of(i))),
            VarClass::MachinePos(i) | VarClass::WorkPos(i) => {
                let actual = self.sync.wait_motion_done(&self.state.pos)?;
                // #5041: work coordinates with the tool length offset included (Fanuc).
                let v = if matches!(class, VarClass::MachinePos(_)) {
                    actual[i]
                } else {
                    actual[i] - self.state.work_zero(i)
                };
                Some(self.in_program_units(i, v))
            }
            VarClass::WorkOffset { k, axis } => {
                Some(self.in_program_units(axis, self.state.work_offsets[k][axis]))
            }
            VarClass::ToolOffset { k, field } => {
                Some(field.get(&self.state.tool_offsets[k - 1]) / unit)
            }
            VarClass::Null | VarClass::Alarm => None,
            _ => return Err(format!("#{n} is not a variable of this control")),
        })
    }

    /// Writes `#n` of a class this layer owns (work and tool offsets): `Ok(false)` for the
    /// other classes; an error if the value in mm overflows (an inch value past f64's range).
    pub(crate) fn write_class(&mut self, class: VarClass, v: MVal) -> Result<bool, String> {
        let mm = |v: f64, unit: f64| -> Result<f64, String> {
            let m = v * unit;
            if m.is_finite() {
                Ok(m)
            } else {
                Err("the offset overflows in mm (not a finite number)".to_string())
            }
        };
        match class {
            VarClass::WorkOffset { k, axis } => {
                let unit = if self.cfg.axes[axis].kind.is_rotary() {
                    1.0
                } else {
                    self.state.unit()
                };
                self.state
                    .set_work_offset(k, axis, mm(v.unwrap_or(0.0), unit)?);
            }
            VarClass::ToolOffset { k, field } => {
                let v = mm(v.unwrap_or(0.0), self.state.unit())?;
                self.state.set_tool_offset(k, field, v);
            }
            _ => return Ok(false),
        }
        Ok(true)
    }

    /// `#4000+g`: the code of modal group `g` (groups cnc402 lacks read vacant, or the
    /// group's cancel code when cnc402 accepts it); `modal_call`: a G66 is in force.
    fn group_code(&self, g: u32, modal_call: bool) -> MVal {
        let st = &self.state;
        let v = match g {
            1 => match st.motion {
                Motion::Rapid => 0.0,
                Motion::Linear => 1.0,
                Motion::ArcCw => 2.0,
                Motion::ArcCcw => 3.0,
            },
            2 => match st.plane {
                Plane::XY => 17.0,
                Plane::ZX => 18.0,
                Plane::YZ => 19.0,
            },
            3 => {
                if st.incremental {
                    91.0
                } else {
                    90.0
                }
            }
            5 => {
                if st.feed_per_rev {
                    95.0
                } else {
                    94.0
                }
            }
            6 => {
                if st.inch {
                    20.0
                } else {
                    21.0
                }
            }
            7 => st.comp.map_or(40.0, |c| match c.side {
                crate::canon::CompSide::Left => 41.0,
                crate::canon::CompSide::Right => 42.0,
            }),
            8 => f64::from(st.tool_length.code()),
            9 => st.cycle.map_or(80.0, |c| f64::from(c.code())),
            10 => {
                if st.return_to_r {
                    99.0
                } else {
                    98.0
                }
            }
            11 => 50.0,
            12 => {
                if modal_call {
                    66.0
                } else {
                    67.0
                }
            }
            14 => 54.0 + st.work_offset as f64,
            15 => f64::from(st.path_mode),
            16 => 69.0,
            17 => 15.0,
            _ => return None,
        };
        Some(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// `account` adds what `path_length` gives for every kind of path segment (straight
        /// moves take a shorter way there), one after another from the start.
        #[test]
        fn account_adds_what_path_length_gives(
            moves in proptest::collection::vec((0u8..4, proptest::collection::vec(-3i8..4, 4)), 1..6),
        ) {
            let cfg = MachineConfig::default_machine();
            let mut m = Machine::new(&cfg, Options::default());
            let axes = PathAxes::new(&cfg);
            let (mut at, mut want) = (m.path_end, 0.0);
            for (which, v) in moves {
                let mut end = AxisPos::default();
                for (i, x) in v.iter().enumerate() {
                    end.0[i] = f64::from(*x) * 0.75;
                }
                let kind = match which {
                    0 => SegmentKind::Rapid { end },
                    1 => SegmentKind::Linear { end, feed: 100.0 },
                    2 => SegmentKind::Tap(TapSegment { end, feed: 100.0, tool: 2, spindle: 3, pitch: -1.0 }),
                    _ => SegmentKind::Arc { end, center: [0.5, -0.5, 0.0], plane: Plane::XY, dir: cnc402_motion::segment::ArcDir::Cw, turns: 0, feed: 100.0 },
                };
                want += path_length(&at, &kind, &axes);
                at = end;
                m.account(&Segment {
                    kind,
                    source: Source { file: Arc::from("p.nc"), line: 1, n: None },
                    ends: cnc402_motion::segment::SegmentEnd::ExactStop,
                });
                prop_assert_eq!(m.path_len.to_bits(), want.to_bits());
                prop_assert_eq!(m.path_end, at);
            }
        }
    }
}
