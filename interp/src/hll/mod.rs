//! The C-like high-level language of source 000 (AxiOMA Control): a program with statement
//! lines is checked whole at `load` (`compile`), then run by an executor thread (`exec`)
//! that hands its G-code blocks to the G-code core here, one request at a time, so that
//! segments stay pull-based and `@ITPPATH`/axis reads wait for the motion before them.
//! The language is documented in `docs/language.md`.

mod compile;
mod exec;
pub(crate) mod globals;
mod ir;
mod req;

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

use cnc402_config::MachineConfig;
use cnc402_lang::ast::{Line, LineKind, Program, Span};
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::{AxisPos, Source};

use crate::block::Machine;
use crate::block::words::{GGroup, Words};
use crate::canon::{self, CanonOp};

use crate::host::channels::{Channels, Seat, SharedGlobals, SharedValue, SingleChannel};
pub use exec::{MAX_ARRAY_LEN, MAX_CALL_DEPTH};
use req::{ChannelCall, Read, Req};

/// The executor thread's stack. The deepest program the parser and the checker allow
/// (`MAX_CALL_DEPTH` nested calls, each from 15 nested blocks and 31 nested parentheses, see
/// `tests/hll_stack.rs`) needs 11–12 MiB in a debug build and 2–3 MiB optimised (measured);
/// the depth limits, not luck, keep a program inside this. Kept small because a runtime that
/// locks its memory (mlockall MCL_FUTURE) locks the whole stack.
const EXECUTOR_STACK: usize = 16 << 20;

/// How many batches (of up to 32 requests) the executor may run ahead of the interpreter.
const AHEAD: usize = 4;

/// Where the answer to a [`Read`] goes.
type ReplyTx = SyncSender<Result<f64, String>>;

struct Running {
    prog: Arc<ir::Prog>,
    chan: Option<(Receiver<Req>, ReplyTx)>,
    /// Requests received in a batch, not handled yet.
    inbox: VecDeque<Req>,
    waiting: Arc<AtomicBool>,
    queue: VecDeque<CanonOp>,
    error: Option<NcError>,
    done: bool,
    /// The executor thread, joined on drop (after `halt` is set and the channels are gone).
    thread: Option<std::thread::JoinHandle<()>>,
    /// Tells the executor to stop at its next statement or loop turn.
    halt: Arc<AtomicBool>,
    /// Requests (statements that act on the machine) handled so far: see `Hll::requests`.
    requests: u64,
    /// Blocks, messages and dwells in a row without motion (`canon::makes_motion`): the
    /// executor counts statements only, so a loop of `MSG` or `sleep(0)` is caught here.
    idle: u64,
}

impl Drop for Running {
    /// Ends the executor thread and waits for it: a blocked send or reply wait fails when the
    /// channels go, a computing loop sees `halt`. Never hangs on a running program.
    fn drop(&mut self) {
        self.halt.store(true, Ordering::Relaxed);
        self.chan = None;
        self.inbox.clear();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The C-like language's part of an interpreter: the `$` globals (kept across the programs
/// of one interpreter) and the program running now, if it is C-like. It runs its G-code blocks
/// on the interpreter's `Machine` (the block layer); program flow holds it.
pub struct Hll {
    globals: globals::Globals,
    run: Option<Running>,
    /// The machine's channels as this channel's programs see them.
    channels: Box<dyn Channels>,
}

impl Default for Hll {
    fn default() -> Self {
        Hll {
            globals: Default::default(),
            run: None,
            channels: Box::new(SingleChannel),
        }
    }
}

impl std::fmt::Debug for Hll {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Hll")
            .field("active", &self.run.is_some())
            .finish()
    }
}

impl Hll {
    /// The channels the built-ins and `@CH` act on (from the next `load` on).
    pub(crate) fn set_channels(&mut self, channels: Box<dyn Channels>) {
        self.channels = channels;
    }

    /// The `$` globals from the next `load` on: the table all channels of a run share.
    pub(crate) fn set_shared_globals(&mut self, shared: SharedGlobals) {
        self.globals = shared.table;
    }

    /// The number of channels and the channel running this interpreter's programs.
    pub(crate) fn seat(&self) -> Seat {
        Seat::of(self.channels.as_ref())
    }

    /// Statements of the C-like program that acted on the machine (a segment or a G-code
    /// line) so far; 0 when no C-like program runs.
    pub fn requests(&self) -> u64 {
        self.run.as_ref().map_or(0, |r| r.requests)
    }
}

/// Whether `program` is written in the C-like language (has at least one statement line).
pub fn is_c_like(program: &Program) -> bool {
    program
        .lines
        .iter()
        .any(|l| matches!(l.kind, LineKind::Stmts(_)))
}

impl Hll {
    /// Whether a C-like program is loaded (then [`next_segment`] runs it).
    pub(crate) fn active(&self) -> bool {
        self.run.is_some()
    }

    /// Prepares `program` if it is C-like: `#use` files, checks, executor thread. A check error
    /// is kept and given out by the first `next_segment`. Not C-like: nothing is running.
    pub(crate) fn load(
        &mut self,
        cfg: &MachineConfig,
        src: &SourceFile,
        program: &Program,
        library: Option<&mut dyn crate::host::ProgramLibrary>,
    ) {
        self.run = None;
        if !is_c_like(program) {
            return;
        }
        let mut r = Running {
            prog: Arc::new(ir::Prog {
                files: vec![Arc::new(src.clone())],
                funcs: Vec::new(),
                bodies: Vec::new(),
            }),
            chan: None,
            inbox: VecDeque::new(),
            waiting: Arc::new(AtomicBool::new(false)),
            queue: VecDeque::new(),
            error: None,
            done: false,
            thread: None,
            halt: Arc::new(AtomicBool::new(false)),
            idle: 0,
            requests: 0,
        };
        match compile::compile(cfg, src.clone(), program.clone(), library) {
            Ok(prog) => {
                let prog = Arc::new(prog);
                let (tx, rx) = sync_channel(AHEAD);
                let (rtx, rrx) = sync_channel(1);
                let ex = exec::Executor::new(
                    prog.clone(),
                    cfg.clone(),
                    (self.globals.clone(), self.seat()),
                    (tx, rrx),
                    r.waiting.clone(),
                    r.halt.clone(),
                );
                let spawned = std::thread::Builder::new()
                    .name("cnc402-hll".into())
                    .stack_size(EXECUTOR_STACK)
                    .spawn(move || ex.run());
                match spawned {
                    Ok(t) => {
                        r.chan = Some((rx, rtx));
                        r.thread = Some(t);
                    }
                    Err(e) => {
                        r.error = Some(NcError::new(
                            src,
                            Span::default(),
                            format!("cannot start the C-like program's executor: {e}"),
                        ))
                    }
                }
                r.prog = prog;
            }
            Err(e) => r.error = Some(e),
        }
        self.run = Some(r);
    }
}

/// The `$` global `name` (scalar, or element `index` of an array) as a number, for tests and
/// tools: `None` if it has no value or is not a number. `it` is the `Interpreter`.
pub fn global_number(it: &impl AsRef<Hll>, name: &str, index: Option<i64>) -> Option<f64> {
    let g = globals::lock(&it.as_ref().globals);
    let v = match (g.get(name)?, index) {
        (globals::Global::Scalar(v), None) => v,
        (globals::Global::Array(a), Some(i)) => a.get(&i)?,
        _ => return None,
    };
    match v {
        SharedValue::Int(i) => Some(*i as f64),
        SharedValue::Double(d) => Some(*d),
        _ => None,
    }
}

impl Hll {
    /// The interpreter's next canonical operation for a C-like program, its blocks run on
    /// `it`.
    pub(crate) fn next_op(&mut self, it: &mut Machine) -> Result<Option<CanonOp>, NcError> {
        let Some(mut r) = self.run.take() else {
            return Ok(None);
        };
        let out = r.next(it, self.channels.as_mut());
        self.run = Some(r);
        out
    }
}

impl Running {
    /// The runaway guard of the requests: `ops` (run from `from`) without motion count one
    /// more, past `interp.block_limit` an error at the statement (`span` of `file`).
    fn count_idle(
        &mut self,
        it: &Machine,
        ops: &[CanonOp],
        from: &AxisPos,
        file: ir::FileId,
        span: Span,
    ) -> Result<(), NcError> {
        self.requests += 1;
        if canon::makes_motion(ops, from) {
            self.idle = 0;
            return Ok(());
        }
        self.idle += 1;
        let limit = it.cfg.interp.block_limit;
        if self.idle <= limit {
            return Ok(());
        }
        Err(NcError::new(
            &self.prog.files[file],
            span,
            format!(
                "runaway: {limit} blocks, messages or dwells in a row without motion (config \
                 interp.block_limit)"
            ),
        )
        .with_expected("a loop that ends, or motion inside it"))
    }

    fn stop(&mut self) {
        // A computing executor stops at its next statement; the drop joins it.
        self.halt.store(true, Ordering::Relaxed);
        self.done = true;
        self.queue.clear();
        self.inbox.clear();
        // Dropping the channel ends the executor thread at its next request.
        self.chan = None;
    }

    fn next(
        &mut self,
        it: &mut Machine,
        channels: &mut dyn Channels,
    ) -> Result<Option<CanonOp>, NcError> {
        loop {
            if let Some(op) = self.queue.pop_front() {
                return Ok(Some(op));
            }
            if let Some(e) = self.error.take() {
                self.stop();
                return Err(e);
            }
            if self.done {
                return Ok(None);
            }
            let req = if let Some(r) = self.inbox.pop_front() {
                Ok(r)
            } else {
                let Some((rx, _)) = &self.chan else {
                    self.done = true;
                    return Ok(None);
                };
                self.waiting.store(true, Ordering::Relaxed);
                let r = rx.recv();
                self.waiting.store(false, Ordering::Relaxed);
                r
            };
            let req = match req {
                Ok(r) => r,
                Err(_) => {
                    self.stop();
                    return Err(NcError::new(
                        &self.prog.files[0],
                        Span::default(),
                        "the C-like program's executor stopped unexpectedly",
                    ));
                }
            };
            match req {
                Req::Batch(v) => self.inbox.extend(v),
                Req::End => {
                    self.done = true;
                    self.chan = None;
                    it.end_of_program(&self.prog.files[0])?;
                }
                Req::Error(e) => {
                    self.stop();
                    return Err(*e);
                }
                Req::Seg { file, span, kind } => {
                    let src = &self.prog.files[file];
                    let (line, _) = src.line_col(span.start as usize);
                    let source = Source {
                        file: src.name.clone(),
                        line,
                        n: None,
                    };
                    let from = it.state.pos;
                    let op = it.single_op(kind, source);
                    if let Err(e) =
                        self.count_idle(it, std::slice::from_ref(&op), &from, file, span)
                    {
                        self.stop();
                        return Err(e);
                    }
                    self.queue.push_back(op);
                }
                Req::Read(what) => {
                    // The queue is empty: every earlier segment has been handed out.
                    let v = read(it, what);
                    if let Some((_, reply)) = &self.chan {
                        let _ = reply.send(v);
                    }
                }
                Req::Channel(call) => {
                    let v = channel_call(it, channels, call, &self.prog.files[0].name);
                    if let Some((_, reply)) = &self.chan {
                        let _ = reply.send(v);
                    }
                }
                Req::Block { file, line } => {
                    if let Err(e) = self.block(it, file, &line, Seat::of(channels)) {
                        self.stop();
                        return Err(e);
                    }
                }
            }
        }
    }

    /// Runs one computed G-code block through the G-code core.
    fn block(
        &mut self,
        it: &mut Machine,
        file: ir::FileId,
        line: &Line,
        seat: Seat,
    ) -> Result<(), NcError> {
        if line.block_delete && it.opts.block_delete {
            return Ok(());
        }
        let src = self.prog.files[file].clone();
        let LineKind::Block(b) = &line.kind else {
            return Ok(());
        };
        let mut w = Words::collect(&src, b)?;
        if let Some(g) = w.g().iter().find(|g| g.1 == GGroup::MacroCall) {
            return Err(NcError::new(
                &src,
                g.2,
                format!(
                    "G{} is a Macro B call: a C-like program calls functions",
                    g.0
                ),
            ));
        }
        if let Some(m) = w.m.iter().find(|m| matches!(m.0, 98 | 99)) {
            return Err(NcError::new(
                &src,
                m.1,
                format!(
                    "M{} is a Macro B sub-program call: a C-like program calls functions",
                    m.0
                ),
            ));
        }
        let wait = crate::block::mcodes::wait_mcode(&it.cfg, (&src, it.dialect), &mut w, seat)?;
        let from = it.state.pos;
        let (mut out, end) = it.execute(&src, &mut w, line, Vec::new())?;
        if let Some(kind) = wait {
            out.push(crate::block::mcodes::wait_op(it, kind, &src, line));
        }
        self.count_idle(it, &out, &from, file, line.span)?;
        self.queue.extend(out);
        if end {
            self.done = true;
            self.chan = None;
        }
        Ok(())
    }
}

/// Answers a system variable read after the motion before it (through the interpreter's
/// [`crate::host::MotionSync`]).
fn read(it: &mut Machine, what: Read) -> Result<f64, String> {
    match what {
        Read::ItpPath => {
            // Wait for the motion first: `path_length_done` alone reports progress so far.
            let programmed = it.state.pos;
            it.sync.wait_motion_done(&programmed)?;
            Ok(it.sync.path_length_done(it.path_len))
        }
        Read::Axis(i) => {
            if i >= it.cfg.axes.len() {
                return Err("no such axis".into());
            }
            // Exactly what `#5041…` reads: work coordinates (the work offset in force and the
            // G92 shift taken off, the tool length offset in), after the motion before it.
            it.read_var(5041 + i as i64)?
                .ok_or_else(|| "the axis position is vacant".to_string())
        }
    }
}

/// Makes a channel call once the motion before it has been executed: another channel starts
/// (or is reset, or is asked for its state) in program order with this channel's motion, as
/// a control that starts channels at block execution does, not when the interpreter, running
/// ahead, reads the call. `main` is the calling program's file (programs are found from it).
fn channel_call(
    it: &mut Machine,
    channels: &mut dyn Channels,
    call: ChannelCall,
    main: &str,
) -> Result<f64, String> {
    let programmed = it.state.pos;
    it.sync.wait_motion_done(&programmed)?;
    let yes = |b: bool| if b { 1.0 } else { 0.0 };
    Ok(match call {
        ChannelCall::Mode(ch) => f64::from(channels.mode(ch)? as u8),
        ChannelCall::State(ch) => f64::from(channels.state(ch)? as u8),
        ChannelCall::Load(ch, p) => yes(channels.load(ch, &p, main)?),
        ChannelCall::Start(ch, p) => yes(channels.start(ch, &p, main)?),
        ChannelCall::Run(ch, p) => yes(channels.run(ch, &p, main)?),
        ChannelCall::Wait(ch) => yes(channels.wait(ch)?),
        ChannelCall::Reset(ch) => yes(channels.reset(ch)?),
    })
}
