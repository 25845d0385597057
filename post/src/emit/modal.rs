//! The posted program's modal state as the control will hold it, and the words (and G10
//! blocks) that bring it to the state an operation of the job ran under: plane, work
//! coordinate system and its zero, tool length offset, cutter compensation, path mode.

use cnc402_config::{MachineConfig, ToolOffset};
use cnc402_interp::canon::{CanonOp, CompSide, PathMode};
use cnc402_motion::segment::{AxisPos, MAX_AXES, Plane};

use super::Emitter;
use super::format::{Unit, position};
use crate::PostError;
use cnc402_config::AxisKind;
use cnc402_interp::canon::ProgramUnits;

/// What the control holds between blocks (`None`: not yet written, so written next time).
#[derive(Clone, Debug)]
pub struct Modal {
    /// Group 01 as last written: 0, 1, 2, 3, or a cycle code.
    pub motion: Option<u32>,
    pub plane: Option<Plane>,
    /// G20/G21 as written.
    pub units: Option<ProgramUnits>,
    pub feed: Option<String>,
    pub path_mode: Option<u32>,
    pub work: Option<usize>,
    /// (43/44/49, H).
    pub tool_length: Option<(u32, u32)>,
    /// `Some(None)`: G40 written.
    pub comp: Option<Option<(CompSide, u32)>>,
    /// The work zeros and tool offsets the control has: the config's, changed by the G10
    /// blocks written so far.
    pub work_zeros: [[f64; MAX_AXES]; 6],
    pub tools: Vec<ToolOffset>,
    /// Work → machine of the last path block (the control's offset there).
    pub offset: AxisPos,
    pub spindle: Option<String>,
    pub coolant: (bool, bool),
    /// The active canned cycle, if any.
    pub cycle: Option<super::ops::CycleModal>,
}

impl Modal {
    pub fn new(cfg: &MachineConfig) -> Modal {
        Modal {
            motion: None,
            // As the preamble (G17 G40 G49) leaves them.
            plane: Some(Plane::XY),
            units: None,
            feed: None,
            path_mode: None,
            work: None,
            tool_length: Some((49, 0)),
            comp: Some(None),
            work_zeros: cfg.work_offsets,
            tools: cfg.tool_offsets.clone(),
            offset: AxisPos(cfg.work_offsets[0]),
            spindle: None,
            coolant: (false, false),
            cycle: None,
        }
    }
}

/// The G code of a plane.
pub fn plane_code(p: Plane) -> u32 {
    match p {
        Plane::XY => 17,
        Plane::ZX => 18,
        Plane::YZ => 19,
    }
}

const SAME: f64 = 1e-9;

impl Emitter<'_> {
    /// The modal words a path block of `op` starts with; G10 blocks the control needs first
    /// are appended to the program here.
    pub(crate) fn modal_words(&mut self, op: &CanonOp) -> Result<Vec<String>, PostError> {
        let st = &op.state;
        let mut words = Vec::new();
        self.length_written = false;
        if self.modal.units != Some(st.units) {
            // A block of its own: the G10 values below are read in the new units.
            let code = if st.units == ProgramUnits::Inch {
                "G20"
            } else {
                "G21"
            };
            self.push(vec![code.into()], Some(op));
            self.modal.units = Some(st.units);
        }
        if self.modal.plane != Some(st.plane) {
            words.push(format!("G{}", plane_code(st.plane)));
            self.modal.plane = Some(st.plane);
        }
        let tool_words = self.tool_length(op)?;
        self.work_zero(op)?;
        if self.modal.work != Some(st.work_offset) {
            words.push(format!("G{}", 54 + st.work_offset));
            self.modal.work = Some(st.work_offset);
        }
        words.extend(tool_words);
        words.extend(self.compensation(op)?);
        let path = st.path_mode.code();
        if self.modal.path_mode != Some(path) {
            words.push(format!("G{path}"));
            self.modal.path_mode = Some(path);
        }
        Ok(words)
    }

    /// G43/G44 H or G49 for the tool length the operation runs with (0 after G28/G30 in G43:
    /// Fanuc cancels the vector at the reference point), with a G10 L10 first when the
    /// control's table gives another length for H.
    fn tool_length(&mut self, op: &CanonOp) -> Result<Vec<String>, PostError> {
        let st = &op.state;
        let want = if self.effective_length(op) == 0.0 || st.tool_length_mode == 49 || st.h == 0 {
            (49, 0)
        } else {
            (st.tool_length_mode, st.h)
        };
        if want.0 != 49 {
            let sign = if want.0 == 44 { -1.0 } else { 1.0 };
            let Some(t) = self.modal.tools.get(want.1 as usize - 1).copied() else {
                return Err(self.refuse(op, format!("H{} is not a tool offset number", want.1)));
            };
            let geometry = sign * st.tool_length - t.length_wear;
            if (t.length - geometry).abs() > SAME {
                self.data_input(op, "tool length")?;
                let r = self.length_word('R', geometry, op)?;
                self.push(
                    vec!["G10".into(), "L10".into(), format!("P{}", want.1), r],
                    Some(op),
                );
                self.modal.tools[want.1 as usize - 1].length = geometry;
                self.modal.tool_length = None;
            }
        }
        if self.modal.tool_length == Some(want) {
            return Ok(Vec::new());
        }
        self.modal.tool_length = Some(want);
        self.length_written = true;
        Ok(match want {
            (49, _) => vec!["G49".into()],
            (mode, h) => vec![format!("G{mode}"), format!("H{h}")],
        })
    }

    /// The tool length vector the operation's offset carries: the state's, or 0 where
    /// G28/G30 cancelled it at the reference point (G43 still modal, the offset without it).
    pub(crate) fn effective_length(&self, op: &CanonOp) -> f64 {
        let st = &op.state;
        let Some(t) = st.tool_axis else { return 0.0 };
        let zero = self.modal.work_zeros[st.work_offset][t];
        let carried = st.offset[t] - zero;
        if (carried - st.tool_length).abs() > SAME && carried.abs() <= SAME {
            0.0
        } else {
            st.tool_length
        }
    }

    /// A G10 L2 block when the job's work zero (G92 shifts, G10 of the job) is not what the
    /// control's table holds for the active system.
    fn work_zero(&mut self, op: &CanonOp) -> Result<(), PostError> {
        let st = &op.state;
        let mut want = st.offset;
        if let Some(t) = st.tool_axis {
            want[t] -= self.effective_length(op);
        }
        let have = self.modal.work_zeros[st.work_offset];
        let differ: Vec<usize> = self
            .axes()
            .filter(|&i| (want[i] - have[i]).abs() > SAME)
            .collect();
        if differ.is_empty() {
            return Ok(());
        }
        self.data_input(op, "work zero (G92 or G10 of the job)")?;
        let mut words = vec![
            "G10".into(),
            "L2".into(),
            format!("P{}", st.work_offset + 1),
        ];
        for i in differ {
            words.push(self.axis_word(i, want[i], op)?);
            self.modal.work_zeros[st.work_offset][i] = want[i];
        }
        self.push(words, Some(op));
        Ok(())
    }

    /// G41/G42 D or G40, with a G10 L12 first when the control's D gives another radius.
    fn compensation(&mut self, op: &CanonOp) -> Result<Vec<String>, PostError> {
        let want = op.state.comp.map(|c| (c.side, c.d));
        if let Some(c) = op.state.comp {
            let Some(t) = self
                .modal
                .tools
                .get((c.d as usize).wrapping_sub(1))
                .copied()
            else {
                return Err(self.refuse(op, format!("D{} is not a tool offset number", c.d)));
            };
            let geometry = c.radius - t.radius_wear;
            if (t.radius - geometry).abs() > SAME {
                self.data_input(op, "cutter radius")?;
                let r = self.length_word('R', geometry, op)?;
                self.push(
                    vec!["G10".into(), "L12".into(), format!("P{}", c.d), r],
                    Some(op),
                );
                self.modal.tools[c.d as usize - 1].radius = geometry;
                self.modal.comp = None;
            }
        }
        if self.modal.comp == Some(want) {
            return Ok(Vec::new());
        }
        self.modal.comp = Some(want);
        Ok(match want {
            None => vec!["G40".into()],
            Some((CompSide::Left, d)) => vec!["G41".into(), format!("D{d}")],
            Some((CompSide::Right, d)) => vec!["G42".into(), format!("D{d}")],
        })
    }

    /// How lengths are written now.
    pub(crate) fn length_unit(&self) -> Unit {
        if self.modal.units == Some(ProgramUnits::Inch) {
            Unit::Inch
        } else {
            Unit::Mm
        }
    }

    /// The word of axis `i` at `value` (mm or degrees).
    pub(crate) fn axis_word(
        &self,
        i: usize,
        value: f64,
        op: &CanonOp,
    ) -> Result<String, PostError> {
        let unit = match self.cfg.axes[i].kind {
            AxisKind::Linear => self.length_unit(),
            _ => Unit::Degree,
        };
        position(self.rules, self.letter(i), value, unit, &op.source)
    }

    /// A length word other than an axis (I J K R Q), `value` in mm.
    pub(crate) fn length_word(
        &self,
        letter: char,
        value: f64,
        op: &CanonOp,
    ) -> Result<String, PostError> {
        position(self.rules, letter, value, self.length_unit(), &op.source)
    }

    /// Refuses an offset change on a control without programmable data input.
    fn data_input(&self, op: &CanonOp, what: &str) -> Result<(), PostError> {
        if self.rules.data_input {
            Ok(())
        } else {
            Err(self.refuse(
                op,
                format!(
                    "the job sets a {what} the machine's tables do not hold, and the control \
                     has no G10 to set it"
                ),
            ))
        }
    }

    /// An error at `op`'s block.
    pub(crate) fn refuse(&self, op: &CanonOp, message: String) -> PostError {
        PostError::target(self.rules, Some(&op.source), message)
    }

    /// The path mode the control is to run a cycle expanded into plain blocks in.
    pub(crate) fn exact_stop() -> PathMode {
        PathMode::ExactStop
    }
}
