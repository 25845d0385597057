//! The machine's own M codes (`[mcodes]` in the config): a block's M words that are not the
//! interpreter's own become what the config maps them to — built-in codes (M13 = M3 M8), a
//! dwell, an output or wait event, a note, or a program call (Fanuc's M-code macro call);
//! and Fanuc's multi-path waiting M codes (`M100 P12`), a channel wait.
//! In the linuxcnc dialect LinuxCNC's own I/O codes M62-M68 are built in.

use cnc402_config::{BUILT_IN_M_CODES, MAction, MachineConfig};
use cnc402_lang::ast::{Line, Span};
use cnc402_lang::{Dialect, NcError, SourceFile};
use cnc402_motion::segment::{SegmentKind, Source, StopKind};

use super::Machine;
use super::exec::Exec;
use super::words::{Arg, GGroup, Words, fmt_num};
use crate::canon::CanonOp;
use crate::host::channels::{Seat, mask_has};

/// Turns a block's macro M code (`action = "macro"`) into the call it stands for, before the
/// block's calls are taken: `M98 P<program>` (Fanuc's sub-program call by M code), or with
/// `args = true` `G65 P<program>` with the block's other words as arguments (custom macro
/// call by M code). A block may hold one; it may not give `P` itself.
pub(crate) fn macro_calls(
    cfg: &MachineConfig,
    src: &SourceFile,
    w: &mut Words,
) -> Result<(), NcError> {
    if w.g().iter().any(|g| g.1 == GGroup::MacroCall) {
        // In a G65/G66 block M is argument #13, not a code.
        return Ok(());
    }
    let mut calls =
        w.m.iter()
            .filter_map(|&(code, span)| match cfg.mcodes.get(&code) {
                Some(&MAction::Macro { program, args }) => Some((code, span, program, args)),
                _ => None,
            });
    let Some((code, span, program, args)) = calls.next() else {
        return Ok(());
    };
    if let Some((second, s2, ..)) = calls.next() {
        return Err(NcError::new(
            src,
            s2,
            format!("M{code} and M{second} both call a program: one call a block"),
        ));
    }
    let p = Arg {
        v: f64::from(program),
        span,
        has_point: false,
    };
    if !w.put('P', p) {
        let at = w.peek('P').map_or(span, |a| a.span);
        return Err(NcError::new(
            src,
            at,
            format!("M{code} calls O{program:04} ([mcodes] {code}): the block cannot give P too"),
        ));
    }
    w.m.retain(|m| m.0 != code);
    if args {
        w.push_g(65, GGroup::MacroCall, span);
    } else {
        w.m.push((98, span));
    }
    Ok(())
}

impl Exec<'_> {
    /// Replaces the block's machine M codes by what `[mcodes]` maps them to; an M code neither
    /// built in nor configured is an error at its word.
    pub(crate) fn machine_m_codes(&mut self) -> Result<(), NcError> {
        let ms = std::mem::take(&mut self.w.m);
        for (code, span) in ms {
            if BUILT_IN_M_CODES.contains(&code) {
                self.w.m.push((code, span));
                continue;
            }
            if self.dialect == Dialect::LinuxCnc
                && !self.cfg.mcodes.contains_key(&code)
                && (62..=68).contains(&code)
            {
                self.linuxcnc_io(code, span)?;
                continue;
            }
            let Some(action) = self.cfg.mcodes.get(&code) else {
                return Err(self
                    .err(span, format!("unknown M code M{code}"))
                    .with_expected(format!(
                        "a built-in M code, or M{code} mapped in the config's [mcodes]"
                    )));
            };
            match action {
                MAction::Alias { codes } => self.w.m.extend(codes.iter().map(|&c| (c, span))),
                MAction::Dwell { seconds } => {
                    if *seconds > 0.0 {
                        self.push(SegmentKind::Dwell { seconds: *seconds });
                    }
                }
                MAction::Ignore { note } => {
                    if !self.st.noted_mcodes.contains(&code) {
                        self.st.noted_mcodes.push(code);
                        let why = note.as_deref().map(|n| format!(": {n}")).unwrap_or_default();
                        self.push(SegmentKind::Message {
                            text: format!("M{code} ignored on this machine ([mcodes]){why}"),
                        });
                    }
                }
                MAction::Output { name, value } => self.push(SegmentKind::Message {
                    text: format!("M{code}: output {name} = {}", u8::from(*value)),
                }),
                MAction::Wait {
                    name,
                    value,
                    timeout_s,
                } => self.push(SegmentKind::Message {
                    text: format!(
                        "M{code}: wait for input {name} = {} (timeout {} s): no inputs are wired yet, taken as met",
                        u8::from(*value),
                        fmt_num(*timeout_s)
                    ),
                }),
                MAction::Macro { program, .. } => {
                    // Blocks of Macro B programs had it turned into a call already.
                    return Err(self.err(
                        span,
                        format!("M{code} calls O{program:04}: a program call is not possible here"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// LinuxCNC's I/O codes, built into its dialect: M62/M63 (digital output on/off with the
    /// next move), M64/M65 (at once), M66 (wait on a digital `P` or analog `E` input, mode
    /// `L` 0-4, timeout `Q` s), M67/M68 (analog output `E` to `Q`). Until machine I/O is wired
    /// they are message events, as `[mcodes]` outputs and waits are; a wait is taken as met.
    fn linuxcnc_io(&mut self, code: u32, span: Span) -> Result<(), NcError> {
        let index = |e: &mut Self, letter: char| -> Result<u32, NcError> {
            match e.w.take(letter) {
                Some(a) if a.v >= 0.0 && a.v.fract() == 0.0 && a.v < 1000.0 => Ok(a.v as u32),
                Some(a) => Err(e
                    .err(
                        a.span,
                        format!("M{code} {letter}{}: not a pin number", fmt_num(a.v)),
                    )
                    .with_expected(format!("{letter} as a whole number 0..999"))),
                None => Err(e
                    .err(span, format!("M{code} needs {letter} (the pin number)"))
                    .with_expected(format!("M{code} {letter}0"))),
            }
        };
        let text = match code {
            62..=65 => {
                let pin = index(self, 'P')?;
                let on = code.is_multiple_of(2);
                let when = if code < 64 {
                    "with the next move"
                } else {
                    "now"
                };
                format!("M{code}: digital output {pin} = {} ({when})", u8::from(on))
            }
            66 => {
                let (kind, pin) = match (self.w.has('P'), self.w.has('E')) {
                    (true, false) => ("digital", index(self, 'P')?),
                    (false, true) => ("analog", index(self, 'E')?),
                    _ => {
                        return Err(self
                            .err(span, "M66 needs exactly one of P (digital) or E (analog)")
                            .with_expected("M66 P0 L3 Q5"));
                    }
                };
                let mode = match self.w.take('L') {
                    None => 0,
                    Some(a) if a.v.fract() == 0.0 && (0.0..=4.0).contains(&a.v) => a.v as u32,
                    Some(a) => {
                        return Err(self
                            .err(a.span, format!("M66 L{}: not a wait mode", fmt_num(a.v)))
                            .with_expected("L0 (now) .. L4 (low)"));
                    }
                };
                let timeout = self.w.take('Q').map_or(0.0, |q| q.v);
                if mode != 0 && !(timeout > 0.0 && timeout.is_finite()) {
                    return Err(self
                        .err(
                            span,
                            format!("M66 L{mode} waits, so it needs a timeout Q > 0"),
                        )
                        .with_expected("M66 P0 L3 Q5"));
                }
                format!(
                    "M66: wait for {kind} input {pin} (mode L{mode}, timeout {} s): no inputs are wired yet, taken as met",
                    fmt_num(timeout)
                )
            }
            _ => {
                let pin = index(self, 'E')?;
                let value = if code == 67 || code == 68 {
                    self.w.take('Q').map_or(0.0, |q| q.v)
                } else {
                    0.0
                };
                format!("M{code}: analog output {pin} = {}", fmt_num(value))
            }
        };
        self.push(SegmentKind::Message { text });
        Ok(())
    }
}

/// Takes the block's Fanuc multi-path waiting M code (`[interp] wait_mcodes`, `M100`…`M199`
/// by default; a code mapped in `[mcodes]` is that action instead) and its `P` out of the
/// block: the `WaitMark` stop it stands for, made after the block's motion. `P` names the
/// paths as Fanuc does, a digit per path (`P12` = paths 1 and 2 = channels 0 and 1); without
/// `P` every channel waits. A path the machine lacks, or `P` without the calling channel's
/// path, is an error at the word. Not in the linuxcnc dialect, whose `M100`…`M199` are user
/// programs.
pub(crate) fn wait_mcode(
    cfg: &MachineConfig,
    (src, dialect): (&SourceFile, Dialect),
    w: &mut Words,
    seat: Seat,
) -> Result<Option<StopKind>, NcError> {
    let Some((first, last)) = cfg.interp.wait_mcodes else {
        return Ok(None);
    };
    if dialect == Dialect::LinuxCnc {
        return Ok(None);
    }
    if w.g().iter().any(|g| g.1 == GGroup::MacroCall) {
        return Ok(None);
    }
    let is_wait = |c: u32| (first..=last).contains(&c) && !cfg.mcodes.contains_key(&c);
    let mut waits = w.m.iter().filter(|m| is_wait(m.0));
    let Some(&(code, _)) = waits.next() else {
        return Ok(None);
    };
    let err = |at: Span, m: String| Err(NcError::new(src, at, m));
    if let Some(&(second, s2)) = waits.next() {
        return err(
            s2,
            format!("M{code} and M{second} are both waits: one a block"),
        );
    }
    if let Some(&(other, s2)) = w.m.iter().find(|m| matches!(m.0, 2 | 30 | 98 | 99)) {
        let m = match other {
            2 | 30 => {
                format!("M{other} ends the program: the wait M{code} goes in a block before it")
            }
            _ => {
                format!("M{other} takes a P word too: the wait M{code} goes in a block of its own")
            }
        };
        return err(s2, m);
    }
    w.m.retain(|m| m.0 != code);
    let channels = match w.take('P') {
        None => 0,
        Some(p) => path_mask(code, &p, seat).map_err(|m| NcError::new(src, p.span, m))?,
    };
    Ok(Some(StopKind::WaitMark {
        mark: code as u16,
        channels,
    }))
}

/// `P` of a waiting M code: a digit 1…9 per path (channel = path - 1), as a channel mask.
fn path_mask(code: u32, p: &Arg, seat: Seat) -> Result<u16, String> {
    let text = fmt_num(p.v);
    if p.v.fract() != 0.0 || !(1.0..=999_999_999.0).contains(&p.v) {
        return Err(format!(
            "M{code} P{text}: P lists the waiting paths, a digit 1-9 each (P12 = paths 1 and 2)"
        ));
    }
    let mut bits = 0u16;
    let digits = (p.v as u64).to_string();
    for d in digits.bytes().map(|b| usize::from(b.wrapping_sub(b'0'))) {
        if d == 0 || d > seat.count {
            return Err(format!(
                "M{code} P{text}: path {d} is not one of this machine's paths (1..={}, \
                 channel n is path n + 1)",
                seat.count
            ));
        }
        bits |= 1 << (d - 1);
    }
    if !mask_has(bits, seat.this) {
        return Err(format!(
            "M{code} P{text}: leaves out path {} (channel {}), the one waiting",
            seat.this + 1,
            seat.this
        ));
    }
    Ok(bits)
}

/// The channel wait of a wait M code of `line` (after the block's operations).
pub(crate) fn wait_op(m: &mut Machine, kind: StopKind, src: &SourceFile, line: &Line) -> CanonOp {
    let source = Source {
        file: src.name.clone(),
        line: line.line_no,
        n: line.n.map(|n| n.value),
    };
    m.single_op(SegmentKind::Stop { kind }, source)
}
