//! The job's own cycle programs carried to a target with Custom Macro B
//! ([`crate::input::calls`]): at a marked call the `G65` is written instead of the moves the
//! program makes (the tool still follows them), and the program's blocks once, after the
//! main program. A call whose first move needs a tool length or compensation block of its own
//! is expanded instead, as on targets without macros.

use cnc402_interp::canon::{CanonKind, CanonOp};
use cnc402_motion::segment::SegmentKind;

use super::Emitter;
use crate::PostError;
use crate::assemble::{Block, SubProgram, Word};
use crate::input::calls::{CycleCall, MARKER};

/// A call being carried: the call, and whether its `G65` is written (`false`: expanded).
#[derive(Clone, Debug)]
pub struct OpenCall {
    call: CycleCall,
    first: u32,
    last: u32,
    written: Option<bool>,
}

impl Emitter<'_> {
    /// Handles `op` as part of a carried call: `Ok(true)` when it is (a marker, or a move the
    /// call's `G65` makes), `Ok(false)` for an operation to emit as usual.
    pub(crate) fn carried_op(&mut self, op: &CanonOp) -> Result<bool, PostError> {
        if let CanonKind::Single(SegmentKind::Message { text }) = &op.kind
            && let Some(i) = text.trim().strip_prefix(MARKER)
        {
            self.close_call();
            let cycles = self.cycles.filter(|_| self.rules.macros);
            let call = i
                .trim()
                .parse::<usize>()
                .ok()
                .and_then(|i| cycles?.calls.get(i));
            if let Some(call) = call {
                let p = &self.cycles.expect("call").programs[call.program];
                self.call = Some(OpenCall {
                    call: call.clone(),
                    first: p.first_line,
                    last: p.last_line,
                    written: None,
                });
            }
            return Ok(true);
        }
        let Some(open) = self.call.clone() else {
            return Ok(false);
        };
        if !(open.first..=open.last).contains(&op.source.line) {
            self.close_call();
            return Ok(false);
        }
        match open.written {
            Some(true) => {
                if let CanonKind::Single(SegmentKind::Coolant { mist, flood }) = op.kind {
                    self.modal.coolant = (mist, flood);
                }
                self.advance(op);
                Ok(true)
            }
            Some(false) => Ok(false),
            None => {
                let written = self.write_call(op, &open.call)?;
                if let Some(c) = self.call.as_mut() {
                    c.written = Some(written);
                }
                if written {
                    self.advance(op);
                }
                Ok(written)
            }
        }
    }

    /// The `G65` of `call` before `op`, its first operation, if the control can take it there.
    fn write_call(&mut self, op: &CanonOp, call: &CycleCall) -> Result<bool, PostError> {
        self.end_cycle(op);
        if !self.state_before_call(op)? {
            return Ok(false);
        }
        let sub = self.carried_sub(call.program);
        let mut block = Block::new(Vec::new(), Some(op.source.clone()));
        block.source.as_mut().expect("source").line = call.line;
        block.words = vec![Word::Text("G65".into()), Word::Sub(sub)];
        block
            .words
            .extend(call.args.iter().cloned().map(Word::Text));
        self.program.main.push(block);
        Ok(true)
    }

    /// The sub-program index of the job's cycle program `program`, written on first use.
    fn carried_sub(&mut self, program: usize) -> usize {
        if let Some(&(_, i)) = self.carried.iter().find(|(p, _)| *p == program) {
            return i;
        }
        let p = &self.cycles.expect("cycles").programs[program];
        self.program.subs.push(SubProgram {
            // The header is one raw line: a short name keeps it within every control's line.
            name: format!("O{} {}", p.number, p.name)
                .chars()
                .take(40)
                .collect(),
            blocks: p
                .body
                .iter()
                .map(|l| Block::new(vec![l.clone()], None))
                .collect(),
        });
        let i = self.program.subs.len() - 1;
        self.carried.push((program, i));
        i
    }

    /// After a carried call: the control holds what the program left, which the post does not
    /// follow: every modal group its blocks write is written again (motion, feed, speed
    /// always).
    pub(crate) fn close_call(&mut self) {
        let Some(c) = self.call.take() else { return };
        if c.written != Some(true) {
            return;
        }
        let program = &self.cycles.expect("cycles").programs[c.call.program];
        let writes = |codes: &[u32]| program.g_codes.iter().any(|g| codes.contains(g));
        let m = &mut self.modal;
        m.motion = None;
        m.feed = None;
        m.spindle = None;
        m.cycle = None;
        if writes(&[17, 18, 19]) {
            m.plane = None;
        }
        if writes(&[20, 21, 70, 71]) {
            m.units = None;
        }
        if writes(&[61, 64]) {
            m.path_mode = None;
        }
        if writes(&[54, 55, 56, 57, 58, 59]) {
            m.work = None;
        }
        if writes(&[43, 44, 49]) {
            m.tool_length = None;
        }
        if writes(&[40, 41, 42]) {
            m.comp = None;
        }
    }
}
