//! LinuxCNC's O-word flow (the `linuxcnc` dialect): subroutines (`sub`/`endsub`/`return`/
//! `call`, with `#1`-`#30` and named locals per call and the returned value in `#<_value>`),
//! `if`/`elseif`/`else`/`endif`, `while`, `do … while`, `repeat`, `break`, `continue`, and
//! the named parameters as a program reads and writes them (LinuxCNC's predefined `#<_x>` …).
//! Lines with the same label are paired once per program unit (`oindex`); every loop still
//! counts toward the runaway guard, and calls toward the frame limit.

use std::sync::Arc;

use cnc402_lang::ast::{Expr, Line, OLabel, OWord, OWordKind};
use cnc402_lang::{Dialect, NcError};

use super::Interpreter;
use super::oindex::{kind_word, oword_of};
use super::units::{Frame, MAX_FRAMES, Unit, split_units};
use crate::expr as eval;
use crate::vars::MVal;

/// Most arguments a call passes (`#1`-`#30`).
pub const MAX_ARGS: usize = 30;

/// Most times one `repeat` runs: a count past it is a program error, not a hang.
pub const MAX_REPEAT: f64 = 1e9;

impl Interpreter {
    /// Executes the O-word line `pc` of `unit`.
    pub(crate) fn oword(
        &mut self,
        unit: &Arc<Unit>,
        line: &Line,
        pc: usize,
        o: &OWord,
    ) -> Result<(), NcError> {
        self.flow.seen_block = true;
        let err = |m: String| NcError::new(&unit.src, line.span, m);
        if let Some(m) = unit.ix.owords.errors.get(&pc) {
            return Err(err(m.clone()));
        }
        if let OWordKind::Call(args) = &o.kind {
            return self.o_call(unit, line, o, args);
        }
        let Some(&link) = unit.ix.owords.links.get(&pc) else {
            return Err(err(format!(
                "{} {}: not paired",
                o.label,
                kind_word(&o.kind)
            )));
        };
        match &o.kind {
            OWordKind::Sub => self.set_pc(link.end + 1),
            OWordKind::EndSub(v) | OWordKind::Return(v) => return self.o_return(unit, line, v),
            OWordKind::If(c) => {
                if !self.o_truth(unit, c)? {
                    let mut at = link.next;
                    // Each step moves forward to the next branch: at most the branches.
                    while let Some(v) = self.line_view(unit, at)?
                        && let Some(OWordKind::ElseIf(c2)) =
                            oword_of(&v.program, at - v.base).map(|o| &o.kind)
                    {
                        if self.o_truth(&v, c2)? {
                            break;
                        }
                        at = unit.ix.owords.links.get(&at).map_or(link.end, |l| l.next);
                    }
                    self.set_pc(at + 1);
                }
            }
            // Reached from the branch before: it ran, the others are skipped.
            OWordKind::ElseIf(_) | OWordKind::Else => self.set_pc(link.end + 1),
            OWordKind::EndIf | OWordKind::Do => {}
            OWordKind::While(c) if pc == link.end => {
                if self.o_truth(unit, c)? {
                    self.set_pc(link.head + 1);
                }
            }
            OWordKind::While(c) => {
                if !self.o_truth(unit, c)? {
                    self.set_pc(link.end + 1);
                }
            }
            OWordKind::EndWhile => self.set_pc(link.head),
            OWordKind::Repeat(c) => {
                let n = self.o_value(unit, c)?.round();
                if n.is_nan() || n > MAX_REPEAT {
                    return Err(NcError::new(
                        &unit.src,
                        c.span,
                        format!("repeat count {n} is more than {MAX_REPEAT}"),
                    ));
                }
                let Some(f) = self.flow.frames.last_mut() else {
                    return Ok(());
                };
                f.repeat_left.retain(|r| r.0 != pc);
                if n >= 1.0 {
                    f.repeat_left.push((pc, n as u64));
                } else {
                    f.pc = link.end + 1;
                }
            }
            OWordKind::EndRepeat => {
                let Some(f) = self.flow.frames.last_mut() else {
                    return Ok(());
                };
                if let Some(k) = f.repeat_left.iter().position(|r| r.0 == link.head) {
                    f.repeat_left[k].1 -= 1;
                    if f.repeat_left[k].1 > 0 {
                        f.pc = link.head + 1;
                    } else {
                        f.repeat_left.remove(k);
                    }
                }
            }
            OWordKind::Break => {
                if let Some(f) = self.flow.frames.last_mut() {
                    f.repeat_left.retain(|r| r.0 != link.head);
                }
                self.set_pc(link.end + 1);
            }
            OWordKind::Continue => {
                let head = self.line_view(unit, link.head)?;
                let head = head
                    .as_ref()
                    .and_then(|v| oword_of(&v.program, link.head - v.base));
                match head.map(|o| &o.kind) {
                    Some(OWordKind::While(_)) => self.set_pc(link.head),
                    _ => self.set_pc(link.end),
                }
            }
            OWordKind::Call(_) => {}
        }
        Ok(())
    }

    fn o_value(&mut self, unit: &Unit, e: &Expr) -> Result<f64, NcError> {
        Ok(eval::eval(&unit.src, e, self)?.unwrap_or(0.0))
    }

    fn o_truth(&mut self, unit: &Unit, e: &Expr) -> Result<bool, NcError> {
        Ok(self.o_value(unit, e)? != 0.0)
    }

    /// `o… call [args]`: the subroutine of that label in this file, run with its own `#1`-`#30`
    /// (the arguments) and named locals.
    fn o_call(
        &mut self,
        unit: &Arc<Unit>,
        line: &Line,
        o: &OWord,
        args: &[Expr],
    ) -> Result<(), NcError> {
        let err = |m: String| NcError::new(&unit.src, o.label_span, m);
        let mut target = std::iter::once(unit)
            .chain(self.flow.units.iter())
            .find_map(|u| u.ix.owords.subs.get(&o.label).map(|&i| (u.clone(), i)));
        if let (None, OLabel::Name(name)) = (&target, &o.label) {
            target = self.o_file(name, unit, o)?;
        }
        let Some((sub_unit, at)) = target else {
            let elsewhere = match &o.label {
                OLabel::Number(_) => String::new(),
                OLabel::Name(s) => format!(", nor in a file {s}.ngc next to it or in the library"),
            };
            return Err(err(format!(
                "subroutine {l} is not defined in {}{elsewhere} ({l} sub … endsub)",
                unit.src.name,
                l = o.label,
            )));
        };
        if self.flow.frames.len() >= MAX_FRAMES {
            return Err(NcError::new(
                &unit.src,
                line.span,
                format!("calls nested deeper than {MAX_FRAMES} levels"),
            ));
        }
        let mut locals: [MVal; 33] = [None; 33];
        for (slot, a) in locals.iter_mut().zip(args.iter().take(MAX_ARGS)) {
            *slot = Some(self.o_value(unit, a)?);
        }
        self.vars.named.set("_value_returned", 0.0).map_err(err)?;
        let mut f = Frame::new(sub_unit, true);
        f.pc = at + 1;
        f.o_call = true;
        self.vars.table.locals.push(locals);
        self.vars.named.push_scope();
        self.flow.frames.push(f);
        Ok(())
    }

    /// LinuxCNC's subroutine file for `o<name> call`: `name.ngc` from the program library
    /// (next to the main program, then in `interp.library_dir`), read once, in the LinuxCNC
    /// dialect. `None` when there is no such file or it does not define `o<name>`.
    fn o_file(
        &mut self,
        name: &str,
        unit: &Unit,
        o: &OWord,
    ) -> Result<Option<(Arc<Unit>, usize)>, NcError> {
        let found = |u: &Arc<Unit>| u.ix.owords.subs.get(&o.label).map(|&i| (u.clone(), i));
        if let Some(u) = self.flow.o_files.get(name) {
            return Ok(found(u));
        }
        let main = self.flow.main_src.name.clone();
        let Some(lib) = self.flow.library.as_mut() else {
            return Ok(None);
        };
        let used = lib
            .resolve_use(&format!("{name}.ngc"), &main)
            .map_err(|e| NcError::new(&unit.src, o.label_span, format!("{}: {e}", o.label)))?;
        let Some(used) = used else {
            return Ok(None);
        };
        let program = Arc::new(cnc402_lang::parse_in(&used.file, Dialect::LinuxCnc)?);
        let file = Arc::new(used.file);
        let (units, main_unit) = split_units(&file, &program);
        let u = units[main_unit].clone();
        // One entry per subroutine name the program calls: bounded by its text.
        self.flow.o_files.insert(name.to_string(), u.clone());
        Ok(found(&u))
    }

    /// `endsub [v]` / `return [v]`: back to the caller, `#<_value>` set to `v`.
    fn o_return(&mut self, unit: &Arc<Unit>, line: &Line, v: &Option<Expr>) -> Result<(), NcError> {
        let in_call =
            self.flow.frames.len() > 1 && self.flow.frames.last().is_some_and(|f| f.o_call);
        if !in_call {
            return Err(NcError::new(
                &unit.src,
                line.span,
                "return from a subroutine that was not called",
            ));
        }
        let value = match v {
            Some(e) => Some(self.o_value(unit, e)?),
            None => None,
        };
        let set = |n: &mut crate::vars::NamedVars| -> Result<(), String> {
            if let Some(x) = value {
                n.set("_value", x)?;
            }
            n.set("_value_returned", if value.is_some() { 1.0 } else { 0.0 })
        };
        set(&mut self.vars.named).map_err(|m| NcError::new(&unit.src, line.span, m))?;
        self.flow.frames.pop();
        self.vars.table.locals.pop();
        self.vars.named.pop_scope();
        Ok(())
    }

    /// `#<name>` as the program reads it: LinuxCNC's predefined names, else what the program
    /// assigned; an unassigned name is an error (LinuxCNC).
    pub(crate) fn read_named(&mut self, name: &str) -> Result<MVal, String> {
        if let Some(v) = self.predefined(name)? {
            return Ok(Some(v));
        }
        match self.vars.named.get(name) {
            Some(v) => Ok(Some(v)),
            None if name == "_value" || name == "_value_returned" => Ok(Some(0.0)),
            None => Err(format!("named parameter #<{name}> is not defined")),
        }
    }

    /// `#<name> = v`; the predefined names are read-only.
    pub(crate) fn write_named(&mut self, name: &str, v: MVal) -> Result<(), String> {
        if self.predefined(name)?.is_some() {
            return Err(format!("#<{name}> is predefined and read-only"));
        }
        self.vars.named.set(name, v.unwrap_or(0.0))
    }

    /// LinuxCNC's predefined named parameters that cnc402 knows (`None`: not one of them).
    fn predefined(&mut self, name: &str) -> Result<MVal, String> {
        let read = |it: &mut Self, n: i64| it.read_var(n).map(|v| v.unwrap_or(0.0));
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        Ok(Some(match name {
            "_x" | "_y" | "_z" | "_a" | "_b" | "_c" | "_u" | "_v" | "_w" => {
                let axis = name.as_bytes()[1].to_ascii_uppercase() as char;
                return self.axis_position(axis).map(Some);
            }
            "_metric" => flag(read(self, 4006)? == 21.0),
            "_imperial" => flag(read(self, 4006)? == 20.0),
            "_absolute" => flag(read(self, 4003)? == 90.0),
            "_incremental" => flag(read(self, 4003)? == 91.0),
            "_feed" => read(self, 4109)?,
            "_rpm" => read(self, 4119)?,
            "_current_tool" => read(self, 4120)?,
            "_call_level" => self.flow.frames.iter().filter(|f| f.o_call).count() as f64,
            _ => return Ok(None),
        }))
    }

    /// The programmed position of `axis` in work coordinates, program units (0 when the
    /// machine has no such axis, as LinuxCNC reads an absent axis).
    pub(crate) fn axis_position(&mut self, axis: char) -> Result<f64, String> {
        match self.m.cfg.axes.iter().position(|a| a.name == axis) {
            Some(i) => Ok(self.read_var(5001 + i as i64)?.unwrap_or(0.0)),
            None => Ok(0.0),
        }
    }
}

/// LinuxCNC's `#5599`: whether `(debug,…)` comments print.
pub(crate) const LC_DEBUG_SWITCH: i64 = 5599;

/// A LinuxCNC program's numbered parameter read: vacant reads as 0 (LinuxCNC has no
/// vacant), and `#5420`-`#5428` are the current X Y Z A B C U V W.
pub(crate) fn linuxcnc_read(it: &mut Interpreter, n: i64) -> Result<MVal, String> {
    if (5420..=5428).contains(&n) {
        let axis = b"XYZABCUVW"[(n - 5420) as usize] as char;
        return it.axis_position(axis).map(Some);
    }
    if n == LC_DEBUG_SWITCH {
        return Ok(Some(it.flow.lc_debug_switch));
    }
    if let Some(&v) = it.flow.lc_globals.get(&n) {
        return Ok(Some(v));
    }
    Ok(Some(it.read_var(n)?.unwrap_or(0.0)))
}
