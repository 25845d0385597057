//! From canonical operations to the target's blocks, with the modal state of the posted
//! program tracked so that a word is written only when the control would not already have it
//! (modal suppression), and so that offsets and cycles the control keeps between blocks
//! match the job's at every block.

mod carried;
mod datum;
pub mod format;
pub mod heidenhain;
mod helix;
mod labels;
pub mod macro_b;
mod modal;
mod ops;

use cnc402_config::MachineConfig;
use cnc402_interp::canon::{CanonKind, CanonOp};
use cnc402_motion::segment::{AxisPos, MAX_AXES, SegmentKind};

use crate::PostError;
use crate::assemble::{Block, Program};
use crate::input::calls::Marked;
use crate::rules::Rules;

pub use modal::Modal;

/// The posted program of `ops` (not yet assembled).
pub fn emit(
    cfg: &MachineConfig,
    rules: &Rules,
    ops: &[CanonOp],
    cycles: Option<&Marked>,
) -> Result<Program, PostError> {
    let mut e = Emitter::new(cfg, rules);
    e.cycles = cycles;
    e.program.title = format!("cnc402 post {}", rules.name);
    e.push(
        ["G17", "G40", "G49", "G80", "G90", "G94"]
            .map(String::from)
            .to_vec(),
        None,
    );
    for op in ops {
        if !e.carried_op(op)? {
            e.op(op)?;
        }
    }
    Ok(e.program)
}

/// The emitter: the program so far, the posted program's modal state, and where the tool is.
pub struct Emitter<'a> {
    pub(crate) cfg: &'a MachineConfig,
    pub(crate) rules: &'a Rules,
    pub(crate) program: Program,
    pub(crate) modal: Modal,
    /// Where the tool is after the operations so far, machine coordinates (the job's and the
    /// posted program's alike: that is what the emitter keeps true).
    pub(crate) pos: AxisPos,
    pub(crate) xyz: [Option<usize>; 3],
    /// The block being built sets or cancels the tool length (G43/G44/G49).
    pub(crate) length_written: bool,
    /// The Macro B bodies written so far, and their sub-program indices.
    pub(crate) macro_subs: Vec<(macro_b::MacroKey, usize)>,
    /// The job's own cycle programs ([`crate::input::calls`]), the call being carried, and
    /// the sub-program index of each program carried so far.
    pub(crate) cycles: Option<&'a Marked>,
    pub(crate) call: Option<carried::OpenCall>,
    pub(crate) carried: Vec<(usize, usize)>,
}

impl<'a> Emitter<'a> {
    pub fn new(cfg: &'a MachineConfig, rules: &'a Rules) -> Self {
        Emitter {
            cfg,
            rules,
            program: Program::default(),
            modal: Modal::new(cfg),
            pos: AxisPos::default(),
            xyz: cnc402_interp::lower::xyz_indices(cfg),
            length_written: false,
            macro_subs: Vec::new(),
            cycles: None,
            call: None,
            carried: Vec::new(),
        }
    }

    pub(crate) fn push(&mut self, words: Vec<String>, op: Option<&CanonOp>) {
        self.program
            .main
            .push(Block::new(words, op.map(|o| o.source.clone())));
    }

    /// Appends the blocks of one operation.
    fn op(&mut self, op: &CanonOp) -> Result<(), PostError> {
        if let Some(why) = ops::other_spindle_refused(op) {
            return Err(self.refuse(op, why));
        }
        match &op.kind {
            CanonKind::CannedCycle(cc) => self.cycle(op, cc)?,
            CanonKind::Single(kind) => self.single(op, kind)?,
        }
        self.advance(op);
        Ok(())
    }

    /// Moves the tool as `op` moves it (its lowering, cycles expanded).
    pub(crate) fn advance(&mut self, op: &CanonOp) {
        let mut segments = Vec::new();
        cnc402_interp::lower::lower(op, self.xyz, &mut segments);
        for s in segments {
            match s.kind {
                SegmentKind::Arc { end, .. } => self.pos = end,
                SegmentKind::SpindleOrient {
                    program: Some(c), ..
                } => {
                    if let Some(i) = self.cfg.spindle_index() {
                        self.pos[i] = c + op.state.offset[i];
                    }
                }
                k => {
                    if let Some(end) = k.line_end() {
                        self.pos = *end;
                    }
                }
            }
        }
    }

    /// The letter of axis `i`.
    pub(crate) fn letter(&self, i: usize) -> char {
        self.cfg.axes[i].name
    }

    /// The configured axes.
    pub(crate) fn axes(&self) -> std::ops::Range<usize> {
        0..self.cfg.axes.len().min(MAX_AXES)
    }
}
