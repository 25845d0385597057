//! The executor of a checked C-like program. It runs on its own thread and hands G-code
//! blocks, messages and dwells to the interpreter through a channel; a motion-dependent
//! system variable is a request answered only after every earlier segment was handed out.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};

use cnc402_config::MachineConfig;
use cnc402_lang::NcError;
use cnc402_lang::ast::{AssignOp, BinaryOp, Block, LineKind, Number, Span, Value, Word};

use super::compile::{axis_of, op_text};
use super::globals::{Global, Globals, from_shared, lock, to_shared};
use super::ir::*;
use super::req::{ChannelCall, Read, Req};
use crate::host::channels::{Seat, check_mask, no_such_channel};
use cnc402_motion::segment::{SegmentKind, StopKind};

/// Deepest chain of user-function calls before the program is stopped.
pub const MAX_CALL_DEPTH: u32 = 200;
/// Requests sent to the interpreter in one hand-off (fewer at the end, at a system variable
/// read, or after [`FLUSH_AFTER`] statements while the interpreter waits).
const BATCH: usize = 32;
/// Statements after which pending requests go out if the interpreter is waiting for them.
const FLUSH_AFTER: u32 = 64;
/// Largest local array.
pub const MAX_ARRAY_LEN: i64 = 1_000_000;
/// Most elements of local arrays alive at once, over every running function: a recursive
/// function with a large local array would otherwise exhaust the memory (200 levels of
/// `MAX_ARRAY_LEN` are 6 GB) and abort instead of stopping with an error.
pub const MAX_LIVE_ELEMENTS: usize = 4_000_000;
/// Longest string a `+` may make (a doubling loop would otherwise exhaust the memory).
pub const MAX_STRING_LEN: usize = 1 << 20;

/// Why execution stopped early.
pub(crate) enum Stop {
    Err(Box<NcError>),
    /// The interpreter is gone (end of program, error there, or dropped).
    Hangup,
}

type R<T> = Result<T, Stop>;

enum Flow {
    Next,
    Break,
    Continue,
    Return(Option<Val>),
}

/// A running function: its locals are `Executor::stack[base..base + slots]`.
struct Frame {
    file: FileId,
    base: usize,
}

pub(crate) struct Executor {
    pub prog: Arc<Prog>,
    pub cfg: MachineConfig,
    pub globals: Globals,
    pub seat: Seat,
    pub tx: SyncSender<Req>,
    pub rx: Receiver<Result<f64, String>>,
    /// Set by the interpreter while it waits for requests: send what is pending now.
    waiting: Arc<AtomicBool>,
    /// Set when the interpreter drops the program: stop at the next statement or loop turn.
    halt: Arc<AtomicBool>,
    /// Requests not sent yet (sent in batches: one channel hand-off per batch).
    pending: Vec<Req>,
    /// Statements since the last batch was sent.
    since_flush: u32,
    ran: Vec<bool>,
    /// The locals of every running function, callers below callees: one stack (rather than
    /// a vector per call) lets an array parameter refer to its caller's array by index.
    stack: Vec<Val>,
    /// Elements of the local arrays on `stack` (at most [`MAX_LIVE_ELEMENTS`]).
    live: usize,
    depth: u32,
    steps: u64,
    limit: u64,
}

impl Executor {
    pub(crate) fn new(
        prog: Arc<Prog>,
        cfg: MachineConfig,
        (globals, seat): (Globals, Seat),
        (tx, rx): (SyncSender<Req>, Receiver<Result<f64, String>>),
        waiting: Arc<AtomicBool>,
        halt: Arc<AtomicBool>,
    ) -> Self {
        let n = prog.files.len();
        let limit = cfg.interp.block_limit.max(1);
        Executor {
            prog,
            cfg,
            globals,
            seat,
            tx,
            rx,
            waiting,
            halt,
            pending: Vec::with_capacity(BATCH),
            since_flush: 0,
            ran: vec![false; n],
            stack: Vec::with_capacity(256),
            live: 0,
            depth: 0,
            steps: 0,
            limit,
        }
    }

    /// Runs the main program to its end and tells the interpreter how it ended.
    pub(crate) fn run(mut self) {
        let r = self.run_file(0);
        let last = match r {
            Ok(()) => Req::End,
            Err(Stop::Err(e)) => Req::Error(e),
            Err(Stop::Hangup) => return,
        };
        self.pending.push(last);
        let _ = self.flush();
    }

    fn run_file(&mut self, file: FileId) -> R<()> {
        if self.ran[file] {
            return Ok(());
        }
        self.ran[file] = true;
        let prog = self.prog.clone();
        let f = &prog.funcs[prog.bodies[file]];
        let base = self.stack.len();
        self.stack.resize(base + f.slots as usize, Val::Int(0));
        let mut frame = Frame { file, base };
        let r = self.block(&mut frame, &f.body).map(|_| ());
        self.pop_frame(base);
        r
    }

    /// Drops the locals from `base` up (a function's frame), and counts its arrays as freed.
    fn pop_frame(&mut self, base: usize) {
        for v in self.stack.get(base..).unwrap_or_default() {
            if let Val::Arr(a) = v {
                self.live = self.live.saturating_sub(a.len());
            }
        }
        self.stack.truncate(base);
    }

    fn err(&self, f: &Frame, span: Span, m: impl Into<String>) -> Stop {
        Stop::Err(Box::new(NcError::new(&self.prog.files[f.file], span, m)))
    }

    fn send(&mut self, r: Req) -> R<()> {
        self.pending.push(r);
        if self.pending.len() >= BATCH {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> R<()> {
        if self.pending.is_empty() {
            return Ok(());
        }
        self.since_flush = 0;
        let batch = std::mem::replace(&mut self.pending, Vec::with_capacity(BATCH));
        self.tx.send(Req::Batch(batch)).map_err(|_| Stop::Hangup)
    }

    fn read(&mut self, f: &Frame, what: Read, span: Span) -> R<f64> {
        self.ask(f, Req::Read(what), span)
    }

    /// Sends `req` with everything before it and waits for the interpreter's answer.
    fn ask(&mut self, f: &Frame, req: Req, span: Span) -> R<f64> {
        self.pending.push(req);
        self.flush()?;
        match self.rx.recv() {
            Ok(Ok(v)) => Ok(v),
            Ok(Err(m)) => Err(self.err(f, span, m)),
            Err(_) => Err(Stop::Hangup),
        }
    }

    fn block(&mut self, f: &mut Frame, body: &[St]) -> R<Flow> {
        for s in body {
            match self.stmt(f, s)? {
                Flow::Next => {}
                other => return Ok(other),
            }
        }
        Ok(Flow::Next)
    }

    fn tick(&mut self, f: &Frame, span: Span) -> R<()> {
        // A program that computes between blocks must not hold back the blocks it made
        // while the interpreter waits for them.
        self.since_flush += 1;
        if self.since_flush >= FLUSH_AFTER
            && !self.pending.is_empty()
            && self.waiting.load(Ordering::Relaxed)
        {
            self.flush()?;
        }
        if self.halt.load(Ordering::Relaxed) {
            return Err(Stop::Hangup);
        }
        self.steps += 1;
        if self.steps > self.limit {
            return Err(self.err(
                f,
                span,
                format!(
                    "runaway: {} statements without motion, a message or a dwell (config \
                     interp.block_limit)",
                    self.limit
                ),
            ));
        }
        Ok(())
    }

    fn stmt(&mut self, f: &mut Frame, s: &St) -> R<Flow> {
        match s {
            St::Decl {
                slot,
                ty,
                size,
                init,
                span,
            } => {
                self.tick(f, *span)?;
                let v = match (size, init) {
                    (Some(n), _) => {
                        let n = self.ev(f, n)?;
                        let n = self.int(f, &n, *span, "an array size")?;
                        if !(0..=MAX_ARRAY_LEN).contains(&n) {
                            return Err(self.err(
                                f,
                                *span,
                                format!("array size {n} is out of range 0..{MAX_ARRAY_LEN}"),
                            ));
                        }
                        // A declaration run again (in a loop) replaces the array it made before.
                        let old = match self.stack.get(f.base + *slot as usize) {
                            Some(Val::Arr(a)) => a.len(),
                            _ => 0,
                        };
                        let live = self.live.saturating_sub(old) + n as usize;
                        if live > MAX_LIVE_ELEMENTS {
                            return Err(self.err(
                                f,
                                *span,
                                format!(
                                    "arrays too large: {live} elements would be alive at once \
                                     (at most {MAX_LIVE_ELEMENTS}, over every running function)"
                                ),
                            ));
                        }
                        self.live = live;
                        Val::Arr(vec![Val::zero(*ty); n as usize])
                    }
                    (None, Some(e)) => {
                        let v = self.ev(f, e)?;
                        self.coerce(f, *ty, v, *span)?
                    }
                    (None, None) => Val::zero(*ty),
                };
                self.stack[f.base + *slot as usize] = v;
            }
            St::Set {
                target,
                op,
                value,
                span,
            } => {
                self.tick(f, *span)?;
                let v = self.ev(f, value)?;
                self.assign(f, target, *op, v, *span)?;
            }
            St::Eval(e) => {
                self.steps += 1;
                self.ev(f, e)?;
            }
            St::If(c, t, o) => {
                self.steps += 1;
                let b = if self.truth(f, c)? { t } else { o };
                return self.block(f, b);
            }
            St::While(c, body, span) => loop {
                self.steps += 1;
                if self.steps > self.limit || self.halt.load(Ordering::Relaxed) {
                    self.tick(f, *span)?;
                }
                if !self.truth(f, c)? {
                    break;
                }
                match self.block(f, body)? {
                    Flow::Break => break,
                    r @ Flow::Return(_) => return Ok(r),
                    Flow::Next | Flow::Continue => {}
                }
            },
            St::For(init, c, step, body, span) => {
                if let r @ Flow::Return(_) = self.block(f, init)? {
                    return Ok(r);
                }
                loop {
                    self.steps += 1;
                    if self.steps > self.limit || self.halt.load(Ordering::Relaxed) {
                        self.tick(f, *span)?;
                    }
                    if let Some(c) = c
                        && !self.truth(f, c)?
                    {
                        break;
                    }
                    match self.block(f, body)? {
                        Flow::Break => break,
                        r @ Flow::Return(_) => return Ok(r),
                        Flow::Next | Flow::Continue => {}
                    }
                    self.block(f, step)?;
                }
            }
            St::Break => return Ok(Flow::Break),
            St::Continue => return Ok(Flow::Continue),
            St::Return(e) => {
                let v = match e {
                    Some(e) => Some(self.ev(f, e)?),
                    None => None,
                };
                return Ok(Flow::Return(v));
            }
            St::Gcode(g) => self.gcode(f, g)?,
            St::Use(file) => self.run_file(*file)?,
        }
        Ok(Flow::Next)
    }

    fn gcode(&mut self, f: &mut Frame, g: &GLine) -> R<()> {
        let mut words = Vec::with_capacity(g.words.len() + g.named.len());
        for (letter, v, span) in &g.words {
            let n = match v {
                WordVal::Num(n) => *n,
                WordVal::Ex(x) => {
                    let value = match self.ev(f, x)? {
                        Val::Int(i) => i as f64,
                        Val::Dbl(d) => d,
                        v => self.num(f, &v, *span, &format!("address {letter}"))?,
                    };
                    Number {
                        value,
                        has_point: true,
                        span: *span,
                    }
                }
            };
            words.push(Word {
                letter: *letter,
                value: Value::Number(n),
                span: *span,
            });
        }
        for (ax, v, span) in &g.named {
            let name = self.ev(f, ax)?;
            let Val::Str(name) = name else {
                return Err(self.err(f, *span, "AXSTR takes an axis name (a string)"));
            };
            let letter = axis_of(&self.cfg, &name).map_err(|m| self.err(f, *span, m))?;
            let value = match self.ev(f, v)? {
                Val::Int(i) => i as f64,
                Val::Dbl(d) => d,
                v => self.num(f, &v, *span, &format!("axis {letter}"))?,
            };
            words.push(Word {
                letter,
                value: Value::Number(Number {
                    value,
                    has_point: true,
                    span: *span,
                }),
                span: *span,
            });
        }
        let mut line = g.line.clone();
        line.kind = LineKind::Block(Block {
            words,
            named_axes: Vec::new(),
        });
        self.steps = 0;
        self.send(Req::Block {
            file: f.file,
            line: Box::new(line),
        })
    }

    fn assign(&mut self, f: &mut Frame, t: &Target, op: AssignOp, v: Val, span: Span) -> R<()> {
        let combine = |me: &Self, f: &Frame, cur: Val, v: Val| -> R<Val> {
            let bop = match op {
                AssignOp::Set => return Ok(v),
                AssignOp::Add => BinaryOp::Add,
                AssignOp::Sub => BinaryOp::Sub,
                AssignOp::Mul => BinaryOp::Mul,
                AssignOp::Div => BinaryOp::Div,
                AssignOp::Mod => BinaryOp::Mod,
            };
            bin(bop, cur, v).map_err(|m| me.err(f, span, m))
        };
        match t {
            Target::Local(slot, ty) => {
                let at = f.base + *slot as usize;
                let cur = std::mem::replace(&mut self.stack[at], Val::Int(0));
                let nv =
                    combine(self, f, cur.clone(), v).and_then(|n| self.coerce(f, *ty, n, span));
                match nv {
                    Ok(n) => self.stack[at] = n,
                    Err(e) => {
                        self.stack[at] = cur;
                        return Err(e);
                    }
                }
            }
            Target::Elem(slot, ty, ix) => {
                let i = self.ev(f, ix)?;
                let i = self.int(f, &i, span, "an index")?;
                let nv = if op == AssignOp::Set {
                    v
                } else {
                    let cur = self.elem(f, *slot, *ty, i, span)?;
                    combine(self, f, cur, v)?
                };
                let nv = self.coerce(f, *ty, nv, span)?;
                match self.place(f, *slot) {
                    Some(ArrPlace::Stack(k)) => {
                        let len = match &mut self.stack[k] {
                            Val::Arr(a) => match usize::try_from(i).ok().and_then(|i| a.get_mut(i))
                            {
                                Some(e) => {
                                    *e = nv;
                                    return Ok(());
                                }
                                None => a.len(),
                            },
                            _ => return Err(self.err(f, span, "not an array")),
                        };
                        return Err(self.err(f, span, out_of_range(i, len)));
                    }
                    Some(ArrPlace::Global(name)) => self.set_global_elem(f, &name, i, nv, span)?,
                    None => return Err(self.err(f, span, "not an array")),
                }
            }
            Target::Global(name) => {
                let nv = if op == AssignOp::Set {
                    v
                } else {
                    let cur = self.global(f, name, None, span)?;
                    combine(self, f, cur, v)?
                };
                let nv = to_shared(nv).map_err(|m| self.err(f, span, m))?;
                let set = lock(&self.globals).set_scalar(name, nv);
                set.map_err(|m| self.err(f, span, m))?;
            }
            Target::GlobalElem(name, ix) => {
                let i = self.ev(f, ix)?;
                let i = self.int(f, &i, span, "an index")?;
                if i < 0 {
                    return Err(self.err(f, span, format!("index {i} of ${name} is negative")));
                }
                let nv = if op == AssignOp::Set {
                    v
                } else {
                    let cur = self.global(f, name, Some(i), span)?;
                    combine(self, f, cur, v)?
                };
                self.set_global_elem(f, name, i, nv, span)?;
            }
        }
        Ok(())
    }

    /// `$name[i] = v` (creating the array at its first element).
    fn set_global_elem(&self, f: &Frame, name: &str, i: i64, v: Val, span: Span) -> R<()> {
        let v = to_shared(v).map_err(|m| self.err(f, span, m))?;
        let set = lock(&self.globals).set_elem(name, i, v);
        set.map_err(|m| self.err(f, span, m))
    }

    /// Where the array of `slot` is: that slot (a local array) or, for an array parameter,
    /// the place it refers to. `None`: the slot holds no array (cannot happen in a checked
    /// program; reported rather than trusted).
    fn place(&self, f: &Frame, slot: u32) -> Option<ArrPlace> {
        let at = f.base + slot as usize;
        match self.stack.get(at)? {
            Val::Arr(_) => Some(ArrPlace::Stack(at)),
            Val::ArrRef(p) => Some(p.clone()),
            _ => None,
        }
    }

    /// The value of [`Ex::Array`]: a reference to the array it names.
    fn array_ref(&self, f: &Frame, a: &ArrArg, span: Span) -> R<Val> {
        match a {
            ArrArg::Slot(s) => self
                .place(f, *s)
                .map(Val::ArrRef)
                .ok_or_else(|| self.err(f, span, "not an array")),
            ArrArg::Global(name) => {
                let g = lock(&self.globals);
                if let Some(Global::Scalar(_)) = g.get(name) {
                    drop(g);
                    return Err(self.err(f, span, format!("${name} is not an array")));
                }
                // A global array not assigned yet is passed too: its first element written
                // creates it, as `$name[i] = …` does.
                Ok(Val::ArrRef(ArrPlace::Global(name.clone())))
            }
        }
    }

    /// The number of elements of the array `v` refers to; for a `$` global array, its
    /// highest assigned index + 1 (0 if none).
    fn len_of(&self, f: &Frame, v: &Val, span: Span) -> R<i64> {
        match v {
            Val::ArrRef(ArrPlace::Stack(k)) => match self.stack.get(*k) {
                Some(Val::Arr(a)) => Ok(a.len() as i64),
                _ => Err(self.err(f, span, "not an array")),
            },
            Val::ArrRef(ArrPlace::Global(name)) => {
                let g = lock(&self.globals);
                match g.get(name) {
                    Some(Global::Array(a)) => {
                        Ok(a.last_key_value().map_or(0, |(k, _)| k.saturating_add(1)))
                    }
                    None => Ok(0),
                    Some(Global::Scalar(_)) => {
                        drop(g);
                        Err(self.err(f, span, format!("${name} is not an array")))
                    }
                }
            }
            _ => Err(self.err(f, span, "len takes an array")),
        }
    }

    /// Element `i` of the array of `slot` (element type `ty`).
    fn elem(&self, f: &Frame, slot: u32, ty: Ty, i: i64, span: Span) -> R<Val> {
        let mut v = self.stack.get(f.base + slot as usize);
        if let Some(Val::ArrRef(ArrPlace::Stack(k))) = v {
            v = self.stack.get(*k);
        }
        match v {
            Some(Val::Arr(a)) => match usize::try_from(i).ok().and_then(|i| a.get(i)) {
                Some(v) => Ok(v.clone()),
                None => Err(self.err(f, span, out_of_range(i, a.len()))),
            },
            Some(Val::ArrRef(ArrPlace::Global(name))) => {
                // A `$` global's elements have no declared type: converted to the parameter's
                // as an assignment would, checked here.
                let v = self.global(f, name, Some(i), span)?;
                let what = format!("${name}[{i}]");
                match (ty, v) {
                    (Ty::Dyn, v) => Ok(v),
                    (Ty::Int | Ty::Double, v @ (Val::Int(_) | Val::Dbl(_))) => {
                        self.coerce(f, ty, v, span)
                    }
                    (Ty::Str, v @ Val::Str(_)) | (Ty::Bool, v @ Val::Bool(_)) => Ok(v),
                    (t, v) => Err(self.err(
                        f,
                        span,
                        format!("{what} holds a {}, not a {}", v.ty().name(), t.name()),
                    )),
                }
            }
            _ => Err(self.err(f, span, "not an array")),
        }
    }

    fn global(&self, f: &Frame, name: &str, i: Option<i64>, span: Span) -> R<Val> {
        let g = lock(&self.globals);
        let v = match (g.get(name), i) {
            (Some(Global::Scalar(v)), None) => Some(from_shared(v)),
            (Some(Global::Array(a)), Some(i)) => a.get(&i).map(from_shared),
            (Some(Global::Array(_)), None) => {
                drop(g);
                return Err(self.err(f, span, format!("${name} is an array: use an element")));
            }
            (Some(Global::Scalar(_)), Some(_)) => {
                drop(g);
                return Err(self.err(f, span, format!("${name} is not an array")));
            }
            (None, _) => None,
        };
        drop(g);
        v.ok_or_else(|| {
            let what = match i {
                Some(i) => format!("${name}[{i}]"),
                None => format!("${name}"),
            };
            self.err(f, span, format!("{what} has no value (never assigned)"))
        })
    }

    fn coerce(&self, f: &Frame, ty: Ty, v: Val, span: Span) -> R<Val> {
        Ok(match (ty, v) {
            (Ty::Dyn, v) => v,
            (Ty::Int, Val::Int(i)) => Val::Int(i),
            (Ty::Int, Val::Dbl(d)) => {
                // The int range is [-2^63, 2^63): both ends are exact in f64, so the test is
                // exact (`as` would saturate silently).
                const TWO_63: f64 = 9_223_372_036_854_775_808.0;
                let t = d.trunc();
                if !(-TWO_63..TWO_63).contains(&t) {
                    return Err(self.err(
                        f,
                        span,
                        format!(
                            "{d:e} does not fit in an int (-9223372036854775808 to \
                             9223372036854775807)"
                        ),
                    ));
                }
                Val::Int(t as i64)
            }
            (Ty::Double, Val::Int(i)) => Val::Dbl(i as f64),
            (Ty::Double, Val::Dbl(d)) => Val::Dbl(d),
            (Ty::Str, v @ Val::Str(_)) => v,
            (Ty::Bool, v @ Val::Bool(_)) => v,
            (t, v) => {
                return Err(self.err(
                    f,
                    span,
                    format!("cannot assign {} to {}", v.ty().name(), t.name()),
                ));
            }
        })
    }

    fn int(&self, f: &Frame, v: &Val, span: Span, what: &str) -> R<i64> {
        match v {
            Val::Int(i) => Ok(*i),
            Val::Dbl(d) if d.fract() == 0.0 && d.abs() < 9e15 => Ok(*d as i64),
            v => Err(self.err(
                f,
                span,
                format!("{what} must be a whole number, not {}", v.text()),
            )),
        }
    }

    fn num(&self, f: &Frame, v: &Val, span: Span, what: &str) -> R<f64> {
        match v {
            Val::Int(i) => Ok(*i as f64),
            Val::Dbl(d) => Ok(*d),
            v => Err(self.err(
                f,
                span,
                format!("{what} needs a number, not {}", v.ty().name()),
            )),
        }
    }

    fn truth(&mut self, f: &mut Frame, c: &Ex) -> R<bool> {
        match self.ev(f, c)? {
            Val::Bool(b) => Ok(b),
            Val::Int(i) => Ok(i != 0),
            Val::Dbl(d) => Ok(d != 0.0),
            v => Err(self.err(
                f,
                span_of(c),
                format!("a condition cannot be {}", v.ty().name()),
            )),
        }
    }

    fn ev(&mut self, f: &mut Frame, e: &Ex) -> R<Val> {
        Ok(match e {
            Ex::Lit(v) => v.clone(),
            Ex::Local(s) => self.stack[f.base + *s as usize].clone(),
            Ex::Elem(s, ty, ix, span) => {
                let i = self.ev(f, ix)?;
                let i = self.int(f, &i, *span, "an index")?;
                self.elem(f, *s, *ty, i, *span)?
            }
            Ex::Array(a, span) => self.array_ref(f, a, *span)?,
            Ex::Global(n, ix, span) => {
                let i = match ix {
                    Some(ix) => {
                        let i = self.ev(f, ix)?;
                        Some(self.int(f, &i, *span, "an index")?)
                    }
                    None => None,
                };
                self.global(f, n, i, *span)?
            }
            Ex::Sys(s, span) => self.sys(f, s, *span)?,
            Ex::Neg(x, span) => match self.ev(f, x)? {
                Val::Int(i) => Val::Int(
                    i.checked_neg()
                        .ok_or_else(|| self.err(f, *span, "integer overflow"))?,
                ),
                Val::Dbl(d) => Val::Dbl(-d),
                v => {
                    return Err(self.err(
                        f,
                        *span,
                        format!("a sign applies to numbers, not {}", v.ty().name()),
                    ));
                }
            },
            Ex::Bin(..) => self.bin_chain(f, e)?,
            Ex::And(a, b) => Val::Bool(self.truth(f, a)? && self.truth(f, b)?),
            Ex::Or(a, b) => Val::Bool(self.truth(f, a)? || self.truth(f, b)?),
            Ex::Not(x, _) => Val::Bool(!self.truth(f, x)?),
            Ex::Call(k, args, span) => self.call(f, *k, args, *span)?,
            Ex::Builtin(b, args, span) => self.builtin(f, *b, args, *span)?,
        })
    }

    /// A chain of binary operators, `a + b - c …` (a left-leaning tree): the left spine is
    /// walked in a loop, so the chain costs one frame here, not one per operator (a call at
    /// its bottom is then MAX_CALL_DEPTH deep on the executor's stack, not times the chain).
    fn bin_chain(&mut self, f: &mut Frame, e: &Ex) -> R<Val> {
        let mut spine = Vec::new();
        let mut at = e;
        while let Ex::Bin(op, a, b, span) = at {
            spine.push((*op, &**b, *span));
            at = a;
        }
        let mut x = self.ev(f, at)?;
        for (op, b, span) in spine.into_iter().rev() {
            let y = self.ev(f, b)?;
            x = bin(op, x, y).map_err(|m| self.err(f, span, m))?;
        }
        Ok(x)
    }

    fn call(&mut self, f: &mut Frame, k: usize, args: &[Ex], span: Span) -> R<Val> {
        let prog = self.prog.clone();
        let func = &prog.funcs[k];
        if self.depth >= MAX_CALL_DEPTH {
            return Err(self.err(
                f,
                span,
                format!(
                    "recursion too deep: more than {MAX_CALL_DEPTH} nested calls (in `{}`)",
                    func.name
                ),
            ));
        }
        // The arguments go to slots 0..n of the new frame, on top of the stack; a call inside
        // an argument runs above them and leaves the stack as it found it.
        let base = self.stack.len();
        for (a, p) in args.iter().zip(&func.params) {
            let v = self.ev(f, a)?;
            let v = if p.array {
                v
            } else {
                self.coerce(f, p.ty, v, span_of(a))?
            };
            self.stack.push(v);
        }
        self.stack.resize(base + func.slots as usize, Val::Int(0));
        let mut frame = Frame {
            file: func.file,
            base,
        };
        self.depth += 1;
        let r = self.block(&mut frame, &func.body);
        self.depth -= 1;
        self.pop_frame(base);
        match r? {
            Flow::Return(Some(v)) => self.coerce(&frame, func.ret, v, func.span),
            _ if func.ret != Ty::Void => Err(self.err(
                f,
                span,
                format!(
                    "function `{}` ended without returning a {}",
                    func.name,
                    func.ret.name()
                ),
            )),
            _ => Ok(Val::Int(0)),
        }
    }

    fn sys(&mut self, f: &mut Frame, s: &Sys, span: Span) -> R<Val> {
        Ok(match s {
            Sys::ItpPath => Val::Dbl(self.read(f, Read::ItpPath, span)?),
            Sys::Axis(i) => Val::Dbl(self.read(f, Read::Axis(*i), span)?),
            Sys::AxisByName(x) => {
                let Val::Str(n) = self.ev(f, x)? else {
                    return Err(self.err(f, span, "@POS[…] takes an axis name (a string)"));
                };
                let c = axis_of(&self.cfg, &n).map_err(|m| self.err(f, span, m))?;
                let i = self.cfg.axis_index(c).unwrap_or(0);
                Val::Dbl(self.read(f, Read::Axis(i), span)?)
            }
            Sys::ChMode(n) | Sys::ChState(n) => {
                let v = self.ev(f, n)?;
                let ch = self.channel_no(f, &v, span, "@CH")?;
                let call = match s {
                    Sys::ChMode(_) => ChannelCall::Mode(ch),
                    _ => ChannelCall::State(ch),
                };
                Val::Int(self.ask(f, Req::Channel(call), span)? as i64)
            }
        })
    }

    /// A channel number `v` of this machine (0-based).
    fn channel_no(&self, f: &Frame, v: &Val, span: Span, what: &str) -> R<usize> {
        let ch = self.int(f, v, span, "a channel number")?;
        let head = |ch: i64| match what {
            "@CH" => format!("@CH[{ch}]"),
            call => format!("{call}({ch})"),
        };
        match usize::try_from(ch) {
            Ok(c) if c < self.seat.count => Ok(c),
            Ok(c) => {
                let why = no_such_channel(c, self.seat.count);
                let why = why.split_once(": ").map_or("", |(_, w)| w);
                Err(self.err(f, span, format!("{}: {why}", head(ch))))
            }
            Err(_) => Err(self.err(
                f,
                span,
                format!("{}: channels are numbered from 0", head(ch)),
            )),
        }
    }

    /// `channel_load/run/start/wait/reset(ch, …)`: the call made when the interpreter
    /// reaches it (after the motion before it), true or false.
    fn channel_builtin(&mut self, f: &Frame, b: Builtin, vs: &[Val], span: Span) -> R<Val> {
        let name = match b {
            Builtin::ChannelLoad => "channel_load",
            Builtin::ChannelRun => "channel_run",
            Builtin::ChannelStart => "channel_start",
            Builtin::ChannelWait => "channel_wait",
            _ => "channel_reset",
        };
        let ch = self.channel_no(f, &vs[0], span, name)?;
        // A `$` global passes the checker as any type: its value is checked here.
        let prog = match vs.get(1) {
            None => String::new(),
            Some(Val::Str(p)) if !p.trim().is_empty() => p.to_string(),
            Some(v) => {
                let got = match v {
                    Val::Str(_) => "an empty string".to_string(),
                    v => format!("a {}", v.ty().name()),
                };
                let what = format!("{name}: the program must be a file name, not {got}");
                return Err(self.err(f, span, what));
            }
        };
        let call = match b {
            Builtin::ChannelLoad => ChannelCall::Load(ch, prog),
            Builtin::ChannelRun => ChannelCall::Run(ch, prog),
            Builtin::ChannelStart => ChannelCall::Start(ch, prog),
            Builtin::ChannelWait => ChannelCall::Wait(ch),
            _ => ChannelCall::Reset(ch),
        };
        // Not motion: a loop of channel calls alone still ends as runaway (`tick`).
        let v = self.ask(f, Req::Channel(call), span)?;
        Ok(Val::Bool(v != 0.0))
    }

    /// `wait_mark(m)`, `wait_mark(m, mask)`: a `WaitMark` stop of this channel until the
    /// channels of `mask` (a bit per channel, 0 = all) reach mark `m`.
    fn wait_mark(&mut self, f: &Frame, vs: &[Val], span: Span) -> R<Val> {
        let m = self.int(f, &vs[0], span, "a wait mark")?;
        let mark = u16::try_from(m).map_err(|_| {
            self.err(
                f,
                span,
                format!("wait_mark({m}): a mark is 0..{}", u16::MAX),
            )
        })?;
        let mask = match vs.get(1) {
            Some(v) => self.int(f, v, span, "a channel mask")?,
            None => 0,
        };
        let channels = check_mask(mask, self.seat)
            .map_err(|m| self.err(f, span, format!("wait_mark: {m}")))?;
        self.steps = 0;
        self.send(Req::Seg {
            file: f.file,
            span,
            kind: SegmentKind::Stop {
                kind: StopKind::WaitMark { mark, channels },
            },
        })?;
        Ok(Val::Int(0))
    }

    fn builtin(&mut self, f: &mut Frame, b: Builtin, args: &[Ex], span: Span) -> R<Val> {
        let mut vs = Vec::with_capacity(args.len());
        for a in args {
            vs.push(self.ev(f, a)?);
        }
        let n = |me: &Self, i: usize| me.num(f, &vs[i], span_of(&args[i]), "this argument");
        let real = |me: &Self, x: f64| -> R<Val> {
            if x.is_finite() {
                Ok(Val::Dbl(x))
            } else {
                Err(me.err(f, span, "the result is not a finite number"))
            }
        };
        use Builtin::*;
        match b {
            Terminate => {
                let code = self.int(f, &vs[0], span_of(&args[0]), "an error code")?;
                let text = vs[1].text();
                Err(self.err(f, span, format!("terminate {code}: {text}")))
            }
            Msg => {
                self.steps = 0;
                self.send(Req::Seg {
                    file: f.file,
                    span,
                    kind: cnc402_motion::segment::SegmentKind::Message { text: vs[0].text() },
                })?;
                Ok(Val::Int(0))
            }
            Sleep => {
                let ms = n(self, 0)?;
                if !(0.0..=86_400_000.0).contains(&ms) {
                    return Err(self.err(
                        f,
                        span,
                        format!("sleep({ms}): the time must be 0..86400000 ms"),
                    ));
                }
                self.steps = 0;
                self.send(Req::Seg {
                    file: f.file,
                    span,
                    kind: cnc402_motion::segment::SegmentKind::Dwell {
                        seconds: ms / 1000.0,
                    },
                })?;
                Ok(Val::Int(0))
            }
            Fabs => real(self, n(self, 0)?.abs()),
            Sqrt => {
                let x = n(self, 0)?;
                if x < 0.0 {
                    return Err(self.err(f, span, format!("sqrt of a negative number ({x})")));
                }
                real(self, x.sqrt())
            }
            Sin => real(self, n(self, 0)?.sin()),
            Cos => real(self, n(self, 0)?.cos()),
            Tan => real(self, n(self, 0)?.tan()),
            Atan2 => real(self, n(self, 0)?.atan2(n(self, 1)?)),
            Floor => real(self, n(self, 0)?.floor()),
            Ceil => real(self, n(self, 0)?.ceil()),
            Round => real(self, n(self, 0)?.round()),
            Pow => real(self, n(self, 0)?.powf(n(self, 1)?)),
            Len => Ok(Val::Int(self.len_of(f, &vs[0], span_of(&args[0]))?)),
            ChannelLoad | ChannelRun | ChannelStart | ChannelWait | ChannelReset => {
                self.channel_builtin(f, b, &vs, span)
            }
            WaitMark => self.wait_mark(f, &vs, span),
            Min | Max => {
                let is_min = b == Min;
                match (&vs[0], &vs[1]) {
                    (Val::Int(x), Val::Int(y)) => {
                        Ok(Val::Int(if is_min { *x.min(y) } else { *x.max(y) }))
                    }
                    _ => {
                        let (x, y) = (n(self, 0)?, n(self, 1)?);
                        real(self, if is_min { x.min(y) } else { x.max(y) })
                    }
                }
            }
        }
    }
}

/// The span of an expression, for errors about its value.
fn span_of(e: &Ex) -> Span {
    match e {
        Ex::Elem(_, _, _, s)
        | Ex::Array(_, s)
        | Ex::Global(_, _, s)
        | Ex::Sys(_, s)
        | Ex::Neg(_, s)
        | Ex::Bin(_, _, _, s)
        | Ex::Not(_, s)
        | Ex::Call(_, _, s)
        | Ex::Builtin(_, _, s) => *s,
        Ex::And(a, b) | Ex::Or(a, b) => span_of(a).join(span_of(b)),
        Ex::Lit(_) | Ex::Local(_) => Span::default(),
    }
}

fn out_of_range(i: i64, len: usize) -> String {
    format!("index {i} is out of range (the array has {len} elements)")
}

/// `a op b` on run-time values, with C's promotions; the message on a type or value error.
pub(crate) fn bin(op: BinaryOp, a: Val, b: Val) -> Result<Val, String> {
    use BinaryOp::*;
    let bad = |a: &Val, b: &Val| {
        format!(
            "{} {} {}: wrong operand types",
            a.ty().name(),
            op_text(op),
            b.ty().name()
        )
    };
    let fin = |x: f64| {
        if x.is_finite() {
            Ok(Val::Dbl(x))
        } else {
            Err("the result is not a finite number".to_string())
        }
    };
    match op {
        Add if matches!(a, Val::Str(_)) || matches!(b, Val::Str(_)) => {
            if matches!(a, Val::Arr(_) | Val::ArrRef(_))
                || matches!(b, Val::Arr(_) | Val::ArrRef(_))
            {
                return Err(bad(&a, &b));
            }
            let mut s = a.text();
            s.push_str(&b.text());
            if s.len() > MAX_STRING_LEN {
                return Err(format!(
                    "string too long: {} bytes (at most {MAX_STRING_LEN})",
                    s.len()
                ));
            }
            Ok(Val::Str(Arc::from(s)))
        }
        Add | Sub | Mul | Div | Mod => match (&a, &b) {
            (Val::Int(x), Val::Int(y)) => {
                let (x, y) = (*x, *y);
                if matches!(op, Div | Mod) && y == 0 {
                    return Err("division by zero".into());
                }
                let r = match op {
                    Add => x.checked_add(y),
                    Sub => x.checked_sub(y),
                    Mul => x.checked_mul(y),
                    Div => x.checked_div(y),
                    _ => x.checked_rem(y),
                };
                r.map(Val::Int)
                    .ok_or_else(|| "integer overflow".to_string())
            }
            (Val::Int(_) | Val::Dbl(_), Val::Int(_) | Val::Dbl(_)) => {
                let x = as_f64(&a);
                let y = as_f64(&b);
                if matches!(op, Div | Mod) && y == 0.0 {
                    return Err("division by zero".into());
                }
                fin(match op {
                    Add => x + y,
                    Sub => x - y,
                    Mul => x * y,
                    Div => x / y,
                    _ => x % y,
                })
            }
            _ => Err(bad(&a, &b)),
        },
        Or | Xor | And => match (&a, &b) {
            (Val::Int(x), Val::Int(y)) => Ok(Val::Int(match op {
                Or => x | y,
                Xor => x ^ y,
                _ => x & y,
            })),
            _ => Err(bad(&a, &b)),
        },
        Eq | Ne | Gt | Ge | Lt | Le => {
            let ord = match (&a, &b) {
                (Val::Str(x), Val::Str(y)) => x.cmp(y),
                (Val::Int(x), Val::Int(y)) => x.cmp(y),
                (
                    Val::Int(_) | Val::Dbl(_) | Val::Bool(_),
                    Val::Int(_) | Val::Dbl(_) | Val::Bool(_),
                ) => as_f64(&a)
                    .partial_cmp(&as_f64(&b))
                    .unwrap_or(std::cmp::Ordering::Less),
                _ => return Err(bad(&a, &b)),
            };
            use std::cmp::Ordering::*;
            Ok(Val::Bool(match op {
                Eq => ord == Equal,
                Ne => ord != Equal,
                Gt => ord == Greater,
                Ge => ord != Less,
                Lt => ord == Less,
                _ => ord != Greater,
            }))
        }
    }
}

fn as_f64(v: &Val) -> f64 {
    match v {
        Val::Int(i) => *i as f64,
        Val::Dbl(d) => *d,
        Val::Bool(b) => f64::from(u8::from(*b)),
        _ => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use std::sync::mpsc::sync_channel;

    use cnc402_lang::SourceFile;

    use super::*;

    /// Runs `text`'s main program on an executor without an interpreter (no G-code lines).
    fn exec(text: &str) -> (Executor, R<()>) {
        let cfg = MachineConfig::default_machine();
        let src = SourceFile::new("x.nc", text);
        let program = cnc402_lang::parse(&src).unwrap();
        let prog = super::super::compile::compile(&cfg, src, program, None).unwrap();
        let (tx, _rx) = sync_channel(4);
        let (_rtx, rrx) = sync_channel(1);
        let mut ex = Executor::new(
            Arc::new(prog),
            cfg,
            (Globals::default(), Seat { count: 1, this: 0 }),
            (tx, rrx),
            Arc::new(AtomicBool::new(false)),
            Arc::new(AtomicBool::new(false)),
        );
        let r = ex.run_file(0);
        (ex, r)
    }

    fn messages(ex: &Executor) -> Vec<String> {
        ex.pending
            .iter()
            .filter_map(|r| match r {
                Req::Seg {
                    kind: cnc402_motion::segment::SegmentKind::Message { text },
                    ..
                } => Some(text.clone()),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn calls_leave_the_stack_of_locals_as_they_found_it() {
        let (ex, r) = exec(
            "int Deep(int nA[], int nN) { int nL[2]; if (nN > 0) return Deep(nA, nN - 1) + 1; \
             nA[0] = 9; return 0; }\n\
             int Two(int nP, int nQ) { return nP * 10 + nQ; }\n\
             int nArr[1];\nint nK = 5;\n\
             MSG(\"\" + Two(Deep(nArr, 3), Deep(nArr, 1)) + \" \" + nK + \" \" + nArr[0]);\n",
        );
        assert!(r.is_ok());
        assert_eq!(messages(&ex), vec!["31 5 9"]);
        // Every frame, the main program's too, is gone at the end.
        assert!(ex.stack.is_empty(), "{:?}", ex.stack);
    }

    #[test]
    fn an_array_parameter_refers_to_the_callers_slot_or_global() {
        let (ex, r) = exec(
            "int Len2(int nA[]) { return len(nA); }\n\
             void Put(int nA[], int nI) { nA[nI] = nI; }\n\
             int nA[4];\nPut(nA, 3);\nPut($gB, 6);\n\
             MSG(\"\" + Len2(nA) + \" \" + nA[3] + \" \" + Len2($gB) + \" \" + $gB[6]);\n",
        );
        assert!(r.is_ok());
        assert_eq!(messages(&ex), vec!["4 3 7 6"]);
        let g = lock(&ex.globals);
        assert!(matches!(g.get("gB"), Some(Global::Array(a)) if a.len() == 1));
    }
}
