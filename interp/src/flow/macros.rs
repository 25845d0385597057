//! Fanuc Custom Macro B execution: the program counter through the units of [`super::units`],
//! calls and returns (`M98`/`M99`, `G65`, `G66`/`G67`), control flow (`GOTO`, `IF`, `WHILE … DO m … END m`), the
//! old `G65 H…` macro instructions (computed by the expression operators), alarms (`#3000`,
//! `G65 H99`) and the runaway-loop guard. Variables are read and written through `sysvars`.

use std::sync::Arc;

use cnc402_lang::ast::{BinaryOp, Block, Expr, ExprKind, Func, Line, LineKind, Span, Value};
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::{SegmentKind, Source, StopKind};

use super::Interpreter;
use super::units::{
    Frame, MAX_FRAMES, MAX_MACRO_LEVELS, ModalCall, Unit, arg_var, spec2_vars, split_units,
};
use crate::block::MainM99;
use crate::block::words::{GGroup, Words, fmt_num};
use crate::expr::{self as eval, C_LIKE_ONLY, ops, var_number};
use crate::vars::MVal;

/// What a block asks for after its own words have run.
pub enum After {
    Nothing,
    /// `M98 P… L…`.
    Call {
        number: u32,
        times: u32,
        span: Span,
    },
    /// `M99 [P n]`.
    Return {
        seq: Option<u32>,
        span: Span,
    },
}

/// What [`Interpreter::plain_lane`] did with a line.
enum Lane {
    /// Ran it.
    Ran,
    /// Read it and left it to the general path: its view (`None`: the file's end), as
    /// [`Interpreter::line_view`] gives it.
    Left(Option<Arc<Unit>>),
    /// Did not read it.
    NotRead,
}

fn whole(v: f64) -> Option<u32> {
    (v >= 0.0 && v.fract() == 0.0 && v <= 99_999_999.0).then_some(v as u32)
}

impl Interpreter {
    /// How many times the program has read a non-volatile variable (`#500–#999`) so far: the
    /// values an operator can change during a program stop (`cnc402 vars set`). A dry run uses
    /// it to tell an error that depends on them from one that does not.
    pub fn persistent_reads(&self) -> u64 {
        self.vars.table.nv_reads
    }

    fn cur_unit(&self) -> Arc<Unit> {
        self.flow
            .frames
            .last()
            .map(|f| f.unit.clone())
            .unwrap_or_else(|| self.flow.units[0].clone())
    }

    fn eval_at(&mut self, src: &SourceFile, e: &Expr) -> Result<MVal, NcError> {
        eval::eval(src, e, self)
    }

    /// Executes the line at the program counter of the innermost frame.
    pub(crate) fn step(&mut self) -> Result<(), NcError> {
        let Some(frame) = self.flow.frames.last_mut() else {
            self.flow.done = true;
            return Ok(());
        };
        let unit = frame.unit.clone();
        let pc = frame.pc;
        if pc >= unit.end {
            return self.end_of_unit(&unit);
        }
        frame.pc += 1;
        // A streamed unit's line is read now: `unit` becomes the view holding it, unless the
        // plain-block lane ran it from its bytes. Whatever runs now but the lane, the lane's
        // next block compares the state again.
        let lane_canon = std::mem::take(&mut self.m.lane_canon);
        let view = match self.plain_lane(&unit, pc, lane_canon)? {
            Lane::Ran => return Ok(()),
            Lane::Left(view) => view,
            Lane::NotRead => self.line_view(&unit, pc)?,
        };
        let Some(unit) = view else {
            return self.end_of_unit(&unit);
        };
        let program = unit.program.clone();
        let line = &program.lines[pc - unit.base];
        if line.block_delete && self.m.opts.block_delete {
            return Ok(());
        }
        if let Some(n) = line.n {
            self.flow.last_n = Some(f64::from(n.value));
        }
        if !matches!(
            line.kind,
            LineKind::Empty | LineKind::Continued | LineKind::ProgramNumber { .. }
        ) {
            self.flow.runaway.note(&unit, line.line_no);
            if self.flow.runaway.count > self.m.cfg.interp.block_limit {
                let (a, b) = self.flow.runaway.lines(&unit);
                return Err(NcError::new(
                    &unit.src,
                    line.span,
                    format!(
                        "runaway program: {} blocks in a row without motion (interp.block_limit); the loop runs over lines {a}-{b} of {}",
                        self.m.cfg.interp.block_limit, unit.src.name
                    ),
                )
                .with_expected("a loop that ends, or motion inside it"));
            }
        }
        let err = |span: Span, m: String| NcError::new(&unit.src, span, m);
        match &line.kind {
            LineKind::Percent => {
                // A called file's opening `%` (nothing but `%` and empty lines before it in
                // the unit) opens it; the main program's blocks must not make it an end.
                if self.flow.frames.len() > 1 && opens_unit(&unit, pc) {
                    return Ok(());
                }
                if self.flow.seen_block {
                    return self.end_of_unit(&unit);
                }
                Ok(())
            }
            LineKind::ProgramNumber { .. } | LineKind::Continued => Ok(()),
            LineKind::OWord(o) => self.oword(&unit, line, pc, o),
            LineKind::Empty => self.exec_block(&unit, line, None),
            LineKind::Block(b) => {
                self.flow.seen_block = true;
                self.exec_block(&unit, line, Some(b))
            }
            LineKind::Stmts(_) => Err(err(
                line.span,
                format!("C-like statements are allowed {C_LIKE_ONLY}"),
            )),
            LineKind::Assign { target, value } => {
                self.flow.seen_block = true;
                self.assign(&unit, line, target, value)
            }
            LineKind::Assigns(pairs) => {
                self.flow.seen_block = true;
                let mut values = Vec::with_capacity(pairs.len());
                for (target, value) in pairs {
                    let to = self.var_target(&unit, target)?;
                    values.push((target, to, self.eval_at(&unit.src, value)?));
                }
                for (target, to, v) in values {
                    self.set_var(&unit, line, (target, to), v)?;
                }
                Ok(())
            }
            LineKind::Goto { target } => {
                self.flow.seen_block = true;
                let n = self.seq_target(&unit, target)?;
                self.jump(&unit, n, target.span)
            }
            LineKind::IfGoto { cond, target } => {
                self.flow.seen_block = true;
                if self.truth(&unit, cond)? {
                    let n = self.seq_target(&unit, target)?;
                    self.jump(&unit, n, target.span)?;
                }
                Ok(())
            }
            LineKind::IfThen { cond, then } => {
                self.flow.seen_block = true;
                if !self.truth(&unit, cond)? {
                    return Ok(());
                }
                match &**then {
                    LineKind::Assign { target, value } => self.assign(&unit, line, target, value),
                    LineKind::Block(b) => self.exec_block(&unit, line, Some(b)),
                    _ => Err(err(
                        line.span,
                        "IF … THEN takes an assignment or a block".into(),
                    )),
                }
            }
            LineKind::While { cond, id } => {
                self.flow.seen_block = true;
                if let Some(m) = unit.ix.loop_errors.get(&pc) {
                    return Err(err(line.span, m.clone()));
                }
                let Some(&end) = unit.ix.loops.get(&pc) else {
                    return Err(err(line.span, format!("WHILE … DO {id} has no END {id}")));
                };
                if !self.truth(&unit, cond)? {
                    self.set_pc(end + 1);
                }
                Ok(())
            }
            LineKind::End { id } => {
                if let Some(m) = unit.ix.loop_errors.get(&pc) {
                    return Err(err(line.span, m.clone()));
                }
                let Some(&w) = unit.ix.loops.get(&pc) else {
                    return Err(err(line.span, format!("END {id} without WHILE … DO {id}")));
                };
                self.set_pc(w);
                Ok(())
            }
        }
    }

    /// A unit holding line `i` of `unit`: `unit` itself when it holds its whole program, else
    /// (streamed) a view of the line read now; `None` past the end of the file.
    pub(super) fn line_view(
        &mut self,
        unit: &Arc<Unit>,
        i: usize,
    ) -> Result<Option<Arc<Unit>>, NcError> {
        match (&mut self.flow.stream, unit.streamed) {
            (Some(s), true) => s.view(unit, i),
            _ => Ok((i < unit.program.lines.len()).then(|| unit.clone())),
        }
    }

    /// Runs line `i` of `unit` in the plain-block lane (`crate::block::plain`) when it can:
    /// a streamed line read where the reader is, a plain block the lane reads, in a state
    /// where the general path would do no more than the lane (no G66 call after a move, the
    /// runaway guard not at its limit), which then does all `step` and `exec_block` do for a
    /// block that moves.
    fn plain_lane(
        &mut self,
        unit: &Arc<Unit>,
        i: usize,
        lane_canon: bool,
    ) -> Result<Lane, NcError> {
        let f = &mut self.flow;
        let (Some(lane), Some(s), true) = (&f.lane, &mut f.stream, unit.streamed) else {
            return Ok(Lane::NotRead);
        };
        if f.modal_call.is_some() || f.runaway.count >= self.m.cfg.interp.block_limit {
            return Ok(Lane::NotRead);
        }
        let at = match s.read_raw_at(i)? {
            None => return Ok(Lane::NotRead),
            Some(None) => return Ok(Lane::Left(None)),
            Some(Some(at)) => at,
        };
        let Some(b) = lane.read(s.body()) else {
            return s.view_read(unit, i, at).map(Lane::Left);
        };
        let line = u32::try_from(at.index + 1).unwrap_or(u32::MAX);
        let source = Source {
            file: unit.src.name.clone(),
            line,
            n: b.n,
        };
        let linuxcnc = unit.program.dialect == cnc402_lang::Dialect::LinuxCnc;
        if !(self.m).run_plain(lane, (&b, linuxcnc), (source, lane_canon), &mut f.queue) {
            return s.view_read(unit, i, at).map(Lane::Left);
        }
        if let Some(n) = b.n {
            f.last_n = Some(f64::from(n));
        }
        // Counted as a block, and a block that moved.
        f.runaway.note(unit, line);
        f.runaway.reset();
        f.seen_block = true;
        f.lane_blocks += 1;
        s.ran_plain(at);
        Ok(Lane::Ran)
    }

    /// The line of `N n` in `unit`, for a jump from the line before `from`.
    fn find_label(&mut self, unit: &Unit, n: u32, from: usize) -> Result<Option<usize>, NcError> {
        match (&mut self.flow.stream, unit.streamed) {
            (Some(s), true) => s.find_label(unit, n, from),
            _ => Ok(unit.ix.labels.get(&n).copied()),
        }
    }

    pub(super) fn set_pc(&mut self, pc: usize) {
        if let Some(f) = self.flow.frames.last_mut() {
            f.pc = pc;
        }
    }

    fn truth(&mut self, unit: &Unit, cond: &Expr) -> Result<bool, NcError> {
        Ok(matches!(self.eval_at(&unit.src, cond)?, Some(v) if v != 0.0))
    }

    fn seq_target(&mut self, unit: &Unit, e: &Expr) -> Result<u32, NcError> {
        let v = self.eval_at(&unit.src, e)?;
        match v.and_then(whole) {
            Some(n) if (1..=99_999).contains(&n) => Ok(n),
            _ => Err(NcError::new(
                &unit.src,
                e.span,
                format!(
                    "GOTO target {} is not a sequence number",
                    v.map_or("vacant".into(), fmt_num)
                ),
            )
            .with_expected("a whole number 1..99999")),
        }
    }

    /// Continues at `N n` of `unit` (the current frame's program).
    fn jump(&mut self, unit: &Unit, n: u32, span: Span) -> Result<(), NcError> {
        let from = self.flow.frames.last().map_or(unit.start, |f| f.pc);
        let Some(i) = self.find_label(unit, n, from)? else {
            return Err(NcError::new(
                &unit.src,
                span,
                format!("sequence number N{n} not found in {}", unit.name()),
            ));
        };
        self.set_pc(i);
        Ok(())
    }

    fn assign(
        &mut self,
        unit: &Unit,
        line: &Line,
        target: &Expr,
        value: &Expr,
    ) -> Result<(), NcError> {
        let to = self.var_target(unit, target)?;
        let v = self.eval_at(&unit.src, value)?;
        self.set_var(unit, line, (target, to), v)
    }

    /// What an assignment's target names: `#n` / `#[expr]` (the index evaluated now, before
    /// the value, as Fanuc and LinuxCNC read a line) or `#<name>` (`None`).
    fn var_target(&mut self, unit: &Unit, target: &Expr) -> Result<Option<i64>, NcError> {
        match &target.kind {
            ExprKind::Var(n) => Ok(Some(i64::from(*n))),
            ExprKind::IndirectVar(e) => {
                Ok(Some(var_number(self.eval_at(&unit.src, e)?.unwrap_or(0.0))))
            }
            ExprKind::Named(_) => Ok(None),
            _ => Err(NcError::new(
                &unit.src,
                target.span,
                "an assignment needs a variable on the left",
            )),
        }
    }

    /// Sets the assignment target (`target` as written, `to` as [`Self::var_target`] read it)
    /// to the evaluated `v`: `#3000` alarms, `#3006` stops with its message.
    fn set_var(
        &mut self,
        unit: &Unit,
        line: &Line,
        (target, to): (&Expr, Option<i64>),
        v: crate::vars::MVal,
    ) -> Result<(), NcError> {
        let n = match (&target.kind, to) {
            (_, Some(n)) => n,
            (ExprKind::Named(name), None) => {
                return self
                    .write_named(name, v)
                    .map_err(|m| NcError::new(&unit.src, target.span, m));
            }
            (_, None) => return Ok(()),
        };
        let text = line
            .comments
            .first()
            .map(|c| c.text.trim().to_string())
            .unwrap_or_default();
        match n {
            3000 => {
                let num = v.unwrap_or(0.0);
                let alarm = 3000 + num.round().max(0.0) as i64;
                let mut m = format!("alarm {alarm}");
                if !text.is_empty() {
                    m.push_str(&format!(": {text}"));
                }
                Err(NcError::new(&unit.src, line.span, m))
            }
            3006 => {
                let source = Source {
                    file: unit.src.name.clone(),
                    line: line.line_no,
                    n: line.n.map(|n| n.value),
                };
                if !text.is_empty() {
                    let op = self
                        .m
                        .single_op(SegmentKind::Message { text }, source.clone());
                    self.flow.queue.push_back(op);
                }
                let stop = SegmentKind::Stop {
                    kind: StopKind::Program,
                };
                let op = self.m.single_op(stop, source);
                self.flow.queue.push_back(op);
                Ok(())
            }
            _ => self
                .write_var(n, v)
                .map_err(|m| NcError::new(&unit.src, target.span, m)),
        }
    }

    /// End of a program unit (its last line, or `%`): the main program ends; a sub-program
    /// returns as with `M99`.
    fn end_of_unit(&mut self, unit: &Unit) -> Result<(), NcError> {
        if self.flow.frames.len() <= 1 {
            self.flow.done = true;
            let src = match (&mut self.flow.stream, unit.streamed) {
                (Some(s), true) => s.last_window()?,
                _ => unit.src.clone(),
            };
            return self.m.end_of_program(&src);
        }
        self.ret(unit, None, Span::default())
    }

    /// `M99 [P seq]`.
    fn ret(&mut self, unit: &Unit, seq: Option<u32>, span: Span) -> Result<(), NcError> {
        let Some(f) = self.flow.frames.last_mut() else {
            return Ok(());
        };
        if f.repeats > 0 {
            f.repeats -= 1;
            f.pc = f.unit.start;
            return Ok(());
        }
        if self.flow.frames.len() == 1 {
            // M99 in the main program: jump to N seq. Without P Fanuc starts the program over,
            // endlessly: a machine run does (`MainM99::Repeat`); a dump or a dry run shows one
            // pass and says where it would repeat.
            return match (seq, self.m.opts.main_m99) {
                (Some(n), _) => self.jump(unit, n, span),
                (None, MainM99::Repeat) => {
                    // Over the opening `%` (past the first block it would end the program).
                    self.set_pc(unit.ix.restart);
                    Ok(())
                }
                (None, MainM99::End) => {
                    self.flow.done = true;
                    if span != Span::default() {
                        self.flow.main_m99_line = Some(unit.src.line_col(span.start as usize).0);
                    }
                    Ok(())
                }
            };
        }
        if let Some(f) = self.flow.frames.pop()
            && f.macro_level
        {
            self.vars.table.locals.pop();
            // An `M99` out of a LinuxCNC subroutine ends its named locals too.
            if f.o_call {
                self.vars.named.pop_scope();
            }
        }
        if let Some(n) = seq {
            let caller = self.cur_unit();
            let from = self.flow.frames.last().map_or(caller.start, |f| f.pc);
            let Some(i) = self.find_label(&caller, n, from)? else {
                return Err(NcError::new(
                    &unit.src,
                    span,
                    format!(
                        "M99 P{n}: sequence number N{n} not found in the caller {}",
                        caller.name()
                    ),
                ));
            };
            self.set_pc(i);
        }
        Ok(())
    }

    /// Program `O<number>`: in the running file, the main file, or the library.
    fn find_program(
        &mut self,
        number: u32,
        src: &SourceFile,
        span: Span,
    ) -> Result<Arc<Unit>, NcError> {
        let cur = self.cur_unit();
        if let Some(u) = self
            .flow
            .units
            .iter()
            .find(|u| u.number == Some(number) && u.src.name == cur.src.name)
            .or_else(|| self.flow.units.iter().find(|u| u.number == Some(number)))
        {
            return Ok(u.clone());
        }
        if let Some(u) = self.flow.lib_cache.get(&number) {
            return Ok(u.clone());
        }
        let not_found = |why: String| NcError::new(src, span, why);
        // The injected library only: the interpreter itself reads no files.
        let Some(lib) = self.flow.library.as_mut() else {
            return Err(not_found(format!(
                "program O{number:04} not found: not in this file, and no program directory is configured"
            )));
        };
        let main = self.flow.main_src.name.clone();
        let Some(file) = lib
            .find(number, &main)
            .map_err(|e| not_found(format!("program O{number:04}: {e}")))?
        else {
            return Err(not_found(format!(
                "program O{number:04} not found (not in this file, nor as O{number:04}.nc/.CNC/… {})",
                lib.describe()
            )));
        };
        let dialect = cnc402_lang::choose_dialect(&file, None, self.m.dialect)?;
        let program = Arc::new(cnc402_lang::parse_in(&file, dialect)?);
        let file = Arc::new(file);
        let (units, main) = split_units(&file, &program);
        let u = units
            .iter()
            .find(|u| u.number == Some(number))
            .cloned()
            .unwrap_or_else(|| units[main].clone());
        for other in &units {
            if let Some(n) = other.number {
                self.flow
                    .lib_cache
                    .entry(n)
                    .or_insert_with(|| other.clone());
            }
        }
        self.flow.lib_cache.insert(number, u.clone());
        Ok(u)
    }

    /// Pushes a call of `O<number>`, `times` runs; `args` gives it its own locals (G65/G66).
    fn call(
        &mut self,
        number: u32,
        times: u32,
        args: Option<[MVal; 33]>,
        src: &SourceFile,
        span: Span,
    ) -> Result<(), NcError> {
        let unit = self.find_program(number, src, span)?;
        if times == 0 {
            return Ok(());
        }
        if self.flow.frames.len() >= MAX_FRAMES {
            return Err(NcError::new(
                src,
                span,
                format!("calls nested deeper than {MAX_FRAMES} programs"),
            ));
        }
        if args.is_some() && self.vars.table.locals.len() > MAX_MACRO_LEVELS {
            return Err(NcError::new(
                src,
                span,
                format!("macro calls (G65/G66) nested deeper than {MAX_MACRO_LEVELS} levels"),
            ));
        }
        let mut f = Frame::new(unit, args.is_some());
        f.repeats = times - 1;
        if let Some(a) = args {
            self.vars.table.locals.push(a);
        }
        self.flow.frames.push(f);
        Ok(())
    }

    /// Takes the macro-call words out of a block. `Ok(None)`: the block was a `G65`/`G66`/
    /// `G67` and is done; otherwise what to do after the block's own words ran.
    pub(crate) fn take_calls(
        &mut self,
        unit: &Unit,
        w: &mut Words,
        ijk: &[(char, MVal, Span)],
    ) -> Result<Option<After>, NcError> {
        if let Some(&(code, _, gspan)) = w.g().iter().find(|g| g.1 == GGroup::MacroCall) {
            self.macro_call(unit, w, ijk, code, gspan)?;
            return Ok(None);
        }
        let src = &unit.src;
        let m98 = w.m.iter().find(|m| m.0 == 98).map(|m| m.1);
        let m99 = w.m.iter().find(|m| m.0 == 99).map(|m| m.1);
        if let (Some(_), Some(s)) = (m98, m99) {
            return Err(NcError::new(src, s, "M98 and M99 in one block"));
        }
        w.m.retain(|m| m.0 != 98 && m.0 != 99);
        if let Some(span) = m98 {
            return m98_call(src, w, span).map(Some);
        }
        if let Some(span) = m99 {
            let seq = match w.take('P') {
                Some(p) => Some(whole(p.v).filter(|&n| n > 0).ok_or_else(|| {
                    NcError::new(
                        src,
                        p.span,
                        format!("P{} is not a sequence number", fmt_num(p.v)),
                    )
                })?),
                None => None,
            };
            return Ok(Some(After::Return { seq, span }));
        }
        Ok(Some(After::Nothing))
    }

    /// A `G65`/`G66`/`G67` block (`code`, its G word at `gspan`): the block does nothing
    /// else, so every other word must be an argument.
    fn macro_call(
        &mut self,
        unit: &Unit,
        w: &mut Words,
        ijk: &[(char, MVal, Span)],
        code: u32,
        gspan: Span,
    ) -> Result<(), NcError> {
        let err = |span: Span, m: String| NcError::new(&unit.src, span, m);
        if let Some(other) = w.g().iter().find(|g| g.2 != gspan) {
            return Err(err(
                other.2,
                format!("G{} cannot share a block with G{code}", other.0),
            ));
        }
        // With G65/G66, M is argument #13 (it is not executed).
        if let Some(m) = w.m.get(1) {
            return Err(err(
                m.1,
                format!("address M given twice in a G{code} block"),
            ));
        }
        let m_arg = w.m.first().map(|m| (m.1.start, f64::from(m.0)));
        if code == 67 {
            self.flow.modal_call = None;
            return match w.first_unused() {
                Some((c, a)) => Err(err(a.span, format!("address {c} is not used with G67"))),
                None => Ok(()),
            };
        }
        let Some(p) = w.take('P') else {
            return Err(err(gspan, format!("G{code} needs P (the program number)"))
                .with_expected(format!("G{code} P9001 …")));
        };
        let number = whole(p.v)
            .filter(|&n| n <= 9999)
            .ok_or_else(|| err(p.span, format!("P{} is not a program number", fmt_num(p.v))))?;
        let times = take_repeats(&unit.src, w)?.unwrap_or(1);
        let args = macro_args(&unit.src, w, ijk, code, m_arg)?;
        if code == 65 {
            self.call(number, times, Some(args), &unit.src, gspan)?;
        } else {
            // Check the program exists now, where the G66 is.
            self.find_program(number, &unit.src, gspan)?;
            self.flow.modal_call = Some(ModalCall {
                number,
                times,
                args,
                depth: self.flow.frames.len(),
            });
        }
        Ok(())
    }

    /// After a block's words: `M98` call, `M99` return, or a `G66` modal call.
    pub(crate) fn after_block(
        &mut self,
        unit: &Unit,
        after: After,
        moved: bool,
    ) -> Result<(), NcError> {
        match after {
            After::Call {
                number,
                times,
                span,
            } => self.call(number, times, None, &unit.src, span),
            After::Return { seq, span } => self.ret(unit, seq, span),
            After::Nothing => {
                if moved
                    && let Some(mc) = self.flow.modal_call.clone()
                    && mc.depth == self.flow.frames.len()
                {
                    let span = unit
                        .line(
                            self.flow
                                .frames
                                .last()
                                .map_or(0, |f| f.pc.saturating_sub(1)),
                        )
                        .map_or_else(Span::default, |l| l.span);
                    self.call(mc.number, mc.times, Some(mc.args), &unit.src, span)?;
                }
                Ok(())
            }
        }
    }

    /// `G65 Hm P#i Q#j R#k`: the old macro instructions (Fanuc Custom Macro A).
    pub(crate) fn g65_h(&mut self, unit: &Unit, line: &Line, b: &Block) -> Result<(), NcError> {
        let src = unit.src.clone();
        let err = |span: Span, m: String| NcError::new(&src, span, m);
        let mut h = None;
        let mut p: Option<&cnc402_lang::ast::Word> = None;
        let mut q = None;
        let mut r = None;
        for w in &b.words {
            match w.letter {
                'G' => {}
                'H' => h = Some(w),
                'P' => p = Some(w),
                'Q' => q = Some(w),
                'R' => r = Some(w),
                c => {
                    return Err(err(w.span, format!("address {c} is not used in G65 H…"))
                        .with_expected("G65 Hm P#i Q#j R#k"));
                }
            }
        }
        let Some(hw) = h else { return Ok(()) };
        let hv = eval::value_in(&src, &hw.value, self)?;
        let Some(code) = hv.and_then(whole) else {
            return Err(err(hw.span, "H is not an instruction number".into()));
        };
        let qv = match q {
            Some(w) => eval::value_in(&src, &w.value, self)?.unwrap_or(0.0),
            None => 0.0,
        };
        let rv = match r {
            Some(w) => eval::value_in(&src, &w.value, self)?.unwrap_or(0.0),
            None => 0.0,
        };
        let p_span = p.map_or(hw.span, |w| w.span);
        // P as a destination `#i`.
        let dest = |this: &mut Self| -> Result<i64, NcError> {
            match p.map(|w| &w.value) {
                Some(Value::Expr(e)) => match &e.kind {
                    ExprKind::Var(n) => Ok(i64::from(*n)),
                    ExprKind::IndirectVar(i) => {
                        Ok(var_number(eval::eval(&src, i, this)?.unwrap_or(0.0)))
                    }
                    _ => Err(err(p_span, "P must name the result variable: P#i".into())),
                },
                _ => Err(err(
                    p_span,
                    format!("G65 H{code:02} needs P#i (the result variable)"),
                )),
            }
        };
        // P as a constant (sequence number, alarm number).
        let pconst = |this: &mut Self| -> Result<u32, NcError> {
            let v = match p {
                Some(w) => eval::value_in(&src, &w.value, this)?,
                None => None,
            };
            v.and_then(whole)
                .ok_or_else(|| err(p_span, format!("G65 H{code:02} needs P as a whole number")))
        };
        let result = match code {
            26 => {
                if rv == 0.0 {
                    return Err(err(line.span, "G65 H26: division by zero".into()));
                }
                let d = dest(self)?;
                let cur = self.read_var(d).map_err(|m| err(p_span, m))?.unwrap_or(0.0);
                cur * qv / rv
            }
            80..=86 => {
                let go = code == 80 || h_operator(code, qv, rv) == Some(Ok(1.0));
                let n = pconst(self)?;
                if go {
                    self.jump(unit, n, p_span)?;
                }
                return Ok(());
            }
            99 => {
                let n = pconst(self)?;
                let mut m = format!("alarm {}", 500 + n);
                if let Some(c) = line.comments.first() {
                    let t = c.text.trim();
                    if !t.is_empty() {
                        m.push_str(&format!(": {t}"));
                    }
                }
                return Err(err(line.span, m));
            }
            _ => match h_operator(code, qv, rv) {
                Some(v) => v.map_err(|m| err(line.span, m))?,
                None => {
                    return Err(
                        err(hw.span, format!("G65 H{code}: unknown macro instruction"))
                            .with_expected("H01-H05, H11-H13, H21-H28, H31-H34, H80-H86, H99"),
                    );
                }
            },
        };
        if !result.is_finite() {
            return Err(err(
                line.span,
                format!("G65 H{code:02}: the result is not a finite number"),
            ));
        }
        let d = dest(self)?;
        self.write_var(d, Some(result)).map_err(|m| err(p_span, m))
    }
}

/// `M98 P… [L…]` (the M98 at `span`): the call to make after the block's own words.
fn m98_call(src: &SourceFile, w: &mut Words, span: Span) -> Result<After, NcError> {
    let Some(p) = w.take('P') else {
        return Err(
            NcError::new(src, span, "M98 needs P (the program number)").with_expected("M98 P9001")
        );
    };
    let pv = whole(p.v).ok_or_else(|| {
        NcError::new(
            src,
            p.span,
            format!("P{} is not a program number", fmt_num(p.v)),
        )
    })?;
    // Fanuc 0: more than four digits = repeat count, then the program number.
    let (mut times, number) = if pv > 9999 {
        (pv / 10000, pv % 10000)
    } else {
        (1, pv)
    };
    if let Some(l) = take_repeats(src, w)? {
        times = l;
    }
    Ok(After::Call {
        number,
        times,
        span,
    })
}

/// The repeat count `L`, if the block gives one.
fn take_repeats(src: &SourceFile, w: &mut Words) -> Result<Option<u32>, NcError> {
    w.take('L')
        .map(|l| {
            whole(l.v).ok_or_else(|| {
                NcError::new(
                    src,
                    l.span,
                    format!("L{} is not a repeat count", fmt_num(l.v)),
                )
            })
        })
        .transpose()
}

/// The local variables `#1`…`#33` a `G<code>` call passes: its address words (specification
/// I), its I/J/K sets (II) and M (`m_arg`, #13), each at its source offset; a variable given
/// twice (D and the second set's I are both #7) takes the later word, as Fanuc mixes the
/// specifications. Any word left over is an error.
fn macro_args(
    src: &SourceFile,
    w: &mut Words,
    ijk: &[(char, MVal, Span)],
    code: u32,
    m_arg: Option<(u32, f64)>,
) -> Result<[MVal; 33], NcError> {
    let err = |span: Span, m: String| NcError::new(src, span, m);
    // (source offset, variable, value)
    let mut given = Vec::new();
    for c in 'A'..='Z' {
        if let Some(i) = arg_var(c)
            && let Some(a) = w.take(c)
        {
            given.push((a.span.start, i, a.v));
        }
    }
    if let Some((at, m)) = m_arg {
        given.push((at, 13, m));
    }
    given.extend(spec2_vars(ijk).map_err(|s| {
        err(
            s,
            format!("G{code}: more than 10 I/J/K sets (argument specification II)"),
        )
        .with_expected("at most I10 J10 K10 (#33)")
    })?);
    given.sort_by_key(|g| g.0);
    let mut args = [None; 33];
    for (_, i, v) in given {
        args[i - 1] = Some(v);
    }
    if let Some((c, a)) = w.first_unused() {
        return Err(
            err(a.span, format!("address {c} is not an argument of G{code}")).with_expected(
                "A-F, H, I-K, M, Q-Z (argument specification I; I J K may repeat: II)",
            ),
        );
    }
    Ok(args)
}

/// The value of the old macro instruction `G65 H<code>` on Q and R, for the instructions that
/// only compute: they are the expression operators under other names (H27, H28 are their own;
/// the messages are the instructions'). `None`: not such an instruction.
fn h_operator(code: u32, q: f64, r: f64) -> Option<Result<f64, String>> {
    let bin = |op: BinaryOp| ops::binary(op, q, r).map_err(|e| e.to_string());
    let func = |f: Func, a: f64| ops::call(f, a, 0.0, false).map_err(|e| e.to_string());
    Some(match code {
        1 => Ok(q),
        2 => bin(BinaryOp::Add),
        3 => bin(BinaryOp::Sub),
        4 => bin(BinaryOp::Mul),
        5 => bin(BinaryOp::Div).map_err(|e| format!("G65 H05: {e}")),
        11 => bin(BinaryOp::Or),
        12 => bin(BinaryOp::And),
        13 => bin(BinaryOp::Xor),
        21 => func(Func::Sqrt, q).map_err(|_| "G65 H21: square root of a negative number".into()),
        22 => func(Func::Abs, q),
        23 => bin(BinaryOp::Mod).map_err(|_| "G65 H23: remainder by zero".into()),
        24 => func(Func::Bin, q).map_err(|e| format!("G65 H24: BIN: {e}")),
        25 => func(Func::Bcd, q).map_err(|e| format!("G65 H25: BCD: {e}")),
        27 => Ok(q.hypot(r)),
        28 => {
            let d = q * q - r * r;
            if d < 0.0 {
                Err("G65 H28: square root of a negative number".into())
            } else {
                Ok(d.sqrt())
            }
        }
        31..=33 => {
            let f = [Func::Sin, Func::Cos, Func::Tan][code as usize - 31];
            func(f, r).and_then(|t| ops::binary(BinaryOp::Mul, q, t).map_err(|e| e.to_string()))
        }
        34 => ops::call(Func::Atan, q, r, true).map_err(|e| e.to_string()),
        81..=86 => {
            let op = [
                BinaryOp::Eq,
                BinaryOp::Ne,
                BinaryOp::Gt,
                BinaryOp::Lt,
                BinaryOp::Ge,
                BinaryOp::Le,
            ][code as usize - 81];
            bin(op)
        }
        _ => return None,
    })
}

/// Whether the `%` at line `pc` of `unit` is its opening one: only `%` and empty lines come
/// before it in the unit (a streamed view, which holds one line, never says so).
fn opens_unit(unit: &Unit, pc: usize) -> bool {
    (unit.start..pc).all(|i| {
        matches!(
            unit.line(i).map(|l| &l.kind),
            Some(LineKind::Empty | LineKind::Percent)
        )
    })
}
